# Tests of the archived-record tools (included by test/ros/tests.cmake):
#  - test_core_programs (test/core/programs/: test_archive_records, test_export_corrected,
#    test_export_corrected_cdf among them; ROS-free, created by the core's loop in CMakeLists.txt):
#    linked here to the archive library, given the programs (export_corrected, records_to_bag);
#  - test_bag_records: gtest without a master (bags, records_to_bag, calibrate_records --bag,
#    export_corrected from a bag and a calibration_node YAML);
#  - rostest replay_agreement: launch/replay.launch vs calibrate_records --bag, same windows;
#  - plot_calibration: scripts/plot_calibration on the real WIC pair (Python, JUnit XML).
# Test binaries and fixtures are EXCLUDE_FROM_ALL: build the `tests` target before ctest.
set(_mic_programs
  RECORDS_TO_BAG_BIN="$<TARGET_FILE:records_to_bag>"
  EXPORT_CORRECTED_BIN="$<TARGET_FILE:export_corrected>"
  CALIBRATE_RECORDS_BIN="$<TARGET_FILE:calibrate_records>"
  PACKAGE_DATA_DIR="${CMAKE_CURRENT_SOURCE_DIR}/data"
  TEST_DATA_DIR="${CMAKE_CURRENT_SOURCE_DIR}/test/data")

foreach(_mic_test test_core_programs)
  if(TARGET ${_mic_test})
    target_link_libraries(${_mic_test} ${PROJECT_NAME}_archive)
    target_compile_definitions(${_mic_test} PRIVATE EXPORT_CORRECTED_BIN="$<TARGET_FILE:export_corrected>"
      RECORDS_TO_BAG_BIN="$<TARGET_FILE:records_to_bag>")
    add_dependencies(${_mic_test} export_corrected records_to_bag calibrate_records)
  endif()
endforeach()

catkin_add_gtest(test_bag_records test/ros/test_bag_records.cpp test/ros/test_bag_export.cpp
  WORKING_DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR})
if(TARGET test_bag_records)
  target_include_directories(test_bag_records PRIVATE test/core ${CATKIN_DEVEL_PREFIX}/include)
  # test support (test/core/test_support.cpp): temporary directories, data paths, running programs.
  target_link_libraries(test_bag_records ${PROJECT_NAME}_bag ${PROJECT_NAME}_archive ${PROJECT_NAME}_ros
    ${PROJECT_NAME}_test_support ${PROJECT_NAME}_core ${GTEST_MAIN_LIBRARIES})
  target_compile_definitions(test_bag_records PRIVATE ${_mic_programs})
  target_compile_options(test_bag_records PRIVATE -Wall -Wextra)
  mic_unity_build(test_bag_records)  # its two files as one translation unit: roscpp's templates once
  add_dependencies(test_bag_records records_to_bag export_corrected calibrate_records
    ${PROJECT_NAME}_generate_messages_cpp)
endif()

# Replay fixture: 6 h of a simulated 1 Hz pair from 2025-05-14T00:00:00Z (a whole multiple of the
# step, so that the live windows are the offline ones), 50 nT spikes in either record, -> bag ->
# offline reports of the windows, despiked (the default) and not (--no-despike).
set(_mic_replay ${CMAKE_CURRENT_BINARY_DIR}/archive_fixtures/replay)
add_custom_command(
  OUTPUT ${_mic_replay}/pair.bag ${_mic_replay}/offline.json ${_mic_replay}/offline_despiked.json
         ${_mic_replay}/pair_remote.bag ${_mic_replay}/offline_remote.json
  COMMAND ${CMAKE_COMMAND} -E make_directory ${_mic_replay}
  COMMAND $<TARGET_FILE:simulate_records> --out-dir ${_mic_replay} --format iaga --days 0.25 --seed 11
          --spikes-per-day 96 --spike-instrument either --remote > ${_mic_replay}/fixture.log
  COMMAND $<TARGET_FILE:records_to_bag> --quiet --reference ${_mic_replay}/reference.iaga --test ${_mic_replay}/test.iaga
          -o ${_mic_replay}/pair.bag >> ${_mic_replay}/fixture.log
  COMMAND $<TARGET_FILE:calibrate_records> --bag ${_mic_replay}/pair.bag --reference-topic /reference/magnetic_field
          --test-topic /test/magnetic_field --window 3600 --step 1800 --no-despike
          --json ${_mic_replay}/offline.json >> ${_mic_replay}/fixture.log
  COMMAND $<TARGET_FILE:calibrate_records> --bag ${_mic_replay}/pair.bag --reference-topic /reference/magnetic_field
          --test-topic /test/magnetic_field --window 3600 --step 1800
          --json ${_mic_replay}/offline_despiked.json >> ${_mic_replay}/fixture.log
  COMMAND $<TARGET_FILE:records_to_bag> --quiet --reference ${_mic_replay}/reference.iaga --test ${_mic_replay}/test.iaga
          --remote ${_mic_replay}/remote.iaga -o ${_mic_replay}/pair_remote.bag >> ${_mic_replay}/fixture.log
  COMMAND $<TARGET_FILE:calibrate_records> --bag ${_mic_replay}/pair_remote.bag --reference-topic /reference/magnetic_field
          --test-topic /test/magnetic_field --remote-topic /remote/magnetic_field --window 3600 --step 1800
          --json ${_mic_replay}/offline_remote.json >> ${_mic_replay}/fixture.log
  DEPENDS simulate_records records_to_bag calibrate_records
  COMMENT "Replay fixture: simulated bag and the offline calibration of its windows")
