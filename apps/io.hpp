// Reading the input images and encoding disparity maps into files (PFM, 16-bit PNG, preview).
#pragma once

#include <opencv2/core.hpp>

#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "mctstereo/mctstereo.hpp"

namespace mctstereo::app {

/// Reads an image (PNG, PPM, PGM, JPEG, BMP, TIFF or WebP, told by its first bytes) as the matcher takes it:
/// 8-bit gray or 8-bit BGR; an alpha channel is dropped. `role` names the image in messages
/// ("left image"). RuntimeError when the file is missing, a folder, unreadable, not an image, or
/// has samples that are not 8-bit.
cv::Mat read_input_image(const std::string& path, std::string_view role);

/// Reads an image as 8-bit gray (colour converted, a palette expanded to its grey values), for
/// ground truth and masks. RuntimeError as read_input_image.
cv::Mat read_gray_image(const std::string& path, std::string_view role);

/// Sends stderr to /dev/null while it lives. Decoders (libpng, FFmpeg) print their own complaints
/// there before OpenCV returns an empty result; the program's one-line error says the same. Only
/// for a moment when no other thread writes to stderr.
class StderrSilenced {
 public:
  StderrSilenced();
  ~StderrSilenced();
  StderrSilenced(const StderrSilenced&) = delete;
  StderrSilenced& operator=(const StderrSilenced&) = delete;

 private:
  int saved_;
};

/// A view of an 8-bit gray or BGR matrix (as returned by read_input_image).
ImageView image_view(const cv::Mat& image);

/// How a disparity map is stored in a file.
enum class DisparityFormat {
  Pfm,    ///< 32-bit float pixels, +INF = invalid, rows bottom to top, little-endian.
  Kitti,  ///< 16-bit PNG, value = 256 x d, 0 = invalid (so d = 0 reads as invalid, as in KITTI).
  Q4,     ///< 16-bit PNG, value = 16 x (d - min_disparity + 1), 0 = invalid; negative d allowed.
};

std::string_view to_string(DisparityFormat format);

/// The format of a disparity file. Without --format (`format_flag` empty) the extension decides:
/// .pfm is pfm, .png is kitti. A --format ("pfm", "kitti", "q4") must agree with a .pfm or .png
/// extension and is taken as it is for any other. UsageError otherwise, naming the file.
DisparityFormat disparity_format_for(const std::string& path, const std::string& format_flag);

/// UsageError when the disparity range of `params` cannot be written in `format`: KITTI holds
/// 256 x d in 16 bits, so 0 <= d <= 255.
void check_format_range(DisparityFormat format, const StereoParams& params, const std::string& path);

/// One sentence telling how to read the values of a file of `format` back into pixels.
std::string describe_format(DisparityFormat format, int min_disparity);

// PFM files: encode_pfm, kPfmNone and decode_pfm are the library's (mctstereo/pfm.hpp).

/// The bytes of a disparity file. `q4` holds 16 x d, with `invalid_q4` where there is no disparity.
std::vector<std::uint8_t> encode_disparity(MapView<const std::int16_t> q4, std::int16_t invalid_q4,
                                           int min_disparity, DisparityFormat format);

/// The extension of `path` in lower case, with its dot (".png"); "" without one.
std::string lower_extension(const std::string& path);

/// The bytes of a confidence map (values in [0, 1]): `.pfm` as float, `.png` as 8-bit gray
/// round(255 c). UsageError naming the path for another extension.
std::vector<std::uint8_t> encode_confidence(MapView<const float> confidence, const std::string& path);
/// UsageError unless `path` ends in .pfm or .png (the encodings of encode_confidence).
void check_confidence_path(const std::string& path);

/// UsageError when OpenCV cannot write an image with the extension of `path`.
void check_preview_path(const std::string& path);

/// The colour preview as an 8-bit BGR image of the map's size: the turbo colormap over the fixed
/// range [dmin, dmax], invalid pixels black. `colour` is reused while the size stays.
void render_preview(MapView<const std::int16_t> q4, std::int16_t invalid_q4, int dmin, int dmax, cv::Mat& colour);

/// The bytes of a colour preview (render_preview): the turbo colormap over the fixed range [dmin, dmax] (so maps of
/// one range compare by colour), invalid pixels black. Encoded as the extension of `path` says.
std::vector<std::uint8_t> encode_preview(MapView<const std::int16_t> q4, std::int16_t invalid_q4, int dmin,
                                         int dmax, const std::string& path);

}  // namespace mctstereo::app
