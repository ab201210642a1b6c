# Tests of the ROS layer, included by CMakeLists.txt when CATKIN_ENABLE_TESTING.
#  - test_ros_layer: gtest without a master (calibration YAML, correction model;
#    test_ros_temperature.cpp: the correction model's temperature terms);
#  - rostests with a real master (rostest starts one per .test file): simulated streams with a
#    fast /clock into calibration_node + correction_node (launch/calibration.launch).
# Test binaries are EXCLUDE_FROM_ALL: build the `tests` target before ctest.
# catkin_lint (-W2): this package's generated message headers are in ${CATKIN_DEVEL_PREFIX}/include
# (external_directory), and the in-package libraries carry ${catkin_INCLUDE_DIRS} as PUBLIC
# include paths for their users in this package; no CMake target is exported
# (external_interface_path): other packages get the core through catkin_package().
#catkin_lint: ignore external_directory
#catkin_lint: ignore external_interface_path
find_package(rostest REQUIRED)
find_package(tf2_msgs REQUIRED)  # rostest_calibration_tf.cpp reads /tf_static

catkin_add_gtest(test_ros_layer test/ros/test_ros_layer.cpp test/ros/test_ros_temperature.cpp test/ros/test_ros_settings.cpp WORKING_DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR})
if(TARGET test_ros_layer)
  target_link_libraries(test_ros_layer ${PROJECT_NAME}_nodes ${PROJECT_NAME}_ros ${PROJECT_NAME}_core ${GTEST_MAIN_LIBRARIES})
  target_compile_options(test_ros_layer PRIVATE -Wall -Wextra)
endif()

# One gtest binary; each .test file runs one of its TESTs (--gtest_filter in the .test). The
# sources group the TESTs by what they test; test/ros/calibration_harness.hpp is their harness.
add_rostest_gtest(rostest_calibration test/ros/nominal.test test/ros/rostest_calibration_main.cpp
  test/ros/rostest_calibration_nominal.cpp test/ros/rostest_calibration_streams.cpp
  test/ros/rostest_calibration_correction.cpp test/ros/rostest_calibration_parameters.cpp
  test/ros/rostest_calibration_lifecycle.cpp test/ros/rostest_calibration_tf.cpp
  test/ros/rostest_calibration_temperature.cpp test/ros/rostest_calibration_scalar.cpp
  test/ros/rostest_calibration_local_events.cpp test/ros/rostest_calibration_late_remote.cpp
  test/ros/station_offline_window.cpp)
# _nodes: calibration_node's settings loader (the late remote's offline path reads the node's parameters).
target_link_libraries(rostest_calibration ${PROJECT_NAME}_nodes ${PROJECT_NAME}_ros ${PROJECT_NAME}_core ${catkin_LIBRARIES})
target_include_directories(rostest_calibration PRIVATE include ${CATKIN_DEVEL_PREFIX}/include ${catkin_INCLUDE_DIRS} ${tf2_msgs_INCLUDE_DIRS})
target_compile_options(rostest_calibration PRIVATE -Wall -Wextra)
target_compile_definitions(rostest_calibration PRIVATE
  CALIBRATION_NODE_PATH="$<TARGET_FILE:calibration_node>"
  CORRECTION_NODE_PATH="$<TARGET_FILE:correction_node>"
  SCALAR_SIMULATOR_PATH="$<TARGET_FILE:scalar_simulator>")
# add_rostest_gtest does not make the test depend on the nodes it launches.
add_dependencies(rostest_calibration calibration_node correction_node scalar_simulator)
foreach(rostest_file silent_topic time_jump decimation two_rates two_instruments three_cornered_hat correction_reload correction_stream bad_parameters temperature scalar local_events)
  add_rostest(test/ros/${rostest_file}.test DEPENDENCIES rostest_calibration calibration_node correction_node)
endforeach()
# ~publish_tf: the rotation part of n on /tf_static (and nothing from a node without it).
add_rostest(test/ros/calibration_tf.test DEPENDENCIES rostest_calibration calibration_node)
# A neighbouring observatory's files as a late live remote: record_file_follower onto ~remote_topic.
add_dependencies(rostest_calibration record_file_follower)
add_rostest(test/ros/late_remote.test DEPENDENCIES rostest_calibration calibration_node record_file_follower)
# Calibration change WARN after a step of the scale ratio; resume from the file after a restart.
add_rostest(test/ros/test_calibration_change.test DEPENDENCIES rostest_calibration calibration_node correction_node)
add_rostest(test/ros/test_calibration_resume.test DEPENDENCIES rostest_calibration calibration_node correction_node)
# test/ros/pty_link.cpp (the pseudo-terminal serial port) and test/ros/driver_test_support.cpp
# (parameters, waiting, packet bytes, stamps, diagnostics) are shared by the two driver rostests.
# test_lemi025_driver: the driver on a pty (test_lemi025_driver.cpp, with main()), on recordings
# (_recordings.cpp) and with impossible parameters (_parameters.cpp), and the simulated station.
add_rostest_gtest(test_lemi025_driver test/ros/test_lemi025_driver.test test/ros/test_lemi025_driver.cpp
  test/ros/test_lemi025_driver_recordings.cpp test/ros/test_lemi025_driver_parameters.cpp
  test/ros/lemi025_test_packets.cpp test/ros/driver_process.cpp test/ros/test_simulated_station.cpp test/ros/station_offline_window.cpp
  test/ros/pty_link.cpp test/ros/driver_test_support.cpp)
