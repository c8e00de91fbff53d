// SHD cost and winner-takes-all (reference::match) for one view, with the per-pixel search ranges
// of search_range_at() made on the fly from the coarse prior, and with the temporal prior's rule
// (with_temporal_prior()) where previous_map is not null.
//
// Options: -DSHD_A=a (1, 3, 5, 7 or 9); -DCODE_WORDS=k (1, 2 or 3 planes of census words);
// -DSUBPIXEL=0/1 (parabola fit into Q4); -DUNIQUENESS=0/1 (ratio test on, the ratio an argument);
// -DMARGIN=0/1 (the winners' margins into `margin` when that argument is not null);
// -DPOPCOUNT_SWAR=0/1 (the SWAR bit count of OpenCL 1.1 devices instead of popcount());
// -DROWS=n (image rows per work-item); -DFULL_UNROLL=0/1 (unroll the loops over rows).
//
// Work: one work-item matches a strip of 16 columns x0 .. x0 + 15 by ROWS rows y0 .. y0 + ROWS - 1.
// It walks the union of its pixels' candidate intervals once, in increasing d, and for each d
//  1. computes the Hamming rows H(x', y', d) = sum_k popcount(ref_k(x', y') ^ other_k(x' + dir d, y'))
//     of the strip's columns and window margins (x' = x0 - h .. x0 + 15 + h: a uint16 and a uint8
//     vector, h = a / 2) for the ROWS + a - 1 rows its windows touch;
//  2. keeps a vertical running sum over the last a Hamming rows (add the row entering, subtract
//     the row leaving, the last a rows kept in a ring), so that a candidate costs ROWS + a - 1
//     Hamming rows for ROWS output rows instead of ROWS * a;
//  3. sums a horizontally shifted copies of the vertical sum (constant shuffles) into the 16 box
//     costs of an output row, and
//  4. feeds them into a one-pass winner-takes-all whose state (per pixel: best cost and
//     disparity, the costs beside the best, the second best outside best - 1 .. best + 1) is
//     private to the work-item.
// The cost volume is never written anywhere, not even in local memory: each cost is used once,
// the moment it is made. Costs are at most 9 * 9 * 80 = 6480, so they are short lanes and
// COST_INF = SHRT_MAX is above every cost.
//
// Why this shape, for a GPU as much as for a CPU device:
// - 16 pixels per work-item amortise the 2h margin columns of every Hamming row (24 columns for
//   16 pixels at h = 4) and load 64 contiguous bytes per code plane and row. On a CPU device the
//   short16 lanes are SIMD registers; on a GPU a work-item runs them as scalar instructions, as
//   many as 16 work-items of one pixel would, without sharing the margins through local memory.
// - The candidate loop runs over the union of only 16 x ROWS pixels' intervals, and per
//   candidate only over the rows whose intervals hold it. At the finer pyramid levels every pixel
//   searches a few candidates around its prior, and a small union follows the per-pixel widths;
//   a work-group-wide union (a tile sharing Hamming rows in local memory, with barriers per
//   candidate) spans both surfaces at every depth edge inside the tile, and a pixel whose prior is
//   invalid (whole range) would make its whole tile search the whole range.
// - No local memory and no barriers: work-items are independent, so any work-group size works
//   and the occupancy is set by registers alone. ROWS trades the vertical reuse (window rows
//   shared by the running sum) against the winner-takes-all state of 16 x ROWS pixels: the host
//   takes 1 row on GPUs (state in registers), 16 on CPU devices (state in the L1 cache).
//
// Borders: the reference clamps every read to the image. A Hamming row needs the 16 + 2h columns
// starting at x0 - h (ref) and x0 - h + dir d (other); where those lie inside the row they are
// plain vector loads, elsewhere (left and right borders, and candidates whose shifted columns
// leave the image) they are gathered column by column with clamped indices. Candidates whose
// matching pixel x + dir d is outside the image are no candidates at all (cost COST_INF for that
// lane), as in the reference.

