// census_transform with Highway SIMD: CT and MCT codes, 8-bit comparisons of a whole vector of
// pixels per neighbour.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cpu/census.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include "cpu/vec_slot-inl.h"

#include <algorithm>
#include <bit>
#include <cstring>
#include <type_traits>

#include "cpu/match_tiles.hpp"
#include "cpu/parallel.hpp"
#include "stages.hpp"

// The codes are assembled byte by byte in memory (see CensusBlock), which presumes little-endian
// words, as on every target Highway dispatches to.
static_assert(std::endian::native == std::endian::little);

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// MCT's threshold for the box kernel is ceil(S / 9) with S <= 9 * 255; as (S + 8) * 7282 >> 16
// (7282 = ceil(2^16 / 9)) the quotient is exact over that whole range, checked here exhaustively.
constexpr bool BoxDivisionExact() {
  for (int s = 0; s <= 9 * 255; ++s)
    if ((((s + 8) * 7282) >> 16) != (s + 8) / 9) return false;
  return true;
}
static_assert(BoxDivisionExact());

// u8 lanes per vector at most: 64 bytes, the slack every Plane row has past its end, so a block of
// pixels never needs more than a Plane guarantees (and stack tiles stay small).
constexpr int kMaxBlock = 64;
constexpr int kMaxRadius = 4;
constexpr int kTileStride = kMaxBlock + 2 * kMaxRadius;
// Blocks of a row whose window leaves it: at most kRadius at the left end and kRadius + 1 at the
// right (fewer unless a block is narrower than kRadius, as on the scalar target).
constexpr int kMaxEdges = 2 * kMaxRadius + 1;

using D8 = hn::CappedTag<std::uint8_t, kMaxBlock>;
using V8 = hn::Vec<D8>;

#if HWY_TARGET != HWY_SCALAR
// One u16 lane per pixel of half a block: pixel p + i of row r.
template <class D16>
HWY_INLINE hn::Vec<D16> LoadWide(D16 d16, const std::uint8_t* r, std::ptrdiff_t p, int i) {
  return hn::PromoteTo(d16, hn::LoadU(hn::Rebind<std::uint8_t, D16>(), r + p + i));
}

// a + 2b + c down the three rows at column offset i: one column of the 1 2 1 / 2 4 2 / 1 2 1 kernel.
template <class D16>
HWY_INLINE hn::Vec<D16> GaussianColumn(D16 d16, const std::uint8_t* r0, const std::uint8_t* r1,
                                       const std::uint8_t* r2, std::ptrdiff_t p, int i) {
  return hn::Add(hn::Add(LoadWide(d16, r0, p, i), LoadWide(d16, r2, p, i)), hn::ShiftLeft<1>(LoadWide(d16, r1, p, i)));
}

// The MCT threshold of the pixels p .. p + Lanes(d16) - 1 of the centre row r1. The sums need 16
// bits, so a block is done in two halves (plain functions, not lambdas: GCC did not inline a lambda
// called twice here, and the call cost the stage a quarter of its time).
template <class D16>
HWY_INLINE hn::Vec<hn::Rebind<std::uint8_t, D16>> MctThresholdHalf(D16 d16, const std::uint8_t* r0,
                                                                  const std::uint8_t* r1, const std::uint8_t* r2,
                                                                  std::ptrdiff_t p, bool gaussian) {
  hn::Vec<D16> t;
  if (gaussian) {
    // Column sums a + 2b + c, then left + 2 centre + right: weights 1 2 1 / 2 4 2 / 1 2 1,
    // S <= 16 * 255; T = (S + 15) >> 4.
    const auto left = GaussianColumn(d16, r0, r1, r2, p, -1);
    const auto centre = GaussianColumn(d16, r0, r1, r2, p, 0);
    const auto right = GaussianColumn(d16, r0, r1, r2, p, 1);
    const auto s = hn::Add(hn::Add(left, right), hn::ShiftLeft<1>(centre));
    t = hn::ShiftRight<4>(hn::Add(s, hn::Set(d16, 15)));
  } else {
    auto s = hn::Set(d16, 8);
    for (int i = -1; i <= 1; ++i)
      s = hn::Add(s, hn::Add(hn::Add(LoadWide(d16, r0, p, i), LoadWide(d16, r1, p, i)), LoadWide(d16, r2, p, i)));
    t = hn::MulHigh(s, hn::Set(d16, 7282));  // (S + 8) / 9, see BoxDivisionExact
  }
  // t <= 255: exact
  return hn::DemoteTo(hn::Rebind<std::uint8_t, D16>(), hn::BitCast(hn::RebindToSigned<D16>(), t));
}
#endif

