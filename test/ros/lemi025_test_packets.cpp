// Packets of the test_lemi025_driver rostest: see lemi025_test_packets.hpp.
#include "lemi025_test_packets.hpp"

#include <cmath>

namespace magnetometer_insitu_calibration {
namespace test {

Lemi025Packet make_packet(double gps_s, char gps_status) {
  Lemi025Packet p;
  p.station = 7;
  p.gps_time_s = gps_s;
  const double i = std::fmod(gps_s - kT0, 40.0);
  p.sensor_temperature_C = 21.37 + 0.01 * i;
  p.electronics_temperature_C = 30.5 - 0.02 * i;
  p.dac_counts = {{100, -200, 300}};
  p.bias_nT = kBias_nT;
  for (int k = 0; k < kLemi025ReadingsPerPacket; ++k) {
    for (int c = 0; c < 3; ++c) p.variation_nT(k, c) = (c + 1) * 10.0 + 0.5 * k + 0.25 * i - 5.0 * c * c;
  }
  p.mode = 2;
  p.flash_free_percent = 77;
  p.supply_V = 12.3;
  p.gps_status = gps_status;
  return p;
}

}  // namespace test
}  // namespace magnetometer_insitu_calibration
