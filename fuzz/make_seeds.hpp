// make_seeds: what its two sources share (make_seeds.cpp: main, the text and LEMI seeds;
// make_seeds_cdf_yaml.cpp: the cdf and calibration_yaml seeds).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace make_seeds {

using Bytes = std::vector<std::uint8_t>;

/// The corpus directory (make_seeds' second argument): a seed goes to <g_out>/<target>/<name>.
extern std::string g_out;

/// Writes a seed, creating its target's directory; exits the program when it cannot.
void write(const std::string& target, const std::string& name, const Bytes& bytes);
void write(const std::string& target, const std::string& name, const std::string& text);
/// The bytes of a file; exits the program when it cannot read it.
Bytes read_bytes(const std::string& path);

/// cdf (and record_file/magpy.cdf): ImagCDF and MagPy CDF files made from the first seconds of
/// <root>/test/data/cdf's WIC LEMI-036 file, and that file cut at 16 KiB.
void write_cdf_seeds(const std::string& root);
#ifdef MIC_FUZZ_WITH_YAML
/// calibration_yaml: a calibration written by calibration_to_yaml (quotes, back-slash, new line,
/// NaN and infinity in it), its first half, and the files of <root>/test/ros/data.
void write_calibration_yaml_seeds(const std::string& root);
#endif

}  // namespace make_seeds
