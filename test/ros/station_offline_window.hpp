// Shared by the end-to-end station rostests (test_simulated_station.cpp) and the late remote's
// rostest (rostest_calibration_late_remote.cpp, preprocess_of): a live window of
// calibration_node against the offline path (prepare_pair, window_records, WindowCalibrator:
// what calibrate_records runs) on the drivers' samples the test recorded, with the node's own
// settings read from the parameter server. Units: nT, UNIX seconds.
#pragma once

#include "magnetometer_insitu_calibration/pipeline/calibration_pipeline.hpp"
#include "magnetometer_insitu_calibration/pipeline/live_streams.hpp"

#include <magnetometer_insitu_calibration/MagnetometerCalibration.h>

#include <Eigen/Core>

#include <cstdint>
#include <map>
#include <string>

namespace station_rostest {

/// The offline pre-processing (calibrate_records') with a node's stream settings: pairing,
/// despiking, periods; no temperature channel.
magnetometer_insitu_calibration::PreprocessSettings preprocess_of(
    const magnetometer_insitu_calibration::LiveStreamSettings& streams);

/// How a live window compared with the offline path.
struct OfflineComparison {
  bool comparable = false;    ///< the test's records cover the window and hold what the node held
  std::string why_not;        ///< when not comparable: what is missing
  double largest_difference = 0.0;  ///< max |n_live - n_offline| over the nine entries
  std::size_t samples = 0, filled = 0;  ///< the offline window's samples and epochs without data
};

/// Compares the live window `live` of the node `node_name` (its private parameters give the
/// settings) with the offline path on `reference` and `test` (raw driver samples by stamp in ns,
/// nT). Comparable only when the records reach `margin_s` beyond the window on both sides and
/// the offline window counts the samples and gaps the message does (the test received every
/// sample the node did).
OfflineComparison compare_with_offline(const magnetometer_insitu_calibration::MagnetometerCalibration& live,
                                       const std::string& node_name,
                                       const std::map<std::uint64_t, Eigen::Vector3d>& reference,
                                       const std::map<std::uint64_t, Eigen::Vector3d>& test, double margin_s = 60.0);

}  // namespace station_rostest
