#!/usr/bin/env bash
# The built suite's ctest as the test command runs it (scripts/run_tests.sh; also
# scripts/stress_tests.sh): on two cores, at most two tests that keep a core busy or stream into
# calibration_node (those one at a time, under a lock), and a light one beside them
# (test/ctest_resources.json, test/ros/tests.cmake). Extra arguments go to ctest.
#   bash scripts/ctest_two_cores.sh [CTEST_ARGS...]
set -eo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
exec ctest --test-dir "$here/build" -j3 --resource-spec-file "$here/test/ctest_resources.json" \
  --output-on-failure --no-tests=error "$@"
