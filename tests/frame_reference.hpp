// The whole frame as docs/PIPELINE.md ("Recipe of one frame") states it, in plain loops over the
// reference stages, written apart from the driver (src/matcher.cpp) and from the plan of the
// levels (src/level_plan.hpp): the backends are compared with it, so that a bug in the driver
// (a flag not passed, a stage skipped or run in the wrong order, the wrong view or level) shows
// as a difference. It allocates per call and favours plainness over speed.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "mctstereo/matcher.hpp"
#include "plane.hpp"
#include "stages.hpp"
#include "pipeline_cases.hpp"

namespace mctstereo::test {

/// What a frame gives the caller, in the Matcher's conventions.
struct FrameResult {
  Plane<std::int16_t> left, right;  ///< Q4 at the input size, invalid = (dmin - 1) x 16; right: compute_right only
  Plane<float> confidence;          ///< [0, 1] at the input size; empty without a confidence map
};

namespace frame_reference_detail {

namespace ref = detail::reference;
using detail::CensusCodes;

/// One level of the recipe: its images, codes and maps.
struct RecipeLevel {
  int width = 0, height = 0, scale_log2 = 0, dmin = 0, dmax = 0;
  Plane<std::uint8_t> image[2];
  CensusCodes codes[2];
  Plane<std::int16_t> map[2];
};

template <typename T>
Plane<T> copy_of(const Plane<T>& src) {
  Plane<T> out(src.width(), src.height());
  for (int y = 0; y < src.height(); ++y) std::copy_n(src.row(y), src.width(), out.row(y));
  return out;
}

inline Plane<std::int16_t> median_of(const Plane<std::int16_t>& src, int k) {
  Plane<std::int16_t> out(src.width(), src.height());
  ref::median_filter(src, k, out);
  return out;
}

// The left map's LR partners on the right map's grid (StereoParams::lr_check_grid), built as the
// parameter describes it: the raw right map's even rows and columns as a half-size map, its
// median there, and each of its pixels spread over the 2 x 2 pixels it stands for.
inline Plane<std::int16_t> grid_partners_of(const Plane<std::int16_t>& right, int median_size) {
  const int w = right.width(), h = right.height();
  Plane<std::int16_t> grid((w + 1) / 2, (h + 1) / 2);
  for (int j = 0; j < grid.height(); ++j)
    for (int i = 0; i < grid.width(); ++i) grid.at(i, j) = right.at(2 * i, 2 * j);
  if (median_size > 0) grid = median_of(grid, median_size);
  Plane<std::int16_t> partners(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) partners.at(x, y) = grid.at(x / 2, y / 2);
  return partners;
}

inline CensusCodes census_of(const Plane<std::uint8_t>& image, const StereoParams& p) {
  CensusCodes codes;
  codes.words = detail::census_words(p.census_window);
  for (int k = 0; k < codes.words; ++k) codes.plane[k].reset(image.width(), image.height(), detail::kCodePad);
  ref::census_transform(image, {p.census, p.census_window, p.mct_kernel}, codes);
  return codes;
}

/// Box aggregation at one level: each needed view searches around the coarser map of the same view.
inline void match_box(RecipeLevel& L, const RecipeLevel* coarser, const StereoParams& p, bool finest, int views,
                      Plane<std::uint8_t>* margin) {
  const int window = finest ? p.shd_window : p.coarse_shd_window;
  const int radius = finest ? p.finest_radius() : p.search_radius;
  for (int v = 0; v < views; ++v) {
    detail::MatchScratch scratch;
    scratch.bytes_per_thread = ref::match_scratch_bytes(L.width, L.dmax - L.dmin + 1, window);
    scratch.data = detail::allocate_aligned<std::uint8_t>(scratch.bytes_per_thread);
    const auto ranges = detail::SearchRanges::around(coarser ? &coarser->map[v] : nullptr, L.dmin, L.dmax, radius);
    const detail::MatchConfig config{v == 0 ? -1 : +1, window, p.subpixel && finest, p.uniqueness_ratio};
    L.map[v].reset(L.width, L.height);
    ref::match(L.codes[v], L.codes[1 - v], ranges, config, scratch, L.map[v], v == 0 ? margin : nullptr);
  }
}

/// Band SGM at one level: the band around the coarser left map, the paths, both views' winners.
inline void match_band_sgm(RecipeLevel& L, const RecipeLevel* coarser, const StereoParams& p, bool finest,
                           bool right_map, Plane<std::uint8_t>* margin) {
  const int range = std::min(L.dmax - L.dmin + 1, L.width);
  const int band = coarser == nullptr ? range : std::min(range, p.sgm_max_band);
  const int window = finest ? p.shd_window : p.coarse_shd_window;
  const int radius = finest ? p.finest_radius() : p.search_radius;
  const std::size_t entries = detail::SgmVolume::entries_for(L.width, L.height, band);
  auto cost = detail::allocate_aligned<std::uint16_t>(std::max<std::size_t>(entries, 1));
  auto sum = detail::allocate_aligned<std::uint16_t>(std::max<std::size_t>(entries, 1));
  detail::SgmVolume volume;
  volume.reset(L.width, L.height, band, L.codes[0].words, cost.get(), sum.get());
  detail::SgmScratch scratch;
  scratch.bytes_per_thread = ref::sgm_scratch_bytes(L.width, L.height, volume.stride) + 64;
  scratch.data = detail::allocate_aligned<std::uint8_t>(scratch.bytes_per_thread);
  const detail::SgmBandConfig band_config{L.dmin, L.dmax, radius, p.prior_size, band};
  ref::sgm_costs(L.codes[0], L.codes[1], coarser ? &coarser->map[0] : nullptr, band_config, window, scratch, volume);
  ref::sgm_aggregate(L.image[0], {p.sgm_paths(), p.sgm_p1, p.sgm_p2, p.sgm_p2_k}, scratch, volume);
  for (int v = 0; v < (right_map ? 2 : 1); ++v) L.map[v].reset(L.width, L.height);
  ref::sgm_select(volume, {p.subpixel && finest, p.uniqueness_ratio}, scratch, L.map[0],
                  right_map ? &L.map[1] : nullptr, margin);
}

}  // namespace frame_reference_detail

/// The frame of `left` and `right` (same size, any formats) with parameters p (valid for the size).
inline FrameResult reference_frame(const ImageView& left, const ImageView& right, const StereoParams& p,
                                   const MatcherOptions& options = {}) {
  namespace fr = frame_reference_detail;
  namespace ref = detail::reference;
  const int width = left.width, height = left.height;
  const bool need_right = p.lr_check || options.compute_right;
  const int views = need_right ? 2 : 1;
  const bool want_confidence = p.sgm() || options.compute_confidence;

  // Gray, the working-scale reductions and the levels: level 0 is the last reduction.
  const ImageView* input[2] = {&left, &right};
  std::vector<Plane<std::uint8_t>> working[2];
  int steps = 0;
  while ((1 << steps) < p.working_scale) ++steps;
  for (int v = 0; v < 2; ++v) {
    working[v].emplace_back(width, height);
    ref::to_gray(*input[v], working[v].back());
    for (int s = 0; s < steps; ++s) {
      const Plane<std::uint8_t>& src = working[v].back();
      Plane<std::uint8_t> dst((src.width() + 1) / 2, (src.height() + 1) / 2);
      ref::pyramid_down(src, dst);
      working[v].push_back(std::move(dst));
    }
  }
  std::vector<fr::RecipeLevel> levels(p.pyramid_levels);
  for (int l = 0; l < p.pyramid_levels; ++l) {
    fr::RecipeLevel& L = levels[l];
    for (int v = 0; v < 2; ++v) {
      if (l == 0) {
        L.image[v] = fr::copy_of(working[v].back());
      } else {
        const Plane<std::uint8_t>& finer = levels[l - 1].image[v];
        L.image[v].reset((finer.width() + 1) / 2, (finer.height() + 1) / 2);
        ref::pyramid_down(finer, L.image[v]);
      }
    }
    L.width = L.image[0].width();
    L.height = L.image[0].height();
    L.scale_log2 = steps + l;
    L.dmin = detail::level_min(p.min_disparity, L.scale_log2);
    L.dmax = detail::level_dmax(p, l, L.scale_log2);
  }
  const int w0 = levels[0].width, h0 = levels[0].height;

  // The colour of the weighted median: the left view's channels at the working scale.
  detail::ColourPlanes colour;
  std::vector<std::array<Plane<std::uint8_t>, 3>> channels(1);
  if (p.weighted_median && left.format != PixelFormat::Gray8) {
    for (auto& c : channels[0]) c.reset(width, height);
    ref::split_channels(left, channels[0]);
    for (int s = 0; s < steps; ++s) {
      std::array<Plane<std::uint8_t>, 3> reduced;
      for (int c = 0; c < 3; ++c) {
        reduced[c].reset((channels.back()[c].width() + 1) / 2, (channels.back()[c].height() + 1) / 2);
        ref::pyramid_down(channels.back()[c], reduced[c]);
      }
      channels.push_back(std::move(reduced));
    }
    colour.channels = 3;
    for (int c = 0; c < 3; ++c) colour.plane[c] = &channels.back()[c];
  } else {
    colour.channels = 1;
    for (int c = 0; c < 3; ++c) colour.plane[c] = &levels[0].image[0];
  }

  // The confidence takes the winners' margins of the finest level, or with box levels under band
  // SGM those of the finest SGM level, replicated.
  int margin_level = 0;
  if (p.sgm())
    while (!p.sgm_at(margin_level)) ++margin_level;
  Plane<std::uint8_t> margin(levels[margin_level].width, levels[margin_level].height), confidence_q8(w0, h0);
  detail::SpeckleScratch speckle;
  speckle.label.reset(w0, h0);
  speckle.stack = detail::allocate_aligned<std::int32_t>(static_cast<std::size_t>(w0) * h0);
  for (int l = p.pyramid_levels - 1; l >= 0; --l) {
    fr::RecipeLevel& L = levels[l];
    const fr::RecipeLevel* coarser = l + 1 < p.pyramid_levels ? &levels[l + 1] : nullptr;
    const bool finest = l == 0;
    for (int v = 0; v < 2; ++v) L.codes[v] = fr::census_of(L.image[v], p);
    Plane<std::uint8_t>* level_margin = l == margin_level && want_confidence ? &margin : nullptr;
    if (p.sgm_at(l))
      fr::match_band_sgm(L, coarser, p, finest, need_right, level_margin);
    else
      fr::match_box(L, coarser, p, finest, views, level_margin);
    if (!finest && !p.refine_all_levels) continue;

    // Refinement. At the finest level the right map only serves the LR check unless asked for.
    const int kept = finest && !options.compute_right ? 1 : views;
    // With the LR check on the grid, the left map is checked against (and the confidence reads)
    // the raw right map's partners instead of its median.
    const bool grid = finest && p.lr_check && p.lr_check_grid;
    const Plane<std::int16_t> partners = grid ? fr::grid_partners_of(L.map[1], p.median_size) : Plane<std::int16_t>();
    if (p.median_size > 0)
      for (int v = 0; v < views; ++v) L.map[v] = fr::median_of(L.map[v], p.median_size);
    if (p.lr_check) {
      Plane<std::int16_t> checked[2];
      for (int v = 0; v < kept; ++v) {
        checked[v].reset(L.width, L.height);
        ref::lr_check(L.map[v], v == 0 && grid ? partners : L.map[1 - v], v == 0 ? -1 : +1, 16 * p.lr_threshold,
                      checked[v]);
      }
      for (int v = 0; v < kept; ++v) L.map[v] = std::move(checked[v]);
    }
    const int speckle_size = p.speckle_size >> (2 * L.scale_log2);
    if (speckle_size > 1)
      for (int v = 0; v < kept; ++v) ref::remove_speckles(L.map[v], speckle_size, 16, speckle);
    if (finest && want_confidence)
      ref::confidence(margin, margin_level, L.map[0], !need_right ? nullptr : grid ? &partners : &L.map[1],
                      p.lr_threshold, confidence_q8);
    for (int v = 0; v < kept; ++v) ref::fill_invalid(L.map[v], p.fill);
    int first_post = 0;
    if (finest && p.weighted_median) {
      detail::WeightedMedianConfig config;
      config.radius = p.wm_radius;
      config.step = p.wm_step;
      config.lut = detail::weighted_median_lut(p.wm_sigma);
      Plane<std::int16_t> weighted(L.width, L.height);
      ref::weighted_median(L.map[0], colour, config, weighted);
      L.map[0] = fr::median_of(weighted, 3);
      first_post = 1;
    }
    if (p.post_median_size > 0)
      for (int v = first_post; v < kept; ++v) L.map[v] = fr::median_of(L.map[v], p.post_median_size);
  }

  // Up-scaling and the output conventions.
  FrameResult result;
  const std::int16_t invalid = static_cast<std::int16_t>((p.min_disparity - 1) * kDisparityScale);
  for (int v = 0; v < (options.compute_right ? 2 : 1); ++v) {
    Plane<std::int16_t> map = fr::copy_of(levels[0].map[v]);
    if (p.working_scale > 1) {
      Plane<std::int16_t> up(width, height);
      ref::upscale(map, p.working_scale, 16 * p.min_disparity, 16 * p.max_disparity(), up);
      map = std::move(up);
    }
    Plane<std::int16_t>& out = v == 0 ? result.left : result.right;
    out.reset(width, height);
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) out.at(x, y) = map.at(x, y) == detail::kInvalid ? invalid : map.at(x, y);
  }
  if (want_confidence) {
    const int s = p.working_scale;
    result.confidence.reset(width, height);
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x)
        result.confidence.at(x, y) =
            confidence_q8.at(std::min(x / s, w0 - 1), std::min(y / s, h0 - 1)) * (1.0f / 255.0f);
  }
  return result;
}

