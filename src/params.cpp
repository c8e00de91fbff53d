#include "mctstereo/params.hpp"

#include <algorithm>
#include <sstream>
#include <stdexcept>

namespace mctstereo {

namespace {

bool is_one_of(int v, std::initializer_list<int> allowed) {
  for (int a : allowed)
    if (v == a) return true;
  return false;
}

struct PresetEntry {
  const char* name;
  const char* description;
  StereoParams (*make)();
};

StereoParams make_realtime() {
  StereoParams p;
  p.census = CensusKind::Census;
  p.census_window = 5;
  p.shd_window = 5;
  // A 5x5 window at the coarse levels gives cleaner priors, hence narrower searches at the finest
  // level: faster overall than a 3x3 one, and radius 1 then loses nothing on Middlebury.
  p.coarse_shd_window = 5;
  // Four levels: the coarsest full search is then 4 times smaller than with three, and the average
  // Middlebury score barely moves (10.85 -> 10.96 %); the median after filling buys it back.
  p.pyramid_levels = 4;
  p.search_radius = 1;
  p.subpixel = true;
  p.median_size = 3;
  p.lr_check = true;
  p.speckle_size = 0;
  p.post_median_size = 3;
  p.fill = FillMode::NearestLower;
  p.refine_all_levels = false;  // measured no worse on Middlebury than refining every level
  // The LR check against the right map on the grid of even rows and columns, its median on that
  // grid: better on Middlebury (2003 10.78 -> 10.56 %, 2005/2006 15.85 -> 15.45) than against the
  // whole right map.
  p.lr_check_grid = true;
  return p;
}

// Band SGM as docs/PIPELINE.md gives it: CT 5x5, a 3x3 box for the cost, 4 paths with adaptive P2,
// the 5x5 prior, uniqueness 10 %, median 3, LR check, speckle removal and the background fill, at
// the finest level only.
// P1 60, P2 200, k 16 came out best of P1 20/40/60 x P2 200/300/500 x k 4/8/16 on Middlebury 2003
// (7.77 % against 7.93 % for 40/300/8 with sub-pixel on), and better on 2005/2006 too. Sub-pixel
// is off: on ground truth in whole pixels it turns pixels off by one into errors beyond one
// (+0.2-0.3 points on 2003, +2 on 2005/2006); --subpixel turns it on where depth precision matters.
StereoParams make_band_sgm() {
  StereoParams p;
  p.census = CensusKind::Census;
  p.census_window = 5;
  p.aggregation = Aggregation::Sgm4;
  p.shd_window = 3;
  p.coarse_shd_window = 3;
  p.sgm_p1 = 60;
  p.sgm_p2 = 200;
  p.sgm_p2_k = 16;
  p.subpixel = false;
  p.prior_size = 5;
  // 16 candidates per pixel at the finer levels: half the memory and time of 32 for 0.2 points.
  p.sgm_max_band = 16;
  p.pyramid_levels = 3;
  p.search_radius = 3;
  p.uniqueness_ratio = 10;
  // Refined at the finest level only, with a 3x3 median before the LR check. A coarse map left
  // unrefined keeps its uncertain pixels invalid, and an invalid prior gives the finer level the
  // whole (max_band) range there instead of a band around a filled-in guess: balanced 5.82 % on
  // Middlebury 2003 and 10.91 on 2005/2006 against 6.39 and 12.83 when every level was refined
  // with a 5x5 median (median 0 or 5 at the finest level: within 0.15 points of 3), and the
  // coarse levels skip their refinement and their right view.
  p.median_size = 3;
  p.lr_check = true;
  p.speckle_size = 100;
  p.fill = FillMode::NearestLower;
  p.post_median_size = 5;
  p.refine_all_levels = false;
  return p;
}

// The colour-weighted median after the fill (docs/PIPELINE.md, "Colour-weighted median"), with its
// 3x3 median in place of the post-fill median 5 at the finest level. Radius 6, step 2 (7 x 7
// samples), sigma 15 came out best of radius 4..15, steps 1..5, sigma 3..30 over Middlebury 2003
// and 2005/2006 together (docs/RESULTS.md): the design's radius 9, step 3, sigma 10 is as good on
// 2003 (balanced 6.27 %) but worse than no median at all on the full-size 2005/2006 images
// (13.24 % against 13.18 %), whose fine structures a 19 x 19 window wipes out.
void add_weighted_median(StereoParams& p) {
  p.weighted_median = true;
  p.wm_radius = 6;
  p.wm_step = 2;
  p.wm_sigma = 15;
}

// Band SGM at the coarsest level, local matching at the two finer ones (box_levels 2): the SGM map
// gives the finer levels a band that box sums of 3 x 3 resolve, and the weighted median keeps the
// edges. Without the uniqueness test every coarse prior is valid, so no pixel of a box level falls
// back to the whole range. On Middlebury 2003 and 2005/2006 (docs/PIPELINE.md, "Box sums at the
// finest levels"): 6.26 % and 10.12 %, against 5.80 and 10.04 with SGM at the middle level too
// (box_levels 1) and 49 weighted-median samples, in two thirds of the frame time (640 x 480, 64
// disparities, 2 threads: 1.69 x StereoBM's frame rate against 1.15 x). SGM at every level with the
// uniqueness test scored 5.82 and 10.91 in twice the time of box_levels 1. The weighted median
// samples 5 x 5 (radius 6, step 3): as good as 7 x 7 behind the box levels (6.19 and 10.17 with
// step 2) in half its time. The box levels search radius 2 around the coarser map (5 candidates
// where it is flat) and the speckle removal takes regions under 50 px: the box levels' wrong
// regions are smaller than SGM's, and the 100 px of the SGM presets also took away right ones.
// Both sets gain (6.13 % and 9.72 %, against 6.26 and 10.12 with radius 3 and 100 px; 6.01 and
// 9.78 with radius 3 and 50 px; 6.38 and 9.98 with radius 2 and 100 px) and the frame some 5 %
// shorter (docs/PIPELINE.md, "Box sums at the finest levels").
StereoParams make_balanced() {
  StereoParams p = make_band_sgm();
  p.box_levels = 2;
  p.uniqueness_ratio = 0;
  p.search_radius = 2;
  p.speckle_size = 50;
  add_weighted_median(p);
  p.wm_step = 3;
  return p;
}

// Band SGM at the two coarser levels, box sums at the finest (box_levels 1), the weighted median's
// 7 x 7 samples. The middle level's band takes up to 32 candidates (search radius 3 around the 5x5
// prior), the finest level radius 2 around it. On Middlebury 2003 and 2005/2006: 5.86 % and 9.28 %
// in 5.3 ms a frame (640 x 480, 64 disparities, 2 threads: 2.4 x StereoSGBM's frame rate), against
// 5.43 and 9.60 in 15 ms (0.85 x StereoSGBM) with SGM at every level, the finest at radius 6 (32
// candidates), uniqueness 10 % and speckles under 100 px: that configuration is
// `--box-levels 0 --finest-radius 6 --uniqueness 10 --speckle-size 100` on top of this preset
// (docs/PIPELINE.md, "Box sums at the finest levels"). At the finest level: radius 3 gave 5.75 and
// 9.49, radius 1 6.46 and 9.42; with the SGM presets' uniqueness 10 % 6.35 and 9.69; middle
// bands of at most 16 candidates 5.84 and 10.04, of 48 5.86 and 9.13 in more memory; 8 paths 6.07
// and 9.68.
StereoParams make_quality() {
  StereoParams p = make_band_sgm();
  p.box_levels = 1;
  p.finest_search_radius = 2;
  p.sgm_max_band = 32;
  p.uniqueness_ratio = 0;
  p.speckle_size = 50;
  add_weighted_median(p);
  return p;
}

// One level, the whole range, 4 paths: what the band costs in quality is measured against this.
StereoParams make_sgm_full() {
  StereoParams p = make_band_sgm();
  p.pyramid_levels = 1;
  return p;
}

// The thesis's variants keep its refinement (median, LR check, fill; no speckle removal).
StereoParams make_mct_full() {
  StereoParams p;
  p.census = CensusKind::ModifiedCensus;
  p.census_window = 9;
  p.mct_kernel = MeanKernel::Gaussian;
  p.shd_window = 5;
  p.pyramid_levels = 1;
  p.median_size = 5;
  p.lr_check = true;
  p.speckle_size = 0;
  p.post_median_size = 5;
  p.fill = FillMode::NearestLower;
  return p;
}

StereoParams make_mr_mct_full() {
  StereoParams p = make_mct_full();
  p.pyramid_levels = 3;
  p.search_radius = 4;
  return p;
}

StereoParams make_mr_mct_5x5() {
  StereoParams p = make_mr_mct_full();
  p.census_window = 5;
  p.search_radius = 3;
  return p;
}

constexpr PresetEntry kPresets[] = {
    {"realtime", "CT 5x5, 4 levels, search radius 1, median 3, LR check on the right map's grid of even rows and columns (the right view matched at its even rows) and median 3 after filling at the finest level: the fastest preset, for robots and AR",
     make_realtime},
    {"balanced", "band SGM at the coarsest of 3 levels (CT 5x5, 4 paths), local 3x3 box matching around the coarser level's map at the two finer levels (radius 2), then median 3, LR check, removal of speckles under 50 px, fill, colour-weighted median (5 x 5 samples): the default",
     make_balanced},
    {"quality", "band SGM at the two coarser of 3 levels (CT 5x5, 4 paths, 5x5 prior, radius 3, up to 32 candidates), local 3x3 box matching at the finest level (radius 2), then median 3, LR check, removal of speckles under 50 px, fill, colour-weighted median (7 x 7 samples): the best maps",
     make_quality},
    {"sgm-full", "SGM over the whole range at one level, 4 paths, the penalties and refinement of quality (without the weighted median): the yardstick of what the band costs",
     make_sgm_full},
    {"mct-full", "thesis MCT-full: MCT 9x9 (Gaussian mean), one level with the full search", make_mct_full},
    {"mr-mct-full", "thesis MR-MCT-full: MCT 9x9 (Gaussian mean), 3 levels, search radius 4", make_mr_mct_full},
    {"mr-mct-5x5", "thesis MR-MCT-5x5: MCT 5x5 (Gaussian mean), 3 levels", make_mr_mct_5x5},
};

const PresetEntry* find_preset(std::string_view name) {
  for (const auto& e : kPresets)
    if (name == e.name) return &e;
  return nullptr;
}

std::string known_presets() {
  std::string s;
  for (const auto& e : kPresets) s += (s.empty() ? "" : ", ") + std::string(e.name);
  return s;
}

}  // namespace

StereoParams preset(std::string_view name) {
  const PresetEntry* e = find_preset(name);
  if (!e) throw std::invalid_argument("unknown preset '" + std::string(name) + "' (known: " + known_presets() + ")");
  return e->make();
}

const std::vector<std::string>& preset_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> v;
    for (const auto& e : kPresets) v.emplace_back(e.name);
    return v;
  }();
  return names;
}

