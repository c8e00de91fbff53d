#include "calibration.hpp"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <opencv2/calib3d.hpp>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "depth_files.hpp"
#include "errors.hpp"
#include "input_files.hpp"
#include "output_files.hpp"

namespace mctstereo::app {

namespace fs = std::filesystem;

namespace {

std::string trimmed(const std::string& text) {
  const char* const space = " \t\r\n\f\v";
  const std::size_t begin = text.find_first_not_of(space);
  if (begin == std::string::npos) return "";
  return text.substr(begin, text.find_last_not_of(space) - begin + 1);
}

std::string lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return std::tolower(c); });
  return text;
}

std::string number_text(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

std::string size_text(int width, int height) { return std::to_string(width) + "x" + std::to_string(height); }

// Errors about one file: "calibration 'FILE': MESSAGE".
struct FileErrors {
  std::string path;

  [[noreturn]] void fail(const std::string& message) const {
    throw RuntimeError("calibration " + in_quotes(path) + ": " + message);
  }
  [[noreturn]] void missing(const std::string& key, const std::string& why = "") const {
    fail("key '" + key + "' is missing" + (why.empty() ? "" : " (" + why + ")"));
  }
  [[noreturn]] void malformed(const std::string& key, const std::string& what) const {
    fail("key '" + key + "' " + what);
  }
};

std::string read_text(const std::string& path) {
  const std::string text = read_input_file(path, "calibration");
  if (trimmed(text).empty()) throw RuntimeError("cannot read calibration " + in_quotes(path) + ": the file is empty");
  return text;
}

// A whole string as a finite number; nullopt when it is anything else.
std::optional<double> parse_number(const std::string& text) {
  double v = 0.0;
  if (!number_problem(text, v).empty()) return std::nullopt;
  return v;
}

// A cheap scan of a FileStorage file for how deeply its values nest: OpenCV's parsers recurse once
// per level, so a file of a few megabytes of '[' (or of '{', or of XML tags, or of indentation)
// overflows the stack before they can fail. Brackets inside strings count too, which only errs on
// the safe side; a calibration file nests a few levels.
constexpr int kMaxStorageNesting = 64;
constexpr std::size_t kMaxStorageIndent = 1024;

void check_storage_nesting(const std::string& path, const std::string& text) {
  int depth = 0, deepest = 0;
  std::size_t indent = 0, deepest_indent = 0;
  bool line_start = true;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\n') {
      line_start = true;
      indent = 0;
      continue;
    }
    if (line_start && (c == ' ' || c == '\t' || c == '-')) {  // YAML nests by indentation and '- '
      deepest_indent = std::max(deepest_indent, ++indent);
      continue;
    }
    line_start = false;
    const char next = i + 1 < text.size() ? text[i + 1] : '\0';
    if (c == '[' || c == '{' || (c == '<' && next != '/' && next != '?' && next != '!')) ++depth;
    if (c == ']' || c == '}' || (c == '<' && next == '/') || (c == '/' && next == '>')) --depth;
    deepest = std::max(deepest, depth);
  }
  if (deepest > kMaxStorageNesting || deepest_indent > kMaxStorageIndent)
    throw RuntimeError("calibration " + in_quotes(path) + ": nested too deeply (" +
                       (deepest > kMaxStorageNesting ? "more than " + std::to_string(kMaxStorageNesting) + " levels"
                                                     : "indented by more than " + std::to_string(kMaxStorageIndent) +
                                                           " characters") +
                       "); a calibration nests a few levels");
}

// A FileStorage file is text: a NUL or another control character (but tab, line feed, carriage
// return) means a binary or damaged file, and OpenCV 4.6's XML parser reads past a NUL inside its
// header into a null pointer (found by fuzz/fuzz_calibration.cpp).
void check_storage_text(const std::string& path, const std::string& text) {
  for (std::size_t i = 0; i < text.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (c < 0x20 && c != '\t' && c != '\n' && c != '\r') {
      char code[8];
      std::snprintf(code, sizeof code, "0x%02x", c);
      throw RuntimeError("calibration " + in_quotes(path) + ": byte " + std::to_string(i) + " is " + code +
                         ", a control character: a YAML, JSON or XML calibration is text");
    }
  }
}

// OpenCV 4.6's FileStorage parsers loop for ever on some malformed files (such as "%YAML:1.0",
// "   s:3", "ncv-" on three lines) and read through null pointers on others (found by
// fuzz/fuzz_calibration.cpp). So each file is parsed first in a child process under a time limit;
// the file is parsed again here only when the child came back. A child that crashed or ran out
// of time is an error naming the file; any other outcome lets the parse below give its own message.
constexpr unsigned kStorageParseSeconds = 5;

