// What the whole-pipeline tests of every backend share: a textured pair with a smooth disparity
// field, the cases the backends are compared on, and map comparison.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <ostream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "mctstereo/matcher.hpp"
#include "test_util.hpp"

namespace mctstereo::test {

/// A gray pair, and the views of it a caller passes to Matcher::compute().
struct StereoPair {
  Plane<std::uint8_t> left, right;
  ImageView left_view() const { return {left.row(0), left.width(), left.height(), left.stride(), PixelFormat::Gray8}; }
  ImageView right_view() const {
    return {right.row(0), right.width(), right.height(), right.stride(), PixelFormat::Gray8};
  }
};

/// The right view of a left view under a smooth disparity field (0 at the top left, growing to
/// max_disp at the bottom right): right(x, y) = left(x + d, y).
inline Plane<std::uint8_t> shifted_view(const Plane<std::uint8_t>& left, int max_disp) {
  const int w = left.width(), h = left.height();
  Plane<std::uint8_t> right(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int d = (max_disp * (x + 2 * y)) / (w + 2 * h + 1);
      right.at(x, y) = left.at(std::min(x + d, w - 1), y);
    }
  return right;
}
/// A gray view as interleaved colour in rows `extra` bytes longer than the pixels:
/// the gray value, a texture of its own and the inverted gray value, as RGB or BGR (the channels
/// differ, so a stage that uses colour sees more than the luma).
struct ColourView {
  std::vector<std::uint8_t> bytes;
  ImageView view;
  ColourView(const Plane<std::uint8_t>& gray, PixelFormat format, int extra, std::uint32_t seed) {
    const int w = gray.width(), h = gray.height();
    const std::ptrdiff_t stride = 3 * w + extra;
    bytes.assign(static_cast<std::size_t>(stride) * h, 0xee);
    const Plane<std::uint8_t> tint = random_texture(w, h, seed);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        std::uint8_t* p = &bytes[static_cast<std::size_t>(y) * stride + 3 * x];
        const std::uint8_t c[3] = {gray.at(x, y), tint.at(x, y), static_cast<std::uint8_t>(255 - gray.at(x, y))};
        for (int k = 0; k < 3; ++k) p[format == PixelFormat::Bgr8 ? 2 - k : k] = c[k];
      }
    view = {bytes.data(), w, h, stride, format};
  }
};

/// A colour left view (ColourView of a texture), its luma as a gray view, and the gray right view
/// that matches the luma with textured_pair's disparity field.
struct ColourPair {
  ColourView left;
  StereoPair luma;  // left: the colour view's luma; right: the right view
  ColourPair(int w, int h, int max_disp, std::uint32_t seed, PixelFormat format, int extra)
      : left(random_texture(w, h, seed), format, extra, seed + 1) {
    luma.left.reset(w, h);
    detail::reference::to_gray(left.view, luma.left);
    luma.right = shifted_view(luma.left, max_disp);
  }
};

/// A textured pair with a smooth disparity field (0 at the top left, growing to max_disp at the
/// bottom right), so that the coarse-to-fine path has real priors.
inline StereoPair textured_pair(int w, int h, int max_disp, std::uint32_t seed) {
  Plane<std::uint8_t> left = random_texture(w, h, seed);
  Plane<std::uint8_t> right = shifted_view(left, max_disp);
  return {std::move(left), std::move(right)};
}

/// The pixels of a map, row after row.
inline std::vector<std::int16_t> pixels(MapView<const std::int16_t> view) {
  std::vector<std::int16_t> out;
  for (int y = 0; y < view.height; ++y) out.insert(out.end(), view.row(y), view.row(y) + view.width);
  return out;
}

/// "(x, y): a vs b" at the first difference of two maps `w` pixels wide, or empty when equal.
inline std::string describe_difference(const std::vector<std::int16_t>& a, const std::vector<std::int16_t>& b,
                                       int w) {
  if (a.size() != b.size()) return "sizes differ";
  for (std::size_t i = 0; i < a.size(); ++i)
    if (a[i] != b[i])
      return "(" + std::to_string(i % w) + ", " + std::to_string(i / w) + "): " + std::to_string(a[i]) + " vs " +
             std::to_string(b[i]);
  return {};
}

/// The confidence of a matcher, row after row, as bytes of the floats (equal means bit for bit).
inline std::vector<std::uint32_t> confidence_bits(const Matcher& m) {
  const MapView<const float> c = m.confidence();
  std::vector<std::uint32_t> out;
  for (int y = 0; y < c.height; ++y)
    for (int x = 0; x < c.width; ++x) {
      std::uint32_t bits;
      std::memcpy(&bits, c.row(y) + x, sizeof bits);
      out.push_back(bits);
    }
  return out;
}

