include(GNUInstallDirs)

# Warnings as an INTERFACE target every voxcut target links.
add_library(voxcut_warnings INTERFACE)
target_compile_options(voxcut_warnings INTERFACE
  -Wall -Wextra -Wpedantic -Wshadow -Wconversion -Wno-sign-conversion
  -Wnon-virtual-dtor -Wold-style-cast -Woverloaded-virtual -Wnull-dereference)

# voxcut_add_module(name SOURCES ... DEPS ...): one library per module, target voxcut_<name>,
# used in the build as voxcut::<name> and installed under that name (cmake/VoxcutPackage.cmake
# installs every module listed in the global property VOXCUT_MODULES). The warnings are linked
# for the build only: a static library passes its private links on, and the warnings are no
# concern of an application that links the installed library.
function(voxcut_add_module name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(voxcut_${name} ${ARG_SOURCES})
  add_library(voxcut::${name} ALIAS voxcut_${name})
  set_target_properties(voxcut_${name} PROPERTIES EXPORT_NAME ${name})
  # The headers use C++20 (std::span, <=>): users of the installed targets get it too.
  target_compile_features(voxcut_${name} PUBLIC cxx_std_20)
  target_include_directories(voxcut_${name} PUBLIC $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/src>
                                                   $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_link_libraries(voxcut_${name} PUBLIC ${ARG_DEPS}
                        PRIVATE $<BUILD_INTERFACE:voxcut_warnings> ${ARG_PRIVATE_DEPS})
  set_property(GLOBAL APPEND PROPERTY VOXCUT_MODULES voxcut_${name})
endfunction()

# voxcut_add_test(name SOURCES ... DEPS ...): a GoogleTest executable registered with CTest.
function(voxcut_add_test name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} GTest::gtest GTest::gtest_main voxcut_warnings)
  target_compile_definitions(${name} PRIVATE VOXCUT_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
                             VOXCUT_BINARY_DIR="${PROJECT_BINARY_DIR}")
  gtest_discover_tests(${name} DISCOVERY_TIMEOUT 60 PROPERTIES TIMEOUT ${VOXCUT_TEST_TIMEOUT})
endfunction()
