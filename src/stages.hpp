// The stage list: every stage of the pipeline, declared once per backend with the same signature.
//
// `reference::` is the specification in code: one plain scalar loop per stage, written to be
// obviously right. `cpu::` computes exactly the same integers with Highway SIMD (dispatched at run
// time) and OpenMP threads over row bands. Tests compare the two bit for bit.
//
// Conventions shared by all stages (see docs/PIPELINE.md):
// - Disparity maps are int16 in Q4 (16 x pixels of their level); kInvalid marks a pixel without one.
// - "dir" selects the reference view: -1 = left view (its pixel x matches x - d in the other view),
//   +1 = right view (x matches x + d).
// - Out-of-image reads repeat the edge pixel (clamped coordinates).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

#include "mctstereo/image.hpp"
#include "mctstereo/params.hpp"
#include "plane.hpp"

namespace mctstereo::detail {

inline constexpr std::int16_t kInvalid = std::numeric_limits<std::int16_t>::min();

/// Columns of replicated census codes on each side of a row: covers the SHD window (radius <= 4)
/// so that the matching loops never clamp.
inline constexpr int kCodePad = 8;

/// Census codes of one image, planar: word k of pixel (x, y) is plane[k].at(x, y); bits of the
/// string beyond the first word continue in the next plane (most significant bits first).
struct CensusCodes {
  int words = 0;
  std::array<Plane<std::uint32_t>, 3> plane;
};

struct CensusConfig {
  CensusKind kind = CensusKind::Census;
  int window = 5;
  MeanKernel kernel = MeanKernel::Gaussian;
};

/// 32-bit words a census string of an n x n window needs: 3 -> 1, 5 -> 1, 7 -> 2, 9 -> 3.
constexpr int census_words(int window) { return (window * window - 1 + 31) / 32; }

struct MatchConfig {
  int dir = -1;                 ///< -1: left reference, +1: right reference
  int shd_window = 5;           ///< a, odd, 1..9
  bool subpixel = false;        ///< parabola fit into Q4
  int uniqueness_ratio = 0;     ///< percent, 0 = off
  /// Match the even rows only and leave the odd ones as they are: the right view's map at the
  /// finest level when the LR check reads it on its grid alone (grid_partner()).
  bool even_rows = false;
};

/// Scratch memory of the matching stage, allocated by the driver once per matcher.
struct MatchScratch {
  std::unique_ptr<std::uint8_t[], FreeDeleter> data;
  std::size_t bytes_per_thread = 0;
  int threads = 1;
};

/// Scratch memory of speckle removal (labels and a stack of W x H entries).
struct SpeckleScratch {
  Plane<std::int32_t> label;
  std::unique_ptr<std::int32_t[], FreeDeleter> stack;
};

// ---------------------------------------------------------------------------------------------
// Helpers shared by every backend (the arithmetic that must be identical everywhere).

/// Sub-pixel offset of the parabola through (d-1, c0), (d, c1), (d+1, c2) in 1/16 px, rounded to
/// nearest (halves away from zero). Requires c0 > c1 <= c2 (ties go to the smaller disparity, so
/// c0 > c1 always holds for a winner), hence the denominator is positive.
inline int subpixel_offset_q4(int c0, int c1, int c2) {
  const int num = 16 * (c0 - c2);
  const int den = 2 * (c0 - 2 * c1 + c2);
  // num / den rounded half away from zero; |num / den| <= 8 since |c0 - c2| <= den / 2.
  const int q = (2 * (num < 0 ? -num : num) + den) / (2 * den);
  return num < 0 ? -q : q;
}

/// A candidate interval [lo, hi] (empty when lo > hi).
struct Interval {
  int lo, hi;
};

/// The search rule of the coarse-to-fine pipeline for pixel (x, y) of a level: without a prior
/// (coarse == nullptr) the whole level range [dmin, dmax]; with one, [2 min - r, 2 max + r] of the
/// valid coarse values in the 3x3 around (x/2, y/2) (clamped to the coarse level), clipped to
/// [dmin, dmax]; an invalid centre prior searches the whole range.
inline Interval search_range_at(const Plane<std::int16_t>* coarse, int dmin, int dmax, int radius, int x, int y) {
  if (coarse == nullptr) return {dmin, dmax};
  const int cw = coarse->width(), ch = coarse->height();
  const int cx = std::min(x / 2, cw - 1), cy = std::min(y / 2, ch - 1);
  if (coarse->at(cx, cy) == kInvalid) return {dmin, dmax};
  int mn = 1 << 20, mx = -(1 << 20);
  for (int j = -1; j <= 1; ++j) {
    for (int i = -1; i <= 1; ++i) {
      const int v = coarse->at(clamp_index(cx + i, cw), clamp_index(cy + j, ch));
      if (v == kInvalid) continue;
      mn = std::min(mn, v >> 4);  // coarse levels hold whole pixels
      mx = std::max(mx, v >> 4);
    }
  }
  // A prior just outside the level range (2 * ceil(dmax / 2) may be dmax + 1) still leaves at
  // least one candidate.
  return {std::min(std::max(dmin, 2 * mn - radius), dmax), std::max(std::min(dmax, 2 * mx + radius), dmin)};
}

/// The temporal prior of one view at one level (docs/PIPELINE.md, "Temporal prior"): the previous
/// frame's map of the level and the level's image in this frame and the previous one. A pixel whose
/// gray value changed by more than `threshold` since the previous frame has moved: it takes no prior.
struct TemporalPrior {
  const Plane<std::int16_t>* map = nullptr;  ///< null: no temporal prior
  const Plane<std::uint8_t>* image = nullptr;
  const Plane<std::uint8_t>* previous_image = nullptr;
  int radius = 0;     ///< of its band and of the narrowed coarser band
  int threshold = 0;  ///< largest change of the gray value of a still pixel
  bool on() const { return map != nullptr; }
};

/// The temporal prior's band at pixel (x, y): [min - r, max + r] of the previous frame's valid
/// values in the 3x3 around (x, y) (coordinates clamped; Q4 values taken to whole pixels, floor
/// for the minimum and ceiling for the maximum), clipped to [dmin, dmax]. Empty (lo > hi) where the
/// centre is invalid or the pixel has moved.
inline Interval temporal_band_at(const TemporalPrior& t, int dmin, int dmax, int x, int y) {
  const Plane<std::int16_t>& previous = *t.map;
  const int w = previous.width(), h = previous.height();
  if (previous.at(x, y) == kInvalid) return {1, 0};
  if (std::abs(t.image->at(x, y) - t.previous_image->at(x, y)) > t.threshold) return {1, 0};
  int mn = 1 << 20, mx = -(1 << 20);
  for (int j = -1; j <= 1; ++j) {
    for (int i = -1; i <= 1; ++i) {
      const int v = previous.at(clamp_index(x + i, w), clamp_index(y + j, h));
      if (v == kInvalid) continue;
      mn = std::min(mn, v >> 4);
      mx = std::max(mx, (v + 15) >> 4);
    }
  }
  return {std::min(std::max(dmin, mn - t.radius), dmax), std::max(std::min(dmax, mx + t.radius), dmin)};
}

/// The temporal prior's rule: the band made from the coarser map (`coarse`, with the level's
/// radius) is kept unless the previous frame's band lies inside it; then the pixel searches the
/// smallest interval holding both the previous frame's band and `narrow`, the coarser map's band
/// made with the temporal radius. The result never leaves `coarse`.
inline Interval with_temporal_prior(Interval coarse, Interval narrow, Interval previous) {
  if (previous.lo > previous.hi || previous.lo < coarse.lo || previous.hi > coarse.hi) return coarse;
  return {std::min(narrow.lo, previous.lo), std::max(narrow.hi, previous.hi)};
}

/// The candidates match() searches at each pixel of a level: read from two planes lo and hi, or
/// made where needed by search_range_at() around a coarse prior. The pipeline takes the second
/// form, so that full-resolution range planes are never written and read back (at 640 x 480 that
/// traffic cost the matching stage more than the ranges themselves).
struct SearchRanges {
  const Plane<std::int16_t>* lo = nullptr;  ///< explicit ranges, when both planes are set
  const Plane<std::int16_t>* hi = nullptr;
  const Plane<std::int16_t>* prior = nullptr;  ///< otherwise: the rule around this prior (null: no prior)
  int dmin = 0, dmax = 0, radius = 0;
  /// The temporal prior (with_temporal_prior()) of this level and view; used only with a coarser
  /// prior.
  TemporalPrior temporal;

