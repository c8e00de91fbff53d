// Speckle removal by connected-component labelling over horizontal runs, driven by bit masks.
//
// The reference's flood fill visits every pixel through a queue. Here SIMD compares turn every row
// into three bit masks (valid, connected to the left neighbour, connected to the pixel above);
// runs of horizontally connected pixels and the links between runs of adjacent rows are then read
// off the masks with bit scans and joined with a union-find, and a second pass erases the runs of
// small components. The result depends only on the components, so it equals the reference's.
// Threads label bands of rows separately; one thread then joins the links across band borders.
//
// Scratch use:
// - scratch.label, row y: the masks of row y as uint32 words (bit x % 32 of word x / 32), three
//   arrays of ceil(W / 32) words (speckle_label_width(): a twelfth of the reference's labels).
// - scratch.stack: the union-find forest, one entry per pixel index y W + x, of which only the
//   first pixel of each run (its head) is used. A root holds -(size of its component); any other
//   head holds the index of another head of the same component.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cpu/speckle.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>

#include <omp.h>

#include "cpu/mask_bits-inl.h"
#include "cpu/parallel.hpp"
#include "stages.hpp"

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// Mask words are 32 bits wide, so vectors hold at most 32 lanes and each fills part of one word.
using D16 = MaskTag16;

// Lanes where |a - b| <= max_diff. max(a, b) - min(a, b) wraps in int16 but is exact as uint16.
HWY_INLINE hn::Mask<D16> Close(hn::Vec<D16> a, hn::Vec<D16> b, hn::Vec<hn::RebindToUnsigned<D16>> max_diff) {
  const hn::RebindToUnsigned<D16> du;
  const auto diff = hn::BitCast(du, hn::Sub(hn::Max(a, b), hn::Min(a, b)));
  return hn::RebindMask(D16(), hn::Eq(hn::SaturatedSub(diff, max_diff), hn::Zero(du)));
}

