// The reference and cpu backends against the recipe of the whole frame written apart from the
// driver (frame_reference.hpp): every preset and awkward case, gray and colour input (RGB and
// BGR with channels that differ, padded rows), the right map and the confidence, 1 and 2 threads.
// The backends share the driver, so comparing them with each other cannot see a bug in it.
#include <string>
#include <vector>

#include "frame_reference.hpp"
#include "pipeline_cases.hpp"

namespace mctstereo::test {

namespace {

/// The options of the i-th case: the four combinations of compute_right and compute_confidence
/// in turn, so that every case is also checked with the right map or the box confidence.
MatcherOptions options_of_case(std::size_t i) {
  MatcherOptions options;
  options.compute_right = i % 2 == 1;
  options.compute_confidence = (i / 2) % 2 == 1;
  return options;
}

void expect_backends_equal_recipe(const ImageView& left, const ImageView& right, const StereoParams& p,
                                  MatcherOptions options) {
  const FrameResult expected = reference_frame(left, right, p, options);
  {
    Matcher m(left.width, left.height, p, Backend::Reference, options);
    m.compute(left, right);
    EXPECT_EQ(difference_from_recipe(m, expected, options), "") << "reference backend";
  }
  for (int threads : {1, 2}) {
    options.threads = threads;
    Matcher m(left.width, left.height, p, Backend::Cpu, options);
    m.compute(left, right);
    EXPECT_EQ(difference_from_recipe(m, expected, options), "") << "cpu backend, " << threads << " threads";
  }
}

TEST(FrameReference, EveryCaseOnGrayInput) {
  const std::vector<PipelineCase> cases = pipeline_cases();
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const PipelineCase& c = cases[i];
    const MatcherOptions options = options_of_case(i);
    SCOPED_TRACE(c.name + (options.compute_right ? ", compute_right" : "") +
                 (options.compute_confidence ? ", compute_confidence" : ""));
    const StereoPair pair = textured_pair(c.w, c.h, c.max_disparity(), 11);
    expect_backends_equal_recipe(pair.left_view(), pair.right_view(), c.params, options);
  }
}

// Colour input whose channels differ (a luma computed with the wrong weights or byte order changes
// the maps), in padded rows, for every preset: the luma drives matching, the channels the weighted
// median.
TEST(FrameReference, EveryPresetOnColourInput) {
  const int w = 91, h = 43;
  for (PixelFormat format : {PixelFormat::Rgb8, PixelFormat::Bgr8}) {
    const ColourPair pair(w, h, 12, 41, format, format == PixelFormat::Rgb8 ? 7 : 0);
    std::size_t i = 0;
    for (const std::string& name : preset_names()) {
      StereoParams p = preset(name);
      p.num_disparities = 20;
      const MatcherOptions options = options_of_case(i++);
      SCOPED_TRACE(name + (format == PixelFormat::Rgb8 ? ", RGB" : ", BGR"));
      expect_backends_equal_recipe(pair.left.view, pair.luma.right_view(), p, options);
    }
  }
}

// The recipe itself: a pair shifted by a constant disparity gives that disparity over the image
// (bar the left border, which no right pixel sees), so that it cannot pass by being as wrong as
// the backends.
TEST(FrameReference, RecipeFindsAConstantShift) {
  const int w = 96, h = 40, shift = 6;
  const Plane<std::uint8_t> right = random_texture(w, h, 17);
  Plane<std::uint8_t> left(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) left.at(x, y) = right.at(std::max(x - shift, 0), y);
  const ImageView lv{left.row(0), w, h, left.stride(), PixelFormat::Gray8};
  const ImageView rv{right.row(0), w, h, right.stride(), PixelFormat::Gray8};
  for (const std::string& name : preset_names()) {
    StereoParams p = preset(name);
    p.num_disparities = 16;
    const FrameResult r = reference_frame(lv, rv, p);
    int exact = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 2 * shift; x < w; ++x) exact += r.left.at(x, y) == 16 * shift;
    EXPECT_GT(exact, (w - 2 * shift) * h * 9 / 10) << name;
  }
}

}  // namespace
}  // namespace mctstereo::test
