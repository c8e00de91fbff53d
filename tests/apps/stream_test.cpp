// `mctstereo stream` run as a user would, on a short synthetic sequence with exact disparities: a
// textured background plane at disparity 8 and a textured square coming closer, its disparity
// growing by 2 per frame. The right views are the textures shifted by exactly those disparities.
#include <gtest/gtest.h>
#include <unistd.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "cli_test_util.hpp"
#include "errors.hpp"
#include "frame_source.hpp"

namespace {

using mctstereo::test::folder_listing;
using mctstereo::test::kProgram;
using mctstereo::test::read_text;
using mctstereo::test::Result;
using mctstereo::test::run_shell;
using mctstereo::test::shell_quoted;

namespace fs = std::filesystem;

constexpr int kWidth = 160, kHeight = 120, kFrames = 6;
constexpr int kBackground = 8;                       // disparity of the background plane
constexpr int kSquareX = 84, kSquareY = 36, kSquareSize = 48;  // the square in the left view
constexpr int kUsage = 2;
const int kFfv1 = cv::VideoWriter::fourcc('F', 'F', 'V', '1');  // lossless
constexpr int kRuntime = 1;

// Integer shifts of one texture: every disparity comes out within one 1/16 pixel step of the truth
// (subpixel refinement rounds a few to the next step).
constexpr double kExact = 1.0 / 16.0;

int square_disparity(int frame) { return 16 + 2 * frame; }

// Seeded noise, blurred so that it keeps its texture at the coarser pyramid levels.
cv::Mat texture(int width, int height, int seed) {
  cv::Mat noise(height, width, CV_8UC1);
  cv::RNG rng(static_cast<std::uint64_t>(seed));
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  cv::Mat smooth;
  cv::GaussianBlur(noise, smooth, cv::Size(0, 0), 1.0);
  cv::normalize(smooth, smooth, 0, 255, cv::NORM_MINMAX);
  return smooth;
}

struct Pair {
  cv::Mat left, right;
};

// Frame `frame` of the scene. A left pixel (x, y) on the background shows background texture
// column x + kMargin, on the square square-texture column x - kSquareX; a right pixel x' shows
// what the left pixel x' + d shows, with the square in front.
Pair scene(int frame, int width = kWidth, int height = kHeight) {
  static const cv::Mat background = texture(kWidth + 64, kHeight, 1);
  static const cv::Mat square = texture(kSquareSize, kSquareSize, 2);
  const int d = square_disparity(frame);
  Pair pair{cv::Mat(height, width, CV_8UC1), cv::Mat(height, width, CV_8UC1)};
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const bool in_rows = y >= kSquareY && y < kSquareY + kSquareSize;
      const auto on_square = [&](int left_x) {
        return in_rows && left_x >= kSquareX && left_x < kSquareX + kSquareSize;
      };
      const auto bg = [&](int left_x) { return background.at<std::uint8_t>(y, left_x + 32); };
      pair.left.at<std::uint8_t>(y, x) =
          on_square(x) ? square.at<std::uint8_t>(y - kSquareY, x - kSquareX) : bg(x);
      pair.right.at<std::uint8_t>(y, x) =
          on_square(x + d) ? square.at<std::uint8_t>(y - kSquareY, x + d - kSquareX) : bg(x + kBackground);
    }
  return pair;
}

std::string numbered(const std::string& pattern, int index) {
  char buf[256];
  std::snprintf(buf, sizeof buf, pattern.c_str(), index);
  return buf;
}

// Disparity maps read back from the files of stream, in pixels (NaN where invalid).
cv::Mat read_kitti(const fs::path& path) {
  const cv::Mat png = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  if (png.empty() || png.type() != CV_16UC1) return {};
  cv::Mat d(png.size(), CV_32FC1);
  for (int y = 0; y < png.rows; ++y)
    for (int x = 0; x < png.cols; ++x) {
      const int v = png.at<std::uint16_t>(y, x);
      d.at<float>(y, x) = v == 0 ? std::numeric_limits<float>::quiet_NaN() : v / 256.0f;
    }
  return d;
}

cv::Mat read_pfm(const fs::path& path) {
  const cv::Mat pfm = cv::imread(path.string(), cv::IMREAD_UNCHANGED);  // OpenCV flips the rows back
  if (pfm.empty() || pfm.type() != CV_32FC1) return {};
  cv::Mat d = pfm.clone();
  for (float& v : cv::Mat_<float>(d))
    if (std::isinf(v)) v = std::numeric_limits<float>::quiet_NaN();
  return d;
}

// Fraction of the pixels of a region whose disparity is within `tolerance` of `expected`.
double fraction_near(const cv::Mat& d, cv::Rect region, double expected, double tolerance) {
  int near = 0;
  for (int y = region.y; y < region.y + region.height; ++y)
    for (int x = region.x; x < region.x + region.width; ++x)
      near += std::abs(d.at<float>(y, x) - expected) <= tolerance ? 1 : 0;
  return static_cast<double>(near) / region.area();
}

// The square's inside, away from its edges, and a band of background left of it, away from the
// image border and from the background that the square hides in the right view (up to 18 pixels
// left of the square).
const cv::Rect kSquareInside(kSquareX + 6, kSquareY + 6, kSquareSize - 12, kSquareSize - 12);
const cv::Rect kBackgroundBand(20, 8, 32, kHeight - 16);

