// Frame time of the whole Matcher (cpu backend) for every preset at 320x240 and 640x480, on a
// synthetic textured pair. Public API only. Run: mctstereo_benchmarks [--benchmark_filter=...].
#include <benchmark/benchmark.h>

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "mctstereo/mctstereo.hpp"

namespace {

struct StereoPair {
  int width, height;
  std::vector<std::uint8_t> left, right;
};

// A smooth random texture seen at two depths: background at disparity 8, a centred rectangle at
// 24, so the matcher meets both textured areas and depth edges, as in a real frame.
StereoPair make_pair(int width, int height) {
  StereoPair p{width, height, std::vector<std::uint8_t>(width * height), std::vector<std::uint8_t>(width * height)};
  std::mt19937 rng(12345);
  std::uniform_int_distribution<int> noise(0, 255);
  // Texture wider than the image so every shifted read stays inside it.
  const int tw = width + 64, cw = tw / 4 + 2;
  std::vector<int> coarse(cw * (height / 4 + 2));
  for (int& c : coarse) c = noise(rng);
  std::vector<std::uint8_t> texture(tw * height);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < tw; ++x)
      texture[y * tw + x] = static_cast<std::uint8_t>((3 * coarse[(y / 4) * cw + x / 4] + noise(rng)) / 4);
  auto disparity = [&](int x, int y) {
    return x > width / 3 && x < 2 * width / 3 && y > height / 3 && y < 2 * height / 3 ? 24 : 8;
  };
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      // The left pixel x shows the scene point that the right view sees at x - d.
      p.left[y * width + x] = texture[y * tw + x + 32];
      const int d = disparity(x, y);
      p.right[y * width + x] = texture[y * tw + std::min(x + 32 + d, tw - 1)];
    }
  return p;
}

mctstereo::ImageView view(const std::vector<std::uint8_t>& pixels, int width, int height) {
  return {pixels.data(), width, height, width, mctstereo::PixelFormat::Gray8};
}

void match_frame(benchmark::State& state, const std::string& preset, int width, int height) {
  const StereoPair pair = make_pair(width, height);
  mctstereo::StereoParams params = mctstereo::preset(preset);
  params.min_disparity = 0;
  params.num_disparities = 64;
  mctstereo::Matcher matcher(width, height, params, mctstereo::Backend::Cpu);
  const mctstereo::ImageView left = view(pair.left, width, height), right = view(pair.right, width, height);
  for (auto _ : state) {
    matcher.compute(left, right);
    benchmark::DoNotOptimize(matcher.disparity_q4().data);
  }
  state.SetLabel(matcher.simd_target() + ", " + std::to_string(matcher.threads()) + " threads");
  state.counters["fps"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["Mpixel/s"] = benchmark::Counter(static_cast<double>(state.iterations()) * width * height * 1e-6,
                                                  benchmark::Counter::kIsRate);
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  for (const std::string& preset : mctstereo::preset_names())
    for (const auto& [w, h] : {std::pair{320, 240}, std::pair{640, 480}})
      benchmark::RegisterBenchmark(("Matcher/" + preset + "/" + std::to_string(w) + "x" + std::to_string(h)).c_str(),
                                   match_frame, preset, w, h)
          ->Unit(benchmark::kMillisecond)
          ->UseRealTime();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
