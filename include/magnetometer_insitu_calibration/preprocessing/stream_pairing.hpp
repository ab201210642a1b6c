// Live pairing of a reference and a test magnetometer stream by time stamp (core of the live
// calibration node; ROS-free).
#pragma once

#include <Eigen/Core>

#include <cstddef>
#include <deque>
#include <vector>

namespace magnetometer_insitu_calibration {

/// One reference and one test reading taken at (nearly) the same time.
struct PairedSample {
  double time_s = 0.0;             ///< UNIX seconds (UTC), the reference stamp
  Eigen::Vector3d reference_nT;    ///< reference frame, nT (NaN passed through)
  Eigen::Vector3d test_nT;         ///< test frame, nT (NaN passed through)
};

struct PairingCounters {
  std::size_t paired = 0;              ///< pairs emitted
  std::size_t unpaired_reference = 0;  ///< reference samples dropped without a partner
  std::size_t unpaired_test = 0;       ///< test samples dropped without a partner
  /// older than the newest sample of the same stream already emitted or dropped
  std::size_t late = 0;
  /// stamp equal to a pending one, or to the newest emitted or dropped one, of the same stream
  std::size_t duplicates = 0;
  /// non-finite stamp, or a stamp from the future: more than max_wait_s ahead of the sample
  /// that follows it on the same stream (discarded then)
  std::size_t invalid = 0;
};

/// Pairs the two streams with the rule of align_by_time applied to the samples still pending
/// (nearest neighbours both ways, ties to the earlier sample, within tolerance_s; output time =
/// reference stamp), deciding as soon as the data allow:
///  * the oldest pending reference r and test s are compared; a sample more than tolerance_s
///    older than the other's oldest can no longer pair and is dropped (unpaired);
///  * when |r - s| <= tolerance_s the pair is emitted once neither the next reference can be
///    closer to s nor the next test closer to r; if that next sample has not arrived yet the
///    pair waits for it;
///  * a sample waits at most max_wait_s, measured in stamp time against the newest stamp
///    received on either stream: then it is paired with the partner it has (if within
///    tolerance) or dropped as unpaired. Memory therefore stays bounded (about max_wait_s
///    times the sample rate per stream) when one stream is silent.
/// Pairs come out in increasing time. Samples may arrive slightly out of order within a
/// stream; one older than that stream's last emitted or dropped stamp is dropped as late.
/// A stamp far in the future (a clock glitch) ages every pending sample at once, so what is
/// pending is decided then; when the next sample of that stream comes more than max_wait_s
/// earlier, the future sample is discarded (counted invalid) and pairing goes on normally.
class StreamPairer {
 public:
  /// Throws InputError for a negative or non-finite tolerance_s or max_wait_s.
  StreamPairer(double tolerance_s, double max_wait_s);

  void push_reference(double time_s, const Eigen::Vector3d& value_nT);
  void push_test(double time_s, const Eigen::Vector3d& value_nT);

  /// The pairs decided since the last call, in time order.
  std::vector<PairedSample> take_pairs();

  /// Decides everything pending now (end of data): pairs what can pair, drops the rest.
  void flush();

  /// Forgets pending samples, pairs not yet taken, stamps seen and counters.
  void reset();

  const PairingCounters& counters() const { return counters_; }
  std::size_t pending_reference() const { return reference_.pending.size(); }
  std::size_t pending_test() const { return test_.pending.size(); }
  double tolerance_s() const { return tolerance_s_; }
  double max_wait_s() const { return max_wait_s_; }

 private:
  struct Sample {
    double time_s;
    Eigen::Vector3d value_nT;
  };
  struct Stream {
    std::deque<Sample> pending;  ///< sorted by time
    bool decided_any = false;
    double last_decided_s = 0.0;  ///< stamp of the newest sample emitted or dropped
  };

  void push(Stream& stream, double time_s, const Eigen::Vector3d& value_nT);
  void drop_front(Stream& stream, std::size_t& counter);
  void match(bool force);
  bool aged(double time_s) const;

  double tolerance_s_;
  double max_wait_s_;
  Stream reference_;
  Stream test_;
  bool seen_any_ = false;
  double newest_s_ = 0.0;  ///< newest stamp received on either stream
  std::vector<PairedSample> ready_;
  PairingCounters counters_;
};

}  // namespace magnetometer_insitu_calibration
