#!/usr/bin/env bash
# Replay benchmark: calibration_node (and correction_node, as launch/replay.launch starts them) fed
# by `rosbag play --clock -r R` with /use_sim_time, at increasing rates R. Measures, per rate:
#   - dropped pairs, from the calibration node's own diagnostics counters after the replay: every
#     reference and test message played was received, every test message paired, none unpaired,
#     late or duplicate, and the expected number of windows queued and estimated (none dropped
#     because the worker was busy, none failed);
#   - the wall time of the replay (first to last /clock; "~": the player's launch to exit, an upper
#     bound, when the monitor was starved of CPU) and the rate achieved (stamp s played / wall s: rosbag play itself may not keep up), the calibration node's CPU
#     (/proc utime+stime, whole run including the last windows' estimates; as a fraction of one
#     core over the replay's wall time) and peak RSS; the correction node's CPU and counts.
# Prints a markdown table per bag; the highest R with "none" in the dropped column is the answer.
#
#   scripts/bench_replay.sh [BUILD_DIR]
#   env: RATES="1 10 50 100 200 500 1000 2000"  rates for the simulated 10 Hz bag
#        WALL=120      at most this many wall seconds per rate: the bag is played for
#                      min(whole bag, about R * WALL) stamp seconds (-u), rounded to whole steps
#        HOURS=4       length of the simulated 10 Hz pair (simulate_records, default settings, no
#                      gaps, no spikes; a LEMI-025 pair: decimated 10 Hz -> 1 Hz by the node)
#        WIC_RATES="500 2000"  rates for the 1 Hz bag of the real WIC pair in data/ ("" = skip)
#        CORRECTION=1  also run correction_node on the test stream (0: calibration_node only)
#        CAL_PARAMS="pairing_max_wait=3600"  more calibration_node parameters (name=value ...)
#        OUT=/tmp/bench_replay  bags (kept and reused), logs, per-run summaries
# Windows: 10 Hz bag window 3600 s step 600 s (a 4-hour bag completes 18 windows), WIC day window
# 21600 s step 3600 s (18 windows); a window is complete when the first sample after its end
# arrives, so the last one, ending with the bag, is not expected. Otherwise config/*.yaml.
# Own roscore on a private port (a running master is not disturbed). Needs calibration_node,
# correction_node, records_to_bag and simulate_records built in BUILD_DIR.
set -eo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$here/build}"
rates="${RATES:-1 10 50 100 200 500 1000 2000}"
wall="${WALL:-120}"
hours="${HOURS:-4}"
wic_rates="${WIC_RATES-500 2000}"
correction="${CORRECTION:-1}"
cal_params="${CAL_PARAMS:-}"
out="${OUT:-/tmp/bench_replay}"
mkdir -p "$out"
source "$build/devel/setup.bash"
set -u
source "$here/scripts/bench_ros_common.sh"
lib="$build/devel/lib/magnetometer_insitu_calibration"

# --- bags (no master needed) -------------------------------------------------------------------
sim_bag="$out/sim10_${hours}h.bag"
if [ ! -s "$sim_bag" ]; then
  "$lib/simulate_records" --out-dir "$out/sim10_${hours}h" --format csv --rate 10 \
    --days "$(/usr/bin/python3 -c "print($hours / 24)")" --gaps 0 --spikes-per-day 0 >"$out/simulate.log"
  "$lib/records_to_bag" --reference "$out/sim10_${hours}h/reference.csv" --test "$out/sim10_${hours}h/test.csv" \
    --output "$sim_bag.tmp" >"$out/records_to_bag_sim.log" 2>&1
  mv "$sim_bag.tmp" "$sim_bag"
fi
wic_bag="$out/wic20250514.bag"
if [ -n "$wic_rates" ] && [ ! -s "$wic_bag" ]; then
  "$lib/records_to_bag" --reference "$here/data/wic20250514_lemi036.sec.gz" --test "$here/data/wic20250514_fge.sec.gz" \
    --output "$wic_bag.tmp" >"$out/records_to_bag_wic.log" 2>&1
  mv "$wic_bag.tmp" "$wic_bag"
fi

# --- master ------------------------------------------------------------------------------------
bench_start_roscore "$out"
cal_pid= cor_pid= play_pid=
trap 'bench_stop $cal_pid $cor_pid $play_pid; bench_stop $bench_core_pid' EXIT
rosparam set /use_sim_time true
ref_topic=/reference/magnetic_field
test_topic=/test/magnetic_field

