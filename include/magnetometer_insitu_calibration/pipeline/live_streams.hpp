// The live streams of one reference and one or more test instruments, from arriving samples to
// the windows the per-window stage calibrates: what calibration_node does between a message and
// its worker, without ROS.
//
// Per stream, in the order the offline pipeline applies the same steps to a whole record
// (calibration_pipeline.hpp), so that a live window equals the offline window of the same
// samples:
//   sample -> StreamingDespiker (each instrument at its own rate; optional)
//          -> StreamPairer (reference and test paired by stamp)
//          -> StreamingDecimator, both on the same epochs (when the inputs are faster than the
//             estimation period)
//          (streams of two rates, or stamped at two phases: each through its StreamingDecimator
//             onto the estimation epochs first, then the StreamPairer; plan_epochs decides, as
//             it does for calibrate_records)
//          -> SlidingWindowBuffer (windows [k step, k step + window) in UNIX time), with the
//             test's thermometer samples around each window (TemperatureBuffer)
//          -> CoincidentWindows (with two or more tests and the three-cornered hat: each window
//             released with another test's window of the same epochs as its third instrument).
// A remote observatory's stream (optional, at its own rate) comes onto the estimation epochs on
// its own, through a SideStream (side_stream.hpp: despiked, and through its own Gaussian FIR when
// the pair's rule filters it, as calibrate_records prepares --remote), from which every completed
// window takes the remote's samples of its epochs.
// An absolute scalar magnetometer's stream (optional) is kept at its own times (F is neither
// despiked, paired nor decimated: calibrate_records gives every window its --scalar record as
// read); every completed window takes the samples within kScalarMargin_s of its ends (the
// scalar check, pipeline/scalar_window.hpp, looks 60 s beyond them).
// Units: nT and UNIX seconds; each instrument in its own frame.
#pragma once

#include "magnetometer_insitu_calibration/common/scalar_record.hpp"
#include "magnetometer_insitu_calibration/pipeline/epoch_alignment.hpp"
#include "magnetometer_insitu_calibration/pipeline/live_windows.hpp"
#include "magnetometer_insitu_calibration/pipeline/side_stream.hpp"
#include "magnetometer_insitu_calibration/preprocessing/gaussian_decimation.hpp"
#include "magnetometer_insitu_calibration/preprocessing/stream_pairing.hpp"
#include "magnetometer_insitu_calibration/preprocessing/streaming_despike.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <deque>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace magnetometer_insitu_calibration {

/// A test instrument as the streams take it.
struct LiveTestInput {
  std::string name;            ///< names the instrument as a third ("test '<name>'")
  bool temperature = false;    ///< it has a thermometer
  double input_period_s = 0.0; ///< its nominal sample period, s; 0: LiveStreamSettings::test_period_s()
};

struct LiveStreamSettings {
  double input_period_s = 1.0;         ///< nominal sample period of the reference stream, s
  /// The tests' nominal period when it is not the reference's (a 10 Hz LEMI-025 beside a 1 s
  /// observatory stream), s; 0: input_period_s.
  double test_input_period_s = 0.0;
  /// The remote's nominal period when it is not the reference's (an observatory's 1 s stream
  /// beside a 10 Hz pair), s; 0: input_period_s.
  double remote_input_period_s = 0.0;
  /// The tests' and the remote's stamps fall at another phase of the period than the
  /// reference's (further off than pairing_tolerance_s): each stream is then low-passed onto
  /// the estimation epochs before pairing, as streams of two rates always are.
  bool stamps_apart = false;
  DecimationSettings decimation;       ///< output_period_s: the estimation period asked for, s
  double pairing_tolerance_s = 0.010;  ///< largest |t_test - t_reference| of a pair, s
  double pairing_max_wait_s = 600.0;   ///< longest wait (stamp time) for a partner, s
  /// How far past a window's end (the pair's stamps) the window waits for a late remote, s: a
  /// neighbouring observatory's daily files arrive hours after its samples were taken.
  double remote_max_wait_s = 21600.0;
  double window_s = 86400.0;           ///< window length, s
  double step_s = 3600.0;              ///< between window starts, s
  bool despike = true;                 ///< StreamingDespiker on every input stream
  DespikeSettings despike_settings;
  /// A step of the paired stamps (or of one filtered stream's) longer than this restarts the
  /// decimators, s.
  double time_jump_threshold_s = 60.0;
  /// Thermometer samples kept beyond each window's ends (the stage's temperature_max_gap_s), s.
  double temperature_margin_s = 60.0;