add_custom_target(${PROJECT_NAME}_replay_fixture DEPENDS ${_mic_replay}/pair.bag ${_mic_replay}/offline.json)

catkin_add_executable_with_gtest(rostest_replay test/ros/rostest_replay.cpp EXCLUDE_FROM_ALL)
if(TARGET rostest_replay)
  target_include_directories(rostest_replay PRIVATE include ${CATKIN_DEVEL_PREFIX}/include ${catkin_INCLUDE_DIRS})
  target_link_libraries(rostest_replay ${PROJECT_NAME}_core ${catkin_LIBRARIES})
  target_compile_options(rostest_replay PRIVATE -Wall -Wextra)
  # add_rostest does not make the test depend on the nodes it launches, nor on the fixture.
  add_dependencies(rostest_replay ${PROJECT_NAME}_generate_messages_cpp ${PROJECT_NAME}_replay_fixture
    calibration_node correction_node)
  add_dependencies(tests rostest_replay)  # EXCLUDE_FROM_ALL: built with the other tests
  # add_rostest names its targets after the .test file and its ARGS: absolute fixture paths in
  # ARGS give a file name under CMakeFiles/ past the 255-character limit in a workspace at a
  # deep path. A wrapper .test in the build folder (target name "replay_agreement.test") passes
  # the fixture paths to test/ros/replay_agreement.test instead.
  # Three replays: the node and calibrate_records despiking (the default), neither despiking,
  # and both with the bag's remote observatory (remote reference).
  foreach(_mic_variant despiked plain remote)
    set(_mic_despike true)
    set(_mic_bag ${_mic_replay}/pair.bag)
    set(_mic_remote "")
    set(_mic_replay_test ${CMAKE_CURRENT_BINARY_DIR}/replay_agreement_${_mic_variant}.test)
    set(_mic_test_name replay_agreement_${_mic_variant})
    if(_mic_variant STREQUAL "despiked")
      set(_mic_offline ${_mic_replay}/offline_despiked.json)
    elseif(_mic_variant STREQUAL "plain")
      set(_mic_despike false)
      set(_mic_replay_test ${CMAKE_CURRENT_BINARY_DIR}/replay_agreement.test)
      set(_mic_offline ${_mic_replay}/offline.json)
    else()
      set(_mic_bag ${_mic_replay}/pair_remote.bag)
      set(_mic_remote /remote/magnetic_field)
      set(_mic_offline ${_mic_replay}/offline_remote.json)
    endif()
    file(WRITE ${_mic_replay_test} "<?xml version=\"1.0\"?>
<!-- Generated by test/ros/archive_tests.cmake: the replay fixture of this build. -->
<launch>
  <include file=\"${CMAKE_CURRENT_SOURCE_DIR}/test/ros/replay_agreement.test\">
    <arg name=\"bag\" value=\"${_mic_bag}\"/>
    <arg name=\"offline_json\" value=\"${_mic_offline}\"/>
    <arg name=\"despike\" value=\"${_mic_despike}\"/>
    <arg name=\"remote_topic\" value=\"${_mic_remote}\"/>
    <arg name=\"test_name\" value=\"${_mic_test_name}\"/>
  </include>
</launch>
")
    add_rostest(${_mic_replay_test} DEPENDENCIES rostest_replay)
  endforeach()
endif()

# catkin's run_tests.py takes the command as one string (as catkin_add_gtest passes it).
catkin_run_tests_target(python plot_calibration python-plot_calibration.xml
  COMMAND "/usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/test/ros/test_plot_calibration.py --calibrate-records $<TARGET_FILE:calibrate_records> --script ${CMAKE_CURRENT_SOURCE_DIR}/scripts/plot_calibration --data-dir ${CMAKE_CURRENT_SOURCE_DIR}/data --certificate ${CMAKE_CURRENT_SOURCE_DIR}/test/data/coil_certificate_marusenkov2010.yaml --xml ${CATKIN_TEST_RESULTS_DIR}/${PROJECT_NAME}/python-plot_calibration.xml"
  DEPENDENCIES calibrate_records)
if(TARGET tests)
  add_dependencies(tests calibrate_records)
endif()
catkin_run_tests_target(python launch_files python-launch_files.xml
  COMMAND "/usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/test/ros/test_launch_files.py --launch-dir ${CMAKE_CURRENT_SOURCE_DIR}/launch --xml ${CATKIN_TEST_RESULTS_DIR}/${PROJECT_NAME}/python-launch_files.xml")

# Precompiled roscpp/message/Eigen headers (cmake/precompiled_headers.cmake).
foreach(_mic_test test_bag_records rostest_replay)
  if(TARGET ${_mic_test})
    mic_use_precompiled_headers(${_mic_test} EXE_ROS)
  endif()
endforeach()
