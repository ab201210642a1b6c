# ROS nodes: a thin layer over ${PROJECT_NAME}_core. Included by CMakeLists.txt after
# catkin_package(). One node = src/ros/<name>.cpp (its class) + src/ros/<name>_main.cpp:
#   mic_add_node(<name> [extra sources...])
# builds the executable <name> into the devel space (rosrun/roslaunch find it), linked to the
# core, the shared ROS-layer library and ${catkin_LIBRARIES}, after the package's messages.

# Shared ROS-layer code: parameter reading, the calibration YAML file, the live sliding window,
# the correction model.
add_library(${PROJECT_NAME}_ros
  src/ros/parameters.cpp
  src/ros/calibration_yaml.cpp
  src/ros/live_window.cpp
  src/ros/correction_model.cpp)
target_include_directories(${PROJECT_NAME}_ros PUBLIC include ${CATKIN_DEVEL_PREFIX}/include ${catkin_INCLUDE_DIRS})
target_link_libraries(${PROJECT_NAME}_ros PUBLIC ${PROJECT_NAME}_core ${catkin_LIBRARIES} ${YAML_CPP_LIBRARIES})
target_compile_options(${PROJECT_NAME}_ros PRIVATE -Wall -Wextra)
add_dependencies(${PROJECT_NAME}_ros ${PROJECT_NAME}_generate_messages_cpp)

macro(mic_add_node name)
  add_executable(${name} src/ros/${name}.cpp src/ros/${name}_main.cpp ${ARGN})
  target_include_directories(${name} PRIVATE include ${CATKIN_DEVEL_PREFIX}/include ${catkin_INCLUDE_DIRS})
  target_link_libraries(${name} ${PROJECT_NAME}_ros ${PROJECT_NAME}_core ${catkin_LIBRARIES})
  target_compile_options(${name} PRIVATE -Wall -Wextra)
  add_dependencies(${name} ${PROJECT_NAME}_generate_messages_cpp)
  mic_use_precompiled_headers(${name} EXE_ROS)
  install(TARGETS ${name} RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
endmacro()

mic_add_node(calibration_node src/ros/calibration_node_settings.cpp src/ros/calibration_node_windows.cpp
  src/ros/calibration_node_output.cpp src/ros/calibration_node_diagnostics.cpp src/ros/calibration_node_tf.cpp)
mic_add_node(correction_node)
mic_add_node(lemi025_driver)