  double test_period_s() const { return test_input_period_s > 0.0 ? test_input_period_s : input_period_s; }
  double remote_period_s() const { return remote_input_period_s > 0.0 ? remote_input_period_s : input_period_s; }
  /// How a test's stream of period_s (0: test_period_s()) and the reference's come onto common
  /// epochs (plan_epochs).
  EpochPlan test_plan(double period_s = 0.0) const;
  /// How the remote's stream comes onto the estimation epochs (its SideStream; plan(): the
  /// rule for it and the reference's).
  SideStreamSettings remote_side() const;
  /// Sample period of the windows, s: every test's stream must give it (validate_test_period).
  double estimation_period_s() const { return test_plan().period_s; }
  /// The filter a window's pair went through with a test of period_s (0: test_period_s()), at the
  /// estimation period; none when paired by stamp at the input rate.
  std::optional<DecimationSettings> window_decimation(double period_s = 0.0) const;
  /// Throws InputError("input_period_s", ...) when a test of period_s cannot give the windows: a
  /// filter kernel shorter than its period, or pairs with the reference at another estimation
  /// period than estimation_period_s() (a test given its own period in a list of tests).
  void validate_test_period(double period_s) const;
  /// Throws InputError("input_period_s", ...) when tests[i] cannot give the windows: its own
  /// period (validate_test_period) or, for the three-cornered hat (`coincident`), a filter unlike
  /// tests[0]'s (the hat compares the tests' spectra above the band, where the filter's gain
  /// falls). LiveCalibrationStreams checks every test so; calibration_node names the entry.
  void validate_test(const std::vector<LiveTestInput>& tests, std::size_t i, bool coincident) const;
  /// Throws InputError naming the field when the streams cannot give windows: an impossible
  /// period, a filter kernel shorter than a stream's period, and (with a remote) a remote that
  /// comes onto the epochs at another estimation period than the tests' pairs.
  void validate(bool remote) const;
};

/// One test instrument's part of the streams (its pairing with the reference onwards).
struct LiveTestStream {
  LiveTestStream(const LiveTestInput& input, const LiveStreamSettings& settings);

  std::string name;              ///< names the instrument as a third ("test '<name>'")
  bool temperature = false;      ///< it has a thermometer
  double input_period_s;         ///< its nominal sample period, s
  StreamingDespiker despiker;
  EpochAlignment alignment;  ///< kEachFiltered: the decimators come before the pairer, else after it
  std::optional<DecimationSettings> decimation;  ///< the filter its windows' pair went through
  StreamPairer pairer;
  std::unique_ptr<StreamingDecimator> reference_decimator, test_decimator;  ///< unless kPairedStamps
  SlidingWindowBuffer windows;
  TemperatureBuffer thermometer;
  PairingCounters counters_before_reset;
  bool any_pair = false;
  double last_pair_s = 0.0;
  std::size_t pipeline_resets = 0;
  std::size_t decimator_restarts = 0;  ///< the decimators started again after a jump of the stamps

  /// Pairing counters since start, across restarts.
  PairingCounters counters() const;
};

/// An absolute scalar magnetometer's part of the streams: F (nT) at its own times, kept while the
/// windows still to complete need it.
struct LiveScalarStream {
  explicit LiveScalarStream(const std::string& name) : name(name) {}

  static constexpr double kMargin_s = 120.0;  ///< kept and copied beyond a window's ends, s
  std::string name;      ///< names the scalar in texts (its topic)
  std::deque<std::pair<double, double>> samples;  ///< (UNIX s, F nT), stamps strictly increasing
  std::size_t received = 0;
  std::size_t refused = 0;  ///< samples not after the last one, or with a non-finite stamp

  /// Appends a sample; false (counted in `refused`) when its stamp is not finite or not after the
  /// last one's. A non-finite F is kept: a gap, as in a record.
  bool push(double time_s, double value_nT);
  /// Its samples within [low_s, high_s], as a window's scalar record.
  std::shared_ptr<ScalarRecord> copy(double low_s, double high_s) const;
  /// Drops the samples before time_s.
  void drop_before(double time_s);
};

