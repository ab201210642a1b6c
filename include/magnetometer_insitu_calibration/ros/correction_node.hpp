// correction_node: publishes the raw test magnetometer stream corrected into the reference
// frame with the accepted calibration in use.
//
// Correction (rows are samples, T = R n + d): r = n^-T (t - d) for each reading t (column
// vectors), d = the calibration's offset_nT at its window end, held constant (the trend is not
// extrapolated); with ~apply_offset false, r = n^-T t (variations only, the old behaviour). Output sensor_msgs/MagneticField in tesla, header.stamp = the raw stamp,
// header.frame_id = reference_frame_id of the calibration. Covariance: n^-T C_t n^-1, plus the
// calibration's own uncertainty propagated to first order (~include_calibration_covariance; the
// offset's interval is not added: with the offset applied, the n term, computed with the full
// field r, already bounds it, since d's uncertainty is mostly mean(R) times n's);
// an all-zero (unknown) input covariance stays all zero.
//
// Which calibration is in use:
//  * at start, the YAML file ~calibration_file if it holds a valid accepted calibration; a
//    missing file is a warning, a malformed or half-written one an error in the diagnostics
//    (the node then publishes nothing until a valid calibration arrives on the topic);
//  * a calibration held when the first test sample arrives (the file's, or calibration_node's
//    latched message of it) is kept only if it belongs to the stream (calibration_stream_mismatch:
//    ~test_name, the sample's frame_id, its window ended by the first sample); else it is refused
//    with a warning naming its source and the field, and the diagnostics report the file refused;
//  * then every MagnetometerCalibration on ~calibration_topic with accepted=true, quality OK,
//    a finite matrix and covariance, and a matrix condition number <= ~max_matrix_condition
//    replaces it at once (the most recently received valid one wins; no interpolation between
//    calibrations). Others are rejected, counted and reported in the diagnostics, and the
//    calibration in use is kept;
//  * with ~reload_period > 0 the file is re-read when it changes (same rules; an unusable file
//    keeps the calibration in use).
//
// Policy:
//  * no calibration yet: nothing is published on the corrected topic (never uncorrected data);
//    the samples are counted ("dropped, no calibration");
//  * a sample whose frame_id differs from the calibration's test_frame_id is not corrected (it
//    is another instrument or frame) and counted, when ~check_frame_id;
//  * samples older than the calibration in use (stamp before its window_start): the calibration
//    is a slowly varying instrument property, so by default (~correct_samples_before_window =
//    true) they are corrected with it like any other sample and counted
//    ("corrected, before window"); with false they are dropped and counted. Samples are never
//    held back or re-corrected when a later calibration arrives: each is corrected once, on
//    arrival, with the calibration in use at that moment.
//  * temperature (~temperature_topic, sensor_msgs/Temperature in deg C; "" = none): when the
//    calibration in use has temperature_fitted, each sample is corrected with its temperature
//    terms (CorrectionModel::correct(t, theta); ~temperature_model apparent: c = a, s = 0, or
//    full: c and s as fitted) using the latest temperature whose stamp is within
//    ~temperature_max_age s of the sample's; with none that recent (or a NaN reading) the sample
//    is corrected without them and counted ("corrected without temperature, none recent"). A
//    calibration without temperature terms corrects every sample without them (counted when
//    the topic is set).
//  * queues (~queue_size in, ~publisher_queue_size out) are sized so that no sample is dropped
//    at the rates of a replay; every sample is accounted for in the diagnostics:
//    received = published + dropped (no calibration, frame, before window).
#pragma once

#include "magnetometer_insitu_calibration/common/setting_bindings.hpp"

#include "magnetometer_insitu_calibration/ros/correction_model.hpp"

#include <magnetometer_insitu_calibration/MagnetometerCalibration.h>

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>
#include <sensor_msgs/MagneticField.h>
#include <sensor_msgs/Temperature.h>

#include <cstddef>
#include <memory>
#include <string>

