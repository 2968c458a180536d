# One helper for every library and every test, so that all targets share warnings and layout.

set(PANOSCAN_WARNINGS -Wall -Wextra -Wno-unused-parameter)

# panoscan_add_library(NAME SOURCES ... PUBLIC_DEPS ... PRIVATE_DEPS ...)
# The public include directory is <folder>/include (headers under include/panoscan/<part>/).
function(panoscan_add_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(${name} STATIC ${ARG_SOURCES})
  target_include_directories(${name} PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include)
  target_link_libraries(${name} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  target_compile_options(${name} PRIVATE ${PANOSCAN_WARNINGS})
endfunction()

# panoscan_add_test(NAME SOURCES ... DEPS ... [LABELS ...])
function(panoscan_add_test name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS;LABELS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} GTest::gtest_main GTest::gmock)
  target_compile_options(${name} PRIVATE ${PANOSCAN_WARNINGS})
  target_compile_definitions(${name} PRIVATE
    PANOSCAN_BINARY_DIR="${CMAKE_BINARY_DIR}" PANOSCAN_SOURCE_DIR="${CMAKE_SOURCE_DIR}")
  add_test(NAME ${name} COMMAND ${name})
  set_tests_properties(${name} PROPERTIES WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR})
  if(ARG_LABELS)
    set_tests_properties(${name} PROPERTIES LABELS "${ARG_LABELS}")
  endif()
endfunction()
