# amctl_add_module(NAME name SOURCES ... [DEPS ...] [PRIVATE_DEPS ...])
# Creates library target amctl_<name> with alias amctl::<name>. Public headers live in
# include/amctl/<name>/; modules may depend only on modules below them.
function(amctl_add_module)
  cmake_parse_arguments(M "" "NAME" "SOURCES;DEPS;PRIVATE_DEPS" ${ARGN})
  set(target amctl_${M_NAME})
  add_library(${target} STATIC ${M_SOURCES})
  add_library(amctl::${M_NAME} ALIAS ${target})
  target_include_directories(${target} PUBLIC
    $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/include>)
  target_link_libraries(${target} PUBLIC ${M_DEPS} PRIVATE ${M_PRIVATE_DEPS})
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic)
  set_property(GLOBAL APPEND PROPERTY AMCTL_MODULES ${target})
endfunction()

# amctl_add_test(NAME name SOURCES ... DEPS ...): one GoogleTest executable, tests
# discovered into CTest. The working directory is the source tree root.
function(amctl_add_test)
  cmake_parse_arguments(T "" "NAME" "SOURCES;DEPS" ${ARGN})
  add_executable(${T_NAME} ${T_SOURCES})
  target_link_libraries(${T_NAME} PRIVATE ${T_DEPS} GTest::gtest GTest::gtest_main)
  target_compile_definitions(${T_NAME} PRIVATE
    AMCTL_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    AMCTL_BINARY_DIR="${PROJECT_BINARY_DIR}")
  # Test names carry the executable ("plan_tests.PlanStream.X"), so `ctest -R plan` selects a
  # module's suites.
  gtest_discover_tests(${T_NAME} WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
    TEST_PREFIX "${T_NAME}." DISCOVERY_TIMEOUT 60)
endfunction()