void check_storage_parses(const std::string& path) {
  std::fflush(nullptr);  // nothing buffered is written twice
  const pid_t child = ::fork();
  if (child < 0) return;  // no process to spare: the parse below runs unguarded, as it would anyway
  if (child == 0) {
    // Default actions: the process ends on a fault or the alarm, whatever handlers it inherited.
    for (const int sig : {SIGALRM, SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT}) ::signal(sig, SIG_DFL);
    ::alarm(kStorageParseSeconds);
    int status = 1;
    try {
      cv::FileStorage storage(path, cv::FileStorage::READ);
      status = storage.isOpened() ? 0 : 1;
    } catch (...) {
    }
    ::_exit(status);  // no exit handlers of the parent (temporary files, sanitizers) run here
  }
  int status = 0;
  while (::waitpid(child, &status, 0) < 0) {
    if (errno != EINTR) return;
  }
  if (!WIFSIGNALED(status)) return;
  const int sig = WTERMSIG(status);
  if (sig == SIGALRM)
    throw RuntimeError("calibration " + in_quotes(path) + ": OpenCV's FileStorage parser did not finish within " +
                       std::to_string(kStorageParseSeconds) + " s (a malformed YAML, JSON or XML file)");
  throw RuntimeError("calibration " + in_quotes(path) + ": OpenCV's FileStorage parser crashed on it (signal " +
                     std::to_string(sig) + ", " + ::strsignal(sig) + "): a malformed YAML, JSON or XML file");
}

// A number for messages, short whatever its size.
std::string short_number(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", v);
  return text;
}

// Depth is focal x baseline / (d + doffs) in float, X and Y are (x - cx) baseline / (d + doffs):
// within these bounds every depth and coordinate of an image up to 32768 pixels is a normal float.
constexpr double kMinGeometry = 1e-30, kMaxGeometry = 1e30;
// Principal points and their difference, in pixels of images at most 32768 wide: far beyond, X, Y
// and depth lose every digit.
constexpr double kMaxPixelOffset = 1e6;

// Why `value` cannot be a focal length or a baseline ("" when it can); `name` names it.
std::string scale_problem(double value, const std::string& name) {
  if (std::isnan(value)) return name + " is not a number";
  if (value <= 0.0) return name + " must be positive (is " + short_number(value) + ")";
  if (value < kMinGeometry)
    return name + " " + short_number(value) + " is too small (at least " + short_number(kMinGeometry) + ")";
  if (value > kMaxGeometry)
    return name + " " + short_number(value) + " is too large (at most " + short_number(kMaxGeometry) + ")";
  return "";
}

// Why a geometry cannot give depths ("" when it can): focal, baseline and their product must lie
// in [kMinGeometry, kMaxGeometry], cx, cy and doffs within kMaxPixelOffset. The names of focal and baseline
// are those of the flags that gave them, if any.
std::string geometry_range_problem(const StereoGeometry& g, const std::string& focal_name,
                                   const std::string& baseline_name) {
  for (const auto& [value, name] : {std::pair{g.focal, focal_name}, std::pair{g.baseline, baseline_name}})
    if (const std::string problem = scale_problem(value, name); !problem.empty()) return problem;
  const std::string product = scale_problem(g.focal * g.baseline, focal_name + " x " + baseline_name + " =");
  if (!product.empty()) return product + ": depths would not fit a float";
  for (const auto& [value, name] : {std::pair{g.cx, "cx"}, std::pair{g.cy, "cy"}, std::pair{g.doffs, "doffs"}}) {
    if (!std::isfinite(value)) return std::string(name) + " must be a finite number (is " + short_number(value) + ")";
    if (std::abs(value) > kMaxPixelOffset)
      return std::string(name) + " " + short_number(value) + " is too far from the image (at most " +
             short_number(kMaxPixelOffset) + " px either way)";
  }
  return "";
}

// ---- Middlebury calib.txt ------------------------------------------------------------------------

