#!/usr/bin/env bash
# Correction latency benchmark: time from a raw test sample's publication (steady/wall clock just
# before publish()) to the arrival of its corrected sample on the corrected topic, through a real
# correction_node (config/correction.yaml) and roscpp TCP (tcp_nodelay both ways), at the live
# LEMI-025 rate of 10 Hz. benchmark/ros/bench_correction_probe publishes an accepted calibration
# and the test samples, subscribes to the corrected topic and matches samples by stamp; it
# prints median, 90th and 99th percentile and maximum (ms) and counts lost samples.
# Cases (LOAD_PAIRS): 0 = the correction node alone; N > 0 = the same while one calibration_node
# takes N simulated 10 Hz pairs in real time (benchmark/ros/bench_publisher, as
# scripts/bench_network.sh), i.e. a loaded station computer. Transports (MODES): tcp = the
# correction_node executable, a separate process; nodelet = the correction_node nodelet (the same
# class) loaded into the probe's own process, which is its nodelet manager: in-process, no TCP.
# Prints a markdown table with the correction's CPU (tcp: the correction_node process; nodelet:
# the probe's process, probe included) and the load average.
#
#   scripts/bench_correction_latency.sh [BUILD_DIR]
#   env: LOAD_PAIRS="0 50"  MODES="tcp nodelet"  DURATION=120 (timed s per case, after a 5 s
#        warm-up)  RATE=10 (Hz)  OUT=/tmp/bench_correction_latency (logs, per-sample CSV
#        latencies_<mode>_<pairs>.csv)  DEVEL=<devel space> (default BUILD_DIR/devel; a catkin
#        workspace's devel/ with BUILD_DIR its build/)
# Own roscore on a private port (a running master is not disturbed). Needs calibration_node and
# correction_node built in BUILD_DIR; the probe and publisher are compiled on demand
# (scripts/bench_ros_common.sh).
set -eo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$here/build}"
loads="${LOAD_PAIRS:-0 50}"
modes="${MODES:-tcp nodelet}"
devel="${DEVEL:-$build/devel}"
duration="${DURATION:-120}"
rate="${RATE:-10}"
out="${OUT:-/tmp/bench_correction_latency}"
mkdir -p "$out"
source "$devel/setup.bash"
set -u
source "$here/scripts/bench_ros_common.sh"
lib="$devel/lib/magnetometer_insitu_calibration"
probe=$(bench_build_ros bench_correction_probe -lnodeletlib)
publisher=$(bench_build_ros bench_publisher)

bench_start_roscore "$out"
cor_pid= cal_pid= pub_pid= probe_pid=
trap 'bench_stop $probe_pid $cor_pid $cal_pid $pub_pid; bench_stop $bench_core_pid' EXIT
cpu_s() { awk '{print ($14 + $15) / '"$(getconf CLK_TCK)"'}' "/proc/$1/stat"; }

rosparam load "$here/config/correction.yaml" /probe_correction
rosparam set /probe_correction/test_topic /probe/test
rosparam set /probe_correction/corrected_topic /probe/corrected
rosparam set /probe_correction/calibration_topic /probe/calibration

echo "| transport | load | samples timed | lost | median (ms) | p90 (ms) | p99 (ms) | max (ms) | probe late ticks | correction CPU (% of a core) | load average 1/5/15 min during |"
echo "|---|---|---|---|---|---|---|---|---|---|---|"
for mode in $modes; do
for n in $loads; do
  probe_args=()
  if [ "$mode" = nodelet ]; then
    probe_args=(--load-nodelet /probe_correction)
    cor_pid=
  else
    "$lib/correction_node" __name:=probe_correction >"$out/correction_${mode}_$n.log" 2>&1 &
    cor_pid=$!
  fi
  label="correction alone"
  if [ "$n" -gt 0 ]; then
    label="+ calibration_node with $n pairs at 10 Hz"
    {
      echo "reference_topic: /bench/reference"
      echo "input_period: 0.1"
      echo "silent_timeout: 30"
      echo "tests:"
      for i in $(seq 0 $((n - 1))); do
        echo "  - {name: t$i, topic: /bench/test_$i, calibration_file: $out/cal_${n}_$i.yaml}"
      done
    } >"$out/params_$n.yaml"
    rosparam delete /bench_calibration >/dev/null 2>&1 || true
    rosparam load "$out/params_$n.yaml" /bench_calibration
    "$lib/calibration_node" __name:=bench_calibration >"$out/calibration_$n.log" 2>&1 &
    cal_pid=$!
    "$publisher" --pairs "$n" --period 0.1 --speed 1 --duration $((duration + 60)) --record 3600 >"$out/publisher_$n.log" 2>&1 &
    pub_pid=$!
    sleep 10  # connections made, the load running
  fi
  sleep 2
  t0=$(date +%s.%N)
  "$probe" --rate "$rate" --duration "$duration" --warmup 5 --csv "$out/latencies_${mode}_$n.csv" "${probe_args[@]}" \
    >"$out/probe_${mode}_$n.log" 2>&1 &
  probe_pid=$!
  watched=${cor_pid:-$probe_pid}
  c0=$(cpu_s $watched)
  # CPU over the run: sampled until the probe exits (its own process is gone at the end).
  c1=$c0
  while kill -0 $probe_pid 2>/dev/null; do c1=$(cpu_s $watched 2>/dev/null || echo $c1); sleep 0.5; done
  wait $probe_pid || true
  t1=$(date +%s.%N)
  load=$(cut -d' ' -f1-3 /proc/loadavg)
  bench_stop $pub_pid $cal_pid $cor_pid
  pub_pid= cal_pid= cor_pid=
  /usr/bin/python3 - "$out/probe_${mode}_$n.log" "$label" "$c0" "$c1" "$t0" "$t1" "$load" "$mode" <<'PY'
import re, sys
text = open(sys.argv[1]).read()
m = re.search(r"latency_ms (.*)", text)
if not m:
    print("| %s | %s | probe failed: %s |" % (sys.argv[8], sys.argv[2], text.strip().splitlines()[-1] if text.strip() else "no output"))
    sys.exit(0)
v = dict(kv.split("=") for kv in m.group(1).split())
cpu = 100 * (float(sys.argv[4]) - float(sys.argv[3])) / (float(sys.argv[6]) - float(sys.argv[5]))
print("| %s | %s | %s | %s | %s | %s | %s | %s | %s | %.2f | %s |" % (sys.argv[8], sys.argv[2], v["samples"], v["lost"], v["median"],
      v["p90"], v["p99"], v["max"], v["late_ticks"], cpu, sys.argv[7]))
PY
done
done
echo
echo "$(uname -n), $(nproc) cores, rate $rate Hz, $duration s timed per case, $(date -u +%Y-%m-%dT%H:%MZ)"