// Checks one frame's disparity map: the square and the background at their known disparities.
void expect_frame(const cv::Mat& d, int frame, double tolerance, double required_fraction) {
  ASSERT_EQ(d.size(), cv::Size(kWidth, kHeight)) << "frame " << frame;
  EXPECT_GE(fraction_near(d, kSquareInside, square_disparity(frame), tolerance), required_fraction)
      << "frame " << frame << ": square at " << square_disparity(frame);
  EXPECT_GE(fraction_near(d, kBackgroundBand, kBackground, tolerance), required_fraction)
      << "frame " << frame << ": background at " << kBackground;
}

// A number following `label` in a summary line; -1 when it is not there.
double number_after(const std::string& text, const std::string& label) {
  const std::size_t at = text.find(label);
  if (at == std::string::npos) return -1.0;
  return std::atof(text.c_str() + at + label.size());
}

class Stream : public mctstereo::test::FolderTest {
 protected:
  void SetUp() override {
    FolderTest::SetUp();
    fs::create_directories(folder_ / "seq");
    fs::create_directories(folder_ / "out");
  }

  // Writes the sequence as seq/left_%04d.png and seq/right_%04d.png, numbered from 0.
  void write_sequence(int frames = kFrames) const {
    for (int f = 0; f < frames; ++f) {
      const Pair p = scene(f);
      ASSERT_TRUE(cv::imwrite((folder_ / numbered("seq/left_%04d.png", f)).string(), p.left));
      ASSERT_TRUE(cv::imwrite((folder_ / numbered("seq/right_%04d.png", f)).string(), p.right));
    }
  }

  enum class View { Left, Right, SideBySide };

  // Writes the sequence as a video of one view or of both side by side; false when OpenCV cannot.
  bool write_video(const std::string& name, int fourcc, View view = View::SideBySide) const {
    const int width = view == View::SideBySide ? 2 * kWidth : kWidth;
    cv::VideoWriter video((folder_ / name).string(), cv::CAP_FFMPEG, fourcc, 10.0, cv::Size(width, kHeight), true);
    if (!video.isOpened()) return false;
    for (int f = 0; f < kFrames; ++f) {
      const Pair p = scene(f);
      cv::Mat gray, colour;
      if (view == View::SideBySide) cv::hconcat(p.left, p.right, gray);
      else gray = view == View::Left ? p.left : p.right;
      cv::cvtColor(gray, colour, cv::COLOR_GRAY2BGR);
      video.write(colour);
    }
    return true;
  }

  Result run(const std::string& args) const { return FolderTest::run("stream " + args); }

  // A failure with `status` and a one-line message containing `message`. Unlike FolderTest's, it
  // leaves the folder unchecked: a stream that fails mid-way keeps the frames written before.
  void expect_failure(const std::string& args, int status, const std::string& message) const {
    const Result r = run(args);
    EXPECT_EQ(r.status, status) << "stream " << args << "\n" << r.output;
    EXPECT_NE(r.output.find(message), std::string::npos)
        << "stream " << args << "\nexpected the message to contain: " << message << "\ngot: " << r.output;
    EXPECT_EQ(r.output.rfind("mctstereo: error: ", 0), 0u) << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << "one line expected:\n" << r.output;
  }
};

// One matching thread: the capture and writing threads of stream share the few cores of a test machine.
const std::string kMatching = "--num-disparities 32 --threads 1 ";
const std::string kSequence = "--left 'seq/left_%04d.png' --right 'seq/right_%04d.png' " + kMatching;

TEST_F(Stream, ImageSequencesGiveTheKnownDisparitiesFrameByFrame) {
  write_sequence();
  const Result r = run(kSequence + "--disparity 'out/disp_%05d.png' --quiet");
  ASSERT_EQ(r.status, 0) << r.output;
  // One summary line: frames, size, the input, latency, matching time, frame rate, how it ended.
  ASSERT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  for (const char* part : {"6 frames 160x120", "from two image sequences", "disparities 0..31", "backend cpu",
                           "end of input", "wrote 6 disparity files 'out/disp_%05d.png' (16-bit PNG KITTI"})
    EXPECT_NE(r.output.find(part), std::string::npos) << part << " missing in: " << r.output;
  const std::regex summary(R"(latency ms: mean ([0-9.]+) p95 ([0-9.]+); matching ms: median ([0-9.]+); ([0-9.]+) fps)");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(r.output, m, summary)) << r.output;
  const double mean = std::stod(m[1]), p95 = std::stod(m[2]), matching = std::stod(m[3]), fps = std::stod(m[4]);
  EXPECT_GT(mean, 0.0);
  EXPECT_GT(p95, 0.0);
  EXPECT_GT(matching, 0.0);
  EXPECT_LE(matching, p95) << "a frame's latency includes its matching";
  EXPECT_GT(fps, 0.0);

  std::set<std::string> expected_files;
  for (int f = 0; f < kFrames; ++f) {
    expected_files.insert(numbered("disp_%05d.png", f));
    expect_frame(read_kitti(folder_ / "out" / numbered("disp_%05d.png", f)), f, kExact, 1.0);
  }
  EXPECT_EQ(folder_listing(folder_ / "out"), expected_files);
}

