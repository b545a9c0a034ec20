# Warnings for our own targets only (never for dependencies).
add_library(shadefit_warnings INTERFACE)
target_compile_options(shadefit_warnings INTERFACE -Wall -Wextra -Wpedantic -Wno-unused-parameter)
add_library(shadefit::warnings ALIAS shadefit_warnings)

add_library(shadefit_sanitizers INTERFACE)
if(SHADEFIT_SANITIZE)
  target_compile_options(shadefit_sanitizers INTERFACE -fsanitize=address,undefined
                                                       -fno-omit-frame-pointer)
  target_link_options(shadefit_sanitizers INTERFACE -fsanitize=address,undefined)
endif()

# shadefit_add_test(<name> SOURCES <files...> LIBS <targets...> [LABELS <labels...>])
# Builds one GoogleTest executable and registers its tests with CTest. Test output (failure
# images) goes to ${CMAKE_BINARY_DIR}/test_output, passed as SHADEFIT_TEST_OUTPUT.
function(shadefit_add_test name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBS;LABELS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} GTest::gtest GTest::gtest_main
                                        shadefit::warnings shadefit_sanitizers)
  target_compile_definitions(${name} PRIVATE
      SHADEFIT_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
      SHADEFIT_TEST_OUTPUT="${CMAKE_BINARY_DIR}/test_output")
  gtest_discover_tests(${name} DISCOVERY_TIMEOUT 60
                       PROPERTIES LABELS "${ARG_LABELS}" SKIP_REGULAR_EXPRESSION "\\[  SKIPPED \\]")
endfunction()
