// The OpenCL runtime: devices, programs built from the embedded sources, build errors, buffers.
#include <vector>

#include "opencl_test_util.hpp"

namespace mctstereo::test {
namespace {

using detail::opencl::Runtime;

TEST(OpenclRuntime, RunsAKernelOfTheEmbeddedSources) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  std::vector<int> data{1, 2, 3, 40};
  cl::Buffer buffer = rt->buffer(data.size() * sizeof(int));
  rt->queue().enqueueWriteBuffer(buffer, CL_TRUE, 0, data.size() * sizeof(int), data.data());
  cl::Kernel k = rt->kernel("smoke", "add_one");
  k.setArg(0, buffer);
  rt->reset_times();
  rt->run(k, cl::NDRange(data.size()), cl::NullRange, "add_one");
  rt->queue().enqueueReadBuffer(buffer, CL_TRUE, 0, data.size() * sizeof(int), data.data());
  EXPECT_EQ(data, (std::vector<int>{2, 3, 4, 41}));
  const auto times = rt->kernel_times();
  ASSERT_EQ(times.size(), 1u);
  EXPECT_EQ(times[0].first, "add_one");
  EXPECT_GE(times[0].second, 0.0);
}

TEST(OpenclRuntime, BuildErrorsCarryTheBuildLog) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  try {
    rt->kernel("smoke", "add_one", "-DMCTSTEREO_SMOKE_BUILD_ERROR");
    FAIL() << "the build should have failed";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("smoke.cl failed to build"), std::string::npos) << what;
    EXPECT_NE(what.find("build log"), std::string::npos) << what;
    EXPECT_NE(what.find("deliberate"), std::string::npos) << what;  // the #error text of smoke.cl
  }
}

TEST(OpenclRuntime, DeviceSelectionByIndexNameAndErrors) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  const auto devices = detail::opencl::list_devices();
  ASSERT_FALSE(devices.empty());
  EXPECT_EQ(detail::opencl::choose_device("0").name, devices[0].name);
  EXPECT_EQ(detail::opencl::choose_device(devices[0].name.substr(0, 4)).index, devices[0].index);
  EXPECT_THROW(detail::opencl::choose_device("999"), std::runtime_error);
  try {
    detail::opencl::choose_device("no-such-device-name");
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(devices[0].name), std::string::npos) << "the message lists the devices";
  }
}

TEST(OpenclRuntime, ImpossibleBufferIsAClearError) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  try {
    rt->buffer(static_cast<std::size_t>(1) << 62);
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("buffer of"), std::string::npos) << e.what();
  }
}

TEST(OpenclRuntime, PlanesRoundTrip) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  detail::Plane<std::int16_t> host(37, 5, 3);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 37; ++x) host.at(x, y) = static_cast<std::int16_t>(x * 100 - y);
  detail::opencl::DevicePlane<std::int16_t> dev;
  dev.reset(*rt, 37, 5);
  EXPECT_EQ(dev.stride % 16, 0);
  detail::opencl::upload(*rt, host, dev);
  detail::Plane<std::int16_t> back(37, 5);
  detail::opencl::download(*rt, dev, back);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 37; ++x) ASSERT_EQ(back.at(x, y), host.at(x, y));
}

}  // namespace
}  // namespace mctstereo::test
