// mctstereo: parameters of the stereo pipeline, their defaults, presets and validation.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace mctstereo {

/// Which local transform encodes each pixel's neighbourhood.
enum class CensusKind {
  Census,          ///< CT: neighbour compared with the centre pixel.
  ModifiedCensus,  ///< MCT: neighbour compared with the 3x3 (mean or Gaussian) mean around the centre.
};

/// The 3x3 kernel whose weighted sum is the MCT reference value.
enum class MeanKernel {
  Box,       ///< 1 1 1 / 1 1 1 / 1 1 1, weight sum 9.
  Gaussian,  ///< 1 2 1 / 2 4 2 / 1 2 1, weight sum 16.
};

/// How pixels left without a disparity (occluded, mismatched) are filled along their row.
enum class FillMode {
  None,          ///< Leave them invalid (the colour-weighted median, when on, still fills them).
  Nearest,       ///< Nearest valid pixel of the row; the closer side wins, a tie takes the smaller disparity.
  NearestLower,  ///< Smaller of the nearest valid values on the left and on the right (background wins).
};

/// How the matching costs of a level are aggregated before the winner is chosen.
enum class Aggregation {
  Box,   ///< a x a box sums of Hamming distances (the fused local matcher)
  Sgm4,  ///< band SGM: semi-global paths over each pixel's candidate band, 4 paths (rows, columns)
  Sgm8,  ///< band SGM with 8 paths (rows, columns and both diagonals)
};

/// Largest SGM penalty P1 or P2.
inline constexpr int kMaxSgmPenalty = 16383;
/// Largest sum of SGM path values that the 16-bit sums hold (65535 marks a non-candidate).
inline constexpr int kMaxSgmSum = 65534;

/// Every parameter of the pipeline. The defaults are the local (box) pipeline; preset("balanced"),
/// the program's default, is band SGM.
///
/// Disparity d means: the left pixel (x, y) matches the right pixel (x - d, y).
/// All disparities and thresholds are in pixels of the full-resolution input.
struct StereoParams {
  /// Smallest disparity searched, pixels. Range [-1024, 1024]. May be negative.
  int min_disparity = 0;
  /// Number of disparities searched: min_disparity .. min_disparity + num_disparities - 1.
  /// Range [1, 2048], and the largest disparity must stay below 2040 (Q4 output is int16).
  int num_disparities = 64;

  /// CT or MCT.
  CensusKind census = CensusKind::Census;
  /// Census window side n: 3, 5, 7 or 9 (8, 24, 48 or 80 bits per pixel).
  int census_window = 5;
  /// Kernel of the MCT mean (ignored by CT).
  MeanKernel mct_kernel = MeanKernel::Gaussian;

  /// Side a of the square window over which Hamming distances are summed (SHD) at the finest
  /// level: 1 (plain Hamming), 3, 5, 7 or 9.
  int shd_window = 5;
  /// SHD window at the coarser pyramid levels (same range as shd_window).
  int coarse_shd_window = 3;

  /// Pyramid levels L, range [1, 5]. 1 = single resolution with the full search.
  int pyramid_levels = 3;
  /// Extra search r, pixels of the level, around the prior from the coarser level. Range [0, 16].
  int search_radius = 3;

