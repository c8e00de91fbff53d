# cmake --install: the public headers (with the generated version.hpp), the library, the CMake package
# (find_package(mctstereo) -> mctstereo::mctstereo), the pkg-config file, and the mctstereo program
# and Python module when they are built.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(MCTSTEREO_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/mctstereo CACHE STRING
  "Where cmake --install puts mctstereoConfig.cmake, relative to the prefix")
set(MCTSTEREO_INSTALL_PKGCONFIGDIR ${CMAKE_INSTALL_LIBDIR}/pkgconfig CACHE STRING
  "Where cmake --install puts mctstereo.pc, relative to the prefix")

install(TARGETS mctstereo EXPORT mctstereoTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT development
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT runtime NAMELINK_COMPONENT development
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT runtime
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/mctstereo DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
  COMPONENT development FILES_MATCHING PATTERN "*.hpp")
install(FILES ${PROJECT_BINARY_DIR}/include/mctstereo/version.hpp DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/mctstereo
  COMPONENT development)

# The package. A static library carries its private dependencies (OpenMP, Highway, OpenCL) as link
# dependencies ($<LINK_ONLY:...>), so the config file finds them again; a shared one needs none.
get_target_property(MCTSTEREO_LIBRARY_TYPE mctstereo TYPE)
if(MCTSTEREO_LIBRARY_TYPE STREQUAL "STATIC_LIBRARY")
  set(MCTSTEREO_STATIC ON)
else()
  set(MCTSTEREO_STATIC OFF)
endif()
install(EXPORT mctstereoTargets NAMESPACE mctstereo:: FILE mctstereoTargets.cmake
  DESTINATION ${MCTSTEREO_INSTALL_CMAKEDIR} COMPONENT development)
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/mctstereoConfig.cmake.in
  ${PROJECT_BINARY_DIR}/package/mctstereoConfig.cmake
  INSTALL_DESTINATION ${MCTSTEREO_INSTALL_CMAKEDIR})
# 0.x: a new minor version may change the API, so only the same major.minor is compatible.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/package/mctstereoConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/package/mctstereoConfig.cmake ${PROJECT_BINARY_DIR}/package/mctstereoConfigVersion.cmake
  DESTINATION ${MCTSTEREO_INSTALL_CMAKEDIR} COMPONENT development)

# pkg-config. Static: the dependencies go into Requires and Libs, so that a plain
# `pkg-config --libs mctstereo` links; shared: into Requires.private and Libs.private.
set(MCTSTEREO_PC_REQUIRES "libhwy")
if(MCTSTEREO_WITH_OPENCL)
  string(APPEND MCTSTEREO_PC_REQUIRES " OpenCL")
endif()
set(MCTSTEREO_PC_OPENMP "${OpenMP_CXX_FLAGS}")
if(MCTSTEREO_STATIC)
  set(MCTSTEREO_PC_REQUIRES_PUBLIC "${MCTSTEREO_PC_REQUIRES}")
  set(MCTSTEREO_PC_REQUIRES_PRIVATE "")
  set(MCTSTEREO_PC_LIBS_PUBLIC "${MCTSTEREO_PC_OPENMP}")
  set(MCTSTEREO_PC_LIBS_PRIVATE "")
else()
  set(MCTSTEREO_PC_REQUIRES_PUBLIC "")
  set(MCTSTEREO_PC_REQUIRES_PRIVATE "${MCTSTEREO_PC_REQUIRES}")
  set(MCTSTEREO_PC_LIBS_PUBLIC "")
  set(MCTSTEREO_PC_LIBS_PRIVATE "${MCTSTEREO_PC_OPENMP}")
endif()
set(MCTSTEREO_PC_CFLAGS "")
if(MCTSTEREO_WITH_OPENCL)
  set(MCTSTEREO_PC_CFLAGS "-DMCTSTEREO_HAVE_OPENCL=1")
endif()
# ${pcfiledir} keeps the file valid wherever the prefix is moved: the path from the .pc file's
# folder back up to the prefix.
file(RELATIVE_PATH MCTSTEREO_PC_TO_PREFIX "/prefix/${MCTSTEREO_INSTALL_PKGCONFIGDIR}" "/prefix")
string(REGEX REPLACE "/$" "" MCTSTEREO_PC_TO_PREFIX "${MCTSTEREO_PC_TO_PREFIX}")
configure_file(${CMAKE_CURRENT_LIST_DIR}/mctstereo.pc.in ${PROJECT_BINARY_DIR}/package/mctstereo.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/package/mctstereo.pc DESTINATION ${MCTSTEREO_INSTALL_PKGCONFIGDIR}
  COMPONENT development)

if(TARGET mctstereo_cli)
  install(TARGETS mctstereo_cli RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT runtime)
endif()
