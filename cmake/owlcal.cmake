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
function(owlcal_tests folder)
  cmake_parse_arguments(ARG "" "" "LIBS" ${ARGN})
  file(GLOB tests CONFIGURE_DEPENDS ${CMAKE_SOURCE_DIR}/tests/${folder}/*_test.cc)
  foreach(t ${tests})
    get_filename_component(stem ${t} NAME_WE)
    set(exe ${folder}_${stem})
    add_executable(${exe} ${t})
    target_link_libraries(${exe} PRIVATE ${ARG_LIBS} GTest::gtest GTest::gtest_main)
    gtest_discover_tests(${exe} DISCOVERY_TIMEOUT 60
      PROPERTIES ENVIRONMENT "OWLCAL_SHARED_DATA=${OWLCAL_SHARED_DATA}")
  endforeach()
endfunction()
