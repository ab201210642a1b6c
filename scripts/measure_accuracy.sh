#!/usr/bin/env bash
# Measures the README's "Measured accuracy" figures again with the current build: every row's and
# bullet's Monte Carlo command, exactly as the README and docs/accuracy.md give it (the seeds, days
# and knobs there), each one's whole output in OUT_DIR/<name>.txt and its summary (the lines that
# are not per-seed lines) printed at the end. The README's figures are copied from these outputs.
#
#   bash scripts/measure_accuracy.sh [BUILD_DIR=build] [OUT_DIR=build/accuracy] [NAMES...]
#
# NAMES picks some of the runs (the names below); none: all. JOBS=N runs N at once (default:
# the machine's cores). The runs are CPU-bound and deterministic: their figures do not depend on
# the machine's load, only their wall time does (about 40 CPU minutes in all). The programs are
# built first (`make benchmarks`). The real WIC day's summary is the main job's
# (scripts/setup_and_demo.sh), not run here.
set -euo pipefail

build=${1:-build}
out=${2:-build/accuracy}
shift $(( $# < 2 ? $# : 2 ))
jobs=${JOBS:-$(nproc)}
bin="$build/devel/lib/magnetometer_insitu_calibration"

# name | environment (space-separated assignments, or -) | program and arguments
runs=(
  "quiet_2d|MC_METHODS=default,plain|monte_carlo_unmodelled quiet 100 2 2000"
  "quiet_1d_default|-|monte_carlo_accuracy --seeds 200 --method robust"
  "quiet_1d_plain|-|monte_carlo_accuracy --seeds 200 --method plain"
  "disturbed_unmodelled|MC_METHODS=default,plain|monte_carlo_unmodelled disturbed 50 5 2000"
  "disturbed|-|monte_carlo_disturbed disturbed 50 5 2000"
  "filter|MC_REF_WHITE=0.0033 MC_REF_PINK=0.0017 MC_METHODS=default,plain|monte_carlo_unmodelled filter 100 2 6000"
  "temperature_noiseless|MC_NOISELESS_REFERENCE=1|monte_carlo_temperature 100 2"
  "temperature_noiseless_plain|MC_NOISELESS_REFERENCE=1 MC_METHOD=plain|monte_carlo_temperature 40 2"
  "temperature|-|monte_carlo_temperature 100 2"
  "temperature_plain|MC_METHOD=plain|monte_carlo_temperature 40 2"
  "remote_road|-|monte_carlo_remote disturbed 50 5 40000"
  "remote_quiet|-|monte_carlo_remote quiet 100 2 42000"
  "short_1h_quiet|MC_METHODS=default,plain|monte_carlo_unmodelled quiet 1000 0.0416667 21000"
  "short_1h_disturbed|MC_METHODS=default,plain|monte_carlo_unmodelled disturbed 1000 0.0416667 21000"
  "short_1h_quiet_coverage|MC_METHODS=default,plain|monte_carlo_unmodelled quiet 1000 0.0416667 30000"
  "short_1h_disturbed_coverage|MC_METHODS=default,plain|monte_carlo_unmodelled disturbed 1000 0.0416667 30000"
  "hat|-|monte_carlo_unmodelled hat 200 1 8400"
  "node_hat|-|monte_carlo_node_hat 200 1 9600"
  "scalar_1s_a|-|monte_carlo_scalar 500 1 1 47000"
  "scalar_1s_b|-|monte_carlo_scalar 500 1 1 47500"
  "scalar_30s_a|-|monte_carlo_scalar 500 1 30 47000"
  "scalar_30s_b|-|monte_carlo_scalar 500 1 30 47500"
  "record_length|-|monte_carlo_record_length 100 2 6 2 52000"
)

selected=()
for entry in "${runs[@]}"; do
  name=${entry%%|*}
  if [[ $# -eq 0 ]] || [[ " $* " == *" $name "* ]]; then selected+=("$entry"); fi
done
if [[ ${#selected[@]} -eq 0 ]]; then
  echo "measure_accuracy: no run named '$*'; names: $(printf '%s ' "${runs[@]%%|*}")" >&2
  exit 2
fi
make -C "$build" benchmarks >/dev/null
mkdir -p "$out"

run_one() {  # entry -> OUT/<name>.txt, its wall time in OUT/<name>.time
  local name=${1%%|*} rest=${1#*|}
  local environment=${rest%%|*} command=${rest#*|}
  [[ $environment == - ]] && environment=
  local start=$SECONDS
  # shellcheck disable=SC2086  # the assignments and arguments are split on purpose
  if ! env $environment nice "$bin"/$command >"$out/$name.txt" 2>&1; then
    echo "measure_accuracy: $name failed: ${environment:+$environment }$command (see $out/$name.txt)" >&2
    return 1
  fi
  echo "$((SECONDS - start))" >"$out/$name.time"
}

failed=0
running=0
for entry in "${selected[@]}"; do
  if (( running >= jobs )); then wait -n || failed=1; running=$((running - 1)); fi
  run_one "$entry" &
  running=$((running + 1))
done
while (( running > 0 )); do wait -n || failed=1; running=$((running - 1)); done

for entry in "${selected[@]}"; do
  name=${entry%%|*} rest=${entry#*|}
  environment=${rest%%|*} command=${rest#*|}
  [[ $environment == - ]] && environment=
  echo
  echo "== $name: ${environment:+$environment }\$B/$command ($(cat "$out/$name.time" 2>/dev/null || echo '?') s wall)"
  grep -v -E '^(seed|  seed|#seed) ' "$out/$name.txt" | tail -n 25 || true
done
exit "$failed"
