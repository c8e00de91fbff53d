// The program against a careless or hostile user: files nested or sized to break a parser, outputs
// that are devices, FIFOs or links, numbers at the edges of a float, empty values, a memory limit.
// Each case fails with a clear message naming the file or flag and leaves the folder as it was, or
// (devices, links) writes where it should and nowhere else. docs/RELIABILITY.md lists the cases.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <thread>

#include "cli_test_util.hpp"

namespace {

using mctstereo::test::folder_listing;
using mctstereo::test::read_text;
using mctstereo::test::Result;
using mctstereo::test::shell_quoted;

namespace fs = std::filesystem;

constexpr int kUsage = 2;
constexpr int kRuntime = 1;
const std::string kPair = "match left.png right.png --num-disparities 16 --threads 1 ";

// An OpenCV P1 and P2 for the 384 x 288 Tsukuba pair: focal 400, baseline 0.1.
constexpr const char* kProjections =
    "P1: !!opencv-matrix\n  rows: 3\n  cols: 4\n  dt: d\n  data: [ 400., 0., 191.5, 0., 0., 400., 143.5, 0., 0., "
    "0., 1., 0. ]\nP2: !!opencv-matrix\n  rows: 3\n  cols: 4\n  dt: d\n  data: [ 400., 0., 191.5, -40., 0., 400., "
    "143.5, 0., 0., 0., 1., 0. ]\n";

bool is_symlink_to(const fs::path& link, const fs::path& target) {
  return fs::is_symlink(fs::symlink_status(link)) && fs::read_symlink(link) == target;
}

class Hardening : public mctstereo::test::FolderTest {
 protected:
  void SetUp() override {
    FolderTest::SetUp();
    copy_tsukuba_pair();
  }

  // A one-channel PFM of width x height zeros, or only its header.
  std::string write_pfm(const std::string& name, int width, int height, bool header_only = false) const {
    std::string bytes = "Pf\n" + std::to_string(width) + " " + std::to_string(height) + "\n-1.0\n";
    if (!header_only) bytes.append(static_cast<std::size_t>(width) * height * 4, '\0');
    return write(name, bytes);
  }

  static std::string program() { return shell_quoted(mctstereo::test::kProgram.string()); }

  // Runs a shell script in the folder, its stderr with its stdout.
  Result run_in_folder(const std::string& script) const {
    return mctstereo::test::run_shell("cd " + shell_quoted(folder_.string()) + " && { " + script + " ; } 2>&1");
  }

