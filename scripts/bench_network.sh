#!/usr/bin/env bash
# Network benchmark: ONE calibration_node (its ~tests list) calibrating N simulated test
# instruments against one reference, all at 10 Hz real time (benchmark/ros/bench_publisher, core
# simulator). For each N: the node's CPU (fraction of one core, /proc utime+stime over the run)
# and RSS, and its diagnostics counters (every test message received and paired, nothing
# unpaired, late or duplicated). Prints a markdown table; the largest N with CPU < 1 core and
# no dropped pair is what one core sustains.
#   scripts/bench_network.sh [BUILD_DIR] ["50 100 200"] [DURATION_S]
# Uses its own roscore on a private port (does not disturb a running master). Results in
# $OUT (default /tmp/bench_network).
set -eo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-/tmp/build_faults}"
counts="${2:-50 100 200}"
duration="${3:-60}"
out="${OUT:-/tmp/bench_network}"
mkdir -p "$out"
source "$build/devel/setup.bash"
set -u
source "$here/scripts/bench_build_publisher.sh"
bench_start_roscore "$out"  # scripts/bench_ros_common.sh
core_pid=$bench_core_pid
cleanup() { [ -n "${node_pid:-}" ] && kill "$node_pid" 2>/dev/null || true; kill "$core_pid" 2>/dev/null || true; wait 2>/dev/null || true; }
trap cleanup EXIT
node_bin="$build/devel/lib/magnetometer_insitu_calibration/calibration_node"
echo "| pairs | node CPU (cores) | CPU per pair (% of a core) | RSS (MB) | RSS per pair (MB) | test msgs received / published | unpaired+late+dup | dropped pairs |"
echo "|---|---|---|---|---|---|---|---|"
for n in $counts; do
  params="$out/params_$n.yaml"
  {
    echo "reference_topic: /bench/reference"
    echo "input_period: 0.1"
    echo "window: 86400"
    echo "step: 3600"
    echo "silent_timeout: 30"
    echo "tests:"
    for i in $(seq 0 $((n - 1))); do
      echo "  - {name: t$i, topic: /bench/test_$i, calibration_file: $out/cal_${n}_$i.yaml}"
    done
  } >"$params"
  rosparam delete /bench_calibration >/dev/null 2>&1 || true
  rosparam load "$params" /bench_calibration
  "$node_bin" __name:=bench_calibration >"$out/node_$n.log" 2>&1 &
  node_pid=$!
  "$publisher" --pairs "$n" --period 0.1 --speed 1 --duration "$duration" --record 3600 >"$out/publisher_$n.log" 2>&1 &
  pub_pid=$!
  /usr/bin/python3 "$here/benchmark/ros/bench_monitor.py" --pid calibration=$node_pid --wait-pid $pub_pid --interval 2 --settle 4 \
    --status-prefix "bench_calibration" --csv "$out/proc_$n.csv" --json "$out/summary_$n.json" >"$out/monitor_$n.log" 2>&1 || true
  wait "$pub_pid" || true
  kill "$node_pid"; wait "$node_pid" 2>/dev/null || true; node_pid=
  /usr/bin/python3 - "$out/summary_$n.json" "$out/publisher_$n.log" "$n" <<'PY'
import json, re, sys
s = json.load(open(sys.argv[1])); pub = open(sys.argv[2]).read(); n = int(sys.argv[3])
m = re.search(r"published (\d+) samples per topic .* (\d+) ticks late", pub)
ticks = int(m.group(1)) if m else -1
node = s["nodes"]["calibration"]
chans = {k: v for k, v in s["diagnostics"].items() if "test topic" in v}
received = sum(int(v["test messages"]) for v in chans.values())
bad = sum(int(v["unpaired reference"]) + int(v["unpaired test"]) + int(v["late"]) + int(v["duplicates"]) for v in chans.values())
dropped = sum(1 for v in chans.values() if int(v["test messages"]) != ticks or int(v["unpaired test"]) or int(v["late"]))
dropped += n - len(chans)
cpu = node["cpu_fraction_of_one_core"]; rss = node["rss_kB_max"] / 1024
print("| %d | %.2f | %.2f | %.0f | %.2f | %d / %d | %d | %d%s |" % (n, cpu, 100 * cpu / n, rss, rss / n, received, ticks * n, bad, dropped,
      "" if m and int(m.group(2)) == 0 else " (publisher late %s)" % (m.group(2) if m else "?")))
PY
done
