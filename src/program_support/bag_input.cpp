// Bag input for command-line programs; see bag_input.hpp.
#include "bag_input.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/record_file.hpp"
#include "magnetometer_insitu_calibration/formats/record_join.hpp"
#include "bag_records.hpp"
#include "command_line.hpp"  // print_warnings

#include <cmath>
#include <iostream>
#include <limits>

namespace magnetometer_insitu_calibration {

namespace {

/// The test's sensor temperature from the bag, if it has one beside the field topic
/// ("/ns/magnetic_field" -> "/ns/temperature/sensor", as the live driver publishes it and
/// records_to_bag writes it, or "/ns/sensor_temperature", records_to_bag's name for it in bags
/// written before), attached to the record as the
/// auxiliary channel "sensor_temperature": each sample takes the latest reading at or before
/// it, not older than 2 s (a LEMI packet's temperature belongs to its ten readings, as the LEMI
/// file readers attach it), NaN otherwise.
void attach_bag_temperature(const std::string& bag, const std::string& field_topic, VectorRecord& record) {
  for (const std::string& name :
       {bag_sibling_topic(field_topic, "sensor_temperature"), bag_sibling_topic(field_topic, "temperature/sensor")}) {
    BagTemperatureStream t;
    try {
      t = read_bag_temperatures(bag, name);
    } catch (const InputError&) {
      continue;  // no such topic (or not sensor_msgs/Temperature): no temperature from it
    }
    if (t.time_s.empty()) continue;
    AuxiliaryChannel channel{"sensor_temperature", "T_sensor (" + name + ")", "degC", {}};
    channel.values.reserve(record.size());
    std::size_t k = 0;
    for (double time : record.time_s) {
      while (k + 1 < t.time_s.size() && t.time_s[k + 1] <= time + 1e-6) ++k;
      const bool usable = t.time_s[k] <= time + 1e-6 && time - t.time_s[k] <= 2.0;
      channel.values.push_back(usable ? t.celsius[k] : std::numeric_limits<double>::quiet_NaN());
    }
    record.auxiliary.push_back(std::move(channel));
    return;
  }
}

}  // namespace

BagInputOptions::BagInputOptions(CLI::App& app, CLI::Option* reference, CLI::Option* test) {
  reference->required(false);
  test->required(false);
  auto* bag = app.add_option("--bag", bag_,
                             "rosbag with sensor_msgs/MagneticField (tesla) on --reference-topic and --test-topic, "
                             "instead of --reference and --test");
  auto* reference_topic = app.add_option("--reference-topic", reference_topic_, "reference topic in --bag");
  auto* test_topic = app.add_option("--test-topic", test_topic_, "test topic in --bag");
  bag->excludes(reference)->excludes(test)->needs(reference_topic)->needs(test_topic);
  reference_topic->needs(bag);
  test_topic->needs(bag);
  bag_option_ = bag;
}

void BagInputOptions::add_remote_topic(CLI::App& app, CLI::Option* remote_files) {
  app.add_option("--remote-topic", remote_topic_,
                 "a remote observatory's MagneticField topic in --bag (any frame), instead of --remote files")
      ->needs(bag_option_)
      ->excludes(remote_files);
}

bool BagInputOptions::remote(VectorRecord& out) const {
  if (remote_topic_.empty()) return false;
  std::vector<std::string> warnings;
  out = std::move(read_bag_records(bag_, {remote_topic_}, &warnings).front());
  out.station = bag_topic_name(remote_topic_);  // names it in the windows' texts
  print_warnings("calibrate_records", warnings);
  return true;
}

std::string BagInputOptions::remote_input() const {
  return remote_topic_.empty() ? std::string() : bag_ + ":" + bag_topic_name(remote_topic_);
}

std::pair<VectorRecord, VectorRecord> BagInputOptions::records(const std::string& reference_path,
                                                               const std::string& test_path) const {
  if (bag_.empty()) {
    if (reference_path.empty() || test_path.empty()) {
      throw InputError(reference_path.empty() ? "--reference" : "--test",
                       "is required (or --bag FILE with --reference-topic and --test-topic)");
    }
    std::vector<std::string> warnings;  // LEMI formats: damaged records skipped, with their offsets
    std::pair<VectorRecord, VectorRecord> out{read_record(reference_path, LemiReadOptions(), &warnings),
                                              read_record(test_path, LemiReadOptions(), &warnings)};
    print_warnings("calibrate_records", warnings);
    return out;
  }
  std::vector<std::string> warnings;
  std::vector<VectorRecord> records = read_bag_records(bag_, {reference_topic_, test_topic_}, &warnings);
  print_warnings("calibrate_records", warnings);
  attach_bag_temperature(bag_, test_topic_, records[1]);
  return {std::move(records[0]), std::move(records[1])};
}

std::pair<VectorRecord, VectorRecord> BagInputOptions::records(const std::vector<std::string>& reference_paths,
                                                               const std::vector<std::string>& test_paths) const {
  if (!bag_.empty() || (reference_paths.size() <= 1 && test_paths.size() <= 1)) {
    return records(reference_paths.empty() ? std::string() : reference_paths.front(),
                   test_paths.empty() ? std::string() : test_paths.front());
  }
  if (reference_paths.empty() || test_paths.empty()) {
    throw InputError(reference_paths.empty() ? "--reference" : "--test", "is required");
  }
  std::vector<std::string> warnings;
  std::pair<VectorRecord, VectorRecord> out{read_records(reference_paths, &warnings), read_records(test_paths, &warnings)};
  print_warnings("calibrate_records", warnings);
  return out;
}

namespace {
std::string joined(const std::vector<std::string>& paths) {
  std::string out;
  for (const std::string& p : paths) out += (out.empty() ? "" : " + ") + p;
  return out;
}
}  // namespace

ReportInputs BagInputOptions::inputs(const std::vector<std::string>& reference_paths,
                                     const std::vector<std::string>& test_paths, const VectorRecord& reference,
                                     const VectorRecord& test) const {
  ReportInputs out = inputs(joined(reference_paths), joined(test_paths));
  if (bag_.empty()) {
    out.reference_files = reference_paths;
    out.test_files = test_paths;
  } else {  // a MagneticField's identity: its frame (export_corrected checks it)
    out.reference_frame_id = bag_frame_id(reference);
    out.test_frame_id = bag_frame_id(test);
  }
  return out;
}

ReportInputs BagInputOptions::inputs(const std::string& reference_path, const std::string& test_path) const {
  ReportInputs out;
  out.reference = reference_path;
  out.test = test_path;
  if (bag_.empty()) return out;
  out.reference = bag_ + ":" + bag_topic_name(reference_topic_);
  out.test = bag_ + ":" + bag_topic_name(test_topic_);
  // A MagneticField names no components: the report claims none (export_corrected then has none
  // to check against a file of the instrument; it checks a bag's frame_id instead).
  out.components_named = false;
  return out;
}

}  // namespace magnetometer_insitu_calibration