TEST_F(Stream, FoldersWithStartAndMaxFramesKeepTheFrameNumbers) {
  write_sequence();
  fs::create_directories(folder_ / "l");
  fs::create_directories(folder_ / "r");
  for (int f = 0; f < kFrames; ++f) {
    fs::rename(folder_ / numbered("seq/left_%04d.png", f), folder_ / "l" / numbered("a%02d.png", f));
    fs::rename(folder_ / numbered("seq/right_%04d.png", f), folder_ / "r" / numbered("b%02d.png", f));
  }
  std::ofstream(folder_ / "l" / "notes.txt") << "not an image";  // left out of the sequence
  const Result r = run("--left l --right r " + kMatching + "--start 2 --max-frames 3 --disparity 'out/d%d.pfm'");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("3 frames 160x120 from two image sequences"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("--max-frames 3"), std::string::npos) << r.output;
  EXPECT_EQ(folder_listing(folder_ / "out"), (std::set<std::string>{"d2.pfm", "d3.pfm", "d4.pfm"}));
  for (int f = 2; f <= 4; ++f) expect_frame(read_pfm(folder_ / "out" / numbered("d%d.pfm", f)), f, kExact, 1.0);
}

TEST_F(Stream, LosslessSideBySideVideoAndPreviewVideo) {
  if (!write_video("both.avi", kFfv1))
    GTEST_SKIP() << "OpenCV cannot write FFV1 video here";
  const Result r = run("--side-by-side both.avi " + kMatching + "--disparity 'out/%03d.png' --format q4 "
                       "--preview-video out/preview.avi");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("6 frames 160x120 from a side-by-side video"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("preview video 'out/preview.avi'"), std::string::npos) << r.output;
  for (int f = 0; f < kFrames; ++f) {
    const cv::Mat q4 = cv::imread((folder_ / "out" / numbered("%03d.png", f)).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(q4.type(), CV_16UC1);
    cv::Mat d;
    q4.convertTo(d, CV_32F, 1.0 / 16.0, -1.0);  // Q4 with min 0: d = value / 16 - 1
    expect_frame(d, f, kExact, 1.0);
  }
  // The preview: left frame | colour disparity, one frame per frame matched.
  cv::VideoCapture preview((folder_ / "out/preview.avi").string());
  ASSERT_TRUE(preview.isOpened());
  int frames = 0;
  cv::Mat frame;
  while (preview.read(frame)) {
    ++frames;
    ASSERT_EQ(frame.size(), cv::Size(2 * kWidth, kHeight));
    // The square is nearer than the background: a different colour (turbo: warmer) in the right half.
    const cv::Vec3b square = frame.at<cv::Vec3b>(kSquareY + kSquareSize / 2, kWidth + kSquareX + kSquareSize / 2);
    const cv::Vec3b background = frame.at<cv::Vec3b>(kHeight / 2, kWidth + 20);
    EXPECT_GT(cv::norm(cv::Vec3d(square) - cv::Vec3d(background)), 60.0) << "frame " << frames - 1;
  }
  EXPECT_EQ(frames, kFrames);
}

TEST_F(Stream, TwoLosslessVideos) {
  if (!write_video("left.avi", kFfv1, View::Left) || !write_video("right.avi", kFfv1, View::Right))
    GTEST_SKIP() << "OpenCV cannot write FFV1 video here";
  const Result r = run("--left left.avi --right right.avi " + kMatching + "--disparity 'out/%d.pfm'");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("6 frames 160x120 from two videos"), std::string::npos) << r.output;
  for (int f = 0; f < kFrames; ++f) expect_frame(read_pfm(folder_ / "out" / numbered("%d.pfm", f)), f, kExact, 1.0);
}

TEST_F(Stream, LossySideBySideVideoComesClose) {
  if (!write_video("both.avi", cv::VideoWriter::fourcc('M', 'J', 'P', 'G')))
    GTEST_SKIP() << "OpenCV cannot write MJPG video here";
  const Result r = run("--side-by-side both.avi " + kMatching + "--start 2 --disparity 'out/%d.pfm'");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("4 frames 160x120"), std::string::npos) << r.output;
  EXPECT_EQ(folder_listing(folder_ / "out"), (std::set<std::string>{"2.pfm", "3.pfm", "4.pfm", "5.pfm"}));
  // JPEG blurs the texture: most pixels within a pixel of the truth.
  for (int f = 2; f < kFrames; ++f) expect_frame(read_pfm(folder_ / "out" / numbered("%d.pfm", f)), f, 1.0, 0.9);
}

TEST_F(Stream, FrameChangingSizeStopsWithTheEarlierFramesWritten) {
  write_sequence();
  const Pair small = scene(3, 80, 60);
  ASSERT_TRUE(cv::imwrite((folder_ / "seq/left_0003.png").string(), small.left));
  ASSERT_TRUE(cv::imwrite((folder_ / "seq/right_0003.png").string(), small.right));
  expect_failure(kSequence + "--disparity 'out/disp_%05d.png' --preview-video out/p.avi", kRuntime,
                 "frame 3 ('seq/left_0003.png' and 'seq/right_0003.png') is 80x60 but the stream began at 160x120");
  // The frames before are written whole, no temporary is left, and the preview video is readable.
  EXPECT_EQ(folder_listing(folder_ / "out"),
            (std::set<std::string>{"disp_00000.png", "disp_00001.png", "disp_00002.png", "p.avi"}));
  for (int f = 0; f < 3; ++f) expect_frame(read_kitti(folder_ / "out" / numbered("disp_%05d.png", f)), f, kExact, 1.0);
  cv::VideoCapture preview((folder_ / "out/p.avi").string());
  ASSERT_TRUE(preview.isOpened());
  int frames = 0;
  for (cv::Mat frame; preview.read(frame);) ++frames;
  EXPECT_EQ(frames, 3);
}

