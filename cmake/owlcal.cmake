# Precompiled headers (off by default; -DOWLCAL_PCH=ON): the standard, Eigen, Ceres, OpenCV and
# JSON headers most files include are parsed once into owlcal_pch (owlcal_pch_test adds GoogleTest
# for the test executables) and every target reuses that precompiled header. A file still includes
# what it uses, so the tree builds the same without them; with GCC an unusable .gch falls back to
# the headers' text. Off because at -O3 they save nothing measurable on the owlcal target and, with
# GCC 12, make false -Warray-bounds / -Wstringop-overflow errors fire in a few tests.
option(OWLCAL_PCH "Precompile the common system headers once for every target" OFF)
set(OWLCAL_PCH_HEADERS
    <algorithm> <array> <chrono> <cmath> <cstdint> <cstdio> <cstdlib> <filesystem> <fstream> <functional>
    <iostream> <limits> <map> <memory> <optional> <random> <set> <sstream> <stdexcept> <string>
    <string_view> <vector>
    <Eigen/Core> <Eigen/Dense> <Eigen/Geometry> <ceres/ceres.h>
    <opencv2/core.hpp> <opencv2/imgproc.hpp> <opencv2/imgcodecs.hpp> <opencv2/calib3d.hpp>
    <nlohmann/json.hpp>)
set(OWLCAL_PCH_DEPS Eigen3::Eigen Ceres::ceres opencv_core opencv_imgproc opencv_imgcodecs opencv_calib3d
    nlohmann_json::nlohmann_json)
# The fuzz build (clang, its own targets) does not use them.
if(OWLCAL_PCH AND NOT OWLCAL_FUZZ)
  file(WRITE ${CMAKE_BINARY_DIR}/generated/owlcal_pch.cc "// The translation unit owlcal's precompiled headers are built from.\n")
  add_library(owlcal_pch STATIC ${CMAKE_BINARY_DIR}/generated/owlcal_pch.cc)
  target_link_libraries(owlcal_pch PUBLIC ${OWLCAL_PCH_DEPS})
  target_precompile_headers(owlcal_pch PRIVATE ${OWLCAL_PCH_HEADERS})
  add_library(owlcal_pch_test STATIC ${CMAKE_BINARY_DIR}/generated/owlcal_pch.cc)
  target_link_libraries(owlcal_pch_test PUBLIC ${OWLCAL_PCH_DEPS} GTest::gtest)
  target_precompile_headers(owlcal_pch_test PRIVATE ${OWLCAL_PCH_HEADERS} <gtest/gtest.h>)
endif()
# owlcal_use_pch(TARGET [test]): TARGET reuses the precompiled headers (the test set with "test").
function(owlcal_use_pch target)
  if(NOT OWLCAL_PCH OR OWLCAL_FUZZ)
    return()
  endif()
  set(from owlcal_pch)
  if(ARGV1 STREQUAL "test")
    set(from owlcal_pch_test)
  endif()
  target_link_libraries(${target} PRIVATE ${OWLCAL_PCH_DEPS})
  target_precompile_headers(${target} REUSE_FROM ${from})
endfunction()

# Unity build (on by default; -DOWLCAL_UNITY=OFF for one object per file): each target's files
# are compiled OWLCAL_UNITY_BATCH at a time as one translation unit, so the CLI11, GoogleTest,
# Eigen, Ceres and JSON headers and their inline code are parsed and generated once per batch
# instead of once per file. Names in a file's anonymous namespace must therefore differ from those
# of the other files of its target: a test file whose helpers share names with another's (TempDir,
# Slurp, Truth, Record) keeps them in a namespace named after the file. The files below compile alone.
option(OWLCAL_UNITY "Compile each target's files in batches (CMake unity build)" ON)
# 16 files a unit: a clean build of every target spends less CPU than at 8 (a developer editing one
# file may prefer -DOWLCAL_UNITY_BATCH=4, which recompiles fewer files per edit).
set(OWLCAL_UNITY_BATCH 16 CACHE STRING "Files per unity translation unit (0: all of a target)")
set(OWLCAL_UNITY_SKIP
    robot/mjpeg_server.cc)  # <linux/tcp.h>, which clashes with <netinet/tcp.h>
# owlcal_unity(TARGET): TARGET is built in unity batches when OWLCAL_UNITY is on.
function(owlcal_unity target)
  if(NOT OWLCAL_UNITY OR OWLCAL_FUZZ)
    return()
  endif()
  set_target_properties(${target} PROPERTIES UNITY_BUILD ON UNITY_BUILD_BATCH_SIZE ${OWLCAL_UNITY_BATCH})
  get_target_property(srcs ${target} SOURCES)
  foreach(src ${srcs})
    file(RELATIVE_PATH rel ${CMAKE_SOURCE_DIR} ${src})
    if(rel IN_LIST OWLCAL_UNITY_SKIP)
      set_source_files_properties(${src} PROPERTIES SKIP_UNITY_BUILD_INCLUSION ON)
    endif()
  endforeach()
endfunction()