  // scene.txt of a scene on the Tsukuba pair with zero ground truth, and `extra` lines.
  void write_scene(const std::string& extra) const {
    fs::create_directories(folder_ / "data/s");
    for (const char* image : {"left.png", "right.png"})
      fs::copy_file(folder_ / image, folder_ / "data/s" / image, fs::copy_options::skip_existing);
    if (!fs::exists(folder_ / "data/s/gt.pfm")) write_pfm("data/s/gt.pfm", 384, 288);
    write("data/s/scene.txt", "scene=s\nleft=left.png\nright=right.png\ngt=gt.pfm\nmasks=none\n" + extra);
  }
};

TEST_F(Hardening, DeeplyNestedCalibrationIsRefusedBeforeOpenCvParsesIt) {
  // OpenCV's FileStorage parsers recurse once per level: these overflowed the stack.
  write("deep.yml", "%YAML:1.0\nP1: " + std::string(50000, '[') + std::string(50000, ']') + "\n");
  write("deep.json", "{\"P1\": " + std::string(200000, '[') + std::string(200000, ']') + "}\n");
  std::string xml = "<?xml version=\"1.0\"?>\n<opencv_storage>";
  for (int i = 0; i < 100000; ++i) xml += "<a>";
  for (int i = 0; i < 100000; ++i) xml += "</a>";
  write("deep.xml", xml + "</opencv_storage>\n");
  std::string indented = "%YAML:1.0\n";
  for (int i = 0; i < 2000; ++i) indented += std::string(i, ' ') + "k" + std::to_string(i) + ":\n";
  write("indented.yml", indented);
  for (const char* file : {"deep.yml", "deep.json", "deep.xml", "indented.yml"})
    expect_failure(kPair + "-o d.pfm --depth z.pfm --calib " + file, kRuntime,
                   "calibration '" + std::string(file) + "': nested too deeply");
  // A calibration as OpenCV writes it nests two levels and still reads.
  write("rig.yml", std::string("%YAML:1.0\n") + kProjections);
  const Result r = run(kPair + "-o d.pfm --depth z.pfm --calib rig.yml");
  EXPECT_EQ(r.status, 0) << r.output;
}

TEST_F(Hardening, GarbageCalibrationAndUnknownUnitsNameTheFile) {
  write("garbage.yml", "%YAML:1.0\nP1: [ [ [ { : : : ]]] ,,,\n");
  expect_failure(kPair + "-o d.pfm --depth z.pfm --calib garbage.yml", kRuntime,
                 "calibration 'garbage.yml': cannot parse it as an OpenCV FileStorage file");
  write("parsec.yml", std::string("%YAML:1.0\nunits: parsec\n") + kProjections);
  expect_failure(kPair + "-o d.pfm --depth z.pfm --calib parsec.yml", kRuntime,
                 "calibration 'parsec.yml': key 'units' is 'parsec', an unknown unit (known: m, cm, mm, in, ft)");
  write("calib.txt", "cam0=[400 0 191.5; 0 400 143.5; 0 0 1]\ndoffs=0\nbaseline=1e-320\nwidth=384\nheight=288\n");
  expect_failure(kPair + "-o d.pfm --depth z.pfm --calib calib.txt", kRuntime,
                 "calibration 'calib.txt': key 'baseline' is too small (below 2.22507e-308): '1e-320'");
}

TEST_F(Hardening, FocalAndBaselineMustGiveDepthsAFloatHolds) {
  const std::string depth = kPair + "-o d.pfm --ply c.ply ";
  expect_failure(depth + "--focal 1e38 --baseline 1e38", kUsage, "--focal 1e+38 is too large (at most 1e+30)");
  expect_failure(depth + "--focal 1e20 --baseline 1e20", kUsage,
                 "--focal x --baseline = 1e+40 is too large (at most 1e+30): depths would not fit a float");
  expect_failure(depth + "--focal 1e-45 --baseline 1", kUsage, "--focal 1e-45 is too small (at least 1e-30)");
  expect_failure(depth + "--focal nan --baseline 1", kUsage, "--focal: 'nan' is not a number");
  expect_failure(depth + "--focal 400 --baseline inf", kUsage, "--baseline: 'inf' is too large");
  expect_failure(depth + "--focal 400 --baseline 1e-320", kUsage, "--baseline: '1e-320' is too small");
  expect_failure(depth + "--focal 400 --baseline 0.1 --cx nan", kUsage, "--cx: 'nan' is not a number");
  expect_failure(depth + "--focal 400 --baseline 0.1 --doffs 1e308", kUsage,
                 "doffs 1e+308 is too far from the image (at most 1e+06 px either way)");
  expect_failure(depth + "--focal 400 --baseline 0.1 --max-depth 1e999", kUsage, "--max-depth: '1e999' is too large");
}

TEST_F(Hardening, EmptyNumbersAreRefused) {
  expect_failure(kPair + "-o d.pfm --min-disparity ''", kUsage, "--min-disparity: the value is empty");
  expect_failure(kPair + "-o d.pfm --speckle-size ''", kUsage, "--speckle-size: the value is empty");
  expect_failure(kPair + "-o d.pfm --threads ''", kUsage, "--threads: the value is empty");
}

TEST_F(Hardening, TheLargestDisparityIsTheBoundThatHelpAndValidationName) {
  const Result help = run("match --help");
  EXPECT_NE(help.output.find("min + N - 1 <= 2039"), std::string::npos) << help.output;
  expect_failure("match left.png right.png -o d.pfm --num-disparities 2048", kUsage,
                 "min_disparity + num_disparities - 1 = 2047 must be at most 2039");
  // With a negative minimum the whole count of 2048 fits.
  expect_failure("match left.png right.png -o d.pfm --num-disparities 2048 --min-disparity -8", kUsage,
                 "num_disparities = 2048 is wider than the image (384 px)");
}

TEST_F(Hardening, RenderRefusesOverflowingSizesAndNonFiniteViews) {
  ASSERT_EQ(run(kPair + "-o d.pfm --ply c.ply --focal 400 --baseline 0.1").status, 0);
  expect_failure("render c.ply -o v.png --size 4294967297x1", kUsage,
                 "--size '4294967297x1': expected WIDTHxHEIGHT, each 1 .. 16384");
  expect_failure("render c.ply -o v.png --size -1x5", kUsage, "--size '-1x5'");
  expect_failure("render c.ply -o v.png --yaw nan", kUsage, "--yaw: 'nan' is not a number");
  expect_failure("render c.ply -o v.png --focal nan", kUsage, "--focal: 'nan' is not a number");
  expect_failure("render c.ply -o v.png --focal inf", kUsage, "--focal: 'inf' is too large");
  expect_failure("render c.ply -o v.png --focal 1e308", kUsage, "--focal 1e+308 is too large (at most 1e+09 pixels)");
  fs::create_directories(folder_ / "cloud_folder");
  expect_failure("render cloud_folder -o v.png", kRuntime, "cannot read point cloud 'cloud_folder': it is a folder");
}

TEST_F(Hardening, OversizedInputsAreTooLargeAndShowTheirValueAsWritten) {
  // A PNG header declaring 100000 x 100000 (the pixels need not follow: the size is refused first).
  const unsigned char png[] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0, 0, 0, 13, 'I', 'H', 'D', 'R',
                               0, 1, 0x86, 0xa0, 0, 1, 0x86, 0xa0, 8, 0, 0, 0, 0, 0, 0, 0, 0};
  write("huge.png", std::string(reinterpret_cast<const char*>(png), sizeof png));
  expect_failure("match huge.png right.png -o d.pfm", kRuntime,
                 "left image 'huge.png' is 100000x100000: too large (at most 32768 x 32768 pixels)");
  write("huge.pgm", "P5\n# a comment\n99999999999 2\n255\n");
  expect_failure("match huge.pgm right.png -o d.pfm", kRuntime, "'huge.pgm' is 99999999999x2: too large");