TEST_F(Stream, BadInputsAreNamed) {
  write_sequence(1);
  std::ofstream(folder_ / "junk.avi") << "not a video at all";
  expect_failure("--side-by-side junk.avi", kRuntime, "cannot open --side-by-side video 'junk.avi'");
  expect_failure("--left missing.avi --right junk.avi", kRuntime, "--left 'missing.avi': no such file or folder");
  expect_failure("--left junk.avi --right seq", kUsage, "is a video but --right 'seq' is a folder");
  expect_failure("--left seq/left_0000.png --right seq/right_0000.png", kUsage, "is a single image");
  expect_failure("--left 'seq/left_%04d.png'", kUsage, "--left needs --right");
  expect_failure("--left 'seq/left_%04d.png' --right 'seq/right_%04d.png' --left-camera 0", kUsage, "give one input");
  expect_failure("", kUsage, "no input");
}

TEST_F(Stream, BadSequencesAreNamed) {
  write_sequence();
  expect_failure("--left 'seq/left_%04d_%d.png' --right 'seq/right_%04d.png'", kUsage, "exactly one");
  expect_failure("--left 'seq/x_%04d.png' --right 'seq/right_%04d.png'", kRuntime, "no such files");
  expect_failure(kSequence + "--start 6", kRuntime, "--start 6");
  expect_failure("--left-camera 0 --right-camera 1 --start 1", kUsage, "--start");

  // Folders of different lengths.
  fs::create_directories(folder_ / "l");
  fs::create_directories(folder_ / "r");
  for (int f = 0; f < kFrames; ++f) {
    fs::copy_file(folder_ / numbered("seq/left_%04d.png", f), folder_ / "l" / numbered("%d.png", f));
    if (f < kFrames - 1)
      fs::copy_file(folder_ / numbered("seq/right_%04d.png", f), folder_ / "r" / numbered("%d.png", f));
  }
  expect_failure("--left l --right r", kRuntime, "--left 'l' holds 6 images but --right 'r' holds 5");
}

TEST_F(Stream, BadOutputPatternsAreRefusedBeforeAnyWork) {
  write_sequence(1);
  expect_failure(kSequence + "--disparity out/disp.png", kUsage, "has 0 integer conversions");
  expect_failure(kSequence + "--disparity 'out/disp_%s.png'", kUsage, "'%s' is not an integer conversion");
  expect_failure(kSequence + "--disparity 'out/%d_%d.png'", kUsage, "has 2 integer conversions");
  expect_failure(kSequence + "--disparity 'out_%d/disp.png'", kUsage, "must be in the file name");
  expect_failure(kSequence + "--disparity 'nowhere/disp_%d.png'", kRuntime, "folder 'nowhere' does not exist");
  expect_failure(kSequence + "--disparity 'out/disp_%d.jpg'", kUsage, "cannot tell the disparity format");
  expect_failure(kSequence + "--preview-video out/p.gif", kUsage, "name it .avi");
  expect_failure(kSequence + "--format q4", kUsage, "--format q4 applies to --disparity files");
  EXPECT_TRUE(fs::is_empty(folder_ / "out"));
}

TEST_F(Stream, OutputsThatWouldReplaceAnInputOrEachOtherAreRefused) {
  write_sequence();
  const std::set<std::string> inputs = folder_listing(folder_ / "seq");
  const std::string before = read_text(folder_ / "seq/left_0002.png");
  // An output named like the inputs: refused, and no input touched.
  expect_failure(kSequence + "--disparity 'seq/left_%04d.png'", kUsage, "refusing to overwrite an input");
  expect_failure(kSequence + "--disparity './seq/../seq/right_%04d.png' --start 2", kUsage,
                 "--disparity './seq/../seq/right_%04d.png' would write './seq/../seq/right_0002.png', an input");
  expect_failure(kSequence + "--depth 'out/z%d.png'", kUsage,
                 "a PNG depth map holds millimetres and needs a calibration");
  expect_failure(kSequence + "--depth 'out/z.pfm' --focal 100 --baseline 0.1", kUsage, "has 0 integer conversions");
  expect_failure(kSequence + "--max-depth 5 --focal 100 --baseline 0.1", kUsage, "--max-depth cuts --depth");
  expect_failure(kSequence + "--disparity 'out/%d.pfm' --depth 'out/%d.pfm'", kUsage, "are the same file");
  expect_failure(kSequence + "--disparity 'out/%d.pfm' --depth 'out/%1d.pfm'", kUsage,
                 "--disparity and --depth are the same file 'out/0.pfm'");
  expect_failure(kSequence + "--depth 'out/z%d.pfm' --focal 100 --baseline 0.1 --cx 300 --calib nowhere.yml",
                 kRuntime, "nowhere.yml");
  EXPECT_EQ(folder_listing(folder_ / "seq"), inputs);
  EXPECT_EQ(read_text(folder_ / "seq/left_0002.png"), before);
  EXPECT_TRUE(fs::is_empty(folder_ / "out"));
}

