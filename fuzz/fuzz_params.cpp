// The parameter space: bytes -> every StereoParams field -> validate(). Each field takes either a
// value near its documented range (most inputs) or any int, so both the edges and overflowing
// values are tried. Invalid parameters must make the Matcher's constructor throw
// std::invalid_argument with validate()'s message; valid ones that also fit the frame size
// (validate(width, height)) are matched on a tiny frame (1..32 x 1..16 pixels, gray or BGR, from the
// input's remaining bytes) by the reference and the cpu backend, whose maps must be equal bit for
// bit and hold only disparities within the range searched (or the invalid value); with the temporal
// prior on, a second frame (the views swapped) is matched around the first and compared too.
#include <fuzzer/FuzzedDataProvider.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "mctstereo/matcher.hpp"
#include "mctstereo/params.hpp"

namespace {

int field(FuzzedDataProvider& in, int lo, int hi) {
  if (in.ConsumeIntegralInRange<int>(0, 15) == 0) return in.ConsumeIntegral<int>();  // anything
  return in.ConsumeIntegralInRange<int>(lo - 2, hi + 2);
}

void fail(const std::string& why) {
  std::fprintf(stderr, "fuzz_params: %s\n", why.c_str());
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mctstereo;
  FuzzedDataProvider in(data, size);
  StereoParams p;
  p.min_disparity = field(in, -1024, 1024);
  p.num_disparities = field(in, 1, 2048);
  if (in.ConsumeBool()) {  // small ranges are the ones a tiny frame can match
    p.min_disparity = in.ConsumeIntegralInRange<int>(-8, 8);
    p.num_disparities = in.ConsumeIntegralInRange<int>(1, 24);
  }
  p.census = in.ConsumeBool() ? CensusKind::Census : CensusKind::ModifiedCensus;
  p.census_window = field(in, 3, 9);
  p.mct_kernel = in.ConsumeBool() ? MeanKernel::Box : MeanKernel::Gaussian;
  p.shd_window = field(in, 1, 9);
  p.coarse_shd_window = field(in, 1, 9);
  p.pyramid_levels = field(in, 1, 5);
  p.search_radius = field(in, 0, 16);
  p.subpixel = in.ConsumeBool();
  p.median_size = field(in, 0, 5);
  p.lr_check = in.ConsumeBool();
  p.lr_threshold = field(in, 0, 16);
  p.speckle_size = field(in, 0, 64);
  p.uniqueness_ratio = field(in, 0, 100);
  p.fill = static_cast<FillMode>(in.ConsumeIntegralInRange<int>(0, 2));
  p.post_median_size = field(in, 0, 5);
  p.refine_all_levels = in.ConsumeBool();
  p.lr_check_grid = in.ConsumeBool();
  p.aggregation = static_cast<Aggregation>(in.ConsumeIntegralInRange<int>(0, 2));
  p.sgm_p1 = field(in, 0, 400);
  p.sgm_p2 = field(in, 0, 1000);
  if (in.ConsumeIntegralInRange<int>(0, 7) == 0) p.sgm_p2 = field(in, 16380, 16386);
  p.sgm_p2_k = field(in, 0, 255);
  p.prior_size = field(in, 3, 5);
  p.finest_search_radius = field(in, -1, 16);
  p.sgm_max_band = field(in, 1, 255);
  p.weighted_median = in.ConsumeBool();
  p.wm_radius = field(in, 1, 15);
  p.wm_step = field(in, 1, 15);
  p.wm_sigma = field(in, 1, 255);
  p.working_scale = field(in, 1, 4);
  p.temporal = in.ConsumeBool();
  p.temporal_radius = field(in, 0, 16);
  p.temporal_threshold = field(in, 0, 255);
  const int width = in.ConsumeIntegralInRange<int>(1, 32);
  const int height = in.ConsumeIntegralInRange<int>(1, 16);
  const bool colour = in.ConsumeBool();
  MatcherOptions options;
  options.threads = in.ConsumeIntegralInRange<int>(1, 2);
  options.compute_confidence = in.ConsumeBool();

  const std::string problems = p.validate();
  if (!problems.empty()) {
    try {
      Matcher m(width, height, p, Backend::Cpu, options);
    } catch (const std::invalid_argument& e) {
      if (std::string(e.what()).find(problems.substr(0, problems.find('\n'))) == std::string::npos)
        fail("the constructor's message '" + std::string(e.what()) + "' does not say '" + problems + "'");
      return 0;
    }
    fail("invalid parameters were accepted by the constructor: " + problems);
  }
  if (!p.validate(width, height).empty()) {
    try {
      Matcher m(width, height, p, Backend::Cpu, options);
    } catch (const std::invalid_argument&) {
      return 0;
    }
    fail("parameters that do not fit " + std::to_string(width) + "x" + std::to_string(height) + " were accepted");
  }

  const int channels = colour ? 3 : 1;
  std::vector<std::uint8_t> left(static_cast<std::size_t>(width * height * channels));
  std::vector<std::uint8_t> right(left.size());
  for (std::uint8_t& v : left) v = in.ConsumeIntegral<std::uint8_t>();
  for (std::uint8_t& v : right) v = in.ConsumeIntegral<std::uint8_t>();
  const PixelFormat format = colour ? PixelFormat::Bgr8 : PixelFormat::Gray8;
  const ImageView lv{left.data(), width, height, width * channels, format};
  const ImageView rv{right.data(), width, height, width * channels, format};

  Matcher reference(width, height, p, Backend::Reference, options);
  Matcher cpu(width, height, p, Backend::Cpu, options);
  // With the temporal prior, a second frame (the views swapped) is matched around the first.
  for (int frame = 0; frame < (p.temporal ? 2 : 1); ++frame) {
    reference.compute(frame == 0 ? lv : rv, frame == 0 ? rv : lv);
    cpu.compute(frame == 0 ? lv : rv, frame == 0 ? rv : lv);
    const MapView<const std::int16_t> a = reference.disparity_q4(), b = cpu.disparity_q4();
    if (a.width != width || a.height != height || b.width != width || b.height != height) fail("map sizes");
    const std::int16_t invalid = cpu.invalid_q4();
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        const std::int16_t va = a.data[y * a.stride + x], vb = b.data[y * b.stride + x];
        if (va != vb)
          fail("frame " + std::to_string(frame) + ": reference and cpu differ at (" + std::to_string(x) + ", " +
               std::to_string(y) + "): " + std::to_string(va) + " vs " + std::to_string(vb));
        if (vb != invalid && (vb < kDisparityScale * p.min_disparity || vb > kDisparityScale * p.max_disparity()))
          fail("disparity " + std::to_string(vb) + " / 16 outside the range searched");
      }
  }
  return 0;
}
