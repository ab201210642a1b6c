// calibration_node as a nodelet (magnetometer_insitu_calibration/calibration_node, nodelets.xml):
// the same CalibrationNode class as the executable (src/ros/calibration_node_main.cpp), built
// with the nodelet's handles. The estimation runs on the node's own worker thread as in the
// executable; the subscription and timer callbacks on the nodelet's single-threaded queue.
#include "magnetometer_insitu_calibration/ros/calibration_node.hpp"
#include "nodelet_support.hpp"

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include <memory>

namespace magnetometer_insitu_calibration {

class CalibrationNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    node_ = construct_node<CalibrationNode>(getName(), getNodeHandle(), getPrivateNodeHandle());
  }
  std::unique_ptr<CalibrationNode> node_;
};

}  // namespace magnetometer_insitu_calibration

PLUGINLIB_EXPORT_CLASS(magnetometer_insitu_calibration::CalibrationNodelet, nodelet::Nodelet)
