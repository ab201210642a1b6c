// Magnetometer records in rosbags, through the rosbag C++ API (no master, no ros::init):
// VectorRecords written as sensor_msgs/MagneticField (and LEMI temperatures as
// sensor_msgs/Temperature), and read back into VectorRecords.
//
// Messages: header.stamp = the record's time (ROS time = UNIX s), bag time = header.stamp, so
// that `rosbag play --clock` replays the data's own time; header.frame_id from the options;
// magnetic_field in tesla (x, y, z = the record's three components, in its instrument frame);
// magnetic_field_covariance all zero ("unknown", REP 145). A missing reading (NaN) is written
// as a message with NaN fields, so that gaps survive the round trip.
//
// Round trip record -> bag -> record: times are exact (a stamp has 1 ns resolution, finer than
// a double at 1.7e9 s); values come back within one unit in the last place (tesla = nT / 1e9 and
// back by * 1e9, as calibration_node converts: not every nT double has a tesla double that maps
// back onto it).
#pragma once

#include "magnetometer_insitu_calibration/common/vector_record.hpp"

#include <cstddef>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace magnetometer_insitu_calibration {

/// One instrument's field record and where it goes in the bag.
struct BagFieldStream {
  std::string topic;                    ///< sensor_msgs/MagneticField topic
  std::string frame_id;                 ///< header.frame_id
  const VectorRecord* record = nullptr; ///< nT, UNIX s
};

/// A scalar temperature series (sensor_msgs/Temperature, deg C, variance 0 = unknown).
struct BagTemperatureStream {
  std::string topic;
  std::string frame_id;
  std::vector<double> time_s;   ///< UNIX s, strictly increasing
  std::vector<double> celsius;  ///< deg C
};

enum class BagCompression { kNone, kBz2, kLz4 };
/// Parses "none", "bz2", "lz4"; throws InputError(where, ...) otherwise.
BagCompression parse_bag_compression(const std::string& text, const std::string& where);

/// Normalises a topic name as a bag stores it: a leading '/' is added when missing.
std::string bag_topic_name(const std::string& topic);

/// A topic next to a field topic, as records_to_bag names the temperatures:
/// "/ns/magnetic_field" -> "/ns/<name>"; a top-level "/mag" -> "/mag_<name>".
std::string bag_sibling_topic(const std::string& field_topic, const std::string& name);

struct BagWriteSummary {
  std::size_t messages = 0;
  std::map<std::string, std::size_t> per_topic;
};

/// Writes every stream into a new bag at `path` (replaced if it exists), all messages merged
/// in stamp order. `progress(done, total)` is called every ~1 % of the messages.
/// Throws InputError naming the record (source) for a time that cannot be a ROS stamp, the
/// topic for a topic used twice, and the bag for a file that cannot be written.
BagWriteSummary write_records_bag(const std::string& path, const std::vector<BagFieldStream>& fields,
                                  const std::vector<BagTemperatureStream>& temperatures,
                                  BagCompression compression = BagCompression::kNone,
                                  const std::function<void(std::size_t, std::size_t)>& progress = {});

/// Reads the sensor_msgs/MagneticField messages of each topic in one pass over the bag
/// (rosbag::View over those topics), in the order of `topics`. Each record: time_s =
/// header.stamp, values in nT (tesla * 1e9), components "X", "Y", "Z", source
/// "<bag>:<topic>", header["frame_id"] (of the first message), header["topic"],
/// header["format"] = "rosbag sensor_msgs/MagneticField". Messages out of stamp order are
/// sorted and repeated stamps dropped (the first kept), each reported in *warnings.
/// Throws InputError(path, ...) when the bag cannot be opened, a topic is missing (the message
/// lists the bag's topics and types) or holds another message type.
std::vector<VectorRecord> read_bag_records(const std::string& path, const std::vector<std::string>& topics,
                                           std::vector<std::string>* warnings = nullptr);

/// The frame_id read_bag_records gave a record (its instrument's identity); "" for a record
/// that did not come from a bag.
std::string bag_frame_id(const VectorRecord& record);

/// Reads a sensor_msgs/Temperature topic (tests, plots). Throws InputError as above.
BagTemperatureStream read_bag_temperatures(const std::string& path, const std::string& topic);

/// Topics and message types of a bag, sorted by topic. Throws InputError(path, ...).
std::vector<std::pair<std::string, std::string>> bag_topics(const std::string& path);

}  // namespace magnetometer_insitu_calibration
