// What the OpenCL tests share: the device they run on, or a skip that says why there is none; and
// device planes that start filled with a marker, so that a kernel that reads the padding after a
// row as data, or writes into it, is caught.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "opencl/runtime.hpp"

namespace mctstereo::test {

/// The runtime of the device the tests use (MCTSTEREO_TEST_DEVICE selects one as --device does;
/// default: the first device), or nullptr when this machine has none. With
/// MCTSTEREO_REQUIRE_OPENCL=1 (as in CI) a missing device fails the test instead.
inline std::shared_ptr<detail::opencl::Runtime> test_runtime() {
  const char* selector = std::getenv("MCTSTEREO_TEST_DEVICE");
  try {
    return detail::opencl::runtime_for(detail::opencl::choose_device(selector ? selector : "0"));
  } catch (const std::exception& e) {
    const char* require = std::getenv("MCTSTEREO_REQUIRE_OPENCL");
    if (require != nullptr && std::string(require) == "1") ADD_FAILURE() << "OpenCL device required: " << e.what();
    return nullptr;
  }
}

/// The byte every element of a fresh test plane is made of: as int16 0x7a7a, a disparity no stage
/// makes from the test maps; as float 1.9e35.
constexpr std::uint8_t kMarkerByte = 0x7a;

/// An element of marker bytes.
template <typename T>
T marker() {
  T v;
  std::memset(&v, kMarkerByte, sizeof v);
  return v;
}

/// A w x h device plane as the pipeline driver allocates it, every element (padding and slack
/// included) the marker.
template <typename T>
detail::opencl::DevicePlane<T> marked_plane(detail::opencl::Runtime& rt, int w, int h) {
  detail::opencl::DevicePlane<T> p;
  p.reset(rt, w, h);
  const std::vector<std::uint8_t> bytes(p.bytes(), kMarkerByte);
  rt.queue().enqueueWriteBuffer(p.buffer, CL_TRUE, 0, bytes.size(), bytes.data());
  return p;
}

/// A marked device plane holding `host`'s pixels.
template <typename T>
detail::opencl::DevicePlane<T> to_device(detail::opencl::Runtime& rt, const detail::Plane<T>& host) {
  detail::opencl::DevicePlane<T> p = marked_plane<T>(rt, host.width(), host.height());
  detail::opencl::upload(rt, host, p);
  return p;
}

template <typename T>
detail::Plane<T> to_host(detail::opencl::Runtime& rt, const detail::opencl::DevicePlane<T>& p) {
  detail::Plane<T> host(p.width, p.height);
  detail::opencl::download(rt, p, host);
  return host;
}

/// "" when every element after the pixels of each row, and the slack after the last row, still
/// holds the marker; otherwise where the first one that does not lies.
template <typename T>
std::string padding_difference(detail::opencl::Runtime& rt, const detail::opencl::DevicePlane<T>& p) {
  std::vector<T> all(p.bytes() / sizeof(T));
  rt.queue().enqueueReadBuffer(p.buffer, CL_TRUE, 0, p.bytes(), all.data());
  const T m = marker<T>();
  for (std::size_t i = 0; i < all.size(); ++i) {
    const int x = static_cast<int>(i % p.stride), y = static_cast<int>(i / p.stride);
    if (y < p.height && x < p.width) continue;
    if (std::memcmp(&all[i], &m, sizeof(T)) != 0)
      return y < p.height ? "row padding written at (" + std::to_string(x) + ", " + std::to_string(y) + ")"
                          : "slack after the last row written at element " + std::to_string(i);
  }
  return {};
}

}  // namespace mctstereo::test

/// Starts an OpenCL test: `rt` is the runtime; skips (saying why) when there is no device.
#define MCTSTEREO_OPENCL_TEST_RUNTIME(rt)                                            \
  const auto rt = ::mctstereo::test::test_runtime();                                 \
  if (!rt) GTEST_SKIP() << "no OpenCL device (install pocl-opencl-icd to run this test)"