#define HALF (SHD_A / 2)
// The second best outside best - 1 .. best + 1 serves the uniqueness test and the margin.
#define TRACK_SECOND (UNIQUENESS || MARGIN)

// Full unrolling of the loops over rows makes every array index a constant, so that the ring of
// Hamming rows and the winner-takes-all state are registers: what a GPU needs (a private array
// indexed at run time lives in slow off-chip memory there). CPU devices keep such arrays in the
// L1 cache anyway, and PoCL takes seconds to compile the unrolled loops.
#if FULL_UNROLL
#define UNROLL _Pragma("unroll")
#else
#define UNROLL
#endif
#define COST_INF 32767
#define DISPARITY_INVALID (-32768)  // kInvalid

#if POPCOUNT_SWAR
// The classic SWAR bit count: pairs, nibbles, bytes, then a multiply adds the four bytes into the
// top one. OpenCL C 1.1 has no popcount(). (On PoCL this form is also the faster one: LLVM turns
// it into a vector bit count, while the popcount() built-in runs element by element.)
#define DEFINE_POPCOUNT(T)                                             \
  T popcount_##T(T v) {                                                \
    v = v - ((v >> (T)(1)) & (T)(0x55555555u));                        \
    v = (v & (T)(0x33333333u)) + ((v >> (T)(2)) & (T)(0x33333333u));   \
    v = (v + (v >> (T)(4))) & (T)(0x0F0F0F0Fu);                        \
    return (v * (T)(0x01010101u)) >> (T)(24);                          \
  }
DEFINE_POPCOUNT(uint16)
DEFINE_POPCOUNT(uint8)
#define POPCOUNT16(v) popcount_uint16(v)
#define POPCOUNT8(v) popcount_uint8(v)
#else
#define POPCOUNT16(v) popcount(v)
#define POPCOUNT8(v) popcount(v)
#endif

// Columns start .. start + 15 of a row of codes, clamped to [0, width - 1]: one vector load where
// they lie inside the row, else column by column.
uint16 load16(const __global uint* row, int start, int width) {
  if (start >= 0 && start + 16 <= width) return vload16(0, row + start);
  uint column[16];
  for (int i = 0; i < 16; ++i) column[i] = row[clamp(start + i, 0, width - 1)];
  return vload16(0, column);
}

// Columns start + 16 .. start + 23, clamped. Only the first 2h of them enter a box sum, so the
// vector load needs only those inside the row: the others may read the row's slack (rows are
// padded by at least 16 elements) and feed lanes that are never used.
uint8 load8(const __global uint* row, int start, int width) {
  if (start >= 0 && start + 16 + 2 * HALF <= width) return vload8(0, row + start + 16);
  uint column[8];
  for (int i = 0; i < 8; ++i) column[i] = row[clamp(start + 16 + i, 0, width - 1)];
  return vload8(0, column);
}

// Lanes k .. k + 15 of the 24 lanes (lo, hi): the vertical sums of the columns k further right.
// Written as swizzles (constant shuffles the compiler sees) rather than shuffle2(), which some
// implementations (PoCL) run as a library call per element.
#define SHIFTED1(lo, hi) (short16)((lo).s12345678, (lo).s9abc, (lo).sdef, (hi).s0)
#define SHIFTED2(lo, hi) (short16)((lo).s23456789, (lo).sabcd, (lo).sef, (hi).s01)
#define SHIFTED3(lo, hi) (short16)((lo).s3456789a, (lo).sbcde, (lo).sf, (hi).s012)
#define SHIFTED4(lo, hi) (short16)((lo).s456789ab, (lo).scdef, (hi).s0123)
#define SHIFTED5(lo, hi) (short16)((lo).s56789abc, (lo).sdef, (hi).s0123, (hi).s4)
#define SHIFTED6(lo, hi) (short16)((lo).s6789abcd, (lo).sef, (hi).s0123, (hi).s45)
#define SHIFTED7(lo, hi) (short16)((lo).s789abcde, (lo).sf, (hi).s0123, (hi).s456)
#define SHIFTED8(lo, hi) (short16)((lo).s89abcdef, (hi))

