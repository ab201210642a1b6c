// record_file_follower: a remote observatory's record files (daily IAGA-2002, ImagCDF, any
// format the package reads), as a cron job fetches them minutes to hours late, published as a
// sensor_msgs/MagneticField stream at the files' own stamps, in order, once each (thin ROS layer
// over the core's RecordFileFollower, formats/record_follower.hpp, which reads them with the
// readers calibrate_records uses).
//
// Output: ~topic, sensor_msgs/MagneticField in tesla (the files' nT / 1e9, NaN where a value is
// missing), header.stamp = the sample's time, header.frame_id = ~frame_id, x, y, z = the files'
// three columns; covariance diag((~noise_nT 1e-9)^2), all zero (unknown) by default.
//
// Follow mode (~follow true): a look at the files every ~poll_period wall seconds; each look's
// new samples are published at ~rate times real time against their stamps (0: as fast as
// possible), while the topic has at least ~wait_for_subscribers subscribers (publishing waits
// otherwise: nothing is published into the void). Replay (~follow false): one look, every line
// read (nothing is being written), published at ~rate, then the node idles with its diagnostics.
//
// Restart: ~state_file holds the newest stamp published (and the stream's station, sample period
// and components), written atomically after each look's samples, every 10 s while publishing and
// at shutdown; a restart publishes the samples after it. A crash between two writes publishes at
// most those 10 s of publishing again; a clean stop (SIGINT, roslaunch) none, and loses none when
// it comes while the node waits for files (a stop while it publishes loses, for the subscribers,
// the messages still queued when the connections close).
//
// Threads: a worker thread looks and publishes; the node handle's callback queue (ros::spin, or
// the nodelet's) runs the diagnostics on a wall-clock timer. Shared figures are under a mutex.
#pragma once

#include "magnetometer_insitu_calibration/common/setting_bindings.hpp"
#include "magnetometer_insitu_calibration/formats/record_follower.hpp"

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <limits>
#include <mutex>
#include <string>
#include <thread>

namespace magnetometer_insitu_calibration {

/// Every parameter of record_file_follower (config/record_file_follower.yaml documents them).
struct RecordFileFollowerSettings {
  std::string path;                ///< directory or glob pattern (required)
  std::string station;             ///< "" = the files' own
  double sample_period_s = 0.0;    ///< s; 0 = the files' own
  std::string state_file;          ///< "" = none
  std::string start;               ///< ISO 8601 UTC; "" = the files' first sample
  double ahead_tolerance_s = 300.0;
  std::string topic = "magnetic_field";
  std::string frame_id = "remote";
  double noise_nT = 0.0;           ///< per-sample noise, nT; 0 = covariance unknown
  bool follow = true;
  double poll_period_s = 10.0;     ///< wall s between looks
  double rate = 1000.0;            ///< publishing speed against the stamps; 0 = as fast as possible
  int wait_for_subscribers = 1;
  int publisher_queue_size = 10000;
  double max_lag_s = 21600.0;      ///< wall s; 0 = no check
  double diagnostic_period_s = 1.0;  ///< wall s

  /// Reads every private parameter; throws ParameterError naming the first impossible one.
  static RecordFileFollowerSettings load(const ros::NodeHandle& private_nh);
  /// The declared parameters bound to these settings.
  static const SettingBindings<RecordFileFollowerSettings>& bindings();
};

class RecordFileFollowerNode {
 public:
  RecordFileFollowerNode(ros::NodeHandle nh, ros::NodeHandle private_nh);
  /// Stops the worker and writes the state file with the newest stamp published.
  ~RecordFileFollowerNode();
  RecordFileFollowerNode(const RecordFileFollowerNode&) = delete;
  RecordFileFollowerNode& operator=(const RecordFileFollowerNode&) = delete;

  const RecordFileFollowerSettings& settings() const { return settings_; }

 private:
  using Clock = std::chrono::steady_clock;

  /// What the diagnostics show, copied from the worker under mutex_.
  struct Figures {
    RecordFollowerCounts counts;
    std::vector<FollowedFile> files;
    RecordFollowerState stream;     ///< station, period, components
    std::size_t published = 0;
    double newest_published_s = -std::numeric_limits<double>::infinity();  ///< UNIX s
    std::size_t lines_refused_last_look = 0;
    double last_look_wall_s = 0.0, last_look_duration_s = 0.0;
    bool waiting_for_subscribers = false;
    bool replay_finished = false;
    std::string look_error;         ///< the last look's failure, "" = none
    std::string state_error;        ///< the state file could not be written, "" = none
    std::string state_written;      ///< when it was last written (ISO 8601), "" = never
  };

  RecordFollowerState resume_state();
  void run();
  void look_once(bool final);
  /// Publishes the samples at ~rate; false when the node stops meanwhile.
  bool publish(const VectorRecord& samples);
  bool wait_for_subscribers();
  /// Waits until `until` or the node stops; false when it stops.
  bool wait_until(Clock::time_point until);
  void save_state();
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);

  ros::NodeHandle nh_, private_nh_;
  RecordFileFollowerSettings settings_;
  std::string node_name_;
  ros::Publisher publisher_;
  diagnostic_updater::Updater updater_;
  ros::WallTimer diagnostic_timer_;

  RecordFileFollower follower_;  ///< the worker's only
  std::string state_text_written_;  ///< the worker's: the state file's text as last written
  Clock::time_point state_due_;

  std::mutex mutex_;             ///< figures_, stopping_
  std::condition_variable wake_;
  bool stopping_ = false;
  Figures figures_;
  std::thread worker_;
};

}  // namespace magnetometer_insitu_calibration
