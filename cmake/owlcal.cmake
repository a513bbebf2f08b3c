# owlcal_library(NAME DEPS ...): a static library from every .cc in the folder NAME.
# Headers are included from the repository root ("models/servo_map.h").
function(owlcal_library name)
  cmake_parse_arguments(ARG "" "" "DEPS" ${ARGN})
  file(GLOB srcs CONFIGURE_DEPENDS ${CMAKE_SOURCE_DIR}/${name}/*.cc)
  if(srcs)
    add_library(owlcal_${name} STATIC ${srcs})
    target_include_directories(owlcal_${name} PUBLIC ${CMAKE_SOURCE_DIR} ${CMAKE_BINARY_DIR}/generated)
    target_link_libraries(owlcal_${name} PUBLIC ${ARG_DEPS})
  else()
    add_library(owlcal_${name} INTERFACE)
    target_include_directories(owlcal_${name} INTERFACE ${CMAKE_SOURCE_DIR} ${CMAKE_BINARY_DIR}/generated)
    target_link_libraries(owlcal_${name} INTERFACE ${ARG_DEPS})
  endif()
endfunction()

# owlcal_tests(FOLDER LIBS ...): one GoogleTest executable per tests/FOLDER/*_test.cc.
# Every test carries its tier as a ctest label and a timeout per test (ctest -L unit runs the fast
# tier alone): executables matching the regex OWLCAL_MC_TESTS are "mc" (Monte-Carlo over robots,
# 1500 s), OWLCAL_E2E_TESTS "e2e" (whole protocols recorded and fitted, the served virtual Owl, or
# the owlcal program run; 900 s), all others "unit" (300 s).
set(OWLCAL_TEST_TMPDIR ${CMAKE_BINARY_DIR}/test-tmp)
file(MAKE_DIRECTORY ${OWLCAL_TEST_TMPDIR})
function(owlcal_tests folder)
  cmake_parse_arguments(ARG "" "" "LIBS" ${ARGN})
  file(GLOB tests CONFIGURE_DEPENDS ${CMAKE_SOURCE_DIR}/tests/${folder}/*_test.cc)
  foreach(t ${tests})
    get_filename_component(stem ${t} NAME_WE)
    set(exe ${folder}_${stem})
    add_executable(${exe} ${t})
    target_link_libraries(${exe} PRIVATE ${ARG_LIBS} GTest::gtest GTest::gtest_main)
    if(exe MATCHES "${OWLCAL_MC_TESTS}")
      set(tier mc)
      set(timeout 1500)
    elseif(exe MATCHES "${OWLCAL_E2E_TESTS}")
      set(tier e2e)
      set(timeout 900)
    else()
      set(tier unit)
      set(timeout 300)
    endif()
    # Each build folder gets its own TMPDIR: suites of several checkouts (or a CI and a developer)
    # running at once never share std::filesystem::temp_directory_path() folders.
    gtest_discover_tests(${exe} DISCOVERY_TIMEOUT 60
                         PROPERTIES ENVIRONMENT "TMPDIR=${OWLCAL_TEST_TMPDIR}" LABELS ${tier} TIMEOUT ${timeout})
  endforeach()
endfunction()