short smallest(short16 v) {
  const short8 m8 = min(v.lo, v.hi);
  const short4 m4 = min(m8.lo, m8.hi);
  const short2 m2 = min(m4.lo, m4.hi);
  return min(m2.x, m2.y);
}
short largest(short16 v) {
  const short8 m8 = max(v.lo, v.hi);
  const short4 m4 = max(m8.lo, m8.hi);
  const short2 m2 = max(m4.lo, m4.hi);
  return max(m2.x, m2.y);
}

// The extrema of search_range_at() for the 16 pixels x0 .. x0 + 15 of the rows whose coarse row is
// cy: min and max (whole pixels) of the valid coarse values in the 3x3 around (x / 2, cy), clamped
// to the coarse plane, and whether the centre is invalid. Pixels x0 + 2k and x0 + 2k + 1 share
// coarse column x0 / 2 + k (x0 is even), so the rule runs on 8 lanes (widened by range_of()).
// Away from the coarse plane's left and right edges the three columns of a coarse row are three
// vector loads.
typedef struct {
  int8 mn, mx, whole;
} PriorExtrema;

PriorExtrema prior_extrema(const __global short* prior, int prior_stride, int prior_width, int prior_height, int x0,
                           int cy) {
  const int c0 = x0 / 2;
  const bool inside = c0 >= 1 && c0 + 8 < prior_width;
  int8 centre, mn = (int8)(1 << 20), mx = (int8)(-(1 << 20));
  for (int j = -1; j <= 1; ++j) {
    const __global short* row = prior + (size_t)clamp(cy + j, 0, prior_height - 1) * prior_stride;
    for (int i = -1; i <= 1; ++i) {
      int8 v;
      if (inside) {
        v = convert_int8(vload8(0, row + c0 + i));
      } else {
        int value[8];
        for (int k = 0; k < 8; ++k) value[k] = row[clamp(min(c0 + k, prior_width - 1) + i, 0, prior_width - 1)];
        v = vload8(0, value);
      }
      if (i == 0 && j == 0) centre = v;
      const int8 valid = v != (int8)(DISPARITY_INVALID);
      mn = select(mn, min(mn, v >> 4), valid);
      mx = select(mx, max(mx, v >> 4), valid);
    }
  }
  PriorExtrema e = {mn, mx, centre == (int8)(DISPARITY_INVALID)};
  return e;
}

// search_range_at() with radius r from the extrema: [2 min - r, 2 max + r] clipped to [dmin, dmax];
// the whole range where the centre is invalid.
void range_of(PriorExtrema e, int dmin, int dmax, int radius, short16* lo, short16* hi) {
  const short8 lo8 =
      convert_short8(select(min(max((int8)(dmin), 2 * e.mn - radius), (int8)(dmax)), (int8)(dmin), e.whole));
  const short8 hi8 =
      convert_short8(select(max(min((int8)(dmax), 2 * e.mx + radius), (int8)(dmin)), (int8)(dmax), e.whole));
  *lo = (short16)(lo8.s00112233, lo8.s44556677);
  *hi = (short16)(hi8.s00112233, hi8.s44556677);
}

// 16 values of a row at columns x0 + i + k (k = 0 .. 15) clamped to [0, width - 1].
int16 row16(const __global short* row, int x0, int i, int width) {
  if (x0 + i >= 0 && x0 + i + 16 <= width) return convert_int16(vload16(0, row + x0 + i));
  int value[16];
  for (int k = 0; k < 16; ++k) value[k] = row[clamp(x0 + i + k, 0, width - 1)];
  return vload16(0, value);
}
int16 gray16(const __global uchar* row, int x0, int width) {
  if (x0 + 16 <= width) return convert_int16(vload16(0, row + x0));
  int value[16];
  for (int k = 0; k < 16; ++k) value[k] = row[min(x0 + k, width - 1)];
  return vload16(0, value);
}