// "[a b c; d e f; g h i]" as a 3 x 3 matrix.
cv::Matx33d parse_middlebury_matrix(const std::string& key, const std::string& value, const FileErrors& errors) {
  const std::string t = trimmed(value);
  const std::string expected = "is not a 3x3 matrix [f 0 cx; 0 f cy; 0 0 1]: '" + t + "'";
  if (t.size() < 2 || t.front() != '[' || t.back() != ']') errors.malformed(key, expected);
  std::vector<std::string> rows;
  std::stringstream body(t.substr(1, t.size() - 2));
  for (std::string row; std::getline(body, row, ';');) rows.push_back(row);
  if (rows.size() != 3) errors.malformed(key, expected);
  cv::Matx33d m;
  for (int r = 0; r < 3; ++r) {
    std::istringstream words(rows[r]);
    std::vector<std::string> entries{std::istream_iterator<std::string>(words), std::istream_iterator<std::string>()};
    if (entries.size() != 3) errors.malformed(key, expected);
    for (int c = 0; c < 3; ++c) {
      const std::optional<double> v = parse_number(entries[c]);
      if (!v) errors.malformed(key, expected);
      m(r, c) = *v;
    }
  }
  return m;
}

Calibration read_middlebury(const std::string& path, const std::string& text, int image_width, int image_height) {
  const FileErrors errors{path};
  std::map<std::string, std::string> values;
  std::istringstream lines(text);
  int line_number = 0;
  for (std::string line; std::getline(lines, line);) {
    ++line_number;
    line = trimmed(line);
    if (line.empty() || line[0] == '#') continue;
    const std::size_t eq = line.find('=');
    if (eq == std::string::npos)
      errors.fail("line " + std::to_string(line_number) + " is not 'key=value': '" + line + "'");
    values[trimmed(line.substr(0, eq))] = trimmed(line.substr(eq + 1));
  }
  const auto number = [&](const std::string& key) -> std::optional<double> {
    const auto it = values.find(key);
    if (it == values.end()) return std::nullopt;
    double v = 0.0;
    const std::string problem = number_problem(it->second, v);
    if (!problem.empty()) errors.malformed(key, problem + ": '" + it->second + "'");
    return v;
  };
  const auto integer = [&](const std::string& key) -> int {
    const std::optional<double> v = number(key);
    if (!v) return 0;
    if (*v != std::floor(*v) || *v < 0 || *v > 1e9)
      errors.malformed(key, "is not a non-negative whole number: '" + values[key] + "'");
    return static_cast<int>(*v);
  };

  if (!values.count("cam0")) errors.missing("cam0", "the left camera matrix [f 0 cx; 0 f cy; 0 0 1]");
  const cv::Matx33d cam0 = parse_middlebury_matrix("cam0", values["cam0"], errors);
  const std::optional<double> baseline = number("baseline");
  if (!baseline) errors.missing("baseline", "the distance between the cameras, in millimetres");
  std::optional<double> doffs = number("doffs");
  if (!doffs) {
    // doffs is the difference of the principal points, which cam1 gives.
    if (!values.count("cam1")) errors.missing("doffs", "or 'cam1' to compute it from");
    doffs = parse_middlebury_matrix("cam1", values["cam1"], errors)(0, 2) - cam0(0, 2);
  } else if (values.count("cam1")) {
    (void)parse_middlebury_matrix("cam1", values["cam1"], errors);  // malformed is malformed, even if unused
  }

  Calibration c;
  c.source = path;
  c.geometry.focal = cam0(0, 0);
  c.geometry.cx = cam0(0, 2);
  c.geometry.cy = cam0(1, 2);
  c.geometry.baseline = *baseline;
  c.geometry.doffs = *doffs;
  c.geometry.units = "mm";
  if (!(c.geometry.focal > 0)) errors.malformed("cam0", "has a focal length " + number_text(cam0(0, 0)) + " <= 0");
  if (!(c.geometry.baseline > 0)) errors.malformed("baseline", "must be positive (is " + number_text(*baseline) + ")");
  c.width = integer("width");
  c.height = integer("height");
  if ((c.width == 0) != (c.height == 0)) errors.missing(c.width == 0 ? "width" : "height", "given with the other");
  if (c.width == 0 && image_width > 0) {
    c.width = image_width;
    c.height = image_height;
  }
  c.ndisp = integer("ndisp");
  (void)number("vmin");  // checked for form only: the disparity range comes from ndisp
  (void)number("vmax");
  return c;
}

// ---- OpenCV FileStorage -----------------------------------------------------------------------------

