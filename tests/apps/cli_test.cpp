// Runs the built `mctstereo` program as a user would, in a temporary folder, and checks exit
// statuses, messages, and which files exist afterwards.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;

const fs::path kProgram = MCTSTEREO_CLI;
const fs::path kData = MCTSTEREO_DATA_DIR;

struct Result {
  int status = -1;
  std::string output;  // stdout and stderr together
};

std::string shell_quoted(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

std::vector<std::uint8_t> read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_bytes(const fs::path& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

// Every name in a folder, hidden ones included (a temporary left behind would be hidden).
std::set<std::string> folder_listing(const fs::path& folder) {
  std::set<std::string> names;
  for (const auto& entry : fs::directory_iterator(folder)) names.insert(entry.path().filename().string());
  return names;
}

// A PFM file read back: the values in top-to-bottom row order.
struct Pfm {
  int width = 0, height = 0;
  double scale = 0;
  std::vector<float> values;
};

Pfm read_pfm(const fs::path& path) {
  const std::vector<std::uint8_t> bytes = read_bytes(path);
  Pfm pfm;
  std::string text(bytes.begin(), bytes.begin() + std::min<std::size_t>(bytes.size(), 64));
  std::istringstream header(text);
  std::string magic;
  header >> magic >> pfm.width >> pfm.height >> pfm.scale;
  EXPECT_EQ(magic, "Pf");
  // The header ends with the single whitespace after the scale.
  const std::size_t data_start = static_cast<std::size_t>(header.tellg()) + 1;
  EXPECT_EQ(bytes.size(), data_start + 4u * pfm.width * pfm.height);
  if (bytes.size() != data_start + 4u * pfm.width * pfm.height) return pfm;
  pfm.values.resize(static_cast<std::size_t>(pfm.width) * pfm.height);
  for (int y = 0; y < pfm.height; ++y)
    for (int x = 0; x < pfm.width; ++x) {
      // Rows are stored bottom to top, little-endian (negative scale).
      const std::size_t at = data_start + 4 * (static_cast<std::size_t>(pfm.height - 1 - y) * pfm.width + x);
      const std::uint32_t bits = bytes[at] | bytes[at + 1] << 8 | bytes[at + 2] << 16 |
                                 static_cast<std::uint32_t>(bytes[at + 3]) << 24;
      float v;
      std::memcpy(&v, &bits, 4);
      pfm.values[static_cast<std::size_t>(y) * pfm.width + x] = v;
    }
  return pfm;
}

// A fresh folder per test holding copies of the Tsukuba pair, so that no test can touch data/.
class Cli : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    folder_ = fs::temp_directory_path() /
              ("mctstereo_cli_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    fs::remove_all(folder_);
    fs::create_directories(folder_);
    fs::copy_file(kData / "tsukuba/imL.png", folder_ / "left.png");
    fs::copy_file(kData / "tsukuba/imR.png", folder_ / "right.png");
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(folder_, ec);
  }

  // Runs `mctstereo ARGS` in the test folder.
  Result run(const std::string& args) const {
    const std::string command =
        "cd " + shell_quoted(folder_.string()) + " && " + shell_quoted(kProgram.string()) + " " + args + " 2>&1";
    Result r;
    FILE* pipe = ::popen(command.c_str(), "r");
    if (!pipe) return r;
    std::array<char, 4096> buf;
    while (std::size_t n = std::fread(buf.data(), 1, buf.size(), pipe)) r.output.append(buf.data(), n);
    const int status = ::pclose(pipe);
    r.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    return r;
  }

  // Runs a command that must fail with `status` and a message containing `message`, leaving the
  // folder exactly as it was: no output, no temporary, inputs byte for byte the same.
  void expect_failure(const std::string& args, int status, const std::string& message) const {
    const std::set<std::string> before = folder_listing(folder_);
    std::vector<std::vector<std::uint8_t>> contents;
    for (const std::string& name : before)
      if (fs::is_regular_file(folder_ / name)) contents.push_back(read_bytes(folder_ / name));
    const Result r = run(args);
    EXPECT_EQ(r.status, status) << "mctstereo " << args << "\n" << r.output;
    EXPECT_NE(r.output.find(message), std::string::npos)
        << "mctstereo " << args << "\nexpected the message to contain: " << message << "\ngot: " << r.output;
    EXPECT_EQ(r.output.rfind("mctstereo: error: ", 0), 0u) << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << "one line expected:\n" << r.output;
    EXPECT_EQ(folder_listing(folder_), before) << "mctstereo " << args;
    std::size_t k = 0;
    for (const std::string& name : before)
      if (fs::is_regular_file(folder_ / name)) EXPECT_EQ(read_bytes(folder_ / name), contents[k++]) << name;
  }

  fs::path folder_;
};

constexpr int kUsage = 2;
constexpr int kRuntime = 1;
const std::string kPair = "match left.png right.png ";

TEST_F(Cli, MatchWritesPfmRightViewAndPreview) {
  const Result r = run(kPair + "-o d.pfm --right-output r.pfm --color preview.png --num-disparities 16");
  ASSERT_EQ(r.status, 0) << r.output;
  // One summary line naming size, range, backend, SIMD target and stage times.
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  for (const char* part : {"384x288", "disparities 0..15", "preset balanced", "backend cpu", "SIMD ", "threads ",
                           "census ", "match ", "refine ", "frame ", " ms", "PFM float"})
    EXPECT_NE(r.output.find(part), std::string::npos) << part << " missing in: " << r.output;

  for (const char* name : {"d.pfm", "r.pfm"}) {
    const Pfm pfm = read_pfm(folder_ / name);
    EXPECT_EQ(pfm.width, 384);
    EXPECT_EQ(pfm.height, 288);
    EXPECT_EQ(pfm.scale, -1.0);
    ASSERT_EQ(pfm.values.size(), 384u * 288u);
    int finite = 0;
    for (float v : pfm.values) {
      EXPECT_TRUE((v >= 0.0f && v <= 15.0f) || v == std::numeric_limits<float>::infinity()) << v;
      finite += std::isfinite(v) ? 1 : 0;
    }
    EXPECT_GT(finite, 384 * 288 / 2) << name;
  }
  const cv::Mat preview = cv::imread((folder_ / "preview.png").string(), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(preview.cols, 384);
  EXPECT_EQ(preview.rows, 288);
  EXPECT_EQ(preview.type(), CV_8UC3);
}

TEST_F(Cli, PngFormatsHoldThePfmValuesScaled) {
  const std::string range = "--num-disparities 16 --fill none";  // leave invalid pixels to check their code
  ASSERT_EQ(run(kPair + "-o d.pfm " + range).status, 0);
  const Result kitti = run(kPair + "-o kitti.png " + range);
  ASSERT_EQ(kitti.status, 0) << kitti.output;
  EXPECT_NE(kitti.output.find("KITTI"), std::string::npos) << kitti.output;
  const Result q4 = run(kPair + "-o q4.png --format q4 " + range);
  ASSERT_EQ(q4.status, 0) << q4.output;
  EXPECT_NE(q4.output.find("Q4, d = value / 16 - 1"), std::string::npos) << q4.output;

  const Pfm pfm = read_pfm(folder_ / "d.pfm");
  const cv::Mat k = cv::imread((folder_ / "kitti.png").string(), cv::IMREAD_UNCHANGED);
  const cv::Mat q = cv::imread((folder_ / "q4.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(k.type(), CV_16UC1);
  ASSERT_EQ(q.type(), CV_16UC1);
  ASSERT_EQ(k.size(), cv::Size(384, 288));
  ASSERT_EQ(q.size(), cv::Size(384, 288));
  ASSERT_EQ(pfm.values.size(), 384u * 288u);
  int invalid = 0;
  for (int y = 0; y < 288; ++y)
    for (int x = 0; x < 384; ++x) {
      const float d = pfm.values[static_cast<std::size_t>(y) * 384 + x];
      const int kv = k.at<std::uint16_t>(y, x), qv = q.at<std::uint16_t>(y, x);
      if (std::isinf(d)) {
        ++invalid;
        ASSERT_EQ(kv, 0) << x << "," << y;
        ASSERT_EQ(qv, 0) << x << "," << y;
      } else {
        ASSERT_EQ(kv, std::lround(256.0f * d)) << x << "," << y;
        ASSERT_EQ(qv, std::lround(16.0f * (d + 1.0f))) << x << "," << y;  // min_disparity 0
      }
    }
  EXPECT_GT(invalid, 0);  // occlusions stay invalid without filling
}

TEST_F(Cli, NegativeMinimumNeedsQ4OrPfm) {
  expect_failure(kPair + "-o d.png --min-disparity -4 --num-disparities 20", kUsage, "negative disparities");
  const Result r = run(kPair + "-o q4.png --format q4 --min-disparity -4 --num-disparities 20");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("d = value / 16 - 5"), std::string::npos) << r.output;
  const cv::Mat q = cv::imread((folder_ / "q4.png").string(), cv::IMREAD_UNCHANGED);
  double lo, hi;
  cv::minMaxLoc(q, &lo, &hi);
  EXPECT_GE(lo, 0);
  EXPECT_LE(hi, 16 * (15 + 4 + 1));  // d <= 15: value <= 16 x (15 - (-4) + 1)
}

TEST_F(Cli, AlphaIsDroppedAndGrayIsAccepted) {
  const cv::Mat left = cv::imread((folder_ / "left.png").string(), cv::IMREAD_COLOR);
  const cv::Mat right = cv::imread((folder_ / "right.png").string(), cv::IMREAD_COLOR);
  cv::Mat left_bgra, right_bgra, left_gray, right_gray;
  cv::cvtColor(left, left_bgra, cv::COLOR_BGR2BGRA);
  cv::cvtColor(right, right_bgra, cv::COLOR_BGR2BGRA);
  cv::cvtColor(left, left_gray, cv::COLOR_BGR2GRAY);
  cv::cvtColor(right, right_gray, cv::COLOR_BGR2GRAY);
  ASSERT_TRUE(cv::imwrite((folder_ / "left_bgra.png").string(), left_bgra));
  ASSERT_TRUE(cv::imwrite((folder_ / "right_bgra.png").string(), right_bgra));
  ASSERT_TRUE(cv::imwrite((folder_ / "left.pgm").string(), left_gray));
  ASSERT_TRUE(cv::imwrite((folder_ / "right.pgm").string(), right_gray));
  ASSERT_EQ(run(kPair + "-o bgr.pfm --num-disparities 16").status, 0);
  const Result bgra = run("match left_bgra.png right_bgra.png -o bgra.pfm --num-disparities 16");
  ASSERT_EQ(bgra.status, 0) << bgra.output;
  EXPECT_EQ(read_bytes(folder_ / "bgra.pfm"), read_bytes(folder_ / "bgr.pfm"));
  const Result gray = run("match left.pgm right.pgm -o gray.pfm --num-disparities 16");
  ASSERT_EQ(gray.status, 0) << gray.output;
  EXPECT_EQ(read_pfm(folder_ / "gray.pfm").width, 384);
}

TEST_F(Cli, UnreadableInputsFailWithTheirName) {
  expect_failure("match left.png missing.png -o d.pfm", kRuntime, "'missing.png': no such file");
  fs::create_directory(folder_ / "folder.png");
  expect_failure("match left.png folder.png -o d.pfm", kRuntime, "'folder.png': it is a folder");
  write_bytes(folder_ / "x.png", {'h', 'e', 'l', 'l', 'o', '\n'});
  expect_failure("match left.png x.png -o d.pfm", kRuntime, "cannot decode right image 'x.png': not a PNG");
  std::vector<std::uint8_t> png = read_bytes(folder_ / "right.png");
  png.resize(png.size() / 2);
  write_bytes(folder_ / "truncated.png", png);
  expect_failure("match truncated.png right.png -o d.pfm", kRuntime,
                 "cannot decode left image 'truncated.png': damaged or truncated PNG");
  ASSERT_TRUE(cv::imwrite((folder_ / "deep.png").string(), cv::Mat(288, 384, CV_16UC1, cv::Scalar(1000))));
  expect_failure("match left.png deep.png -o d.pfm", kRuntime, "'deep.png' has 16-bit samples");
}

TEST_F(Cli, PairOfDifferentSizesFails) {
  const cv::Mat right = cv::imread((folder_ / "right.png").string(), cv::IMREAD_COLOR);
  ASSERT_TRUE(cv::imwrite((folder_ / "small.png").string(), right(cv::Rect(0, 0, 300, 200))));
  expect_failure("match left.png small.png -o d.pfm", kRuntime, "is 384x288 but right image 'small.png' is 300x200");
}

TEST_F(Cli, InvalidParametersNameTheParameter) {
  expect_failure(kPair + "-o d.pfm --num-disparities 0", kUsage, "num_disparities = 0 must be in [1, 2048]");
  expect_failure(kPair + "-o d.pfm --num-disparities -5", kUsage, "num_disparities = -5");
  expect_failure(kPair + "-o d.pfm --num-disparities 1000", kUsage,
                 "num_disparities = 1000 is wider than the image (384 px)");
  expect_failure(kPair + "-o d.pfm --census-window 4", kUsage, "census_window = 4 must be 3, 5, 7 or 9");
  expect_failure(kPair + "-o d.pfm --census-window 11", kUsage, "census_window = 11");
  expect_failure(kPair + "-o d.pfm --shd-window 2", kUsage, "shd_window = 2 must be 1, 3, 5, 7 or 9 (--shd-window)");
  expect_failure(kPair + "-o d.pfm --preset fancy", kUsage, "unknown preset 'fancy'");
  expect_failure(kPair + "-o d.pfm --census xyz", kUsage, "--census");
  expect_failure(kPair + "-o d.pfm --backend gpu", kUsage, "unknown backend 'gpu'");
  expect_failure(kPair + "-o d.pfm --no-such-flag", kUsage, "--no-such-flag");
}

TEST_F(Cli, BadOutputsAreRefusedBeforeAnyWork) {
  expect_failure(kPair + "-o d.pfm --format tiff", kUsage, "--format: tiff not in");
  expect_failure(kPair + "-o d.bmp", kUsage, "cannot tell the disparity format of 'd.bmp'");
  expect_failure(kPair + "-o d.pfm --format q4", kUsage, "--format q4 writes PNG but 'd.pfm' ends in .pfm");
  expect_failure(kPair + "-o missing/d.pfm", kRuntime, "folder 'missing' does not exist");
  expect_failure(kPair + "-o left.png", kUsage, "refusing to overwrite an input");
  expect_failure(kPair + "-o ./right.png", kUsage, "refusing to overwrite an input");
  expect_failure(kPair + "-o d.png --color right.png", kUsage, "refusing to overwrite an input");
  expect_failure(kPair + "-o d.pfm --right-output d.pfm", kUsage, "are the same file");
  expect_failure(kPair + "-o d.png --num-disparities 300", kUsage, "d <= 255");
}

TEST_F(Cli, HelpExplainsUnitsAndScaling) {
  const Result r = run("match --help");
  EXPECT_EQ(r.status, 0);
  for (const char* part : {"256 x d", "16 x (d - min + 1)", "+INF", "pixels", "--census-window", "--preset"})
    EXPECT_NE(r.output.find(part), std::string::npos) << part;
  expect_failure("", kUsage, "subcommand");
  expect_failure("frob", kUsage, "unknown subcommand 'frob'");
}

TEST_F(Cli, EvalScoresTsukuba) {
  const Result r = run("eval " + shell_quoted(kData.string()) + " --preset balanced --json scores.json");
  ASSERT_EQ(r.status, 0) << r.output;
  // The row: scene nonocc all disc density ms.
  const std::size_t row = r.output.find("\ntsukuba ");
  ASSERT_NE(row, std::string::npos) << r.output;
  std::istringstream numbers(r.output.substr(row + 9));
  double nonocc = -1, all = -1, disc = -1, density = -1;
  numbers >> nonocc >> all >> disc >> density;
  // Measured 5.53 / 6.60 / 17.80 with the balanced preset; bounds just above.
  EXPECT_GT(nonocc, 0.0);
  EXPECT_LT(nonocc, 5.8);
  EXPECT_LE(nonocc, all);
  EXPECT_LT(all, 6.9);
  EXPECT_LT(disc, 18.5);
  EXPECT_GT(density, 99.0);  // the preset fills invalid pixels
  EXPECT_NE(r.output.find("average percent bad (3 numbers"), std::string::npos) << r.output;

  const std::vector<std::uint8_t> bytes = read_bytes(folder_ / "scores.json");
  const std::string json(bytes.begin(), bytes.end());
  for (const char* key : {"\"preset\": \"balanced\"", "\"parameters\"", "\"census_window\": 5", "\"scenes\"",
                          "\"scene\": \"tsukuba\"", "\"nonocc\"", "\"all\"", "\"disc\"", "\"density\"", "\"ms\"",
                          "\"num_disparities\": 16", "\"average\"", "\"average_percent_bad\""})
    EXPECT_NE(json.find(key), std::string::npos) << key << " missing in " << json;
}

TEST_F(Cli, EvalWithoutScenesFails) {
  fs::create_directory(folder_ / "empty");
  expect_failure("eval empty", kRuntime, "no scene under 'empty'");
  expect_failure("eval nowhere", kRuntime, "'nowhere' does not exist");
}

TEST_F(Cli, BenchWritesStereoBmRecords) {
  // 16 disparities: OpenCV needs a frame wider than its range.
  const Result r = run("bench --sizes 64x48 --frames 3 --min-time 0 --num-disparities 16 --presets realtime,balanced "
                       "--json bench.json --data " + shell_quoted((kData / "tsukuba").string()));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("opencv-stereobm"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("peak resident memory"), std::string::npos) << r.output;
  const std::vector<std::uint8_t> bytes = read_bytes(folder_ / "bench.json");
  const std::string json(bytes.begin(), bytes.end());
  for (const char* key : {"\"settings\"", "\"cpu_model\"", "\"simd_target\"", "\"opencv_version\"", "\"records\"",
                          "\"method\": \"opencv-stereobm\"", "\"method\": \"opencv-stereosgbm\"",
                          "\"method\": \"realtime\"", "\"method\": \"balanced\"", "\"median_ms\"", "\"p95_ms\"",
                          "\"fps\"", "\"ratio_to_stereobm\": 1\n", "\"width\": 64", "\"height\": 48",
                          "\"estimate_memory_bytes\""})
    EXPECT_NE(json.find(key), std::string::npos) << key << " missing in " << json;
  expect_failure("bench --sizes 64by48", kUsage, "'64by48' is not a size");
}

}  // namespace
