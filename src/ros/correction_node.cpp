// correction_node: the raw test stream corrected into the reference frame (see correction_node.hpp).
#include "magnetometer_insitu_calibration/ros/correction_node.hpp"

#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"  // kNormalQuantile95
#include "magnetometer_insitu_calibration/pipeline/calibration_record.hpp"  // calibration_stream_mismatch
#include "magnetometer_insitu_calibration/pipeline/setting_declarations.hpp"

#include "magnetometer_insitu_calibration/ros/calibration_yaml.hpp"
#include "magnetometer_insitu_calibration/ros/parameters.hpp"
#include "magnetometer_insitu_calibration/ros/si_units.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"

#include <ros/names.h>

#include <cerrno>
#include <cmath>
#include <limits>
#include <cstring>
#include <sstream>
#include <sys/stat.h>

namespace magnetometer_insitu_calibration {

namespace {

using diagnostic_msgs::DiagnosticStatus;
using diagnostic_updater::DiagnosticStatusWrapper;

using C = CorrectionNodeSettings;

}  // namespace

/// The declared parameters bound to the node's settings (pipeline/setting_declarations.hpp).
const SettingBindings<C>& CorrectionNodeSettings::bindings() {
  static const SettingBindings<C> bindings = [] {
    SettingBindings<C> b(correction_setting_declarations());
    b.bind("test_topic", [](C& c) -> std::string& { return c.test_topic; })
        .bind("test_name", [](C& c) -> std::string& { return c.test_name; })
        .bind("corrected_topic", [](C& c) -> std::string& { return c.corrected_topic; })
        .bind("calibration_topic", [](C& c) -> std::string& { return c.calibration_topic; })
        .bind("calibration_file", [](C& c) -> std::string& { return c.calibration_file; })
        .bind("temperature_topic", [](C& c) -> std::string& { return c.temperature_topic; })
        .bind("reload_period", [](C& c) -> double& { return c.reload_period_s; })
        .bind("correct_samples_before_window", [](C& c) -> bool& { return c.correct_samples_before_window; })
        .bind("check_frame_id", [](C& c) -> bool& { return c.check_frame_id; })
        .bind("include_calibration_covariance", [](C& c) -> bool& { return c.include_calibration_covariance; })
        .bind("apply_offset", [](C& c) -> bool& { return c.apply_offset; })
        .bind("max_matrix_condition", [](C& c) -> double& { return c.max_matrix_condition; })
        .bind("temperature_max_age", [](C& c) -> double& { return c.temperature_max_age_s; })
        .bind("temperature_model", [](C& c) -> std::string& { return c.temperature_model; })
        .bind("queue_size", [](C& c) -> int& { return c.queue_size; })
        .bind("publisher_queue_size", [](C& c) -> int& { return c.publisher_queue_size; })
        .bind("diagnostic_period", [](C& c) -> double& { return c.diagnostic_period_s; });
    return b;
  }();
  return bindings;
}

namespace {

std::string window_text(const MagnetometerCalibration& c) {
  return time_for_message(c.window_start.toSec()) + " .. " + time_for_message(c.window_end.toSec());
}

}  // namespace

CorrectionNodeSettings CorrectionNodeSettings::load(const ros::NodeHandle& p) {
  CorrectionNodeSettings s;
  load_declared(p, bindings(), s);
  // The rules between parameters.
  if (s.corrected_topic == s.test_topic) throw ParameterError("corrected_topic", "must differ from ~test_topic");
  if (s.reload_period_s > 0.0 && s.calibration_file.empty()) {
    throw ParameterError("reload_period", "is set but ~calibration_file is empty");
  }
  for (const std::string* other : {&s.test_topic, &s.corrected_topic, &s.calibration_topic}) {
    if (!s.temperature_topic.empty() && s.temperature_topic == *other) {
      throw ParameterError("temperature_topic", "'" + s.temperature_topic + "' is a magnetic field or calibration topic");
    }
  }
  return s;
}

CorrectionNode::CorrectionNode(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : nh_(nh),
      private_nh_(private_nh),
      settings_(CorrectionNodeSettings::load(private_nh)),
      node_name_(private_nh.getNamespace()),  // the node's name; a nodelet's own name in a manager
      updater_(nh, private_nh, private_nh.getNamespace()) {
  for (const std::string& name : unknown_private_parameters(private_nh_, declared_parameters(correction_setting_declarations()))) {
    ROS_WARN("%s: unknown parameter ~%s is ignored (misspelt?)", node_name_.c_str(), name.c_str());
  }
  updater_.setHardwareID("test " + nh_.resolveName(settings_.test_topic));
  updater_.add("correction", [this](DiagnosticStatusWrapper& status) { diagnose(status); });
  if (!settings_.calibration_file.empty()) load_file(true);

  corrected_publisher_ =
      nh_.advertise<sensor_msgs::MagneticField>(settings_.corrected_topic, static_cast<std::uint32_t>(settings_.publisher_queue_size));
  const ros::TransportHints hints = ros::TransportHints().tcpNoDelay();
  calibration_subscriber_ = nh_.subscribe(settings_.calibration_topic, 10, &CorrectionNode::on_calibration, this, hints);
  test_subscriber_ = nh_.subscribe(settings_.test_topic, static_cast<std::uint32_t>(settings_.queue_size),
                                   &CorrectionNode::on_test, this, hints);
  if (!settings_.temperature_topic.empty()) {
    temperature_subscriber_ = nh_.subscribe(settings_.temperature_topic, static_cast<std::uint32_t>(settings_.queue_size),
                                            &CorrectionNode::on_temperature, this, hints);
  }
  diagnostic_timer_ = nh_.createTimer(ros::Duration(settings_.diagnostic_period_s),
                                      [this](const ros::TimerEvent&) { updater_.force_update(); });
  if (settings_.reload_period_s > 0.0) {
    reload_timer_ = nh_.createWallTimer(ros::WallDuration(settings_.reload_period_s),
                                        [this](const ros::WallTimerEvent&) { load_file(false); });
  }
  ROS_INFO("%s: %s -> %s with calibrations from %s%s", node_name_.c_str(), nh_.resolveName(settings_.test_topic).c_str(),
           nh_.resolveName(settings_.corrected_topic).c_str(), nh_.resolveName(settings_.calibration_topic).c_str(),
           settings_.calibration_file.empty() ? "" : (" and " + settings_.calibration_file).c_str());
}

std::string CorrectionNode::adopt(const MagnetometerCalibration& c, const std::string& source) {
  // The file's calibration again (calibration_node's latched message of it) changes nothing;
  // one refused at the stream's start stays refused.
  if (active_ && calibrations_equal(active_->calibration, c)) return "";
  if (refused_ && calibrations_equal(*refused_, c)) return "refused at the stream's start";
  std::string reason;
  if (!c.accepted) {
    reason = "not accepted (" + c.quality_text + ")";
  } else if (c.quality != MagnetometerCalibration::QUALITY_OK) {
    reason = "accepted=true but quality " + std::to_string(c.quality) + " is not OK";
  }
  std::unique_ptr<CorrectionModel> model;
  if (reason.empty()) {
    Eigen::Matrix3d n;
    Matrix9d covariance;
    for (int k = 0; k < 9; ++k) n(k / 3, k % 3) = c.matrix[k];
    for (int k = 0; k < 81; ++k) covariance(k / 9, k % 9) = c.matrix_covariance[k];
    try {
      // Offset in nT (test frame) -> tesla, the unit of the topics; constant (trend not extrapolated).
      // With the offset, n's uncertainty propagates from the window's reference mean
      // (CorrectionModel); without it, from the whole field.
      Eigen::Vector3d offset = Eigen::Vector3d::Zero(), anchor = Eigen::Vector3d::Zero();
      if (settings_.apply_offset) {
        offset = kTeslaPerNanotesla * Eigen::Vector3d(c.offset_nT[0], c.offset_nT[1], c.offset_nT[2]);
        anchor = kTeslaPerNanotesla * Eigen::Vector3d(c.reference_mean_nT[0], c.reference_mean_nT[1], c.reference_mean_nT[2]);
      }
      model = std::make_unique<CorrectionModel>(n, covariance, settings_.max_matrix_condition, offset, anchor);
      if (c.temperature_fitted) {  // c in nT/degC -> T/degC; s in ppm/degC -> 1/degC
        const auto vector = [](const boost::array<double, 3>& a, double factor) {
          return Eigen::Vector3d(factor * a[0], factor * a[1], factor * a[2]);
        };
        const bool full = settings_.temperature_model == "full";
        if (full) {
          model->set_temperature(c.temperature_reference_C, vector(c.temperature_offset_nT_per_C, kTeslaPerNanotesla),
                                 vector(c.temperature_scale_ppm_per_C, 1e-6));
        } else {  // apparent: a u, no scale term
          model->set_temperature(c.temperature_reference_C, vector(c.temperature_apparent_nT_per_C, kTeslaPerNanotesla),
                                 Eigen::Vector3d::Zero());
        }
        // Standard errors (ci95 / 1.96) in T/degC and 1/degC; F = n^T m + d, the window's mean
        // test field (0 without the offset: the scale term's lever is then the whole field).
        model->set_temperature_uncertainty(vector(c.temperature_apparent_ci95_nT_per_C, kTeslaPerNanotesla / kNormalQuantile95),
                                           full ? vector(c.temperature_scale_ci95_ppm_per_C, 1e-6 / kNormalQuantile95)
                                                : Eigen::Vector3d::Zero(),
                                           n.transpose() * anchor + offset);
      }
    } catch (const std::invalid_argument& e) {
      reason = e.what();
    }
  }
  if (!reason.empty()) {
    ++rejected_;
    rejected_since_adoption_ = true;
    last_rejection_ = source + ", window " + window_text(c) + ": " + reason;
    if (c.accepted) {
      ROS_WARN("%s: calibration rejected: %s", node_name_.c_str(), last_rejection_.c_str());
    } else {
      ROS_INFO("%s: calibration rejected: %s", node_name_.c_str(), last_rejection_.c_str());
    }
    return reason;
  }
  auto next = std::make_unique<Active>();
  next->calibration = c;
  next->model = std::move(model);
  next->source = source;
  next->adopted_s = ros::Time::now().toSec();
  active_ = std::move(next);
  ++adopted_;
  rejected_since_adoption_ = false;
  ROS_INFO("%s: calibration of window %s (%s) in use, from %s", node_name_.c_str(), window_text(c).c_str(),
           c.test_name.c_str(), source.c_str());
  return "";
}

void CorrectionNode::load_file(bool at_start) {
  const std::string& path = settings_.calibration_file;
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0) {
    if (errno == ENOENT) {
      file_missing_ = true;
      file_error_ = false;
      file_state_ = "missing (no calibration written yet)";
      if (at_start) ROS_WARN("%s: no calibration file %s yet", node_name_.c_str(), path.c_str());
    } else {
      file_error_ = true;
      file_state_ = path + ": " + std::strerror(errno);
    }
    return;
  }
  const long long mtime_ns = static_cast<long long>(info.st_mtim.tv_sec) * 1000000000LL + info.st_mtim.tv_nsec;
  if (!at_start && mtime_ns == file_mtime_ns_ && static_cast<long long>(info.st_size) == file_size_) return;
  file_mtime_ns_ = mtime_ns;
  file_size_ = static_cast<long long>(info.st_size);
  file_missing_ = false;
  try {
    const MagnetometerCalibration c = load_calibration_file(path);
    if (active_ && calibrations_equal(active_->calibration, c)) {
      file_error_ = false;
      file_state_ = "loaded (same as in use)";
      return;
    }
    const std::string reason = adopt(c, "file " + path);
    file_error_ = !reason.empty();
    file_state_ = reason.empty() ? "loaded" : path + ": calibration not usable: " + reason;
  } catch (const CalibrationFileError& e) {
    file_error_ = true;
    file_state_ = e.what();
    ROS_ERROR("%s: calibration file unusable, %s: %s", node_name_.c_str(),
              active_ ? "keeping the calibration in use" : "nothing will be published until a calibration arrives",
              e.what());
  }
}

void CorrectionNode::on_calibration(const MagnetometerCalibration::ConstPtr& calibration) {
  ++calibration_messages_;
  adopt(*calibration, "topic " + nh_.resolveName(settings_.calibration_topic));
  // calibration_node writes the file before it publishes: the file's state follows the topic
  // (unchanged files are not read again).
  if (!settings_.calibration_file.empty()) load_file(false);
}

void CorrectionNode::on_temperature(const sensor_msgs::Temperature::ConstPtr& message) {
  ++temperature_messages_;
  temperature_C_ = message->temperature;
  temperature_stamp_s_ = message->header.stamp.toSec();
}

void CorrectionNode::refuse_if_not_of_stream(const sensor_msgs::MagneticField& first) {
  const MagnetometerCalibration& c = active_->calibration;
  const std::string reason = calibration_stream_mismatch(
      c.test_name, c.test_frame_id, RecordTime{c.window_end.sec, c.window_end.nsec},
      {settings_.test_name, settings_.check_frame_id ? first.header.frame_id : c.test_frame_id,
       RecordTime{first.header.stamp.sec, first.header.stamp.nsec}});
  if (reason.empty()) return;
  ++rejected_;
  last_rejection_ = active_->source + ", window " + window_text(c) + ": not of this stream: " + reason;
  ROS_WARN("%s: calibration refused: %s", node_name_.c_str(), last_rejection_.c_str());
  if (active_->source == "file " + settings_.calibration_file) {
    file_error_ = true;
    file_state_ = settings_.calibration_file + ": refused, not of this stream: " + reason;
  }
  refused_ = std::make_unique<MagnetometerCalibration>(c);
  active_.reset();
}

void CorrectionNode::on_test(const sensor_msgs::MagneticField::ConstPtr& message) {
  // A calibration held before the stream began must belong to it (docs/nodes.md).
  if (++received_ == 1 && active_) refuse_if_not_of_stream(*message);
  if (!active_) {
    ++dropped_no_calibration_;
    return;
  }
  const MagnetometerCalibration& c = active_->calibration;
  if (settings_.check_frame_id && message->header.frame_id != c.test_frame_id) {
    ++dropped_frame_;
    last_frame_seen_ = message->header.frame_id;
    return;
  }
  if (message->header.stamp < c.window_start) {
    if (!settings_.correct_samples_before_window) {
      ++dropped_before_window_;
      return;
    }
    ++corrected_before_window_;
  }
  const CorrectionModel& model = *active_->model;
  const Eigen::Vector3d test(message->magnetic_field.x, message->magnetic_field.y, message->magnetic_field.z);  // T
  Eigen::Vector3d reference;  // T, reference frame
  double corrected_at_C = std::numeric_limits<double>::quiet_NaN();  // temperature the terms were applied at
  if (model.has_temperature() && !settings_.temperature_topic.empty()) {
    const double age_s = std::abs(message->header.stamp.toSec() - temperature_stamp_s_);
    if (temperature_messages_ > 0 && age_s <= settings_.temperature_max_age_s && std::isfinite(temperature_C_)) {
      reference = model.correct(test, temperature_C_);
      corrected_at_C = temperature_C_;
      ++corrected_with_temperature_;
    } else {
      reference = model.correct(test);
      ++corrected_temperature_stale_;
    }
  } else {
    reference = model.correct(test);
    if (!settings_.temperature_topic.empty()) ++corrected_calibration_without_temperature_;
  }
  Eigen::Matrix3d test_covariance;  // T^2, test frame
  for (int k = 0; k < 9; ++k) test_covariance(k / 3, k % 3) = message->magnetic_field_covariance[k];

  sensor_msgs::MagneticField out;
  out.header.stamp = message->header.stamp;
  out.header.frame_id = c.reference_frame_id;
  out.magnetic_field.x = reference(0);
  out.magnetic_field.y = reference(1);
  out.magnetic_field.z = reference(2);
  if (!test_covariance.isZero(0.0)) {  // all zero = unknown, and stays unknown
    const Eigen::Matrix3d covariance =
        model.corrected_covariance(test_covariance, reference, settings_.include_calibration_covariance, corrected_at_C);
    for (int k = 0; k < 9; ++k) out.magnetic_field_covariance[k] = covariance(k / 3, k % 3);
  }
  corrected_publisher_.publish(out);
  ++published_;
}

void CorrectionNode::diagnose(DiagnosticStatusWrapper& status) {
  status.summary(DiagnosticStatus::OK, "correcting");
  status.add("test topic", nh_.resolveName(settings_.test_topic));
  status.add("corrected topic", nh_.resolveName(settings_.corrected_topic));
  status.add("calibration topic", nh_.resolveName(settings_.calibration_topic));
  status.add("calibration file", settings_.calibration_file);
  status.add("calibration file state", file_state_);
  status.add("received", received_);
  status.add("published", published_);
  status.add("dropped, no calibration", dropped_no_calibration_);
  status.add("dropped, frame_id mismatch", dropped_frame_);
  status.add("dropped, before window", dropped_before_window_);
  status.add("corrected, before window", corrected_before_window_);
  status.add("temperature topic",
             settings_.temperature_topic.empty() ? std::string("none") : nh_.resolveName(settings_.temperature_topic));
  if (!settings_.temperature_topic.empty()) {
    status.add("temperature samples", temperature_messages_);
    status.add("temperature last (degC)", temperature_C_);
    status.add("temperature last stamp",
               temperature_messages_ > 0 ? time_for_message(temperature_stamp_s_) : std::string("none"));
    status.add("temperature model", settings_.temperature_model);
    status.add("corrected with temperature", corrected_with_temperature_);
    status.add("corrected without temperature, none recent", corrected_temperature_stale_);
    status.add("corrected without temperature, calibration has none", corrected_calibration_without_temperature_);
  }
  status.add("calibration messages", calibration_messages_);
  status.add("calibrations adopted", adopted_);
  status.add("calibrations rejected", rejected_);
  status.add("last rejection", last_rejection_);
  if (active_) {
    const MagnetometerCalibration& c = active_->calibration;
    status.add("calibration source", active_->source);
    status.add("calibration window", window_text(c));
    status.add("calibration stamp", time_for_message(c.header.stamp.toSec()));
    status.add("calibration test name", c.test_name);
    status.add("calibration frames", c.test_frame_id + " -> " + c.reference_frame_id);
    std::ostringstream matrix;
    matrix.precision(9);
    for (int k = 0; k < 9; ++k) matrix << (k ? " " : "") << c.matrix[k];
    status.add("calibration matrix n (row-major)", matrix.str());
    status.add("calibration condition number", active_->model->condition_number());
    std::ostringstream offset;
    offset.precision(6);
    for (int k = 0; k < 3; ++k) offset << (k ? " " : "") << c.offset_nT[k];
    offset << " (95 % +-";
    for (int k = 0; k < 3; ++k) offset << " " << c.offset_ci95_nT[k];
    offset << ")";
    status.add("calibration offset at window end (nT)", offset.str());
    status.add("offset applied", settings_.apply_offset);
    std::ostringstream mean;
    mean.precision(8);
    for (int k = 0; k < 3; ++k) mean << (k ? " " : "") << c.reference_mean_nT[k];
    status.add("calibration reference mean (nT; n's uncertainty propagates from it)", mean.str());
    status.add("calibration temperature terms", c.temperature_fitted ? "fitted" : "none");
    status.add("calibration temperature text", c.temperature_text);
    if (c.temperature_fitted) {
      std::ostringstream terms;
      terms.precision(6);
      terms << "reference " << c.temperature_reference_C << " degC; offset";
      for (int k = 0; k < 3; ++k) terms << " " << c.temperature_offset_nT_per_C[k];
      terms << " nT/degC; scale";
      for (int k = 0; k < 3; ++k) terms << " " << c.temperature_scale_ppm_per_C[k];
      terms << " ppm/degC";
      status.add("calibration temperature coefficients", terms.str());
    }
  } else {
    status.add("calibration source", "none");
  }
  if (file_error_) {
    status.mergeSummary(active_ ? DiagnosticStatus::WARN : DiagnosticStatus::ERROR,
                        "calibration file unusable: " + file_state_);
  }
  if (!active_) {
    status.mergeSummary(DiagnosticStatus::WARN, "no calibration yet: " + std::to_string(dropped_no_calibration_) +
                                                    " samples not published");
  } else if (rejected_since_adoption_) {
    status.mergeSummary(DiagnosticStatus::WARN, "latest calibration rejected (" + last_rejection_ + "), still using " +
                                                    window_text(active_->calibration));
  }
  if (dropped_frame_ > reported_frame_) {
    status.mergeSummary(DiagnosticStatus::WARN, std::to_string(dropped_frame_ - reported_frame_) +
                                                    " samples with frame_id '" + last_frame_seen_ +
                                                    "' instead of '" + active_->calibration.test_frame_id + "'");
  }
  reported_frame_ = dropped_frame_;
  if (corrected_temperature_stale_ > reported_stale_) {
    status.mergeSummary(DiagnosticStatus::WARN, std::to_string(corrected_temperature_stale_ - reported_stale_) +
                                                    " samples corrected without temperature: none within " +
                                                    number_text(settings_.temperature_max_age_s) + " s");
  }
  reported_stale_ = corrected_temperature_stale_;
}

}  // namespace magnetometer_insitu_calibration