// Both tests become one 8-bit comparison per neighbour, bit = I(P') < T(P):
// - CT: T = I(P).
// - MCT: I(P') * norm < S  <=>  I(P') < S / norm  <=>  I(P') < ceil(S / norm) for integer I(P'),
//   and ceil(S / norm) <= 255 since S <= 255 * norm. So T = ceil(S / norm) exactly, no rounding.
// rows[j] points at column 0 of window row j (j = 0 .. 2r), whose centre row is rows[r].
template <int kRadius>
HWY_INLINE V8 MctThreshold(D8 d8, const std::uint8_t* const* rows, std::ptrdiff_t x, bool gaussian) {
  const std::uint8_t* r0 = rows[kRadius - 1];
  const std::uint8_t* r1 = rows[kRadius];
  const std::uint8_t* r2 = rows[kRadius + 1];
#if HWY_TARGET == HWY_SCALAR
  // One pixel per vector: the weighted sum as in the reference.
  auto at = [&](const std::uint8_t* r, int i) { return static_cast<int>(r[x + i]); };
  int s;
  if (gaussian) {
    s = at(r0, -1) + at(r0, 1) + at(r2, -1) + at(r2, 1) + 2 * (at(r0, 0) + at(r1, -1) + at(r1, 1) + at(r2, 0)) +
        4 * at(r1, 0);
    return hn::Set(d8, static_cast<std::uint8_t>((s + 15) >> 4));
  }
  s = 0;
  for (int i = -1; i <= 1; ++i) s += at(r0, i) + at(r1, i) + at(r2, i);
  return hn::Set(d8, static_cast<std::uint8_t>((s + 8) / 9));
#else
  // Each half of the block in u16 lanes, then narrowed back to one vector.
  const hn::Repartition<std::uint16_t, D8> d16;
  const std::ptrdiff_t nh = static_cast<std::ptrdiff_t>(hn::Lanes(d16));
  const auto lower = MctThresholdHalf(d16, r0, r1, r2, x, gaussian);
  const auto upper = MctThresholdHalf(d16, r0, r1, r2, x + nh, gaussian);
  return hn::Combine(d8, upper, lower);
#endif
}

// Whether neighbour b of the string (row-major over the window, the centre skipped) is darker
// than the threshold, for the block of pixels at column x. The neighbour's row and column offset
// are compile-time constants, so the load addresses the window row's register with an immediate
// displacement. (With an array of neighbour pointers, GCC kept the pointers in vector registers
// and extracted one for every load: 12 % more time for the stage at 640 x 480.)
template <int kRadius, int kB>
HWY_INLINE auto Darker(D8 d8, const std::uint8_t* const* rows, std::ptrdiff_t x, V8 thr) {
  constexpr int kWindow = 2 * kRadius + 1;
  constexpr int kCentre = (kWindow * kWindow - 1) / 2;
  constexpr int kL = kB < kCentre ? kB : kB + 1;  // index in the window, centre included
  return hn::Lt(hn::LoadU(d8, rows[kL / kWindow] + x + (kL % kWindow - kRadius)), thr);
}

// String byte kByte (neighbours 8 kByte .. 8 kByte + 7, the first in the most significant bit) of
// every pixel of the block, one byte per pixel.
template <int kRadius, int kByte>
HWY_INLINE V8 CodeByte(D8 d8, const std::uint8_t* const* rows, std::ptrdiff_t x, V8 thr) {
  constexpr int kB = 8 * kByte;
#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
  // Comparisons give mask registers here: a masked add of the bit's weight costs one instruction.
  V8 acc = hn::IfThenElseZero(Darker<kRadius, kB>(d8, rows, x, thr), hn::Set(d8, 0x80));
#define MCTSTEREO_CENSUS_BIT(k) \
  acc = hn::IfThenElse(Darker<kRadius, kB + k>(d8, rows, x, thr), hn::Add(acc, hn::Set(d8, 0x80 >> k)), acc)
#else
  // Comparisons give vectors of 0 / -1: shift the byte left and subtract the mask, which needs no
  // per-bit constants (they would not all fit in 16 registers with the rest).
  V8 acc = hn::Zero(d8);
#define MCTSTEREO_CENSUS_BIT(k) \
  acc = hn::Sub(hn::Add(acc, acc), hn::VecFromMask(d8, Darker<kRadius, kB + k>(d8, rows, x, thr)))
  MCTSTEREO_CENSUS_BIT(0);
#endif
  MCTSTEREO_CENSUS_BIT(1);
  MCTSTEREO_CENSUS_BIT(2);
  MCTSTEREO_CENSUS_BIT(3);
  MCTSTEREO_CENSUS_BIT(4);
  MCTSTEREO_CENSUS_BIT(5);
  MCTSTEREO_CENSUS_BIT(6);
  MCTSTEREO_CENSUS_BIT(7);
#undef MCTSTEREO_CENSUS_BIT
  return acc;
}

