# Shared pieces of the ROS benchmarks (scripts/bench_*.sh), sourced after
#   here=<package dir>; build=<catkin build dir with devel/>; source "$build/devel/setup.bash"
# (devel=<devel space> when it is not $build/devel, e.g. a catkin workspace's devel/).
#
# bench_build_ros NAME [LIB...]
#                        compiles benchmark/ros/NAME.cpp (roscpp + the core library + the package's
#                        messages + LIB..., e.g. -lnodeletlib; not in the CMake build) into
#                        $build/NAME when missing or older than its source, and prints that path.
# bench_start_roscore DIR
#                        starts a private roscore on a random port (a running master is not
#                        disturbed), exports ROS_MASTER_URI, ROS_IP, ROS_HOME=DIR/ros_home and
#                        waits until it answers; its log is DIR/roscore.log. Sets $bench_core_pid.
# bench_stop PID...      kills those processes (started by the benchmark) and reaps them.
# bench_load             "load average 1/5/15 min: a b c" from /proc/loadavg.

bench_build_ros() {
  local name="$1" bin="$build/$1"
  shift
  if [ ! -x "$bin" ] || [ "$here/benchmark/ros/$name.cpp" -nt "$bin" ]; then
    g++ -std=c++17 -O2 -o "$bin" "$here/benchmark/ros/$name.cpp" \
      -I "$here/include" -I "${devel:-$build/devel}/include" -I /usr/include/eigen3 \
      $(pkg-config --cflags --libs roscpp sensor_msgs) \
      -Wl,-rpath,"${devel:-$build/devel}/lib" "${devel:-$build/devel}/lib/libmagnetometer_insitu_calibration_core.so" -lfftw3 "$@" >&2
  fi
  echo "$bin"
}

bench_start_roscore() {
  local dir="$1" port=$((20000 + RANDOM % 20000)) i
  mkdir -p "$dir/ros_home"
  export ROS_MASTER_URI="http://127.0.0.1:$port" ROS_IP=127.0.0.1 ROS_HOME="$dir/ros_home"
  roscore -p "$port" >"$dir/roscore.log" 2>&1 &
  bench_core_pid=$!
  for i in $(seq 50); do rosparam list >/dev/null 2>&1 && return 0; sleep 0.2; done
  echo "bench: roscore on port $port did not answer" >&2
  return 1
}

bench_stop() {
  local p
  for p in "$@"; do [ -n "$p" ] && kill "$p" 2>/dev/null || true; done
  for p in "$@"; do [ -n "$p" ] && wait "$p" 2>/dev/null || true; done
}

bench_load() {
  awk '{print "load average 1/5/15 min: " $1 " " $2 " " $3}' /proc/loadavg
}
