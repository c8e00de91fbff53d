// Known answers of the reference stages on small hand-made inputs.
#include "test_util.hpp"

namespace mctstereo::test {
namespace {

using detail::kInvalid;

TEST(ReferenceGray, Bt601IntegerWeights) {
  const std::uint8_t rgb[] = {255, 0, 0, 0, 255, 0, 0, 0, 255, 255, 255, 255, 10, 20, 30};
  Plane<std::uint8_t> out(5, 1);
  detail::reference::to_gray({rgb, 5, 1, sizeof rgb, PixelFormat::Rgb8}, out);
  // (77 R + 150 G + 29 B + 128) >> 8
  EXPECT_EQ(out.at(0, 0), (77 * 255 + 128) >> 8);
  EXPECT_EQ(out.at(1, 0), (150 * 255 + 128) >> 8);
  EXPECT_EQ(out.at(2, 0), (29 * 255 + 128) >> 8);
  EXPECT_EQ(out.at(3, 0), 255);
  EXPECT_EQ(out.at(4, 0), (77 * 10 + 150 * 20 + 29 * 30 + 128) >> 8);
  Plane<std::uint8_t> bgr_out(5, 1);
  const std::uint8_t bgr[] = {0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 255, 30, 20, 10};
  detail::reference::to_gray({bgr, 5, 1, sizeof bgr, PixelFormat::Bgr8}, bgr_out);
  EXPECT_EQ(first_difference(out, bgr_out), "");
}

TEST(ReferencePyramid, ConstantStaysConstantAndSizesRoundUp) {
  Plane<std::uint8_t> src(7, 5);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 7; ++x) src.at(x, y) = 77;
  Plane<std::uint8_t> dst(4, 3);
  detail::reference::pyramid_down(src, dst);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 4; ++x) EXPECT_EQ(dst.at(x, y), 77);
}

TEST(ReferencePyramid, ImpulseGivesTheBinomialWeights) {
  Plane<std::uint8_t> src(9, 9);
  src.at(4, 4) = 255;
  Plane<std::uint8_t> dst(5, 5);
  detail::reference::pyramid_down(src, dst);
  // dst(2,2) samples src(4,4) with weight 6*6/256; dst(1,2) is two pixels away: 1*6/256.
  EXPECT_EQ(dst.at(2, 2), (36 * 255 + 128) >> 8);
  EXPECT_EQ(dst.at(1, 2), (6 * 255 + 128) >> 8);
  EXPECT_EQ(dst.at(1, 1), (1 * 255 + 128) >> 8);
  EXPECT_EQ(dst.at(0, 0), 0);
}

TEST(ReferenceSubpixel, ParabolaVertexInSixteenths) {
  EXPECT_EQ(detail::subpixel_offset_q4(10, 5, 10), 0);   // symmetric
  EXPECT_EQ(detail::subpixel_offset_q4(10, 0, 0 + 1), 7);  // 16*9/(2*11) = 6.54 -> 7 toward d+1
  EXPECT_EQ(detail::subpixel_offset_q4(20, 10, 15), 3);  // 16*5/(2*15) = 2.67 -> 3
  EXPECT_EQ(detail::subpixel_offset_q4(15, 10, 20), -3);
  EXPECT_EQ(detail::subpixel_offset_q4(11, 10, 10 + 0), 8);  // 16*1/(2*1) = 8: the half-pixel edge
}

TEST(ReferenceLevels, RangesRoundOutward) {
  EXPECT_EQ(detail::level_min(0, 2), 0);
  EXPECT_EQ(detail::level_max(63, 2), 16);
  EXPECT_EQ(detail::level_min(-5, 1), -3);
  EXPECT_EQ(detail::level_max(-5, 1), -2);
  EXPECT_EQ(detail::level_min(7, 1), 3);
  EXPECT_EQ(detail::level_max(7, 1), 4);
}

TEST(ReferenceSearchRanges, PriorNeighbourhoodAndInvalidCentre) {
  Plane<std::int16_t> coarse(3, 1);
  coarse.at(0, 0) = 16 * 4;
  coarse.at(1, 0) = 16 * 6;
  coarse.at(2, 0) = kInvalid;
  Plane<std::int16_t> lo(6, 2), hi(6, 2);
  detail::reference::search_ranges(&coarse, 0, 20, 1, lo, hi);
  // x = 0, 1 -> coarse x 0, neighbours {4, 6}: [2*4 - 1, 2*6 + 1]
  EXPECT_EQ(lo.at(0, 0), 7);
  EXPECT_EQ(hi.at(0, 0), 13);
  // x = 2, 3 -> coarse x 1, neighbours {4, 6, invalid}: the same
  EXPECT_EQ(lo.at(3, 1), 7);
  EXPECT_EQ(hi.at(3, 1), 13);
  // x = 4, 5 -> coarse x 2 is invalid: the whole range
  EXPECT_EQ(lo.at(5, 0), 0);
  EXPECT_EQ(hi.at(5, 0), 20);
  // Clipping to the level range.
  detail::reference::search_ranges(&coarse, 9, 10, 1, lo, hi);
  EXPECT_EQ(lo.at(0, 0), 9);
  EXPECT_EQ(hi.at(0, 0), 10);
}

