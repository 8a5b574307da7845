# twocam_add_library(NAME SOURCES ... PUBLIC_LIBS ... PRIVATE_LIBS ...)
# One static library per module (twocam_<name>, alias twocam::<name>), include root src/.
function(twocam_add_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_LIBS;PRIVATE_LIBS" ${ARGN})
  add_library(twocam_${name} STATIC ${ARG_SOURCES})
  add_library(twocam::${name} ALIAS twocam_${name})
  target_include_directories(twocam_${name} PUBLIC ${PROJECT_SOURCE_DIR}/src)
  target_compile_features(twocam_${name} PUBLIC cxx_std_17)
  target_link_libraries(twocam_${name} PUBLIC ${ARG_PUBLIC_LIBS} PRIVATE twocam_warnings ${ARG_PRIVATE_LIBS})
endfunction()

# twocam_add_test(NAME SOURCES ... LIBS ...): one GoogleTest binary, discovered by CTest.
function(twocam_add_test name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} twocam_test_support GTest::gtest GTest::gtest_main twocam_warnings)
  gtest_discover_tests(${name} DISCOVERY_TIMEOUT 60
                       PROPERTIES ENVIRONMENT "TWOCAM_SOURCE_DIR=${PROJECT_SOURCE_DIR}")
endfunction()