// One or more FileStorage files read as one: a key comes from the first file that has it (OpenCV's
// stereo_calib sample writes intrinsics.yml and extrinsics.yml, which share none).
class StorageReader {
 public:
  StorageReader(const std::vector<std::string>& paths, const FileErrors& errors) : errors_(errors) {
    for (const std::string& path : paths) {
      const FileErrors file_errors{path};
      paths_.push_back(path);
      cv::FileStorage& storage = storages_.emplace_back();
      try {
        storage.open(path, cv::FileStorage::READ);
      } catch (const cv::Exception& e) {
        file_errors.fail("cannot parse it as an OpenCV FileStorage file (YAML, XML, JSON): " + trimmed(e.err));
      } catch (const std::exception&) {
        // A parser that lost its way (a length from garbage): its words say nothing about the file.
        file_errors.fail("cannot parse it as an OpenCV FileStorage file (YAML, XML, JSON): malformed");
      }
      if (!storage.isOpened()) file_errors.fail("cannot open it as an OpenCV FileStorage file (YAML, XML, JSON)");
      // Keys are looked up in the top-level map; OpenCV throws for a file whose top level is a
      // sequence or a lone value.
      if (!storage.root().isMap())
        file_errors.fail("its top level is not a map of keys (K1: ..., P1: ...), as in a calibration file");
    }
  }

  bool has(const std::string& key) const { return !node(key).empty(); }

  // The matrix under `key` as CV_64F, with `rows` x `cols` when those are > 0; empty when absent.
  cv::Mat matrix(const std::string& key, int rows, int cols) const {
    if (!has(key)) return {};
    const cv::FileNode found = node(key);
    cv::Mat m;
    try {
      // The declared size first: OpenCV allocates rows x cols before it counts the data, so that
      // "rows: 100000, cols: 100000" would ask for 80 GB. A calibration's matrices are 4 x 4 at most.
      if (found.isMap() && declared_values(found) > 0) found >> m;
    } catch (const std::exception&) {  // cv::Exception, or a std::length_error from a garbage count
      m.release();
    }
    if (m.empty() || m.channels() != 1)
      errors_.malformed(key, "is not an OpenCV matrix of at most " + std::to_string(kMaxMatrixSide) + " x " +
                                 std::to_string(kMaxMatrixSide) +
                                 " values (!!opencv-matrix with rows, cols, dt and as many data as rows x cols)");
    m.convertTo(m, CV_64F);
    if ((rows > 0 && m.rows != rows) || (cols > 0 && m.cols != cols))
      errors_.malformed(key, "is " + std::to_string(m.rows) + "x" + std::to_string(m.cols) + ", expected " +
                                 std::to_string(rows) + "x" + std::to_string(cols));
    for (auto it = m.begin<double>(); it != m.end<double>(); ++it)
      if (!std::isfinite(*it)) errors_.malformed(key, "has a value that is not a finite number");
    return m;
  }

  // A vector of `lengths` elements (any of them) as a column.
  cv::Mat vector(const std::string& key, std::initializer_list<int> lengths) const {
    cv::Mat m = matrix(key, 0, 0);
    if (m.empty()) return m;
    const int n = static_cast<int>(m.total());
    if ((m.rows != 1 && m.cols != 1) || std::find(lengths.begin(), lengths.end(), n) == lengths.end()) {
      std::string known;
      for (int l : lengths) known += (known.empty() ? "" : ", ") + std::to_string(l);
      errors_.malformed(key, "is " + std::to_string(m.rows) + "x" + std::to_string(m.cols) + ", expected a vector of " +
                                 known + " values");
    }
    return m.reshape(1, n);
  }

  std::optional<int> integer(const std::string& key) const {
    if (!has(key)) return std::nullopt;
    const cv::FileNode found = node(key);
    if (!found.isInt() && !found.isReal()) errors_.malformed(key, "is not a number");
    const double v = found.real();
    if (v != std::floor(v) || v < 0 || v > 1e9) errors_.malformed(key, "is not a non-negative whole number");
    return static_cast<int>(v);
  }

  std::optional<std::string> text(const std::string& key) const {
    if (!has(key)) return std::nullopt;
    const cv::FileNode found = node(key);
    if (!found.isString()) errors_.malformed(key, "is not a string");
    return found.string();
  }

 private:
  static constexpr int kMaxMatrixSide = 16;

  // rows x cols of a matrix node when both are whole numbers in [1, kMaxMatrixSide] and its data
  // holds that many values; 0 otherwise.
  static int declared_values(const cv::FileNode& matrix) {
    const cv::FileNode rows = matrix["rows"], cols = matrix["cols"], data = matrix["data"];
    if (!rows.isInt() || !cols.isInt() || !data.isSeq()) return 0;
    const int r = static_cast<int>(rows), c = static_cast<int>(cols);
    if (r < 1 || c < 1 || r > kMaxMatrixSide || c > kMaxMatrixSide) return 0;
    return data.size() == static_cast<std::size_t>(r) * static_cast<std::size_t>(c) ? r * c : 0;
  }

