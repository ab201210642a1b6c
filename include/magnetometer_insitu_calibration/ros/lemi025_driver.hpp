// lemi025_driver: a LEMI-025 (or LEMI-036) fluxgate magnetometer as ROS topics, read live from
// its serial port or replayed from a recording (thin ROS layer over the core's PacketSource).
//
// Output (config/lemi025_driver.yaml documents the parameters):
//  * magnetic_field (sensor_msgs/MagneticField): one message per reading, 10 per packet (10 Hz
//    live), in TESLA (1 nT = 1e-9 T), X, Y, Z = the instrument's own sensor axes, full field
//    (bias + variation) or variation only (~field). header.frame_id = ~frame_id.
//    Covariance: diag((~noise_nT * 1e-9)^2) T^2 (all zero, "unknown", when ~noise_nT = 0).
//    A reading that is not finite or outside the plausible range (|variation| > 100000 nT) is
//    published as NaN (never a sentinel value) and counted.
//  * temperature/sensor and temperature/electronics (sensor_msgs/Temperature, deg C): one per
//    packet (1 Hz live), stamped like the packet's first reading; variance 0 (unknown).
//  * diagnostics (diagnostic_updater): packet rate (FrequencyStatus), link and parser counters
//    (checksum errors, resyncs, bytes skipped, time jumps, disconnects, reconnects, samples
//    dropped), instrument state (GPS status and time source, supply voltage, temperatures, bias
//    field and its changes).
//
// Time stamps:
//  * GPS status 'A' (active): reading k of a packet is stamped t_gps - 0.3 s + 0.1 s k (the
//    vendor's time-scale correction, Lemi025Packet::sample_time_s).
//  * Any other GPS status ('P' passive, 'O' no antenna, 'S' antenna short circuit), live serial
//    port: the instrument clock is not trusted; the packet is stamped from the PC clock
//    (ros::Time::now()) at its arrival, taken as the time of its last reading (first reading
//    0.9 s before). Successive packets advance by 1 s, slewed towards the arrival times by a
//    tenth of the difference, so arrival jitter does not jitter the 10 Hz stamps; a difference
//    over 0.5 s restarts from the arrival time. The diagnostics say so (WARN, or ERROR and no
//    data when ~gps_required).
//  * Recordings: a LemiBin record carries the PC clock at reception, used the same way when
//    GPS is not active; a raw stream capture and a compact-flash image have no PC time, so
//    their GPS-clock times are kept and the diagnostics say so.
//  * Stamps never go backwards: a reading whose stamp is not after the last published one (a
//    clock step backwards, a repeated packet) is dropped and counted; publishing resumes when
//    the stamps pass the last published one.
//  * Isolated GPS time jumps. Reference R = the GPS second of the newest packet accepted on GPS
//    time, n = packets received since (any time source; an outlier that was dropped keeps its
//    one-second slot). A GPS packet with R < t <= R + n runs on from R and is published at
//    once. One AHEAD of R + n (a day-ahead receiver glitch, a corrupted time byte that passed the
//    checksum or checksum none, but also a real re-synchronisation or a lost packet) is held, not
//    published, until a later packet decides:
//      - a packet consistent with a held one in the same way (t_held < t <= t_held + packets
//        since it): the held packet is real; it and then the new one are published, nothing
//        lost, counted in "GPS time jumps confirmed";
//      - a packet consistent with R: the held packets were outliers; they are dropped and
//        counted in "packets dropped (isolated GPS time jump)" (10 readings each), WARN;
//      - neither: it is held too (at most 3 held; the oldest is dropped and counted beyond).
//    Cost: a packet after a forward discontinuity is published ONE packet later (1 s live, the
//    next packet confirms it); while the GPS seconds run on, nothing is held. A packet held
//    when a packet without GPS time comes, or older than a confirmed one (a real jump, then a
//    gap, then another real jump), is dropped and counted: the one case of a lost good packet.
//    A backwards or repeated second is never held (it cannot push the last stamp ahead): the
//    rule above drops what is not after the last published reading. The first GPS packet
//    after start has no reference: it is held the same way until a later packet confirms it
//    (so a glitch in the very first packet cannot block the data that follow), at the same cost
//    of one packet's delay. Held packets are published at the end of a recording.
//  * PC clock steps (GPS not active): a packet arriving more than 0.5 s off the 1 s prediction
//    restarts the stamps from the arrival time and is counted in "PC clock steps" (WARN). A
//    forward step leaves a gap in the stamps and loses nothing; after a backward step of D s the
//    readings stamped before the last published one (about D s of data) are dropped and counted
//    as "readings dropped (stamp not after the previous)": stamps never go backwards.
//
// Threads: a reading thread waits on the packet source and publishes; the main thread
// (ros::spin) runs the diagnostics, on a wall-clock timer (every ~diagnostic_period s of real
// time, also while a simulated /clock is paused or stepped). Shared counters are under a mutex.
// Reconnection: the serial port is reopened at once and then every ~reopen_interval s after a
// disconnection (USB adapter unplugged, pty closed, or the device path now naming another
// device: a re-created or re-pointed symlink) by the core's StreamPacketSource; the device need
// not exist at start. While disconnected the "link" diagnostic is ERROR and says why (the
// device's last error) and how many reopen attempts were made.
#pragma once