  /// Sub-pixel refinement by a parabola through the costs around the winner (finest level only).
  bool subpixel = true;
  /// Median filter side k: 0 (off), 3 or 5. Applied at every level that is refined.
  int median_size = 3;
  /// Left-right consistency check.
  bool lr_check = true;
  /// Largest allowed |dL(x) - dR(x - dL(x))|, pixels of the level. Range [0, 16].
  int lr_threshold = 1;
  /// The left map's LR check at the finest level reads the right view's map on the grid of its
  /// even rows and columns: the raw right map is taken at (2i, 2j), the median (median_size)
  /// runs on that half-size grid, and a left pixel whose partner is right pixel (x', y) compares
  /// with grid pixel (x' / 2, y / 2). The check reads a quarter of the right map's pixels, and
  /// without compute_right the right view is matched at its even rows only. With the box presets'
  /// noisier right maps the check gets better too (realtime on Middlebury 2003: 10.56 % against
  /// 10.78 with the whole right map; 2005/2006: 15.45 against 15.85). The right map itself
  /// (MatcherOptions::compute_right) is refined as without it.
  bool lr_check_grid = false;
  /// Regions (4-connected, neighbours within 1 px) smaller than this many pixels are invalidated.
  /// 0 = off. Range [0, 1000000]. Scaled by 1/4 per pyramid level.
  int speckle_size = 50;
  /// Uniqueness: invalid where 100 * (second best - best) <= uniqueness_ratio * best, the second best
  /// taken outside d-1..d+1. 0 = off. Percent, range [0, 100].
  int uniqueness_ratio = 0;
  /// Filling of invalid pixels.
  FillMode fill = FillMode::NearestLower;
  /// Median filter side after filling: 0 (off), 3 or 5. Smooths the horizontal streaks that
  /// row-wise filling leaves in occluded areas.
  int post_median_size = 5;
  /// Refine (median, LR check, speckle, fill) at every pyramid level rather than the finest only.
  bool refine_all_levels = true;

  /// Cost aggregation: box sums as the thesis, or semi-global paths inside the coarse-to-fine band
  /// (docs/PIPELINE.md, "Band SGM"). With SGM, shd_window and coarse_shd_window are the box of the
  /// matching cost C that the paths aggregate.
  Aggregation aggregation = Aggregation::Box;
  /// With SGM aggregation: the finest this many pyramid levels match locally (box sums of
  /// shd_window, or coarse_shd_window below the finest level, around the 3x3 prior as the box
  /// pipeline does), the coarser ones by band SGM, whose maps give the priors. 0 = every level
  /// SGM. Range [0, 4]; the coarsest level always aggregates by SGM (with pyramid_levels 1, the
  /// one level does).
  int box_levels = 0;
  /// SGM penalty for a step of one disparity between neighbours along a path. Range [0, 16383],
  /// units of the cost C (Hamming bits).
  int sgm_p1 = 40;
  /// SGM penalty for a jump of more than one disparity. Range [sgm_p1, 16383], units of C.
  int sgm_p2 = 300;
  /// Adaptive P2: P2' = max(P1, P2 k / (k + |I(p) - I(q)|)) with k = sgm_p2_k and I the level's gray
  /// image, so that jumps are cheaper across intensity edges. 0 = constant P2. Range [0, 255].
  int sgm_p2_k = 8;
  /// Side of the coarser map's neighbourhood around (x/2, y/2) whose priors span a pixel's search
  /// range: 3 or 5. 5 (SGM only) keeps both surfaces of a depth edge in the band, so that the paths
  /// can move the edge.
  int prior_size = 3;
  /// Search radius r at the finest level: -1 = search_radius. Range [-1, 16].
  int finest_search_radius = -1;
  /// SGM: most candidates per pixel at a level with a prior (the band is stored as W x H x this).
  /// A band whose priors span more is cut to this width around the pixel's own prior. The coarsest
  /// level (and sgm-full) holds its whole range. Range [1, 255].
  int sgm_max_band = 32;

