#!/usr/bin/env bash
# Builds the libFuzzer targets (fuzz/CMakeLists.txt) with clang, ASan and UBSan, apart from the
# catkin build. Usage: fuzz/build_fuzzers.sh [build dir]   (default: <package>/build_fuzz,
# or $MIC_FUZZ_BUILD_DIR). Prints the build directory on its last line.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
build="${1:-${MIC_FUZZ_BUILD_DIR:-$here/../build_fuzz}}"
if ! command -v clang++ >/dev/null; then
  echo "build_fuzzers: clang++ not found (scripts/install_deps.sh installs clang libclang-rt-14-dev)" >&2
  exit 1
fi
cmake -S "$here" -B "$build" -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE= >/dev/null
cmake --build "$build" -j"${MIC_FUZZ_BUILD_JOBS:-2}" >&2
cd "$build" && pwd
