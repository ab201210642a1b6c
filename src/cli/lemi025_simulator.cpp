// lemi025_simulator: a LEMI-025 on a pseudo-terminal, so a whole station runs without hardware.
//
// Creates a pty, points --link (a symlink, replaced atomically) at its slave, and writes one
// 153-byte packet per second (times --speed) with ten 10 Hz readings of simulate_pair()'s
// reference or test record (--role). Two simulators with the same --seed, --start and settings
// play the two instruments of one consistent pair (the test = reference through n_true).
//
// Time: the packet's GPS second is the data's; reading k of packet i is the record's sample
// 10 i + k, taken at gps - 0.3 s + 0.1 k as the vendor specifies. Without --start the record
// begins at the current UTC hour and the first packet is the one of the current second, so
// GPS times follow the wall clock like a real instrument (and two roles started in the same
// hour agree). Gap samples (NaN) are not sendable: their packet is skipped.
//
// The simulator keeps the slave open in raw mode: bytes wait in its input queue (a few kB)
// while no driver is connected; when it is full, packets are dropped and counted. Stopping
// the simulator (SIGINT/SIGTERM) closes the master: a connected driver sees a hang-up.
#include "magnetometer_insitu_calibration/common/input_error.hpp"
#include "magnetometer_insitu_calibration/formats/lemi025_packet.hpp"
#include "magnetometer_insitu_calibration/simulation/hut_temperature.hpp"
#include "magnetometer_insitu_calibration/simulation/lemi025_station.hpp"
#include "magnetometer_insitu_calibration/simulation/simulator.hpp"
#include "magnetometer_insitu_calibration/common/time_format.hpp"

#include "command_line.hpp"  // parse_command_line: exit 1 on a usage error (src/program_support)

#include <CLI/CLI.hpp>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <fcntl.h>
#include <iostream>
#include <random>
#include <stdlib.h>
#include <termios.h>
#include <thread>
#include <unistd.h>

namespace mic = magnetometer_insitu_calibration;

// The simulation's station record has the packets' timing (simulation may not include formats).
static_assert(mic::kLemi025StationSamplePeriod_s == mic::kLemi025SamplePeriod_s, "LEMI-025 reading period");
static_assert(mic::kLemi025StationTimeShift_s == mic::kLemi025TimeShift_s, "LEMI-025 time shift");

namespace {

std::atomic<bool> g_stop{false};
void on_signal(int) { g_stop = true; }

struct Pty {
  int master = -1;
  int slave = -1;
  std::string slave_name;
};

Pty open_pty() {
  Pty pty;
  pty.master = posix_openpt(O_RDWR | O_NOCTTY);
  if (pty.master < 0 || grantpt(pty.master) != 0 || unlockpt(pty.master) != 0)
    throw std::runtime_error(std::string("cannot create a pseudo-terminal: ") + std::strerror(errno));
  pty.slave_name = ptsname(pty.master);
  pty.slave = ::open(pty.slave_name.c_str(), O_RDWR | O_NOCTTY);
  if (pty.slave < 0) throw std::runtime_error("cannot open " + pty.slave_name);
  termios tio{};
  tcgetattr(pty.slave, &tio);
  cfmakeraw(&tio);
  cfsetispeed(&tio, B57600);
  cfsetospeed(&tio, B57600);
  tcsetattr(pty.slave, TCSANOW, &tio);
  const int flags = fcntl(pty.master, F_GETFL);
  fcntl(pty.master, F_SETFL, flags | O_NONBLOCK);  // a full queue drops packets, never blocks
  return pty;
}

void point_link(const std::string& link, const std::string& target) {
  const std::string tmp = link + ".tmp" + std::to_string(::getpid());
  ::unlink(tmp.c_str());
  if (::symlink(target.c_str(), tmp.c_str()) != 0 || ::rename(tmp.c_str(), link.c_str()) != 0)
    throw mic::InputError("--link", "cannot create symlink " + link + ": " + std::strerror(errno));
}

// Bias field as the LEMI sets it: the record's mean, in 2.5 nT steps.
Eigen::Vector3d bias_of(const mic::Readings& values) {
  Eigen::Vector3d bias = Eigen::Vector3d::Zero();
  for (int c = 0; c < 3; ++c) {
    double sum = 0.0;
    std::size_t n = 0;
    for (Eigen::Index i = 0; i < values.rows(); ++i)
      if (std::isfinite(values(i, c))) {
        sum += values(i, c);
        ++n;
      }
    bias[c] = n > 0 ? std::round(sum / n / mic::kLemi025BiasStep_nT) * mic::kLemi025BiasStep_nT : 0.0;
  }
  return bias;
}


/// The command line.
struct Options {
  std::string link, role = "reference", start_text, checksum_text = "sum8";
  double rate = 1.0, speed = 1.0;  ///< packets per wall-clock second, time-lapse factor
  double duration_s = 6 * 3600.0;  ///< record length, s
  int station = 1;
  std::string gps_status = "A";
  bool loop = false;
  long corrupt_every = 0;
  double variation_rms = mic::kLemi025StationVariationRms_nT;  ///< nT
  mic::SimulationSettings s;
  // The test in a field hut (hut_temperature.hpp, seed = --seed, its default coefficients): its
  // readings carry the temperature effect and its packets the hut thermometer's reading.
  double hut_daily_C = 0.0, hut_heater_C = 0.0, hut_heater_period_s = 1800.0;

