// The opencl backend from the command line: `mctstereo devices`, match and bench with --backend
// opencl and auto, --device, and the messages when there is no device. Tests that need a device
// skip, saying so, where there is none; MCTSTEREO_REQUIRE_OPENCL=1 (CI) makes that a failure. The
// tests of a machine without OpenCL run everywhere: OCL_ICD_VENDORS pointed at an empty folder
// hides every driver from the OpenCL ICD loader.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "cli_test_util.hpp"

namespace {

using mctstereo::test::kData;
using mctstereo::test::kProgram;
using mctstereo::test::read_text;
using mctstereo::test::Result;
using mctstereo::test::run_shell;
using mctstereo::test::shell_quoted;

namespace fs = std::filesystem;

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

class OpenclCli : public mctstereo::test::FolderTest {
 protected:
  void SetUp() override {
    FolderTest::SetUp();
    fs::create_directories(folder_ / "no_vendors");
    copy_tsukuba_pair();
  }

  // Runs `mctstereo ARGS` in the test folder; without_drivers hides every OpenCL driver.
  Result run(const std::string& args, bool without_drivers = false) const {
    return FolderTest::run(
        args, without_drivers ? "OCL_ICD_VENDORS=" + shell_quoted((folder_ / "no_vendors").string()) + " " : "");
  }

