#!/usr/bin/env bash
# Short fuzzing pass over every reader of outside bytes (fuzz/README.md): builds the libFuzzer
# targets with clang + ASan + UBSan (fuzz/build_fuzzers.sh, apart from the catkin build), replays
# the regression inputs in fuzz/regressions/<target>/, then fuzzes each target for
# MIC_FUZZ_SECONDS (default 15) from its committed seed corpus (fuzz/corpus/<target>/, not
# modified: new inputs go to a temporary directory). Exits non-zero if any target crashes,
# leaks, hangs, or fails a check; the crashing input is kept under $MIC_FUZZ_OUT/artifacts.
#
# Environment: MIC_FUZZ_SECONDS (per target), MIC_FUZZ_PARALLEL (targets at once, default 2:
# the machine has 2 cores; use 1 when something else runs),
# MIC_FUZZ_BUILD_DIR (default <package>/build_fuzz), MIC_FUZZ_OUT (default a new temp dir),
# MIC_FUZZ_TARGETS (space-separated subset, default all).
set -uo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
seconds="${MIC_FUZZ_SECONDS:-15}"
parallel="${MIC_FUZZ_PARALLEL:-2}"
out="${MIC_FUZZ_OUT:-$(mktemp -d /tmp/mic_fuzz.XXXXXX)}"
mkdir -p "$out/artifacts"
start=$(date +%s)

build="$(bash "$root/fuzz/build_fuzzers.sh" "${MIC_FUZZ_BUILD_DIR:-$root/build_fuzz}" 2>"$out/build.log" | tail -n 1)"
if [ -z "$build" ] || [ ! -f "$build/fuzz_targets.txt" ]; then
  cat "$out/build.log" >&2
  echo "run_fuzz_short: build failed" >&2
  exit 1
fi
built=$(date +%s)
echo "run_fuzz_short: built in $((built - start)) s ($build); ${seconds} s per target, $parallel at a time; logs in $out"

targets="${MIC_FUZZ_TARGETS:-$(cat "$build/fuzz_targets.txt")}"

# Common libFuzzer options: bounded input size and time per input, memory cap, leak checks.
fuzz_options=(-max_len=16384 -timeout=10 -rss_limit_mb=2048 -print_final_stats=1)

run_target() {  # name -> exit status of the replay and the fuzzing run
  local name="$1" exe="$build/fuzz_$1" log="$out/$1.log" status=0
  local dict="$root/fuzz/dicts/$1.dict" dict_option=()
  [ -f "$dict" ] && dict_option=(-dict="$dict")
  : >"$log"
  # 1. Regressions: every input that once crashed must now pass (plain replay, no fuzzing).
  if compgen -G "$root/fuzz/regressions/$1/*" >/dev/null; then
    "$exe" -runs=1 "$root"/fuzz/regressions/"$1"/* >>"$log" 2>&1 || status=$?
  fi
  # 2. Fuzzing from the committed seeds; new inputs go to a scratch corpus.
  if [ "$status" -eq 0 ]; then
    mkdir -p "$out/corpus/$1"
    "$exe" "${fuzz_options[@]}" "${dict_option[@]}" -max_total_time="$seconds" \
      -artifact_prefix="$out/artifacts/$1-" "$out/corpus/$1" "$root/fuzz/corpus/$1" >>"$log" 2>&1 || status=$?
  fi
  return "$status"
}

summary() {  # name status -> one line: executions, coverage, features
  local log="$out/$1.log" execs cov ft
  execs=$(grep -o 'stat::number_of_executed_units: [0-9]*' "$log" | tail -n 1 | awk '{print $2}')
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -n 1 | awk '{print $2}')
  ft=$(grep -o 'ft: [0-9]*' "$log" | tail -n 1 | awk '{print $2}')
  if [ "$2" -eq 0 ]; then
    printf '  %-24s ok      execs %-9s cov %-5s ft %s\n' "$1" "${execs:-?}" "${cov:-?}" "${ft:-?}"
  else
    printf '  %-24s FAILED  (exit %s) see %s\n' "$1" "$2" "$log"
    grep -E 'ERROR: |FUZZ CHECK FAILED|SUMMARY: |Test unit written|runtime error' "$log" | head -n 8 | sed 's/^/      /'
  fi
}

passed=0
failed=0
for name in $targets; do
  [ -x "$build/fuzz_$name" ] || continue
  ( status=0; run_target "$name" || status=$?; echo "$status" >"$out/$name.status" ) &
  while [ "$(jobs -rp | wc -l)" -ge "$parallel" ]; do wait -n || true; done
done
wait
for name in $targets; do
  if [ ! -x "$build/fuzz_$name" ]; then
    echo "  $name: not built (see $out/build.log)"
    failed=$((failed + 1))
    continue
  fi
  status="$(cat "$out/$name.status" 2>/dev/null || echo 1)"
  summary "$name" "$status"
  if [ "$status" -eq 0 ]; then passed=$((passed + 1)); else failed=$((failed + 1)); fi
done
echo "run_fuzz_short: $(( $(date +%s) - start )) s in all (build $((built - start)) s)"
echo "fuzz: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