TEST_F(Stream, DepthFollowsTheDisparityOfEveryFrame) {
  write_sequence();
  const Result r = run(kSequence + "--disparity 'out/d%d.pfm' --depth 'out/z%d.pfm' --focal 100 --baseline 0.1");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("6 depth files 'out/z%d.pfm' (depth PFM, m, +INF = none)"), std::string::npos) << r.output;
  for (int f = 0; f < kFrames; ++f) {
    const cv::Mat d = read_pfm(folder_ / "out" / numbered("d%d.pfm", f));
    const cv::Mat z = read_pfm(folder_ / "out" / numbered("z%d.pfm", f));
    ASSERT_EQ(d.size(), cv::Size(kWidth, kHeight));
    ASSERT_EQ(z.size(), cv::Size(kWidth, kHeight));
    // Z = focal x baseline / d, and no depth where there is no disparity.
    for (int y = 0; y < kHeight; ++y)
      for (int x = 0; x < kWidth; ++x) {
        const float dv = d.at<float>(y, x), zv = z.at<float>(y, x);
        if (std::isnan(dv) || dv <= 0.0f) {
          ASSERT_TRUE(std::isnan(zv)) << x << "," << y << " frame " << f;
        } else {
          ASSERT_NEAR(zv, 10.0 / dv, 1e-5 * zv) << x << "," << y << " frame " << f;
        }
      }
    // The square comes closer frame by frame: 10 / 16 m, 10 / 18 m, ...
    const cv::Point centre(kSquareX + kSquareSize / 2, kSquareY + kSquareSize / 2);
    EXPECT_NEAR(z.at<float>(centre), 10.0 / square_disparity(f), 1e-3) << "frame " << f;
  }
}

// The raw cameras of a rig, slightly turned against each other: stream rectifies every frame as
// match rectifies one pair, so their files agree byte for byte.
TEST_F(Stream, RawRigIsRectifiedFrameByFrameAsMatchDoes) {
  write_sequence(3);
  {
    cv::FileStorage rig((folder_ / "rig.yml").string(), cv::FileStorage::WRITE);
    const cv::Mat K = (cv::Mat_<double>(3, 3) << 150, 0, 79.5, 0, 150, 59.5, 0, 0, 1);
    const double angle = 0.01;  // radians about the optical axis
    const cv::Mat R = (cv::Mat_<double>(3, 3) << std::cos(angle), -std::sin(angle), 0, std::sin(angle),
                       std::cos(angle), 0, 0, 0, 1);
    rig << "image_width" << kWidth << "image_height" << kHeight << "units" << "m";
    rig << "K1" << K << "D1" << cv::Mat::zeros(1, 5, CV_64F) << "K2" << K << "D2" << cv::Mat::zeros(1, 5, CV_64F);
    rig << "R" << R << "T" << (cv::Mat_<double>(3, 1) << -0.1, 0, 0);
  }
  const Result r = run(kSequence + "--calib rig.yml --disparity 'out/s%d.pfm' --depth 'out/sz%d.pfm'");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("3 frames 160x120"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("rectified with 'rig.yml'"), std::string::npos) << r.output;
  for (int f = 0; f < 3; ++f) {
    const Result m = run_shell("cd " + shell_quoted(folder_.string()) + " && " + shell_quoted(kProgram.string()) +
                               " match " + numbered("seq/left_%04d.png", f) + " " + numbered("seq/right_%04d.png", f) +
                               " " + kMatching + "--calib rig.yml -o out/m.pfm --depth out/mz.pfm 2>&1");
    ASSERT_EQ(m.status, 0) << m.output;
    EXPECT_EQ(read_text(folder_ / "out" / numbered("s%d.pfm", f)), read_text(folder_ / "out/m.pfm")) << "frame " << f;
    EXPECT_EQ(read_text(folder_ / "out" / numbered("sz%d.pfm", f)), read_text(folder_ / "out/mz.pfm")) << "frame " << f;
    // Rectification turns the views by a fraction of a degree: the square keeps about its disparity.
    const cv::Mat d = read_pfm(folder_ / "out" / numbered("s%d.pfm", f));
    ASSERT_EQ(d.size(), cv::Size(kWidth, kHeight));
    EXPECT_GE(fraction_near(d, kSquareInside, square_disparity(f), 1.0), 0.8) << "frame " << f;
  }
}

TEST_F(Stream, CamerasThatDoNotOpenAreNamed) {
  expect_failure("--left-camera 60 --right-camera 61", kRuntime, "cannot open camera 60 (--left-camera)");
  expect_failure("--left-camera 3 --right-camera 3", kUsage, "both camera 3");
}

TEST_F(Stream, ShowWithoutADisplayFallsBackToProgress) {
  write_sequence(2);
  const Result r = run_shell("cd " + shell_quoted(folder_.string()) + " && env -u DISPLAY -u WAYLAND_DISPLAY " +
                             shell_quoted(kProgram.string()) + " stream " + kSequence + "--show 2>&1");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(r.output.rfind("mctstereo: note: --show: there is no display", 0), 0u) << r.output;
  EXPECT_NE(r.output.find("2 frames 160x120"), std::string::npos) << r.output;
}