  // The key's node in the first file that has it; an empty node when none has. OpenCV throws from
  // a lookup in a file that it parsed without complaint but whose top-level map it cannot walk.
  cv::FileNode node(const std::string& key) const {
    for (std::size_t i = 0; i < storages_.size(); ++i) {
      cv::FileNode n;
      try {
        n = storages_[i][key];
      } catch (const cv::Exception& e) {
        FileErrors{paths_[i]}.fail("cannot look up key '" + key + "', malformed OpenCV FileStorage file: " +
                                   trimmed(e.err));
      }
      if (!n.empty() && !n.isNone()) return n;
    }
    return {};
  }

  std::vector<std::string> paths_;  // of storages_, one for one
  std::vector<cv::FileStorage> storages_;
  const FileErrors& errors_;
};

// The values of a matrix of doubles, row by row (its size checked when it was read).
template <std::size_t N>
std::array<double, N> matrix_values(const cv::Mat& m) {
  std::array<double, N> values{};
  for (std::size_t i = 0; i < N; ++i)
    values[i] = m.at<double>(static_cast<int>(i) / m.cols, static_cast<int>(i) % m.cols);
  return values;
}

cv::Mat matrix_of(const double* values, int rows, int cols) {
  return cv::Mat(rows, cols, CV_64F, const_cast<double*>(values)).clone();
}

// The geometry from P1 and P2, or from Q (the library's), its problems as the file's.
StereoGeometry geometry_of(const cv::Mat& P1, const cv::Mat& P2, const cv::Mat& Q, const FileErrors& errors) {
  try {
    if (!P1.empty()) return geometry_from_projections(matrix_values<12>(P1), matrix_values<12>(P2));
    return geometry_from_reprojection(matrix_values<16>(Q));
  } catch (const GeometryMatrixError& e) {
    errors.malformed(e.matrix(), e.problem());
  }
}

// P1, P2 and Q of a rectified geometry, in OpenCV's form (CALIB_ZERO_DISPARITY aside from doffs).
void projections_of(const StereoGeometry& g, cv::Mat& P1, cv::Mat& P2, cv::Mat& Q) {
  P1 = matrix_of(left_projection(g).data(), 3, 4);
  P2 = matrix_of(right_projection(g).data(), 3, 4);
  Q = matrix_of(reprojection_matrix(g).data(), 4, 4);
}

// The names of several files for messages: "a.yml + b.yml".
std::string joined(const std::vector<std::string>& paths) {
  std::string s;
  for (const std::string& p : paths) s += (s.empty() ? "" : " + ") + p;
  return s;
}

