// rostest (test/ros/test_nodelet_device_error.test): errors of lemi025_driver run as a nodelet
// stay visible under the nodelet's own name. The .test starts a nodelet manager and sets the
// parameters; the test loads the nodelets itself (service <manager>/load_nodelet) once it
// listens to /rosout_agg and /diagnostics, so that nothing is published before it listens.
//  * a serial port that cannot be opened: the load succeeds (the port may appear later), a WARN
//    on /rosout names the nodelet, the device and "not open yet", and the nodelet's own
//    diagnostics ("<nodelet>: link", not the manager's name) report ERROR "disconnected";
//  * an impossible parameter (~baud 12345): the load fails and a FATAL on /rosout names the
//    nodelet and ~baud.
// Private parameters: manager (full name), absent_device (a path that does not exist).
#include "driver_test_support.hpp"

#include <gtest/gtest.h>
#include <nodelet/NodeletLoad.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Log.h>

#include <mutex>
#include <string>
#include <vector>

namespace {

using magnetometer_insitu_calibration::test::DriverDiagnostics;
using magnetometer_insitu_calibration::test::param;
using magnetometer_insitu_calibration::test::wait_for;

class RosoutInbox {
 public:
  RosoutInbox() { subscriber_ = ros::NodeHandle().subscribe("/rosout_agg", 1000, &RosoutInbox::on_log, this); }
  bool connected() const { return subscriber_.getNumPublishers() > 0; }
  /// Whether a message at `level` containing every one of `texts` has arrived.
  bool has(std::uint8_t level, const std::vector<std::string>& texts) {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& log : logs_) {
      if (log.level != level) continue;
      bool all = true;
      for (const auto& t : texts) all = all && log.msg.find(t) != std::string::npos;
      if (all) return true;
    }
    return false;
  }

 private:
  void on_log(const rosgraph_msgs::Log::ConstPtr& log) {
    std::lock_guard<std::mutex> lock(mutex_);
    logs_.push_back(*log);
  }
  std::mutex mutex_;
  std::vector<rosgraph_msgs::Log> logs_;
  ros::Subscriber subscriber_;
};

/// Asks the manager to load lemi025_driver as `name`; true when it reports success.
bool load_driver(const std::string& manager, const std::string& name) {
  nodelet::NodeletLoad load;
  load.request.name = name;
  load.request.type = "magnetometer_insitu_calibration/lemi025_driver";
  return ros::service::call(manager + "/load_nodelet", load) && load.response.success;
}

TEST(NodeletDeviceError, AbsentPortIsReportedUnderTheNodeletName) {
  const std::string manager = param("manager"), device = param("absent_device");
  ASSERT_FALSE(manager.empty());
  ASSERT_FALSE(device.empty());
  RosoutInbox rosout;
  DriverDiagnostics diagnostics("device_error/lemi_absent");
  ASSERT_TRUE(wait_for([&] { return rosout.connected(); }, 30.0)) << "no /rosout_agg publisher";
  ASSERT_TRUE(ros::service::waitForService(manager + "/load_nodelet", ros::Duration(30.0)));

  ASSERT_TRUE(load_driver(manager, "/device_error/lemi_absent"));
  EXPECT_TRUE(wait_for([&] { return rosout.has(rosgraph_msgs::Log::WARN,
                                               {"/device_error/lemi_absent: ", device, "not open yet"}); },
                       20.0))
      << "no WARN naming the nodelet and " << device;
  diagnostic_msgs::DiagnosticStatus link;
  EXPECT_TRUE(wait_for([&] { return diagnostics.status("link", link); }, 20.0))
      << "no diagnostics named device_error/lemi_absent: link";
  EXPECT_EQ(link.level, diagnostic_msgs::DiagnosticStatus::ERROR) << link.message;
  EXPECT_NE(link.message.find("disconnected"), std::string::npos) << link.message;
  EXPECT_EQ(diagnostics.value("link", "connected"), "False");
}

TEST(NodeletDeviceError, ImpossibleParameterFailsTheLoad) {
  const std::string manager = param("manager");
  RosoutInbox rosout;
  ASSERT_TRUE(wait_for([&] { return rosout.connected(); }, 30.0)) << "no /rosout_agg publisher";
  ASSERT_TRUE(ros::service::waitForService(manager + "/load_nodelet", ros::Duration(30.0)));

  EXPECT_FALSE(load_driver(manager, "/device_error/lemi_bad"));
  EXPECT_TRUE(wait_for([&] { return rosout.has(rosgraph_msgs::Log::FATAL, {"/device_error/lemi_bad: ", "baud", "12345"}); },
                       20.0))
      << "no FATAL naming the nodelet and ~baud";
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_nodelet_device_error");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