TEST_F(Stream, SigtermStopsCleanlyWithEveryWrittenFileWhole) {
  // A long sequence of links to the same six frames, stopped once a few frames are out.
  write_sequence();
  fs::create_directories(folder_ / "l");
  fs::create_directories(folder_ / "r");
  constexpr int kLong = 500;
  for (int f = 0; f < kLong; ++f) {
    const std::string name = numbered("%05d.png", f);
    fs::create_symlink(fs::absolute(folder_ / numbered("seq/left_%04d.png", f % kFrames)), folder_ / "l" / name);
    fs::create_symlink(fs::absolute(folder_ / numbered("seq/right_%04d.png", f % kFrames)), folder_ / "r" / name);
  }
  const std::string command = "cd " + shell_quoted(folder_.string()) + " && { " + shell_quoted(kProgram.string()) +
                              " stream --left l --right r " + kMatching +
                              "--disparity 'out/%05d.png' --quiet > summary.txt 2>&1 & pid=$!; "
                              "while [ ! -e out/00003.png ] && kill -0 $pid 2>/dev/null; do sleep 0.02; done; "
                              "kill -TERM $pid; wait $pid; echo $?; }";
  const Result r = run_shell(command);
  const std::string summary = read_text(folder_ / "summary.txt");
  EXPECT_EQ(r.output, "0\n") << summary;
  EXPECT_NE(summary.find("stopped by SIGTERM"), std::string::npos) << summary;
  const int frames = static_cast<int>(number_after(summary, ""));
  EXPECT_GE(frames, 4) << summary;
  EXPECT_LT(frames, kLong) << summary;
  // Frames 0 .. frames - 1, each whole, and nothing else.
  std::set<std::string> expected;
  for (int f = 0; f < frames; ++f) expected.insert(numbered("%05d.png", f));
  EXPECT_EQ(folder_listing(folder_ / "out"), expected);
  for (int f = 0; f < std::min(frames, 12); ++f)
    expect_frame(read_kitti(folder_ / "out" / numbered("%05d.png", f)), f % kFrames, kExact, 1.0);
}

int frames_in_video(const fs::path& path) {
  cv::VideoCapture video(path.string(), cv::CAP_FFMPEG);
  int frames = 0;
  while (video.isOpened() && video.grab()) ++frames;
  return frames;
}

TEST_F(Stream, SigintDeliveredTwiceAtOnceStopsCleanlyWithAWholePreview) {
  // `timeout -s INT` signals the process and then its group: two SIGINTs a moment apart are one
  // request. Before, the second ended the process at once: exit 130, no summary, an empty video.
  // The Tsukuba pair over and over: its frames take long enough that the second signal comes while
  // the frames in flight are still being finished.
  fs::create_directories(folder_ / "l");
  fs::create_directories(folder_ / "r");
  for (int f = 0; f < 500; ++f) {
    fs::create_symlink(mctstereo::test::kData / "tsukuba/imL.png", folder_ / "l" / numbered("%05d.png", f));
    fs::create_symlink(mctstereo::test::kData / "tsukuba/imR.png", folder_ / "r" / numbered("%05d.png", f));
  }
  const std::string command = "cd " + shell_quoted(folder_.string()) + " && { " + shell_quoted(kProgram.string()) +
                              " stream --left l --right r " + kMatching +
                              "--disparity 'out/%05d.png' --preview-video p.avi --quiet > summary.txt 2>&1 & pid=$!; "
                              "while [ ! -e out/00003.png ] && kill -0 $pid 2>/dev/null; do sleep 0.02; done; "
                              "kill -INT $pid; sleep 0.02; kill -INT $pid 2>/dev/null; wait $pid; echo $?; }";
  const Result r = run_shell(command);
  const std::string summary = read_text(folder_ / "summary.txt");
  EXPECT_EQ(r.output, "0\n") << summary;
  EXPECT_NE(summary.find("stopped by SIGINT"), std::string::npos) << summary;
  EXPECT_NE(summary.find("preview video 'p.avi'"), std::string::npos) << summary;
  const int frames = static_cast<int>(number_after(summary, ""));
  EXPECT_GE(frames, 4) << summary;
  EXPECT_EQ(frames_in_video(folder_ / "p.avi"), frames) << summary;
}

TEST_F(Stream, ASecondSigintMoreThanASecondLaterEndsAtOnceLeavingNoTemporary) {
  // The process is stopped (SIGSTOP) between the two signals, so the frames in flight cannot be
  // finished before the second one arrives however fast the machine is; the monotonic clock the
  // handler reads runs on while the process is stopped. Frames slow enough (SGM over 256 disparities
  // at 1280 x 720, one thread) that the first signal is handled while a frame is still in flight.
  cv::Mat left(720, 1280, CV_8UC1), right;
  cv::RNG(7).fill(left, cv::RNG::UNIFORM, 0, 256);
  cv::hconcat(left.colRange(8, 1280), left.colRange(0, 8), right);
  ASSERT_TRUE(cv::imwrite((folder_ / "seq/l.png").string(), left));
  ASSERT_TRUE(cv::imwrite((folder_ / "seq/r.png").string(), right));
  fs::create_directories(folder_ / "l");
  fs::create_directories(folder_ / "r");
  for (int f = 0; f < 50; ++f) {
    fs::create_symlink(folder_ / "seq/l.png", folder_ / "l" / numbered("%05d.png", f));
    fs::create_symlink(folder_ / "seq/r.png", folder_ / "r" / numbered("%05d.png", f));
  }
  const std::string command = "cd " + shell_quoted(folder_.string()) + " && { " + shell_quoted(kProgram.string()) +
                              " stream --left l --right r --preset sgm-full --num-disparities 256 --threads 1 "
                              "--preview-video out/p.avi --quiet > summary.txt 2>&1 & pid=$!; "
                              "while [ -z \"$(ls -A out)\" ] && kill -0 $pid 2>/dev/null; do sleep 0.02; done; "
                              "kill -INT $pid; sleep 0.1; kill -STOP $pid; sleep 1.3; kill -INT $pid; kill -CONT $pid; "
                              "wait $pid; echo $?; }";
  const Result r = run_shell(command);
  EXPECT_EQ(r.output, "130\n") << read_text(folder_ / "summary.txt");
  EXPECT_TRUE(fs::is_empty(folder_ / "out")) << "the temporary of the preview video is removed";
}

