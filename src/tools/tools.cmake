# Archived-record tools (included by CMakeLists.txt after src/ros/nodes.cmake):
#  - ${PROJECT_NAME}_archive: ROS-free, every record format read past damaged records, LEMI
#    temperatures, correction into the reference frame, calibrate_records JSON windows;
#  - ${PROJECT_NAME}_bag (src/program_support, shared with src/cli): sensor_msgs/MagneticField
#    bags <-> VectorRecords (rosbag C++ API, no master) and the --bag input of calibrate_records;
#  - programs records_to_bag, export_corrected; the benchmark benchmark_bag_read (not in `all`);
#  - calibrate_records (built by CMakeLists.txt from src/cli) gets the bag input.
# catkin_lint (-W2): this package's generated message headers are in ${CATKIN_DEVEL_PREFIX}/include
# (external_directory), and the in-package libraries carry ${catkin_INCLUDE_DIRS} as PUBLIC
# include paths for their users in this package; no CMake target is exported
# (external_interface_path): other packages get the core through catkin_package().
#catkin_lint: ignore external_directory
#catkin_lint: ignore external_interface_path
add_library(${PROJECT_NAME}_archive src/tools/archive_records.cpp src/tools/archive_join.cpp)
target_include_directories(${PROJECT_NAME}_archive PUBLIC include src/tools)
target_link_libraries(${PROJECT_NAME}_archive PUBLIC ${PROJECT_NAME}_core)
target_compile_options(${PROJECT_NAME}_archive PRIVATE -Wall -Wextra)

add_library(${PROJECT_NAME}_bag src/program_support/bag_records.cpp src/program_support/bag_input.cpp)
target_include_directories(${PROJECT_NAME}_bag PUBLIC include src/program_support ${catkin_INCLUDE_DIRS})
target_link_libraries(${PROJECT_NAME}_bag PUBLIC ${PROJECT_NAME}_core ${catkin_LIBRARIES})
target_compile_options(${PROJECT_NAME}_bag PRIVATE -Wall -Wextra)

add_executable(records_to_bag src/tools/records_to_bag.cpp)
target_link_libraries(records_to_bag ${PROJECT_NAME}_bag ${PROJECT_NAME}_archive)

add_executable(export_corrected src/tools/export_corrected.cpp)
target_include_directories(export_corrected PRIVATE ${CATKIN_DEVEL_PREFIX}/include)
target_link_libraries(export_corrected ${PROJECT_NAME}_bag ${PROJECT_NAME}_archive ${PROJECT_NAME}_ros)
add_dependencies(export_corrected ${PROJECT_NAME}_generate_messages_cpp)

# A benchmark, not a test: built with the others (make -C build benchmark_bag_read, or
# benchmarks), not by `all`; its figures go in docs/archived_records.md.
add_executable(benchmark_bag_read EXCLUDE_FROM_ALL src/tools/benchmark_bag_read.cpp)
target_link_libraries(benchmark_bag_read ${PROJECT_NAME}_bag)
add_dependencies(benchmarks benchmark_bag_read)

foreach(program records_to_bag export_corrected benchmark_bag_read)
  target_include_directories(${program} PRIVATE src/program_support)  # command_line.hpp, bag_records.hpp
  mic_use_precompiled_headers(${program} EXE_ROS)
  target_compile_options(${program} PRIVATE -Wall -Wextra)
endforeach()
install(TARGETS records_to_bag export_corrected RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
install(TARGETS benchmark_bag_read OPTIONAL RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})

# calibrate_records --bag FILE --reference-topic T --test-topic T.
foreach(_mic_target ${PROJECT_NAME}_archive ${PROJECT_NAME}_bag)
  mic_unity_build(${_mic_target})
  mic_adapter_optimization(${_mic_target})
endforeach()

if(TARGET calibrate_records)
  target_link_libraries(calibrate_records ${PROJECT_NAME}_bag)
endif()

catkin_install_python(PROGRAMS scripts/plot_calibration DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
install(TARGETS ${PROJECT_NAME}_archive ${PROJECT_NAME}_bag
  ARCHIVE DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  LIBRARY DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  RUNTIME DESTINATION ${CATKIN_GLOBAL_BIN_DESTINATION})
# launch/ (replay.launch with the others) is installed by CMakeLists.txt.