# owlcal_library(NAME DEPS ...): a static library from every .cc in the folder NAME.
# Headers are included from the repository root ("models/servo_map.h").
function(owlcal_library name)
  cmake_parse_arguments(ARG "" "" "DEPS" ${ARGN})
  file(GLOB srcs CONFIGURE_DEPENDS ${CMAKE_SOURCE_DIR}/${name}/*.cc)
  if(srcs)
    add_library(owlcal_${name} STATIC ${srcs})
    target_include_directories(owlcal_${name} PUBLIC ${CMAKE_SOURCE_DIR} ${CMAKE_BINARY_DIR}/generated)
    target_link_libraries(owlcal_${name} PUBLIC ${ARG_DEPS})
    owlcal_use_pch(owlcal_${name})
    owlcal_unity(owlcal_${name})
  else()
    add_library(owlcal_${name} INTERFACE)
    target_include_directories(owlcal_${name} INTERFACE ${CMAKE_SOURCE_DIR} ${CMAKE_BINARY_DIR}/generated)
    target_link_libraries(owlcal_${name} INTERFACE ${ARG_DEPS})
  endif()
endfunction()

# owlcal_tests(FOLDER LIBS ...): the GoogleTest files tests/FOLDER/*_test.cc, one executable per
# folder and tier (FOLDER_tests, FOLDER_e2e_tests, FOLDER_mc_tests): one link each instead of one per
# file. Every test carries its tier as a ctest label and a timeout per test (ctest -L unit runs the
# fast tier alone): files whose FOLDER_STEM matches the regex OWLCAL_MC_TESTS are "mc" (Monte-Carlo
# over robots, 1500 s), OWLCAL_E2E_TESTS "e2e" (whole protocols recorded and fitted, the served
# virtual Owl, or the owlcal program run; 900 s), all others "unit" (300 s). Test code is compiled
# at -O1: it is parsed more than optimised, and the work it calls lives in the libraries.
set(OWLCAL_TEST_TMPDIR ${CMAKE_BINARY_DIR}/test-tmp)
file(MAKE_DIRECTORY ${OWLCAL_TEST_TMPDIR})
function(owlcal_tests folder)
  cmake_parse_arguments(ARG "" "" "LIBS" ${ARGN})
  file(GLOB tests CONFIGURE_DEPENDS ${CMAKE_SOURCE_DIR}/tests/${folder}/*_test.cc)
  set(unit_srcs)
  set(e2e_srcs)
  set(mc_srcs)
  foreach(t ${tests})
    get_filename_component(stem ${t} NAME_WE)
    if("${folder}_${stem}" MATCHES "${OWLCAL_MC_TESTS}")
      list(APPEND mc_srcs ${t})
    elseif("${folder}_${stem}" MATCHES "${OWLCAL_E2E_TESTS}")
      list(APPEND e2e_srcs ${t})
    else()
      list(APPEND unit_srcs ${t})
    endif()
  endforeach()
  set(targets)
  foreach(tier unit e2e mc)
    if(NOT ${tier}_srcs)
      continue()
    endif()
    # COST: ctest -j starts the long tiers first, so the longest test is not left running alone
    # at the end of the run.
    if(tier STREQUAL "unit")
      set(exe ${folder}_tests)
      set(timeout 300)
      set(cost 1)
    else()
      set(exe ${folder}_${tier}_tests)
      set(timeout 900)
      set(cost 100)
      if(tier STREQUAL "mc")
        set(timeout 1500)
        set(cost 10000)
      endif()
    endif()
    add_executable(${exe} ${${tier}_srcs})
    target_link_libraries(${exe} PRIVATE ${ARG_LIBS} GTest::gtest GTest::gtest_main)
    target_compile_options(${exe} PRIVATE -O1)
    owlcal_use_pch(${exe} test)
    owlcal_unity(${exe})
    # Each build folder gets its own TMPDIR: suites of several checkouts (or a CI and a developer)
    # running at once never share std::filesystem::temp_directory_path() folders.
    # A suite of OWLCAL_ONE_PROCESS_SUITES records (or calibrates) once in SetUpTestSuite for all
    # its tests: it is one ctest test running the whole suite, not one process per test that
    # would each record it again.
    set(whole_suites)
    foreach(src ${${tier}_srcs})
      foreach(suite ${OWLCAL_ONE_PROCESS_SUITES})
        file(STRINGS ${src} uses REGEX "^TEST_F\\(${suite},")
        if(uses)
          list(APPEND whole_suites ${suite})
        endif()
      endforeach()
    endforeach()
    set(filter "*")
    if(whole_suites)
      list(JOIN whole_suites ".*:" negative)
      set(filter "-${negative}.*")
    endif()
    gtest_discover_tests(${exe} DISCOVERY_TIMEOUT 60 TEST_FILTER ${filter}
                         PROPERTIES ENVIRONMENT "TMPDIR=${OWLCAL_TEST_TMPDIR}" LABELS ${tier} TIMEOUT ${timeout} COST ${cost})
    foreach(suite ${whole_suites})
      add_test(NAME ${suite}.AllTests COMMAND ${exe} --gtest_filter=${suite}.*)
      set_tests_properties(${suite}.AllTests PROPERTIES ENVIRONMENT "TMPDIR=${OWLCAL_TEST_TMPDIR}" LABELS ${tier}
                           TIMEOUT ${timeout} COST ${cost})
    endforeach()
    list(APPEND targets ${exe})
  endforeach()
  set(OWLCAL_TEST_TARGETS_${folder} ${targets} PARENT_SCOPE)
endfunction()