TEST_F(Stream, PreviewVideoOnAFullDiskIsAnErrorAndLeavesNoVideo) {
  // A file size limit stands for the full disk (SIGXFSZ ignored: the write fails with EFBIG, as a
  // full disk fails with ENOSPC). Before, a truncated video and "wrote preview video", exit 0.
  write_sequence();
  const std::set<std::string> before = folder_listing(folder_);
  const Result r = run_shell("cd " + shell_quoted(folder_.string()) + " && trap '' XFSZ && ulimit -f 64 && " +
                             shell_quoted(kProgram.string()) + " stream " + kSequence +
                             "--preview-video p.avi --quiet 2>&1");
  EXPECT_EQ(r.status, kRuntime) << r.output;
  EXPECT_EQ(r.output.rfind("mctstereo: error: cannot write preview video 'p.avi': ", 0), 0u) << r.output;
  EXPECT_NE(r.output.find(" frames read back (is the disk full?)"), std::string::npos) << r.output;
  EXPECT_EQ(folder_listing(folder_), before) << "no video, no temporary";
}

TEST_F(Stream, OutputsThatCannotHoldAVideoOrNameOneFileTwiceAreRefused) {
  write_sequence(2);
  fs::create_symlink("/dev/null", folder_ / "null.avi");
  expect_failure(kSequence + "--preview-video null.avi", kRuntime,
                 "cannot write preview video 'null.avi': it is a device or a FIFO, and a preview video must be a "
                 "regular file");
  expect_failure(kSequence + "--disparity 'out/%05d.pfm' --depth './out/%05d.pfm'", kUsage,
                 "--disparity and --depth are the same file");
  EXPECT_TRUE(fs::is_empty(folder_ / "out"));
}

// A camera that stops delivering frames mid-stream is an error naming it and the frames it gave,
// not the end of input: two captures of short lossless videos stand in for the cameras.
TEST(StreamSource, CameraThatStopsIsAnError) {
  const fs::path folder = fs::temp_directory_path() / ("mctstereo_camera_stop_" + std::to_string(::getpid()));
  fs::remove_all(folder);
  fs::create_directories(folder);
  const auto write_video = [&](const std::string& name, int frames) {
    cv::VideoWriter video((folder / name).string(), cv::CAP_FFMPEG, kFfv1, 10.0, cv::Size(kWidth, kHeight), true);
    if (!video.isOpened()) return false;
    for (int f = 0; f < frames; ++f) video.write(cv::Mat(kHeight, kWidth, CV_8UC3, cv::Scalar(10 * f, 50, 90)));
    return true;
  };
  if (!write_video("left.mkv", 3) || !write_video("right.mkv", 5)) GTEST_SKIP() << "OpenCV here writes no FFV1 video";
  const auto open = [&](const std::string& name) { return cv::VideoCapture((folder / name).string(), cv::CAP_FFMPEG); };

  for (const bool left_stops : {true, false}) {
    auto source = left_stops ? mctstereo::app::camera_pair_source(open("left.mkv"), 2, open("right.mkv"), 5)
                             : mctstereo::app::camera_pair_source(open("right.mkv"), 2, open("left.mkv"), 5);
    mctstereo::app::StereoFrame frame;
    for (int f = 0; f < 3; ++f) {
      ASSERT_TRUE(source->read(frame)) << "frame " << f;
      EXPECT_EQ(frame.left.size(), cv::Size(kWidth, kHeight));
    }
    try {
      source->read(frame);
      ADD_FAILURE() << "a camera that stopped read as the end of the input";
    } catch (const mctstereo::app::RuntimeError& e) {
      const std::string expected =
          std::string("camera ") + (left_stops ? "2" : "5") + " stopped delivering frames after 3 frames";
      EXPECT_EQ(std::string(e.what()), expected);
    }
  }
  fs::remove_all(folder);
}

}  // namespace

// --synthetic: frames made in the process, of known disparity; frame N the same on every run.
TEST(StreamSynthetic, FramesHoldTheirKnownDisparitiesAndTheSquareMoves) {
  using mctstereo::app::kSyntheticBackground;
  using mctstereo::app::kSyntheticSquare;
  const cv::Size size(96, 48);
  mctstereo::app::StereoFrame a, b;
  mctstereo::app::make_synthetic_frame(size, 3, a);
  mctstereo::app::make_synthetic_frame(size, 3, b);
  ASSERT_EQ(a.left.size(), size);
  ASSERT_EQ(a.left.type(), CV_8UC1);
  EXPECT_EQ(cv::norm(a.left, b.left, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.right, b.right, cv::NORM_INF), 0.0);
  // Every left pixel whose match lies inside the right view shows what that right pixel shows,
  // unless the square covers it there (the background it hides).
  int checked = 0, square = 0;
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      const int d = mctstereo::app::synthetic_disparity(size, 3, x, y);
      ASSERT_TRUE(d == kSyntheticBackground || d == kSyntheticSquare);
      const int xr = x - d;
      if (xr < 0) continue;
      if (d == kSyntheticBackground && mctstereo::app::synthetic_disparity(size, 3, xr + kSyntheticSquare, y) ==
                                           kSyntheticSquare)
        continue;  // occluded in the right view
      ASSERT_EQ(a.left.at<std::uint8_t>(y, x), a.right.at<std::uint8_t>(y, xr)) << x << ", " << y;
      ++checked;
      square += d == kSyntheticSquare ? 1 : 0;
    }
  EXPECT_GT(checked, size.area() * 3 / 4);
  EXPECT_EQ(square, 16 * 16);  // the square (a third of 48) is whole in both views
  // Frame 4's square lies 2 px to the right of frame 3's.
  int first3 = -1, first4 = -1;
  for (int x = 0; x < size.width && (first3 < 0 || first4 < 0); ++x) {
    if (first3 < 0 && mctstereo::app::synthetic_disparity(size, 3, x, 24) == kSyntheticSquare) first3 = x;
    if (first4 < 0 && mctstereo::app::synthetic_disparity(size, 4, x, 24) == kSyntheticSquare) first4 = x;
  }
  EXPECT_EQ(first4, first3 + 2);
  EXPECT_THROW(mctstereo::app::parse_synthetic_size("20x20", "--synthetic"), mctstereo::app::UsageError);
  EXPECT_THROW(mctstereo::app::parse_synthetic_size("320x", "--synthetic"), mctstereo::app::UsageError);
  EXPECT_EQ(mctstereo::app::parse_synthetic_size("320x240", "--synthetic"), cv::Size(320, 240));
}