Calibration read_storage(const std::vector<std::string>& paths, int image_width, int image_height) {
  const std::string path = joined(paths);
  const FileErrors errors{path};
  const StorageReader file(paths, errors);
  Calibration c;
  c.source = path;

  // Image size: image_width / image_height, or width / height.
  const std::string width_key = !file.has("image_width") && !file.has("image_height") &&
                                        (file.has("width") || file.has("height"))
                                    ? "width"
                                    : "image_width";
  const std::string height_key = width_key == "image_width" ? "image_height" : "height";
  c.width = file.integer(width_key).value_or(0);
  c.height = file.integer(height_key).value_or(0);
  if ((c.width == 0) != (c.height == 0)) errors.missing(c.width == 0 ? width_key : height_key, "given with the other");
  if (c.width == 0 && image_width > 0) {  // the size of the images it is used for (OpenCV's sample writes none)
    c.width = image_width;
    c.height = image_height;
  }
  c.ndisp = file.integer("ndisp").value_or(0);

  // The raw cameras. OpenCV's stereo_calib sample names the camera matrices M1, M2.
  const std::string k1_key = file.has("K1") || !file.has("M1") ? "K1" : "M1";
  const std::string k2_key = file.has("K2") || !file.has("M2") ? "K2" : "M2";
  c.K1 = file.matrix(k1_key, 3, 3);
  c.D1 = file.vector("D1", {4, 5, 8, 12, 14});
  c.K2 = file.matrix(k2_key, 3, 3);
  c.D2 = file.vector("D2", {4, 5, 8, 12, 14});
  const bool has_intrinsics = !c.K1.empty() || !c.D1.empty() || !c.K2.empty() || !c.D2.empty();
  if (has_intrinsics) {
    const std::string why = "K1, D1, K2 and D2 come together";
    if (c.K1.empty()) errors.missing(k1_key, why);
    if (c.D1.empty()) errors.missing("D1", why);
    if (c.K2.empty()) errors.missing(k2_key, why);
    if (c.D2.empty()) errors.missing("D2", why);
  }
  if (file.has("R")) {
    c.R = file.matrix("R", 0, 0);
    if (!((c.R.rows == 3 && c.R.cols == 3) || c.R.total() == 3))
      errors.malformed("R", "is " + std::to_string(c.R.rows) + "x" + std::to_string(c.R.cols) +
                                ", expected 3x3 (or a 3-vector of Rodrigues angles)");
  }
  c.T = file.vector("T", {3});
  c.R1 = file.matrix("R1", 3, 3);
  c.R2 = file.matrix("R2", 3, 3);
  c.P1 = file.matrix("P1", 3, 4);
  c.P2 = file.matrix("P2", 3, 4);
  c.Q = file.matrix("Q", 4, 4);
  if (c.P1.empty() != c.P2.empty()) errors.missing(c.P1.empty() ? "P1" : "P2", "P1 and P2 come together");

  // Whether the images this file is for must be rectified: yes when it holds the raw cameras,
  // unless it says `rectified: 1` (the images were rectified with it already).
  const std::optional<int> rectified = file.integer("rectified");
  if (rectified && *rectified > 1) errors.malformed("rectified", "must be 0 or 1");
  if (rectified && *rectified == 0 && !has_intrinsics)
    errors.malformed("rectified", "is 0 but there are no K1, D1, K2, D2 to rectify with");
  c.needs_rectification = has_intrinsics && rectified.value_or(0) == 0;

  if (c.P1.empty() && has_intrinsics && !c.R.empty() && !c.T.empty()) {
    // The raw rig only: rectify it as OpenCV does (alpha 0: only valid pixels; zero disparity at infinity).
    if (c.width == 0) errors.missing(width_key, "rectifying K1, D1, K2, D2, R, T needs the image size");
    cv::Mat R1, R2, P1, P2, Q;
    try {
      cv::stereoRectify(c.K1, c.D1, c.K2, c.D2, cv::Size(c.width, c.height), c.R, c.T, R1, R2, P1, P2, Q,
                        cv::CALIB_ZERO_DISPARITY, 0.0);
    } catch (const cv::Exception& e) {
      errors.fail("cannot rectify K1, D1, K2, D2, R, T: " + trimmed(e.err));
    }
    for (cv::Mat* m : {&R1, &R2, &P1, &P2, &Q}) m->convertTo(*m, CV_64F);
    if (c.R1.empty()) c.R1 = R1;
    if (c.R2.empty()) c.R2 = R2;
    c.P1 = P1;
    c.P2 = P2;
    if (c.Q.empty()) c.Q = Q;
  } else if (has_intrinsics && (c.R.empty() != c.T.empty())) {
    errors.missing(c.R.empty() ? "R" : "T", "R and T come together");
  }

  if (!c.P1.empty() || !c.Q.empty()) {
    c.geometry = geometry_of(c.P1, c.P2, c.Q, errors);
  } else {
    errors.missing("P1", "the file needs P1 and P2, or Q, or K1, D1, K2, D2, R and T");
  }
  c.geometry.units = file.text("units").value_or("m");
  if (trimmed(c.geometry.units).empty()) errors.malformed("units", "is empty");
  try {
    (void)millimetres_per_unit(c.geometry.units);  // as the flag --units: a unit depth can be given in
  } catch (const UsageError&) {
    errors.malformed("units", "is '" + c.geometry.units + "', an unknown unit (known: m, cm, mm, in, ft)");
  }

  if (c.needs_rectification) {
    // Remapping needs each camera's rotation and projection and the size the maps are made for.
    if (c.R1.empty()) errors.missing("R1", "rectifying needs R1, R2, P1 and P2");
    if (c.R2.empty()) errors.missing("R2", "rectifying needs R1, R2, P1 and P2");
    if (c.P1.empty()) errors.missing("P1", "rectifying needs R1, R2, P1 and P2");
    if (c.width == 0) errors.missing(width_key, "rectifying needs the image size");
  }
  return c;
}

