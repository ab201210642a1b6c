# Sourced by scripts/bench_network.sh and scripts/bench_soak.sh with $build (a catkin build dir
# with devel/) and $here (the package): sources scripts/bench_ros_common.sh (shared benchmark
# pieces) and compiles benchmark/ros/bench_publisher.cpp (roscpp + the core library; not in the
# CMake build) into $build/bench_publisher; sets $publisher.
source "$here/scripts/bench_ros_common.sh"
publisher=$(bench_build_ros bench_publisher)
