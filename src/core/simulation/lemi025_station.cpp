// The record a simulated LEMI-025 station plays: see lemi025_station.hpp.
#include "magnetometer_insitu_calibration/simulation/lemi025_station.hpp"

#include <cmath>

namespace magnetometer_insitu_calibration {

SimulationSettings lemi025_station_settings(SimulationSettings base, double start_s, double duration_s,
                                            double variation_rms_nT) {
  base.start_time_s = start_s + kLemi025StationTimeShift_s;  // reading 0 of packet 0: 0.3 s before its second
  base.duration_s = std::ceil(duration_s);
  base.sample_period_s = kLemi025StationSamplePeriod_s;
  base.variation_rms_nT = variation_rms_nT;
  return base;
}

double lemi025_live_start_s(double now_s) { return std::floor(now_s / 3600.0) * 3600.0; }

}  // namespace magnetometer_insitu_calibration
