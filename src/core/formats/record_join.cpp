// Joining several files of one instrument; see record_join.hpp.
#include "magnetometer_insitu_calibration/formats/record_join.hpp"

#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/formats/lemi_archive.hpp"
#include "magnetometer_insitu_calibration/formats/record_file.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace magnetometer_insitu_calibration {

VectorRecord join_records(std::vector<VectorRecord> parts, std::vector<std::string>* warnings) {
  if (parts.empty()) throw InputError("records", "no file to read");
  if (parts.size() == 1) return std::move(parts.front());
  std::stable_sort(parts.begin(), parts.end(), [](const VectorRecord& a, const VectorRecord& b) {
    const double ta = a.empty() ? std::numeric_limits<double>::infinity() : a.time_s.front();
    const double tb = b.empty() ? std::numeric_limits<double>::infinity() : b.time_s.front();
    return ta < tb;
  });
  VectorRecord out;
  out.components = parts.front().components;
  out.station = parts.front().station;
  out.header = parts.front().header;
  std::vector<std::string> channel_names;
  std::size_t total = 0;
  for (const VectorRecord& p : parts) {
    if (p.components != out.components) {
      throw InputError(p.source, "components " + p.components[0] + "," + p.components[1] + "," + p.components[2] +
                                     " differ from " + parts.front().source + "'s " + out.components[0] + "," +
                                     out.components[1] + "," + out.components[2] + " (not the same instrument?)");
    }
    out.source += (out.source.empty() ? "" : " + ") + p.source;
    total += p.size();
    for (const AuxiliaryChannel& a : p.auxiliary) {
      if (std::find(channel_names.begin(), channel_names.end(), a.name) == channel_names.end()) {
        channel_names.push_back(a.name);
        out.auxiliary.push_back({a.name, a.description, a.unit, {}});
      }
    }
  }
  out.time_s.reserve(total);
  out.values_nT.resize(static_cast<Eigen::Index>(total), 3);
  for (AuxiliaryChannel& a : out.auxiliary) a.values.reserve(total);
  std::size_t n = 0;
  std::string last_source;
  for (const VectorRecord& p : parts) {
    std::vector<const AuxiliaryChannel*> channels;
    for (const AuxiliaryChannel& a : out.auxiliary) {
      const auto it = std::find_if(p.auxiliary.begin(), p.auxiliary.end(), [&](const AuxiliaryChannel& b) { return b.name == a.name; });
      channels.push_back(it == p.auxiliary.end() || it->values.size() != p.size() ? nullptr : &*it);
    }
    std::size_t dropped = 0;
    double first_dropped = 0, last_dropped = 0, largest_difference = 0;
    for (std::size_t i = 0; i < p.size(); ++i) {
      const double t = p.time_s[i];
      if (n > 0 && !(t > out.time_s.back())) {
        if (dropped++ == 0) first_dropped = t;
        last_dropped = t;
        // The same time kept from an earlier part: how different are the values?
        const auto same = std::lower_bound(out.time_s.begin(), out.time_s.end(), t);
        if (same != out.time_s.end() && *same == t) {
          const auto k = static_cast<Eigen::Index>(same - out.time_s.begin());
          for (int c = 0; c < 3; ++c) {
            const double d = std::abs(out.values_nT(k, c) - p.values_nT(static_cast<Eigen::Index>(i), c));
            if (std::isfinite(d)) largest_difference = std::max(largest_difference, d);
          }
        }
        continue;
      }
      out.time_s.push_back(t);
      out.values_nT.row(static_cast<Eigen::Index>(n)) = p.values_nT.row(static_cast<Eigen::Index>(i));
      for (std::size_t c = 0; c < channels.size(); ++c) {
        out.auxiliary[c].values.push_back(channels[c] ? channels[c]->values[i] : std::numeric_limits<double>::quiet_NaN());
      }
      ++n;
    }
    if (dropped > 0 && warnings) {
      char diff[64];
      std::snprintf(diff, sizeof diff, "%.2f", largest_difference);
      warnings->push_back(p.source + ": " + std::to_string(dropped) + " samples from " + time_for_message(first_dropped) +
                          " to " + time_for_message(last_dropped) + " overlap " + last_source +
                          ": dropped (largest value difference at equal times " + diff + " nT)");
    }
    if (!p.empty()) last_source = p.source;
  }
  out.values_nT.conservativeResize(static_cast<Eigen::Index>(n), 3);
  return out;
}

VectorRecord read_records(const std::vector<std::string>& paths, std::vector<std::string>* warnings) {
  std::vector<VectorRecord> parts;
  for (const std::string& path : paths) {
    parts.push_back(read_record(path, LemiReadOptions(), warnings));
  }
  return join_records(std::move(parts), warnings);
}

}  // namespace magnetometer_insitu_calibration
