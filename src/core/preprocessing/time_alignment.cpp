#include "magnetometer_insitu_calibration/preprocessing/time_alignment.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"

#include <cmath>
#include <cstdint>
#include <sstream>
#include <string>

namespace magnetometer_insitu_calibration {
namespace {

std::string source_name(const VectorRecord& record, const char* fallback) {
  return record.source.empty() ? std::string(fallback) : record.source;
}

/// Indices of the samples kept (first of each run of equal stamps). Throws on a stamp that is
/// not finite or goes backwards.
std::vector<std::size_t> checked_unique_indices(const VectorRecord& record, const char* fallback,
                                                std::size_t& duplicates) {
  const std::string where = source_name(record, fallback);
  if (static_cast<std::size_t>(record.values_nT.rows()) != record.time_s.size()) {
    throw InputError(where, "has " + std::to_string(record.time_s.size()) + " times but " +
                                std::to_string(record.values_nT.rows()) + " rows of values");
  }
  std::vector<std::size_t> kept;
  kept.reserve(record.time_s.size());
  for (std::size_t i = 0; i < record.time_s.size(); ++i) {
    const double t = record.time_s[i];
    if (!std::isfinite(t)) {
      throw InputError(where, "time stamp of sample " + std::to_string(i) + " is not finite");
    }
    if (!kept.empty()) {
      const double previous = record.time_s[kept.back()];
      if (t == previous) {
        ++duplicates;
        continue;
      }
      if (t < previous) {
        std::ostringstream text;
        text.precision(15);
        text << "time goes backwards at sample " << i << " (" << t << " s after " << previous
             << " s)";
        throw InputError(where, text.str());
      }
    }
    kept.push_back(i);
  }
  return kept;
}

/// For every a[i], the index into b of the nearest b (ties: the earlier). a, b increasing.
std::vector<std::size_t> nearest_indices(const std::vector<double>& a, const std::vector<double>& b) {
  std::vector<std::size_t> nearest(a.size(), 0);
  std::size_t j = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    // Advance while the next b is strictly closer to a[i].
    while (j + 1 < b.size() && std::abs(b[j + 1] - a[i]) < std::abs(b[j] - a[i])) ++j;
    nearest[i] = j;
  }
  return nearest;
}

/// "<source> spans <first> to <last>" (ISO 8601 UTC), or "<source> has no sample".
std::string span_text(const VectorRecord& record) {
  if (record.empty()) return record.source + " has no sample";
  return record.source + " spans " + time_for_message(record.time_s.front()) + " to " +
         time_for_message(record.time_s.back());
}

/// Why no sample paired: the records' spans do not overlap, or their stamps are too far apart.
std::string no_pair_problem(const VectorRecord& reference, const VectorRecord& test, double tolerance_s) {
  const std::string spans = "reference " + span_text(reference) + ", test " + span_text(test);
  const bool disjoint = reference.empty() || test.empty() || reference.time_s.back() < test.time_s.front() ||
                        test.time_s.back() < reference.time_s.front();
  if (disjoint) return "records do not overlap in time: " + spans;
  std::ostringstream text;
  text << "no reference and test stamps within the pairing tolerance of " << tolerance_s << " s of each other: " << spans;
  return text.str();
}

}  // namespace

PairedRecord align_by_time(const VectorRecord& reference, const VectorRecord& test,
                           double tolerance_s) {
  if (!std::isfinite(tolerance_s) || tolerance_s < 0.0) {
    throw InputError("tolerance_s", "must be >= 0 and finite");
  }
  PairedRecord out;
  const std::vector<std::size_t> ref_rows =
      checked_unique_indices(reference, "--reference", out.duplicates);
  const std::vector<std::size_t> test_rows = checked_unique_indices(test, "--test", out.duplicates);

  std::vector<double> ref_t(ref_rows.size()), test_t(test_rows.size());
  for (std::size_t i = 0; i < ref_rows.size(); ++i) ref_t[i] = reference.time_s[ref_rows[i]];
  for (std::size_t j = 0; j < test_rows.size(); ++j) test_t[j] = test.time_s[test_rows[j]];

  std::vector<std::pair<std::size_t, std::size_t>> pairs;  // rows in reference, test
  if (!ref_t.empty() && !test_t.empty()) {
    const std::vector<std::size_t> test_of_ref = nearest_indices(ref_t, test_t);
    const std::vector<std::size_t> ref_of_test = nearest_indices(test_t, ref_t);
    for (std::size_t i = 0; i < ref_t.size(); ++i) {
      const std::size_t j = test_of_ref[i];
      if (ref_of_test[j] == i && std::abs(test_t[j] - ref_t[i]) <= tolerance_s) {
        pairs.emplace_back(ref_rows[i], test_rows[j]);
      }
    }
  }
  if (pairs.empty()) throw InputError("--reference/--test", no_pair_problem(reference, test, tolerance_s));

  const auto n = static_cast<Eigen::Index>(pairs.size());
  out.time_s.resize(pairs.size());
  out.reference_nT.resize(n, 3);
  out.test_nT.resize(n, 3);
  for (Eigen::Index k = 0; k < n; ++k) {
    const auto [i, j] = pairs[static_cast<std::size_t>(k)];
    out.time_s[static_cast<std::size_t>(k)] = reference.time_s[i];
    out.reference_nT.row(k) = reference.values_nT.row(static_cast<Eigen::Index>(i));
    out.test_nT.row(k) = test.values_nT.row(static_cast<Eigen::Index>(j));
  }
  out.unpaired_reference = ref_rows.size() - pairs.size();
  out.unpaired_test = test_rows.size() - pairs.size();
  return out;
}

}  // namespace magnetometer_insitu_calibration
