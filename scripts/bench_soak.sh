#!/usr/bin/env bash
# Soak: a simulated station (reference + one test instrument at 1 Hz, core simulator) played at
# SPEED times real time for DAYS days of stamps into calibration_node (realistic window 86400 s,
# step 3600 s) and correction_node. RSS and CPU of both nodes are sampled from /proc every
# INTERVAL s; at the end their diagnostics say whether every sample was received, paired and
# corrected and every window estimated (none dropped). Prints a markdown summary.
#   SPEED=2880 DAYS=30 scripts/bench_soak.sh [BUILD_DIR]
# 30 days at 2880x is 15 min of wall time. Own roscore on a private port. Results in $OUT
# (default /tmp/bench_soak): proc.csv (RSS/CPU series), summary.json, node logs.
set -eo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-/tmp/build_faults}"
speed="${SPEED:-2880}"
days="${DAYS:-30}"
interval="${INTERVAL:-10}"
out="${OUT:-/tmp/bench_soak}"
mkdir -p "$out"
rm -f "$out"/calibration.yaml
source "$build/devel/setup.bash"
set -u
source "$here/scripts/bench_build_publisher.sh"
bench_start_roscore "$out"  # scripts/bench_ros_common.sh
core_pid=$bench_core_pid
cleanup() { kill ${cal_pid:-} ${cor_pid:-} 2>/dev/null || true; kill "$core_pid" 2>/dev/null || true; wait 2>/dev/null || true; }
trap cleanup EXIT
lib="$build/devel/lib/magnetometer_insitu_calibration"
share="$here/config"
rosparam load "$share/calibration.yaml" /soak_calibration
rosparam load "$share/correction.yaml" /soak_correction
rosparam set /soak_calibration/reference_topic /soak/reference
rosparam set /soak_calibration/test_topic /soak/test_0
rosparam set /soak_calibration/test_name soak
rosparam set /soak_calibration/calibration_topic /soak/calibration
rosparam set /soak_calibration/calibration_file "$out/calibration.yaml"
rosparam set /soak_calibration/silent_timeout 60
rosparam set /soak_correction/test_topic /soak/test_0
rosparam set /soak_correction/calibration_topic /soak/calibration
rosparam set /soak_correction/corrected_topic /soak/corrected
rosparam set /soak_correction/calibration_file "$out/calibration.yaml"
rosparam set /soak_correction/check_frame_id false
"$lib/calibration_node" __name:=soak_calibration >"$out/calibration.log" 2>&1 &
cal_pid=$!
"$lib/correction_node" __name:=soak_correction >"$out/correction.log" 2>&1 &
cor_pid=$!
start=1747180800
duration=$((days * 86400))
"$publisher" --pairs 1 --period 1 --speed "$speed" --duration "$duration" --record 86400 --start $start \
  --reference-topic /soak/reference --test-prefix /soak/test_ >"$out/publisher.log" 2>&1 &
pub_pid=$!
/usr/bin/python3 "$here/benchmark/ros/bench_monitor.py" --pid calibration=$cal_pid --pid correction=$cor_pid --wait-pid $pub_pid \
  --interval "$interval" --settle 30 --status-prefix soak_ --csv "$out/proc.csv" --json "$out/summary.json" >"$out/monitor.log" 2>&1 || true
wait "$pub_pid" || true
/usr/bin/python3 - "$out/summary.json" "$out/publisher.log" "$duration" "$speed" <<'PY'
import json, re, sys
s = json.load(open(sys.argv[1])); pub = open(sys.argv[2]).read(); duration = int(sys.argv[3]); speed = sys.argv[4]
m = re.search(r"published (\d+) samples per topic .* in ([\d.]+) s wall, (\d+) ticks late", pub)
ticks = int(m.group(1)) if m else -1
d = s["diagnostics"]
cal = next((v for k, v in d.items() if "test topic" in v and "paired" in v), {})
ref = next((v for k, v in d.items() if "stamp jumps forward" in v and "test topic" not in v), {})
cor = next((v for k, v in d.items() if "corrected topic" in v), {})
# Windows [k 3600, k 3600 + 86400) complete when a sample after their end arrives.
expected_windows = (duration - 86400) // 3600
print("Soak: %d days of 1 Hz stamps at %sx real time, %s s wall (publisher %s ticks late)" %
      (duration // 86400, speed, m.group(2) if m else "?", m.group(3) if m else "?"))
print()
print("| | calibration_node | correction_node |")
print("|---|---|---|")
for key, label in (("rss_kB_first", "RSS first (MB)"), ("rss_kB_max", "RSS max (MB)"), ("rss_kB_last", "RSS last (MB)"),
                   ("rss_kB_growth_second_half", "RSS growth, 2nd half (MB)")):
    print("| %s | %.1f | %.1f |" % (label, s["nodes"]["calibration"][key] / 1024, s["nodes"]["correction"][key] / 1024))
print("| CPU (cores) | %.2f | %.2f |" % (s["nodes"]["calibration"]["cpu_fraction_of_one_core"], s["nodes"]["correction"]["cpu_fraction_of_one_core"]))
print()
g = lambda v, k: v.get(k, "?")
print("- published per topic: %d; reference received %s; test received %s; paired %s; unpaired ref/test %s/%s; late %s; duplicates %s" %
      (ticks, g(ref, "messages"), g(cal, "test messages"), g(cal, "paired"), g(cal, "unpaired reference"), g(cal, "unpaired test"), g(cal, "late"), g(cal, "duplicates")))
print("- windows: expected about %d; queued %s, estimated %s, accepted %s, flagged %s, failed %s, dropped (worker busy) %s, pending %s" %
      (expected_windows, g(cal, "windows queued"), g(cal, "windows estimated"), g(cal, "windows accepted"), g(cal, "windows flagged"),
       g(cal, "windows failed"), g(cal, "windows dropped (worker busy)"), g(cal, "windows pending")))
print("- correction: received %s, published %s, dropped no calibration %s, adopted %s, rejected %s" %
      (g(cor, "received"), g(cor, "published"), g(cor, "dropped, no calibration"), g(cor, "calibrations adopted"), g(cor, "calibrations rejected")))
PY