  static SearchRanges planes(const Plane<std::int16_t>& lo, const Plane<std::int16_t>& hi) {
    SearchRanges r;
    r.lo = &lo;
    r.hi = &hi;
    return r;
  }
  static SearchRanges around(const Plane<std::int16_t>* prior, int dmin, int dmax, int radius) {
    SearchRanges r;
    r.prior = prior;
    r.dmin = dmin;
    r.dmax = dmax;
    r.radius = radius;
    return r;
  }
  bool from_planes() const { return lo != nullptr; }
  bool with_temporal() const { return temporal.on() && prior != nullptr; }
  Interval at(int x, int y) const {
    if (from_planes()) return {lo->at(x, y), hi->at(x, y)};
    const Interval band = search_range_at(prior, dmin, dmax, radius, x, y);
    if (!with_temporal()) return band;
    return with_temporal_prior(band, search_range_at(prior, dmin, dmax, temporal.radius, x, y),
                               temporal_band_at(temporal, dmin, dmax, x, y));
  }
};

/// One level's census and local matching (census_match): both views' images and the views to
/// match, view 0 the left (dir -1) and view 1 the right (dir +1).
struct CensusMatchJob {
  std::array<const Plane<std::uint8_t>*, 2> image{};
  CensusConfig census;
  int views = 1;  ///< 1: the left view only; 2: both
  std::array<SearchRanges, 2> ranges;
  std::array<MatchConfig, 2> config;
  std::array<Plane<std::int16_t>*, 2> disparity{};
  Plane<std::uint8_t>* margin = nullptr;  ///< view 0's margins (as match() gives them), or null
  /// Whole code planes of both views, for a backend that makes the codes in whole planes (the
  /// reference); the cpu backend makes them strip by strip in its scratch and needs none.
  CensusCodes* codes = nullptr;
};

/// The finest level's refinement of the left map from the raw maps of both views
/// (refine_left_map), where no stage after the LR check needs whole maps: median (both views),
/// LR check (left against right), fill, median after filling.
struct LeftMapRefinement {
  int median_size = 0;       ///< 0 (off), 3 or 5
  int threshold_q4 = 16;     ///< the LR check's largest difference, Q4
  FillMode fill = FillMode::NearestLower;
  int post_median_size = 0;  ///< 0 (off), 3 or 5
  bool grid = false;         ///< the right map's partners on its grid (grid_partner())
};

/// Band SGM (docs/PIPELINE.md, "Band SGM"): the candidates, costs and path sums of one level,
/// for the left view as reference (the right view's map comes from the same sums).
///
/// Pixel (x, y) holds count(x, y) candidates lo(x, y) .. lo(x, y) + count - 1, all with
/// 0 <= x - d < W, in a slot of `stride` entries at index (y W + x) stride; entries past count
/// hold kSgmInf (kSgmInf8 in byte costs). Costs are the a x a box sums of Hamming distances (as
/// match()), sums the path values added up (16 bits).
inline constexpr std::uint16_t kSgmInf = 0xFFFF;
inline constexpr std::uint8_t kSgmInf8 = 0xFF;

/// The largest SGM cost with an a x a box of census distances of w x w - 1 bits each.
constexpr int sgm_max_cost(int shd_window, int census_window) {
  return shd_window * shd_window * (census_window * census_window - 1);
}
/// Whether a level's costs go into bytes: every cost below kSgmInf8 (at most 216 for CT 5x5 with
/// a 3x3 box, the presets' windows). Half the memory and traffic of 16-bit costs (quality at
/// 640 x 480 on the cpu backend: 4 % of the frame time; at 1280 x 720 with 256 disparities
/// 28 MiB less).
constexpr bool sgm_byte_costs(int shd_window, int census_window) {
  return sgm_max_cost(shd_window, census_window) < kSgmInf8;
}

struct SgmVolume {
  int width = 0, height = 0;
  int band = 0;    ///< most candidates of a pixel at this level
  int stride = 0;  ///< entries per pixel slot: band rounded up to a multiple of 16
  Plane<std::int16_t> lo, count;
  /// W x H x stride entries each, in storage the caller owns: the levels run one after the other,
  /// so the driver gives all of them the same storage, sized for the largest. The costs are 16-bit
  /// (cost) or, after use_byte_costs(), bytes (cost8); exactly one of the two is set.
  /// A level aggregated in segments of rows (cpu::sgm_segmented) holds only the rows
  /// row0 .. row0 + segment rows - 1 in that storage: slot_of() counts from row0.
  std::uint16_t* cost = nullptr;
  std::uint8_t* cost8 = nullptr;
  std::uint16_t* sum = nullptr;
  int row0 = 0;
  /// cpu backend: the right view's codes mirrored (x -> W - 1 - x), so that the codes of a pixel's
  /// candidates lo, lo + 1, ... lie at increasing addresses; rows mirror_row0 .. of the level
  /// (all of them, or a segment's window).
  std::array<Plane<std::uint32_t>, 3> mirrored;
  int mirror_row0 = 0;

