// Bag input for command-line programs: --bag FILE --reference-topic T --test-topic T as an
// alternative to --reference FILE --test FILE (calibrate_records).
#pragma once

#include "magnetometer_insitu_calibration/pipeline/calibration_report.hpp"
#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <CLI/CLI.hpp>

#include <string>
#include <utility>
#include <vector>

namespace magnetometer_insitu_calibration {

class BagInputOptions {
 public:
  /// Adds --bag, --reference-topic and --test-topic to `app`; `reference` and `test` (the file
  /// options) stop being required, and exclude --bag.
  BagInputOptions(CLI::App& app, CLI::Option* reference, CLI::Option* test);

  /// After parsing: the reference and test records, from the files (read_record: IAGA-2002,
  /// CSV, LEMI formats) or from the bag's two topics in one pass (read_bag_records). Warnings
  /// (LEMI records skipped, bag messages reordered) go to stderr. Throws InputError("--reference", ...) when neither
  /// the files nor the bag are given.
  std::pair<VectorRecord, VectorRecord> records(const std::string& reference_path, const std::string& test_path) const;
  /// The same with several files per instrument (daily files), each side joined in time order
  /// by read_records (record_join.hpp); overlaps between files are reported on stderr.
  std::pair<VectorRecord, VectorRecord> records(const std::vector<std::string>& reference_paths,
                                                const std::vector<std::string>& test_paths) const;

  /// Names of the inputs for the report: the files (several joined by " + ", and listed one by
  /// one), or "<bag>:<topic>" with the frames of the records read from the bag.
  ReportInputs inputs(const std::vector<std::string>& reference_paths, const std::vector<std::string>& test_paths,
                      const VectorRecord& reference, const VectorRecord& test) const;

  bool from_bag() const { return !bag_.empty(); }

  /// Adds --remote-topic (a remote observatory's MagneticField topic in --bag); call once.
  void add_remote_topic(CLI::App& app, CLI::Option* remote_files);
  /// The remote's record from the bag; false when no --remote-topic was given.
  bool remote(VectorRecord& out) const;
  /// "<bag>:<topic>" of the remote, "" without one.
  std::string remote_input() const;

 private:
  /// The names alone: the joined files, or "<bag>:<topic>".
  ReportInputs inputs(const std::string& reference_path, const std::string& test_path) const;
  std::string bag_, reference_topic_, test_topic_, remote_topic_;
  CLI::Option* bag_option_ = nullptr;
};

}  // namespace magnetometer_insitu_calibration
