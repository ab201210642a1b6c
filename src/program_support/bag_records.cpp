// Records in rosbags; see bag_records.hpp.
#include "bag_records.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/ros/si_units.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/MagneticField.h>
#include <sensor_msgs/Temperature.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <set>
#include <sstream>

namespace magnetometer_insitu_calibration {

namespace {

const std::string kMagneticFieldType = ros::message_traits::DataType<sensor_msgs::MagneticField>::value();
const std::string kTemperatureType = ros::message_traits::DataType<sensor_msgs::Temperature>::value();

ros::Time stamp_of(double time_s, const std::string& source) {
  // ros::Time holds unsigned 32-bit seconds; bags refuse time 0.
  if (!std::isfinite(time_s) || !(time_s >= 1e-9) || !(time_s < 4294967295.0)) {
    std::ostringstream text;
    text.precision(17);
    text << "time " << time_s << " s cannot be a ROS stamp (0 < t < 2^32 s)";
    throw InputError(source, text.str());
  }
  return ros::Time().fromSec(time_s);
}

void open_bag(rosbag::Bag& bag, const std::string& path, std::uint32_t mode) {
  try {
    bag.open(path, mode);
  } catch (const rosbag::BagException& e) {
    throw InputError(path, std::string(mode == rosbag::bagmode::Read ? "cannot open the bag: " : "cannot write the bag: ") +
                               e.what());
  }
}

std::string describe_topics(const std::vector<std::pair<std::string, std::string>>& topics) {
  if (topics.empty()) return "the bag holds no message";
  std::string text = "topics in the bag:";
  for (const auto& t : topics) text += " " + t.first + " (" + t.second + ")";
  return text;
}

std::vector<std::pair<std::string, std::string>> topics_of(rosbag::Bag& bag) {
  rosbag::View all(bag);
  std::set<std::pair<std::string, std::string>> unique;
  for (const rosbag::ConnectionInfo* c : all.getConnections()) unique.emplace(c->topic, c->datatype);
  return {unique.begin(), unique.end()};
}

/// Checks that each topic exists in the bag with `type`.
void check_topics(rosbag::Bag& bag, const std::string& path, const std::vector<std::string>& topics,
                  const std::string& type) {
  const auto present = topics_of(bag);
  for (const std::string& topic : topics) {
    bool found = false;
    for (const auto& p : present) {
      if (p.first != topic) continue;
      if (p.second != type) {
        throw InputError(path, "topic " + topic + " holds " + p.second + ", not " + type);
      }
      found = true;
    }
    if (!found) throw InputError(path, "no " + type + " message on topic " + topic + "; " + describe_topics(present));
  }
}

/// Sorts (stably) by time and drops repeated stamps; reports what it did.
template <typename Row>
void order_by_time(std::vector<double>& time_s, std::vector<Row>& rows, const std::string& what,
                   std::vector<std::string>* warnings) {
  bool sorted = true;
  for (std::size_t i = 1; i < time_s.size() && sorted; ++i) sorted = time_s[i] > time_s[i - 1];
  if (sorted) return;
  std::vector<std::size_t> order(time_s.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return time_s[a] < time_s[b]; });
  std::size_t moved = 0, dropped = 0;
  std::vector<double> t;
  std::vector<Row> r;
  t.reserve(order.size());
  r.reserve(order.size());
  for (std::size_t k = 0; k < order.size(); ++k) {
    moved += order[k] != k;
    if (!t.empty() && time_s[order[k]] == t.back()) {
      ++dropped;
      continue;
    }
    t.push_back(time_s[order[k]]);
    r.push_back(rows[order[k]]);
  }
  time_s.swap(t);
  rows.swap(r);
  if (warnings != nullptr) {
    warnings->push_back(what + ": messages out of stamp order were sorted (" + std::to_string(moved) +
                        " moved), " + std::to_string(dropped) + " with a repeated stamp dropped");
  }
}

}  // namespace

BagCompression parse_bag_compression(const std::string& text, const std::string& where) {
  if (text == "none") return BagCompression::kNone;
  if (text == "bz2") return BagCompression::kBz2;
  if (text == "lz4") return BagCompression::kLz4;
  throw InputError(where, "expected none, bz2 or lz4, got '" + text + "'");
}

std::string bag_topic_name(const std::string& topic) {
  return !topic.empty() && topic[0] != '/' ? "/" + topic : topic;
}

std::string bag_sibling_topic(const std::string& field_topic, const std::string& name) {
  const std::string topic = bag_topic_name(field_topic);
  const std::size_t slash = topic.rfind('/');
  if (slash == 0) return topic + "_" + name;
  return topic.substr(0, slash + 1) + name;
}

