// Calibration files (Middlebury calib.txt, OpenCV YAML, XML, JSON) read into the geometry of a
// rectified pair, written back, and the calibration flags of the command line.
#include <gtest/gtest.h>
#include <unistd.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <initializer_list>
#include <string>
#include <vector>

#include "calibration.hpp"
#include "cli_test_util.hpp"
#include "errors.hpp"

namespace mctstereo::app {
namespace {

namespace fs = std::filesystem;

// Middlebury 2014 "Adirondack" (full size), as published.
constexpr const char* kAdirondack =
    "cam0=[4161.221 0 1445.577; 0 4161.221 984.686; 0 0 1]\n"
    "cam1=[4161.221 0 1654.636; 0 4161.221 984.686; 0 0 1]\n"
    "doffs=209.059\n"
    "baseline=176.252\n"
    "width=2880\n"
    "height=1988\n"
    "ndisp=280\n"
    "isint=0\n"
    "vmin=33\n"
    "vmax=218\n"
    "dyavg=0.188\n"
    "dymax=0.385\n";

class Calibrations : public ::mctstereo::test::FolderTest {
 protected:

  // An OpenCV FileStorage file of `name` (its extension picks YAML, XML or JSON) filled by `fill`.
  std::string write_storage(const std::string& name, const std::function<void(cv::FileStorage&)>& fill) const {
    const fs::path path = folder_ / name;
    cv::FileStorage file(path.string(), cv::FileStorage::WRITE);
    fill(file);
    file.release();
    return path.string();
  }

