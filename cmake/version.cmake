# mctstereo/version.hpp (macros and constants) and version() (the version of the library that runs),
# both from project(VERSION), generated into the build folder.
configure_file(${CMAKE_CURRENT_LIST_DIR}/version.hpp.in ${PROJECT_BINARY_DIR}/include/mctstereo/version.hpp @ONLY)
configure_file(${CMAKE_CURRENT_LIST_DIR}/version.cpp.in ${PROJECT_BINARY_DIR}/generated/version.cpp @ONLY)
target_sources(mctstereo PRIVATE ${PROJECT_BINARY_DIR}/generated/version.cpp)
target_include_directories(mctstereo PUBLIC $<BUILD_INTERFACE:${PROJECT_BINARY_DIR}/include>)