  /// mirror_rows: rows of the mirrored planes (0: the level's height).
  void reset(int w, int h, int band_width, int words, std::uint16_t* cost_storage, std::uint16_t* sum_storage,
             int mirror_rows = 0) {
    width = w;
    height = h;
    band = band_width;
    stride = stride_for(band_width);
    lo.reset(w, h);
    count.reset(w, h);
    cost = cost_storage;
    cost8 = nullptr;
    sum = sum_storage;
    row0 = mirror_row0 = 0;
    for (int k = 0; k < 3; ++k) mirrored[k] = {};
    for (int k = 0; k < words; ++k) mirrored[k].reset(w, mirror_rows > 0 ? mirror_rows : h, mirror_pad(stride));
  }
  /// Row y of mirrored plane k.
  const std::uint32_t* mirrored_row(int k, int y) const { return mirrored[k].row(y - mirror_row0); }
  static int stride_for(int band_width) { return (band_width + 15) / 16 * 16; }
  static int mirror_pad(int slot_stride) { return slot_stride + 16; }
  /// Entries of cost (and of sum) for a level.
  static std::size_t entries_for(int w, int h, int band_width) {
    return static_cast<std::size_t>(w) * h * stride_for(band_width);
  }
  /// Bytes of a level's own planes (not the shared storage).
  static std::size_t plane_bytes_for(int w, int h, int band_width, int words, int mirror_rows = 0) {
    return 2 * Plane<std::int16_t>::bytes_for(w, h) +
           words * Plane<std::uint32_t>::bytes_for(w, mirror_rows > 0 ? mirror_rows : h,
                                                   mirror_pad(stride_for(band_width)));
  }
  /// Byte costs in `storage` (W x H x stride bytes) instead of 16-bit ones: only where every cost
  /// of the level is below kSgmInf8 (sgm_byte_costs()).
  void use_byte_costs(std::uint8_t* storage) {
    cost = nullptr;
    cost8 = storage;
  }
  std::size_t slot_of(int x, int y) const { return (static_cast<std::size_t>(y - row0) * width + x) * stride; }
  /// Entry k of pixel (x, y)'s costs, kSgmInf past its count, whatever their storage.
  int cost_value(int x, int y, int k) const {
    const std::size_t i = slot_of(x, y) + static_cast<std::size_t>(k);
    if (cost8 == nullptr) return cost[i];
    return cost8[i] == kSgmInf8 ? kSgmInf : cost8[i];
  }
  /// Sets entry k of pixel (x, y)'s costs (c below kSgmInf8 in byte costs, or kSgmInf).
  void set_cost(int x, int y, int k, int c) {
    const std::size_t i = slot_of(x, y) + static_cast<std::size_t>(k);
    if (cost8 == nullptr)
      cost[i] = static_cast<std::uint16_t>(c);
    else
      cost8[i] = c == kSgmInf ? kSgmInf8 : static_cast<std::uint8_t>(c);
  }
  std::uint16_t* cost_at(int x, int y) { return cost + slot_of(x, y); }
  const std::uint16_t* cost_at(int x, int y) const { return cost + slot_of(x, y); }
  std::uint8_t* cost8_at(int x, int y) { return cost8 + slot_of(x, y); }
  const std::uint8_t* cost8_at(int x, int y) const { return cost8 + slot_of(x, y); }
  std::uint16_t* sum_at(int x, int y) { return sum + slot_of(x, y); }
  const std::uint16_t* sum_at(int x, int y) const { return sum + slot_of(x, y); }
};

/// How one level's band is made from the coarser map.
struct SgmBandConfig {
  int dmin = 0, dmax = 0;  ///< the level's range
  int radius = 3;          ///< r around the priors
  int prior_size = 5;      ///< 3 or 5: the coarse neighbourhood whose priors span the band
  int max_band = 32;       ///< cut wider bands to this (the volume's band)
  /// The temporal prior (with_temporal_prior()) of the left view at this level; used only with a
  /// coarser map.
  TemporalPrior temporal;
};

struct SgmPathConfig {
  int paths = 4;  ///< 4 or 8
  int p1 = 40, p2 = 300, p2_k = 8;
};

struct SgmSelectConfig {
  bool subpixel = false;
  int uniqueness_ratio = 0;
};

/// Scratch of the path aggregation, allocated once per matcher.
struct SgmScratch {
  std::unique_ptr<std::uint8_t[], FreeDeleter> data;
  std::size_t bytes_per_thread = 0;
  int threads = 1;
};

/// The prior rule of the SGM band at pixel (x, y) with radius r: [2 min - r, 2 max + r] over the
/// valid priors of the prior_size x prior_size coarse neighbourhood of (x/2, y/2), clipped to the
/// level range (at least one candidate stays); no prior or an invalid centre: the whole range.
/// *centre is 2 x the centre prior (the middle of the range without one).
inline Interval sgm_prior_band_at(const Plane<std::int16_t>* coarse, const SgmBandConfig& config, int radius, int x,
                                  int y, int* centre) {
  *centre = (config.dmin + config.dmax) >> 1;
  if (coarse == nullptr) return {config.dmin, config.dmax};
  const int cw = coarse->width(), ch = coarse->height();
  const int cx = std::min(x / 2, cw - 1), cy = std::min(y / 2, ch - 1);
  if (coarse->at(cx, cy) == kInvalid) return {config.dmin, config.dmax};
  *centre = 2 * (coarse->at(cx, cy) >> 4);
  const int h = config.prior_size / 2;
  int mn = 1 << 20, mx = -(1 << 20);
  for (int j = -h; j <= h; ++j) {
    for (int i = -h; i <= h; ++i) {
      const int v = coarse->at(clamp_index(cx + i, cw), clamp_index(cy + j, ch));
      if (v == kInvalid) continue;
      mn = std::min(mn, v >> 4);
      mx = std::max(mx, v >> 4);
    }
  }
  return {std::min(std::max(config.dmin, 2 * mn - radius), config.dmax),
          std::max(std::min(config.dmax, 2 * mx + radius), config.dmin)};
}

/// The SGM band of one pixel (left view): the prior rule with the level's radius (with the
/// temporal prior, with_temporal_prior() of it), then clipped to the candidates inside the image
/// (0 <= x - d < W; none: an empty band), and a band wider than max_band is cut to max_band
/// candidates around c = 2 x the centre prior: lo = clamp(c - max_band / 2, lo, hi - max_band + 1).
inline Interval sgm_band_at(const Plane<std::int16_t>* coarse, const SgmBandConfig& config, int width, int x, int y) {
  int centre = 0;
  Interval band = sgm_prior_band_at(coarse, config, config.radius, x, y, &centre);
  if (coarse != nullptr && config.temporal.on())
    band = with_temporal_prior(band, sgm_prior_band_at(coarse, config, config.temporal.radius, x, y, &centre),
                               temporal_band_at(config.temporal, config.dmin, config.dmax, x, y));
  int lo = std::max(band.lo, x - width + 1);
  const int hi = std::min(band.hi, x);
  if (hi - lo + 1 > config.max_band) lo = std::clamp(centre - config.max_band / 2, lo, hi - config.max_band + 1);
  return {lo, lo > hi ? lo - 1 : std::min(hi, lo + config.max_band - 1)};
}

/// The winner's margin 255 (S2 - S1) / S2 (box costs or SGM sums; S2 = 0: 0). second == INT_MAX:
/// no candidate outside best - 1 .. best + 1. Then, when the winner is flanked (best - 1 and
/// best + 1 are both candidates), the band holds the winner's neighbourhood and nothing else: no
/// rival, 255 (at the finer levels of a narrow band the common case: the coarser level that chose
/// the band has settled the pixel). Otherwise the pixel has one or two candidates, as where the
/// image border cuts its band: 0.
inline std::uint8_t sgm_margin(int best_sum, int second, bool flanked) {
  if (second == std::numeric_limits<int>::max()) return flanked ? 255 : 0;
  return second > 0 ? static_cast<std::uint8_t>(255 * (second - best_sum) / second) : 0;
}

/// sgm_margin() without an integer division (some 12 cycles of latency per pixel on x86): the
/// quotient 255 (S2 - S1) / S2 of integers below 2^24 and 2^16 is either exact in double or at
/// least 1 / S2 >= 2^-16 below the next integer, far more than the rounding error of a double
/// division (255 x 2^-53), so truncating the double quotient gives the integer quotient.
inline std::uint8_t sgm_margin_fast(int best_sum, int second, bool flanked) {
  if (second == std::numeric_limits<int>::max()) return flanked ? 255 : 0;
  return second > 0
             ? static_cast<std::uint8_t>(static_cast<double>(255 * (second - best_sum)) / static_cast<double>(second))
             : 0;
}

/// An SGM winner's Q4 value after uniqueness and sub-pixel: kInvalid when the uniqueness test
/// fails; cm1, cp1 < 0 mean that best - 1, best + 1 are not candidates.
inline std::int16_t sgm_winner_q4(int best, int best_sum, int second, int cm1, int cp1, const SgmSelectConfig& config) {
  if (config.uniqueness_ratio > 0 && second != std::numeric_limits<int>::max() &&
      100 * (second - best_sum) <= config.uniqueness_ratio * best_sum)
    return kInvalid;
  int q4 = 16 * best;
  if (config.subpixel && cm1 >= 0 && cp1 >= 0) q4 += subpixel_offset_q4(cm1, best_sum, cp1);
  return static_cast<std::int16_t>(q4);
}

/// The agreement term of the confidence: max(0, den - |v - r|) with den = 16 (threshold + 1), v
/// the pixel's map value, r the right map's value at x - ((v + 8) >> 4) (kInvalid: none).
inline int confidence_agreement(int v, int r, int den) {
  return r == kInvalid ? 0 : std::max(0, den - (v > r ? v - r : r - v));
}

/// Confidence of one pixel: see the stage confidence().
inline std::uint8_t confidence_at(const Plane<std::uint8_t>& margin, int margin_shift, const Plane<std::int16_t>& checked,
                                  const Plane<std::int16_t>* right, int threshold, int x, int y) {
  const int v = checked.at(x, y);
  if (v == kInvalid) return 0;
  const int den = 16 * (threshold + 1);
  int num = den;
  if (right != nullptr) {
    const int xr = x - ((v + 8) >> 4);
    num = confidence_agreement(v, xr >= 0 && xr < checked.width() ? right->at(xr, y) : kInvalid, den);
  }
  return static_cast<std::uint8_t>(margin.at(x >> margin_shift, y >> margin_shift) * num / den);
}

/// Padding (entries) on each side of the cpu right-view rows of sgm_select: a vector run of a
/// pixel's candidates reaches up to a slot stride and a vector left of pixel 0.
inline int right_row_pad(int stride) { return stride + 32; }

/// Adaptive P2 of a path step between gray values a and b.
inline int sgm_p2_at(const SgmPathConfig& c, int a, int b) {
  if (c.p2_k == 0) return c.p2;
  const int diff = a > b ? a - b : b - a;
  return std::max(c.p1, (c.p2 * c.p2_k) / (c.p2_k + diff));
}

/// The path steps (dx, dy) in the order their values are added: 4 paths take the first four.
inline constexpr int kSgmSteps[8][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}, {1, 1}, {-1, 1}, {1, -1}, {-1, -1}};