#include "magnetometer_insitu_calibration/common/setting_bindings.hpp"

#include "magnetometer_insitu_calibration/formats/lemi025_packet.hpp"
#include "magnetometer_insitu_calibration/formats/lemi_archive.hpp"
#include "magnetometer_insitu_calibration/instrument/packet_source.hpp"

#include <diagnostic_updater/diagnostic_updater.h>
#include <diagnostic_updater/update_functions.h>
#include <ros/ros.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

namespace magnetometer_insitu_calibration {

/// Where the driver's packets come from (~source).
enum class Lemi025SourceKind { kSerial, kStreamFile, kLemiBin, kCompactFlash };

/// Every parameter of lemi025_driver, read and validated once at start-up.
struct Lemi025DriverSettings {
  Lemi025SourceKind source = Lemi025SourceKind::kSerial;
  std::string source_name = "serial";       ///< serial | stream_file | lemibin | compact_flash
  std::string device;                       ///< serial device or pty symlink (serial)
  int baud = 57600;                         ///< 57600 or 19200 (serial)
  std::string file;                         ///< recording (stream_file, lemibin, compact_flash)
  double rate = 1.0;                        ///< replay speed factor, 1 = real time, 0 = as fast as possible
  ChecksumMode checksum = ChecksumMode::kNone;
  LemiFieldMode field = LemiFieldMode::kFullField;
  std::string frame_id = "lemi025";
  double noise_nT = 0.02;                   ///< per-reading noise, nT rms (covariance diagonal)
  double reopen_interval_s = 1.0;           ///< s between reopen attempts while disconnected
  bool gps_required = false;                ///< drop readings while GPS status is not 'A'
  double expected_packet_rate = 1.0;        ///< packets/s expected from the serial port (1 live)
  double min_supply_V = 0.0;                ///< supply voltage below which to warn, V (0 = no check)
  int publisher_queue_size = 1000;          ///< messages
  int wait_for_subscribers = 0;             ///< a recording starts when magnetic_field has this many (0: at once)
  double diagnostic_period_s = 1.0;         ///< s between diagnostics

  /// Reads every private parameter; throws ParameterError naming the first impossible one.
  static Lemi025DriverSettings load(const ros::NodeHandle& private_nh);
  /// The declared parameters bound to these settings (the documents' and the tests' view).
  static const SettingBindings<Lemi025DriverSettings>& bindings();
  /// True for the recorded sources (stream_file, lemibin, compact_flash).
  bool recorded() const { return source != Lemi025SourceKind::kSerial; }
};

/// Time stamps of the PC clock for packets without GPS time (see the file comment).
class PcPacketClock {
 public:
  /// Time of the first reading of a packet that arrived at `arrival_s` (its last reading).
  double first_reading_time(double arrival_s);
  /// The next packet starts a new sequence (after a GPS-stamped packet or a disconnection).
  void reset() { have_previous_ = false; }
  /// Restarts from the arrival time because it differed from the 1 s prediction by more than
  /// 0.5 s (a PC clock step, or packets not arriving for a while), since construction.
  std::uint64_t steps() const { return steps_; }
  /// Arrival minus prediction at the newest step, s (negative: the PC clock went backwards).
  double last_step_s() const { return last_step_s_; }

 private:
  bool have_previous_ = false;
  double previous_s_ = 0.0;
  std::uint64_t steps_ = 0;
  double last_step_s_ = 0.0;
};

class Lemi025Driver {
 public:
  /// Reads the parameters (throws ParameterError), opens the source (a recording that cannot
  /// be read throws ParameterError naming ~file), advertises and starts the reading thread.
  Lemi025Driver(ros::NodeHandle nh, ros::NodeHandle private_nh);
  ~Lemi025Driver();
  Lemi025Driver(const Lemi025Driver&) = delete;
  Lemi025Driver& operator=(const Lemi025Driver&) = delete;

  const Lemi025DriverSettings& settings() const { return settings_; }