// String byte kByte, or zeros where the word has no such byte (kByte < kFirst).
template <int kRadius, int kByte, int kFirst>
HWY_INLINE V8 CodeByteOrZero(D8 d8, const std::uint8_t* const* rows, std::ptrdiff_t x, V8 thr) {
  if constexpr (kByte >= kFirst) {
    return CodeByte<kRadius, kByte>(d8, rows, x, thr);
  } else {
    return hn::Zero(d8);
  }
}

// Output word kWord (and the ones after it) of the block at column x. Each 32-bit word holds
// up to 4 bytes of the string, the first byte most significant and the word right-aligned. In
// little-endian memory the word's bytes are the string bytes in reverse order followed by zeros,
// so one interleaving store writes the block in order.
template <int kRadius, int kWord>
HWY_INLINE void CensusWords(D8 d8, const std::uint8_t* const* rows, std::ptrdiff_t x, V8 thr,
                            std::uint32_t* const* out) {
  constexpr int kWindow = 2 * kRadius + 1;
  constexpr int kBytes = (kWindow * kWindow - 1) / 8;  // 1, 3, 6, 10: strings are whole bytes
  constexpr int kFirst = 4 * kWord;
  constexpr int kLast = std::min(kFirst + 4, kBytes) - 1;
  // Byte i of the word in memory: string byte kLast - i, or zero.
  const V8 b0 = CodeByte<kRadius, kLast>(d8, rows, x, thr);
  const V8 b1 = CodeByteOrZero<kRadius, kLast - 1, kFirst>(d8, rows, x, thr);
  const V8 b2 = CodeByteOrZero<kRadius, kLast - 2, kFirst>(d8, rows, x, thr);
  const V8 b3 = CodeByteOrZero<kRadius, kLast - 3, kFirst>(d8, rows, x, thr);
  hn::StoreInterleaved4(b0, b1, b2, b3, d8, reinterpret_cast<std::uint8_t*>(out[kWord] + x));
  if constexpr (kFirst + 4 < kBytes) CensusWords<kRadius, kWord + 1>(d8, rows, x, thr, out);
}

// Codes of the block of Lanes(d8) pixels starting at column x; rows[j] points at column 0 of
// window row j (j = 0 .. 2 kRadius).
template <int kRadius, bool kMct>
HWY_INLINE void CensusBlock(D8 d8, const std::uint8_t* const* rows, std::ptrdiff_t x, bool gaussian,
                            std::uint32_t* const* out) {
  const V8 thr = kMct ? MctThreshold<kRadius>(d8, rows, x, gaussian) : hn::LoadU(d8, rows[kRadius] + x);
  CensusWords<kRadius, 0>(d8, rows, x, thr, out);
}

// Copies source columns [first, first + count) of a row into dst, clamping columns to [0, w).
void ClampedCopy(const std::uint8_t* src, int w, int first, int count, std::uint8_t* dst) {
  const int begin = std::clamp(-first, 0, count);          // dst index of column 0
  const int end = std::clamp(w - first, begin, count);     // dst index of column w
  std::memset(dst, src[0], static_cast<std::size_t>(begin));
  std::memcpy(dst + begin, src + first + begin, static_cast<std::size_t>(end - begin));
  std::memset(dst + end, src[w - 1], static_cast<std::size_t>(count - end));
}

