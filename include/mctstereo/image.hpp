// mctstereo: non-owning image views with a row stride.
#pragma once

#include <cstddef>
#include <cstdint>

namespace mctstereo {

/// Layout of the bytes of one input pixel.
enum class PixelFormat {
  Gray8,  ///< one byte per pixel
  Rgb8,   ///< three bytes per pixel, R G B
  Bgr8,   ///< three bytes per pixel, B G R (OpenCV's order)
};

/// Bytes per pixel of a format.
constexpr int bytes_per_pixel(PixelFormat f) { return f == PixelFormat::Gray8 ? 1 : 3; }

/// A read-only 8-bit image: the caller owns the pixels, which must outlive the call they are passed
/// to. `stride` is the distance in bytes from the start of one row to the next
/// (at least width * bytes_per_pixel(format)).
struct ImageView {
  const std::uint8_t* data = nullptr;
  int width = 0;
  int height = 0;
  std::ptrdiff_t stride = 0;
  PixelFormat format = PixelFormat::Gray8;

  const std::uint8_t* row(int y) const { return data + y * stride; }
};

/// A 2-D view of typed values (a disparity map, say) with a stride counted in elements.
template <typename T>
struct MapView {
  T* data = nullptr;
  int width = 0;
  int height = 0;
  std::ptrdiff_t stride = 0;  ///< elements from the start of one row to the next

  T* row(int y) const { return data + y * stride; }
  T& at(int x, int y) const { return data[y * stride + x]; }
};

}  // namespace mctstereo