/// The colour of a level's left image for the colour-weighted median: `channels` planes of the
/// level's size, 1 (gray input: its one channel) or 3 (the input's channels, in its byte order:
/// only max over the channels enters, so RGB and BGR give the same weights).
struct ColourPlanes {
  int channels = 1;
  std::array<const Plane<std::uint8_t>*, 3> plane{};
};

/// The colour-weighted median (docs/PIPELINE.md, "Colour-weighted median"): samples at the
/// multiples of `step` in [-radius, radius] in each direction, weight lut[max over channels
/// |C(p) - C(q)|] (0..64).
struct WeightedMedianConfig {
  int radius = 9;
  int step = 3;
  alignas(64) std::array<std::uint8_t, 256> lut{};
};

/// LUT[k] = round(64 exp(-k / sigma)), k = 0..255, as integers: built once on the host (every
/// backend takes this table, none evaluates exp itself).
inline std::array<std::uint8_t, 256> weighted_median_lut(int sigma) {
  std::array<std::uint8_t, 256> lut{};
  for (int k = 0; k < 256; ++k)
    lut[k] = static_cast<std::uint8_t>(std::lround(64.0 * std::exp(-static_cast<double>(k) / sigma)));
  return lut;
}

/// The integer disparity of a Q4 value: (v + 8) >> 4, i.e. rounded to nearest with halves up.
inline int q4_to_whole(int v) { return (v + 8) >> 4; }

