# Warnings for our own targets only (never for dependencies).
add_library(shadefit_warnings INTERFACE)
target_compile_options(shadefit_warnings INTERFACE -Wall -Wextra -Wpedantic -Wno-unused-parameter)
# In a unity build every source is an included file, so GCC's -Wsubobject-linkage, meant for a
# header that defines a class deriving from a type of an anonymous namespace, fires on a source's
# own GoogleTest fixtures (TEST_F of a fixture in the source's anonymous namespace): seen on two
# tests of tests/cli/bad_input_test.cpp. In a source of its own that is correct code.
if(CMAKE_UNITY_BUILD AND CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
  target_compile_options(shadefit_warnings INTERFACE -Wno-subobject-linkage)
endif()
add_library(shadefit::warnings ALIAS shadefit_warnings)

# Sanitizers apply to every target (libraries, the CLI, tests), not only to the test programs: a
# heap overflow in a parser is found only where the parser itself is instrumented. UBSan findings
# abort (-fno-sanitize-recover) so that a report fails the test that caused it
# (scripts/sanitizer-check.sh). SHADEFIT_FUZZ (clang only) adds libFuzzer's coverage
# instrumentation for the harnesses in tests/fuzz/ (scripts/fuzz-check.sh).
add_library(shadefit_sanitizers INTERFACE)
# UBSan's four pointer checks, which shadefit_without_pointer_checks() turns off in the
# automatic-differentiation kernels (see there).
set(SHADEFIT_POINTER_CHECKS alignment,null,object-size,pointer-overflow)
if(SHADEFIT_SANITIZE OR SHADEFIT_FUZZ)
  set(SHADEFIT_SANITIZER_FLAGS -fsanitize=address,undefined -fno-sanitize-recover=undefined
                               -fno-omit-frame-pointer)
  if(SHADEFIT_FUZZ)
    if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
      message(FATAL_ERROR "SHADEFIT_FUZZ needs clang (libFuzzer): configure with "
                          "-DCMAKE_CXX_COMPILER=clang++ -DCMAKE_C_COMPILER=clang")
    endif()
    list(APPEND SHADEFIT_SANITIZER_FLAGS -fsanitize=fuzzer-no-link)
  endif()
  # Eigen (Memory.h) stops trusting malloc's 16-byte alignment under __SANITIZE_ADDRESS__ and
  # switches to its hand-made aligned malloc, whose blocks must be freed by its own free. Debian's
  # libceres.a is built without ASan and frees Eigen storage with plain free(), so matrices that
  # cross between our code and Ceres (ceres::Covariance) were "freed at an address not
  # malloc()-ed" under ASan only. glibc's and ASan's mallocs are both 16-byte aligned on x86-64:
  # say so, and both sides agree again.
  list(APPEND SHADEFIT_SANITIZER_FLAGS -DEIGEN_MALLOC_ALREADY_ALIGNED=1)
  add_compile_options(${SHADEFIT_SANITIZER_FLAGS})
  add_link_options(-fsanitize=address,undefined)
endif()

# shadefit_without_pointer_checks(<sources...>)
# In a sanitizer build, compiles the given sources of the current directory without UBSan's
# alignment, null, object-size and pointer-overflow checks; every other UBSan check and
# AddressSanitizer stay on. Only for the automatic-differentiation kernels, where every residual
# runs through ceres::Jet<double, N>: the checks go on every reference into a Jet's Eigen
# storage, and code that carries them is too large for clang to inline Eigen's expression
# functions. On a Jet loop (clang 14, -O2) they cost 140x (0.09 s -> 12.8 s), and the test of a
# cycles-principled fit under environment light took 246 s instead of 7.5 s (docs/testing.md).
# ASan still checks every load and store in these files, which finds the out-of-bounds, null and
# use-after-free accesses the four checks would.
function(shadefit_without_pointer_checks)
  if(SHADEFIT_SANITIZE OR SHADEFIT_FUZZ)
    set_property(SOURCE ${ARGN} APPEND PROPERTY COMPILE_OPTIONS
                 -fno-sanitize=${SHADEFIT_POINTER_CHECKS})
  endif()
endfunction()

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