  write_scene("max_disp=99999999999\n");
  expect_failure("eval data", kRuntime,
                 "scene.txt': max_disp=99999999999 is too large (disparities lie in [-4096, 4096])");
  write_scene("max_disp=1e-320\n");
  expect_failure("eval data", kRuntime, "max_disp=1e-320 is too small (below 2.22507e-308)");
  write_pfm("data/s/gt.pfm", 100000, 100000, true);
  write_scene("max_disp=15\n");
  expect_failure("eval data", kRuntime,
                 "PFM header 'Pf 100000 100000 -1.0': 100000x100000 is too large (at most 32768 x 32768");
}

TEST_F(Hardening, InputsThatAreNotRegularFilesAreRefusedWithoutOpeningThem) {
  ASSERT_EQ(::mkfifo((folder_ / "fifo.png").c_str(), 0644), 0);
  // Before, open() of a FIFO without a writer never returned.
  expect_failure("match fifo.png right.png -o d.pfm", kRuntime,
                 "cannot read left image 'fifo.png': it is a FIFO, not a regular file");
  expect_failure(kPair + "-o d.pfm --depth z.pfm --calib fifo.png", kRuntime,
                 "cannot read calibration 'fifo.png': it is a FIFO, not a regular file");
  expect_failure("render fifo.png -o v.png", kRuntime, "cannot read point cloud 'fifo.png': it is a FIFO");
  expect_failure("stream --left fifo.png --right fifo.png", kRuntime,
                 "cannot open --left 'fifo.png': it is a FIFO, not a video file, folder or camera");
  EXPECT_TRUE(fs::is_fifo(folder_ / "fifo.png"));
}

TEST_F(Hardening, ACheckOfTheRectificationOfATinyPairSaysItIsTooSmall) {
  ASSERT_TRUE(cv::imwrite((folder_ / "one.png").string(), cv::Mat(1, 1, CV_8UC1, cv::Scalar(128))));
  expect_failure("match one.png one.png --num-disparities 1 --check-rectification", kRuntime,
                 "the pair is 1x1: too small to check its rectification");
}

