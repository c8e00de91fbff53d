# Writes OUTPUT, a C++ source holding every OpenCL C file of INPUTS (a ;-list) as a string, so that
# the library carries its kernels: run at build time by src/CMakeLists.txt.
set(body "")
foreach(file IN LISTS INPUTS)
  get_filename_component(name "${file}" NAME_WE)
  file(READ "${file}" text)
  # Raw string literals have a length limit per piece on some compilers: cut into 16 KB chunks.
  string(LENGTH "${text}" length)
  set(pieces "")
  set(offset 0)
  while(offset LESS length)
    string(SUBSTRING "${text}" ${offset} 16000 piece)
    string(APPEND pieces "R\"mctstereo_cl(${piece})mctstereo_cl\"\n")
    math(EXPR offset "${offset} + 16000")
  endwhile()
  string(APPEND body "    {\"${name}\",\n${pieces}},\n")
endforeach()
file(WRITE "${OUTPUT}.tmp" "// Generated from src/opencl/kernels/*.cl by cmake/embed_kernels.cmake: do not edit.
#include <string_view>
#include <utility>

namespace mctstereo::detail::opencl {

extern const std::pair<std::string_view, std::string_view> kKernelSources[];
extern const int kKernelSourceCount;

const std::pair<std::string_view, std::string_view> kKernelSources[] = {
${body}};
const int kKernelSourceCount = static_cast<int>(sizeof(kKernelSources) / sizeof(kKernelSources[0]));

}  // namespace mctstereo::detail::opencl
")
file(COPY_FILE "${OUTPUT}.tmp" "${OUTPUT}" ONLY_IF_DIFFERENT)
file(REMOVE "${OUTPUT}.tmp")