class LiveCalibrationStreams {
 public:
  /// `tests`: names, whether each has a thermometer, and a period of its own where given;
  /// `coincident`: release each window with another test's window of the same epochs (the
  /// three-cornered hat; two or more tests). Throws InputError for settings or a test's period
  /// that cannot give windows (LiveStreamSettings::validate, validate_test_period).
  LiveCalibrationStreams(const LiveStreamSettings& settings, const std::vector<LiveTestInput>& tests, bool coincident);

  /// A window completed by a sample, for the per-window stage.
  struct Completed {
    std::size_t test = 0;
    WindowRecords window;
    std::size_t third_test = 0;  ///< the test whose samples are window.third, when it is set
  };

  std::vector<Completed> push_reference(double time_s, const Eigen::Vector3d& value_nT);
  std::vector<Completed> push_test(std::size_t test, double time_s, const Eigen::Vector3d& value_nT);
  /// The test's thermometer, deg C (NaN: none in that message).
  void push_temperature(std::size_t test, double time_s, double value_C);
  /// A remote observatory's stream, named `name` in texts; call once, before any sample. Throws
  /// InputError when its period cannot give the windows' epochs (LiveStreamSettings::validate).
  void add_remote(const std::string& name);
  /// A remote sample (its own frame, nT); returns the windows that waited for it. A window the
  /// pair completes waits until the remote's samples reach its end, or until the pair is
  /// remote_max_wait_s (stamp time) past it: a remote that arrives after the pair fills the
  /// window as the offline --remote does; past the wait the window goes on with what the remote
  /// gave (WindowRecords::remote_late says so).
  std::vector<Completed> push_remote(double time_s, const Eigen::Vector3d& value_nT);
  /// The remote's stream on the estimation epochs, null without one.
  const SideStream* remote() const { return remote_.get(); }
  /// Windows the pair has completed that wait for the remote.
  std::size_t waiting_for_remote() const { return waiting_remote_.size(); }
  /// The epochs those windows hold (each its pair's record on the estimation epochs).
  std::size_t waiting_epochs() const {
    std::size_t epochs = 0;
    for (const Waiting& w : waiting_remote_) epochs += w.window.paired.time_s.size();
    return epochs;
  }
  /// An absolute scalar magnetometer's stream, named `name` in texts; call once, before any sample.
  void add_scalar(const std::string& name);
  /// A scalar sample (F, nT, at its own time); false when refused (LiveScalarStream::push).
  bool push_scalar(double time_s, double value_nT);
  /// The scalar's part, null without one.
  const LiveScalarStream* scalar() const { return scalar_.get(); }
  /// Restarts a test's pairing, decimation and windows (its stamps went back).
  void restart(std::size_t test);
  /// Restarts everything (the reference's stamps went back).
  void restart_all();

  const LiveStreamSettings& settings() const { return settings_; }
  const LiveTestStream& test(std::size_t i) const { return *tests_.at(i); }
  std::size_t tests() const { return tests_.size(); }
  std::size_t reference_spikes() const { return reference_despiker_.spikes(); }
  std::size_t coincident_pending() const { return coincident_ ? coincident_->pending() : 0; }

 private:
  void drain(std::size_t test, std::vector<Completed>& out);
  void drop_remote_epochs();
  void window_done(std::size_t test, WindowRecords&& window, std::vector<Completed>& out);
  void release_waiting(std::vector<Completed>& out);
  void finish_window(std::size_t test, WindowRecords&& window, std::vector<Completed>& out);

  /// Windows completed by the pair, waiting for the remote (push_remote).
  struct Waiting {
    std::size_t test = 0;
    WindowRecords window;
  };
  std::deque<Waiting> waiting_remote_;
  double newest_pair_s_ = -std::numeric_limits<double>::infinity();  ///< the newest stamp of the pair, s

  LiveStreamSettings settings_;
  StreamingDespiker reference_despiker_;
  std::vector<std::unique_ptr<LiveTestStream>> tests_;
  std::unique_ptr<CoincidentWindows> coincident_;
  std::unique_ptr<SideStream> remote_;
  std::string remote_name_;  ///< names the remote in texts (its topic)
  std::unique_ptr<LiveScalarStream> scalar_;
};

}  // namespace magnetometer_insitu_calibration