  /// Colour-weighted median (docs/PIPELINE.md, "Colour-weighted median") at the finest level,
  /// after LR check, speckle removal and the fill, followed by a 3x3 median that takes the place
  /// of the post-fill median there (post_median_size still applies to the coarser levels). Each
  /// pixel takes the weighted median of the whole disparities sampled around it, weighted by how
  /// alike the left image's colours are (gray input: its gray values). Pixels still invalid
  /// (FillMode::None) take the median of their valid neighbours too.
  bool weighted_median = false;
  /// Window radius R of the weighted median, pixels of the working scale: samples lie at the
  /// multiples of wm_step in [-R, R] in x and in y (coordinates clamped). Range [1, 15].
  int wm_radius = 9;
  /// Sampling step S of the weighted median window, pixels. Range [1, wm_radius]. 9 and 3 give
  /// 7 x 7 = 49 samples.
  int wm_step = 3;
  /// Colour scale sigma of the weights 64 exp(-k / sigma) (rounded to integers), with k the
  /// largest difference of the channels, 0..255. Range [1, 255].
  int wm_sigma = 10;

  /// Temporal prior for sequences (docs/PIPELINE.md, "Temporal prior"): each level with a coarser
  /// prior also reads the same level's map of the previous frame. Where the pixel's gray value is
  /// unchanged (temporal_threshold) and the previous frame's band (its 3x3 disparities +-
  /// temporal_radius) lies inside the band the coarser map gives, the pixel searches the union of
  /// that band and the coarser map's band narrowed to temporal_radius; elsewhere (motion, a cut) it
  /// searches as without the prior. A pixel never searches more than
  /// without it, so a still scene needs fewer candidates and a new one the same. Only levels whose
  /// radius exceeds temporal_radius change. Every backend; Matcher::reset_temporal() drops the
  /// history.
  bool temporal = false;
  /// Radius of both narrowed bands of the temporal prior, pixels of the level. Range [0, 16].
  int temporal_radius = 1;
  /// Temporal prior: a pixel whose gray value at the level changed by more than this since the
  /// previous frame has moved and searches as without the prior. Above the sensor noise of the
  /// level's (smoothed) image. Range [0, 255], gray levels.
  int temporal_threshold = 12;

  /// Working scale s: 1, 2 or 4. The pipeline runs on the input reduced s times (binomial pyramid)
  /// and the result is replicated s x s with disparities multiplied by s.
  int working_scale = 1;

  /// Largest disparity searched: min_disparity + num_disparities - 1.
  int max_disparity() const { return min_disparity + num_disparities - 1; }
  /// Whether the aggregation is semi-global.
  bool sgm() const { return aggregation != Aggregation::Box; }
  /// Whether pyramid level l (0 = the finest) aggregates by SGM (box_levels).
  bool sgm_at(int level) const { return sgm() && (level >= box_levels || level == pyramid_levels - 1); }
  /// SGM paths: 4 or 8 (0 for box aggregation).
  int sgm_paths() const { return aggregation == Aggregation::Sgm4 ? 4 : aggregation == Aggregation::Sgm8 ? 8 : 0; }
  /// The search radius of the finest level.
  int finest_radius() const { return finest_search_radius < 0 ? search_radius : finest_search_radius; }
  /// Whether the finest level's LR check reads the right map on its grid (lr_check_grid takes effect).
  bool lr_check_on_grid() const { return lr_check && lr_check_grid; }

  /// Checks every parameter and their combination. Returns an empty string when valid,
  /// otherwise one message per problem (joined by newlines) naming the parameter and its range.
  std::string validate() const;
  /// The same, also checking against the image size (range wider than the image, too many levels).
  std::string validate(int width, int height) const;
};

/// Named presets: "realtime", "balanced", "quality", "sgm-full", "mct-full", "mr-mct-full",
/// "mr-mct-5x5".
/// Throws std::invalid_argument naming the known presets for an unknown name.
/// The disparity range of the returned parameters is the default; set it afterwards.
StereoParams preset(std::string_view name);
/// The names accepted by preset(), in a stable order.
const std::vector<std::string>& preset_names();
/// One line saying what the preset is for.
std::string_view preset_description(std::string_view name);

std::string_view to_string(CensusKind kind);
std::string_view to_string(MeanKernel kernel);
std::string_view to_string(FillMode mode);
std::string_view to_string(Aggregation aggregation);

}  // namespace mctstereo
