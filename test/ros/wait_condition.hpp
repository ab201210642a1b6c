// A test's wait for a condition on what its callbacks record: checked under their mutex every
// 20 ms of wall time until it holds or `timeout_s` passes (a bound that turns a broken node into a
// failure, never reached by a working one on a slow machine).
#pragma once

#include <ros/time.h>

#include <functional>
#include <mutex>

namespace magnetometer_insitu_calibration {
namespace test {

/// True as soon as `done()` (called with `mutex` held) is; false when it is not after timeout_s.
inline bool wait_for_condition(std::mutex& mutex, const std::function<bool()>& done, double timeout_s) {
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
  while (ros::WallTime::now() < deadline) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (done()) return true;
    }
    ros::WallDuration(0.02).sleep();
  }
  std::lock_guard<std::mutex> lock(mutex);
  return done();
}

}  // namespace test
}  // namespace magnetometer_insitu_calibration
