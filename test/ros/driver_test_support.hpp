// Helpers shared by the lemi025_driver rostests (test_lemi025_driver, test_faults_driver): the
// test node's private parameters, waiting on a condition, a packet's bytes, the exact stamps the
// driver gives a packet's readings, the readings it publishes and what it reports on
// /diagnostics.
#pragma once

#include "magnetometer_insitu_calibration/formats/lemi025_packet.hpp"
#include "pty_link.hpp"

#include <diagnostic_msgs/DiagnosticArray.h>
#include <diagnostic_msgs/DiagnosticStatus.h>
#include <ros/ros.h>
#include <sensor_msgs/MagneticField.h>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

namespace magnetometer_insitu_calibration {
namespace test {

/// The test node's private parameter ~name (a string), `fallback` when it is not set.
std::string param(const std::string& name, const std::string& fallback = "");

/// How long a test waits for a condition, wall s: the one generous timeout that turns a hang
/// into a failure. The tests wait for conditions (readings arrived, a diagnostics counter
/// reached, the driver read every byte written), never for a duration, so a busy machine only
/// makes them slower; this bound is never reached unless something is broken.
constexpr double kPatience_s = 60.0;

/// Polls `done` every 0.01 s (wall clock) until it holds or timeout_s (s) have passed; returns
/// done() once more at the end.
bool wait_for(const std::function<bool()>& done, double timeout_s = kPatience_s);

/// The bytes of packet p with checksum sum8 (the checksum the .test files give the driver).
std::vector<std::uint8_t> encode(const Lemi025Packet& p);

/// Exact stamp of reading k (0..9) of the packet of GPS second gps_s (s): t_gps - 0.3 + 0.1 k s.
ros::Time gps_stamp(double gps_s, int k);

/// The readings the driver publishes on <driver_namespace>/magnetic_field, in order of arrival.
class FieldInbox {
 public:
  explicit FieldInbox(const std::string& driver_namespace);
  FieldInbox(const FieldInbox&) = delete;
  FieldInbox& operator=(const FieldInbox&) = delete;

  /// Whether the driver's field topic has a publisher.
  bool fields_connected() const { return fields_sub_.getNumPublishers() > 0; }
  std::size_t field_count();
  std::vector<sensor_msgs::MagneticField> fields_from(std::size_t first);
  std::vector<sensor_msgs::MagneticField> all_fields() { return fields_from(0); }
  /// A gtest failure at the first reading whose stamp is not after the one before.
  void expect_all_stamps_increasing();

 private:
  void on_field(const sensor_msgs::MagneticField::ConstPtr& m);

  std::mutex mutex_;
  std::vector<sensor_msgs::MagneticField> fields_;
  ros::Subscriber fields_sub_;
};

/// What one driver node reports on /diagnostics: the newest status of each of its tasks
/// ("packet rate", "link", "instrument") and every status in order of arrival.
class DriverDiagnostics {
 public:
  /// Subscribes to /diagnostics; keeps the statuses named "<driver_node>: <task>".
  explicit DriverDiagnostics(const std::string& driver_node);
  DriverDiagnostics(const DriverDiagnostics&) = delete;
  DriverDiagnostics& operator=(const DriverDiagnostics&) = delete;

  /// The newest status of `task`, if any.
  bool status(const std::string& task, diagnostic_msgs::DiagnosticStatus& out);
  /// A value of the newest status of `task`, "" if absent.
  std::string value(const std::string& task, const std::string& key);
  /// A value of the newest status of `task` as an integer, -1 if absent.
  long long counter(const std::string& task, const std::string& key);
  /// Waits (up to timeout_s, s) until the counter reaches at least `target`; returns the last
  /// value seen.
  long long wait_counter(const std::string& task, const std::string& key, long long target,
                         double timeout_s = kPatience_s);
  /// header.stamp of the newest diagnostics message of the driver: the driver's ros::Time::now()
  /// when it published it (its simulated clock under /use_sim_time); zero before the first.
  ros::Time last_stamp();
  /// How many statuses have arrived so far (a mark for any_since; a WARN lasts one period).
  std::size_t history_size();
  /// Whether a status of `task` at `level` whose message contains `text` arrived after `mark`.
  bool any_since(std::size_t mark, const std::string& task, std::uint8_t level, const std::string& text);
  /// Waits for two more diagnostics messages of the driver, so that the counters reflect what
  /// the driver had done before the call.
  void fresh();

 private:
  std::size_t diagnostics_seen();
  void on_diagnostics(const diagnostic_msgs::DiagnosticArray::ConstPtr& m);

  const std::string prefix_;  ///< "<driver_node>: "
  std::mutex mutex_;
  std::map<std::string, diagnostic_msgs::DiagnosticStatus> statuses_;
  std::vector<std::pair<std::string, diagnostic_msgs::DiagnosticStatus>> history_;
  std::size_t diagnostics_seen_ = 0;  ///< messages that held a status of the driver
  ros::Time last_stamp_;
  ros::Subscriber subscriber_;
};

/// A driver's readings and diagnostics together: writing into its pty and waiting until the
/// driver has consumed it.
class DriverInbox : public FieldInbox, public DriverDiagnostics {
 public:
  DriverInbox(const std::string& driver_namespace, const std::string& driver_node)
      : FieldInbox(driver_namespace), DriverDiagnostics(driver_node) {}

  /// Waits until the driver's "bytes read" reaches every byte written into `port` (the driver
  /// has read them; the packets they held have been handled: published, held or dropped).
  /// A gtest failure if not within kPatience_s.
  void wait_all_read(const PtyLink& port);
  /// Writes `bytes` into the pty, waits for `expected` more readings (a gtest failure when they
  /// do not come), then until the driver has read every byte (so anything extra it published
  /// would be here too); returns the readings that came after the write.
  std::vector<sensor_msgs::MagneticField> write_and_collect(PtyLink& port, const std::vector<std::uint8_t>& bytes,
                                                            std::size_t expected);
};

/// Fixture set-up of the tests of the driver started by the .test file: a fatal gtest failure
/// unless `topics_connected` holds and then the driver's link reports the pty connected, each
/// within kPatience_s.
void assert_driver_on_pty(const std::function<bool()>& topics_connected, DriverDiagnostics& diagnostics);

}  // namespace test
}  // namespace magnetometer_insitu_calibration
