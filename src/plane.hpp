// Internal owning 2-D buffers. Rows are 64-byte aligned and padded so that SIMD code may read and
// write whole vectors past the last pixel of a row without leaving the allocation.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <new>

namespace mctstereo::detail {

inline constexpr std::size_t kAlignment = 64;

struct FreeDeleter {
  void operator()(void* p) const { std::free(p); }
};

template <typename T>
std::unique_ptr<T[], FreeDeleter> allocate_aligned(std::size_t count) {
  std::size_t bytes = (count * sizeof(T) + kAlignment - 1) / kAlignment * kAlignment;
  if (bytes == 0) bytes = kAlignment;
  void* p = std::aligned_alloc(kAlignment, bytes);
  if (!p) throw std::bad_alloc();
  std::fill_n(static_cast<unsigned char*>(p), bytes, 0);
  return std::unique_ptr<T[], FreeDeleter>(static_cast<T*>(p));
}

/// A W x H plane of T. `pad` columns on both sides of every row (x in [-pad, width + pad)) are
/// addressable; stride (elements) is a multiple of 64 bytes with at least 64 bytes of slack.
template <typename T>
class Plane {
 public:
  Plane() = default;
  Plane(int width, int height, int pad = 0) { reset(width, height, pad); }

  void reset(int width, int height, int pad = 0) {
    width_ = width;
    height_ = height;
    pad_ = pad;
    stride_ = stride_for(width, pad);
    data_ = allocate_aligned<T>(static_cast<std::size_t>(stride_) * std::max(height, 1));
  }

  /// The stride of a row of `width` pixels and `pad` columns each side: rounded up to whole
  /// 64-byte lines, with at least one line of slack.
  static std::ptrdiff_t stride_for(int width, int pad) {
    const std::size_t per_line = kAlignment / sizeof(T);
    const std::size_t need = static_cast<std::size_t>(width + 2 * pad) + per_line;  // + slack
    return static_cast<std::ptrdiff_t>((need + per_line - 1) / per_line * per_line);
  }
  /// Bytes that reset(width, height, pad) allocates.
  static std::size_t bytes_for(int width, int height, int pad = 0) {
    return static_cast<std::size_t>(stride_for(width, pad)) * std::max(height, 1) * sizeof(T);
  }

  int width() const { return width_; }
  int height() const { return height_; }
  int pad() const { return pad_; }
  std::ptrdiff_t stride() const { return stride_; }
  bool empty() const { return width_ == 0 || height_ == 0; }
  std::size_t bytes() const { return static_cast<std::size_t>(stride_) * height_ * sizeof(T); }

  /// Pointer to pixel x = 0 of row y (pad columns lie before it).
  T* row(int y) { return data_.get() + y * stride_ + pad_; }
  const T* row(int y) const { return data_.get() + y * stride_ + pad_; }
  T& at(int x, int y) { return row(y)[x]; }
  const T& at(int x, int y) const { return row(y)[x]; }

  /// Repeats the first and last pixel of every row into the pad columns.
  void replicate_pad() {
    for (int y = 0; y < height_; ++y) {
      T* r = row(y);
      for (int i = 1; i <= pad_; ++i) {
        r[-i] = r[0];
        r[width_ - 1 + i] = r[width_ - 1];
      }
    }
  }

 private:
  int width_ = 0, height_ = 0, pad_ = 0;
  std::ptrdiff_t stride_ = 0;
  std::unique_ptr<T[], FreeDeleter> data_;
};

inline int clamp_index(int v, int n) { return v < 0 ? 0 : (v >= n ? n - 1 : v); }

/// out[i] = row[clamp_index(start + i, w)] for i < count: the in-range part in one copy, the
/// clamped ends filled with the edge values (an index clamped per entry made the border vectors
/// of the SIMD filters cost several interior ones).
template <typename T>
void copy_clamped(const T* row, int w, int start, int count, T* out) {
  int i = 0;
  for (; i < count && start + i < 0; ++i) out[i] = row[0];
  const int inside_end = std::min(count, w - start);
  if (inside_end > i) {
    std::memcpy(out + i, row + start + i, sizeof(T) * static_cast<std::size_t>(inside_end - i));
    i = inside_end;
  }
  for (; i < count; ++i) out[i] = row[w - 1];
}

}  // namespace mctstereo::detail
