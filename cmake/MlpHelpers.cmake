# Project-wide helpers: warnings applied per target (PRIVATE), library and test registration.

# -Wshadow: a name that hides another is a bug waiting (a loop's `c` over the function's `c`);
# -Wconversion: a silent narrowing (a 64-bit count into an int, a size into a double past 2^53)
# is written out as a cast where it is meant. Clang's -Wconversion also includes
# -Wsign-conversion, which GCC's does not: turned off there so both compilers mean the same.
# Clang also reports an `omp simd` loop it could not vectorise (under the sanitizers, say) as a
# warning; the loop is still right, only slower: not an error.
function(mlp_set_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wconversion -Werror
                                           $<$<CXX_COMPILER_ID:Clang>:-Wno-sign-conversion>
                                           $<$<CXX_COMPILER_ID:Clang>:-Wno-pass-failed>)
endfunction()

# mlp_add_library(<name> SOURCES ... [PUBLIC_DEPS ...] [PRIVATE_DEPS ...])
# Creates mlp_<name> with alias mlp::<name>, public headers in <module>/include.
function(mlp_add_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(mlp_${name} ${ARG_SOURCES})
  add_library(mlp::${name} ALIAS mlp_${name})
  target_include_directories(mlp_${name} PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include)
  target_link_libraries(mlp_${name} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  target_compile_features(mlp_${name} PUBLIC cxx_std_20)
  mlp_set_warnings(mlp_${name})
endfunction()

# mlp_add_test(<module> <name> SOURCES ... DEPS ... [RESOURCE_LOCK lock] [TIMEOUT s] [COST s]): one
# gtest binary, tests discovered as <module>/<Suite>.<Case> so ctest -R geometry/ selects a
# module. Tests sharing a RESOURCE_LOCK never run at once under ctest -j (one LinuxCNC per
# machine). TIMEOUT (default 300 s; 4 times that sanitized or under qemu-user, the arm64 build's
# tests) is a hang guard, not a speed check.
function(mlp_add_test module name)
  cmake_parse_arguments(ARG "" "RESOURCE_LOCK;TIMEOUT;COST" "SOURCES;DEPS" ${ARGN})
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 300)
  endif()
  if(MLP_SANITIZE)  # the guard scaled as the tests' own waits are (MLP_TEST_TIME_SCALE=4)
    math(EXPR ARG_TIMEOUT "${ARG_TIMEOUT} * 4")
  elseif(CMAKE_CROSSCOMPILING)  # emulated: the virtual probes' renders took 243 and 284 s of 300
    math(EXPR ARG_TIMEOUT "${ARG_TIMEOUT} * 4")
  endif()
  set(target test_${module}_${name})
  add_executable(${target} ${ARG_SOURCES})
  target_link_libraries(${target} PRIVATE ${ARG_DEPS} mlp_test_main GTest::gmock)
  mlp_set_warnings(${target})
  set_target_properties(${target} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/tests)
  set(lock)
  if(ARG_RESOURCE_LOCK)
    set(lock RESOURCE_LOCK ${ARG_RESOURCE_LOCK})
  endif()
  # COST: seconds a test takes, so that a clean clone's ctest (no timings of an earlier run)
  # starts the long ones first instead of leaving one for the end on a core of its own.
  set(cost)
  if(ARG_COST)
    set(cost COST ${ARG_COST})
  endif()
  gtest_discover_tests(${target} TEST_PREFIX "${module}/" DISCOVERY_TIMEOUT 60
                       PROPERTIES ENVIRONMENT "MLP_SHARED_DATA=${MLP_SHARED_DATA_DIR}"
                                  TIMEOUT ${ARG_TIMEOUT} ${lock} ${cost})
endfunction()

# mlp_import_opencv_modules(<module>...): imported targets opencv_<module> from the headers and
# shared libraries alone. The firmware's sysroot holds only the OpenCV modules it runs with,
# and Debian's OpenCVConfig.cmake (in libopencv-dev) insists on every module being there.
function(mlp_import_opencv_modules)
  find_path(MLP_OPENCV_INCLUDE_DIR opencv2/core.hpp PATH_SUFFIXES opencv4 REQUIRED)
  foreach(module IN LISTS ARGN)
    find_library(MLP_OPENCV_${module}_LIBRARY opencv_${module} REQUIRED)
    add_library(opencv_${module} SHARED IMPORTED GLOBAL)
    set_target_properties(opencv_${module} PROPERTIES
      IMPORTED_LOCATION "${MLP_OPENCV_${module}_LIBRARY}"
      INTERFACE_INCLUDE_DIRECTORIES "${MLP_OPENCV_INCLUDE_DIR}")
  endforeach()
endfunction()