TEST_F(Stream, SyntheticInputIsMatchedToItsKnownDisparities) {
  const Result r = run("--synthetic 160x120 --start 5 --max-frames 4 " + kMatching +
                       "--disparity 'out/d%d.pfm' --quiet");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("4 frames 160x120 from a synthetic random-dot scene"), std::string::npos) << r.output;
  EXPECT_EQ(folder_listing(folder_ / "out"), (std::set<std::string>{"d5.pfm", "d6.pfm", "d7.pfm", "d8.pfm"}));
  for (int f = 5; f <= 8; ++f) {
    const cv::Mat d = read_pfm(folder_ / "out" / numbered("d%d.pfm", f));
    ASSERT_EQ(d.size(), cv::Size(160, 120)) << f;
    // Away from the square's edges and the image border, every pixel within 1/16 px of the truth.
    int near = 0, total = 0;
    for (int y = 4; y < 116; ++y)
      for (int x = 24; x < 156; ++x) {
        bool interior = true;
        const int truth = mctstereo::app::synthetic_disparity({160, 120}, f, x, y);
        for (int dy = -3; dy <= 3 && interior; ++dy)
          for (int dx = -3 - mctstereo::app::kSyntheticSquare; dx <= 3 && interior; ++dx)
            interior = mctstereo::app::synthetic_disparity({160, 120}, f, x + dx, y + dy) == truth;
        if (!interior) continue;
        ++total;
        near += std::abs(d.at<float>(y, x) - truth) <= kExact ? 1 : 0;
      }
    EXPECT_GT(total, 8000) << f;
    EXPECT_GE(near, total * 99 / 100) << "frame " << f << ": " << near << " of " << total;
  }
  expect_failure("--synthetic 10x10", kUsage, "--synthetic '10x10': the width must lie in [48, 8192]");
  expect_failure("--synthetic 64x48 --left 'seq/left_%04d.png' --right x", kUsage, "give one input");
}

// --temporal: the same known disparities with fewer candidates; the summary says so.
TEST_F(Stream, TemporalPriorKeepsTheMapsWithFewerCandidates) {
  const auto candidates = [](const std::string& output) {
    const std::size_t at = output.find("last frame: ");
    return at == std::string::npos ? -1.0 : std::stod(output.substr(at + 12));
  };
  fs::create_directories(folder_ / "alone");
  fs::create_directories(folder_ / "temporal");
  const Result alone = run("--synthetic 160x120 --max-frames 6 --preset quality " + kMatching +
                           "--disparity 'alone/d%d.pfm' --quiet");
  const Result temporal = run("--synthetic 160x120 --max-frames 6 --preset quality --temporal " + kMatching +
                              "--disparity 'temporal/d%d.pfm' --quiet");
  ASSERT_EQ(alone.status, 0) << alone.output;
  ASSERT_EQ(temporal.status, 0) << temporal.output;
  EXPECT_NE(temporal.output.find("candidates per pixel at the finest level (temporal prior)"), std::string::npos)
      << temporal.output;
  EXPECT_GT(candidates(alone.output), 0.0) << alone.output;
  // quality's finest level searches radius 2 around its prior (box sums), 3 candidates around the
  // previous frame's map: 3.76 per pixel against 5.39 alone.
  EXPECT_LT(candidates(temporal.output), 0.8 * candidates(alone.output)) << temporal.output;
  for (int f = 1; f < 6; ++f) {
    const cv::Mat a = read_pfm(folder_ / "alone" / numbered("d%d.pfm", f));
    const cv::Mat t = read_pfm(folder_ / "temporal" / numbered("d%d.pfm", f));
    int differ = 0;
    for (int y = 0; y < a.rows; ++y)
      for (int x = 0; x < a.cols; ++x) differ += std::abs(a.at<float>(y, x) - t.at<float>(y, x)) > 1.0f;
    EXPECT_LT(differ, a.rows * a.cols / 100) << "frame " << f;
  }
  expect_failure("--synthetic 64x48 --temporal-radius 2", kUsage,
                 "--temporal-radius applies to --temporal, which was not given");
  expect_failure("--synthetic 64x48 --temporal --temporal-threshold 300", kUsage,
                 "temporal_threshold = 300 must be in [0, 255]");
}
