// The MagnetometerCalibration message of a calibration record: see calibration_message.hpp.
#include "magnetometer_insitu_calibration/ros/calibration_message.hpp"

#include <limits>
#include <stdexcept>
#include <string>

namespace magnetometer_insitu_calibration {

ros::Time to_ros_time(const RecordTime& time, const char* field) {
  if (time.sec < 0 || time.sec > std::numeric_limits<std::uint32_t>::max() || time.nsec >= 1000000000u) {
    throw std::out_of_range(std::string(field) + ": " + std::to_string(time.sec) + " s does not fit ROS time");
  }
  return ros::Time(static_cast<std::uint32_t>(time.sec), time.nsec);
}

namespace {

// One conversion per kind of field (calibration_record.hpp) to the message's type.
template <typename Out, typename In>
void assign_value(Out& out, const In& in, const char*) {
  out = in;
}
void assign_value(ros::Time& out, const RecordTime& in, const char* field) { out = to_ros_time(in, field); }
template <typename T, std::size_t N>
void assign_value(boost::array<T, N>& out, const std::array<T, N>& in, const char*) {
  std::copy(in.begin(), in.end(), out.begin());
}

}  // namespace

MagnetometerCalibration to_message(const CalibrationRecord& r) {
  MagnetometerCalibration m;
  m.header.stamp = to_ros_time(r.stamp, "stamp");
  m.header.frame_id = r.frame_id;
#define MIC_FIELD_TO_MESSAGE(kind, name, since, comment) assign_value(m.name, r.name, #name);
  MIC_CALIBRATION_FIELDS(MIC_FIELD_TO_MESSAGE)
#undef MIC_FIELD_TO_MESSAGE
  return m;
}

void set_verdicts(MagnetometerCalibration& m, const std::vector<ToleranceVerdict>& verdicts) {
  m.verdicts.clear();
  for (const ToleranceVerdict& v : verdicts) {
    ParameterVerdict out;  // the message (msg/ParameterVerdict.msg)
    out.parameter = v.parameter;
    out.value = v.value;
    out.ci95 = v.ci95;
    out.nominal = v.nominal;
    out.tolerance = v.tolerance;
    out.verdict = verdict_name(v.verdict);
    out.record_needed_s = v.record_needed_s;
    m.verdicts.push_back(out);
  }
}

}  // namespace magnetometer_insitu_calibration