BagWriteSummary write_records_bag(const std::string& path, const std::vector<BagFieldStream>& fields,
                                  const std::vector<BagTemperatureStream>& temperatures, BagCompression compression,
                                  const std::function<void(std::size_t, std::size_t)>& progress) {
  // Every series as (times, topic); checked before the bag is created.
  struct Series {
    const std::vector<double>* time_s;
    std::string topic;
    std::size_t next = 0;
    std::uint32_t seq = 0;
  };
  std::vector<Series> series;
  std::set<std::string> topics;
  std::size_t total = 0;
  for (const BagFieldStream& f : fields) {
    if (f.record == nullptr) throw InputError(f.topic, "no record given");
    series.push_back({&f.record->time_s, bag_topic_name(f.topic)});
    if (f.record->values_nT.rows() != static_cast<Eigen::Index>(f.record->size())) {
      throw InputError(f.record->source, "record has " + std::to_string(f.record->size()) + " times but " +
                                             std::to_string(f.record->values_nT.rows()) + " rows");
    }
  }
  for (const BagTemperatureStream& t : temperatures) {
    if (t.celsius.size() != t.time_s.size()) throw InputError(t.topic, "temperature times and values differ in number");
    series.push_back({&t.time_s, bag_topic_name(t.topic)});
  }
  for (std::size_t s = 0; s < series.size(); ++s) {
    const std::string& topic = series[s].topic;
    std::string why;
    if (topic.size() < 2) throw InputError(topic.empty() ? std::string("topic") : topic, "not a valid topic name");
    if (!topics.insert(topic).second) throw InputError(topic, "topic used twice in one bag");
    const std::string source = s < fields.size() ? fields[s].record->source : topic;
    const std::vector<double>& t = *series[s].time_s;
    for (std::size_t i = 0; i < t.size(); ++i) {
      stamp_of(t[i], source);
      if (i > 0 && !(t[i] > t[i - 1])) {
        throw InputError(source, "times not strictly increasing at sample " + std::to_string(i));
      }
    }
    total += t.size();
  }

  rosbag::Bag bag;
  open_bag(bag, path, rosbag::bagmode::Write);
  bag.setCompression(compression == BagCompression::kBz2   ? rosbag::compression::BZ2
                     : compression == BagCompression::kLz4 ? rosbag::compression::LZ4
                                                           : rosbag::compression::Uncompressed);
  BagWriteSummary summary;
  const std::size_t report_every = std::max<std::size_t>(1, total / 100);
  sensor_msgs::MagneticField field;
  sensor_msgs::Temperature temperature;
  try {
    for (;;) {
      // The series whose next message is the earliest (few series: a linear scan).
      std::size_t best = series.size();
      double best_t = std::numeric_limits<double>::infinity();
      for (std::size_t s = 0; s < series.size(); ++s) {
        const Series& se = series[s];
        if (se.next < se.time_s->size() && (*se.time_s)[se.next] < best_t) {
          best_t = (*se.time_s)[se.next];
          best = s;
        }
      }
      if (best == series.size()) break;
      Series& se = series[best];
      const std::size_t i = se.next++;
      const ros::Time stamp = ros::Time().fromSec(best_t);
      if (best < fields.size()) {
        const BagFieldStream& f = fields[best];
        field.header.seq = se.seq++;
        field.header.stamp = stamp;
        field.header.frame_id = f.frame_id;
        const auto row = static_cast<Eigen::Index>(i);
        field.magnetic_field.x = f.record->values_nT(row, 0) / kNanoteslaPerTesla;
        field.magnetic_field.y = f.record->values_nT(row, 1) / kNanoteslaPerTesla;
        field.magnetic_field.z = f.record->values_nT(row, 2) / kNanoteslaPerTesla;
        bag.write(se.topic, stamp, field);
      } else {
        const BagTemperatureStream& t = temperatures[best - fields.size()];
        temperature.header.seq = se.seq++;
        temperature.header.stamp = stamp;
        temperature.header.frame_id = t.frame_id;
        temperature.temperature = t.celsius[i];
        temperature.variance = 0.0;
        bag.write(se.topic, stamp, temperature);
      }
      ++summary.per_topic[se.topic];
      if (++summary.messages % report_every == 0 && progress) progress(summary.messages, total);
    }
    bag.close();
  } catch (const rosbag::BagException& e) {
    throw InputError(path, std::string("write failed: ") + e.what());
  }
  if (progress) progress(summary.messages, total);
  return summary;
}

