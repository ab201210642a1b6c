#!/usr/bin/env bash
# README command 2: builds and runs every test (gtest on the core, rostest with a real master,
# end-to-end launch/bag tests); exits non-zero if any test fails or none ran.
set -eo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh
# `tests` first: make runs its goals one after the other (CMake's top Makefile is .NOTPARALLEL),
# and the tests depend on every program and node they run, so that goal builds nearly everything
# with both cores busy, the test binaries beside the libraries; `all` is then left with nothing.
bash scripts/build.sh tests all
source build/devel/setup.bash
# rostest needs a writable ROS_HOME and a host name that resolves (ros1-on-debian.md).
export ROS_HOME="${ROS_HOME:-$(mktemp -d)}"
export ROS_LOG_DIR="$ROS_HOME/log"
export ROS_HOSTNAME=localhost
rm -rf build/test_results
status=0
bash scripts/ctest_two_cores.sh || status=$?  # two cores shared by resource groups
# catkin_test_results exits 1 on failures; ctest already judged an empty run.
catkin_test_results build/test_results || status=$?
exit $status