// The same for the window row of an edge block (bx = 0 or bx = w - block) when the row is at least
// block + kRadius wide, so that the window leaves it on one side only: one copy of a fixed size
// (vector moves; ClampedCopy's three library calls per row made an edge block cost four interior
// ones, half the stage's time at 640 x 480), then kRadius repeated edge pixels. The copy reads
// kTileStride bytes at most, from column max(bx - kRadius, 0): with block >= 2 kMaxRadius that
// ends within the row and its 64 bytes of slack. Tile columns past block + 2 kRadius are never
// read.
template <int kRadius>
HWY_INLINE void EdgeTileRow(const std::uint8_t* src, int w, int bx, int block, std::uint8_t* dst) {
  if (bx == 0) {
    std::memcpy(dst + kRadius, src, kTileStride - kRadius);
    for (int i = 0; i < kRadius; ++i) dst[i] = src[0];
  } else {
    std::memcpy(dst, src + bx - kRadius, kTileStride);
    for (int i = block + kRadius; i < block + 2 * kRadius; ++i) dst[i] = src[w - 1];
  }
}

// The block layout of a row of width w, the same in every row. The blocks whose window lies
// inside the row start at the first block x >= kRadius and end before x_end. The blocks at either
// end (whose window leaves the row) read their window from a tile with the edge pixels repeated,
// column kRadius of the tile being the block's first pixel; the last block overlaps the one
// before rather than running past the row (the overlapped pixels get the same codes again).
struct RowLayout {
  int first, x_end, edges;
  int edge_x[kMaxEdges];
  bool fixed_copy;  // EdgeTileRow's condition
};

template <int kRadius>
RowLayout MakeRowLayout(int w) {
  const int block = static_cast<int>(hn::Lanes(D8()));
  RowLayout l;
  l.first = (kRadius + block - 1) / block * block;
  l.x_end = l.first;
  while (l.x_end + block + kRadius <= w) l.x_end += block;
  l.edges = 0;
  for (int e = 0; e < std::min(l.first, w); e += block) l.edge_x[l.edges++] = e;
  for (int e = l.x_end; e < w; e += block) l.edge_x[l.edges++] = w >= block ? std::min(e, w - block) : 0;
  l.fixed_copy = w >= block + kRadius && block >= 2 * kMaxRadius;
  return l;
}

// The codes of image row y into out[k] (column 0 of word k's row), and `pad` replicated columns
// on both sides.
template <int kRadius, bool kMct>
void CensusRow(const Plane<std::uint8_t>& image, int y, const RowLayout& layout, bool gaussian, int words,
               std::uint32_t* const* out, int pad) {
  constexpr int kWindow = 2 * kRadius + 1;
  const D8 d8;
  const int block = static_cast<int>(hn::Lanes(d8));
  const int w = image.width(), h = image.height();
  const std::uint8_t* rows[kWindow];
  for (int j = 0; j < kWindow; ++j) rows[j] = image.row(clamp_index(y - kRadius + j, h));
  // The edge tiles are filled before the interior blocks run: a block's loads straddle the
  // copies' stores, cannot be forwarded from them, and would wait for them to reach the cache
  // if they came right after.
  HWY_ALIGN std::uint8_t tiles[kMaxEdges][kWindow * kTileStride];
  for (int i = 0; i < layout.edges; ++i) {
    std::uint8_t* tile = tiles[i];
    if (layout.fixed_copy) {
      for (int j = 0; j < kWindow; ++j) EdgeTileRow<kRadius>(rows[j], w, layout.edge_x[i], block, tile + j * kTileStride);
    } else {
      for (int j = 0; j < kWindow; ++j)
        ClampedCopy(rows[j], w, layout.edge_x[i] - kRadius, block + 2 * kRadius, tile + j * kTileStride);
    }
  }
  // The interior blocks, in a loop without calls: the bit weights and the row pointers stay
  // in registers (with the copies in the same loop, GCC broadcast the seven weights again in
  // every block).
  for (int x = layout.first; x < layout.x_end; x += block) CensusBlock<kRadius, kMct>(d8, rows, x, gaussian, out);
  // A row narrower than a block is written through a stack buffer: a whole block would run
  // past the row's slack.
  HWY_ALIGN std::uint32_t narrow[3][kMaxBlock];
  for (int i = 0; i < layout.edges; ++i) {
    const std::uint8_t* tile_rows[kWindow];
    for (int j = 0; j < kWindow; ++j) tile_rows[j] = tiles[i] + j * kTileStride + kRadius;
    std::uint32_t* dst[3];
    for (int k = 0; k < words; ++k) dst[k] = w >= block ? out[k] + layout.edge_x[i] : narrow[k];
    CensusBlock<kRadius, kMct>(d8, tile_rows, 0, gaussian, dst);
    if (w < block)
      for (int k = 0; k < words; ++k) std::memcpy(out[k], narrow[k], sizeof(std::uint32_t) * w);
  }
  // Replicated columns for the matching stage's window.
  for (int k = 0; k < words; ++k) {
    std::uint32_t* r = out[k];
    std::fill(r - pad, r, r[0]);
    std::fill(r + w, r + w + pad, r[w - 1]);
  }
}