# _nodes: calibration_node's settings loader (station_offline_window.cpp reads the node's parameters).
target_link_libraries(test_lemi025_driver ${PROJECT_NAME}_nodes ${PROJECT_NAME}_ros ${PROJECT_NAME}_core ${catkin_LIBRARIES})
add_dependencies(test_lemi025_driver lemi025_driver lemi025_simulator scalar_simulator calibration_node correction_node)
add_rostest(test/ros/test_simulated_station.test DEPENDENCIES test_lemi025_driver)
# The same station with the test in a field hut: temperature from the packets to both nodes.
add_rostest(test/ros/test_simulated_station_hut.test DEPENDENCIES test_lemi025_driver)
# The same station with its four nodes as nodelets in one manager (launch/station.launch nodelet_manager:=).
add_dependencies(test_lemi025_driver ${PROJECT_NAME}_nodelets)
add_rostest(test/ros/test_simulated_station_nodelets.test DEPENDENCIES test_lemi025_driver)
# lemi025_driver as a nodelet: an absent port and an impossible parameter reported under its name.
add_rostest_gtest(test_nodelet_device_error test/ros/test_nodelet_device_error.test test/ros/test_nodelet_device_error.cpp test/ros/pty_link.cpp test/ros/driver_test_support.cpp)
target_link_libraries(test_nodelet_device_error ${PROJECT_NAME}_ros ${PROJECT_NAME}_core ${catkin_LIBRARIES})
target_compile_options(test_nodelet_device_error PRIVATE -Wall -Wextra)
add_dependencies(test_nodelet_device_error ${PROJECT_NAME}_nodelets)
add_rostest(test/ros/test_simulated_network.test DEPENDENCIES test_lemi025_driver)
# Fault injection (test/ros/test_faults_*.test): the driver's serial line.
add_rostest_gtest(test_faults_driver test/ros/test_faults_driver.test test/ros/test_faults_driver.cpp
  test/ros/test_faults_driver_pc_clock.cpp test/ros/pty_link.cpp test/ros/driver_test_support.cpp)
target_link_libraries(test_faults_driver ${PROJECT_NAME}_ros ${PROJECT_NAME}_core ${catkin_LIBRARIES})
target_compile_options(test_faults_driver PRIVATE -Wall -Wextra)
add_dependencies(test_faults_driver lemi025_driver)
# The same binary (~suite DriverPcClock): GPS lost, the driver's PC clock (sim time) steps back and forward.
add_rostest(test/ros/test_faults_driver_pc_clock.test DEPENDENCIES test_faults_driver lemi025_driver)
add_rostest_gtest(test_faults_calibration test/ros/test_faults_calibration.test test/ros/test_faults_calibration.cpp)
target_link_libraries(test_faults_calibration ${PROJECT_NAME}_ros ${PROJECT_NAME}_core ${catkin_LIBRARIES})
target_compile_options(test_faults_calibration PRIVATE -Wall -Wextra)
add_dependencies(test_faults_calibration calibration_node)

# record_file_follower: a remote observatory's files followed (faults, a restart), replayed, and as
# a nodelet; the pieces of the WIC day come from the core tests' helpers (test_support).
add_rostest_gtest(test_record_file_follower test/ros/record_file_follower.test test/ros/test_record_file_follower.cpp)
target_link_libraries(test_record_file_follower ${PROJECT_NAME}_test_support ${PROJECT_NAME}_core ${catkin_LIBRARIES})
target_compile_options(test_record_file_follower PRIVATE -Wall -Wextra)
add_dependencies(test_record_file_follower record_file_follower ${PROJECT_NAME}_nodelets)
add_rostest(test/ros/record_file_follower_nodelet.test DEPENDENCIES test_record_file_follower)

# Archived records: bags, records_to_bag, calibrate_records --bag, export_corrected, replay, plots.
include(${CMAKE_CURRENT_SOURCE_DIR}/test/ros/archive_tests.cmake)

# Precompiled roscpp/message/Eigen headers, and the sources of each test one translation unit
# (cmake/precompiled_headers.cmake).
foreach(_mic_test test_ros_layer rostest_calibration test_lemi025_driver test_faults_driver test_faults_calibration test_nodelet_device_error)
  if(TARGET ${_mic_test})
    mic_use_precompiled_headers(${_mic_test} EXE_ROS)
    mic_unity_build(${_mic_test})
  endif()