/// "at pixel x, y" where the confidence maps of two matchers first differ, "no confidence" when
/// the first has none, or empty when they are equal bit for bit.
inline std::string confidence_difference(const Matcher& a, const Matcher& b) {
  const std::vector<std::uint32_t> ca = confidence_bits(a), cb = confidence_bits(b);
  if (ca.empty()) return "no confidence";
  if (ca.size() != cb.size()) return "sizes differ";
  for (std::size_t i = 0; i < ca.size(); ++i)
    if (ca[i] != cb[i]) return "at pixel " + std::to_string(i % a.width()) + ", " + std::to_string(i / a.width());
  return {};
}

/// What a matcher of `backend` refuses with std::invalid_argument: views of another size, a
/// null view, a stride shorter than a row, and a range the parameters do not allow.
inline void expect_rejects_wrong_input(Backend backend, const MatcherOptions& options = {}) {
  StereoParams p = preset("realtime");
  p.num_disparities = 16;
  Matcher m(64, 32, p, backend, options);
  std::vector<std::uint8_t> px(64 * 32);
  const ImageView good{px.data(), 64, 32, 64, PixelFormat::Gray8};
  EXPECT_THROW(m.compute({px.data(), 63, 32, 64, PixelFormat::Gray8}, good), std::invalid_argument);
  EXPECT_THROW(m.compute(good, {nullptr, 64, 32, 64, PixelFormat::Gray8}), std::invalid_argument);
  EXPECT_THROW(m.compute(good, {px.data(), 64, 32, 32, PixelFormat::Gray8}), std::invalid_argument);
  StereoParams bad = p;
  bad.num_disparities = 0;
  EXPECT_THROW(Matcher(64, 32, bad, backend, options), std::invalid_argument);
  bad = p;
  bad.num_disparities = 65;
  EXPECT_THROW(Matcher(64, 32, bad, backend, options), std::invalid_argument);
}

struct PipelineCase {
  std::string name;
  StereoParams params;
  int w, h;
  /// The name as an identifier, for test names.
  std::string id() const {
    std::string id = name;
    std::replace(id.begin(), id.end(), '-', '_');
    return id;
  }
  /// The largest disparity of the case's pair: within the range, and at most half the width.
  int max_disparity() const { return params.max_disparity() > 0 ? std::min(params.max_disparity(), w / 2) : 0; }
};

// Test logs name the case, not its bytes.
inline void PrintTo(const PipelineCase& c, std::ostream* os) { *os << c.name << " " << c.w << "x" << c.h; }

