// The record a simulated LEMI-025 station plays (lemi025_simulator, and scalar_simulator beside
// it): the simulated pair at the LEMI-025's 10 Hz, packet i stamped with GPS second start_s + i
// and its ten readings taken at start_s + i - 0.3 + 0.1 k, as the vendor specifies. Every
// simulated instrument of a station builds its record with these settings from the same seed,
// start and duration, so that they see one field.
#pragma once

#include "magnetometer_insitu_calibration/simulation/simulator.hpp"

namespace magnetometer_insitu_calibration {

/// The LEMI-025's reading period and the vendor's time shift of reading 0 from the packet's GPS
/// second, s: formats/lemi025_packet.hpp's kLemi025SamplePeriod_s and kLemi025TimeShift_s, which
/// the simulation may not include; lemi025_simulator asserts at compile time that they agree.
constexpr double kLemi025StationSamplePeriod_s = 0.1;
constexpr double kLemi025StationTimeShift_s = -0.3;

/// The simulated station's rms of the horizontal variations, nT (lemi025_simulator
/// --variation-rms-nT's default).
constexpr double kLemi025StationVariationRms_nT = 5.0;

/// `base` (seed, field_seed and the rest) with the station's time base: 10 Hz from the first
/// reading of GPS second start_s (UNIX s), ceil(duration_s) seconds, the given rms of the
/// horizontal variations (nT).
SimulationSettings lemi025_station_settings(SimulationSettings base, double start_s, double duration_s,
                                            double variation_rms_nT);

/// A live station's first GPS second: the UTC hour that `now_s` (UNIX s) is in.
double lemi025_live_start_s(double now_s);

}  // namespace magnetometer_insitu_calibration