endforeach()

# Every launch file parses, resolves its includes, args and $(find) paths, and names executables
# that exist (roslaunch-check; replay.launch needs its bag argument).
find_package(roslaunch REQUIRED)
# The script's shebang is `/usr/bin/env python3`; Debian's rospkg lives only under /usr/bin/python3.
set(roslaunch_check_script "/usr/bin/python3 ${roslaunch_DIR}/../scripts/roslaunch-check")
# launch/include/*.launch are checked through the files that include them.
foreach(_mic_launch calibration network network_example simulated_network simulated_station station)
  roslaunch_add_file_check(launch/${_mic_launch}.launch USE_TEST_DEPENDENCIES)
endforeach()
roslaunch_add_file_check(launch/replay.launch bag:=/tmp/any.bag USE_TEST_DEPENDENCIES)
# The station with its nodes as nodelets in one manager.
roslaunch_add_file_check(launch/station.launch nodelet_manager:=station_manager USE_TEST_DEPENDENCIES)
# A remote observatory's files followed, alone and in a station and a network station.
roslaunch_add_file_check(launch/remote_files.launch path:=/tmp/any USE_TEST_DEPENDENCIES)
roslaunch_add_file_check(launch/station.launch remote_files:=/tmp/any USE_TEST_DEPENDENCIES)
roslaunch_add_file_check(launch/network.launch remote_files:=/tmp/any USE_TEST_DEPENDENCIES)

# How ctest shares the 2 cores (run_tests.sh: ctest -j3 --resource-spec-file
# test/ctest_resources.json, which declares two "cores").
#  - Each test that keeps a core busy (the core's gtests, the plotting script, the bag replays,
#    the bag tools' gtest, the launch files' script) or must keep up with a fast stream takes one
#    core (RESOURCE_GROUPS cores:1): never more than two at once.
#  - The light tests take none and run as a third: the driver rostests (packets at a few per
#    second), the rostests that start nodes on wall-clock time with no stream to keep up with
#    (impossible parameters, the correction node's file reload and its refusal of another
#    stream's file), the launch checks and the layering check. Each used 10-40 % of a core
#    (CPU over wall time: the driver's rostest 3.1 s over 29 s, the impossible parameters 2.7 s
#    over 11.8 s, the file reload 1.3 s over 2.9 s).
#  - The rostests that drive calibration_node with fast simulated streams (their pairing and
#    windows assume the node keeps up; the pty stations at 200x) also take one lock: never two
#    of them at once. Their streams are paced, so they leave most of their core idle (the network
#    at 200x used 31 %); each is checked beside a busy loop on one core (docs/tests.md).
#    Measured: time_jump beside another test and an extra busy process lost a window's samples
#    at the jump; beside one other test it keeps them.
#  - COST: a fresh build has no timings, and ctest starts the costliest first. The lock's chain
#    (about 175 s) starts first and runs beside the others; the rest start longest first (their
#    wall seconds on the 2-core VM), so that no long test is left running alone at the end.
set(_mic_light_tests
  "lemi025_driver|faults_driver|nodelet_device_error|bad_parameters|correction_reload|correction_stream|roslaunch-check|core_layering")
set(_mic_unlocked_rostests "${_mic_light_tests}|replay_agreement|record_file_follower")
set(_mic_test_costs  # regular expression, then seconds
  test_core_pipeline 40 test_core_programs 32 test_core_estimation 32 plot_calibration 30
  lemi025_driver.test 29 test_bag_records 18 replay_agreement 14 launch_files 12 test_ros_layer 12
  bad_parameters 12 faults_driver 8 test_core_formats 5 correction_stream 5 correction_reload 4)
get_property(_mic_all_tests DIRECTORY PROPERTY TESTS)
foreach(_mic_test ${_mic_all_tests})
  if(NOT _mic_test MATCHES "${_mic_light_tests}")
    set_tests_properties(${_mic_test} PROPERTIES RESOURCE_GROUPS "cores:1")
  endif()
  if(_mic_test MATCHES "_rostest_" AND NOT _mic_test MATCHES "${_mic_unlocked_rostests}")
    set_tests_properties(${_mic_test} PROPERTIES RESOURCE_LOCK mic_streaming_rostest COST 100)
    continue()
  endif()
  set(_mic_costs ${_mic_test_costs})
  while(_mic_costs)
    list(POP_FRONT _mic_costs _mic_pattern _mic_cost)
    if(_mic_test MATCHES "${_mic_pattern}")
      set_tests_properties(${_mic_test} PROPERTIES COST ${_mic_cost})
      break()
    endif()
  endwhile()
endforeach()