std::string bag_frame_id(const VectorRecord& record) {
  const auto it = record.header.find("frame_id");
  return it == record.header.end() ? std::string() : it->second;
}

std::vector<VectorRecord> read_bag_records(const std::string& path, const std::vector<std::string>& topics,
                                           std::vector<std::string>* warnings) {
  rosbag::Bag bag;
  open_bag(bag, path, rosbag::bagmode::Read);
  std::vector<std::string> names;
  for (const std::string& t : topics) names.push_back(bag_topic_name(t));
  if (names.empty()) return {};
  check_topics(bag, path, names, kMagneticFieldType);

  struct Collector {
    std::vector<double> time_s;
    std::vector<std::array<double, 3>> values;
    std::string frame_id;
    std::size_t frame_changes = 0;
  };
  std::vector<Collector> collected(names.size());
  try {
    rosbag::View view(bag, rosbag::TopicQuery(names));
    const std::size_t expected = view.size();
    for (Collector& c : collected) {
      c.time_s.reserve(expected / std::max<std::size_t>(1, names.size()) + 16);
      c.values.reserve(expected / std::max<std::size_t>(1, names.size()) + 16);
    }
    std::size_t slot = 0;  // topic index of the previous message (the streams interleave)
    for (const rosbag::MessageInstance& m : view) {
      const std::string& topic = m.getTopic();
      if (topic != names[slot]) {
        slot = static_cast<std::size_t>(std::find(names.begin(), names.end(), topic) - names.begin());
        if (slot >= names.size()) {
          slot = 0;
          continue;
        }
      }
      const sensor_msgs::MagneticField::ConstPtr msg = m.instantiate<sensor_msgs::MagneticField>();
      if (!msg) continue;
      Collector& c = collected[slot];
      if (c.time_s.empty()) c.frame_id = msg->header.frame_id;
      else if (msg->header.frame_id != c.frame_id) ++c.frame_changes;
      c.time_s.push_back(msg->header.stamp.toSec());
      c.values.push_back({msg->magnetic_field.x * kNanoteslaPerTesla, msg->magnetic_field.y * kNanoteslaPerTesla,
                          msg->magnetic_field.z * kNanoteslaPerTesla});
    }
  } catch (const rosbag::BagException& e) {
    throw InputError(path, std::string("read failed: ") + e.what());
  }

  std::vector<VectorRecord> out(names.size());
  for (std::size_t k = 0; k < names.size(); ++k) {
    Collector& c = collected[k];
    VectorRecord& r = out[k];
    r.source = path + ":" + names[k];
    order_by_time(c.time_s, c.values, r.source, warnings);
    if (c.frame_changes > 0 && warnings != nullptr) {
      warnings->push_back(r.source + ": frame_id changes in " + std::to_string(c.frame_changes) +
                          " messages (first: '" + c.frame_id + "')");
    }
    r.time_s = std::move(c.time_s);
    r.values_nT.resize(static_cast<Eigen::Index>(c.values.size()), 3);
    for (std::size_t i = 0; i < c.values.size(); ++i) {
      for (int j = 0; j < 3; ++j) r.values_nT(static_cast<Eigen::Index>(i), j) = c.values[i][j];
    }
    r.header["frame_id"] = c.frame_id;
    r.header["topic"] = names[k];
    r.header["format"] = "rosbag " + kMagneticFieldType;
  }
  return out;
}

BagTemperatureStream read_bag_temperatures(const std::string& path, const std::string& topic) {
  rosbag::Bag bag;
  open_bag(bag, path, rosbag::bagmode::Read);
  BagTemperatureStream out;
  out.topic = bag_topic_name(topic);
  check_topics(bag, path, {out.topic}, kTemperatureType);
  try {
    rosbag::View view(bag, rosbag::TopicQuery(out.topic));
    for (const rosbag::MessageInstance& m : view) {
      const sensor_msgs::Temperature::ConstPtr msg = m.instantiate<sensor_msgs::Temperature>();
      if (!msg) continue;
      if (out.time_s.empty()) out.frame_id = msg->header.frame_id;
      out.time_s.push_back(msg->header.stamp.toSec());
      out.celsius.push_back(msg->temperature);
    }
  } catch (const rosbag::BagException& e) {
    throw InputError(path, std::string("read failed: ") + e.what());
  }
  order_by_time(out.time_s, out.celsius, path + ":" + out.topic, nullptr);
  return out;
}

std::vector<std::pair<std::string, std::string>> bag_topics(const std::string& path) {
  rosbag::Bag bag;
  open_bag(bag, path, rosbag::bagmode::Read);
  return topics_of(bag);
}

}  // namespace magnetometer_insitu_calibration
