# Precompiled headers, to keep the test command (a clean build on 2 cores) short.
#
# Most of the compile time of a test, a node or a command-line program is parsing the same
# third-party headers (gtest, Eigen, nlohmann/json, CLI11, roscpp and its messages). Each group
# compiles its headers once and its members reuse the .gch (target_precompile_headers REUSE_FROM).
# GCC uses a .gch only when the flags that matter match: executables are position-independent
# (-fpie, Debian's default) while the package's shared libraries are -fPIC with a *_EXPORTS
# macro, so the executables' groups are owned by small OBJECT libraries compiled like an
# executable, and the core library has its own. -Winvalid-pch warns if a member is ever refused.
#
#   mic_use_precompiled_headers(<target> EXE_CORE|EXE_ROS|TEST_CORE)
#
# The members of these groups (programs' and nodes' main files, the bag tools, the tests), their
# owners and the ROS and archive libraries (mic_adapter_optimization) are compiled at -O1: they
# adapt messages and files and drive the core, where the numerical work is, and the core stays at
# the build type's level (-O3 in Release). At -O3 code generation was two thirds of a bag tool's
# 13-15 s compile (-ftime-report); the test command on a fresh 2-core clone went from 692 s (its
# build about 370 s) to 620 s (about 305 s). The five ROS and archive libraries (their precompiled
# header too) took 135 s of compiler CPU at -O3 and 70 s at -O1 (docs/tests.md, "Time").
#
# CORE_LIB:  ${PROJECT_NAME}_core's own sources (Eigen, standard library);
# EXE_CORE:  the ROS-free command-line programs (+ nlohmann/json, CLI11);
# EXE_ROS:   nodes, bag tools and the tests of the ROS layer (+ roscpp, messages, rosbag);
# TEST_CORE: the gtest executables of test/core (+ gtest, json), owned by the static test-support
#            library that they all link (created with mic_own_test_precompiled_headers).
# Appended after the build type's flags, so it wins; empty in a Debug build (-O0 stays). The
# core's gtests at -O0 instead were measured no faster to build and 12 s slower to run.
if(CMAKE_BUILD_TYPE MATCHES "^(Release|RelWithDebInfo)$")
  set(MIC_ADAPTER_OPTIMIZATION -O1)
else()
  set(MIC_ADAPTER_OPTIMIZATION "")
endif()
set(MIC_PCH_CORE_LIB
  <Eigen/Dense> <algorithm> <cmath> <cstdint> <stdexcept> <string> <vector>)
set(MIC_PCH_EXE_CORE
  <Eigen/Dense> <nlohmann/json.hpp> <CLI/CLI.hpp>
  <cmath> <cstdint> <fstream> <sstream> <string> <vector>)
set(MIC_PCH_EXE_ROS
  <ros/ros.h> <rosbag/bag.h> <rosbag/view.h> <sensor_msgs/MagneticField.h>
  <diagnostic_updater/diagnostic_updater.h> <Eigen/Dense>
  <cmath> <cstdint> <string> <vector>)
set(MIC_PCH_TEST_CORE
  <gtest/gtest.h> <Eigen/Dense> <nlohmann/json.hpp>
  <cmath> <cstdint> <fstream> <sstream> <string> <vector>)

# Owners. The core library precompiles for itself; the executables' owners compile an empty file.
target_precompile_headers(${PROJECT_NAME}_core PRIVATE ${MIC_PCH_CORE_LIB})
set(MIC_PCH_OWNER_CORE_LIB ${PROJECT_NAME}_core)
foreach(_mic_group EXE_CORE EXE_ROS)
  string(TOLOWER ${_mic_group} _mic_lower)
  set(MIC_PCH_OWNER_${_mic_group} ${PROJECT_NAME}_pch_${_mic_lower})
  add_library(${MIC_PCH_OWNER_${_mic_group}} OBJECT ${CMAKE_CURRENT_SOURCE_DIR}/cmake/precompiled_headers.cpp)
  target_precompile_headers(${MIC_PCH_OWNER_${_mic_group}} PRIVATE ${MIC_PCH_${_mic_group}})
  target_compile_options(${MIC_PCH_OWNER_${_mic_group}} PRIVATE -Winvalid-pch ${MIC_ADAPTER_OPTIMIZATION})
  target_link_libraries(${MIC_PCH_OWNER_${_mic_group}} PRIVATE Eigen3::Eigen nlohmann_json::nlohmann_json)
endforeach()
target_include_directories(${PROJECT_NAME}_pch_exe_ros PRIVATE ${catkin_INCLUDE_DIRS})

# The test-support library (STATIC: compiled like an executable) owns TEST_CORE.
function(mic_own_test_precompiled_headers target)
  target_precompile_headers(${target} PRIVATE ${MIC_PCH_TEST_CORE})
  target_compile_options(${target} PRIVATE -Winvalid-pch ${MIC_ADAPTER_OPTIMIZATION})
  set(MIC_PCH_OWNER_TEST_CORE ${target} PARENT_SCOPE)
endfunction()

# The ROS and archive libraries: adapters, compiled like the executables they serve.
function(mic_adapter_optimization target)
  target_compile_options(${target} PRIVATE ${MIC_ADAPTER_OPTIMIZATION})
endfunction()

function(mic_use_precompiled_headers target group)
  if(NOT DEFINED MIC_PCH_OWNER_${group})
    message(FATAL_ERROR "mic_use_precompiled_headers(${target} ${group}): unknown group")
  endif()
  target_precompile_headers(${target} REUSE_FROM ${MIC_PCH_OWNER_${group}})
  target_compile_options(${target} PRIVATE -Winvalid-pch ${MIC_ADAPTER_OPTIMIZATION})
endfunction()

# Unity builds for the targets whose sources share their heavy templates. A ROS source's compile
# is mostly instantiating and emitting roscpp's, the messages' and gtest's inline templates, and
# every source of a target emitted its own copies: compiled as one translation unit, the ten
# sources of rostest_calibration took 18 s of compiler CPU, against 82 s as ten objects in a
# make -j2 build (docs/tests.md, "Time"). The core's sources
# instantiate each its own Eigen expressions and gain nothing (measured: 113 s as three batches,
# 116 s apart), so they stay one file each. The sources of such a target must not define the
# same name in their anonymous namespaces.
function(mic_unity_build target)
  set_target_properties(${target} PROPERTIES UNITY_BUILD ON UNITY_BUILD_BATCH_SIZE 0)
endfunction()