# run_rate BAG_LABEL BAG PERIOD WINDOW STEP RATE: one replay; prints one table row.
run_rate() {
  local label="$1" bag="$2" period="$3" window="$4" step="$5" rate="$6"
  local tag="${label}_r$rate" bag_span span
  bag_span=$(/usr/bin/python3 - "$bag" <<'PY'
import subprocess, sys, yaml
info = yaml.safe_load(subprocess.run(["rosbag", "info", "--yaml", sys.argv[1]], check=True, capture_output=True, text=True).stdout)
print("%.3f" % (info["end"] - info["start"]))
PY
)
  # Stamp seconds to play: the whole bag, or R * WALL; when windows can complete, rounded down to
  # whole steps plus 60 s (no window end near the last sample: the expected count is exact).
  span=$(/usr/bin/python3 -c "
b = $bag_span; s = $rate * $wall
print(('%.3f' % b) if s >= b else ('%d' % s) if s < $window + $step else '%d' % ((s - 60) // $step * $step + 60))")
  rm -f "$out/cal_$tag.yaml"
  rosparam delete /bench_calibration >/dev/null 2>&1 || true
  rosparam delete /bench_correction >/dev/null 2>&1 || true
  rosparam load "$here/config/calibration.yaml" /bench_calibration
  rosparam set /bench_calibration/reference_topic $ref_topic
  rosparam set /bench_calibration/test_topic $test_topic
  rosparam set /bench_calibration/test_name bench
  rosparam set /bench_calibration/calibration_topic /bench/calibration
  rosparam set /bench_calibration/calibration_file "$out/cal_$tag.yaml"
  rosparam set /bench_calibration/input_period "$period"
  rosparam set /bench_calibration/window "$window"
  rosparam set /bench_calibration/step "$step"
  local kv
  for kv in $cal_params; do rosparam set "/bench_calibration/${kv%%=*}" "${kv#*=}"; done
  "$lib/calibration_node" __name:=bench_calibration >"$out/calibration_$tag.log" 2>&1 &
  cal_pid=$!
  local pids="--pid calibration=$cal_pid"
  if [ "$correction" = 1 ]; then
    rosparam load "$here/config/correction.yaml" /bench_correction
    rosparam set /bench_correction/test_topic $test_topic
    rosparam set /bench_correction/calibration_topic /bench/calibration
    rosparam set /bench_correction/corrected_topic /bench/corrected
    rosparam set /bench_correction/calibration_file "$out/cal_$tag.yaml"
    "$lib/correction_node" __name:=bench_correction >"$out/correction_$tag.log" 2>&1 &
    cor_pid=$!
    pids="$pids --pid correction=$cor_pid"
  fi
  local duration_opt="-u $span"  # the whole bag: no -u
  [ "$(/usr/bin/python3 -c "print(int($span >= $bag_span))")" = 1 ] && duration_opt=
  local load_before
  load_before=$(cut -d' ' -f1 /proc/loadavg)
  # The player and options of launch/replay.launch (rosrun execs the player: $play_pid is its pid).
  # Launch the player once both nodes have subscribed (their start-up is not timed).
  /usr/bin/python3 - "$correction" <<'PY' || true
import os, sys, time, xmlrpc.client
master = xmlrpc.client.ServerProxy(os.environ["ROS_MASTER_URI"])
want = {("/reference/magnetic_field", "/bench_calibration"), ("/test/magnetic_field", "/bench_calibration")}
if sys.argv[1] == "1":
    want.add(("/test/magnetic_field", "/bench_correction"))
for _ in range(300):
    subs = {(topic, node) for topic, nodes in master.getSystemState("/bench")[2][1] for node in nodes}
    if want <= subs:
        break
    time.sleep(0.05)
PY
  local t_launch
  t_launch=$(date +%s.%N)
  rosrun rosbag play --clock --rate "$rate" --start 0 --delay 1 --queue 100000 --wait-for-subscribers $duration_opt \
    "$bag" --topics $ref_topic $test_topic >/dev/null 2>"$out/play_$tag.log" &
  play_pid=$!
  /usr/bin/python3 "$here/benchmark/ros/bench_monitor.py" $pids --pid play=$play_pid --wait-pid $play_pid --interval 0.5 --settle 8 --clock \
    --status-prefix bench_ --csv "$out/proc_$tag.csv" --json "$out/summary_$tag.json" >"$out/monitor_$tag.log" 2>&1 || true
  wait $play_pid || true
  play_pid=
  bench_stop $cal_pid $cor_pid
  cal_pid= cor_pid=
  /usr/bin/python3 - "$out/summary_$tag.json" "$bag" "$span" "$period" "$window" "$step" "$rate" "$load_before" "$t_launch" <<'PY'
import json, math, subprocess, sys, yaml
s = json.load(open(sys.argv[1])); bag = sys.argv[2]
span, period, window, step, rate = (float(x) for x in sys.argv[3:8]); load = sys.argv[8]; t_launch = float(sys.argv[9])
info = yaml.safe_load(subprocess.run(["rosbag", "info", "--yaml", bag], check=True, capture_output=True, text=True).stdout)
counts = {t["topic"]: t["messages"] for t in info["topics"]}
bag_span = info["end"] - info["start"]
if span >= bag_span - 1e-6:  # whole bag
    expected = {t: counts[t] for t in ("/reference/magnetic_field", "/test/magnetic_field")}
    last = bag_span
else:  # -u span plays stamps start .. start + span inclusive (regular grid from the bag start)
    n = int(math.floor(span / period + 1e-6)) + 1
    expected = {t: min(n, counts[t]) for t in ("/reference/magnetic_field", "/test/magnetic_field")}
    last = (n - 1) * period
# Windows [k step, k step + window) (bag start = a whole step) over the pipeline's epochs: at
# 10 Hz the decimated 1 Hz epochs start and end one FIR half width (4 sigma, about 4 s) inside
# the input; the first window starts at the first epoch, or the next whole step.
lag = 4.0 if period < 0.99 else 0.0
first_k = int(math.ceil((lag - 0.5) / step - 1e-9))
last_k = int(math.floor((last - lag - window + 0.5) / step + 1e-9))
windows = max(0, last_k - first_k + 1)
d = s["diagnostics"]
ch = next((v for v in d.values() if "test topic" in v and "paired" in v), {})
ref = next((v for v in d.values() if "stamp jumps forward" in v and "test topic" not in v), {})
cor = next((v for v in d.values() if "corrected topic" in v), {})
g = lambda v, k: int(float(v.get(k, -1)))
ref_rx, test_rx = g(ref, "messages"), g(ch, "test messages")
bad = {k: g(ch, k) for k in ("unpaired reference", "unpaired test", "late", "duplicates", "invalid stamps")}
queued, estimated = g(ch, "windows queued"), g(ch, "windows estimated")
dropped_w, failed = g(ch, "windows dropped (worker busy)"), g(ch, "windows failed")
problems = []
if ref_rx != expected["/reference/magnetic_field"]: problems.append("reference %d/%d received" % (ref_rx, expected["/reference/magnetic_field"]))
if test_rx != expected["/test/magnetic_field"]: problems.append("test %d/%d received" % (test_rx, expected["/test/magnetic_field"]))
problems += ["%s %d" % (k, v) for k, v in bad.items() if v != 0]
if g(ch, "paired") != min(ref_rx, test_rx) - bad["unpaired reference"] - bad["unpaired test"]: pass
if queued != windows or estimated != windows: problems.append("windows %d queued, %d estimated of %d" % (queued, estimated, windows))
if dropped_w: problems.append("%d windows dropped (worker busy)" % dropped_w)
if failed: problems.append("%d windows failed" % failed)
# Replay wall time: between the first and last /clock of the replay as the monitor saw them; when
# the monitor was starved of CPU (it saw less than the whole replay, or much faster than the
# player ran), "~" and the time from the player's launch (the nodes subscribed) to its exit, less
# its 1 s --delay (its set-up and about 1 s of shutdown included: an upper bound).
cal = s["nodes"]["calibration"]
clk = s.get("clock", {})
wall_launch = (s.get("publisher_end_time") or float("nan")) - t_launch - 1.0
wall, mark = clk.get("wall_s") or float("nan"), ""
if not (clk.get("sim_s", 0) >= 0.99 * (last - 1) and wall >= wall_launch - 3.0):
    wall, mark = wall_launch, "~"
achieved = span / wall
corr = s["nodes"].get("correction")
corr_txt = "-" if corr is None else "%.2f; %s / %s" % (corr["cpu_s_total"] / wall, cor.get("published", "?"), cor.get("received", "?"))
play = s["nodes"].get("play")
print("| %g | %.0f | %s%.1f | %s%.0f | %d / %d | %s / %s | %d / %d | %.2f | %.2f | %.0f | %s | %s | %s | %s |" % (
    rate, span, mark, wall, mark, achieved, test_rx, expected["/test/magnetic_field"], ch.get("paired", "?"), expected["/test/magnetic_field"],
    estimated, windows, cal["cpu_s_total"], cal["cpu_s_total"] / wall, cal["rss_kB_max"] / 1024, corr_txt,
    "-" if play is None else "%.2f" % (play["cpu_s_total"] / wall),
    "none" if not problems else "**" + "; ".join(problems) + "**", load))
PY
}

header() {
  echo
  echo "$1"
  echo
  echo "| rate R (x real time) | stamp s played | replay wall s | achieved rate | test msgs received / played | paired / played | windows estimated / expected | calibration_node CPU s | CPU (cores) | RSS max (MB) | correction_node CPU (cores); corrected / received | rosbag play CPU (cores) | dropped | load (1 min) before |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
}

header "Simulated 10 Hz pair (LEMI-025-like), $hours h, window 3600 s step 600 s, input_period 0.1: $(basename "$sim_bag")"
for r in $rates; do run_rate sim10 "$sim_bag" 0.1 3600 600 "$r"; done
if [ -n "$wic_rates" ]; then
  header "Real WIC pair 2025-05-14 (1 Hz, LEMI-036 / DTU FGE), window 21600 s step 3600 s: $(basename "$wic_bag")"
  for r in $wic_rates; do run_rate wic "$wic_bag" 1.0 21600 3600 "$r"; done
fi
echo
echo "$(uname -n), $(nproc) cores, $(bench_load) at the end, $(date -u +%Y-%m-%dT%H:%MZ)"
