// Pairing of a reference and a test record by time stamp (merge-join of two sorted series).
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <cstddef>
#include <vector>

namespace magnetometer_insitu_calibration {

/// Samples of the reference and the test instrument taken at (nearly) the same time.
/// Row k of reference_nT and of test_nT belong to time_s[k]. Frames: each instrument's own.
struct PairedRecord {
  std::vector<double> time_s;     ///< UNIX seconds (UTC): the reference stamps, increasing
  Readings reference_nT;          ///< N x 3, nT, NaN = missing
  Readings test_nT;               ///< N x 3, nT, NaN = missing
  std::size_t unpaired_reference = 0;  ///< reference samples left without a test partner
  std::size_t unpaired_test = 0;       ///< test samples left without a reference partner
  std::size_t duplicates = 0;          ///< samples dropped because their stamp repeated (both records)

  std::size_t size() const { return time_s.size(); }
};

/// Pairs reference sample i with test sample j when each is the other's nearest neighbour in
/// time (ties go to the earlier sample) and |t_test[j] - t_ref[i]| <= tolerance_s. Each sample
/// is used at most once; the output time is the reference stamp. Values are copied as they are
/// (NaN stays NaN). Runs in O(N_ref + N_test).
///
/// A stamp equal to the previous stamp of the same record is a duplicate: the later sample is
/// dropped and counted in `duplicates`. All other samples count either as paired or as
/// unpaired_reference / unpaired_test, including those outside the common time span.
///
/// Throws InputError(record.source, ...) naming the sample index when a record's stamps go
/// backwards or are not finite; InputError("tolerance_s", ...) for a negative or non-finite
/// tolerance; InputError("--reference/--test", ...) when nothing pairs: "records do not overlap
/// in time: reference <source> spans <first> to <last>, test <source> spans ..." (ISO 8601 UTC),
/// or, spans overlapping, "no reference and test stamps within the pairing tolerance ..."
PairedRecord align_by_time(const VectorRecord& reference, const VectorRecord& test,
                           double tolerance_s = 0.010);

}  // namespace magnetometer_insitu_calibration
