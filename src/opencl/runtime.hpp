// The OpenCL runtime of the opencl backend: devices, one context and profiling queue per device,
// programs built once per (kernel file, build options) from the sources embedded in the library,
// device planes, and the errors a user can act on.
#pragma once

#define CL_HPP_TARGET_OPENCL_VERSION 120
#define CL_HPP_MINIMUM_OPENCL_VERSION 110
#define CL_HPP_ENABLE_EXCEPTIONS
#include <CL/opencl.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "plane.hpp"

namespace mctstereo::detail::opencl {

struct DeviceInfo {
  int index = -1;  ///< position in list_devices()
  std::string platform, name, vendor, version, c_version, driver;
  bool gpu = false;
  std::uint64_t global_memory = 0, max_allocation = 0;
  int compute_units = 0;
  /// OpenCL C 1.2 or later: the popcount built-in exists (1.1 devices take the SWAR form).
  bool has_popcount = false;
  cl::Device device;
};

/// Every device of every platform, platform by platform. Empty when there is no OpenCL platform
/// (no ICD loader configuration or no driver installed).
std::vector<DeviceInfo> list_devices();

/// The device a selector names: "" prefers the first GPU, else the first device; a number is an
/// index into list_devices(); other text picks the first device whose name or platform name
/// contains it (case-insensitive). std::runtime_error naming the devices there are otherwise.
DeviceInfo choose_device(const std::string& selector);

/// The text of the embedded kernel file src/opencl/kernels/NAME.cl; std::logic_error if unknown.
std::string_view kernel_source(std::string_view name);

/// "clEnqueueNDRangeKernel: CL_OUT_OF_RESOURCES (-5)".
std::string describe(const cl::Error& error);

/// One device: context, an in-order queue with profiling, the programs built for it, and the
/// profiling events of the kernels run since reset_times().
class Runtime {
 public:
  explicit Runtime(const DeviceInfo& device);
  Runtime(const Runtime&) = delete;
  Runtime& operator=(const Runtime&) = delete;

  const DeviceInfo& device() const { return device_; }
  cl::Context& context() { return context_; }
  cl::CommandQueue& queue() { return queue_; }

  /// A new kernel object for kernel `name` of the program built from kernel file `file` with
  /// `options` (-D ...). Builds on first use per (file, options); std::runtime_error with the
  /// build log if that fails. It allocates (the key, the kernel): stages call it when they are
  /// made, not per frame.
  cl::Kernel kernel(std::string_view file, std::string_view name, const std::string& options = "");

  /// Enqueues `kernel` and keeps its event under `label` for for_each_kernel_time().
  void run(const cl::Kernel& kernel, const cl::NDRange& global, const cl::NDRange& local, const char* label);

  /// Calls fn(label, milliseconds) for each kernel enqueued since the last reset_times(), in
  /// enqueue order, with the device time it took; waits for the queue to finish first.
  template <typename Fn>
  void for_each_kernel_time(Fn&& fn) {
    queue_.finish();
    for (const auto& [label, event] : events_) fn(label, milliseconds(event));
  }
  /// Device milliseconds per label (summed, in first-run order) of the kernels enqueued since the
  /// last reset_times(); waits for the queue to finish.
  std::vector<std::pair<std::string, double>> kernel_times();
  /// Forgets the events. Their list keeps its capacity, so that frames after the first record
  /// theirs without allocating.
  void reset_times();

  /// A device buffer; std::runtime_error naming the size and the device when it cannot be had.
  cl::Buffer buffer(std::size_t bytes, cl_mem_flags flags = CL_MEM_READ_WRITE);

 private:
  static double milliseconds(const cl::Event& event);  // from the event's profiling times

  DeviceInfo device_;
  cl::Context context_;
  cl::CommandQueue queue_;
  std::mutex programs_mutex_;
  std::map<std::string, cl::Program> programs_;  // key: file + '\n' + options
  std::vector<std::pair<const char*, cl::Event>> events_;
};

/// The runtime of a device, shared by every matcher of the process, so that programs are built
/// once per (device, options).
std::shared_ptr<Runtime> runtime_for(const DeviceInfo& device);

/// A 2-D plane in device memory: rows of `stride` elements, stride a multiple of 16 elements so
/// that kernels may load 16 values of a row at once (vload16) without leaving it, plus 16 more
/// elements of slack after the last row.
template <typename T>
struct DevicePlane {
  cl::Buffer buffer;
  int width = 0, height = 0, stride = 0;

  void reset(Runtime& rt, int w, int h) {
    width = w;
    height = h;
    stride = (w + 15) / 16 * 16 + 16;
    buffer = rt.buffer(bytes());
  }
  std::size_t bytes() const { return (static_cast<std::size_t>(stride) * height + 16) * sizeof(T); }
};

/// Census codes in device memory, planar as on the host (word k of every pixel in plane[k]).
struct DeviceCodes {
  int words = 0;
  DevicePlane<std::uint32_t> plane[3];
};

/// Host plane -> device plane of the same size (blocking).
template <typename T>
void upload(Runtime& rt, const Plane<T>& src, DevicePlane<T>& dst) {
  const std::array<std::size_t, 3> origin{0, 0, 0};
  const std::array<std::size_t, 3> region{static_cast<std::size_t>(src.width()) * sizeof(T),
                                          static_cast<std::size_t>(src.height()), 1};
  if (src.width() == 0 || src.height() == 0) return;
  rt.queue().enqueueWriteBufferRect(dst.buffer, CL_TRUE, origin, origin, region, dst.stride * sizeof(T), 0,
                                    src.stride() * sizeof(T), 0, src.row(0));
}

/// Device plane -> host plane of the same size (blocking).
template <typename T>
void download(Runtime& rt, const DevicePlane<T>& src, Plane<T>& dst) {
  const std::array<std::size_t, 3> origin{0, 0, 0};
  const std::array<std::size_t, 3> region{static_cast<std::size_t>(dst.width()) * sizeof(T),
                                          static_cast<std::size_t>(dst.height()), 1};
  if (dst.width() == 0 || dst.height() == 0) return;
  rt.queue().enqueueReadBufferRect(src.buffer, CL_TRUE, origin, origin, region, src.stride * sizeof(T), 0,
                                   dst.stride() * sizeof(T), 0, dst.row(0));
}

}  // namespace mctstereo::detail::opencl
