// correction_node as a nodelet (magnetometer_insitu_calibration/correction_node, nodelets.xml):
// the same CorrectionNode class as the executable (src/ros/correction_node_main.cpp), built with
// the nodelet's handles. In a manager shared with its publisher and subscribers, messages pass by
// pointer, without serialisation or TCP. Parameters, topics and diagnostics are the node's
// (include/magnetometer_insitu_calibration/ros/correction_node.hpp); its callbacks run on the
// nodelet's single-threaded queue, as on the executable's ros::spin() thread.
#include "magnetometer_insitu_calibration/ros/correction_node.hpp"
#include "nodelet_support.hpp"

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include <memory>

namespace magnetometer_insitu_calibration {

class CorrectionNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    node_ = construct_node<CorrectionNode>(getName(), getNodeHandle(), getPrivateNodeHandle());
  }
  std::unique_ptr<CorrectionNode> node_;
};

}  // namespace magnetometer_insitu_calibration

PLUGINLIB_EXPORT_CLASS(magnetometer_insitu_calibration::CorrectionNodelet, nodelet::Nodelet)
