#include "io.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <optional>

#include "errors.hpp"
#include "input_files.hpp"
#include "output_files.hpp"

namespace mctstereo::app {

namespace fs = std::filesystem;

std::string lower_extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext;
}

namespace {

std::vector<std::uint8_t> read_bytes(const std::string& path, std::string_view role) {
  const std::string text = read_input_file(path, role);
  if (text.empty())
    throw RuntimeError("cannot read " + std::string(role) + " " + in_quotes(path) + ": the file is empty");
  return {text.begin(), text.end()};
}

// The container a file claims to be, from its first bytes; empty when none of ours.
std::string signature_name(const std::vector<std::uint8_t>& b) {
  if (b.size() >= 8 && b[0] == 0x89 && b[1] == 'P' && b[2] == 'N' && b[3] == 'G') return "PNG";
  if (b.size() >= 3 && b[0] == 0xFF && b[1] == 0xD8 && b[2] == 0xFF) return "JPEG";
  if (b.size() >= 2 && b[0] == 'P' && b[1] >= '1' && b[1] <= '6') return b[1] == '2' || b[1] == '5' ? "PGM" : "PPM";
  if (b.size() >= 2 && b[0] == 'B' && b[1] == 'M') return "BMP";
  if (b.size() >= 4 && ((b[0] == 'I' && b[1] == 'I' && b[2] == 42 && b[3] == 0) ||
                        (b[0] == 'M' && b[1] == 'M' && b[2] == 0 && b[3] == 42)))
    return "TIFF";
  if (b.size() >= 12 && std::equal(b.begin(), b.begin() + 4, "RIFF") && std::equal(b.begin() + 8, b.begin() + 12, "WEBP"))
    return "WebP";
  return "";
}

// The largest image read: the matcher's limit, which is also OpenCV's 2^30 pixels.
constexpr long kMaxImageSide = 32768;

struct DeclaredSize {
  long width = 0, height = 0;  // saturated at kMaxImageSide + 1
  std::string text;            // "WIDTHxHEIGHT" as the header writes it
};

DeclaredSize declared(std::uint32_t width, std::uint32_t height) {
  return {std::min<long>(width, kMaxImageSide + 1), std::min<long>(height, kMaxImageSide + 1),
          std::to_string(width) + "x" + std::to_string(height)};
}

std::uint32_t big_endian(const std::vector<std::uint8_t>& b, std::size_t at, int bytes) {
  std::uint32_t v = 0;
  for (int i = 0; i < bytes; ++i) v = v << 8 | b[at + i];
  return v;
}

// The size a PNG, PNM or JPEG header declares, read before decoding: OpenCV refuses an image beyond
// its limits as if it were damaged. Nullopt when the header says nothing readable.
std::optional<DeclaredSize> declared_size(const std::vector<std::uint8_t>& b) {
  const std::string kind = signature_name(b);
  if (kind == "PNG" && b.size() >= 24) return declared(big_endian(b, 16, 4), big_endian(b, 20, 4));
  if (kind == "PGM" || kind == "PPM") {
    std::size_t at = 2;
    DeclaredSize size;
    for (long* n : {&size.width, &size.height}) {
      while (at < b.size() && (std::isspace(b[at]) || b[at] == '#')) {  // white space and comments
        if (b[at] == '#')
          while (at < b.size() && b[at] != '\n') ++at;
        else
          ++at;
      }
      if (at >= b.size() || !std::isdigit(b[at])) return std::nullopt;
      if (!size.text.empty()) size.text += 'x';
      for (; at < b.size() && std::isdigit(b[at]); ++at) {
        *n = std::min(*n * 10 + (b[at] - '0'), kMaxImageSide + 1);
        size.text += static_cast<char>(b[at]);
      }
    }
    return size;
  }
  if (kind == "JPEG") {
    // Segments from the start of the file up to the frame header (SOFn: not DHT, JPG or DAC).
    for (std::size_t at = 2; at + 9 <= b.size() && b[at] == 0xFF;) {
      const std::uint8_t marker = b[at + 1];
      if (marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC)
        return declared(big_endian(b, at + 7, 2), big_endian(b, at + 5, 2));
      at += 2 + big_endian(b, at + 2, 2);
    }
  }
  return std::nullopt;
}

void check_declared_size(const std::vector<std::uint8_t>& bytes, const std::string& path, std::string_view role) {
  const std::optional<DeclaredSize> size = declared_size(bytes);
  if (size && (size->width > kMaxImageSide || size->height > kMaxImageSide))
    throw RuntimeError(std::string(role) + " " + in_quotes(path) + " is " + size->text + ": too large (at most " +
                       std::to_string(kMaxImageSide) + " x " + std::to_string(kMaxImageSide) + " pixels)");
}

cv::Mat decode(const std::vector<std::uint8_t>& bytes, int flags, const std::string& path, std::string_view role) {
  // Only the formats named here reach OpenCV: its other decoders (DICOM through GDCM, say) abort
  // the process on some damaged files (found by fuzz/fuzz_image.cpp). OpenCV asks its DICOM decoder
  // before its PNM one, and DICOM's mark lies at byte 128, so a PGM that also carries it is refused.
  const bool dicom = bytes.size() >= 132 && std::equal(bytes.begin() + 128, bytes.begin() + 132, "DICM");
  if (signature_name(bytes).empty() || dicom)
    throw RuntimeError("cannot decode " + std::string(role) + " " + in_quotes(path) +
                       ": not a PNG, PPM, PGM, JPEG, BMP, TIFF or WebP image");
  check_declared_size(bytes, path, role);
  cv::Mat image;
  try {
    StderrSilenced quiet;
    image = cv::imdecode(bytes, flags);
  } catch (const cv::Exception&) {
    image.release();
  }
  if (image.empty()) {
    const std::string claimed = signature_name(bytes);
    throw RuntimeError("cannot decode " + std::string(role) + " " + in_quotes(path) + ": damaged or truncated " +
                       claimed + " file");
  }
  return image;
}

std::string depth_name(int depth) {
  switch (depth) {
    case CV_8S: return "8-bit signed";
    case CV_16U: return "16-bit";
    case CV_16S: return "16-bit signed";
    case CV_32S: return "32-bit integer";
    case CV_32F: return "32-bit float";
    case CV_64F: return "64-bit float";
    default: return "non-8-bit";
  }
}

}  // namespace