/// Most samples per pixel of the colour-weighted median (radius 15, step 1).
inline constexpr int kMaxWeightedMedianSamples = 31 * 31;

/// Level range [floor(dmin / 2^l), ceil(dmax / 2^l)].
inline int level_min(int dmin, int l) { return dmin >> l; }  // arithmetic shift = floor
inline int level_max(int dmax, int l) { return -((-dmax) >> l); }
/// The top of the range of pyramid level `level` at scale 2^l: level_max(), except at a band SGM
/// level that is the coarsest of a pyramid (level > 0), which ends at floor(dmax / 2^l). Its band
/// is its whole range, in slots rounded up to 16 entries: N disparities from 0, N a multiple of
/// 2^l x 16, give N / 2^l candidates in one slot instead of N / 2^l + 1 in a slot twice as wide.
/// The ceiling's extra candidate stands for full-resolution disparities above
/// 2^l floor(dmax / 2^l), which the finer levels reach from the candidate below it (their search
/// radius).
inline int level_dmax(const StereoParams& p, int level, int l) {
  if (p.sgm_at(level) && level > 0 && level + 1 == p.pyramid_levels)
    return std::max(level_min(p.min_disparity, l), p.max_disparity() >> l);
  return level_max(p.max_disparity(), l);
}

// ---------------------------------------------------------------------------------------------
// The stages. Both namespaces declare exactly the same functions.

