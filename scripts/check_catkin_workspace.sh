#!/usr/bin/env bash
# CI step 3 (.ci/run): the package as a ROS user gets it. In a fresh catkin workspace at a deep
# path under a temporary folder (…/home/observatory/field_station_software/catkin_workspace):
#  1. copy the package into src/ and `catkin_make install` (tests off: the test command builds
#     and runs them; a deep workspace with tests on is verified in docs/ros_package.md);
#  2. a second workspace overlaying only the install space builds test/catkin_consumer, another
#     package that find_package()s this one, includes a core header and links the core library,
#     and runs it (the Eq. 2 estimator on a tiny record);
#  3. from the install space alone (a clean environment that sources only install/setup.bash):
#     `rosrun magnetometer_insitu_calibration calibrate_records` on the WIC demo records found with
#     `rospack find` (the JSON report must hold the five windows), then
#     `roslaunch magnetometer_insitu_calibration simulated_station.launch` at 100x real time, as
#     separate processes and as nodelets in one manager, each until /test/calibration publishes.
# Exits non-zero on the first failure. Prints the time of each phase.
#   bash scripts/check_catkin_workspace.sh        env: MIC_CHECK_KEEP=1 keeps the temporary folder
set -eo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
tmp="$(mktemp -d /tmp/mic_catkin_check.XXXXXX)"
ws="$tmp/home/observatory/field_station_software/catkin_workspace"
overlay="$tmp/home/observatory/field_station_software/consumer_workspace"
log="$tmp/log"
mkdir -p "$ws/src/magnetometer_insitu_calibration" "$overlay/src" "$log"
cleanup() {
  local status=$?
  if [ -n "${launch_pid:-}" ]; then kill -INT "$launch_pid" 2>/dev/null; wait "$launch_pid" 2>/dev/null; fi
  if [ "$status" -ne 0 ]; then echo "check_catkin_workspace: FAILED (logs in $log)" >&2
  elif [ -z "${MIC_CHECK_KEEP:-}" ]; then rm -rf "$tmp"; fi
}
trap cleanup EXIT
# Debian's ROS tools need /usr/bin/python3 (a pyenv python3 first on PATH breaks catkin).
export PATH="/usr/bin:$PATH"
t_start=$(date +%s)
phase() { echo "check_catkin_workspace: $1 ($(( $(date +%s) - t_start )) s)"; }
# The clean environment of a new shell: nothing sourced, a writable ROS_HOME, a host name that
# resolves, a master port of its own.
clean=(HOME="$tmp" PATH=/usr/bin:/bin LANG=C.UTF-8 ROS_HOME="$tmp/ros_home" ROS_LOG_DIR="$tmp/ros_home/log"
       ROS_HOSTNAME=localhost ROS_MASTER_URI="http://localhost:$((20000 + RANDOM % 20000))")
clean_env() { env -i "${clean[@]}" bash -c "source '$1' && $2"; }

# 1. The package, without build folders, into the workspace; catkin_make install.
tar -C "$here" --exclude=./build --exclude=./build_fuzz --exclude='./build_*' --exclude=./.git -cf - . |
  tar -C "$ws/src/magnetometer_insitu_calibration" -xf -
phase "workspace $ws"
(cd "$ws" && catkin_make -DCMAKE_BUILD_TYPE=Release -DCATKIN_ENABLE_TESTING=OFF -j"$(nproc)" install) \
  >"$log/catkin_make_install.log" 2>&1 || { tail -n 40 "$log/catkin_make_install.log" >&2; exit 1; }
phase "catkin_make install done"
for f in lib/magnetometer_insitu_calibration/calibrate_records lib/magnetometer_insitu_calibration/simulate_records \
         lib/magnetometer_insitu_calibration/lemi025_simulator lib/magnetometer_insitu_calibration/lemi025_driver \
         lib/magnetometer_insitu_calibration/calibration_node lib/magnetometer_insitu_calibration/correction_node \
         lib/magnetometer_insitu_calibration/records_to_bag lib/magnetometer_insitu_calibration/export_corrected \
         lib/magnetometer_insitu_calibration/plot_calibration lib/magnetometer_insitu_calibration/play_bag lib/libmagnetometer_insitu_calibration_core.so \
         lib/libmagnetometer_insitu_calibration_nodelets.so share/magnetometer_insitu_calibration/nodelets.xml \
         share/magnetometer_insitu_calibration/launch/include/lemi025_simulator.launch \
         share/magnetometer_insitu_calibration/config/calibration.yaml \
         share/magnetometer_insitu_calibration/data/wic20250514_fge.sec.gz \
         include/magnetometer_insitu_calibration/estimation/fd_wlse.hpp \
         include/magnetometer_insitu_calibration/MagnetometerCalibration.h; do
  [ -e "$ws/install/$f" ] || { echo "check_catkin_workspace: not installed: $f" >&2; exit 1; }
