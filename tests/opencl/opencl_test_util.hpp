// What the OpenCL tests share: the device they run on, or a skip that says why there is none.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <memory>
#include <string>

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

}  // namespace mctstereo::test

/// Starts an OpenCL test: `rt` is the runtime; skips (saying why) when there is no device.
#define MCTSTEREO_OPENCL_TEST_RUNTIME(rt)                                            \
  const auto rt = ::mctstereo::test::test_runtime();                                 \
  if (!rt) GTEST_SKIP() << "no OpenCL device (install pocl-opencl-icd to run this test)"