  // read_calibration must fail with a RuntimeError whose message holds each of `parts`.
  static void expect_error(const std::string& path, std::initializer_list<std::string> parts) {
    try {
      (void)read_calibration(path);
      ADD_FAILURE() << path << ": no error";
    } catch (const RuntimeError& e) {
      for (const std::string& part : parts)
        EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << "'" << part << "' missing in: " << e.what();
    }
  }
};

// A rectified horizontal pair: f = 700, principal points (320, 240) and (330, 240), baseline 0.12.
const cv::Mat kP1 = (cv::Mat_<double>(3, 4) << 700, 0, 320, 0, 0, 700, 240, 0, 0, 0, 1, 0);
const cv::Mat kP2 = (cv::Mat_<double>(3, 4) << 700, 0, 330, -700 * 0.12, 0, 700, 240, 0, 0, 0, 1, 0);

void expect_rectified_pair(const Calibration& c) {
  EXPECT_DOUBLE_EQ(c.geometry.focal, 700.0);
  EXPECT_DOUBLE_EQ(c.geometry.cx, 320.0);
  EXPECT_DOUBLE_EQ(c.geometry.cy, 240.0);
  EXPECT_DOUBLE_EQ(c.geometry.baseline, 0.12);
  EXPECT_DOUBLE_EQ(c.geometry.doffs, 10.0);
}

TEST_F(Calibrations, MiddleburyCalibTxt) {
  const std::string path = write("calib.txt", kAdirondack);
  const Calibration c = read_calibration(path);
  EXPECT_DOUBLE_EQ(c.geometry.focal, 4161.221);
  EXPECT_DOUBLE_EQ(c.geometry.cx, 1445.577);
  EXPECT_DOUBLE_EQ(c.geometry.cy, 984.686);
  EXPECT_DOUBLE_EQ(c.geometry.baseline, 176.252);
  EXPECT_DOUBLE_EQ(c.geometry.doffs, 209.059);
  EXPECT_EQ(c.geometry.units, "mm");
  EXPECT_EQ(c.width, 2880);
  EXPECT_EQ(c.height, 1988);
  EXPECT_EQ(c.ndisp, 280);
  EXPECT_FALSE(c.needs_rectification);
  EXPECT_EQ(c.source, path);
  // A disparity of 100 px lies at f B / (d + doffs) millimetres.
  EXPECT_NEAR(c.geometry.depth(100.0), 4161.221 * 176.252 / 309.059, 1e-9);
}

TEST_F(Calibrations, MiddleburyWithoutDoffsTakesItFromCam1) {
  const std::string path = write("calib.txt",
                                      "cam0=[1000 0 300.5; 0 1000 200; 0 0 1]\r\n"
                                      "cam1=[1000 0 312.75; 0 1000 200; 0 0 1]\r\n"
                                      "baseline=50\r\n");
  const Calibration c = read_calibration(path);
  EXPECT_DOUBLE_EQ(c.geometry.doffs, 12.25);
  EXPECT_DOUBLE_EQ(c.geometry.baseline, 50.0);
  EXPECT_EQ(c.width, 0);  // no size given: unknown
  EXPECT_EQ(c.height, 0);
}

TEST_F(Calibrations, OpenCvYamlAndXmlWithProjections) {
  for (const char* name : {"stereo.yml", "stereo.xml", "stereo.json"}) {
    const std::string path = write_storage(name, [](cv::FileStorage& f) {
      f << "image_width" << 640 << "image_height" << 480 << "P1" << kP1 << "P2" << kP2;
    });
    const Calibration c = read_calibration(path);
    expect_rectified_pair(c);
    EXPECT_EQ(c.geometry.units, "m");
    EXPECT_EQ(c.width, 640) << name;
    EXPECT_EQ(c.height, 480) << name;
    EXPECT_FALSE(c.needs_rectification) << name;
  }
  // width/height as keys, and a unit.
  const std::string path = write_storage("other.yaml", [](cv::FileStorage& f) {
    f << "width" << 640 << "height" << 480 << "units" << "mm" << "P1" << kP1 << "P2" << kP2;
  });
  const Calibration c = read_calibration(path);
  EXPECT_EQ(c.width, 640);
  EXPECT_EQ(c.geometry.units, "mm");
}

TEST_F(Calibrations, OpenCvQOnly) {
  // Q of the pair above: [1 0 0 -cx; 0 1 0 -cy; 0 0 0 f; 0 0 1/B doffs/B].
  const cv::Mat q = (cv::Mat_<double>(4, 4) << 1, 0, 0, -320, 0, 1, 0, -240, 0, 0, 0, 700, 0, 0, 1 / 0.12, 10 / 0.12);
  const std::string path = write_storage("q.yml", [&](cv::FileStorage& f) { f << "Q" << q; });
  const Calibration c = read_calibration(path);
  expect_rectified_pair(c);
  EXPECT_FALSE(c.needs_rectification);
}

// A rig of two identical distortion-free cameras side by side, 0.1 apart: rectification changes nothing.
void write_parallel_rig(cv::FileStorage& f) {
  const cv::Mat k = (cv::Mat_<double>(3, 3) << 500, 0, 319.5, 0, 500, 239.5, 0, 0, 1);
  f << "image_width" << 640 << "image_height" << 480;
  f << "K1" << k << "D1" << cv::Mat::zeros(1, 5, CV_64F) << "K2" << k << "D2" << cv::Mat::zeros(1, 5, CV_64F);
  f << "R" << cv::Mat::eye(3, 3, CV_64F) << "T" << (cv::Mat_<double>(3, 1) << -0.1, 0, 0);
}

TEST_F(Calibrations, OpenCvRawRigIsRectifiedByStereoRectify) {
  const std::string path = write_storage("rig.yml", write_parallel_rig);
  const Calibration c = read_calibration(path);
  EXPECT_TRUE(c.needs_rectification);
  EXPECT_NEAR(c.geometry.focal, 500.0, 1e-6);
  EXPECT_NEAR(c.geometry.cx, 319.5, 1e-6);
  EXPECT_NEAR(c.geometry.cy, 239.5, 1e-6);
  EXPECT_NEAR(c.geometry.baseline, 0.1, 1e-12);
  EXPECT_NEAR(c.geometry.doffs, 0.0, 1e-9);  // CALIB_ZERO_DISPARITY
  for (const cv::Mat* m : {&c.R1, &c.R2, &c.P1, &c.P2, &c.Q}) EXPECT_FALSE(m->empty());
  EXPECT_EQ(c.P1.size(), cv::Size(4, 3));
  EXPECT_NEAR(cv::norm(c.R1, cv::Mat::eye(3, 3, CV_64F)), 0.0, 1e-9);
}

TEST_F(Calibrations, RawCamerasWithProjectionsNeedRectificationUnlessMarkedRectified) {
  const auto fill = [](int rectified) {
    return [rectified](cv::FileStorage& f) {
      write_parallel_rig(f);
      f << "R1" << cv::Mat::eye(3, 3, CV_64F) << "R2" << cv::Mat::eye(3, 3, CV_64F) << "P1" << kP1 << "P2" << kP2;
      if (rectified >= 0) f << "rectified" << rectified;
    };
  };
  const Calibration raw = read_calibration(write_storage("raw.yml", fill(-1)));
  EXPECT_TRUE(raw.needs_rectification);
  expect_rectified_pair(raw);  // the file's P1, P2, not stereoRectify's
  EXPECT_TRUE(read_calibration(write_storage("raw0.yml", fill(0))).needs_rectification);
  const Calibration done = read_calibration(write_storage("done.yml", fill(1)));
  EXPECT_FALSE(done.needs_rectification);
  expect_rectified_pair(done);
}

TEST_F(Calibrations, WriteThenReadGivesTheSameValues) {
  Calibration original = read_calibration(write("calib.txt", kAdirondack));
  const std::string path = (folder_ / "written.yml").string();
  write_calibration(path, original);
  const Calibration back = read_calibration(path);
  EXPECT_DOUBLE_EQ(back.geometry.focal, original.geometry.focal);
  EXPECT_DOUBLE_EQ(back.geometry.cx, original.geometry.cx);
  EXPECT_DOUBLE_EQ(back.geometry.cy, original.geometry.cy);
  EXPECT_DOUBLE_EQ(back.geometry.baseline, original.geometry.baseline);
  EXPECT_NEAR(back.geometry.doffs, original.geometry.doffs, 1e-12);
  EXPECT_EQ(back.geometry.units, "mm");
  EXPECT_EQ(back.width, 2880);
  EXPECT_EQ(back.height, 1988);
  EXPECT_EQ(back.ndisp, 280);
  EXPECT_FALSE(back.needs_rectification);

  // A raw rig keeps its cameras and that it needs rectification.
  const Calibration rig = read_calibration(write_storage("rig.yml", write_parallel_rig));
  const std::string rig_path = (folder_ / "rig_written.yml").string();
  write_calibration(rig_path, rig);
  const Calibration rig_back = read_calibration(rig_path);
  EXPECT_TRUE(rig_back.needs_rectification);
  EXPECT_EQ(cv::norm(rig_back.K1, rig.K1), 0.0);
  EXPECT_EQ(cv::norm(rig_back.D2, rig.D2), 0.0);
  EXPECT_EQ(cv::norm(rig_back.T, rig.T), 0.0);
  EXPECT_EQ(cv::norm(rig_back.R1, rig.R1), 0.0);
  EXPECT_DOUBLE_EQ(rig_back.geometry.focal, rig.geometry.focal);
  EXPECT_DOUBLE_EQ(rig_back.geometry.baseline, rig.geometry.baseline);
  EXPECT_NEAR(rig_back.geometry.doffs, rig.geometry.doffs, 1e-12);
}

TEST_F(Calibrations, BadFilesNameTheFileAndTheKey) {
  expect_error((folder_ / "none.txt").string(), {"none.txt", "no such file"});
  expect_error(folder_.string(), {"folder"});
  expect_error(write("empty.txt", "\n"), {"empty.txt", "empty"});
  expect_error(write("what.txt", "focal: 3\n"), {"what.txt", "unknown format"});

  const std::string cam0 = "cam0=[1000 0 300; 0 1000 200; 0 0 1]\n";
  expect_error(write("m1.txt", cam0 + "doffs=0\n"), {"m1.txt", "'baseline'", "missing"});
  expect_error(write("m2.txt", "cam0=x\nbaseline=50\n"), {"m2.txt", "'cam0'", "3x3"});
  expect_error(write("m3.txt", "cam1=[1000 0 300; 0 1000 200; 0 0 1]\ndoffs=0\nbaseline=5\n"),
               {"m3.txt", "'cam0'", "missing"});
  expect_error(write("m4.txt", "cam0=[1000 0 300; 0 1000 200]\nbaseline=50\ndoffs=0\n"), {"'cam0'", "3x3"});
  expect_error(write("m5.txt", cam0 + "baseline=fifty\ndoffs=0\n"), {"m5.txt", "'baseline'", "fifty"});
  expect_error(write("m6.txt", cam0 + "baseline=-50\ndoffs=0\n"), {"'baseline'", "positive"});
  expect_error(write("m7.txt", cam0 + "baseline=50\n"), {"m7.txt", "'doffs'", "cam1"});
  expect_error(write("m8.txt", "cam0=[0 0 300; 0 0 200; 0 0 1]\nbaseline=50\ndoffs=0\n"), {"'cam0'", "focal"});
  expect_error(write("m9.txt", cam0 + "baseline=50\ndoffs=0\nwidth=640\n"), {"'height'", "missing"});

  expect_error(write("broken.yml", "%YAML:1.0\nP1: [1, 2\n"), {"broken.yml", "cannot parse"});
  expect_error(
      write_storage("nothing.yml", [](cv::FileStorage& f) { f << "image_width" << 640 << "image_height" << 480; }),
      {"nothing.yml", "'P1'", "missing"});
  expect_error(write_storage("p2.yml", [](cv::FileStorage& f) { f << "P1" << kP1; }), {"p2.yml", "'P2'", "missing"});
  expect_error(
      write_storage("shape.yml", [](cv::FileStorage& f) { f << "P1" << cv::Mat::eye(3, 3, CV_64F) << "P2" << kP2; }),
      {"shape.yml", "'P1'", "3x3", "3x4"});
  expect_error(write_storage("scalar.yml", [](cv::FileStorage& f) { f << "P1" << 5 << "P2" << kP2; }),
               {"scalar.yml", "'P1'", "not an OpenCV matrix"});
  expect_error(write_storage("swapped.yml", [](cv::FileStorage& f) { f << "P1" << kP1 << "P2" << kP1; }),
               {"swapped.yml", "'P2'", "baseline"});
  expect_error(write_storage("rig.yml", [](cv::FileStorage& f) { f << "K1" << cv::Mat::eye(3, 3, CV_64F); }),
               {"rig.yml", "'D1'", "missing"});
  expect_error(
      write_storage("size.yml", [](cv::FileStorage& f) { f << "image_width" << 640 << "P1" << kP1 << "P2" << kP2; }),
      {"size.yml", "'image_height'", "missing"});
  expect_error(write_storage("rigsize.yml",
                             [](cv::FileStorage& f) {
                               const cv::Mat k = cv::Mat::eye(3, 3, CV_64F), d = cv::Mat::zeros(1, 5, CV_64F);
                               f << "K1" << k << "D1" << d << "K2" << k << "D2" << d << "R" << k;
                               f << "T" << (cv::Mat_<double>(3, 1) << -0.1, 0, 0);
                             }),
               {"rigsize.yml", "'image_width'", "missing"});
  expect_error(write_storage("q.yml", [](cv::FileStorage& f) { f << "Q" << cv::Mat::eye(4, 4, CV_64F); }),
               {"q.yml", "'Q'", "focal"});
}

// Inputs found by fuzz/fuzz_calibration.cpp: each crashed, hung or exhausted memory in OpenCV's
// FileStorage before it was checked.
TEST_F(Calibrations, FilesThatBrokeOpenCvsParserAreRefusedNamingTheFile) {
  // A top level that is a sequence: cv::FileStorage::operator[] threw an unnamed cv::Exception.
  expect_error(write("seq.yml", "%YAML:1.0\n- 1\n- 2\n"), {"seq.yml", "top level is not a map"});
  // A NUL inside the XML header: OpenCV 4.6's XML parser read a null pointer (SIGSEGV).
  const char nul[] = "<?xml version=\"1.0\0\0\"?>\n<opencv_storage>\n</opencv_storage>\n";
  expect_error(write("nul.xml", std::string(nul, sizeof nul - 1)), {"nul.xml", "byte 18 is 0x00", "control character"});
  // "rows: 100000, cols: 100000": OpenCV allocated 80 GB before it counted the data.
  const std::string huge = "%YAML:1.0\nP1: !!opencv-matrix\n   rows: 100000\n   cols: 100000\n   dt: d\n"
                           "   data: [ 1., 2. ]\n";
  expect_error(write("huge.yml", huge), {"huge.yml", "'P1'", "at most 16 x 16 values"});
  // A declared size that the data does not fill.
  expect_error(write("short.yml", "%YAML:1.0\nP1: !!opencv-matrix\n   rows: 3\n   cols: 4\n   dt: d\n   data: [ 1. ]\n"),
               {"short.yml", "'P1'", "as many data as rows x cols"});
  // Three lines on which OpenCV 4.6's YAML parser loops for ever: refused after 5 s.
  const auto start = std::chrono::steady_clock::now();
  expect_error(write("loop.yml", "%YAML:1.0\n   s:3\nncv-\n"), {"loop.yml", "did not finish within 5 s"});
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(30));
  // A file that OpenCV parses but whose top-level map it cannot walk (a fuzzer's find): the
  // lookup of a key threw an unnamed cv::Exception, which ended the program.
  expect_error(write("lookup.yml", "%YAML:1.0\n   s:3\nncv" + std::string(44, '-') + "\n"),
               {"lookup.yml", "cannot look up key", "malformed"});
}

TEST_F(Calibrations, AnotherImageSizeIsRefusedNamingBothSizes) {
  const Calibration c = read_calibration(write("calib.txt", kAdirondack));
  EXPECT_NO_THROW(check_calibration_fits(c, 2880, 1988, "left image 'l.png'"));
  try {
    check_calibration_fits(c, 1440, 994, "left image 'l.png'");
    ADD_FAILURE() << "no error";
  } catch (const RuntimeError& e) {
    const std::string message = e.what();
    for (const char* part : {"2880x1988", "1440x994", "'l.png'", "calib.txt"})
      EXPECT_NE(message.find(part), std::string::npos) << part << " missing in: " << message;
  }
  Calibration flags_only;
  EXPECT_NO_THROW(check_calibration_fits(flags_only, 17, 5, "x"));
}

// The flags parsed from `args` into a fresh command line.
std::optional<Calibration> resolve_flags(const std::vector<std::string>& args, int width, int height) {
  CLI::App app;
  CalibrationFlags flags;
  flags.add_to(app);
  std::vector<std::string> reversed(args.rbegin(), args.rend());  // CLI11 takes them last first
  app.parse(reversed);
  return flags.resolve(width, height, "left image");
}

TEST_F(Calibrations, FlagsGiveTheGeometryAndOverrideAFile) {
  EXPECT_FALSE(resolve_flags({}, 640, 480).has_value());
  const std::optional<Calibration> plain = resolve_flags({"--focal", "700", "--baseline", "0.12"}, 640, 480);
  ASSERT_TRUE(plain.has_value());
  EXPECT_EQ(plain->geometry.focal, 700.0);
  EXPECT_EQ(plain->geometry.baseline, 0.12);
  EXPECT_EQ(plain->geometry.cx, 319.5);
  EXPECT_EQ(plain->geometry.cy, 239.5);
  EXPECT_EQ(plain->geometry.doffs, 0.0);
  EXPECT_EQ(plain->geometry.units, "m");
  EXPECT_EQ(plain->source, "flags");

  const std::optional<Calibration> all = resolve_flags(
      {"--focal", "700", "--baseline", "120", "--cx", "300", "--cy", "200", "--doffs", "4", "--units", "mm"}, 640, 480);
  EXPECT_EQ(all->geometry.cx, 300.0);
  EXPECT_EQ(all->geometry.cy, 200.0);
  EXPECT_EQ(all->geometry.doffs, 4.0);
  EXPECT_EQ(all->geometry.units, "mm");

  const std::string calib = write("calib.txt", kAdirondack);
  const std::optional<Calibration> file = resolve_flags({"--calib", calib, "--focal", "4000"}, 2880, 1988);
  EXPECT_EQ(file->geometry.focal, 4000.0);
  EXPECT_EQ(file->geometry.baseline, 176.252);
  EXPECT_EQ(file->geometry.doffs, 209.059);
  EXPECT_EQ(file->geometry.units, "mm");
  // --units alone converts the file's baseline.
  const std::optional<Calibration> metres = resolve_flags({"--calib", calib, "--units", "m"}, 2880, 1988);
  EXPECT_DOUBLE_EQ(metres->geometry.baseline, 0.176252);
  EXPECT_EQ(metres->geometry.units, "m");
}

TEST_F(Calibrations, IncompleteOrBadFlagsNameTheFlag) {
  const auto usage_message = [](const std::vector<std::string>& args) -> std::string {
    try {
      (void)resolve_flags(args, 640, 480);
    } catch (const UsageError& e) {
      return e.what();
    }
    return "no usage error";
  };
  EXPECT_NE(usage_message({"--focal", "700"}).find("--baseline is missing"), std::string::npos)
      << usage_message({"--focal", "700"});
  EXPECT_NE(usage_message({"--baseline", "1"}).find("--focal is missing"), std::string::npos);
  EXPECT_NE(usage_message({"--cx", "3"}).find("--focal and --baseline are missing"), std::string::npos);
  EXPECT_NE(usage_message({"--focal", "7", "--baseline", "1", "--units", "parsec"}).find("parsec"), std::string::npos);
  EXPECT_THROW(resolve_flags({"--focal", "-7", "--baseline", "1"}, 640, 480), CLI::ParseError);
  const std::string calib = write("calib.txt", kAdirondack);
  EXPECT_THROW(resolve_flags({"--calib", calib}, 640, 480), RuntimeError);  // another size
}


// ---- Real rigs: the files OpenCV's stereo_calib sample writes (samples/cpp/stereo_calib.cpp):
// intrinsics.yml with M1 D1 M2 D2 and extrinsics.yml with R T R1 R2 P1 P2 Q, no image size, the
// distortion of CALIB_RATIONAL_MODEL (8 coefficients, a 1x8 row).

// A rig of two slightly different cameras, the right one 0.12 to the right and turned a little.
struct SampleRig {
  cv::Mat M1 = (cv::Mat_<double>(3, 3) << 702.1, 0, 318.4, 0, 701.7, 241.2, 0, 0, 1);
  cv::Mat M2 = (cv::Mat_<double>(3, 3) << 699.3, 0, 322.9, 0, 699.0, 238.6, 0, 0, 1);
  cv::Mat R = (cv::Mat_<double>(3, 3) << 0.99998, -0.0049, 0.0032, 0.0049, 0.99998, 0.0011, -0.0032, -0.0011, 0.99999);
  cv::Mat T = (cv::Mat_<double>(3, 1) << -0.1198, 0.0004, -0.0011);
  cv::Mat distortion(int n) const {
    cv::Mat d = cv::Mat::zeros(1, n, CV_64F);
    const double values[14] = {-0.12, 0.031, 0.0004, -0.0002, 0.002, 0.0011, -0.0006, 0.0003,
                               0.0001, -0.0001, 0.00005, -0.00004, 0.0002, -0.0001};
    for (int i = 0; i < n; ++i) d.at<double>(0, i) = values[i];
    return d;
  }
  // What stereoRectify makes of it for images of `size` (as the sample does, alpha -1 aside).
  void rectify(cv::Size size, int n, cv::Mat& R1, cv::Mat& R2, cv::Mat& P1, cv::Mat& P2, cv::Mat& Q) const {
    cv::stereoRectify(M1, distortion(n), M2, distortion(n), size, R, T, R1, R2, P1, P2, Q, cv::CALIB_ZERO_DISPARITY, 0.0);
  }
};

TEST_F(Calibrations, StereoCalibSampleFilesGivenTwiceAreReadAsOne) {
  const SampleRig rig;
  cv::Mat R1, R2, P1, P2, Q;
  rig.rectify({640, 480}, 8, R1, R2, P1, P2, Q);
  const std::string intrinsics = write_storage("intrinsics.yml", [&](cv::FileStorage& f) {
    f << "M1" << rig.M1 << "D1" << rig.distortion(8) << "M2" << rig.M2 << "D2" << rig.distortion(8);
  });
  const std::string extrinsics = write_storage("extrinsics.yml", [&](cv::FileStorage& f) {
    f << "R" << rig.R << "T" << rig.T << "R1" << R1 << "R2" << R2 << "P1" << P1 << "P2" << P2 << "Q" << Q;
  });
  for (const auto& order : {std::vector<std::string>{"--calib", intrinsics, "--calib", extrinsics},
                            std::vector<std::string>{"--calib", extrinsics, "--calib", intrinsics}}) {
    const std::optional<Calibration> c = resolve_flags(order, 640, 480);
    ASSERT_TRUE(c.has_value());
    EXPECT_TRUE(c->needs_rectification);
    EXPECT_EQ(c->width, 640);  // the pair's: the files have no size
    EXPECT_EQ(c->height, 480);
    EXPECT_EQ(cv::norm(c->K1, rig.M1), 0.0);
    EXPECT_EQ(cv::norm(c->K2, rig.M2), 0.0);
    EXPECT_EQ(c->D1.total(), 8u);
    EXPECT_EQ(cv::norm(c->P2, P2), 0.0);  // the file's projections, not recomputed
    EXPECT_DOUBLE_EQ(c->geometry.focal, P1.at<double>(0, 0));
    EXPECT_NEAR(c->geometry.baseline, cv::norm(rig.T), 1e-9);
    EXPECT_NE(c->source.find(" + "), std::string::npos) << c->source;  // both files name it
    const Rectifier rectifier(*c, 640, 480);  // the maps need the size the file lacks
    EXPECT_DOUBLE_EQ(rectifier.geometry().focal, c->geometry.focal);
  }
  // Read alone, the intrinsics say what they lack.
  expect_error(intrinsics, {"intrinsics.yml", "'P1'", "R and T"});
}

TEST_F(Calibrations, AMergedSampleFileWithoutSizeTakesThePairsSize) {
  // The sample's two files merged into one, as rigs often ship them: the raw cameras and R, T only,
  // so rectifying (stereoRectify) needs the image size, which the pair gives.
  const SampleRig rig;
  const std::string merged = write_storage("stereo.yml", [&](cv::FileStorage& f) {
    f << "M1" << rig.M1 << "D1" << rig.distortion(5) << "M2" << rig.M2 << "D2" << rig.distortion(5);
    f << "R" << rig.R << "T" << rig.T;
  });
  expect_error(merged, {"stereo.yml", "'image_width'", "image size"});  // no pair, no size
  const std::optional<Calibration> c = resolve_flags({"--calib", merged}, 800, 600);
  ASSERT_TRUE(c.has_value());
  EXPECT_EQ(c->width, 800);
  EXPECT_EQ(c->height, 600);
  EXPECT_TRUE(c->needs_rectification);
  cv::Mat R1, R2, P1, P2, Q;
  rig.rectify({800, 600}, 5, R1, R2, P1, P2, Q);
  EXPECT_NEAR(cv::norm(c->P1, P1), 0.0, 1e-9);
  EXPECT_NEAR(c->geometry.focal, P1.at<double>(0, 0), 1e-9);
  // A file with its own size keeps it: another pair size is refused.
  const std::string sized = write_storage("sized.yml", [&](cv::FileStorage& f) {
    f << "image_width" << 640 << "image_height" << 480;
    f << "M1" << rig.M1 << "D1" << rig.distortion(5) << "M2" << rig.M2 << "D2" << rig.distortion(5);
    f << "R" << rig.R << "T" << rig.T;
  });
  EXPECT_EQ(resolve_flags({"--calib", sized}, 640, 480)->width, 640);
  EXPECT_THROW(resolve_flags({"--calib", sized}, 800, 600), RuntimeError);
}

TEST_F(Calibrations, DistortionOf4To14CoefficientsAndKOrMNames) {
  const SampleRig rig;
  for (int n : {4, 5, 8, 12, 14}) {
    for (const bool m_names : {true, false}) {
      const std::string path = write_storage("d" + std::to_string(n) + (m_names ? "m" : "k") + ".yml",
                                             [&](cv::FileStorage& f) {
                                               f << (m_names ? "M1" : "K1") << rig.M1 << "D1" << rig.distortion(n);
                                               f << (m_names ? "M2" : "K2") << rig.M2 << "D2" << rig.distortion(n);
                                               f << "R" << rig.R << "T" << rig.T;
                                             });
      const Calibration c = read_calibration(path, 640, 480);
      EXPECT_EQ(c.D1.total(), static_cast<std::size_t>(n)) << path;
      EXPECT_EQ(c.D2.total(), static_cast<std::size_t>(n)) << path;
      EXPECT_EQ(cv::norm(c.K1, rig.M1), 0.0) << path;
      cv::Mat R1, R2, P1, P2, Q;
      rig.rectify({640, 480}, n, R1, R2, P1, P2, Q);
      EXPECT_NEAR(cv::norm(c.P2, P2), 0.0, 1e-9) << path;
      EXPECT_NO_THROW(Rectifier(c, 640, 480)) << path;
    }
  }
  for (int n : {3, 6, 9}) {
    const std::string path = write_storage("bad" + std::to_string(n) + ".yml", [&](cv::FileStorage& f) {
      f << "M1" << rig.M1 << "D1" << cv::Mat::zeros(1, n, CV_64F) << "M2" << rig.M2 << "D2" << rig.distortion(5);
      f << "R" << rig.R << "T" << rig.T;
    });
    expect_error(path, {"'D1'", "4, 5, 8, 12, 14"});
  }
}

TEST_F(Calibrations, CalibTwiceOnlyCombinesOpenCvFiles) {
  const std::string middlebury = write("calib.txt", kAdirondack);
  const std::string projections = write_storage("p.yml", [](cv::FileStorage& f) { f << "P1" << kP1 << "P2" << kP2; });
  try {
    (void)resolve_flags({"--calib", middlebury, "--calib", projections}, 2880, 1988);
    ADD_FAILURE() << "no error";
  } catch (const RuntimeError& e) {
    EXPECT_NE(std::string(e.what()).find("only OpenCV FileStorage files"), std::string::npos) << e.what();
  }
  // One --calib takes one file: a second word is not swallowed.
  CLI::App app;
  CalibrationFlags flags;
  flags.add_to(app);
  std::vector<std::string> positional;
  app.add_option("pair", positional);
  std::vector<std::string> args{"--calib", projections, "left.png", "right.png"};
  std::reverse(args.begin(), args.end());
  app.parse(args);
  EXPECT_EQ(flags.files(), std::vector<std::string>{projections});
  EXPECT_EQ(positional, (std::vector<std::string>{"left.png", "right.png"}));
}

}  // namespace
}  // namespace mctstereo::app