// A line "cam0=...", "cam1=...", "baseline=..." or "doffs=..." makes a file a calib.txt.
bool looks_like_middlebury(const std::string& text) {
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    const std::size_t eq = line.find('=');
    if (eq == std::string::npos) continue;
    const std::string key = trimmed(line.substr(0, eq));
    if (key == "cam0" || key == "cam1" || key == "baseline" || key == "doffs") return true;
  }
  return false;
}

bool looks_like_storage(const std::string& path, const std::string& text) {
  const std::string ext = lower(fs::path(path).extension().string());
  if (ext == ".yml" || ext == ".yaml" || ext == ".xml" || ext == ".json") return true;
  const std::string start = trimmed(text).substr(0, 5);
  return start == "%YAML" || start == "<?xml" || start.rfind('{', 0) == 0;
}

}  // namespace

Calibration read_calibration(const std::string& path, int image_width, int image_height) {
  return read_calibration(std::vector<std::string>{path}, image_width, image_height);
}

Calibration read_calibration(const std::vector<std::string>& paths, int image_width, int image_height) {
  if (paths.empty()) throw std::invalid_argument("read_calibration: no file");
  if ((image_width > 0) != (image_height > 0))
    throw std::invalid_argument("read_calibration: give both image_width and image_height, or neither");
  for (const std::string& path : paths) {
    const std::string text = read_text(path);
    if (looks_like_middlebury(text)) {
      if (paths.size() == 1) return read_middlebury(path, text, image_width, image_height);
      throw RuntimeError("calibration " + in_quotes(path) +
                         ": a Middlebury calib.txt holds a whole calibration: only OpenCV FileStorage files "
                         "(intrinsics and extrinsics) are read together");
    }
    if (!looks_like_storage(path, text))
      throw RuntimeError("calibration " + in_quotes(path) +
                         ": unknown format: expected a Middlebury calib.txt (cam0=[...], baseline=...) or an OpenCV "
                         "FileStorage file (.yml, .yaml, .xml, .json)");
    check_storage_text(path, text);
    check_storage_nesting(path, text);
    check_storage_parses(path);
  }
  return read_storage(paths, image_width, image_height);
}

void write_calibration(const std::string& path, const Calibration& calibration) {
  calibration.geometry.validate();
  cv::FileStorage file;
  try {
    file.open(path, cv::FileStorage::WRITE | cv::FileStorage::FORMAT_YAML);
  } catch (const cv::Exception& e) {
    throw RuntimeError("cannot write calibration " + in_quotes(path) + ": " + trimmed(e.err));
  }
  if (!file.isOpened()) throw RuntimeError("cannot write calibration " + in_quotes(path));
  if (calibration.width > 0) {
    file << "image_width" << calibration.width;
    file << "image_height" << calibration.height;
  }
  file << "units" << calibration.geometry.units;
  if (calibration.ndisp > 0) file << "ndisp" << calibration.ndisp;
  const bool has_intrinsics = !calibration.K1.empty();
  if (has_intrinsics) file << "rectified" << (calibration.needs_rectification ? 0 : 1);
  const std::pair<const char*, const cv::Mat*> raw[] = {{"K1", &calibration.K1}, {"D1", &calibration.D1},
                                                        {"K2", &calibration.K2}, {"D2", &calibration.D2},
                                                        {"R", &calibration.R},   {"T", &calibration.T},
                                                        {"R1", &calibration.R1}, {"R2", &calibration.R2}};
  for (const auto& [key, m] : raw)
    if (!m->empty()) file << key << *m;
  // The projections are written from the geometry, so flags that changed it are kept.
  cv::Mat P1, P2, Q;
  projections_of(calibration.geometry, P1, P2, Q);
  file << "P1" << P1 << "P2" << P2 << "Q" << Q;
  file.release();
}

void check_calibration_fits(const Calibration& calibration, int width, int height, const std::string& image) {
  if (calibration.width == 0 && calibration.height == 0) return;  // size unknown: flags only
  if (calibration.width == width && calibration.height == height) return;
  throw RuntimeError("calibration " + in_quotes(calibration.source) + " is for " +
                     size_text(calibration.width, calibration.height) + " images but " + image + " is " +
                     size_text(width, height) +
                     ": use the calibration of that size (scaling an image scales focal, cx, cy and doffs)");
}

