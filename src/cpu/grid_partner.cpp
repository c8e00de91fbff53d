// The left map's LR partners on the right map's grid, grid row by grid row
// (cpu/grid_partner_row-inl.h).
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cpu/grid_partner.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include "cpu/grid_partner_row-inl.h"

#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "cpu/match_tiles.hpp"
#include "cpu/parallel.hpp"
#include "stages.hpp"

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {

void GridPartner(const Plane<std::int16_t>& right, int k, MatchScratch& scratch, Plane<std::int16_t>& partner) {
  const int w = right.width(), h = right.height();
  const std::ptrdiff_t stride = grid_row_stride(w);
  // Each thread's slice holds the grid rows from its first 64-byte boundary: less is a driver
  // bug, not an input.
  if (aligned_slice_bytes(scratch) < grid_rows_bytes(w)) std::abort();
  if (t_pool && t_pool->size() > scratch.threads) std::abort();
  parallel_lines(
      (h + 1) / 2,
      [&](int j0, int j1) {
        std::int16_t* rows = reinterpret_cast<std::int16_t*>(aligned_slice(scratch, thread_slot()));
        for (int j = j0; j < j1; ++j) {
          GridPartnerRow(right, k, j, rows, stride, partner.row(2 * j));
          if (2 * j + 1 < h) std::memcpy(partner.row(2 * j + 1), partner.row(2 * j), sizeof(std::int16_t) * w);
        }
      },
      scratch.threads);
}

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mctstereo::detail::cpu {
HWY_EXPORT(GridPartner);

void grid_partner(const Plane<std::int16_t>& right, int median_size, MatchScratch& scratch,
                  Plane<std::int16_t>& partner) {
  if (right.empty()) return;
  HWY_DYNAMIC_DISPATCH(GridPartner)(right, median_size, scratch, partner);
}

// + kAlignment: the driver's slices start anywhere; each thread aligns its own.
std::size_t grid_partner_scratch_bytes(int width) { return grid_rows_bytes(width) + kAlignment; }

}  // namespace mctstereo::detail::cpu
#endif  // HWY_ONCE
