// The plan of a frame's levels: their sizes, ranges, windows, bands and the sizes of the buffers
// they share, made once from the parameters. The host driver (src/matcher.cpp), the OpenCL
// pipeline (src/opencl/pipeline.cpp) and estimate_memory() all build their levels from it, so
// a stage or a level rule is added in one place.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "mctstereo/params.hpp"
#include "cpu/sgm_segments.hpp"
#include "stages.hpp"

namespace mctstereo::detail {

/// 2^l >= v: the working scale's reductions.
inline int log2_exact(int v) {
  int l = 0;
  while ((1 << l) < v) ++l;
  return l;
}

struct Size2 {
  int width = 0, height = 0;
};

/// One pyramid level.
struct LevelSpec {
  int width = 0, height = 0;
  int scale_log2 = 0;  ///< this level is 2^scale_log2 times smaller than the input
  int dmin = 0, dmax = 0;
  int shd_window = 5;
  int radius = 0;         ///< search radius around the coarser level's priors
  bool refine = true;     ///< median, LR check, speckles, fill at this level
  bool coarsest = false;  ///< no prior: the whole range
  int speckle = 0;        ///< speckle removal's region size here; on only when > 1
  bool is_sgm = false;    ///< band SGM here (else box sums: census_match)
  bool right_map = false; ///< the right view's map is made here (both views are matched)
  int sgm_band = 0;       ///< band SGM: most candidates of a pixel (0 without SGM)
  int sgm_stride = 0;     ///< band SGM: entries per pixel slot
  /// Band SGM: costs in bytes (sgm_byte_costs() of the level's box and the census).
  bool sgm_byte_costs = false;
  /// Band SGM on the cpu backend: rows of a segment (cpu::sgm_segmented()); 0: the whole volume.
  int sgm_segment_rows = 0;
  /// The temporal prior narrows this level's search (StereoParams::temporal; a level with a coarser
  /// prior whose radius exceeds the temporal radius): it keeps its maps of the previous frame.
  bool temporal = false;
  int range() const { return dmax - dmin + 1; }
  /// Entries of the level's SGM volume: the whole level's or a segment's.
  std::size_t sgm_storage_entries() const {
    return SgmVolume::entries_for(width, sgm_segment_rows > 0 ? sgm_segment_rows : height, sgm_band);
  }
  /// Rows of the mirrored codes: a segment's and the box's margins, or the level's (0).
  int sgm_mirror_rows() const {
    return sgm_segment_rows > 0 ? std::min(height, sgm_segment_rows + 2 * (shd_window / 2)) : 0;
  }
  /// The views whose maps of the previous frame the temporal prior reads: the left one under SGM
  /// (the band is the left view's), every matched view with box sums.
  int temporal_views() const { return !temporal ? 0 : is_sgm ? 1 : right_map ? 2 : 1; }
};

struct LevelPlan {
  std::vector<Size2> working;     ///< the input size, then each working-scale reduction
  std::vector<LevelSpec> levels;  ///< levels[0] is the finest (the working scale)
  int census_words = 1;
  std::size_t sgm_entries = 0;     ///< band SGM: cost (and sum) entries of the largest volume
  std::size_t sgm_cost_bytes = 0;  ///< band SGM: bytes of the largest volume's costs
  std::size_t sgm_row_state_bytes = 0;  ///< band SGM in segments: the largest level's row states
  int sgm_max_stride = 16;      ///< band SGM: the widest slot
  int sgm_levels = 0;           ///< levels that aggregate by SGM (the coarsest ones)
  int box_range = 0;            ///< most disparities of a box level (0: none)
  const LevelSpec& finest() const { return levels.front(); }
  /// The level whose winners' margins the confidence takes: the finest, or under SGM with box
  /// levels the finest SGM level (its margins replicated 2^margin_level times).
  int margin_level() const { return sgm_levels > 0 ? static_cast<int>(levels.size()) - sgm_levels : 0; }
  /// The largest SGM level (its width sizes the SGM stages' scratch); only when sgm_levels > 0.
  const LevelSpec& finest_sgm() const { return levels[levels.size() - static_cast<std::size_t>(sgm_levels)]; }
};

/// The temporal prior's hand-over between frames, for the host driver and the OpenCL pipeline
/// alike: the last frame's maps and images of the levels it narrows become this frame's previous
/// ones, by swaps (the planes this frame writes next held the frame before). Level: a LevelSpec
/// with disparity[], previous[], image[] and previous_image[]; finest_image(v): level 0's image of
/// view v (the last working-scale reduction, which the level does not hold itself).
template <class Level, class FinestImage>
void swap_in_previous_maps(std::vector<Level>& levels, FinestImage finest_image) {
  for (std::size_t l = 0; l < levels.size(); ++l) {
    Level& L = levels[l];
    for (int v = 0; v < L.temporal_views(); ++v) {
      std::swap(L.disparity[v], L.previous[v]);
      std::swap(l == 0 ? finest_image(v) : L.image[v], L.previous_image[v]);
    }
  }
}

/// The band width of a level for SGM: its whole range at the coarsest level, else at most
/// max_band; never more than the candidates a pixel of the level can have (its width).
inline int sgm_band_width(const StereoParams& p, int dmin, int dmax, int width, bool coarsest) {
  const int range = std::min(dmax - dmin + 1, width);
  return coarsest ? range : std::min(range, p.sgm_max_band);
}

/// Bytes of the costs and sums of `rows` rows of a band SGM level.
inline std::size_t sgm_volume_bytes(const LevelSpec& L, int rows) {
  return SgmVolume::entries_for(L.width, rows, L.sgm_band) * (L.sgm_byte_costs ? 3 : 4);
}

/// Fewest rows of a segment. Every segment costs a few passes over short runs of rows: quality at
/// 1280 x 720 with 256 disparities and 2 threads matched in 80-95 ms with segments of 32 rows and
/// 90 ms with 22 (the fewest bytes), against 51-61 ms whole; 48 and 64 rows were no faster than 32
/// within this machine's noise (measured before a segment's second pass ran in two sweeps on
/// 2 threads).
inline constexpr int kMinSegmentRows = 32;

/// Rows per segment of the largest SGM level: the fewest bytes of one segment's costs and sums
/// and of the row states (a checkpoint of 2 bytes per entry of a row per segment), at least
/// kMinSegmentRows.
inline int sgm_segment_rows_for(const LevelSpec& L) {
  const std::size_t per_row = sgm_volume_bytes(L, 1), state = SgmVolume::entries_for(L.width, 1, L.sgm_band) * 2;
  int best = L.height;
  std::size_t best_bytes = sgm_volume_bytes(L, L.height);
  for (int rows = std::min(kMinSegmentRows, L.height); rows < L.height; ++rows) {
    const std::size_t bytes = rows * per_row + static_cast<std::size_t>((L.height + rows - 1) / rows) * state;
    if (bytes < best_bytes) best = rows, best_bytes = bytes;
  }
  return best;
}

/// Band SGM with 4 paths on the cpu backend, when the largest level's costs and sums exceed
/// `limit` bytes: that level in segments of sgm_segment_rows_for() rows, and every other level
/// whose volume does not fit the storage of one such segment in segments that do.
inline void plan_sgm_segments(const StereoParams& p, std::size_t limit, LevelPlan& plan) {
  if (plan.sgm_levels == 0 || p.sgm_paths() != 4) return;
  const LevelSpec* largest = nullptr;
  for (const LevelSpec& L : plan.levels)
    if (L.is_sgm && (largest == nullptr || sgm_volume_bytes(L, L.height) > sgm_volume_bytes(*largest, largest->height)))
      largest = &L;
  if (sgm_volume_bytes(*largest, largest->height) <= limit) return;
  const std::size_t storage = sgm_volume_bytes(*largest, sgm_segment_rows_for(*largest));
  plan.sgm_entries = plan.sgm_cost_bytes = 0;
  for (LevelSpec& L : plan.levels) {
    if (!L.is_sgm) continue;
    if (sgm_volume_bytes(L, L.height) > storage) {
      L.sgm_segment_rows = std::clamp(static_cast<int>(storage / sgm_volume_bytes(L, 1)), 1, L.height);
      plan.sgm_row_state_bytes = std::max(
          plan.sgm_row_state_bytes, cpu::sgm_row_state_bytes(L.width, L.height, L.sgm_stride, L.sgm_segment_rows));
    }
    plan.sgm_entries = std::max(plan.sgm_entries, L.sgm_storage_entries());
    plan.sgm_cost_bytes = std::max(plan.sgm_cost_bytes, L.sgm_storage_entries() * (L.sgm_byte_costs ? 1 : 2));
  }
}

/// The plan of a width x height frame with valid parameters p; need_right: the right view is
/// matched at the finest level (LR check or the right map asked for); sgm_volume_limit: the cpu
/// backend's MatcherOptions::sgm_volume_limit (the most bytes of a whole SGM volume; the other
/// backends keep whole volumes).
inline LevelPlan plan_levels(const StereoParams& p, int width, int height, bool need_right,
                             std::size_t sgm_volume_limit = SIZE_MAX) {
  LevelPlan plan;
  plan.census_words = census_words(p.census_window);
  const int scale_steps = log2_exact(p.working_scale);
  int lw = width, lh = height;
  for (int s = 0; s <= scale_steps; ++s) {
    plan.working.push_back({lw, lh});
    if (s < scale_steps) lw = (lw + 1) / 2, lh = (lh + 1) / 2;
  }
  for (int l = 0; l < p.pyramid_levels; ++l) {
    LevelSpec L;
    L.width = lw;
    L.height = lh;
    L.scale_log2 = scale_steps + l;
    L.dmin = level_min(p.min_disparity, L.scale_log2);
    L.dmax = level_dmax(p, l, L.scale_log2);
    L.shd_window = l == 0 ? p.shd_window : p.coarse_shd_window;
    L.radius = l == 0 ? p.finest_radius() : p.search_radius;
    L.refine = l == 0 || p.refine_all_levels;
    L.coarsest = l + 1 == p.pyramid_levels;
    L.speckle = p.speckle_size >> (2 * L.scale_log2);
    L.temporal = p.temporal && !L.coarsest && p.temporal_radius < L.radius;
    L.is_sgm = p.sgm_at(l);
    if (L.is_sgm) {
      L.sgm_band = sgm_band_width(p, L.dmin, L.dmax, lw, L.coarsest);
      L.sgm_stride = SgmVolume::stride_for(L.sgm_band);
      L.sgm_byte_costs = sgm_byte_costs(L.shd_window, p.census_window);
      const std::size_t entries = SgmVolume::entries_for(lw, lh, L.sgm_band);
      plan.sgm_entries = std::max(plan.sgm_entries, entries);
      plan.sgm_cost_bytes = std::max(plan.sgm_cost_bytes, entries * (L.sgm_byte_costs ? 1 : 2));
      plan.sgm_max_stride = std::max(plan.sgm_max_stride, L.sgm_stride);
      ++plan.sgm_levels;
    } else {
      plan.box_range = std::max(plan.box_range, L.range());
    }
    // The right view's map: at the finest level for the LR check, at a level that refines (its
    // own LR check), and wherever the finer level matches both views with box sums (the right
    // view searches around it). SGM takes a finer level's band from the left map alone.
    const bool finer_box = l > 0 && !plan.levels.back().is_sgm;
    L.right_map = need_right && (l == 0 || L.refine || finer_box || !L.is_sgm);
    plan.levels.push_back(L);
    lw = (lw + 1) / 2;
    lh = (lh + 1) / 2;
  }
  plan_sgm_segments(p, sgm_volume_limit, plan);
  return plan;
}

}  // namespace mctstereo::detail
