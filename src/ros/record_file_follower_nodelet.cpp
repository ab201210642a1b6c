// record_file_follower as a nodelet (magnetometer_insitu_calibration/record_file_follower,
// nodelets.xml): the same RecordFileFollowerNode class as the executable
// (src/ros/record_file_follower_main.cpp), built with the nodelet's handles. Its worker thread
// looks at the files and publishes; the diagnostics run on the nodelet's callback queue.
#include "magnetometer_insitu_calibration/ros/record_file_follower.hpp"
#include "nodelet_support.hpp"

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include <memory>

namespace magnetometer_insitu_calibration {

class RecordFileFollowerNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    node_ = construct_node<RecordFileFollowerNode>(getName(), getNodeHandle(), getPrivateNodeHandle());
  }
  std::unique_ptr<RecordFileFollowerNode> node_;
};

}  // namespace magnetometer_insitu_calibration

PLUGINLIB_EXPORT_CLASS(magnetometer_insitu_calibration::RecordFileFollowerNodelet, nodelet::Nodelet)