  // What `mctstereo devices` says; "" (and a failure under MCTSTEREO_REQUIRE_OPENCL=1) when this
  // build or machine has no OpenCL device.
  std::string device_listing() const {
    const Result r = run("devices");
    EXPECT_EQ(r.status, 0) << r.output;
    if (contains(r.output, "  0: ")) return r.output;
    const char* require = std::getenv("MCTSTEREO_REQUIRE_OPENCL");
    if (require != nullptr && std::string(require) == "1") ADD_FAILURE() << "OpenCL device required:\n" << r.output;
    return "";
  }
  bool build_has_opencl() const { return !contains(run("devices").output, "has no opencl backend"); }
};

#define SKIP_WITHOUT_OPENCL_DEVICE()                                                     \
  const std::string devices = device_listing();                                         \
  if (devices.empty()) GTEST_SKIP() << "no OpenCL device (install pocl-opencl-icd to run this test)"

#define SKIP_WITHOUT_OPENCL_BUILD() \
  if (!build_has_opencl()) GTEST_SKIP() << "this build has no opencl backend"

const std::string kPair = "match left.png right.png --num-disparities 16 ";

TEST_F(OpenclCli, DevicesListsEveryDevice) {
  SKIP_WITHOUT_OPENCL_DEVICE();
  for (const char* part : {"platform ", "  0: ", "[default]", "OpenCL ", "OpenCL C ", "compute units",
                           "global memory", "popcount built-in ", "--device"})
    EXPECT_TRUE(contains(devices, part)) << part << " missing in:\n" << devices;
  EXPECT_TRUE(contains(devices, "(GPU)") || contains(devices, "(CPU)") || contains(devices, "(accelerator)") ||
              contains(devices, "(other)"))
      << devices;
}

TEST_F(OpenclCli, DevicesWithoutDriversSaysHowToInstallOne) {
  SKIP_WITHOUT_OPENCL_BUILD();
  const Result r = run("devices", true);
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(contains(r.output, "No OpenCL device found")) << r.output;
  EXPECT_TRUE(contains(r.output, "pocl-opencl-icd")) << r.output;
  EXPECT_TRUE(contains(r.output, "GPU: the vendor's driver")) << r.output;
}

TEST_F(OpenclCli, MatchOnOpenclWritesTheCpuBackendsFiles) {
  SKIP_WITHOUT_OPENCL_DEVICE();
  const Result ocl = run(kPair + "-o o.pfm --right-output o_right.pfm --backend opencl --device 0");
  ASSERT_EQ(ocl.status, 0) << ocl.output;
  const Result cpu = run(kPair + "-o c.pfm --right-output c_right.pfm --backend cpu");
  ASSERT_EQ(cpu.status, 0) << cpu.output;
  EXPECT_EQ(read_text(folder_ / "o.pfm"), read_text(folder_ / "c.pfm"));
  EXPECT_EQ(read_text(folder_ / "o_right.pfm"), read_text(folder_ / "c_right.pfm"));
  EXPECT_GT(read_text(folder_ / "o.pfm").size(), 384u * 288u * 4u);
  // One summary line with the device and the kernels' times.
  EXPECT_EQ(std::count(ocl.output.begin(), ocl.output.end(), '\n'), 1) << ocl.output;
  for (const char* part : {"backend opencl", ", device ", "upload ", " census ", " match ", " median ",
                           " lr_check ", " fill ", " output ", " download ", "frame "})
    EXPECT_TRUE(contains(ocl.output, part)) << part << " missing in: " << ocl.output;
  EXPECT_FALSE(contains(ocl.output, "SIMD")) << ocl.output;
}

// stream --temporal on the device: the same files as on the cpu backend, frame after frame, and
// the summary says that the last frame took the prior.
TEST_F(OpenclCli, StreamWithTheTemporalPriorWritesTheCpuBackendsFiles) {
  SKIP_WITHOUT_OPENCL_DEVICE();
  fs::create_directories(folder_ / "cpu");
  fs::create_directories(folder_ / "ocl");
  const std::string stream = "stream --synthetic 96x64 --max-frames 4 --preset quality --num-disparities 24 --temporal ";
  const Result ocl = run(stream + "--backend opencl --device 0 --disparity 'ocl/d%d.pfm'");
  ASSERT_EQ(ocl.status, 0) << ocl.output;
  const Result cpu = run(stream + "--backend cpu --disparity 'cpu/d%d.pfm'");
  ASSERT_EQ(cpu.status, 0) << cpu.output;
  EXPECT_TRUE(contains(ocl.output, "last frame: temporal prior")) << ocl.output;
  for (int f = 0; f < 4; ++f) {
    const std::string name = "d" + std::to_string(f) + ".pfm";
    EXPECT_GT(read_text(folder_ / "ocl" / name).size(), 96u * 64u * 4u) << name;
    EXPECT_EQ(read_text(folder_ / "ocl" / name), read_text(folder_ / "cpu" / name)) << name;
  }
}

TEST_F(OpenclCli, UnknownDeviceFailsListingTheDevices) {
  SKIP_WITHOUT_OPENCL_DEVICE();
  const Result r = run(kPair + "-o d.pfm --backend opencl --device 999");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_EQ(r.output.rfind("mctstereo: error: --device 999: OpenCL device 999 does not exist; the devices are:", 0),
            0u)
      << r.output;
  EXPECT_TRUE(contains(r.output, " 0: ")) << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << "one line expected:\n" << r.output;
  EXPECT_FALSE(fs::exists(folder_ / "d.pfm"));
}

TEST_F(OpenclCli, DeviceWithABackendWithoutDevicesIsAUsageError) {
  const Result r = run(kPair + "-o d.pfm --backend cpu --device 0");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_EQ(r.output, "mctstereo: error: --device 0: only --backend opencl and auto run on an OpenCL device\n");
  EXPECT_FALSE(fs::exists(folder_ / "d.pfm"));
  const Result bench = run("bench --backend reference --device 0 --sizes 64x48");
  EXPECT_EQ(bench.status, 2) << bench.output;
  EXPECT_EQ(bench.output, "mctstereo: error: --device 0: only --backend opencl and auto run on an OpenCL device\n");
}

TEST_F(OpenclCli, OpenclWithoutDriversFailsClearly) {
  SKIP_WITHOUT_OPENCL_BUILD();
  const Result r = run(kPair + "-o d.pfm --backend opencl", true);
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_EQ(r.output.rfind("mctstereo: error: --backend opencl: no OpenCL device: no OpenCL platform is installed", 0),
            0u)
      << r.output;
  EXPECT_FALSE(fs::exists(folder_ / "d.pfm"));
  const Result bench = run("bench --backend opencl --sizes 64x48", true);
  EXPECT_EQ(bench.status, 1) << bench.output;
  EXPECT_TRUE(contains(bench.output, "mctstereo: error: --backend opencl: no OpenCL device")) << bench.output;
}

TEST_F(OpenclCli, AutoWithoutGpuSaysSoAndMatchesOnTheCpu) {
  const Result hidden = run(kPair + "-o hidden.pfm --backend auto", true);
  ASSERT_EQ(hidden.status, 0) << hidden.output;
  EXPECT_TRUE(contains(hidden.output, "backend cpu")) << hidden.output;
  EXPECT_EQ(hidden.output.rfind("mctstereo: note: ", 0), 0u) << hidden.output;
  EXPECT_TRUE(contains(hidden.output, ": running on the cpu backend\n")) << hidden.output;
  const Result cpu = run(kPair + "-o cpu.pfm --backend cpu");
  ASSERT_EQ(cpu.status, 0) << cpu.output;
  EXPECT_EQ(read_text(folder_ / "hidden.pfm"), read_text(folder_ / "cpu.pfm"));

  // The same on this machine's drivers, when none of its devices is a GPU.
  const std::string devices = run("devices").output;
  if (contains(devices, "(GPU)")) return;
  const Result r = run(kPair + "-o auto.pfm --backend auto");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(contains(r.output, "backend cpu")) << r.output;
  if (build_has_opencl())
    EXPECT_EQ(r.output.rfind("mctstereo: note: no OpenCL GPU found: running on the cpu backend\n", 0), 0u) << r.output;
  EXPECT_EQ(read_text(folder_ / "auto.pfm"), read_text(folder_ / "cpu.pfm"));
}

TEST_F(OpenclCli, BenchTimesTheOpenclKernels) {
  SKIP_WITHOUT_OPENCL_DEVICE();
  const Result r = run("bench --sizes 64x48 --num-disparities 16 --presets realtime --backend opencl,cpu --threads 1 "
                       "--frames 2 --warmup 1 --min-time 0 --json b.json --data " +
                       shell_quoted((kData / "tsukuba").string()));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(contains(r.output, "OpenCL    ")) << r.output;
  // Two stage tables: the cpu backend's stages and the opencl backend's kernels.
  std::size_t tables = 0;
  for (std::size_t at = r.output.find("per-stage medians"); at != std::string::npos;
       at = r.output.find("per-stage medians", at + 1))
    ++tables;
  EXPECT_EQ(tables, 2u) << r.output;
  const std::string json = read_text(folder_ / "b.json");
  for (const char* part : {"\"opencl_device\": ", "\"backend\": \"opencl\"", "\"backend\": \"cpu\"", "\"upload\": ",
                           "\"lr_check\": ", "\"download\": ", "\"refine\": "})
    EXPECT_TRUE(contains(json, part)) << part << " missing in:\n" << json;
}

}  // namespace