// temporal_band_at() of stages.hpp for the 16 pixels x0 .. x0 + 15 of row y: [min - r, max + r] of
// the previous frame's valid values in the 3x3 around each (floor of the Q4 values for the minimum,
// ceiling for the maximum), clipped to [dmin, dmax]; empty (lo > hi) where the previous centre is
// invalid or the gray value changed by more than `threshold`. Columns past the image read the
// last one (their lanes are no pixels).
void temporal_range(const __global short* previous_map, int previous_map_stride, const __global uchar* image,
                    int image_stride, const __global uchar* previous_image, int previous_image_stride, int width,
                    int height, int x0, int y, int dmin, int dmax, int radius, int threshold, short16* lo,
                    short16* hi) {
  int16 centre, mn = (int16)(1 << 20), mx = (int16)(-(1 << 20));
  for (int j = -1; j <= 1; ++j) {
    const __global short* row = previous_map + (size_t)clamp(y + j, 0, height - 1) * previous_map_stride;
    for (int i = -1; i <= 1; ++i) {
      const int16 v = row16(row, x0, i, width);
      if (i == 0 && j == 0) centre = v;
      const int16 valid = v != (int16)(DISPARITY_INVALID);
      mn = select(mn, min(mn, v >> 4), valid);
      mx = select(mx, max(mx, (v + 15) >> 4), valid);
    }
  }
  const int16 now = gray16(image + (size_t)y * image_stride, x0, width);
  const int16 then = gray16(previous_image + (size_t)y * previous_image_stride, x0, width);
  const int16 empty = (centre == (int16)(DISPARITY_INVALID)) | (abs_diff(now, then) > (uint16)(threshold));
  *lo = convert_short16(select(min(max((int16)(dmin), mn - radius), (int16)(dmax)), (int16)(1), empty));
  *hi = convert_short16(select(max(min((int16)(dmax), mx + radius), (int16)(dmin)), (int16)(0), empty));
}