std::string_view preset_description(std::string_view name) {
  const PresetEntry* e = find_preset(name);
  return e ? e->description : "";
}

std::string StereoParams::validate() const {
  std::ostringstream err;
  auto fail = [&](const std::string& msg) { err << (err.tellp() > 0 ? "\n" : "") << msg; };
  if (min_disparity < -1024 || min_disparity > 1024)
    fail("min_disparity = " + std::to_string(min_disparity) + " is outside [-1024, 1024]");
  if (num_disparities < 1 || num_disparities > 2048)
    fail("num_disparities = " + std::to_string(num_disparities) + " must be in [1, 2048]");
  else if (static_cast<long long>(min_disparity) + num_disparities - 1 > 2039)  // in 64 bits: any int is checked
    fail("min_disparity + num_disparities - 1 = " +
         std::to_string(static_cast<long long>(min_disparity) + num_disparities - 1) +
         " must be at most 2039 (the Q4 int16 output)");
  if (!is_one_of(census_window, {3, 5, 7, 9}))
    fail("census_window = " + std::to_string(census_window) + " must be 3, 5, 7 or 9");
  if (!is_one_of(shd_window, {1, 3, 5, 7, 9}))
    fail("shd_window = " + std::to_string(shd_window) + " must be 1, 3, 5, 7 or 9");
  if (!is_one_of(coarse_shd_window, {1, 3, 5, 7, 9}))
    fail("coarse_shd_window = " + std::to_string(coarse_shd_window) + " must be 1, 3, 5, 7 or 9");
  if (pyramid_levels < 1 || pyramid_levels > 5)
    fail("pyramid_levels = " + std::to_string(pyramid_levels) + " must be in [1, 5]");
  if (search_radius < 0 || search_radius > 16)
    fail("search_radius = " + std::to_string(search_radius) + " must be in [0, 16]");
  if (!is_one_of(median_size, {0, 3, 5}))
    fail("median_size = " + std::to_string(median_size) + " must be 0 (off), 3 or 5");
  if (!is_one_of(post_median_size, {0, 3, 5}))
    fail("post_median_size = " + std::to_string(post_median_size) + " must be 0 (off), 3 or 5");
  if (lr_threshold < 0 || lr_threshold > 16)
    fail("lr_threshold = " + std::to_string(lr_threshold) + " must be in [0, 16]");
  if (speckle_size < 0 || speckle_size > 1000000)
    fail("speckle_size = " + std::to_string(speckle_size) + " must be in [0, 1000000]");
  if (uniqueness_ratio < 0 || uniqueness_ratio > 100)
    fail("uniqueness_ratio = " + std::to_string(uniqueness_ratio) + " must be in [0, 100]");
  if (!is_one_of(working_scale, {1, 2, 4}))
    fail("working_scale = " + std::to_string(working_scale) + " must be 1, 2 or 4");
  if (finest_search_radius < -1 || finest_search_radius > 16)
    fail("finest_search_radius = " + std::to_string(finest_search_radius) + " must be in [-1, 16] (-1: search_radius)");
  if (!is_one_of(prior_size, {3, 5}))
    fail("prior_size = " + std::to_string(prior_size) + " must be 3 or 5");
  else if (prior_size == 5 && !sgm())
    fail("prior_size = 5 needs SGM aggregation (the box matcher searches around the 3x3 prior)");
  if (sgm_p1 < 0 || sgm_p1 > kMaxSgmPenalty)
    fail("sgm_p1 = " + std::to_string(sgm_p1) + " must be in [0, " + std::to_string(kMaxSgmPenalty) + "]");
  if (sgm_p2 < 0 || sgm_p2 > kMaxSgmPenalty)
    fail("sgm_p2 = " + std::to_string(sgm_p2) + " must be in [0, " + std::to_string(kMaxSgmPenalty) + "]");
  else if (sgm_p1 > sgm_p2)
    fail("sgm_p1 = " + std::to_string(sgm_p1) + " must not exceed sgm_p2 = " + std::to_string(sgm_p2));
  if (sgm_p2_k < 0 || sgm_p2_k > 255)
    fail("sgm_p2_k = " + std::to_string(sgm_p2_k) + " must be in [0, 255] (0: constant P2)");
  if (wm_radius < 1 || wm_radius > 15)
    fail("wm_radius = " + std::to_string(wm_radius) + " must be in [1, 15] (pixels)");
  if (wm_step < 1 || wm_step > std::max(1, std::min(wm_radius, 15)))
    fail("wm_step = " + std::to_string(wm_step) + " must be in [1, wm_radius = " + std::to_string(wm_radius) +
         "] (pixels)");
  if (wm_sigma < 1 || wm_sigma > 255)
    fail("wm_sigma = " + std::to_string(wm_sigma) + " must be in [1, 255] (colour levels)");
  if (temporal_radius < 0 || temporal_radius > 16)
    fail("temporal_radius = " + std::to_string(temporal_radius) + " must be in [0, 16] (pixels)");
  if (temporal_threshold < 0 || temporal_threshold > 255)
    fail("temporal_threshold = " + std::to_string(temporal_threshold) + " must be in [0, 255] (gray levels)");
  if (box_levels < 0 || box_levels > 4)
    fail("box_levels = " + std::to_string(box_levels) + " must be in [0, 4]");
  else if (box_levels > 0 && !sgm())
    fail("box_levels = " + std::to_string(box_levels) +
         " needs SGM aggregation (with box aggregation every level matches with box sums)");
  if (sgm_max_band < 1 || sgm_max_band > 255)
    fail("sgm_max_band = " + std::to_string(sgm_max_band) + " must be in [1, 255]");
  if (sgm() && is_one_of(census_window, {3, 5, 7, 9}) && is_one_of(shd_window, {1, 3, 5, 7, 9}) &&
      is_one_of(coarse_shd_window, {1, 3, 5, 7, 9}) && sgm_p2 >= 0 && sgm_p2 <= kMaxSgmPenalty) {
    // Path values stay below C_max + P2 and their sum below paths x (C_max + P2): 16-bit sums, with
    // 65535 kept as the "not a candidate" mark.
    // The SGM levels' cost box: coarse_shd_window alone when the finest level matches locally.
    const int window = sgm_at(0) ? std::max(shd_window, coarse_shd_window) : coarse_shd_window;
    const int c_max = window * window * (census_window * census_window - 1);
    const long long bound = static_cast<long long>(sgm_paths()) * (c_max + sgm_p2);
    if (bound > kMaxSgmSum)
      fail("SGM sums could overflow 16 bits: paths (" + std::to_string(sgm_paths()) + ") x (largest cost " +
           std::to_string(c_max) + " = window " + std::to_string(window) + "^2 x " +
           std::to_string(census_window * census_window - 1) + " census bits, + sgm_p2 " + std::to_string(sgm_p2) +
           ") = " + std::to_string(bound) + " exceeds " + std::to_string(kMaxSgmSum) +
           ": lower sgm_p2, shd_window, coarse_shd_window or census_window, or use 4 paths");
  }
  return err.str();
}

