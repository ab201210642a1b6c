#!/usr/bin/env bash
# The core library's include rules, checked on every include line of src/core and
# include/magnetometer_insitu_calibration (a ctest entry, core_layering):
#   concern        may include (besides itself)
#   common         nothing of the package
#   formats        common                      (record formats never include estimation)
#   instrument     common, formats
#   preprocessing  common
#   estimation     common                      (estimation never includes formats)
#   simulation     common, preprocessing, estimation
#   pipeline       common, preprocessing, estimation
# and no core file includes ROS (<ros/...>, <sensor_msgs/...>, the package's ros/ headers).
# Prints each violation as file:line and exits 1 if there is any.
set -u
root="${1:-$(cd "$(dirname "$0")/.." && pwd)}"
declare -A allowed=(
  [common]="common"
  [formats]="common formats"
  [instrument]="common formats instrument"
  [preprocessing]="common preprocessing"
  [estimation]="common estimation"
  [simulation]="common preprocessing estimation simulation"
  [pipeline]="common preprocessing estimation pipeline"
)
violations=0
checked=0
for concern in "${!allowed[@]}"; do
  for dir in "$root/src/core/$concern" "$root/include/magnetometer_insitu_calibration/$concern"; do
    [ -d "$dir" ] || { echo "missing folder: $dir"; violations=$((violations + 1)); continue; }
    while IFS= read -r hit; do
      file=${hit%%:*}; rest=${hit#*:}; line=${rest%%:*}; text=${rest#*:}
      checked=$((checked + 1))
      if [[ "$text" =~ \<(ros|rosbag|sensor_msgs|std_msgs|diagnostic_updater|nodelet)/ ]] ||
         [[ "$text" =~ magnetometer_insitu_calibration/ros/ ]]; then
        echo "${file#$root/}:$line: ROS include in the ROS-free core: $text"
        violations=$((violations + 1)); continue
      fi
      if [[ "$text" =~ \"magnetometer_insitu_calibration/([a-z_]+)/ ]]; then
        target=${BASH_REMATCH[1]}
        if [[ " ${allowed[$concern]} " != *" $target "* ]]; then
          echo "${file#$root/}:$line: $concern may not include $target: $text"
          violations=$((violations + 1))
        fi
      elif [[ "$text" =~ \"magnetometer_insitu_calibration/[a-z_0-9]+\.hpp\" ]]; then
        echo "${file#$root/}:$line: header outside the concern folders: $text"
        violations=$((violations + 1))
      fi
    done < <(grep -rn '^[[:space:]]*#[[:space:]]*include' "$dir" --include='*.cpp' --include='*.hpp')
  done
done
echo "check_layering: $checked include lines checked, $violations violations"
[ "$checked" -gt 0 ] && [ "$violations" -eq 0 ]