done

# 2. Another package against the install space only.
cp -a "$here/test/catkin_consumer" "$overlay/src/mic_core_consumer"
clean_env "$ws/install/setup.bash" "cd '$overlay' && catkin_make -DCMAKE_BUILD_TYPE=Release install" \
  >"$log/consumer.log" 2>&1 || { tail -n 40 "$log/consumer.log" >&2; exit 1; }
clean_env "$overlay/install/setup.bash" "rosrun mic_core_consumer estimate_tiny_record"
phase "consumer package built against the install space and run"

# 3. From the install space alone.
setup="$ws/install/setup.bash"
clean_env "$setup" 'pkg=$(rospack find magnetometer_insitu_calibration) && echo "rospack find: $pkg" &&
  case "$pkg" in */install/share/magnetometer_insitu_calibration) ;; *) echo "not the install space" >&2; exit 1;; esac &&
  rosrun magnetometer_insitu_calibration calibrate_records --reference "$pkg/data/wic20250514_lemi036.sec.gz" \
    --test "$pkg/data/wic20250514_fge.sec.gz" --intervals 4 --json "'"$tmp/wic.json"'"' \
  >"$log/calibrate_records.log" 2>&1 || { tail -n 40 "$log/calibrate_records.log" >&2; exit 1; }
/usr/bin/python3 - "$tmp/wic.json" <<'PY'
import json, sys
report = json.load(open(sys.argv[1]))
windows = report.get("windows") or report.get("intervals") or []
if len(windows) != 5:
    sys.exit("check_catkin_workspace: the WIC report holds %d windows, not 5" % len(windows))
agreement = report.get("window_agreement")
if not agreement or agreement.get("windows") != 4:
    sys.exit("check_catkin_workspace: the WIC report has no agreement of its 4 intervals: %r" % agreement)
print("check_catkin_workspace: WIC report, %d windows; %s" % (len(windows), agreement["text"]))
PY
phase "rosrun calibrate_records on the WIC demo"

run_station() {  # $1: extra roslaunch arguments
  local echo_log="$log/calibration_topic$2.log"
  clean[-1]="ROS_MASTER_URI=http://localhost:$((20000 + RANDOM % 20000))"  # a master of its own
  # Not through a function: $! is then roslaunch itself (env and bash exec it), which stops on SIGINT.
  env -i "${clean[@]}" bash -c "source '$setup' && exec roslaunch magnetometer_insitu_calibration simulated_station.launch speed:=100 \
      start:=2025-05-13T23:55:00Z duration:=3000 end_with_record:=false \
      'calibration_params:={input_period: 0.1, window: 1800, step: 600, band_low: 0.002, band_high: 0.05, silent_timeout: 30}' \
      reference_link:=$tmp/ros_home/reference_link test_link:=$tmp/ros_home/test_link \
      calibration_file:=$tmp/ros_home/calibration$2.yaml $1" >"$log/station$2.log" 2>&1 &
  launch_pid=$!
  # The first calibration message (30 min window at 100x: about 20 s after the drivers connect).
  if ! clean_env "$setup" "for i in \$(seq 150); do rosnode list >/dev/null 2>&1 && break; sleep 0.2; done
        timeout 180 rostopic echo -n 1 /test/calibration/quality_text" >"$echo_log" 2>&1; then
    kill -INT "$launch_pid" 2>/dev/null; wait "$launch_pid" 2>/dev/null || true; launch_pid=
    tail -n 30 "$log/station$2.log" "$echo_log" >&2
    exit 1
  fi
  kill -INT "$launch_pid"; wait "$launch_pid" 2>/dev/null || true; launch_pid=
  echo "check_catkin_workspace: /test/calibration quality_text $(head -n 1 "$echo_log")"
}
mkdir -p "$tmp/ros_home"
run_station "" ""
phase "roslaunch simulated_station.launch: calibration published"
run_station "nodelet_manager:=station_manager" "_nodelets"
phase "roslaunch simulated_station.launch nodelet_manager:=station_manager: calibration published"
echo "check_catkin_workspace: OK"