TEST_F(Hardening, TheSameOutputSpeltTwoWaysIsRefusedBeforeItExists) {
  fs::create_directories(folder_ / "s");
  const std::string absolute = (folder_ / "x.pfm").string();
  for (const std::string& second : {std::string("./x.pfm"), absolute, std::string("s/../x.pfm")})
    expect_failure(kPair + "-o x.pfm --depth " + shell_quoted(second), kUsage, "-o and --depth are the same file");
  expect_failure(kPair + "-o x.png --color ./x.png", kUsage, "-o and --color are the same file");
  // Through a folder that does not exist the name cannot be written at all.
  expect_failure(kPair + "-o x.pfm --depth t/../x.pfm", kRuntime, "folder 't/..' does not exist");
}

TEST_F(Hardening, DevicesAndFifosAreWrittenInPlaceAndLinksThrough) {
  // Links in the folder stand for the devices: should the program rename over them, the link goes
  // and the device stays.
  fs::create_symlink("/dev/full", folder_ / "full.pfm");
  expect_failure(kPair + "-o full.pfm", kRuntime, "cannot write 'full.pfm': No space left on device");
  EXPECT_TRUE(is_symlink_to(folder_ / "full.pfm", "/dev/full"));

  fs::create_symlink("/dev/null", folder_ / "null.pfm");
  fs::create_symlink("/dev/null", folder_ / "null.png");
  const Result to_null = run(kPair + "-o null.pfm --color null.png");
  EXPECT_EQ(to_null.status, 0) << to_null.output;
  EXPECT_TRUE(is_symlink_to(folder_ / "null.pfm", "/dev/null"));
  EXPECT_TRUE(fs::is_character_file("/dev/null"));

  ASSERT_EQ(::mkfifo((folder_ / "fifo.pfm").c_str(), 0644), 0);
  expect_failure(kPair + "-o fifo.pfm", kRuntime, "cannot write 'fifo.pfm': it is a FIFO that no process reads");
  const Result through_fifo = run_in_folder("{ cat fifo.pfm > read.pfm & } ; sleep 0.3; " + program() + " " + kPair +
                                            "-o fifo.pfm; status=$?; wait; exit $status");
  EXPECT_EQ(through_fifo.status, 0) << through_fifo.output;
  EXPECT_TRUE(fs::is_fifo(folder_ / "fifo.pfm"));
  EXPECT_EQ(read_text(folder_ / "read.pfm").rfind("Pf\n384 288\n-1.0\n", 0), 0u);

  write("target.pfm", "old");
  fs::create_symlink("target.pfm", folder_ / "link.pfm");
  const Result through_link = run(kPair + "-o link.pfm");
  EXPECT_EQ(through_link.status, 0) << through_link.output;
  EXPECT_TRUE(is_symlink_to(folder_ / "link.pfm", "target.pfm"));
  EXPECT_EQ(read_text(folder_ / "target.pfm").rfind("Pf\n384 288\n-1.0\n", 0), 0u);

  // A file the program has open is written where it is, at its offset.
  const Result to_stdout = run_in_folder(program() + " " + kPair + "-o /dev/stdout --format pfm > out.pfm");
  EXPECT_EQ(to_stdout.status, 0) << to_stdout.output;
  const std::string out = read_text(folder_ / "out.pfm");
  EXPECT_EQ(out.rfind("Pf\n384 288\n-1.0\n", 0), 0u);
  EXPECT_NE(out.find("wrote /dev/stdout"), std::string::npos) << "the summary follows the map";
  // The summary is output too.
  const Result summary_to_full = run_in_folder(program() + " " + kPair + "-o d.pfm > /dev/full");
  EXPECT_EQ(summary_to_full.status, kRuntime);
  EXPECT_EQ(summary_to_full.output, "mctstereo: error: cannot write to stdout: No space left on device\n");

  fs::create_symlink("missing.pfm", folder_ / "dangling.pfm");
  expect_failure(kPair + "-o dangling.pfm", kRuntime, "'dangling.pfm': it is a symbolic link to a missing file");
  // A link to an input is the input.
  fs::create_symlink("left.png", folder_ / "to_left.png");
  expect_failure(kPair + "-o to_left.png", kUsage, "refusing to overwrite an input");
}