cv::Mat read_input_image(const std::string& path, std::string_view role) {
  // Reading the bytes first rather than cv::imread keeps "missing" and "not an image" apart.
  const cv::Mat decoded = decode(read_bytes(path, role), cv::IMREAD_UNCHANGED, path, role);
  if (decoded.depth() != CV_8U)
    throw RuntimeError(std::string(role) + " " + in_quotes(path) + " has " + depth_name(decoded.depth()) +
                       " samples; only 8-bit images are matched (convert it to 8 bits per channel)");
  cv::Mat image;
  switch (decoded.channels()) {
    case 1: image = decoded; break;
    case 2: cv::extractChannel(decoded, image, 0); break;  // gray + alpha
    case 3: image = decoded; break;
    case 4: cv::cvtColor(decoded, image, cv::COLOR_BGRA2BGR); break;
    default:
      throw RuntimeError(std::string(role) + " " + in_quotes(path) + " has " + std::to_string(decoded.channels()) +
                         " channels; expected gray, BGR or BGRA");
  }
  return image;
}

cv::Mat read_gray_image(const std::string& path, std::string_view role) {
  return decode(read_bytes(path, role), cv::IMREAD_GRAYSCALE, path, role);
}

StderrSilenced::StderrSilenced() : saved_(::dup(STDERR_FILENO)) {
  const int null = ::open("/dev/null", O_WRONLY | O_CLOEXEC);
  if (saved_ >= 0 && null >= 0) ::dup2(null, STDERR_FILENO);
  if (null >= 0) ::close(null);
}