 private:
  /// What the diagnostics show; written by the reading thread under mutex_.
  struct State {
    PacketSourceStats stats;
    bool connected = false;
    std::string connection_problem;           ///< why not connected (the device's last error)
    double disconnected_since_wall_s = -1.0;  ///< wall s the link went down, -1 while connected
    std::string last_disconnect;              ///< "<wall time> disconnected: <source> (<why>)"
    bool at_end = false;
    std::uint64_t packets_received = 0;       ///< packets handed to the driver
    std::uint64_t readings_published = 0;
    std::uint64_t readings_invalid = 0;       ///< published as NaN
    std::uint64_t readings_dropped_time = 0;  ///< stamp not after the last published one
    std::uint64_t readings_dropped_gps = 0;   ///< GPS not active and ~gps_required
    std::uint64_t readings_bad_time = 0;      ///< no usable time at all
    std::uint64_t packets_without_gps = 0;    ///< GPS status not 'A'
    std::uint64_t bias_changes = 0;
    std::uint64_t packets_dropped_unconfirmed = 0;  ///< isolated GPS time jumps not confirmed
    std::uint64_t gps_jumps_confirmed = 0;          ///< GPS time jumps confirmed by the next packet
    std::uint64_t pc_clock_steps = 0;               ///< PcPacketClock::steps()
    double last_pc_clock_step_s = 0.0;              ///< PcPacketClock::last_step_s(), s
    bool have_packet = false;
    Lemi025Packet last;                       ///< newest packet (readings not used)
    std::string time_source = "none yet";
    double last_stamp_s = 0.0;                ///< last published reading stamp, s
    double last_bias_change_wall_s = -1.0;    ///< wall s of the newest bias change
    std::string last_bias_change;             ///< "old -> new nT at <time>"
    std::string last_warning;
  };

  /// A GPS-stamped packet held until the next packet confirms its time (see the file comment).
  struct HeldPacket {
    Lemi025Packet packet;
    double arrival_s = 0.0;      ///< PC (ROS) time of its arrival, s
    double recorded_pc_s = 0.0;  ///< LemiBin PC time, s, or NaN
    std::uint64_t slots = 0;     ///< packets received after it
  };

  // Port handling (lemi025_driver_port.cpp).
  /// Opens the source ~source names into source_ (a serial port that is absent is retried by
  /// the source; a recording that cannot be read throws ParameterError naming ~file).
  void open_source();
  /// The reading thread: waits on the source, logs disconnections and reconnections, publishes.
  void run();
  /// Recordings with ~wait_for_subscribers: blocks the reading thread until magnetic_field has
  /// that many subscribers; false when the node stops first.
  bool wait_for_subscribers();
  bool pace(std::uint64_t index);
  // Packet timing (lemi025_driver_timing.cpp).
  /// Every packet from the source: GPS-time screening, then publish_packet (or hold / drop).
  void handle(const Lemi025Packet& packet, double arrival_s, double recorded_pc_s);
  /// Publishes a GPS-stamped packet and makes its GPS second the reference.
  void accept_gps(const Lemi025Packet& packet, double arrival_s, double recorded_pc_s);
  /// Drops the `count` oldest held packets (unconfirmed outliers), counts them and says why.
  void drop_held(std::size_t count, const std::string& why);
  /// End of a recording: the held packets are published (no later packet can confirm them).
  void release_held();
  /// Stamps and publishes the packet's readings and temperatures, updates the diagnostics state.
  void publish_packet(const Lemi025Packet& packet, double arrival_s, double recorded_pc_s);
  // Diagnostics (lemi025_driver_diagnostics.cpp).
  /// Adds the "packet rate", "link" and "instrument" tasks and starts their timer.
  void setup_diagnostics();
  void diagnose_link(diagnostic_updater::DiagnosticStatusWrapper& status);
  void diagnose_instrument(diagnostic_updater::DiagnosticStatusWrapper& status);

  ros::NodeHandle nh_, private_nh_;
  Lemi025DriverSettings settings_;
  std::string node_name_;
  std::unique_ptr<PacketSource> source_;
  const LemiBinPacketSource* lemibin_ = nullptr;  ///< source_ when it is a LemiBin file
  std::string description_;

  ros::Publisher field_publisher_, sensor_temperature_publisher_, electronics_temperature_publisher_;
  diagnostic_updater::Updater updater_;
  double min_frequency_ = 0.0, max_frequency_ = 0.0;
  std::unique_ptr<diagnostic_updater::FrequencyStatus> frequency_;
  ros::WallTimer diagnostic_timer_;

  // Reading thread only.
  PcPacketClock pc_clock_;
  bool have_published_ = false;
  ros::Time last_published_;
  double last_temperature_s_ = 0.0;
  bool dropping_ = false;
  std::uint64_t packet_index_ = 0;
  bool have_gps_reference_ = false;
  double gps_reference_s_ = 0.0;           ///< GPS second of the newest packet accepted on GPS time, UNIX s
  std::uint64_t slots_since_reference_ = 0;  ///< packets received after it (held, dropped, non-GPS)
  std::deque<HeldPacket> held_;            ///< oldest first, at most 3
  std::chrono::steady_clock::time_point pace_start_;  ///< wall time of the first replayed packet

  std::mutex mutex_;
  State state_;
  std::uint64_t reported_checksum_ = 0, reported_resyncs_ = 0, reported_time_jumps_ = 0,
                reported_disconnects_ = 0, reported_dropped_ = 0, reported_unconfirmed_ = 0,
                reported_pc_steps_ = 0;  ///< diagnostics thread only

  std::mutex stop_mutex_;
  std::condition_variable stop_cv_;
  std::atomic<bool> stopping_{false};
  std::thread reader_;
};

}  // namespace magnetometer_insitu_calibration
