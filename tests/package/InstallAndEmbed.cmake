# cmake -P script: installs the voxcut build VOXCUT_BINARY_DIR into WORK_DIR/install, configures
# and builds the example EXAMPLE_SOURCE_DIR against it in WORK_DIR/embed_world, and runs it.
# CONFIG is the build type; CMAKE_GENERATOR, CMAKE_CXX_COMPILER, CMAKE_CXX_COMPILER_LAUNCHER and
# the flags, when given, are passed on to the example's configuration. Fails on the first step
# that fails, naming it.
cmake_minimum_required(VERSION 3.25)

foreach(var VOXCUT_BINARY_DIR EXAMPLE_SOURCE_DIR WORK_DIR)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "InstallAndEmbed.cmake: ${var} is not set")
  endif()
endforeach()

set(prefix ${WORK_DIR}/install)
set(example_build ${WORK_DIR}/embed_world)
# A fresh prefix and build every run, so that nothing left from an earlier run (a header since
# removed, a stale cache) can make the package look complete.
file(REMOVE_RECURSE ${prefix} ${example_build})

# run(step command...): runs the command quietly; if it fails, stops the script with its output.
function(run step)
  list(JOIN ARGN " " command_line)
  message(STATUS "${step}: ${command_line}")
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE result OUTPUT_VARIABLE output
                  ERROR_VARIABLE output)
  if(NOT result EQUAL 0)
    message(FATAL_ERROR "${step} failed (${result}):\n${output}")
  endif()
endfunction()

set(config_args)
if(CONFIG)
  set(config_args --config ${CONFIG})
endif()
run(install ${CMAKE_COMMAND} --install ${VOXCUT_BINARY_DIR} --prefix ${prefix} ${config_args})

# The world API's header closure (docs/architecture.md, "The world API"): a translation unit
# that includes only the installed voxcut/sim/World.h reaches no header of fem/, linalg/,
# topology/, octree/ or surface/.
# EIGEN_INCLUDE is Eigen's include folder (the build passes it).
if(CMAKE_CXX_COMPILER AND EIGEN_INCLUDE)
  set(closure_source ${WORK_DIR}/world_closure.cpp)
  file(WRITE ${closure_source} "#include \"voxcut/sim/World.h\"\n")
  set(eigen_flags)
  foreach(dir IN LISTS EIGEN_INCLUDE)
    list(APPEND eigen_flags -I${dir})
  endforeach()
  execute_process(COMMAND ${CMAKE_CXX_COMPILER} -std=c++20 -M -I${prefix}/include
                          ${eigen_flags} ${closure_source}
                  RESULT_VARIABLE result OUTPUT_VARIABLE closure ERROR_VARIABLE closure)
  if(NOT result EQUAL 0)
    message(FATAL_ERROR "closure failed (${result}): World.h alone does not compile:\n${closure}")
  endif()
  if(NOT closure MATCHES "include/voxcut/sim/World\\.h")
    message(FATAL_ERROR "closure failed: the installed World.h was not the one included")
  endif()
  string(REGEX MATCHALL "voxcut/(fem|linalg|topology|octree|surface)/[A-Za-z0-9_]+\\.h" leaked
               "${closure}")
  if(leaked)
    list(REMOVE_DUPLICATES leaked)
    message(FATAL_ERROR "closure failed: World.h reaches module internals: ${leaked}")
  endif()
  message(STATUS "closure: World.h reaches only its value types")
endif()

set(configure_args -S ${EXAMPLE_SOURCE_DIR} -B ${example_build} -DCMAKE_PREFIX_PATH=${prefix})
if(CONFIG)
  list(APPEND configure_args -DCMAKE_BUILD_TYPE=${CONFIG})
endif()
if(CMAKE_GENERATOR)
  list(APPEND configure_args -G ${CMAKE_GENERATOR})
endif()
foreach(var CMAKE_CXX_COMPILER CMAKE_CXX_COMPILER_LAUNCHER CMAKE_CXX_FLAGS CMAKE_EXE_LINKER_FLAGS)
  if(DEFINED ${var})
    list(APPEND configure_args "-D${var}=${${var}}")
  endif()
endforeach()
# The flags of the build type (CMAKE_CXX_FLAGS_RELWITHDEBINFO, ...), whichever was passed.
get_cmake_property(variables VARIABLES)
foreach(var IN LISTS variables)
  if(var MATCHES "^CMAKE_CXX_FLAGS_[A-Z]+$")
    list(APPEND configure_args "-D${var}=${${var}}")
  endif()
endforeach()
run(configure ${CMAKE_COMMAND} ${configure_args})
run(build ${CMAKE_COMMAND} --build ${example_build} ${config_args})

# Single-configuration generators put the program at the top of the build, multi-configuration
# ones in a folder per configuration.
set(program ${example_build}/embed_world)
if(NOT EXISTS ${program} AND CONFIG)
  set(program ${example_build}/${CONFIG}/embed_world)
endif()
message(STATUS "run: ${program}")
execute_process(COMMAND ${program} RESULT_VARIABLE result)
if(NOT result EQUAL 0)
  message(FATAL_ERROR "run failed (${result})")
endif()
