#!/usr/bin/env bash
# Configures and builds the package standalone with catkin (Debian 12's ROS 1) into build/,
# devel space build/devel. Debian's ROS Python tools need /usr/bin/python3, not a pyenv one.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DCATKIN_ENABLE_TESTING=ON \
  -DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3 >/dev/null \
  || { mkdir -p build; cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DCATKIN_ENABLE_TESTING=ON \
       -DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3; }
make -C build --no-print-directory -j"$(nproc)" "$@"
