// The live window against the offline path on the same samples (station_offline_window.hpp).
#include "station_offline_window.hpp"

#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/ros/calibration_node.hpp"

#include <ros/ros.h>

#include <algorithm>
#include <cmath>

namespace station_rostest {

namespace mic = magnetometer_insitu_calibration;

namespace {

/// The samples of `by_stamp` within [first_s, last_s] as a record named `source`.
mic::VectorRecord record_of(const std::map<std::uint64_t, Eigen::Vector3d>& by_stamp, double first_s, double last_s,
                            const std::string& source) {
  mic::VectorRecord r;
  r.source = source;
  const auto begin = by_stamp.lower_bound(static_cast<std::uint64_t>(std::llround(first_s * 1e9)));
  const auto end = by_stamp.upper_bound(static_cast<std::uint64_t>(std::llround(last_s * 1e9)));
  r.values_nT.resize(static_cast<Eigen::Index>(std::distance(begin, end)), 3);
  Eigen::Index row = 0;
  for (auto it = begin; it != end; ++it, ++row) {
    r.time_s.push_back(1e-9 * static_cast<double>(it->first));
    r.values_nT.row(row) = it->second.transpose();
  }
  return r;
}

}  // namespace

mic::PreprocessSettings preprocess_of(const mic::LiveStreamSettings& streams) {
  mic::PreprocessSettings p;
  p.pairing_tolerance_s = streams.pairing_tolerance_s;
  p.despike = streams.despike;
  p.despike_settings = streams.despike_settings;
  p.output_period_s = streams.estimation_period_s();
  p.temperature_channel = "none";
  return p;
}

OfflineComparison compare_with_offline(const mic::MagnetometerCalibration& live, const std::string& node_name,
                                       const std::map<std::uint64_t, Eigen::Vector3d>& reference,
                                       const std::map<std::uint64_t, Eigen::Vector3d>& test, double margin_s) {
  OfflineComparison out;
  const double start_s = live.window_start.toSec(), end_s = live.window_end.toSec();
  for (const auto* r : {&reference, &test}) {
    if (r->empty() || 1e-9 * static_cast<double>(r->begin()->first) > start_s - margin_s ||
        1e-9 * static_cast<double>(r->rbegin()->first) < end_s + margin_s) {
      out.why_not = "the test's records do not reach " + std::to_string(margin_s) + " s beyond the window";
      return out;
    }
  }
  const mic::CalibrationNodeSettings settings = mic::CalibrationNodeSettings::load(ros::NodeHandle(node_name));
  const double first_s = start_s - margin_s, last_s = end_s + margin_s;
  const mic::PreparedPair prepared = mic::prepare_pair(record_of(reference, first_s, last_s, "reference"),
                                                       record_of(test, first_s, last_s, "test"),
                                                       preprocess_of(settings.streams));
  const auto& grid = prepared.paired.time_s;
  const auto at = std::lower_bound(grid.begin(), grid.end(), start_s - 0.25 * prepared.sample_period_s);
  if (at == grid.end() || std::abs(*at - start_s) > 0.25 * prepared.sample_period_s) {
    out.why_not = "the offline grid has no epoch at the window's start " + mic::format_iso8601(start_s, 3);
    return out;
  }
  const auto count = static_cast<std::size_t>(std::llround((end_s - start_s) / prepared.sample_period_s)) + 1;
  mic::WindowCalibrator calibrator(settings.window);
  const mic::CalibrationWindow offline = calibrator.calibrate(
      mic::window_records(prepared, static_cast<std::size_t>(at - grid.begin()), count, settings.streams.temperature_margin_s));
  out.samples = offline.estimate.samples;
  out.filled = offline.missing();
  if (out.samples != live.samples || out.filled != live.filled_samples) {
    out.why_not = "the node held other samples than the test received (offline " + std::to_string(out.samples) +
                  " samples, " + std::to_string(out.filled) + " without data; live " + std::to_string(live.samples) +
                  ", " + std::to_string(live.filled_samples) + ")";
    return out;
  }
  out.comparable = true;
  for (int k = 0; k < 9; ++k) {
    out.largest_difference = std::max(out.largest_difference,
                                      std::abs(live.matrix[static_cast<std::size_t>(k)] - offline.estimate.n(k / 3, k % 3)));
  }
  return out;
}

}  // namespace station_rostest