  bool hut() const { return hut_daily_C > 0.0 || hut_heater_C > 0.0; }
};

void add_options(CLI::App& app, Options& o) {
  app.add_option("--link", o.link, "symlink to create, pointing at the pty slave (e.g. /tmp/lemi_ref)")->required();
  app.add_option("--role", o.role, "reference|test: which instrument of the simulated pair")->capture_default_str();
  app.add_option("--seed", o.s.seed, "random seed (same seed = same pair)")->capture_default_str();
  app.add_option("--field-seed", o.s.field_seed,
                 "seed of the field's variations alone (0: --seed); stations with one field seed share the field")
      ->capture_default_str();
  app.add_option("--rate", o.rate, "packets per second of wall-clock time")->capture_default_str();
  app.add_option("--speed", o.speed, "time-lapse factor applied to --rate")->capture_default_str();
  app.add_option("--start", o.start_text, "UTC start of the record, ISO 8601 (default: current hour, live)");
  app.add_option("--duration", o.duration_s, "record length, s (10 Hz samples are simulated up front)")
      ->capture_default_str();
  app.add_flag("--loop", o.loop, "start the record again at its end (else exit)");
  app.add_option("--checksum", o.checksum_text, "checksum byte: none|sum8|xor8")->capture_default_str();
  app.add_option("--station", o.station, "station number byte, 1-255")->capture_default_str();
  app.add_option("--gps-status", o.gps_status, "GPS status char: A P O S")->capture_default_str();
  app.add_option("--variation-rms-nT", o.variation_rms, "rms of x,y variations, nT")->capture_default_str();
  app.add_option("--delay-s", o.s.delay_s, "delay of the test instrument, s")->capture_default_str();
  app.add_option("--corrupt-every", o.corrupt_every, "flip one byte in every N-th packet (0: never)")
      ->capture_default_str();
  app.add_option("--hut-daily-C", o.hut_daily_C, "test in a hut: amplitude of the daily temperature cycle, degC (0: no hut)")
      ->capture_default_str();
  app.add_option("--hut-heater-C", o.hut_heater_C, "test in a hut: heater cycle amplitude, degC")->capture_default_str();
  app.add_option("--hut-heater-period-s", o.hut_heater_period_s, "test in a hut: heater cycle period, s")
      ->capture_default_str();
}

/// Checks the options; returns the checksum mode. Throws InputError naming the option.
mic::ChecksumMode check_options(const Options& o) {
  if (o.role != "reference" && o.role != "test") throw mic::InputError("--role", "reference or test");
  const std::optional<mic::ChecksumMode> checksum = mic::parse_checksum_mode(o.checksum_text);
  if (!checksum) throw mic::InputError("--checksum", "none, sum8 or xor8");
  if (!(o.rate > 0.0) || !(o.speed > 0.0)) throw mic::InputError("--rate", "rate and speed must be > 0");
  if (o.station < 1 || o.station > 255) throw mic::InputError("--station", "1-255");
  if (o.gps_status.size() != 1 || std::string("APOS").find(o.gps_status[0]) == std::string::npos)
    throw mic::InputError("--gps-status", "one of A P O S");
  if (!(o.duration_s >= 1.0)) throw mic::InputError("--duration", "at least 1 s");
  return *checksum;
}

/// The simulated pair at 10 Hz from start_s (GPS second of packet 0), with the hut if asked for.
mic::SimulatedPair simulate(const Options& o, double start_s) {
  // Sample 10 i + k is taken at gps_i - 0.3 + 0.1 k: the record starts 0.3 s before second 0.
  mic::SimulationSettings s = mic::lemi025_station_settings(o.s, start_s, o.duration_s, o.variation_rms);
  s.keep_clean_field = false;
  mic::SimulatedPair pair = mic::simulate_pair(s);
  if (o.hut()) {
    mic::HutTemperatureSettings h;
    h.seed = s.seed;
    h.daily_amplitude_C = o.hut_daily_C;
    h.heater_amplitude_C = o.hut_heater_C;
    h.heater_period_s = o.hut_heater_period_s;
    h.validate();
    mic::add_hut_temperature(pair, h);
  }
  return pair;
}

/// What the packets carry: the instrument's 10 Hz record (nT), the test's hut thermometer
/// (degC per reading) or none, the bias field (nT), the GPS second of packet 0 and the count.
struct Playback {
  const mic::VectorRecord& record;
  const std::vector<double>* thermometer;
  Eigen::Vector3d bias;
  double start_s;
  std::size_t packets;
};

/// Packet `index` of pass `cycle` over the record into p; false when one of its readings is a
/// gap (NaN): such a packet is not sendable.
bool make_packet(const Playback& r, const Options& o, std::size_t index, std::uint64_t cycle, mic::Lemi025Packet& p) {
  p.station = static_cast<std::uint8_t>(o.station);
  p.gps_time_s = r.start_s + static_cast<double>(index) + cycle * static_cast<double>(r.packets);
  // Without a hut: a smooth 20 +- 0.5 degC daily cycle.
  p.sensor_temperature_C = 20.0 + 0.5 * std::sin(2 * M_PI * p.gps_time_s / 86400.0);
  if (r.thermometer != nullptr) {  // the reading of the packet's first sample
    const double t = (*r.thermometer)[index * mic::kLemi025ReadingsPerPacket];
    if (std::isfinite(t)) p.sensor_temperature_C = t;
  }
  p.electronics_temperature_C = p.sensor_temperature_C + 3.0;
  p.bias_nT = r.bias;
  p.mode = 2;
  p.flash_free_percent = 90;
  p.supply_V = 12.0;
  p.gps_status = o.gps_status[0];
  bool gap = false;
  for (int k = 0; k < mic::kLemi025ReadingsPerPacket; ++k) {
    const auto row = static_cast<Eigen::Index>(index * mic::kLemi025ReadingsPerPacket + k);
    for (int c = 0; c < 3; ++c) {
      const double v = r.record.values_nT(row, c);
      gap = gap || !std::isfinite(v);
      p.variation_nT(k, c) = v - r.bias[c];
    }
  }
  return !gap;
}

struct Counts {
  std::uint64_t sent = 0, dropped = 0, skipped_gaps = 0;
};

/// Writes one packet every 1 / (rate speed) s of the steady clock to the pty master, from packet
/// `index`, until the record ends (again from its start with --loop) or a signal arrives.
Counts play(const Playback& r, const Options& o, mic::ChecksumMode checksum, int master, std::size_t index) {
  const double period_s = 1.0 / (o.rate * o.speed);
  auto next_wall = std::chrono::steady_clock::now();
  Counts n;
  std::uint64_t cycle = 0;
  while (!g_stop) {
    if (index >= r.packets) {
      if (!o.loop) break;
      index = 0;
      ++cycle;
    }
    mic::Lemi025Packet p;
    if (!make_packet(r, o, index, cycle, p)) {
      ++n.skipped_gaps;
    } else {
      auto bytes = mic::encode_lemi025_packet(p, checksum);
      if (o.corrupt_every > 0 && (n.sent + n.dropped + 1) % static_cast<std::uint64_t>(o.corrupt_every) == 0)
        bytes[40] ^= 0x5A;
      const ssize_t written = ::write(master, bytes.data(), bytes.size());
      if (written == static_cast<ssize_t>(bytes.size())) {
        ++n.sent;
      } else {
        ++n.dropped;  // queue full (no reader) or a partial write: a real line loses bytes too
      }
    }
    ++index;
    next_wall += std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(period_s));
    std::this_thread::sleep_until(next_wall);
  }
  return n;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"LEMI-025 simulator on a pseudo-terminal: packets of a simulated 10 Hz record."};
  Options o;
  add_options(app, o);
  if (const auto status = mic::parse_command_line(app, argc, argv)) return *status;

  try {
    const mic::ChecksumMode checksum = check_options(o);
    const double now = std::floor(std::chrono::duration<double>(
                                      std::chrono::system_clock::now().time_since_epoch())
                                      .count());
    const bool live = o.start_text.empty();
    double start_s = live ? mic::lemi025_live_start_s(now) : 0.0;
    if (!live) {
      try {
        start_s = std::round(mic::parse_iso8601(o.start_text));
      } catch (const std::invalid_argument& e) {
        throw mic::InputError("--start", e.what());
      }
    }
    const mic::SimulatedPair pair = simulate(o, start_s);
    const mic::VectorRecord& record = o.role == "reference" ? pair.reference : pair.test;
    const std::vector<double>* thermometer = o.role == "test" && o.hut() ? &pair.test.auxiliary.back().values : nullptr;
    const Playback playback{record, thermometer, bias_of(record.values_nT), start_s,
                            record.size() / mic::kLemi025ReadingsPerPacket};

    Pty pty = open_pty();
    point_link(o.link, pty.slave_name);
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    std::signal(SIGPIPE, SIG_IGN);
    std::cerr << "lemi025_simulator: " << o.role << " instrument on " << pty.slave_name << " (" << o.link
              << "), seed " << o.s.seed << ", record from " << mic::format_iso8601(start_s, 0) << ", "
              << playback.packets << " packets, checksum " << o.checksum_text << "\n";
    // Live: the packet of the current second first, as a real instrument's.
    const std::size_t first = live ? static_cast<std::size_t>(std::max(0.0, now - start_s)) % playback.packets : 0;
    const Counts n = play(playback, o, checksum, pty.master, first);
    ::unlink(o.link.c_str());
    ::close(pty.slave);
    ::close(pty.master);
    std::cerr << "lemi025_simulator: " << n.sent << " packets sent, " << n.dropped << " dropped, "
              << n.skipped_gaps << " skipped (gaps)\n";
    return 0;
  } catch (const mic::InputError& e) {
    std::cerr << "lemi025_simulator: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "lemi025_simulator: " << e.what() << "\n";
    return 1;
  }
}
