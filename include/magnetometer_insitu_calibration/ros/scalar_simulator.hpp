// scalar_simulator: an absolute scalar magnetometer beside a simulated LEMI-025 station, for the
// scalar check of calibration_node (~scalar_topic) without hardware.
//
// It simulates the station's record as lemi025_simulator does (simulation/lemi025_station.hpp:
// the same ~seed, ~field_seed, ~start and ~duration give the same field) and publishes
// F = |B| + white noise (simulation/scalar_magnetometer.hpp) as ScalarField (tesla) every ~period
// seconds, 0.37 s off the GPS seconds. It keeps pace with the station's own clock, not the wall
// clock: each reference sample (~reference_topic) releases the F samples up to ~lead seconds after
// its stamp, so F arrives ahead of the pair whatever the playback speed, and the record loops as
// lemi025_simulator --loop plays it. Not a nodelet: like the LEMI simulators it stands in for an
// instrument outside the station's nodes.
//
// Parameters (validated at start; an impossible value is fatal, naming it):
//   ~seed (int >= 1, 1), ~field_seed (int >= 0, 0: the seed), ~start (ISO 8601, "": the current
//   UTC hour, as a live lemi025_simulator), ~duration (s of record, 21600), ~period (s between F
//   samples, 1; 0.1 to 3600), ~white_nT (rms noise per sample, 0.01), ~lead (s, 60),
//   ~reference_topic (reference/magnetic_field), ~scalar_topic (scalar/field), ~frame_id (scalar).
// Diagnostics: samples published, the newest stamp, the reference samples seen.
#pragma once

#include "magnetometer_insitu_calibration/common/scalar_record.hpp"

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>
#include <sensor_msgs/MagneticField.h>

#include <cstdint>
#include <string>

namespace magnetometer_insitu_calibration {

struct ScalarSimulatorSettings {
  int seed = 1, field_seed = 0;
  std::string start;  ///< ISO 8601; empty: the current UTC hour
  double duration_s = 21600.0, period_s = 1.0, white_nT = 0.01, lead_s = 60.0;
  std::string reference_topic = "reference/magnetic_field", scalar_topic = "scalar/field", frame_id = "scalar";

  /// Reads and checks the private parameters; throws ParameterError naming the first bad one.
  static ScalarSimulatorSettings load(const ros::NodeHandle& private_nh);
};

class ScalarSimulator {
 public:
  ScalarSimulator(ros::NodeHandle nh, ros::NodeHandle private_nh);

 private:
  void on_reference(const sensor_msgs::MagneticField::ConstPtr& message);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);

  ScalarSimulatorSettings settings_;
  ScalarRecord record_;        ///< one pass of the record: F (nT) at its times (UNIX s)
  double start_s_ = 0.0;       ///< GPS second of the record's first packet
  std::uint64_t next_ = 0;     ///< index of the next sample over the passes (pass * size + k)
  std::uint64_t published_ = 0, references_ = 0;
  double last_stamp_s_ = 0.0;
  ros::Publisher publisher_;
  ros::Subscriber subscriber_;
  diagnostic_updater::Updater updater_;
};

}  // namespace magnetometer_insitu_calibration
