# Installs voxcut as a CMake package: every module library (voxcut::core ... voxcut::io), the
# convenience target voxcut::voxcut that links them all, the headers under
# include/voxcut/<module>/, the command line, and voxcutConfig.cmake with its version file, so
# that an application finds it with find_package(voxcut) (examples/embed_world shows how).
# Included after src/voxcut and apps/voxcut are added.
include(CMakePackageConfigHelpers)

# Every module, in the order they were added (the dependency order).
get_property(voxcut_module_targets GLOBAL PROPERTY VOXCUT_MODULES)

add_library(voxcut_all INTERFACE)
add_library(voxcut::voxcut ALIAS voxcut_all)
set_target_properties(voxcut_all PROPERTIES EXPORT_NAME voxcut)
target_link_libraries(voxcut_all INTERFACE ${voxcut_module_targets})

set(VOXCUT_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/voxcut)

install(TARGETS ${voxcut_module_targets} voxcut_all EXPORT voxcutTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(TARGETS voxcut RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
# The headers keep their layout: #include "voxcut/sim/World.h" works from the include folder.
# None is generated (the built-in bunny is a generated source file, not a header).
install(DIRECTORY ${PROJECT_SOURCE_DIR}/src/voxcut DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
        FILES_MATCHING PATTERN "*.h")
install(EXPORT voxcutTargets NAMESPACE voxcut:: DESTINATION ${VOXCUT_INSTALL_CMAKEDIR})

# The module names, for find_package(voxcut COMPONENTS ...).
list(TRANSFORM voxcut_module_targets REPLACE "^voxcut_" "" OUTPUT_VARIABLE VOXCUT_MODULE_NAMES)
list(JOIN VOXCUT_MODULE_NAMES ", " VOXCUT_MODULE_LIST)
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/voxcutConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/voxcutConfig.cmake
                              INSTALL_DESTINATION ${VOXCUT_INSTALL_CMAKEDIR})
# Before 1.0, a minor version may break the API.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/voxcutConfigVersion.cmake
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/voxcutConfig.cmake
              ${PROJECT_BINARY_DIR}/voxcutConfigVersion.cmake
        DESTINATION ${VOXCUT_INSTALL_CMAKEDIR})