TEST_F(Hardening, OpenMpThreadCountIsCappedAtTheHardwareThreads) {
  // Before, OMP_NUM_THREADS=100000 started that many threads and crashed.
  const Result r = run("match left.png right.png --num-disparities 16 -o d.pfm", "OMP_NUM_THREADS=100000 ");
  ASSERT_EQ(r.status, 0) << r.output;
  std::smatch threads;
  ASSERT_TRUE(std::regex_search(r.output, threads, std::regex("threads ([0-9]+)"))) << r.output;
  EXPECT_LE(std::stoi(threads[1]), static_cast<int>(std::max(1u, std::thread::hardware_concurrency()))) << r.output;
}

TEST_F(Hardening, ThreadsThatCannotStartUnderAMemoryLimitAreFewerNotFatal) {
  // Stacks of 1 GiB under a limit of 6 GiB of address space: a team of 16 threads cannot start.
  // Before, libgomp ended the process ("Thread creation failed").
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer reserves terabytes of address space for its shadow memory: a program "
                  "built with it cannot start under any limit of the address space";
#endif
  const Result r = run_in_folder("ulimit -s 1048576 && ulimit -v 6291456 && " + program() +
                                 " match left.png right.png --num-disparities 16 -o d.pfm --threads 16");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("mctstereo: note: only "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(" of 16 threads could be started (memory limit?)"), std::string::npos) << r.output;
  EXPECT_EQ(read_text(folder_ / "d.pfm").rfind("Pf\n384 288\n-1.0\n", 0), 0u);
}

}  // namespace

namespace {

// Found by fuzz/fuzz_image.cpp: a file that OpenCV gave to its DICOM decoder (GDCM) aborted the
// whole process in an assertion. Only PNG, PNM, JPEG, BMP, TIFF and WebP reach OpenCV now, and a
// PGM that also carries DICOM's mark at byte 128 (which OpenCV asks before its PNM decoder) is
// refused; other formats OpenCV knows (Sun raster, say) are refused by name.
TEST_F(Hardening, OnlyTheImageFormatsNamedReachOpenCvsDecoders) {
  std::string dicom_pgm = "P5\n8 8\n255\n";
  dicom_pgm.resize(128, '#');
  dicom_pgm += "DICM";
  dicom_pgm.append(64, '\x01');
  write("dicom.pgm", dicom_pgm);
  expect_failure("match dicom.pgm right.png -o d.pfm", kRuntime,
                 "cannot decode left image 'dicom.pgm': not a PNG, PPM, PGM, JPEG, BMP, TIFF or WebP image");
  const unsigned char sun[] = {0x59, 0xa6, 0x6a, 0x95, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 8,
                               0,    0,    0,    1,    0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 7};
  write("sun.ras", std::string(reinterpret_cast<const char*>(sun), sizeof sun));
  expect_failure("match left.png sun.ras -o d.pfm", kRuntime,
                 "cannot decode right image 'sun.ras': not a PNG, PPM, PGM, JPEG, BMP, TIFF or WebP image");
  // The formats named still decode: the pair as BMP gives the PNG pair's map.
  ASSERT_TRUE(cv::imwrite((folder_ / "left.bmp").string(), cv::imread((folder_ / "left.png").string())));
  ASSERT_TRUE(cv::imwrite((folder_ / "right.tif").string(), cv::imread((folder_ / "right.png").string())));
  const Result bmp = run("match left.bmp right.tif --num-disparities 16 -o b.pfm");
  ASSERT_EQ(bmp.status, 0) << bmp.output;
  const Result png = run("match left.png right.png --num-disparities 16 -o p.pfm");
  ASSERT_EQ(png.status, 0) << png.output;
  EXPECT_EQ(read_text(folder_ / "b.pfm"), read_text(folder_ / "p.pfm"));
}

}  // namespace
