// The opencl band SGM stages against the reference stages, bit for bit: the band planes, every
// entry of the cost and sum volumes (entries past a pixel's count included), the left and right
// maps and the margins, then the confidence; with and without a coarse prior (3x3 and 5x5, cut
// bands), every SHD window, 1 to 3 census words, 4 and 8 paths, adaptive and constant P2,
// sub-pixel and uniqueness, both popcount forms, 1-row and odd sizes.
#include <cstdint>
#include <string>
#include <vector>

#include "opencl/stages.hpp"
#include "opencl_test_util.hpp"
#include "test_util.hpp"

namespace mctstereo::test {
namespace {

using detail::opencl::DeviceCodes;
using detail::opencl::DevicePlane;
using detail::opencl::DeviceSgmVolume;
using detail::opencl::Popcount;
using detail::opencl::Runtime;

struct StageCase {
  int w, h, dmin, dmax;
  bool prior;
  int prior_size, max_band, radius, shd_window, census_window, paths, p2_k;
  bool subpixel;
  int uniqueness;
  Popcount popcount;
  int temporal_radius = -1;  ///< the temporal prior's radius (with a prior); -1: none
};

std::string name_of(const StageCase& c) {
  return std::to_string(c.w) + "x" + std::to_string(c.h) + " d " + std::to_string(c.dmin) + ".." +
         std::to_string(c.dmax) + (c.prior ? " prior " + std::to_string(c.prior_size) : " no prior") + " band " +
         std::to_string(c.max_band) + " a " + std::to_string(c.shd_window) + " ct " + std::to_string(c.census_window) +
         " paths " + std::to_string(c.paths) + " k " + std::to_string(c.p2_k) + (c.subpixel ? " subpixel" : "") +
         " unique " + std::to_string(c.uniqueness) + (c.popcount == Popcount::Swar ? " swar" : " builtin") +
         (c.temporal_radius >= 0 ? " temporal " + std::to_string(c.temporal_radius) : "");
}

DeviceCodes to_device_codes(Runtime& rt, const detail::CensusCodes& host) {
  DeviceCodes d;
  d.words = host.words;
  for (int k = 0; k < host.words; ++k) d.plane[k] = to_device(rt, host.plane[k]);
  return d;
}

template <typename T>
std::vector<T> read_buffer(Runtime& rt, const cl::Buffer& buffer, std::size_t n) {
  std::vector<T> out(n);
  rt.queue().enqueueReadBuffer(buffer, CL_TRUE, 0, n * sizeof(T), out.data());
  return out;
}

// The index of the first difference of two arrays, or -1.
long first_mismatch(const std::uint16_t* a, const std::vector<std::uint16_t>& b) {
  for (std::size_t i = 0; i < b.size(); ++i)
    if (a[i] != b[i]) return static_cast<long>(i);
  return -1;
}

// byte_costs: the device volume keeps its costs in bytes (the case's costs must lie below 255);
// the reference's 16-bit costs are compared with them entry by entry.
void expect_stages_equal(Runtime& rt, const StageCase& c, bool byte_costs) {
  SCOPED_TRACE(name_of(c) + (byte_costs ? ", byte costs" : ""));
  const ShiftedPair pair = shifted_pair(c.w, c.h, 7 + c.w, std::max(0, (c.dmin + c.dmax) / 2));
  const detail::CensusCodes left = reference_census(pair.left, c.census_window, CensusKind::Census);
  const detail::CensusCodes right = reference_census(pair.right, c.census_window, CensusKind::Census);
  const int cw = (c.w + 1) / 2, ch = (c.h + 1) / 2;
  const Plane<std::int16_t> coarse =
      random_disparity(cw, ch, 3, 16 * (c.dmin / 2), 16 * (c.dmax / 2 + 1), 0.15, true);
  detail::SgmBandConfig band{c.dmin, c.dmax, c.radius, c.prior_size, c.max_band};
  // The temporal prior: a previous map near twice the coarse values (+-1 px, Q4 fractions) where
  // the random map is valid, and gray images whose change straddles the threshold (12).
  const bool temporal = c.temporal_radius >= 0;
  Plane<std::int16_t> previous = random_disparity(c.w, c.h, 5, -16, 16, 0.2, false);
  for (int y = 0; y < c.h; ++y)
    for (int x = 0; x < c.w; ++x) {
      const int prior = coarse.at(std::min(x / 2, cw - 1), std::min(y / 2, ch - 1));
      std::int16_t& v = previous.at(x, y);
      if (prior == detail::kInvalid) v = detail::kInvalid;
      if (v != detail::kInvalid) v = static_cast<std::int16_t>(std::clamp(2 * prior + v, 16 * c.dmin, 16 * c.dmax));
    }
  Plane<std::uint8_t> previous_image(c.w, c.h);
  for (int y = 0; y < c.h; ++y)
    for (int x = 0; x < c.w; ++x)
      previous_image.at(x, y) =
          static_cast<std::uint8_t>(std::clamp(pair.left.at(x, y) + (x * 7 + y * 3) % 27 - 13, 0, 255));
  if (temporal) band.temporal = {&previous, &pair.left, &previous_image, c.temporal_radius, 12};
  const detail::SgmPathConfig paths{c.paths, 20, 150, c.p2_k};
  const detail::SgmSelectConfig select{c.subpixel, c.uniqueness};

  // The reference stages on host storage.
  const std::size_t entries = detail::SgmVolume::entries_for(c.w, c.h, c.max_band);
  std::vector<std::uint16_t> cost(entries), sum(entries);
  detail::SgmVolume host;
  host.reset(c.w, c.h, c.max_band, left.words, cost.data(), sum.data());
  detail::SgmScratch scratch;
  scratch.bytes_per_thread = detail::reference::sgm_scratch_bytes(c.w, c.h, host.stride);
  scratch.data = detail::allocate_aligned<std::uint8_t>(scratch.bytes_per_thread);
  Plane<std::int16_t> want_left(c.w, c.h), want_right(c.w, c.h);
  Plane<std::uint8_t> want_margin(c.w, c.h);
  detail::reference::sgm_costs(left, right, c.prior ? &coarse : nullptr, band, c.shd_window, scratch, host);
  const std::vector<std::uint16_t> want_cost = cost;
  if (temporal) {
    // The case narrows bands (else it would test nothing of the rule).
    detail::SgmBandConfig alone = band;
    alone.temporal = {};
    std::vector<std::uint16_t> cost_alone(entries), sum_alone(entries);
    detail::SgmVolume volume_alone;
    volume_alone.reset(c.w, c.h, c.max_band, left.words, cost_alone.data(), sum_alone.data());
    detail::reference::sgm_costs(left, right, &coarse, alone, c.shd_window, scratch, volume_alone);
    long narrowed = 0;
    for (int y = 0; y < c.h; ++y)
      for (int x = 0; x < c.w; ++x) narrowed += host.count.at(x, y) < volume_alone.count.at(x, y);
    EXPECT_GT(narrowed, c.w * c.h / 20) << "pixels narrowed by the temporal prior";
  }
  detail::reference::sgm_aggregate(pair.left, paths, scratch, host);
  detail::reference::sgm_select(host, select, scratch, want_left, &want_right, &want_margin);

  // The same on the device.
  DeviceSgmVolume dev;
  dev.width = c.w, dev.height = c.h, dev.band = c.max_band, dev.stride = host.stride;
  dev.lo = marked_plane<std::int16_t>(rt, c.w, c.h);
  dev.count = marked_plane<std::int16_t>(rt, c.w, c.h);
  dev.byte_costs = byte_costs;
  dev.cost = rt.buffer(entries * (byte_costs ? 1 : 2));
  dev.sum = rt.buffer(entries * 2);
  dev.scratch = rt.buffer(DeviceSgmVolume::scratch_entries_for(c.w, c.h, c.max_band) * 2);
  const DeviceCodes dl = to_device_codes(rt, left), dr = to_device_codes(rt, right);
  const DevicePlane<std::int16_t> dcoarse = to_device(rt, coarse);
  const DevicePlane<std::uint8_t> gray = to_device(rt, pair.left);
  DevicePlane<std::int16_t> got_left = marked_plane<std::int16_t>(rt, c.w, c.h);
  DevicePlane<std::int16_t> got_right = marked_plane<std::int16_t>(rt, c.w, c.h);
  DevicePlane<std::uint8_t> got_margin = marked_plane<std::uint8_t>(rt, c.w, c.h);
  const DevicePlane<std::int16_t> dprevious = to_device(rt, previous);
  const DevicePlane<std::uint8_t> dprevious_image = to_device(rt, previous_image);
  const detail::opencl::DeviceTemporal dtemporal{&dprevious, &gray, &dprevious_image, c.temporal_radius, 12};
  detail::opencl::SgmCosts(rt, c.popcount)
      .run(dl, dr, c.prior ? &dcoarse : nullptr, band, c.shd_window, dev, temporal ? &dtemporal : nullptr);
  std::vector<std::uint16_t> got_cost(entries);
  if (byte_costs) {
    const std::vector<std::uint8_t> bytes = read_buffer<std::uint8_t>(rt, dev.cost, entries);
    for (std::size_t i = 0; i < entries; ++i) got_cost[i] = bytes[i] == detail::kSgmInf8 ? detail::kSgmInf : bytes[i];
  } else {
    got_cost = read_buffer<std::uint16_t>(rt, dev.cost, entries);
  }
  detail::opencl::SgmAggregate(rt).run(gray, paths, dev);
  detail::opencl::SgmSelect(rt).run(dev, select, c.dmin, c.dmax, got_left, &got_right, &got_margin);

  EXPECT_EQ(first_difference(to_host(rt, dev.lo), host.lo), "") << "lo";
  EXPECT_EQ(first_difference(to_host(rt, dev.count), host.count), "") << "count";
  EXPECT_EQ(first_mismatch(want_cost.data(), got_cost), -1) << "cost entry";
  EXPECT_EQ(first_mismatch(sum.data(), read_buffer<std::uint16_t>(rt, dev.sum, entries)), -1) << "sum entry";
  EXPECT_EQ(first_difference(to_host(rt, got_left), want_left), "") << "left map";
  EXPECT_EQ(first_difference(to_host(rt, got_right), want_right), "") << "right map";
  EXPECT_EQ(first_difference(to_host(rt, got_margin), want_margin), "") << "margin";
  for (const auto* p : {&got_left, &got_right}) EXPECT_EQ(padding_difference(rt, *p), "");
  EXPECT_EQ(padding_difference(rt, got_margin), "");

  // The confidence of the left map against the right one, and without a right map; then with the
  // margins of a level twice and four times smaller (every other and every fourth margin).
  for (bool with_right : {true, false}) {
    Plane<std::uint8_t> want(c.w, c.h);
    detail::reference::confidence(want_margin, 0, want_left, with_right ? &want_right : nullptr, 1, want);
    DevicePlane<std::uint8_t> got = marked_plane<std::uint8_t>(rt, c.w, c.h);
    detail::opencl::Confidence(rt).run(got_margin, 0, got_left, with_right ? &got_right : nullptr, 1, got);
    EXPECT_EQ(first_difference(to_host(rt, got), want), "") << "confidence, right map " << with_right;
    EXPECT_EQ(padding_difference(rt, got), "");
  }
  for (int shift : {1, 2}) {
    const int mw = ((c.w - 1) >> shift) + 1, mh = ((c.h - 1) >> shift) + 1;
    Plane<std::uint8_t> coarse_margin(mw, mh), want(c.w, c.h);
    for (int y = 0; y < mh; ++y)
      for (int x = 0; x < mw; ++x) coarse_margin.at(x, y) = want_margin.at(x << shift, y << shift);
    detail::reference::confidence(coarse_margin, shift, want_left, &want_right, 1, want);
    DevicePlane<std::uint8_t> got = marked_plane<std::uint8_t>(rt, c.w, c.h);
    detail::opencl::Confidence(rt).run(to_device(rt, coarse_margin), shift, got_left, &got_right, 1, got);
    EXPECT_EQ(first_difference(to_host(rt, got), want), "") << "confidence, margin shift " << shift;
  }
}

TEST(OpenclSgmStages, EqualReference) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  const Popcount swar = Popcount::Swar, builtin = Popcount::Builtin;
  const std::vector<StageCase> cases = {
      // w, h, dmin, dmax, prior, prior_size, max_band, radius, a, census, paths, k, subpixel, unique, popcount
      {53, 27, 0, 15, false, 5, 16, 3, 3, 5, 4, 8, false, 10, swar},
      {53, 27, 0, 31, true, 5, 9, 3, 3, 5, 8, 8, true, 0, swar},
      {40, 19, -6, 12, true, 3, 14, 2, 5, 7, 4, 0, true, 15, builtin},
      {33, 1, 0, 9, true, 5, 8, 1, 1, 9, 8, 8, false, 10, swar},
      {17, 2, -3, 5, false, 5, 9, 3, 7, 3, 8, 4, true, 5, builtin},
      {70, 9, 0, 63, false, 5, 64, 3, 9, 5, 4, 8, true, 10, swar},
      {1, 12, 0, 0, true, 5, 1, 3, 3, 5, 8, 8, true, 10, swar},
      // The temporal prior: radius 0 and 1, 5x5 and 3x3 priors, a negative range, a band cut.
      {53, 27, 0, 31, true, 5, 16, 3, 3, 5, 4, 16, false, 10, swar, 1},
      {41, 20, -6, 12, true, 3, 14, 2, 3, 5, 4, 8, false, 0, swar, 0},
      {37, 3, 0, 23, true, 3, 8, 3, 3, 5, 4, 8, false, 10, swar, 1},
  };
  for (const StageCase& c : cases) {
    if (c.popcount == builtin && !rt->device().has_popcount) continue;
    expect_stages_equal(*rt, c, false);
    if (detail::sgm_byte_costs(c.shd_window, c.census_window)) expect_stages_equal(*rt, c, true);
  }
}

}  // namespace
}  // namespace mctstereo::test