std::string StereoParams::validate(int width, int height) const {
  std::string err = validate();
  auto fail = [&](const std::string& msg) { err += (err.empty() ? "" : "\n") + msg; };
  if (width < 1 || height < 1) {
    fail("image size " + std::to_string(width) + " x " + std::to_string(height) + " must be at least 1 x 1");
    return err;
  }
  if (width > 32768 || height > 32768)
    fail("image size " + std::to_string(width) + " x " + std::to_string(height) + " exceeds 32768 x 32768");
  // A disparity d can only be valid somewhere when |d| < width.
  const long long max_d = static_cast<long long>(min_disparity) + num_disparities - 1;  // any int: no overflow
  if (num_disparities >= 1 && (min_disparity >= width || max_d <= -width))
    fail("disparity range [" + std::to_string(min_disparity) + ", " + std::to_string(max_d) +
         "] does not overlap the image width " + std::to_string(width) + " (|d| must be below the width)");
  else if (num_disparities > width)
    fail("num_disparities = " + std::to_string(num_disparities) + " is wider than the image (" +
         std::to_string(width) + " px)");
  return err;
}

std::string_view to_string(Aggregation aggregation) {
  switch (aggregation) {
    case Aggregation::Box: return "box";
    case Aggregation::Sgm4: return "sgm4";
    case Aggregation::Sgm8: return "sgm8";
  }
  return "?";
}

std::string_view to_string(CensusKind kind) { return kind == CensusKind::Census ? "ct" : "mct"; }
std::string_view to_string(MeanKernel kernel) { return kernel == MeanKernel::Box ? "mean" : "gaussian"; }
std::string_view to_string(FillMode mode) {
  switch (mode) {
    case FillMode::None: return "none";
    case FillMode::Nearest: return "nearest";
    case FillMode::NearestLower: return "nearest-lower";
  }
  return "?";
}

}  // namespace mctstereo