/// "" when the matcher's last frame equals the recipe's bit for bit (left map, right map with
/// compute_right, confidence when the recipe has one), else where they first differ.
inline std::string difference_from_recipe(const Matcher& m, const FrameResult& expected, const MatcherOptions& options) {
  const int w = expected.left.width();
  std::string diff = describe_difference(pixels(m.disparity_q4()), pixels(expected.left), w);
  if (!diff.empty()) return "left map " + diff;
  if (options.compute_right) {
    diff = describe_difference(pixels(m.right_disparity_q4()), pixels(expected.right), w);
    if (!diff.empty()) return "right map " + diff;
  }
  const MapView<const float> c = m.confidence();
  if (expected.confidence.empty()) return c.data == nullptr ? "" : "a confidence map the recipe does not make";
  if (c.data == nullptr) return "no confidence map";
  for (int y = 0; y < c.height; ++y)
    for (int x = 0; x < c.width; ++x)
      if (std::memcmp(&c.row(y)[x], &expected.confidence.at(x, y), sizeof(float)) != 0)
        return "confidence at (" + std::to_string(x) + ", " + std::to_string(y) + "): " +
               std::to_string(c.row(y)[x]) + " vs " + std::to_string(expected.confidence.at(x, y));
  return {};
}

}  // namespace mctstereo::test
