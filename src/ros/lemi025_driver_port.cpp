// lemi025_driver, port handling: opening the source ~source names (serial port, stream
// recording, LemiBin file, compact-flash image) and the reading thread that waits on it, logs
// disconnections and reconnections, and paces recorded packets (see lemi025_driver.hpp).
#include "magnetometer_insitu_calibration/ros/lemi025_driver.hpp"

#include "lemi025_driver_internal.hpp"
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"
#include "magnetometer_insitu_calibration/instrument/serial_port.hpp"
#include "magnetometer_insitu_calibration/ros/parameters.hpp"

#include <chrono>
#include <limits>

namespace magnetometer_insitu_calibration {

using namespace lemi025_driver_detail;

void Lemi025Driver::open_source() {
  const Lemi025DriverSettings& s = settings_;
  // Open the source. A serial device that is absent is not fatal (it may be plugged in later);
  // a recording that cannot be read is.
  try {
    if (s.source == Lemi025SourceKind::kSerial || s.source == Lemi025SourceKind::kStreamFile) {
      std::unique_ptr<ByteSource> bytes;
      if (s.source == Lemi025SourceKind::kSerial) {
        auto serial = std::make_unique<SerialPortSource>(s.device, s.baud);
        if (!serial->ok()) {
          ROS_WARN("%s: %s not open yet (%s): retrying every %g s", node_name_.c_str(), s.device.c_str(),
                   serial->last_error().c_str(), s.reopen_interval_s);
        }
        bytes = std::move(serial);
      } else {
        FileByteSourceOptions options;
        options.bytes_per_second = s.rate * kBytesPerPacketSecond;
        bytes = std::make_unique<FileByteSource>(s.file, options);
      }
      StreamPacketSourceOptions options;
      options.parser.checksum = s.checksum;
      options.reopen_interval_s = s.reopen_interval_s;
      source_ = std::make_unique<StreamPacketSource>(std::move(bytes), options);
    } else if (s.source == Lemi025SourceKind::kLemiBin) {
      LemiReadOptions options;
      options.checksum = s.checksum;
      auto lemibin = std::make_unique<LemiBinPacketSource>(s.file, options);
      lemibin_ = lemibin.get();
      source_ = std::move(lemibin);
    } else {
      source_ = std::make_unique<CompactFlashPacketSource>(s.file);
    }
  } catch (const InputError& e) {
    if (e.where() == "baud") throw ParameterError("baud", e.problem());
    throw ParameterError(s.recorded() ? "file" : "device", e.what());
  } catch (const std::exception& e) {  // e.g. std::filesystem errors of the file readers
    throw ParameterError(s.recorded() ? "file" : "device", e.what());
  }
}

bool Lemi025Driver::pace(std::uint64_t index) {
  using Clock = std::chrono::steady_clock;
  if (index == 0) pace_start_ = Clock::now();
  const auto due = pace_start_ + std::chrono::duration_cast<Clock::duration>(
                               std::chrono::duration<double>(static_cast<double>(index) / settings_.rate));
  std::unique_lock<std::mutex> lock(stop_mutex_);
  return !stop_cv_.wait_until(lock, due, [this] { return stopping_.load(); });
}

bool Lemi025Driver::wait_for_subscribers() {
  const auto wanted = static_cast<std::uint32_t>(settings_.wait_for_subscribers);
  ROS_INFO("%s: replay starts when %s has %u subscriber(s) (~wait_for_subscribers)", node_name_.c_str(),
           nh_.resolveName("magnetic_field").c_str(), wanted);
  std::unique_lock<std::mutex> lock(stop_mutex_);
  while (field_publisher_.getNumSubscribers() < wanted) {
    if (!ros::ok() || stop_cv_.wait_for(lock, std::chrono::milliseconds(50), [this] { return stopping_.load(); })) {
      return false;
    }
  }
  return true;
}

void Lemi025Driver::run() {
  if (settings_.recorded() && settings_.wait_for_subscribers > 0 && !wait_for_subscribers()) return;
  bool end_reported = false;
  while (!stopping_ && ros::ok()) {
    const std::optional<Lemi025Packet> packet = source_->next(kReadTimeout_s);
    const double arrival_s = ros::Time::now().toSec();
    std::string last_warning, last_disconnect;
    for (const std::string& warning : source_->take_warnings()) {
      if (warning.rfind("reconnected", 0) == 0) {
        ROS_INFO("%s: %s", node_name_.c_str(), warning.c_str());
      } else {
        ROS_WARN("%s: %s", node_name_.c_str(), warning.c_str());
      }
      if (warning.rfind("disconnected", 0) == 0) {
        pc_clock_.reset();
        last_disconnect = warning;
      }
      last_warning = warning;
    }
    if (packet) {
      double recorded_pc_s = std::numeric_limits<double>::quiet_NaN();
      if (lemibin_ && packet_index_ < lemibin_->pc_times_s().size()) recorded_pc_s = lemibin_->pc_times_s()[packet_index_];
      if (settings_.recorded() && settings_.source != Lemi025SourceKind::kStreamFile && settings_.rate > 0.0) {
        if (!pace(packet_index_)) break;
      }
      ++packet_index_;
      handle(*packet, arrival_s, recorded_pc_s);
    }
    const bool at_end = source_->at_end();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      state_.stats = source_->stats();
      const bool connected = source_->connected();
      if (connected) {
        state_.disconnected_since_wall_s = -1.0;
      } else if (state_.disconnected_since_wall_s < 0.0) {
        state_.disconnected_since_wall_s = wall_now_s();
      }
      state_.connected = connected;
      state_.connection_problem = source_->connection_problem();
      state_.at_end = at_end;
      if (!last_warning.empty()) state_.last_warning = time_for_message(wall_now_s()) + " " + last_warning;
      if (!last_disconnect.empty()) state_.last_disconnect = time_for_message(wall_now_s()) + " " + last_disconnect;
    }
    if (at_end && !packet) {
      release_held();
      if (!end_reported) {
        ROS_INFO("%s: end of recording %s after %llu packets", node_name_.c_str(), settings_.file.c_str(),
                 static_cast<unsigned long long>(packet_index_));
        end_reported = true;
      }
      std::unique_lock<std::mutex> lock(stop_mutex_);
      stop_cv_.wait(lock, [this] { return stopping_.load(); });
    }
  }
}

}  // namespace magnetometer_insitu_calibration