StderrSilenced::~StderrSilenced() {
  if (saved_ < 0) return;
  ::dup2(saved_, STDERR_FILENO);
  ::close(saved_);
}

ImageView image_view(const cv::Mat& image) {
  ImageView view;
  view.data = image.data;
  view.width = image.cols;
  view.height = image.rows;
  view.stride = static_cast<std::ptrdiff_t>(image.step[0]);
  view.format = image.channels() == 1 ? PixelFormat::Gray8 : PixelFormat::Bgr8;
  return view;
}

std::string_view to_string(DisparityFormat format) {
  switch (format) {
    case DisparityFormat::Pfm: return "pfm";
    case DisparityFormat::Kitti: return "kitti";
    case DisparityFormat::Q4: return "q4";
  }
  return "?";
}

DisparityFormat disparity_format_for(const std::string& path, const std::string& format_flag) {
  const std::string ext = lower_extension(path);
  const bool known_extension = ext == ".pfm" || ext == ".png";
  if (format_flag.empty()) {
    if (!known_extension)
      throw UsageError("cannot tell the disparity format of " + in_quotes(path) +
                       ": name it .pfm (float) or .png (16-bit KITTI or Q4), or give --format");
    return ext == ".pfm" ? DisparityFormat::Pfm : DisparityFormat::Kitti;
  }
  const DisparityFormat format = format_flag == "pfm"   ? DisparityFormat::Pfm
                                 : format_flag == "q4"  ? DisparityFormat::Q4
                                 : format_flag == "kitti" ? DisparityFormat::Kitti
                                                          : throw UsageError("--format: unknown format '" + format_flag +
                                                                             "' (known: kitti, q4, pfm)");
  if (known_extension && (format == DisparityFormat::Pfm) != (ext == ".pfm"))
    throw UsageError("--format " + format_flag + " writes " + (format == DisparityFormat::Pfm ? "PFM" : "PNG") +
                     " but " + in_quotes(path) + " ends in " + ext);
  return format;
}

void check_format_range(DisparityFormat format, const StereoParams& params, const std::string& path) {
  if (format != DisparityFormat::Kitti) return;
  if (params.min_disparity < 0)
    throw UsageError("KITTI PNG " + in_quotes(path) + " cannot hold negative disparities (min_disparity = " +
                     std::to_string(params.min_disparity) + "): use --format q4 or a .pfm file");
  if (params.max_disparity() > 255)
    throw UsageError("KITTI PNG " + in_quotes(path) + " holds 256 x d in 16 bits, so d <= 255, but the range reaches " +
                     std::to_string(params.max_disparity()) + ": use --format q4 or a .pfm file");
}

std::string describe_format(DisparityFormat format, int min_disparity) {
  switch (format) {
    case DisparityFormat::Pfm: return "PFM float, pixels, +INF = invalid";
    case DisparityFormat::Kitti: return "16-bit PNG KITTI, d = value / 256, 0 = invalid";
    case DisparityFormat::Q4: {
      const int offset = min_disparity - 1;
      const std::string tail =
          offset == 0 ? "" : (offset > 0 ? " + " : " - ") + std::to_string(std::abs(offset));
      return "16-bit PNG Q4, d = value / 16" + tail + ", 0 = invalid";
    }
  }
  return "?";
}

