// Helpers of the lemi025_driver rostests: see driver_test_support.hpp.
#include "driver_test_support.hpp"

#include <gtest/gtest.h>

namespace magnetometer_insitu_calibration {
namespace test {

std::string param(const std::string& name, const std::string& fallback) {
  std::string value;
  return ros::param::get("~" + name, value) ? value : fallback;
}

bool wait_for(const std::function<bool()>& done, double timeout_s) {
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
  while (ros::ok() && ros::WallTime::now() < deadline) {
    if (done()) return true;
    ros::WallDuration(0.01).sleep();
  }
  return done();
}

std::vector<std::uint8_t> encode(const Lemi025Packet& p) {
  const auto bytes = encode_lemi025_packet(p, ChecksumMode::kSum8);
  return std::vector<std::uint8_t>(bytes.begin(), bytes.end());
}

ros::Time gps_stamp(double gps_s, int k) {
  return ros::Time(static_cast<std::uint32_t>(gps_s)) + ros::Duration(-0.3 + 0.1 * k);
}

FieldInbox::FieldInbox(const std::string& driver_namespace) {
  ros::NodeHandle nh;
  fields_sub_ = nh.subscribe(driver_namespace + "/magnetic_field", 10000, &FieldInbox::on_field, this);
}

std::size_t FieldInbox::field_count() {
  std::lock_guard<std::mutex> lock(mutex_);
  return fields_.size();
}

std::vector<sensor_msgs::MagneticField> FieldInbox::fields_from(std::size_t first) {
  std::lock_guard<std::mutex> lock(mutex_);
  return std::vector<sensor_msgs::MagneticField>(fields_.begin() + static_cast<std::ptrdiff_t>(first), fields_.end());
}

void FieldInbox::expect_all_stamps_increasing() {
  const auto all = all_fields();
  for (std::size_t i = 1; i < all.size(); ++i) {
    ASSERT_GT(all[i].header.stamp, all[i - 1].header.stamp) << "message " << i << " goes backwards";
  }
}

void FieldInbox::on_field(const sensor_msgs::MagneticField::ConstPtr& m) {
  std::lock_guard<std::mutex> lock(mutex_);
  fields_.push_back(*m);
}

DriverDiagnostics::DriverDiagnostics(const std::string& driver_node) : prefix_(driver_node + ": ") {
  ros::NodeHandle nh;
  subscriber_ = nh.subscribe("/diagnostics", 1000, &DriverDiagnostics::on_diagnostics, this);
}

bool DriverDiagnostics::status(const std::string& task, diagnostic_msgs::DiagnosticStatus& out) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = statuses_.find(task);
  if (it == statuses_.end()) return false;
  out = it->second;
  return true;
}

std::string DriverDiagnostics::value(const std::string& task, const std::string& key) {
  diagnostic_msgs::DiagnosticStatus s;
  if (!status(task, s)) return "";
  for (const auto& kv : s.values)
    if (kv.key == key) return kv.value;
  return "";
}

long long DriverDiagnostics::counter(const std::string& task, const std::string& key) {
  const std::string text = value(task, key);
  return text.empty() ? -1 : std::stoll(text);
}

long long DriverDiagnostics::wait_counter(const std::string& task, const std::string& key, long long target,
                                          double timeout_s) {
  long long seen = -1;
  wait_for([&] { return (seen = counter(task, key)) >= target; }, timeout_s);
  return seen;
}

std::size_t DriverDiagnostics::history_size() {
  std::lock_guard<std::mutex> lock(mutex_);
  return history_.size();
}

bool DriverDiagnostics::any_since(std::size_t mark, const std::string& task, std::uint8_t level,
                                  const std::string& text) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (std::size_t i = mark; i < history_.size(); ++i) {
    const auto& h = history_[i];
    if (h.first == task && h.second.level == level && h.second.message.find(text) != std::string::npos) return true;
  }
  return false;
}

void DriverDiagnostics::fresh() {
  const std::size_t n0 = diagnostics_seen();
  EXPECT_TRUE(wait_for([&] { return diagnostics_seen() >= n0 + 2; })) << "no diagnostics from the driver";
}

ros::Time DriverDiagnostics::last_stamp() {
  std::lock_guard<std::mutex> lock(mutex_);
  return last_stamp_;
}

std::size_t DriverDiagnostics::diagnostics_seen() {
  std::lock_guard<std::mutex> lock(mutex_);
  return diagnostics_seen_;
}

void DriverDiagnostics::on_diagnostics(const diagnostic_msgs::DiagnosticArray::ConstPtr& m) {
  std::lock_guard<std::mutex> lock(mutex_);
  bool ours = false;
  for (const auto& s : m->status) {
    if (s.name.compare(0, prefix_.size(), prefix_) == 0) {
      statuses_[s.name.substr(prefix_.size())] = s;
      history_.emplace_back(s.name.substr(prefix_.size()), s);
      ours = true;
    }
  }
  if (ours) {
    ++diagnostics_seen_;
    last_stamp_ = m->header.stamp;
  }
}

void DriverInbox::wait_all_read(const PtyLink& port) {
  const auto written = static_cast<long long>(port.bytes_written());
  EXPECT_GE(wait_counter("link", "bytes read", written), written) << "the driver did not read every byte written";
}

std::vector<sensor_msgs::MagneticField> DriverInbox::write_and_collect(PtyLink& port,
                                                                       const std::vector<std::uint8_t>& bytes,
                                                                       std::size_t expected) {
  const std::size_t before = field_count();
  port.write(bytes);
  EXPECT_TRUE(wait_for([&] { return field_count() >= before + expected; }))
      << "got " << field_count() - before << " of " << expected << " readings";
  wait_all_read(port);
  return fields_from(before);
}

void assert_driver_on_pty(const std::function<bool()>& topics_connected, DriverDiagnostics& diagnostics) {
  ASSERT_TRUE(wait_for(topics_connected)) << "driver topics not connected";
  ASSERT_TRUE(wait_for([&] { return diagnostics.value("link", "connected") == "True"; }))
      << "driver not connected to the pty: " << diagnostics.value("link", "last warning");
}

}  // namespace test
}  // namespace magnetometer_insitu_calibration