// A random right image and a left image that is the right one shifted by a constant disparity:
// every pixel whose window sees only shifted content must find that disparity with cost 0.
TEST(ReferenceMatch, ConstantShiftIsFoundExactly) {
  const int w = 48, h = 12, shift = 5;
  Plane<std::uint8_t> right = random_image(w, h, 7);
  Plane<std::uint8_t> left(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) left.at(x, y) = right.at(std::max(x - shift, 0), y);
  detail::CensusCodes cl, cr;
  for (auto* c : {&cl, &cr}) {
    c->words = 1;
    c->plane[0].reset(w, h, detail::kCodePad);
  }
  const detail::CensusConfig census{CensusKind::Census, 5, MeanKernel::Box};
  detail::reference::census_transform(left, census, cl);
  detail::reference::census_transform(right, census, cr);
  Plane<std::int16_t> lo(w, h), hi(w, h), disp(w, h);
  detail::reference::search_ranges(nullptr, 0, 15, 0, lo, hi);
  detail::MatchScratch scratch;
  scratch.bytes_per_thread = detail::reference::match_scratch_bytes(w, 16, 5);
  scratch.data = detail::allocate_aligned<std::uint8_t>(scratch.bytes_per_thread);
  detail::reference::match(cl, cr, detail::SearchRanges::planes(lo, hi), {-1, 5, false, 0}, scratch, disp);
  for (int y = 0; y < h; ++y)
    for (int x = shift + 4; x < w - 4; ++x) ASSERT_EQ(disp.at(x, y), 16 * shift) << x << "," << y;
  // x = 0 of the left view has only d <= 0 in the image: with the range [0, 15] it takes d = 0.
  EXPECT_EQ(disp.at(0, 0), 0);
  // With a range starting at 1 it has no candidate at all.
  detail::reference::search_ranges(nullptr, 1, 15, 0, lo, hi);
  detail::reference::match(cl, cr, detail::SearchRanges::planes(lo, hi), {-1, 5, false, 0}, scratch, disp);
  EXPECT_EQ(disp.at(0, 0), kInvalid);
  EXPECT_EQ(disp.at(1, 0), 16);
}

// The winner's margin 255 (S2 - S1) / S2, S2 the best cost outside best - 1 .. best + 1, on codes
// set by hand (a 1 x 1 window: the cost is the popcount of one XOR).
TEST(ReferenceMatch, MarginSkipsTheWinnersNeighbours) {
  const int w = 8, h = 1;
  detail::CensusCodes cl, cr;
  for (auto* c : {&cl, &cr}) {
    c->words = 1;
    c->plane[0].reset(w, h, detail::kCodePad);
  }
  cl.plane[0].at(4, 0) = 1u << 8;
  // Pixel 4 of the left view against right pixels 4 - d: costs 5, 2, 1, 3, 4 for d = 0 .. 4.
  const std::uint32_t right_codes[5] = {0b111, 0b11, 0, 0b1, 0b1111};
  for (int x = 0; x < 5; ++x) cr.plane[0].at(x, 0) = right_codes[x];
  Plane<std::int16_t> lo(w, h), hi(w, h), disp(w, h);
  Plane<std::uint8_t> margin(w, h);
  detail::reference::search_ranges(nullptr, 0, 4, 0, lo, hi);
  detail::MatchScratch scratch;
  scratch.bytes_per_thread = detail::reference::match_scratch_bytes(w, 5, 1);
  scratch.data = detail::allocate_aligned<std::uint8_t>(scratch.bytes_per_thread);
  detail::reference::match(cl, cr, detail::SearchRanges::planes(lo, hi), {-1, 1, false, 0}, scratch, disp, &margin);
  EXPECT_EQ(disp.at(4, 0), 16 * 2);
  // S1 = 1 at d = 2; d = 1 (cost 2) and d = 3 are its neighbours, so S2 = 4 (d = 4): 255 x 3 / 4.
  EXPECT_EQ(margin.at(4, 0), 191);
  // Pixel 0 has one candidate in the image (d = 0) and pixel 1 two (d = 0, 1): the image border
  // cuts their bands, and a winner without both neighbours and without a rival has margin 0.
  EXPECT_EQ(margin.at(0, 0), 0);
  EXPECT_EQ(margin.at(1, 0), 0);
  // With a range starting at 1, pixel 0 has no candidate: invalid, margin 0.
  margin.at(0, 0) = 99;
  detail::reference::search_ranges(nullptr, 1, 4, 0, lo, hi);
  detail::reference::match(cl, cr, detail::SearchRanges::planes(lo, hi), {-1, 1, false, 0}, scratch, disp, &margin);
  EXPECT_EQ(disp.at(0, 0), kInvalid);
  EXPECT_EQ(margin.at(0, 0), 0);
  EXPECT_EQ(margin.at(4, 0), 191);
  // The band 1 .. 3 of pixel 4 (costs 2, 1, 3) holds the winner d = 2 and its two neighbours and
  // nothing else: no rival, margin 255.
  detail::reference::search_ranges(nullptr, 1, 3, 0, lo, hi);
  detail::reference::match(cl, cr, detail::SearchRanges::planes(lo, hi), {-1, 1, false, 0}, scratch, disp, &margin);
  EXPECT_EQ(disp.at(4, 0), 16 * 2);
  EXPECT_EQ(margin.at(4, 0), 255);
}

TEST(ReferenceUpscale, ReplicatesScalesAndClamps) {
  Plane<std::int16_t> src(2, 1);
  src.at(0, 0) = 16 * 3;
  src.at(1, 0) = kInvalid;
  Plane<std::int16_t> dst(3, 2);
  detail::reference::upscale(src, 2, 0, 16 * 5, dst);
  EXPECT_EQ(dst.at(0, 0), 16 * 5);  // 6 clamped to the range maximum 5
  EXPECT_EQ(dst.at(1, 1), 16 * 5);
  EXPECT_EQ(dst.at(2, 0), kInvalid);
}

}  // namespace
}  // namespace mctstereo::test