std::vector<std::uint8_t> encode_disparity(MapView<const std::int16_t> q4, std::int16_t invalid_q4,
                                           int min_disparity, DisparityFormat format) {
  const int w = q4.width, h = q4.height;
  if (format == DisparityFormat::Pfm) {
    std::vector<float> values(static_cast<std::size_t>(w) * h);
    for (int y = 0; y < h; ++y) {
      const std::int16_t* row = q4.row(y);
      for (int x = 0; x < w; ++x)
        values[static_cast<std::size_t>(y) * w + x] =
            row[x] == invalid_q4 ? kPfmNone : static_cast<float>(row[x]) / kDisparityScale;
    }
    return encode_pfm(MapView<const float>{values.data(), w, h, w});
  }
  cv::Mat png(h, w, CV_16UC1);
  // Q4 stores 16 x d; shifting by min_disparity - 1 makes every valid value at least 16, so 0 is
  // free for invalid pixels and negative disparities fit.
  const int q4_offset = 16 * (min_disparity - 1);
  for (int y = 0; y < h; ++y) {
    const std::int16_t* src = q4.row(y);
    std::uint16_t* dst = png.ptr<std::uint16_t>(y);
    for (int x = 0; x < w; ++x) {
      if (src[x] == invalid_q4) {
        dst[x] = 0;
      } else if (format == DisparityFormat::Kitti) {
        dst[x] = static_cast<std::uint16_t>(std::clamp(16 * src[x], 0, 65535));  // 256 x d = 16 x (16 x d)
      } else {
        dst[x] = static_cast<std::uint16_t>(std::clamp(src[x] - q4_offset, 1, 65535));
      }
    }
  }
  std::vector<std::uint8_t> bytes;
  if (!cv::imencode(".png", png, bytes)) throw RuntimeError("cannot encode a 16-bit PNG");
  return bytes;
}

void check_preview_path(const std::string& path) {
  if (!cv::haveImageWriter(path))
    throw UsageError("--color " + in_quotes(path) + ": cannot write an image with this extension (use .png)");
}

void render_preview(MapView<const std::int16_t> q4, std::int16_t invalid_q4, int dmin, int dmax, cv::Mat& colour) {
  const int w = q4.width, h = q4.height;
  cv::Mat level(h, w, CV_8UC1), invalid(h, w, CV_8UC1);
  const double lo = 16.0 * dmin, span = 16.0 * std::max(dmax - dmin, 1);
  for (int y = 0; y < h; ++y) {
    const std::int16_t* src = q4.row(y);
    std::uint8_t* dst = level.ptr<std::uint8_t>(y);
    std::uint8_t* bad = invalid.ptr<std::uint8_t>(y);
    for (int x = 0; x < w; ++x) {
      bad[x] = src[x] == invalid_q4 ? 255 : 0;
      dst[x] = static_cast<std::uint8_t>(std::clamp(std::lround(255.0 * (src[x] - lo) / span), 0L, 255L));
    }
  }
  cv::applyColorMap(level, colour, cv::COLORMAP_TURBO);
  colour.setTo(cv::Scalar::all(0), invalid);
}

std::vector<std::uint8_t> encode_preview(MapView<const std::int16_t> q4, std::int16_t invalid_q4, int dmin,
                                         int dmax, const std::string& path) {
  cv::Mat colour;
  render_preview(q4, invalid_q4, dmin, dmax, colour);
  std::vector<std::uint8_t> bytes;
  if (!cv::imencode(fs::path(path).extension().string(), colour, bytes))
    throw RuntimeError("cannot encode the preview " + in_quotes(path));
  return bytes;
}

void check_confidence_path(const std::string& path) {
  const std::string ext = lower_extension(path);
  if (ext != ".pfm" && ext != ".png")
    throw UsageError("--confidence " + in_quotes(path) + ": unknown extension '" + fs::path(path).extension().string() +
                     "': use .pfm (float, 0 to 1) or .png (8-bit, 0 to 255)");
}

std::vector<std::uint8_t> encode_confidence(MapView<const float> confidence, const std::string& path) {
  check_confidence_path(path);
  if (lower_extension(path) == ".pfm") return encode_pfm(confidence);
  cv::Mat gray(confidence.height, confidence.width, CV_8UC1);
  for (int y = 0; y < confidence.height; ++y)
    for (int x = 0; x < confidence.width; ++x)
      gray.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(std::lround(255.0f * confidence.at(x, y)));
  std::vector<std::uint8_t> bytes;
  if (!cv::imencode(".png", gray, bytes)) throw RuntimeError("cannot encode the confidence map as PNG");
  return bytes;
}

}  // namespace mctstereo::app
