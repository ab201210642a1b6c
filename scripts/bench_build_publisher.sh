# Sourced by scripts/bench_network.sh and scripts/bench_soak.sh with $build (a catkin build dir
# with devel/) and $here (the package): compiles benchmark/ros/bench_publisher.cpp (roscpp +
# the core library; not in the CMake build) into $build/bench_publisher; sets $publisher.
publisher="$build/bench_publisher"
if [ ! -x "$publisher" ] || [ "$here/benchmark/ros/bench_publisher.cpp" -nt "$publisher" ]; then
  g++ -std=c++17 -O2 -o "$publisher" "$here/benchmark/ros/bench_publisher.cpp" \
    -I "$here/include" -I "$build/devel/include" -I /usr/include/eigen3 \
    $(pkg-config --cflags --libs roscpp sensor_msgs) \
    -Wl,-rpath,"$build/devel/lib" "$build/devel/lib/libmagnetometer_insitu_calibration_core.so" -lfftw3
fi
