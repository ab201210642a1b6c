// Shared by the end-to-end station rostests (test_simulated_station.cpp): what one
// reference/test pair of a running station publishes, recorded by stamp. Units as on the
// topics converted to nT (fields) and deg C (temperature); stamps keyed in ns.
#pragma once

#include <magnetometer_insitu_calibration/MagnetometerCalibration.h>

#include <Eigen/Core>
#include <ros/ros.h>
#include <sensor_msgs/MagneticField.h>
#include <sensor_msgs/Temperature.h>

#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace station_rostest {

namespace mic = magnetometer_insitu_calibration;

/// The topics and frame ids of one reference/test pair, and the seed of its simulators.
struct PairUnderTest {
  std::string label;  ///< for messages, e.g. "a/t1"
  std::string test_topic, temperature_topic;  ///< the test driver's raw field and thermometer ("" = none)
  std::string reference_topic;                ///< the reference driver's raw field ("" = not recorded)
  std::string calibration_topic, corrected_topic;
  std::string reference_frame_id, test_frame_id;
  std::uint64_t seed = 1;
};

/// Records a pair's raw test samples (and thermometer), its calibrations and its corrected
/// samples. Subscribed before the station's first window: the simulators start their record
/// five minutes of stamps before it.
class StationRecorder {
 public:
  explicit StationRecorder(const PairUnderTest& pair) {
    ros::NodeHandle nh;
    calibration_sub_ = nh.subscribe(pair.calibration_topic, 1000, &StationRecorder::on_calibration, this);
    test_sub_ = nh.subscribe(pair.test_topic, 100000, &StationRecorder::on_test, this);
    corrected_sub_ = nh.subscribe(pair.corrected_topic, 100000, &StationRecorder::on_corrected, this);
    if (!pair.reference_topic.empty()) {
      reference_sub_ = nh.subscribe(pair.reference_topic, 100000, &StationRecorder::on_reference, this);
    }
    if (!pair.temperature_topic.empty()) {
      temperature_sub_ = nh.subscribe(pair.temperature_topic, 100000, &StationRecorder::on_temperature, this);
    }
  }

  std::vector<mic::MagnetometerCalibration> calibrations() {
    std::lock_guard<std::mutex> lock(mutex_);
    return calibrations_;
  }
  /// Raw test samples by stamp (ns), nT, test frame.
  std::map<std::uint64_t, Eigen::Vector3d> test() {
    std::lock_guard<std::mutex> lock(mutex_);
    return test_;
  }
  /// Raw reference samples by stamp (ns), nT, reference frame (empty unless reference_topic).
  std::map<std::uint64_t, Eigen::Vector3d> reference() {
    std::lock_guard<std::mutex> lock(mutex_);
    return reference_;
  }
  /// Thermometer readings by stamp (ns), deg C.
  std::map<std::uint64_t, double> temperature() {
    std::lock_guard<std::mutex> lock(mutex_);
    return temperature_;
  }
  /// Corrected samples by stamp (ns), nT, and the frame_id each came in.
  std::map<std::uint64_t, Eigen::Vector3d> corrected() {
    std::lock_guard<std::mutex> lock(mutex_);
    return corrected_;
  }
  std::vector<std::string> corrected_frame_ids() {
    std::lock_guard<std::mutex> lock(mutex_);
    return corrected_frame_ids_;
  }
  std::size_t corrected_count() {
    std::lock_guard<std::mutex> lock(mutex_);
    return corrected_.size();
  }

 private:
  static Eigen::Vector3d field_nT(const sensor_msgs::MagneticField& m) {
    return 1e9 * Eigen::Vector3d(m.magnetic_field.x, m.magnetic_field.y, m.magnetic_field.z);
  }
  void on_calibration(const mic::MagnetometerCalibration::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    calibrations_.push_back(*m);
  }
  void on_test(const sensor_msgs::MagneticField::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    test_[m->header.stamp.toNSec()] = field_nT(*m);
  }
  void on_reference(const sensor_msgs::MagneticField::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    reference_[m->header.stamp.toNSec()] = field_nT(*m);
  }
  void on_temperature(const sensor_msgs::Temperature::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    temperature_[m->header.stamp.toNSec()] = m->temperature;
  }
  void on_corrected(const sensor_msgs::MagneticField::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    corrected_[m->header.stamp.toNSec()] = field_nT(*m);
    if (corrected_frame_ids_.empty() || corrected_frame_ids_.back() != m->header.frame_id) {
      corrected_frame_ids_.push_back(m->header.frame_id);
    }
  }

  std::mutex mutex_;
  std::vector<mic::MagnetometerCalibration> calibrations_;
  std::map<std::uint64_t, Eigen::Vector3d> reference_, test_, corrected_;
  std::map<std::uint64_t, double> temperature_;
  std::vector<std::string> corrected_frame_ids_;  ///< each change of frame_id once
  ros::Subscriber calibration_sub_, reference_sub_, test_sub_, corrected_sub_, temperature_sub_;
};

}  // namespace station_rostest
