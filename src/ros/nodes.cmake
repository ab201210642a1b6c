# ROS nodes: a thin layer over ${PROJECT_NAME}_core. Included by CMakeLists.txt after
# catkin_package(). One node = src/ros/<name>.cpp (its class) + src/ros/<name>_main.cpp:
#   mic_add_node(<name> [extra sources...])
# builds the executable <name> into the devel space (rosrun/roslaunch find it), linked to the
# core, the shared ROS-layer library and ${catkin_LIBRARIES}, after the package's messages.
# catkin_lint (-W2): this package's generated message headers are in ${CATKIN_DEVEL_PREFIX}/include
# (external_directory), and the in-package libraries carry ${catkin_INCLUDE_DIRS} as PUBLIC
# include paths for their users in this package; no CMake target is exported
# (external_interface_path): other packages get the core through catkin_package().
#catkin_lint: ignore external_directory
#catkin_lint: ignore external_interface_path

# Shared ROS-layer code: parameter reading, the calibration message and YAML file, the correction
# model.
add_library(${PROJECT_NAME}_ros
  src/ros/calibration_message.cpp
  src/ros/calibration_yaml.cpp
  src/ros/correction_model.cpp
  src/ros/parameters.cpp)
target_include_directories(${PROJECT_NAME}_ros PUBLIC include ${CATKIN_DEVEL_PREFIX}/include ${catkin_INCLUDE_DIRS})
target_link_libraries(${PROJECT_NAME}_ros PUBLIC ${PROJECT_NAME}_core ${catkin_LIBRARIES} ${YAML_CPP_LIBRARIES})
target_compile_options(${PROJECT_NAME}_ros PRIVATE -Wall -Wextra)
add_dependencies(${PROJECT_NAME}_ros ${PROJECT_NAME}_generate_messages_cpp)

# The node classes (src/ros/<name>.cpp and the extra sources of mic_add_node) are one shared
# library, linked by the executables (src/ros/<name>_main.cpp) and by the nodelets
# (src/ros/<name>_nodelet.cpp): one class per node in both forms.
add_library(${PROJECT_NAME}_nodes "")
target_include_directories(${PROJECT_NAME}_nodes PUBLIC include ${CATKIN_DEVEL_PREFIX}/include ${catkin_INCLUDE_DIRS})
target_link_libraries(${PROJECT_NAME}_nodes PUBLIC ${PROJECT_NAME}_ros ${PROJECT_NAME}_core ${catkin_LIBRARIES})
target_compile_options(${PROJECT_NAME}_nodes PRIVATE -Wall -Wextra)
target_precompile_headers(${PROJECT_NAME}_nodes PRIVATE ${MIC_PCH_EXE_ROS})  # its own (-fPIC)
add_dependencies(${PROJECT_NAME}_nodes ${PROJECT_NAME}_generate_messages_cpp)

macro(mic_add_node name)
  target_sources(${PROJECT_NAME}_nodes PRIVATE src/ros/${name}.cpp ${ARGN})
  add_executable(${name} src/ros/${name}_main.cpp)
  target_include_directories(${name} PRIVATE include ${CATKIN_DEVEL_PREFIX}/include ${catkin_INCLUDE_DIRS})
  target_link_libraries(${name} ${PROJECT_NAME}_nodes ${PROJECT_NAME}_ros ${PROJECT_NAME}_core ${catkin_LIBRARIES})
  target_compile_options(${name} PRIVATE -Wall -Wextra)
  add_dependencies(${name} ${PROJECT_NAME}_generate_messages_cpp)
  mic_use_precompiled_headers(${name} EXE_ROS)
  install(TARGETS ${name} RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
endmacro()

mic_add_node(calibration_node src/ros/calibration_node_settings.cpp src/ros/calibration_node_windows.cpp
  src/ros/calibration_node_output.cpp src/ros/calibration_node_diagnostics.cpp src/ros/calibration_node_tf.cpp)
mic_add_node(correction_node)
mic_add_node(lemi025_driver src/ros/lemi025_driver_port.cpp src/ros/lemi025_driver_timing.cpp
  src/ros/lemi025_driver_diagnostics.cpp)
# A remote observatory's record files (daily IAGA-2002, ImagCDF, ...) as a MagneticField stream.
mic_add_node(record_file_follower src/ros/record_file_follower_diagnostics.cpp)
# A simulated scalar magnetometer for the simulated station (not a nodelet: it stands in for an
# instrument, as lemi025_simulator does).
mic_add_node(scalar_simulator)

# Nodelets (nodelets.xml, exported in package.xml): magnetometer_insitu_calibration/<node>.
add_library(${PROJECT_NAME}_nodelets
  src/ros/calibration_node_nodelet.cpp
  src/ros/correction_node_nodelet.cpp
  src/ros/lemi025_driver_nodelet.cpp
  src/ros/record_file_follower_nodelet.cpp)
target_link_libraries(${PROJECT_NAME}_nodelets ${PROJECT_NAME}_nodes ${catkin_LIBRARIES})
target_compile_options(${PROJECT_NAME}_nodelets PRIVATE -Wall -Wextra)

foreach(_mic_target ${PROJECT_NAME}_ros ${PROJECT_NAME}_nodes ${PROJECT_NAME}_nodelets)
  mic_unity_build(${_mic_target})
  mic_adapter_optimization(${_mic_target})
endforeach()

install(TARGETS ${PROJECT_NAME}_nodelets ${PROJECT_NAME}_nodes ${PROJECT_NAME}_ros
  ARCHIVE DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  LIBRARY DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  RUNTIME DESTINATION ${CATKIN_GLOBAL_BIN_DESTINATION})
install(FILES nodelets.xml DESTINATION ${CATKIN_PACKAGE_SHARE_DESTINATION})
# launch/replay.launch's player (rosbag play of the bag in its ~bag parameter).
catkin_install_python(PROGRAMS scripts/play_bag DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