__kernel void match(__global const uint* ref0, __global const uint* ref1, __global const uint* ref2,
                    __global const uint* other0, __global const uint* other1, __global const uint* other2,
                    int code_stride, int width, int height, __global const short* prior, int prior_stride,
                    int prior_width, int prior_height, int dmin, int dmax, int radius, int dir, int uniqueness_ratio,
                    __global short* disparity, int disparity_stride, __global uchar* margin, int margin_stride,
                    __global const short* previous_map, int previous_map_stride, __global const uchar* image,
                    int image_stride, __global const uchar* previous_image, int previous_image_stride,
                    int temporal_radius, int temporal_threshold) {
  const int x0 = (int)get_global_id(0) * 16;
  const int y0 = (int)get_global_id(1) * ROWS;
  if (x0 >= width || y0 >= height) return;

  const short16 lane = (short16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  const short16 x = (short16)((short)x0) + lane;
  // Candidates whose matching pixel x + dir d lies in the image: dir < 0: x - w < d <= x;
  // dir > 0: -x <= d < w - x. Columns beyond the image get an empty interval.
  const short16 in_image_lo = dir < 0 ? x - (short16)((short)(width - 1)) : -x;
  const short16 in_image_hi = dir < 0 ? x : (short16)((short)(width - 1)) - x;
  const short16 beyond = x >= (short16)((short)width);

  // Per pixel: the candidate interval [F, L] and the winner-takes-all state.
  short16 first[ROWS], last[ROWS];
  short16 best_cost[ROWS], best_d[ROWS];
#if SUBPIXEL
  short16 previous[ROWS], before_best[ROWS], after_best[ROWS];  // costs at d - 1, best - 1, best + 1
#endif
#if TRACK_SECOND
  short16 second[ROWS], min_upto1[ROWS], min_upto2[ROWS];  // second best; minima up to d - 1, d - 2
#endif
  // The hull of each row's intervals: a candidate outside it needs neither the row's winner-takes-
  // all step nor the Hamming rows of its window (a prior whose centre is invalid searches the
  // whole range, but only in its own rows).
  short row_lo[ROWS], row_hi[ROWS];
  short union_lo = COST_INF, union_hi = -COST_INF;
  short16 lo = (short16)((short)dmin), hi = (short16)((short)dmax);
  // With the temporal prior (previous_map != 0): the coarse rule at the temporal radius too.
  short16 coarse_lo = lo, coarse_hi = hi, narrow_lo = lo, narrow_hi = hi;
  int prior_row = -1;  // coarse row of the coarse ranges
UNROLL
  for (int r = 0; r < ROWS; ++r) {
    const int cy = min((y0 + r) / 2, prior_height - 1);
    if (prior != 0 && cy != prior_row) {
      const PriorExtrema e = prior_extrema(prior, prior_stride, prior_width, prior_height, x0, cy);
      range_of(e, dmin, dmax, radius, &coarse_lo, &coarse_hi);
      if (previous_map != 0) range_of(e, dmin, dmax, temporal_radius, &narrow_lo, &narrow_hi);
      prior_row = cy;
    }
    lo = coarse_lo;
    hi = coarse_hi;
    if (prior != 0 && previous_map != 0 && y0 + r < height) {
      // with_temporal_prior(): the previous frame's band where it lies inside the coarse band,
      // joined with the narrowed coarse band.
      short16 t_lo, t_hi;
      temporal_range(previous_map, previous_map_stride, image, image_stride, previous_image, previous_image_stride, width,
                     height, x0, y0 + r, dmin, dmax, temporal_radius, temporal_threshold, &t_lo, &t_hi);
      const short16 use = (t_lo <= t_hi) & (t_lo >= coarse_lo) & (t_hi <= coarse_hi);
      lo = select(coarse_lo, min(narrow_lo, t_lo), use);
      hi = select(coarse_hi, max(narrow_hi, t_hi), use);
    }
    const short16 outside = beyond | (short16)(y0 + r >= height ? -1 : 0);
    first[r] = select(max(lo, in_image_lo), (short16)(COST_INF), outside);
    last[r] = select(min(hi, in_image_hi), (short16)(-COST_INF), outside);
    row_lo[r] = smallest(first[r]);
    row_hi[r] = largest(last[r]);
    union_lo = min(union_lo, row_lo[r]);
    union_hi = max(union_hi, row_hi[r]);
    best_cost[r] = (short16)(COST_INF);
    best_d[r] = (short16)(0);
#if SUBPIXEL
    previous[r] = before_best[r] = after_best[r] = (short16)(COST_INF);
#endif
#if TRACK_SECOND
    second[r] = min_upto1[r] = min_upto2[r] = (short16)(COST_INF);
#endif
  }

  const int ref_start = x0 - HALF;
  for (int d = union_lo; d <= union_hi; ++d) {
    const int other_start = ref_start + dir * d;
    const short16 dv = (short16)((short)d);
    int r_first = ROWS, r_last = -1;  // the rows whose hull holds d
UNROLL
    for (int r = 0; r < ROWS; ++r) {
      if (row_lo[r] <= d && d <= row_hi[r]) {
        r_first = min(r_first, r);
        r_last = r;
      }
    }
    short16 vsum_lo = (short16)(0), ring_lo[SHD_A];
#if HALF > 0
    short8 vsum_hi = (short8)(0), ring_hi[SHD_A];
#endif
    // Hamming row t is image row y0 - h + t; output row r has the window rows t = r .. r + a - 1.
    int slot = 0;  // t % a
UNROLL
    for (int t = 0; t < ROWS + SHD_A - 1; ++t) {
      // Rows outside the windows of the rows that search d enter the running sum as zeros.
      short16 h_lo = (short16)(0);
      short8 h_hi = (short8)(0);  // unused where h = 0
      if (t >= r_first && t <= r_last + SHD_A - 1) {
        const size_t row = (size_t)clamp(y0 - HALF + t, 0, height - 1) * code_stride;
        uint16 ones_lo = POPCOUNT16(load16(ref0 + row, ref_start, width) ^ load16(other0 + row, other_start, width));
#if CODE_WORDS > 1
        ones_lo += POPCOUNT16(load16(ref1 + row, ref_start, width) ^ load16(other1 + row, other_start, width));
#endif
#if CODE_WORDS > 2
        ones_lo += POPCOUNT16(load16(ref2 + row, ref_start, width) ^ load16(other2 + row, other_start, width));
#endif
        h_lo = convert_short16(ones_lo);
#if HALF > 0
        uint8 ones_hi = POPCOUNT8(load8(ref0 + row, ref_start, width) ^ load8(other0 + row, other_start, width));
#if CODE_WORDS > 1
        ones_hi += POPCOUNT8(load8(ref1 + row, ref_start, width) ^ load8(other1 + row, other_start, width));
#endif
#if CODE_WORDS > 2
        ones_hi += POPCOUNT8(load8(ref2 + row, ref_start, width) ^ load8(other2 + row, other_start, width));
#endif
        h_hi = convert_short8(ones_hi);
#endif
      }
      // The slot of row t - a, which leaves the window now.
      vsum_lo += h_lo;
      if (t >= SHD_A) vsum_lo -= ring_lo[slot];
      ring_lo[slot] = h_lo;
#if HALF > 0
      vsum_hi += h_hi;
      if (t >= SHD_A) vsum_hi -= ring_hi[slot];
      ring_hi[slot] = h_hi;
#endif
      slot = slot == SHD_A - 1 ? 0 : slot + 1;
      if (t < SHD_A - 1) continue;
      const int r = t - (SHD_A - 1);
      if (r < r_first || r > r_last) continue;

      // Box sums: lane i adds the vertical sums of columns x0 + i - h .. x0 + i + h.
      short16 cost = vsum_lo;
#if SHD_A >= 3
      cost += SHIFTED1(vsum_lo, vsum_hi) + SHIFTED2(vsum_lo, vsum_hi);
#endif
#if SHD_A >= 5
      cost += SHIFTED3(vsum_lo, vsum_hi) + SHIFTED4(vsum_lo, vsum_hi);
#endif
#if SHD_A >= 7
      cost += SHIFTED5(vsum_lo, vsum_hi) + SHIFTED6(vsum_lo, vsum_hi);
#endif
#if SHD_A >= 9
      cost += SHIFTED7(vsum_lo, vsum_hi) + SHIFTED8(vsum_lo, vsum_hi);
#endif

      // One step of the winner-takes-all. Pixels that do not search d see COST_INF, which never
      // wins and never lowers a minimum: as if the candidate were skipped. Ties keep the smaller
      // d (strict < while d increases). When d becomes the best: the cost beside it on the left
      // is the one just seen (d - 1), the one on the right comes with the next step, and the
      // second best outside d - 1 .. d + 1 restarts from the minimum up to d - 2; it is then
      // lowered by every later candidate but d + 1.
      const short16 c = select(cost, (short16)(COST_INF), (dv < first[r]) | (dv > last[r]));
      const short16 better = c < best_cost[r];
#if SUBPIXEL || TRACK_SECOND
      const short16 next = dv == best_d[r] + (short16)(1);  // d == the best so far + 1
#endif
#if SUBPIXEL
      before_best[r] = select(before_best[r], previous[r], better);
      after_best[r] = select(select(after_best[r], c, next), (short16)(COST_INF), better);
      previous[r] = c;
#endif
#if TRACK_SECOND
      second[r] = select(select(min(second[r], c), second[r], next), min_upto2[r], better);
      min_upto2[r] = min_upto1[r];
      min_upto1[r] = min(min_upto1[r], c);
#endif
      best_cost[r] = min(best_cost[r], c);
      best_d[r] = select(best_d[r], dv, better);
    }
  }

UNROLL
  for (int r = 0; r < ROWS; ++r) {
    const int y = y0 + r;
    if (y >= height) break;
    int16 invalid = convert_int16(best_cost[r] == (short16)(COST_INF));
#if UNIQUENESS
    // 100 (second - best) <= ratio * best, in int: 100 * 6480 does not fit in a short.
    const int16 best = convert_int16(best_cost[r]), sec = convert_int16(second[r]);
    invalid |= (sec != (int16)(COST_INF)) & ((int16)(100) * (sec - best) <= (int16)(uniqueness_ratio) * best);
#endif
    int16 q4 = convert_int16(best_d[r]) * 16;
#if SUBPIXEL
    // subpixel_offset_q4 of stages.hpp where both neighbours of the best are candidates; the
    // denominator is positive there (c0 > c1 <= c2), elsewhere it is replaced by 1 and unused.
    const int16 d = convert_int16(best_d[r]);
    const int16 fit = (d > convert_int16(first[r])) & (d < convert_int16(last[r])) & ~invalid;
    const int16 c0 = convert_int16(before_best[r]), c1 = convert_int16(best_cost[r]),
                c2 = convert_int16(after_best[r]);
    const int16 num = (int16)(16) * (c0 - c2);
    const int16 den = select((int16)(1), (int16)(2) * (c0 - (int16)(2) * c1 + c2), fit);
    const int16 magnitude = select(num, -num, num < (int16)(0));
    const int16 q = ((int16)(2) * magnitude + den) / ((int16)(2) * den);
    q4 += select((int16)(0), select(q, -q, num < (int16)(0)), fit);
#endif
    // The int -> short conversion keeps the low 16 bits, as the reference's cast.
    const short16 out = select(convert_short16(q4), (short16)(DISPARITY_INVALID), convert_short16(invalid));
    __global short* dst = disparity + (size_t)y * disparity_stride + x0;
    if (x0 + 16 <= width) {
      vstore16(out, 0, dst);
    } else {
      short value[16];
      vstore16(out, 0, value);
      for (int i = 0; i < width - x0; ++i) dst[i] = value[i];
    }
#if MARGIN
    // sgm_margin of stages.hpp: 255 (second - best) / second; without a second best 255 where the
    // winner is flanked by both neighbours, else 0; 0 without a candidate or with second = 0 (the
    // divisor is then replaced by 1 and the quotient unused).
    if (margin != 0) {
      const int16 b = convert_int16(best_cost[r]), s = convert_int16(second[r]);
      const int16 bd = convert_int16(best_d[r]);
      const int16 flanked = (bd > convert_int16(first[r])) & (bd < convert_int16(last[r]));
      const int16 no_second = (b != (int16)(COST_INF)) & (s == (int16)(COST_INF));
      const int16 no_rival = no_second & flanked;
      const int16 zero = (b == (int16)(COST_INF)) | (s == (int16)(0)) | (no_second & ~flanked);
      const int16 q = ((int16)(255) * (s - b)) / select(s, (int16)(1), zero | no_rival);
      const int16 value16 = select(select(q, (int16)(0), zero), (int16)(255), no_rival);
      uchar value[16];
      vstore16(convert_uchar16(value16), 0, value);
      __global uchar* m = margin + (size_t)y * margin_stride + x0;
      for (int i = 0; i < min(16, width - x0); ++i) m[i] = value[i];
    }
#endif
  }
}
