#!/usr/bin/env bash
# Installs every Debian 12 package this project needs to build, run and test.
# Only Debian's own packages (ROS 1 Noetic-era packages shipped by Debian); nothing else.
set -euo pipefail
PACKAGES=(
  build-essential cmake pkg-config
  ros-core-dev librosbag-dev python3-rostest python3-sensor-msgs rosbash python3-rosbag
  libdiagnostic-updater-dev python3-diagnostic-msgs ros-diagnostic-msgs
  libnodeletlib-dev libnodeletlib-tools catkin-tools catkin-lint libtf2-ros-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libeigen3-dev libfftw3-dev zlib1g-dev libyaml-cpp-dev
  python3-yaml python3-matplotlib python3-numpy
  nlohmann-json3-dev libcli11-dev
  socat gzip
  clang libclang-rt-14-dev
  libjcdf-java default-jre-headless
)
missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
echo "install_deps: installing ${missing[*]}"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