std::string number_problem(const std::string& text, double& value) {
  const std::string t = trimmed(text);
  char* end = nullptr;
  errno = 0;
  value = t.empty() ? 0.0 : std::strtod(t.c_str(), &end);
  if (t.empty() || end != t.c_str() + t.size() || std::isnan(value)) return "is not a number";
  if (std::isinf(value) || (errno == ERANGE && std::abs(value) > 1.0)) return "is too large";
  // strtod flushes what lies below the smallest normal double towards 0, with ERANGE.
  if (errno == ERANGE) return "is too small (below " + number_text(std::numeric_limits<double>::min()) + ")";
  return "";
}

const CLI::Validator& positive_number() {
  static const CLI::Validator validator(
      [](std::string& text) -> std::string {
        double v = 0.0;
        const std::string problem = number_problem(text, v);
        if (!problem.empty() && problem != "is not a number") return "'" + text + "' " + problem;
        return problem.empty() && v > 0.0 ? "" : "must be a positive number, not '" + text + "'";
      },
      "POSITIVE");
  return validator;
}

void CalibrationFlags::add_to(CLI::App& app) {
  app.add_option("--calib", files_,
                 "stereo calibration: Middlebury calib.txt, or OpenCV YAML/XML/JSON with P1 P2, Q, or K1 (M1) D1 K2 (M2) "
                 "D2 R T; twice for OpenCV's intrinsics and extrinsics files (read as one); the image size, when the "
                 "file has none, is the pair's")
      ->allow_extra_args(false);
  app.add_option("--focal", focal_, "focal length in pixels of the images as given (overrides --calib)")
      ->check(positive_number());
  app.add_option("--baseline", baseline_, "distance between the camera centres, in --units (overrides --calib)")
      ->check(positive_number());
  app.add_option("--cx", cx_, "principal point x of the left rectified camera, pixels (default (width - 1) / 2)");
  app.add_option("--cy", cy_, "principal point y, pixels (default (height - 1) / 2)");
  app.add_option("--doffs", doffs_, "x of the right principal point minus x of the left, pixels (default 0)");
  app.add_option("--units", units_,
                 "unit of --baseline and so of depth and X, Y, Z: m, cm, mm, in, ft (default m, or the file's unit; "
                 "with --calib and no --baseline the file's baseline is converted)");
}

bool CalibrationFlags::given() const {
  return !files_.empty() || focal_ || baseline_ || cx_ || cy_ || doffs_ || !units_.empty();
}

std::optional<Calibration> CalibrationFlags::resolve(int width, int height, const std::string& image) const {
  if (!given()) return std::nullopt;
  if (!units_.empty()) (void)millimetres_per_unit(units_);  // UsageError naming an unknown unit
  Calibration c;
  if (!files_.empty()) {
    c = read_calibration(files_, width, height);
    check_calibration_fits(c, width, height, image);
    if (!baseline_ && !units_.empty() && lower(units_) != lower(c.geometry.units)) {
      // Converting needs the file's unit to be one we know.
      try {
        c.geometry.baseline *= millimetres_per_unit(c.geometry.units) / millimetres_per_unit(units_);
      } catch (const UsageError&) {
        throw RuntimeError("calibration " + in_quotes(c.source) + ": key 'units': '" + c.geometry.units +
                           "' cannot be converted to --units " + units_ + " (known: m, cm, mm, in, ft)");
      }
      c.geometry.units = units_;
    }
  } else {
    if (!focal_ || !baseline_) {
      const std::string missing = !focal_ && !baseline_ ? "--focal and --baseline are"
                                  : !focal_             ? "--focal is"
                                                        : "--baseline is";
      throw UsageError("incomplete calibration: " + missing +
                       " missing (without --calib, a calibration needs --focal and --baseline)");
    }
    c.source = "flags";
    c.geometry.cx = (width - 1) / 2.0;
    c.geometry.cy = (height - 1) / 2.0;
    c.geometry.units = "m";
  }
  if (focal_) c.geometry.focal = *focal_;
  if (baseline_) c.geometry.baseline = *baseline_;
  if (baseline_ && !units_.empty()) c.geometry.units = units_;
  if (cx_) c.geometry.cx = *cx_;
  if (cy_) c.geometry.cy = *cy_;
  if (doffs_) c.geometry.doffs = *doffs_;
  const std::string problem =
      geometry_range_problem(c.geometry, focal_ ? "--focal" : "focal", baseline_ ? "--baseline" : "baseline");
  if (!problem.empty())
    throw UsageError(std::string("calibration ") + (files_.empty() ? "flags" : in_quotes(c.source)) + ": " + problem);
  return c;
}

}  // namespace mctstereo::app