template <int kRadius, bool kMct>
void CensusImpl(const Plane<std::uint8_t>& image, bool gaussian, CensusCodes& codes) {
  const RowLayout layout = MakeRowLayout<kRadius>(image.width());
  parallel_lines(image.height(), [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y) {
      std::uint32_t* out[3];
      for (int k = 0; k < codes.words; ++k) out[k] = codes.plane[k].row(y);
      CensusRow<kRadius, kMct>(image, y, layout, gaussian, codes.words, out, codes.plane[0].pad());
    }
  });
}

// Rows [y_begin, y_end) on the calling thread, into the slots of dst (census_match's strips).
template <int kRadius, bool kMct>
void CensusRowsImpl(const Plane<std::uint8_t>& image, bool gaussian, int y_begin, int y_end, const CodeRows& dst) {
  const RowLayout layout = MakeRowLayout<kRadius>(image.width());
  for (int y = y_begin; y < y_end; ++y) {
    std::uint32_t* out[3];
    for (int k = 0; k < dst.words; ++k) out[k] = dst.row(k, y);
    CensusRow<kRadius, kMct>(image, y, layout, gaussian, dst.words, out, kCodePad);
  }
}

// Calls fn(radius, mct) with both as compile-time constants (std::integral_constant) for the
// census variant of config.
template <class Fn>
void WithCensusVariant(const CensusConfig& config, const Fn& fn) {
  using std::integral_constant;
  const bool mct = config.kind != CensusKind::Census;
  switch (config.window * 2 + (mct ? 1 : 0)) {
    case 3 * 2: return fn(integral_constant<int, 1>(), std::false_type());
    case 3 * 2 + 1: return fn(integral_constant<int, 1>(), std::true_type());
    case 5 * 2: return fn(integral_constant<int, 2>(), std::false_type());
    case 5 * 2 + 1: return fn(integral_constant<int, 2>(), std::true_type());
    case 7 * 2: return fn(integral_constant<int, 3>(), std::false_type());
    case 7 * 2 + 1: return fn(integral_constant<int, 3>(), std::true_type());
    case 9 * 2: return fn(integral_constant<int, 4>(), std::false_type());
    case 9 * 2 + 1: return fn(integral_constant<int, 4>(), std::true_type());
    default: return;  // validate() admits only windows 3, 5, 7, 9
  }
}

void CensusTransform(const Plane<std::uint8_t>& image, const CensusConfig& config, CensusCodes& codes) {
  if (image.width() == 0 || image.height() == 0) return;
  const bool gaussian = config.kernel == MeanKernel::Gaussian;
  WithCensusVariant(config, [&](auto radius, auto mct) {
    CensusImpl<decltype(radius)::value, decltype(mct)::value>(image, gaussian, codes);
  });
}

void CensusRows(const Plane<std::uint8_t>& image, const CensusConfig& config, int y_begin, int y_end,
                const CodeRows& dst) {
  if (image.width() == 0 || y_begin >= y_end) return;
  const bool gaussian = config.kernel == MeanKernel::Gaussian;
  WithCensusVariant(config, [&](auto radius, auto mct) {
    CensusRowsImpl<decltype(radius)::value, decltype(mct)::value>(image, gaussian, y_begin, y_end, dst);
  });
}

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mctstereo::detail::cpu {
HWY_EXPORT(CensusTransform);
HWY_EXPORT(CensusRows);
void census_rows(const Plane<std::uint8_t>& image, const CensusConfig& config, int y_begin, int y_end,
                 const CodeRows& dst) {
  HWY_DYNAMIC_DISPATCH(CensusRows)(image, config, y_begin, y_end, dst);
}
void census_transform(const Plane<std::uint8_t>& image, const CensusConfig& config, CensusCodes& codes) {
  HWY_DYNAMIC_DISPATCH(CensusTransform)(image, config, codes);
}
}  // namespace mctstereo::detail::cpu
#endif