/// Every preset, then the cases where coarse to fine, refinement or sizes are awkward.
inline std::vector<PipelineCase> pipeline_cases() {
  std::vector<PipelineCase> out;
  for (const std::string& name : preset_names()) {
    StereoParams p = preset(name);
    p.num_disparities = 24;
    out.push_back({name, p, 97, 61});
  }
  StereoParams neg = preset("balanced");
  neg.min_disparity = -7;
  neg.num_disparities = 30;
  out.push_back({"negative_min", neg, 81, 33});
  StereoParams wide = preset("quality");
  wide.num_disparities = 38;
  out.push_back({"range_nearly_image_width", wide, 40, 20});
  StereoParams scaled = preset("realtime");
  scaled.working_scale = 2;
  scaled.num_disparities = 32;
  out.push_back({"working_scale_2", scaled, 75, 45});
  StereoParams scaled4 = preset("balanced");
  scaled4.working_scale = 4;
  scaled4.pyramid_levels = 2;
  scaled4.min_disparity = -5;
  scaled4.num_disparities = 40;
  out.push_back({"working_scale_4_negative_min", scaled4, 130, 66});
  StereoParams unique = preset("balanced");
  unique.uniqueness_ratio = 10;
  unique.fill = FillMode::Nearest;
  unique.census = CensusKind::ModifiedCensus;
  unique.census_window = 7;
  unique.mct_kernel = MeanKernel::Box;
  out.push_back({"uniqueness_mct7_box_nearest", unique, 64, 40});
  StereoParams every = preset("balanced");
  every.refine_all_levels = true;
  every.speckle_size = 400;  // large regions, at every level
  every.num_disparities = 24;
  out.push_back({"every_level_refined_large_speckles", every, 90, 50});
  // Band SGM at every level of balanced's band, and at the coarsest of four levels only (box
  // sums at the three finer ones, 5 x 5 prior of the one SGM level, uniqueness there).
  StereoParams all_sgm = preset("balanced");
  all_sgm.box_levels = 0;
  all_sgm.min_disparity = -3;
  all_sgm.num_disparities = 29;
  out.push_back({"sgm_at_every_level", all_sgm, 87, 41});
  // SGM at the two coarser of three levels (balanced's box levels 1): the middle SGM level picks the
  // right view's winners for the box level above it, and its prior is the coarsest SGM map.
  StereoParams two_sgm = preset("balanced");
  two_sgm.box_levels = 1;
  two_sgm.num_disparities = 40;
  out.push_back({"sgm_at_the_two_coarser_levels", two_sgm, 103, 57});
  StereoParams one_sgm = preset("balanced");
  one_sgm.pyramid_levels = 4;
  one_sgm.box_levels = 3;
  one_sgm.uniqueness_ratio = 15;
  one_sgm.num_disparities = 48;
  out.push_back({"sgm_at_the_coarsest_of_four", one_sgm, 121, 67});
  StereoParams plain = preset("balanced");
  plain.median_size = 0;
  plain.post_median_size = 0;
  plain.lr_check = false;
  plain.speckle_size = 0;
  plain.fill = FillMode::None;
  plain.shd_window = 1;
  plain.coarse_shd_window = 1;
  plain.num_disparities = 20;
  out.push_back({"no_refinement_hamming", plain, 50, 30});
  StereoParams tiny = preset("realtime");
  tiny.num_disparities = 4;
  out.push_back({"tiny_17x5", tiny, 17, 5});
  StereoParams single = tiny;
  single.num_disparities = 1;
  out.push_back({"one_column", single, 1, 64});
  out.push_back({"one_row", tiny, 64, 1});
  StereoParams odd = preset("mr-mct-5x5");
  odd.num_disparities = 21;
  out.push_back({"odd_131x37", odd, 131, 37});
  StereoParams sgm8 = preset("balanced");
  sgm8.box_levels = 0;
  sgm8.aggregation = Aggregation::Sgm8;
  sgm8.sgm_p2_k = 0;
  sgm8.subpixel = true;
  sgm8.uniqueness_ratio = 0;
  sgm8.min_disparity = -4;
  sgm8.num_disparities = 37;
  out.push_back({"sgm8_constant_p2_subpixel_negative_min", sgm8, 77, 29});
  StereoParams sgm_wide = preset("sgm-full");
  sgm_wide.num_disparities = 260;
  out.push_back({"sgm_full_260_disparities", sgm_wide, 300, 6});
  StereoParams sgm_rows = sgm_every_level();
  sgm_rows.num_disparities = 20;
  out.push_back({"sgm_two_rows", sgm_rows, 45, 2});
  // The colour-weighted median (gray input here; colour in the tests of their own): on the
  // default preset, at working scale 2 with a negative range, a dense small window with a wide
  // sigma, and one row.
  StereoParams wm = preset("balanced");
  wm.weighted_median = true;
  wm.num_disparities = 24;
  out.push_back({"weighted_median", wm, 97, 61});
  StereoParams wm_scaled = preset("quality");
  wm_scaled.weighted_median = true;
  wm_scaled.working_scale = 2;
  wm_scaled.min_disparity = -6;
  wm_scaled.num_disparities = 36;
  out.push_back({"weighted_median_scale_2_negative_min", wm_scaled, 83, 47});
  StereoParams wm_dense = preset("realtime");
  wm_dense.weighted_median = true;
  wm_dense.wm_radius = 4;
  wm_dense.wm_step = 1;
  wm_dense.wm_sigma = 60;
  wm_dense.num_disparities = 20;
  out.push_back({"weighted_median_dense_box", wm_dense, 65, 33});
  StereoParams wm_row = wm;
  wm_row.num_disparities = 8;
  out.push_back({"weighted_median_one_row", wm_row, 33, 1});
  // The LR check on the right map's grid (realtime's) on other presets and with odd sizes, four
  // cases in a row so that the frame-reference test gives them the four combinations of the
  // right map and the confidence: band SGM below box levels, SGM at every level (no box level
  // shares its scratch), a 5 x 5 median on the grid, and none.
  StereoParams grid_balanced = preset("balanced");
  grid_balanced.lr_check_grid = true;
  grid_balanced.num_disparities = 24;
  out.push_back({"lr_check_grid_balanced", grid_balanced, 97, 61});
  StereoParams grid_sgm = sgm_every_level();
  grid_sgm.lr_check_grid = true;
  grid_sgm.num_disparities = 20;
  out.push_back({"lr_check_grid_sgm_every_level", grid_sgm, 71, 39});
  StereoParams grid_median5 = preset("realtime");
  grid_median5.median_size = 5;
  grid_median5.num_disparities = 28;
  out.push_back({"lr_check_grid_median_5", grid_median5, 67, 43});
  StereoParams grid_no_median = preset("realtime");
  grid_no_median.median_size = 0;
  grid_no_median.num_disparities = 16;
  out.push_back({"lr_check_grid_no_median", grid_no_median, 33, 3});
  return out;
}

}  // namespace mctstereo::test
