#include "opencl/runtime.hpp"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>

namespace mctstereo::detail::opencl {

extern const std::pair<std::string_view, std::string_view> kKernelSources[];
extern const int kKernelSourceCount;

namespace {

const char* error_name(cl_int code) {
  switch (code) {
    case CL_DEVICE_NOT_FOUND: return "CL_DEVICE_NOT_FOUND";
    case CL_DEVICE_NOT_AVAILABLE: return "CL_DEVICE_NOT_AVAILABLE";
    case CL_COMPILER_NOT_AVAILABLE: return "CL_COMPILER_NOT_AVAILABLE";
    case CL_MEM_OBJECT_ALLOCATION_FAILURE: return "CL_MEM_OBJECT_ALLOCATION_FAILURE";
    case CL_OUT_OF_RESOURCES: return "CL_OUT_OF_RESOURCES";
    case CL_OUT_OF_HOST_MEMORY: return "CL_OUT_OF_HOST_MEMORY";
    case CL_BUILD_PROGRAM_FAILURE: return "CL_BUILD_PROGRAM_FAILURE";
    case CL_INVALID_VALUE: return "CL_INVALID_VALUE";
    case CL_INVALID_PLATFORM: return "CL_INVALID_PLATFORM";
    case CL_INVALID_DEVICE: return "CL_INVALID_DEVICE";
    case CL_INVALID_BUFFER_SIZE: return "CL_INVALID_BUFFER_SIZE";
    case CL_INVALID_BUILD_OPTIONS: return "CL_INVALID_BUILD_OPTIONS";
    case CL_INVALID_KERNEL_NAME: return "CL_INVALID_KERNEL_NAME";
    case CL_INVALID_KERNEL_ARGS: return "CL_INVALID_KERNEL_ARGS";
    case CL_INVALID_ARG_INDEX: return "CL_INVALID_ARG_INDEX";
    case CL_INVALID_ARG_VALUE: return "CL_INVALID_ARG_VALUE";
    case CL_INVALID_ARG_SIZE: return "CL_INVALID_ARG_SIZE";
    case CL_INVALID_WORK_GROUP_SIZE: return "CL_INVALID_WORK_GROUP_SIZE";
    case CL_INVALID_WORK_ITEM_SIZE: return "CL_INVALID_WORK_ITEM_SIZE";
    case CL_INVALID_GLOBAL_WORK_SIZE: return "CL_INVALID_GLOBAL_WORK_SIZE";
    case CL_INVALID_MEM_OBJECT: return "CL_INVALID_MEM_OBJECT";
    case CL_INVALID_COMMAND_QUEUE: return "CL_INVALID_COMMAND_QUEUE";
    case CL_PLATFORM_NOT_FOUND_KHR: return "CL_PLATFORM_NOT_FOUND_KHR (no OpenCL platform installed)";
    default: return "OpenCL error";
  }
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::string device_list_text(const std::vector<DeviceInfo>& devices) {
  std::string text;
  for (const DeviceInfo& d : devices)
    text += "\n  " + std::to_string(d.index) + ": " + d.name + " (" + d.platform + ", " + (d.gpu ? "GPU" : "not a GPU") +
            ")";
  return text;
}

// "OpenCL C 1.2 pocl" -> true for 1.2 and later.
bool c_version_at_least_1_2(const std::string& c_version) {
  int major = 0, minor = 0;
  if (std::sscanf(c_version.c_str(), "OpenCL C %d.%d", &major, &minor) != 2) return false;
  return major > 1 || (major == 1 && minor >= 2);
}

}  // namespace

std::string describe(const cl::Error& error) {
  return std::string(error.what()) + ": " + error_name(error.err()) + " (" + std::to_string(error.err()) + ")";
}

std::vector<DeviceInfo> list_devices() {
  std::vector<DeviceInfo> out;
  std::vector<cl::Platform> platforms;
  try {
    cl::Platform::get(&platforms);
  } catch (const cl::Error&) {
    return out;  // no platform: the ICD loader found no driver
  }
  for (const cl::Platform& platform : platforms) {
    std::vector<cl::Device> devices;
    try {
      platform.getDevices(CL_DEVICE_TYPE_ALL, &devices);
    } catch (const cl::Error&) {
      continue;  // a platform without devices
    }
    for (const cl::Device& device : devices) {
      DeviceInfo info;
      info.index = static_cast<int>(out.size());
      info.platform = platform.getInfo<CL_PLATFORM_NAME>();
      info.name = device.getInfo<CL_DEVICE_NAME>();
      info.vendor = device.getInfo<CL_DEVICE_VENDOR>();
      info.version = device.getInfo<CL_DEVICE_VERSION>();
      info.c_version = device.getInfo<CL_DEVICE_OPENCL_C_VERSION>();
      info.driver = device.getInfo<CL_DRIVER_VERSION>();
      info.gpu = (device.getInfo<CL_DEVICE_TYPE>() & CL_DEVICE_TYPE_GPU) != 0;
      info.global_memory = device.getInfo<CL_DEVICE_GLOBAL_MEM_SIZE>();
      info.max_allocation = device.getInfo<CL_DEVICE_MAX_MEM_ALLOC_SIZE>();
      info.compute_units = static_cast<int>(device.getInfo<CL_DEVICE_MAX_COMPUTE_UNITS>());
      info.has_popcount = c_version_at_least_1_2(info.c_version);
      info.device = device;
      // Names carry padding on some drivers.
      while (!info.name.empty() && (info.name.back() == ' ' || info.name.back() == '\0')) info.name.pop_back();
      out.push_back(std::move(info));
    }
  }
  return out;
}

DeviceInfo choose_device(const std::string& selector) {
  const std::vector<DeviceInfo> devices = list_devices();
  if (devices.empty())
    throw std::runtime_error(
        "no OpenCL device: no OpenCL platform is installed (for the CPU: apt-get install pocl-opencl-icd; for a GPU: "
        "the vendor's driver with its OpenCL ICD)");
  if (selector.empty()) {
    for (const DeviceInfo& d : devices)
      if (d.gpu) return d;
    return devices.front();
  }
  if (std::all_of(selector.begin(), selector.end(), [](unsigned char c) { return std::isdigit(c); })) {
    const long index = std::strtol(selector.c_str(), nullptr, 10);
    if (index >= 0 && index < static_cast<long>(devices.size())) return devices[index];
    throw std::runtime_error("OpenCL device " + selector + " does not exist; the devices are:" +
                             device_list_text(devices));
  }
  const std::string wanted = lower(selector);
  for (const DeviceInfo& d : devices)
    if (lower(d.name).find(wanted) != std::string::npos || lower(d.platform).find(wanted) != std::string::npos)
      return d;
  throw std::runtime_error("no OpenCL device matches '" + selector + "'; the devices are:" + device_list_text(devices));
}

std::string_view kernel_source(std::string_view name) {
  for (int i = 0; i < kKernelSourceCount; ++i)
    if (kKernelSources[i].first == name) return kKernelSources[i].second;
  throw std::logic_error("no embedded OpenCL kernel file '" + std::string(name) + "'");
}

Runtime::Runtime(const DeviceInfo& device) : device_(device) {
  try {
    context_ = cl::Context(device.device);
    queue_ = cl::CommandQueue(context_, device.device, CL_QUEUE_PROFILING_ENABLE);
  } catch (const cl::Error& e) {
    throw std::runtime_error("cannot open OpenCL device " + device.name + ": " + describe(e));
  }
  events_.reserve(256);
}

cl::Kernel Runtime::kernel(std::string_view file, std::string_view name, const std::string& options) {
  const std::string key = std::string(file) + '\n' + options;
  cl::Program program;
  {
    std::lock_guard<std::mutex> lock(programs_mutex_);
    auto it = programs_.find(key);
    if (it == programs_.end()) {
      const std::string_view source = kernel_source(file);
      cl::Program built(context_, std::string(source));
      try {
        built.build(std::vector<cl::Device>{device_.device}, options.c_str());
      } catch (const cl::Error& e) {
        std::string log;
        try {
          log = built.getBuildInfo<CL_PROGRAM_BUILD_LOG>(device_.device);
        } catch (const cl::Error&) {
        }
        throw std::runtime_error("OpenCL kernel file " + std::string(file) + ".cl failed to build for " + device_.name +
                                 " (options '" + options + "'): " + describe(e) + "\nbuild log:\n" + log);
      }
      it = programs_.emplace(key, built).first;
    }
    program = it->second;
  }
  try {
    return cl::Kernel(program, std::string(name).c_str());
  } catch (const cl::Error& e) {
    throw std::runtime_error("OpenCL kernel " + std::string(name) + " of " + std::string(file) + ".cl: " + describe(e));
  }
}

void Runtime::run(const cl::Kernel& kernel, const cl::NDRange& global, const cl::NDRange& local, const char* label) {
  cl::Event event;
  try {
    queue_.enqueueNDRangeKernel(kernel, cl::NullRange, global, local, nullptr, &event);
  } catch (const cl::Error& e) {
    if (e.err() == CL_OUT_OF_RESOURCES || e.err() == CL_MEM_OBJECT_ALLOCATION_FAILURE)
      throw std::runtime_error(std::string("OpenCL device ") + device_.name + " ran out of memory or resources in " +
                               label + ": " + describe(e));
    throw std::runtime_error(std::string("OpenCL kernel ") + label + ": " + describe(e));
  }
  events_.emplace_back(label, std::move(event));
}

std::vector<std::pair<std::string, double>> Runtime::kernel_times() {
  std::vector<std::pair<std::string, double>> times;
  for_each_kernel_time([&](const char* label, double ms) {
    auto it = std::find_if(times.begin(), times.end(), [&](const auto& t) { return t.first == label; });
    if (it == times.end()) times.emplace_back(label, ms);
    else it->second += ms;
  });
  return times;
}

double Runtime::milliseconds(const cl::Event& event) {
  const auto start = event.getProfilingInfo<CL_PROFILING_COMMAND_START>();
  const auto end = event.getProfilingInfo<CL_PROFILING_COMMAND_END>();
  return static_cast<double>(end - start) * 1e-6;
}

void Runtime::reset_times() { events_.clear(); }

cl::Buffer Runtime::buffer(std::size_t bytes, cl_mem_flags flags) {
  const std::size_t size = std::max<std::size_t>(bytes, 64);
  if (device_.max_allocation != 0 && size > device_.max_allocation)
    throw std::runtime_error("OpenCL device " + device_.name + " cannot hold a buffer of " + std::to_string(size) +
                             " bytes (its largest allocation is " + std::to_string(device_.max_allocation) + ")");
  try {
    return cl::Buffer(context_, flags, size);
  } catch (const cl::Error& e) {
    throw std::runtime_error("OpenCL device " + device_.name + " is out of memory for a buffer of " +
                             std::to_string(size) + " bytes: " + describe(e));
  }
}

std::shared_ptr<Runtime> runtime_for(const DeviceInfo& device) {
  static std::mutex mutex;
  // Kept for the life of the process: building programs costs far more than holding them.
  static std::map<std::string, std::shared_ptr<Runtime>> runtimes;  // key: platform, device, index
  const std::string key = device.platform + '\n' + device.name + '\n' + std::to_string(device.index);
  std::lock_guard<std::mutex> lock(mutex);
  auto& rt = runtimes[key];
  if (!rt) rt = std::make_shared<Runtime>(device);
  return rt;
}

}  // namespace mctstereo::detail::opencl
