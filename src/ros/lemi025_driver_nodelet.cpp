// lemi025_driver as a nodelet (magnetometer_insitu_calibration/lemi025_driver, nodelets.xml):
// the same Lemi025Driver class as the executable (src/ros/lemi025_driver_main.cpp), built with
// the nodelet's handles. The serial port is read on the driver's own thread as in the
// executable; the diagnostics timer runs on the nodelet's single-threaded queue. A port that
// cannot be opened is reported as by the executable, under the nodelet's own name: a warning
// at start ("<nodelet>: <device> not open yet (<error>): retrying every <s> s") and ERROR
// "disconnected" in its diagnostics until the port opens.
#include "magnetometer_insitu_calibration/ros/lemi025_driver.hpp"
#include "nodelet_support.hpp"

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include <memory>

namespace magnetometer_insitu_calibration {

class Lemi025DriverNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    node_ = construct_node<Lemi025Driver>(getName(), getNodeHandle(), getPrivateNodeHandle());
  }
  std::unique_ptr<Lemi025Driver> node_;
};

}  // namespace magnetometer_insitu_calibration

PLUGINLIB_EXPORT_CLASS(magnetometer_insitu_calibration::Lemi025DriverNodelet, nodelet::Nodelet)