#define MCTSTEREO_DECLARE_STAGES                                                                  \
  /* RGB/BGR -> luma: Y = (77 R + 150 G + 29 B + 128) >> 8 (BT.601, weights sum to 256). */      \
  void to_gray(const ImageView& src, Plane<std::uint8_t>& dst);                                  \
  /* 5-tap binomial blur (1 4 6 4 1 / 16 in each direction, clamped borders), keeping the even */ \
  /* pixels: dst(x, y) = (sum_ij w_i w_j src(2x + i, 2y + j) + 128) >> 8. dst is ceil(W/2) wide.*/ \
  void pyramid_down(const Plane<std::uint8_t>& src, Plane<std::uint8_t>& dst);                    \
  /* CT or MCT codes of every pixel; fills the kCodePad replicated columns. */                    \
  void census_transform(const Plane<std::uint8_t>& image, const CensusConfig& config,             \
                        CensusCodes& codes);                                                      \
  /* Per-pixel search ranges of a level as planes: search_range_at() at every pixel. (match()   */ \
  /* applies the same rule itself; this form serves callers that want the ranges.)              */ \
  void search_ranges(const Plane<std::int16_t>* coarse, int dmin, int dmax, int radius,           \
                     Plane<std::int16_t>& lo, Plane<std::int16_t>& hi);                            \
  /* SHD cost over each pixel's range and winner-takes-all (ties to the smaller d); output Q4. */  \
  /* margin != nullptr: also the winner's margin sgm_margin(best, second best outside d-1..d+1) */ \
  /* of every pixel (0 without a candidate), the confidence's first factor.                     */ \
  void match(const CensusCodes& ref, const CensusCodes& other, const SearchRanges& ranges,        \
             const MatchConfig& config, MatchScratch& scratch, Plane<std::int16_t>& disparity,     \
             Plane<std::uint8_t>* margin = nullptr);                                               \
  /* Scratch bytes one thread of match() needs for images `width` wide and ranges up to         */ \
  /* max_range candidates.                                                                       */ \
  std::size_t match_scratch_bytes(int width, int max_range, int shd_window);                      \
  /* census_transform() of both views, then match() of each of job.views views (view v: ref v, */ \
  /* other 1 - v; margins for view 0) in one stage, so that a backend may make each strip's    */ \
  /* codes right before it matches the strip, while they are in the cache (cpu).               */ \
  void census_match(const CensusMatchJob& job, MatchScratch& scratch);                           \
  /* Scratch bytes one thread of census_match() needs (match_scratch_bytes() and the strips).   */ \
  std::size_t census_match_scratch_bytes(int width, int max_range, int shd_window, int census_words); \
  /* k x k median; invalid pixels enter as the smallest value (see median_filter.cpp). */         \
  void median_filter(const Plane<std::int16_t>& src, int k, Plane<std::int16_t>& dst);            \
  /* dst = src, invalid where the other view disagrees by more than threshold_q4 / 16 px. */      \
  void lr_check(const Plane<std::int16_t>& src, const Plane<std::int16_t>& other, int dir,       \
                int threshold_q4, Plane<std::int16_t>& dst);                                       \
  /* Invalidates 4-connected regions (neighbours within max_diff_q4) of fewer than max_size px. */ \
  void remove_speckles(Plane<std::int16_t>& disparity, int max_size, int max_diff_q4,             \
                       SpeckleScratch& scratch);                                                   \
  /* Width of scratch.label for maps `width` wide (its height: the maps'; scratch.stack holds    */ \
  /* width x height entries).                                                                   */ \
  int speckle_label_width(int width);                                                            \
  /* Fills invalid pixels along their row. */                                                     \
  void fill_invalid(Plane<std::int16_t>& disparity, FillMode mode);                               \
  /* The left map's LR partners on the grid of the right map's even rows and columns            */ \
  /* (StereoParams::lr_check_grid): partner(x, y) = M(x / 2, y / 2), M the k x k median          */ \
  /* (k = median_size; 0: none) of the grid G(i, j) = right(2i, 2j), i < ceil(W/2), j < ceil(H/2), */ \
  /* clamped at the grid's borders as median_filter() clamps. scratch: grid_partner_scratch_bytes() */ \
  /* per thread.                                                                                  */ \
  void grid_partner(const Plane<std::int16_t>& right, int median_size, MatchScratch& scratch,    \
                    Plane<std::int16_t>& partner);                                                 \
  /* Scratch bytes one thread of grid_partner() needs for maps `width` wide.                      */ \
  std::size_t grid_partner_scratch_bytes(int width);                                               \
  /* out = post-median(fill(lr_check(median(left), median(right), dir -1))), each step exactly  */ \
  /* as its own stage (a median of size 0 is skipped; config.grid: grid_partner(right) in place */ \
  /* of median(right)). left and right (the raw maps) may be overwritten; spare is a plane of  */ \
  /* their size; out is none of the three. The cpu backend runs                                  */ \
  /* it strip by strip in `scratch` (refine_left_map_scratch_bytes() per thread), while each     */ \
  /* strip's rows are in the cache.                                                              */ \
  void refine_left_map(Plane<std::int16_t>& left, Plane<std::int16_t>& right,                    \
                       const LeftMapRefinement& config, MatchScratch& scratch,                   \
                       Plane<std::int16_t>& spare, Plane<std::int16_t>& out);                    \
  /* Scratch bytes one thread of refine_left_map() needs for maps `width` wide.                 */ \
  std::size_t refine_left_map_scratch_bytes(int width);                                          \
  /* The caller's convention of the Q4 map: dst = src with kInvalid replaced by invalid_q4, over */ \
  /* dst's size (src at least as large).                                                        */ \
  void output_q4(const Plane<std::int16_t>& src, std::int16_t invalid_q4, Plane<std::int16_t>& dst); \
  /* Replicates each pixel factor x factor and multiplies by factor, clamped to [lo_q4, hi_q4]; */ \
  /* dst may be smaller than factor x src (the excess is cut).                                  */ \
  void upscale(const Plane<std::int16_t>& src, int factor, int lo_q4, int hi_q4,                  \
               Plane<std::int16_t>& dst);                                                          \
  /* Band SGM. The band of every pixel (sgm_band_at) and its a x a SHD costs (left reference). */ \
  void sgm_costs(const CensusCodes& left, const CensusCodes& right, const Plane<std::int16_t>* coarse, \
                 const SgmBandConfig& config, int shd_window, SgmScratch& scratch, SgmVolume& volume); \
  /* The paths' values over each pixel's band, added up into volume.sum; gray: the left image.  */ \
  void sgm_aggregate(const Plane<std::uint8_t>& gray, const SgmPathConfig& config, SgmScratch& scratch, \
                     SgmVolume& volume);                                                           \
  /* Scratch bytes one thread of any sgm_ stage needs (level w x h, slot stride).              */ \
  std::size_t sgm_scratch_bytes(int width, int height, int stride);                              \
  /* Confidence in 0..255 at the pixels valid in `checked` (the map after the LR check and      */ \
  /* speckle removal): margin x agreement, agreement = max(0, 16 (t + 1) - |v - dR|) / (16(t+1)) */ \
  /* with dR the right map at x - ((v + 8) >> 4) (1 without a right map); 0 elsewhere. The     */ \
  /* margin of (x, y) is margin(x >> margin_shift, y >> margin_shift): a coarser level's, 2^s   */ \
  /* times smaller, when the finest levels match with box sums under SGM levels.               */ \
  void confidence(const Plane<std::uint8_t>& margin, int margin_shift, const Plane<std::int16_t>& checked, \
                  const Plane<std::int16_t>* right, int threshold, Plane<std::uint8_t>& dst);        \
  /* Winners on the sums: the left map, the right map when right != nullptr (from the same sums:*/ \
  /* S_R(x, d) = S(x + d, d) where that left pixel searched d), and the left winners' margin     */ \
  /* 255 (S2 - S1) / S2 (S2: best sum outside d-1..d+1; 0 without one) when margin != nullptr.  */ \
  void sgm_select(const SgmVolume& volume, const SgmSelectConfig& config, SgmScratch& scratch,     \
                  Plane<std::int16_t>& left, Plane<std::int16_t>* right, Plane<std::uint8_t>* margin); \
  /* Channels of interleaved RGB/BGR input into three planes (byte order kept); gray input:    */ \
  /* its one channel into dst[0].                                                               */ \
  void split_channels(const ImageView& src, std::array<Plane<std::uint8_t>, 3>& dst);              \
  /* Colour-weighted median of a map (docs/PIPELINE.md): at each pixel the smallest whole d     */ \
  /* whose running weight (samples with q4_to_whole(v) <= d) reaches ceil(total / 2); the pixel */ \
  /* keeps its Q4 value where d is its own whole disparity, else 16 d; total 0: unchanged.      */ \
  /* Invalid samples weigh 0. Values within +-2039 px (the Q4 range of the parameters).         */ \
  void weighted_median(const Plane<std::int16_t>& src, const ColourPlanes& colour,                 \
                       const WeightedMedianConfig& config, Plane<std::int16_t>& dst);

namespace reference {
MCTSTEREO_DECLARE_STAGES
}  // namespace reference

namespace cpu {
MCTSTEREO_DECLARE_STAGES
/// Name of the SIMD target that dynamic dispatch picks on this machine.
const char* simd_target_name();
/// The colour-weighted median by other exact methods, kept for measurement (bench/): a histogram
/// of the window's whole disparities per pixel, or a sort of its (d, w) samples; scalar code with
/// OpenMP over rows. weighted_median() itself is the fastest exact form (a vector binary search).
enum class WeightedMedianMethod { Histogram, Sort };
void weighted_median_scalar(const Plane<std::int16_t>& src, const ColourPlanes& colour,
                            const WeightedMedianConfig& config, WeightedMedianMethod method,
                            Plane<std::int16_t>& dst);
}  // namespace cpu

#undef MCTSTEREO_DECLARE_STAGES

}  // namespace mctstereo::detail
