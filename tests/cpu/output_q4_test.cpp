// output_q4: the caller's Q4 convention (kInvalid -> the invalid value), a known answer of the
// reference, and cpu == reference on every SIMD target with 1 and 2 threads.
#include "test_util.hpp"

namespace mctstereo::test {
namespace {

using detail::kInvalid;

TEST(ReferenceOutputQ4, ReplacesOnlyTheInvalidMarker) {
  const auto src = make_map(4, 2, {kInvalid, 0, -16, 32767,  //
                                   -32767, kInvalid, 5, kInvalid});
  Plane<std::int16_t> dst(4, 2);
  detail::reference::output_q4(src, -16, dst);
  EXPECT_EQ(pixels(dst), (std::vector<std::int16_t>{-16, 0, -16, 32767, -32767, -16, 5, -16}));
}

TEST(CpuOutputQ4, EqualsReferenceAtAwkwardSizes) {
  std::uint32_t seed = 40;
  for (const auto& w_h : awkward_sizes()) {
    const auto w = w_h.first;
    const auto h = w_h.second;
    // A source larger than the destination (an up-scaled map cut to the output size).
    const Plane<std::int16_t> src = random_disparity(w + 3, h + 1, ++seed, -32767, 32767, 0.3);
    for (std::int16_t invalid : {std::int16_t{-16}, std::int16_t{-32768}, std::int16_t{160}}) {
      Plane<std::int16_t> expected(w, h);
      detail::reference::output_q4(src, invalid, expected);
      for_each_target_and_threads([&](const std::string& where) {
        Plane<std::int16_t> got(w, h, 3);
        detail::cpu::output_q4(src, invalid, got);
        ASSERT_EQ(first_difference(got, expected), "") << w << "x" << h << " invalid " << invalid << " " << where;
      });
    }
  }
}

}  // namespace
}  // namespace mctstereo::test
