#!/usr/bin/env bash
# Runs the ctest suite N times and prints, per test, in how many runs it failed: the check that
# the suite does not flake. Without --fresh-clones it does NOT build: build first (bash
# scripts/run_tests.sh once, or scripts/build.sh tests all); it stops if build/ has no tests.
#
#   bash scripts/stress_tests.sh N [--fresh-clones] [--hog K] [--ptys] [--logs DIR] [-- CTEST_ARGS...]
#
#   N            number of runs of the test command's ctest (scripts/ctest_two_cores.sh)
#   --fresh-clones  each run is the README's whole test command (scripts/run_tests.sh: install
#                check, build, every test) on a new clone of this checkout's HEAD, as CI runs
#                it; the clone is removed after its run (its log is kept)
#   --hog K      beside K busy-loop processes (each keeps one core busy), started before the
#                first run and stopped at the end (by their process ids)
#   --ptys       beside a process that opens a pseudo-terminal every 0.1 s and keeps each 20 s
#                (another program's ptys take freed pty numbers: what once made the driver
#                rostests fail when one test's stale link named the other test's pty)
#   --logs DIR   where each run's output goes (run_<i>.log); default a new mktemp -d folder
#   -- ARGS      more ctest arguments, e.g. -- -R 'lemi025_driver|faults_driver' for a subset
#
# Output: one line per run (exit status, wall seconds, failed tests), then a table "failed
# runs / runs" per test that failed at least once. Exit status 0 only when every test passed
# in every run (and every run found tests).
#
# Examples: bash scripts/stress_tests.sh 5 --hog 2         # five built-suite runs beside two hogs
#           bash scripts/stress_tests.sh 5 --fresh-clones  # the test command on five new clones
set -uo pipefail
cd "$(dirname "$0")/.."

usage() { sed -n '2,21p' "$0" >&2; exit 2; }
[[ $# -ge 1 && "$1" =~ ^[0-9]+$ && "$1" -ge 1 ]] || usage
runs=$1
shift
hogs=0
ptys=0
fresh=0
logs=""
extra=()
while [[ $# -gt 0 ]]; do
  case "$1" in
    --hog) [[ $# -ge 2 && "$2" =~ ^[0-9]+$ ]] || usage; hogs=$2; shift 2 ;;
    --ptys) ptys=1; shift ;;
    --fresh-clones) fresh=1; shift ;;
    --logs) [[ $# -ge 2 ]] || usage; logs=$2; shift 2 ;;
    --) shift; extra=("$@"); break ;;
    *) usage ;;
  esac
done

if [[ $fresh -eq 0 ]] && [[ ! -f build/CTestTestfile.cmake || ! -f build/devel/setup.bash ]]; then
  echo "stress_tests.sh: no build/ with tests: build first (bash scripts/run_tests.sh)" >&2
  exit 2
fi
if [[ $fresh -eq 0 ]]; then
  # setup.bash reads unset variables: source it before set -u matters (ros1-on-debian.md).
  set +u
  source build/devel/setup.bash
  set -u
fi
logs=${logs:-$(mktemp -d /tmp/stress_tests.XXXXXX)}
mkdir -p "$logs"

hog_pids=()
stop_hogs() {
  local pid
  for pid in "${hog_pids[@]}"; do kill "$pid" 2>/dev/null; done
  for pid in "${hog_pids[@]}"; do wait "$pid" 2>/dev/null; done
  hog_pids=()
}
trap stop_hogs EXIT
trap 'exit 130' INT TERM
for ((h = 0; h < hogs; ++h)); do
  bash -c 'while :; do :; done' &
  hog_pids+=($!)
done
if [[ $ptys -eq 1 ]]; then
  /usr/bin/python3 -c '
import os, time
held = []
while True:
    held.append((time.time(),) + os.openpty())
    while time.time() - held[0][0] > 20.0:
        _, m, s = held.pop(0); os.close(m); os.close(s)
    time.sleep(0.1)' &
  hog_pids+=($!)
fi

declare -A failed_runs=()
any_failed=0
what="ctest -j3 (two cores) ${extra[*]:-}"
((fresh)) && what="the test command on a fresh clone"
echo "stress_tests.sh: $runs run(s) of $what beside $hogs busy loop(s)$( ((ptys)) && echo " and a pty churn"); logs in $logs"
for ((i = 1; i <= runs; ++i)); do
  log="$logs/run_$i.log"
  # A fresh ROS_HOME per run: logs and pty links of one run never meet the next's.
  ROS_HOME=$(mktemp -d "$logs/ros_home_$i.XXXXXX")
  export ROS_HOME ROS_LOG_DIR="$ROS_HOME/log" ROS_HOSTNAME=localhost
  start=$(date +%s)
  if ((fresh)); then
    clone=$(mktemp -d /tmp/stress_clone.XXXXXX)
    git clone -q "$PWD" "$clone/repo" && (cd "$clone/repo" && bash scripts/run_tests.sh) > "$log" 2>&1
    status=$?
    rm -rf "$clone"
  else
    bash scripts/ctest_two_cores.sh "${extra[@]}" > "$log" 2>&1
    status=$?
  fi
  seconds=$(( $(date +%s) - start ))
  # ctest prints "  1/53 Test #38: <name> ....***Failed  12.3 sec" (also ***Timeout, ***Exception).
  failed=$(sed -n 's/^ *[0-9]*\/[0-9]* Test *#[0-9]*: \([^ ]*\) .*\*\*\*.*/\1/p' "$log" | sort -u)
  if [[ $status -ne 0 && -z "$failed" ]]; then failed="(ctest exit $status, no test named: see $log)"; fi
  while IFS= read -r t; do
    [[ -n "$t" ]] && failed_runs[$t]=$(( ${failed_runs[$t]:-0} + 1 ))
  done <<< "$failed"
  [[ $status -ne 0 || -n "$failed" ]] && any_failed=1
  echo "run $i/$runs: exit $status, ${seconds} s, failed: $(echo "${failed:-none}" | tr '\n' ' ')"
done

echo
if [[ $any_failed -eq 0 ]]; then
  echo "every test passed in all $runs run(s)"
  exit 0
fi
echo "failed runs / runs, per test:"
for t in "${!failed_runs[@]}"; do printf '  %3d / %d  %s\n' "${failed_runs[$t]}" "$runs" "$t"; done | sort -rn
exit 1