namespace magnetometer_insitu_calibration {

/// Every parameter of correction_node (config/correction.yaml documents them).
struct CorrectionNodeSettings {
  std::string test_topic;                       ///< raw test sensor_msgs/MagneticField (required)
  std::string test_name;                        ///< a calibration held at start must be this test's ("" = any)
  std::string corrected_topic = "corrected";    ///< output sensor_msgs/MagneticField
  std::string calibration_topic = "calibration";
  std::string calibration_file;                 ///< YAML loaded at start ("" = none)
  double reload_period_s = 0.0;                 ///< wall s between file checks, 0 = only at start
  int queue_size = 10000;                       ///< subscriber queue, messages
  int publisher_queue_size = 10000;             ///< publisher queue, messages
  bool correct_samples_before_window = true;
  bool check_frame_id = true;
  bool include_calibration_covariance = true;
  bool apply_offset = true;                     ///< r = n^-T (t - offset_nT at window end); false: r = n^-T t
  double max_matrix_condition = 100.0;          ///< largest accepted condition number of n
  double diagnostic_period_s = 1.0;             ///< ROS time between diagnostics, s
  std::string temperature_topic;                ///< test sensor's sensor_msgs/Temperature (deg C), "" = none
  double temperature_max_age_s = 10.0;          ///< largest |sample stamp - temperature stamp| used, s
  /// "apparent": c = the apparent coefficient a, s = 0 (what a window determines well); "full":
  /// c and s as fitted (s is known only through the field's variations: intervals of thousands
  /// of ppm/degC on a quiet day, which the correction then carries wherever the field leaves F).
  std::string temperature_model = "apparent";

  /// Reads every private parameter; throws ParameterError naming the first impossible one.
  static CorrectionNodeSettings load(const ros::NodeHandle& private_nh);
  /// The declared parameters bound to these settings (the documents' and the tests' view).
  static const SettingBindings<CorrectionNodeSettings>& bindings();
};

class CorrectionNode {
 public:
  CorrectionNode(ros::NodeHandle nh, ros::NodeHandle private_nh);

  const CorrectionNodeSettings& settings() const { return settings_; }

 private:
  struct Active {
    MagnetometerCalibration calibration;
    std::unique_ptr<CorrectionModel> model;
    std::string source;      ///< "file <path>" or "topic <name>"
    double adopted_s = 0.0;  ///< ROS time, s
  };

  /// Adopts a calibration or returns why not (empty = adopted).
  std::string adopt(const MagnetometerCalibration& calibration, const std::string& source);
  void load_file(bool at_start);
  /// Drops the calibration in use when it is not of the stream whose first sample is `first`.
  void refuse_if_not_of_stream(const sensor_msgs::MagneticField& first);
  void on_calibration(const MagnetometerCalibration::ConstPtr& calibration);
  void on_test(const sensor_msgs::MagneticField::ConstPtr& message);
  void on_temperature(const sensor_msgs::Temperature::ConstPtr& message);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);

  ros::NodeHandle nh_, private_nh_;
  CorrectionNodeSettings settings_;
  std::string node_name_;
  ros::Publisher corrected_publisher_;
  ros::Subscriber calibration_subscriber_, test_subscriber_, temperature_subscriber_;
  diagnostic_updater::Updater updater_;
  ros::Timer diagnostic_timer_;
  ros::WallTimer reload_timer_;

  std::unique_ptr<Active> active_;
  std::unique_ptr<MagnetometerCalibration> refused_;  ///< refused at the stream's first sample
  std::size_t received_ = 0, published_ = 0, dropped_no_calibration_ = 0, dropped_frame_ = 0,
              dropped_before_window_ = 0, corrected_before_window_ = 0, reported_frame_ = 0;
  std::string last_frame_seen_;
  std::size_t temperature_messages_ = 0, corrected_with_temperature_ = 0, corrected_temperature_stale_ = 0,
              corrected_calibration_without_temperature_ = 0, reported_stale_ = 0;
  double temperature_C_ = 0.0, temperature_stamp_s_ = 0.0;  ///< latest reading (deg C) and its stamp (UNIX s)
  std::size_t adopted_ = 0, rejected_ = 0, calibration_messages_ = 0;
  std::string last_rejection_;
  bool rejected_since_adoption_ = false;
  std::string file_state_ = "not loaded";  ///< "loaded", "missing", or the error
  bool file_error_ = false;
  bool file_missing_ = false;
  long long file_mtime_ns_ = -1;
  long long file_size_ = -1;
};

}  // namespace magnetometer_insitu_calibration
