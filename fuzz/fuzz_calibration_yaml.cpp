// libFuzzer target: the calibration file loaded by correction_node
// (ros/calibration_yaml.hpp: calibration_from_yaml; yaml-cpp and the generated message only,
// no ROS master). Input: the file's text.
// Checks: a value or CalibrationFileError (never a YAML::Exception or another exception); an
// accepted file round-trips: calibration_to_yaml of it loads back equal (calibrations_equal).
// yaml-cpp itself is Debian's uninstrumented build: its crashes would still be caught by ASan,
// but coverage guidance stops at its interface.
#include "fuzz_common.hpp"

#include "magnetometer_insitu_calibration/ros/calibration_yaml.hpp"

using namespace magnetometer_insitu_calibration;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (!mic_fuzz::within_bounds(data, size, false)) return -1;
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const MagnetometerCalibration c = calibration_from_yaml(text, "fuzz.yaml");
    const std::string again = calibration_to_yaml(c, "fuzz");
    MagnetometerCalibration back;
    try {
      back = calibration_from_yaml(again, "fuzz-roundtrip.yaml");
    } catch (const CalibrationFileError& e) {
      mic_fuzz::fail(__FILE__, __LINE__, std::string("written file does not load back: ") + e.what() +
                                             "\n--- written ---\n" + again);
    }
    std::string difference;
    FUZZ_CHECK(calibrations_equal(c, back, &difference),
               "round trip changes field " + difference + "\n--- written ---\n" + again);
  } catch (const CalibrationFileError&) {
  } catch (...) {
    mic_fuzz::unexpected_exception(__FILE__, __LINE__);
  }
  return 0;
}
