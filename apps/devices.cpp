#include "devices.hpp"

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "mctstereo/mctstereo.hpp"

namespace mctstereo::app {

namespace {

constexpr const char* kInstallHint =
    "To run the opencl backend, install an OpenCL driver with its ICD:\n"
    "  CPU (any x86-64 or ARM): PoCL, e.g. 'apt-get install pocl-opencl-icd' (Debian, Ubuntu)\n"
    "  GPU: the vendor's driver with OpenCL (NVIDIA: the proprietary driver, e.g. nvidia-opencl-icd;\n"
    "       AMD: ROCm or mesa-opencl-icd; Intel: intel-opencl-icd)\n"
    "'clinfo -l' lists what the OpenCL ICD loader finds.\n";

constexpr const char* kDevicesFooter =
    "Choose a device with --device INDEX or --device TEXT (a part of its name or platform) on match, eval and "
    "bench, with --backend opencl or auto. Without --device, the first GPU is used, else the first device.\n";

std::string gib(std::uint64_t bytes) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f GiB", static_cast<double>(bytes) / (1024.0 * 1024.0 * 1024.0));
  return buf;
}

}  // namespace

DevicesCommand::DevicesCommand(CLI::App& parent)
    : command_(parent.add_subcommand("devices", "list the OpenCL platforms and devices of --backend opencl")) {
  command_->footer(kDevicesFooter);
}

void DevicesCommand::run() const {
  if (!have_opencl()) {
    std::printf(
        "This build of mctstereo has no opencl backend: it was built without OpenCL's headers and ICD loader.\n"
        "Install them (Debian: ocl-icd-opencl-dev opencl-clhpp-headers opencl-c-headers) and rebuild.\n");
    return;
  }
  const std::vector<OpenclDevice> devices = opencl_devices();
  if (devices.empty()) {
    std::printf("No OpenCL device found: no OpenCL platform is installed, or none has a device.\n%s", kInstallHint);
    return;
  }
  // The device --backend opencl and auto take without --device.
  int default_index = devices.front().index;
  for (const OpenclDevice& d : devices)
    if (d.type == "GPU") {
      default_index = d.index;
      break;
    }
  std::string platform;
  for (const OpenclDevice& d : devices) {
    if (d.platform != platform) {
      platform = d.platform;
      std::printf("platform %s\n", platform.c_str());
    }
    std::printf("  %d: %s (%s)%s\n", d.index, d.name.c_str(), d.type.c_str(),
                d.index == default_index ? "  [default]" : "");
    std::printf("     %s; %s; driver %s\n", d.version.c_str(), d.c_version.c_str(), d.driver.c_str());
    std::printf("     %d compute units, %s global memory (largest buffer %s), popcount built-in %s\n",
                d.compute_units, gib(d.global_memory).c_str(), gib(d.max_allocation).c_str(),
                d.has_popcount ? "yes" : "no (OpenCL C 1.1: bits are counted in software)");
  }
  bool any_gpu = false;
  for (const OpenclDevice& d : devices) any_gpu = any_gpu || d.type == "GPU";
  if (!any_gpu)
    std::printf("No GPU: --backend auto runs on the cpu backend; --backend opencl runs on device %d.\n",
                default_index);
  std::printf("%s", kDevicesFooter);
}

}  // namespace mctstereo::app