// Writes the three masks of rows [y0, y1) into the label plane (see the top of the file).
// Requires max_diff >= 0.
void RowMasks(const Plane<std::int16_t>& disparity, int max_diff, int y0, int y1, Plane<std::int32_t>& label) {
  const D16 d;
  const hn::RebindToUnsigned<D16> du;
  const int w = disparity.width(), words = (w + 31) / 32;
  const int n = static_cast<int>(hn::Lanes(d));
  const auto invalid = hn::Set(d, kInvalid);
  const auto diff_limit = hn::Set(du, static_cast<std::uint16_t>(std::min(max_diff, 65535)));

  for (int y = y0; y < y1; ++y) {
    std::uint32_t* valid = reinterpret_cast<std::uint32_t*>(label.row(y));
    std::uint32_t* left = valid + words;
    std::uint32_t* up = valid + 2 * words;
    std::fill(valid, valid + 3 * words, 0u);
    const std::int16_t* row = disparity.row(y);
    const std::int16_t* above = y > 0 ? disparity.row(y - 1) : nullptr;
    // Lanes past the last pixel read the row's slack; their bits are cleared below.
    for (int x = 0; x < w; x += n) {
      const auto v = hn::LoadU(d, row + x);
      const auto next = hn::LoadU(d, row + x + 1);
      const auto ok = hn::Ne(v, invalid);
      const int word = x / 32, shift = x % 32;
      valid[word] |= MaskBits(ok) << shift;
      // Pixel x connected to x + 1, stored at bit x here and moved to bit x + 1 below.
      left[word] |= MaskBits(hn::And(hn::And(ok, hn::Ne(next, invalid)), Close(v, next, diff_limit))) << shift;
      if (above) {
        const auto a = hn::LoadU(d, above + x);
        up[word] |= MaskBits(hn::And(hn::And(ok, hn::Ne(a, invalid)), Close(v, a, diff_limit))) << shift;
      }
    }
    for (int i = words - 1; i >= 0; --i) left[i] = (left[i] << 1) | (i > 0 ? left[i - 1] >> 31 : 0u);
    if (w % 32) {
      const std::uint32_t keep = (1u << (w % 32)) - 1;
      valid[words - 1] &= keep;
      left[words - 1] &= keep;
      up[words - 1] &= keep;
    }
  }
}

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mctstereo::detail::cpu {
HWY_EXPORT(RowMasks);

namespace {

// Root of p, halving the path on the way (every other node skips to its grandparent).
inline std::int32_t find_root(std::int32_t* parent, std::int32_t p) {
  for (;;) {
    const std::int32_t q = parent[p];
    if (q < 0) return p;
    const std::int32_t g = parent[q];
    if (g < 0) return q;
    parent[p] = g;
    p = g;
  }
}

// Joins two roots; the smaller index stays root so that every link points backwards.
inline std::int32_t unite(std::int32_t* parent, std::int32_t a, std::int32_t b) {
  if (a == b) return a;
  const std::int32_t lo = std::min(a, b), hi = std::max(a, b);
  parent[lo] += parent[hi];  // sizes are stored negated
  parent[hi] = lo;
  return lo;
}

// First x >= from whose bit is clear, or w. Bits at and past w are clear.
inline int next_clear(const std::uint32_t* bits, int words, int from, int w) {
  int i = from >> 5;
  if (i >= words) return w;
  std::uint32_t z = ~bits[i] & (~0u << (from & 31));
  while (z == 0) {
    if (++i == words) return w;
    z = ~bits[i];
  }
  return std::min(32 * i + std::countr_zero(z), w);
}

// The masks of one row, and what follows from them.
struct RowMaskView {
  const std::uint32_t* valid;  // pixel valid
  const std::uint32_t* left;   // connected to its left neighbour
  const std::uint32_t* up;     // connected to the pixel above

  std::uint32_t heads(int i) const { return valid[i] & ~left[i]; }

  // Vertical links of word i worth a union. A link whose left neighbour in the same run also
  // links, into the same run above, joins a component already joined: only the first link of
  // each such stretch is kept.
  std::uint32_t links(int i, const RowMaskView& above) const {
    const std::uint32_t up_prev = (up[i] << 1) | (i > 0 ? up[i - 1] >> 31 : 0u);
    return up[i] & ~(up_prev & left[i] & above.left[i]);
  }

  // Head of the run that holds the valid pixel x: the last head at or before x.
  int run_head(int x) const {
    int i = x >> 5;
    std::uint32_t m = heads(i) & ((2u << (x & 31)) - 1u);  // bits 0 .. x % 32
    while (m == 0) m = heads(--i);
    return 32 * i + 31 - std::countl_zero(m);
  }
};

}  // namespace

// The three mask arrays of a row.
int speckle_label_width(int width) { return 3 * ((width + 31) / 32); }

void remove_speckles(Plane<std::int16_t>& disparity, int max_size, int max_diff_q4, SpeckleScratch& scratch) {
  const int w = disparity.width(), h = disparity.height();
  if (w == 0 || h == 0 || max_size <= 1) return;  // every region has at least one pixel
  if (max_diff_q4 < 0) {
    // No two pixels connect: every valid pixel is a region of one, smaller than max_size.
    for (int y = 0; y < h; ++y) std::fill(disparity.row(y), disparity.row(y) + w, kInvalid);
    return;
  }
  Plane<std::int32_t>& label = scratch.label;
  std::int32_t* parent = scratch.stack.get();
  const int words = (w + 31) / 32;
  const auto masks = [&](int y) {
    const auto* m = reinterpret_cast<const std::uint32_t*>(label.row(y));
    return RowMaskView{m, m + words, m + 2 * words};
  };

  // The rows are cut into bands, each labelled on its own by one chunk; the links across band
  // boundaries are joined afterwards by one thread. Union-find entries are pixel indices, so bands
  // never collide, and the components, hence the result, do not depend on the bands.
  const int bands = std::min(stage_threads(), h);
  const auto band_start = [&](int b) { return static_cast<int>(static_cast<std::int64_t>(h) * b / bands); };
  parallel_for(bands, 1, [&](int b0, int b1) {
    for (int band = b0; band < b1; ++band) {
      const int y0 = band_start(band), y1 = band_start(band + 1);
      HWY_DYNAMIC_DISPATCH(RowMasks)(disparity, max_diff_q4, y0, y1, label);

      // Pass 1, in raster order: every run head becomes a root holding the run's size; a run joins
      // the component of each run above it that it touches.
      for (int y = y0; y < y1; ++y) {
        const RowMaskView row = masks(y);
        std::int32_t root = -1;  // root of the current run's component
        for (int i = 0; i < words; ++i) {
          const std::uint32_t heads = row.heads(i);
          const std::uint32_t links = y > y0 ? row.links(i, masks(y - 1)) : 0u;
          for (std::uint32_t events = heads | links; events != 0; events &= events - 1) {
            const int b = std::countr_zero(events);
            const int x = 32 * i + b;
            if ((heads >> b) & 1u) {
              root = y * w + x;
              parent[root] = -(next_clear(row.left, words, x + 1, w) - x);
            }
            if ((links >> b) & 1u)
              root = unite(parent, root, find_root(parent, (y - 1) * w + masks(y - 1).run_head(x)));
          }
        }
      }
    }
  });
  for (int band = 1; band < bands; ++band) {
    const int y = band_start(band);
    if (y == 0 || y >= h) continue;
    const RowMaskView row = masks(y), above = masks(y - 1);
    for (int i = 0; i < words; ++i) {
      for (std::uint32_t links = row.links(i, above); links != 0; links &= links - 1) {
        const int x = 32 * i + std::countr_zero(links);
        unite(parent, find_root(parent, y * w + row.run_head(x)), find_root(parent, (y - 1) * w + above.run_head(x)));
      }
    }
  }

  // Pass 2: erase the runs of small components. The forest is only read from here on.
  parallel_lines(h, [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y) {
      const RowMaskView row = masks(y);
      std::int16_t* d = disparity.row(y);
      for (int i = 0; i < words; ++i) {
        for (std::uint32_t heads = row.heads(i); heads != 0; heads &= heads - 1) {
          const int x = 32 * i + std::countr_zero(heads);
          std::int32_t p = y * w + x;
          while (parent[p] >= 0) p = parent[p];
          if (-parent[p] < max_size) std::fill(d + x, d + next_clear(row.left, words, x + 1, w), kInvalid);
        }
      }
    }
  });
}

}  // namespace mctstereo::detail::cpu
#endif
