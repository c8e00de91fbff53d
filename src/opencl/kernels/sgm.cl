// Band SGM (reference::sgm_costs, sgm_aggregate, sgm_select, confidence): the band and costs of
// each pixel, the path recursion along every line of one direction, the winners of both views
// from the sums, and the confidence of the checked map.
//
// Options: -DPOPCOUNT_SWAR=0 or 1 (as match.cl).
//
// The volume: pixel (x, y) holds count(x, y) candidates lo(x, y) .. lo + count - 1 in a slot of
// `slot` entries at (y W + x) slot of cost and sum; entries past count hold SGM_INF. Sums are
// 16-bit; costs too, or bytes where every cost of the level is below 255 (byte_costs != 0, as
// sgm_byte_costs() says; 255 then marks the entries past count). Codes
// are planar 32-bit words (census.cl), rows `code_stride` elements apart. All arithmetic is in
// int, as the reference: validate() bounds every in-band path value and sum below 0xFFFF.

#define SGM_INF 0xFFFF
#define DISPARITY_INVALID (-32768)  // kInvalid
#define FAR (0x7FFFFFFF / 2)        // INT_MAX / 2: a predecessor's value outside its band

#if POPCOUNT_SWAR
uint bits_of(uint v) {
  v = v - ((v >> 1) & 0x55555555u);
  v = (v & 0x33333333u) + ((v >> 2) & 0x33333333u);
  v = (v + (v >> 4)) & 0x0F0F0F0Fu;
  return (v * 0x01010101u) >> 24;
}
#else
#define bits_of(v) popcount(v)
#endif

// The prior rule of sgm_prior_band_at() with radius r, from the extrema mn, mx (whole pixels) of
// the valid priors around a valid centre.
int2 prior_band(int mn, int mx, int dmin, int dmax, int radius) {
  return (int2)(min(max(dmin, 2 * mn - radius), dmax), max(min(dmax, 2 * mx + radius), dmin));
}

// temporal_band_at() of stages.hpp: [min - r, max + r] of the previous frame's valid values in the
// 3x3 around (x, y) (floor of the Q4 values for the minimum, ceiling for the maximum), clipped to
// [dmin, dmax]; empty (lo > hi) where the previous centre is invalid or the gray value changed by
// more than `threshold`.
int2 temporal_band_at(__global const short* previous_map, int previous_map_stride, __global const uchar* image,
                      int image_stride, __global const uchar* previous_image, int previous_image_stride, int width,
                      int height, int dmin, int dmax, int radius, int threshold, int x, int y) {
  if (previous_map[(size_t)y * previous_map_stride + x] == DISPARITY_INVALID) return (int2)(1, 0);
  const int change = abs((int)image[(size_t)y * image_stride + x] - (int)previous_image[(size_t)y * previous_image_stride + x]);
  if (change > threshold) return (int2)(1, 0);
  int mn = 1 << 20, mx = -(1 << 20);
  for (int j = -1; j <= 1; ++j) {
    const __global short* row = previous_map + (size_t)clamp(y + j, 0, height - 1) * previous_map_stride;
    for (int i = -1; i <= 1; ++i) {
      const int v = row[clamp(x + i, 0, width - 1)];
      if (v == DISPARITY_INVALID) continue;
      mn = min(mn, v >> 4);
      mx = max(mx, (v + 15) >> 4);
    }
  }
  return (int2)(min(max(dmin, mn - radius), dmax), max(min(dmax, mx + radius), dmin));
}

// sgm_band_at() of stages.hpp for pixel (x, y): [2 min - r, 2 max + r] over the valid priors of
// the prior_size x prior_size coarse neighbourhood, the level range without a prior (or with an
// invalid centre); with the temporal prior (previous_map != 0) with_temporal_prior() of it and of the
// same rule at the temporal radius; then clipped to 0 <= x - d < W and cut to max_band around
// 2 x the centre.
int2 band_at(__global const short* prior, int prior_stride, int prior_width, int prior_height, int dmin, int dmax,
             int radius, int prior_size, int max_band, int width, int x, int y, int2 previous_band, int temporal_radius) {
  int lo = dmin, hi = dmax, centre = (dmin + dmax) >> 1;
  int2 narrow = (int2)(dmin, dmax);
  if (prior != 0) {
    const int cx = min(x / 2, prior_width - 1), cy = min(y / 2, prior_height - 1);
    const int c = prior[(size_t)cy * prior_stride + cx];
    if (c != DISPARITY_INVALID) {
      centre = 2 * (c >> 4);
      const int h = prior_size / 2;
      int mn = 1 << 20, mx = -(1 << 20);
      for (int j = -h; j <= h; ++j) {
        const __global short* row = prior + (size_t)clamp(cy + j, 0, prior_height - 1) * prior_stride;
        for (int i = -h; i <= h; ++i) {
          const int v = row[clamp(cx + i, 0, prior_width - 1)];
          if (v == DISPARITY_INVALID) continue;
          mn = min(mn, v >> 4);  // arithmetic shift: floor, as the reference
          mx = max(mx, v >> 4);
        }
      }
      const int2 band = prior_band(mn, mx, dmin, dmax, radius);
      lo = band.x;
      hi = band.y;
      narrow = prior_band(mn, mx, dmin, dmax, temporal_radius);
    }
    // The temporal prior (an empty previous band when it is off or has nothing here): kept only
    // when it lies inside the coarse band, then joined with the narrowed coarse band.
    if (previous_band.x <= previous_band.y && previous_band.x >= lo && previous_band.y <= hi) {
      lo = min(narrow.x, previous_band.x);
      hi = max(narrow.y, previous_band.y);
    }
  }
  lo = max(lo, x - width + 1);
  hi = min(hi, x);
  if (hi - lo + 1 > max_band) lo = clamp(centre - max_band / 2, lo, hi - max_band + 1);
  return (int2)(lo, lo > hi ? lo - 1 : min(hi, lo + max_band - 1));
}

// One work-item per pixel: its band (lo, count) and the a x a sums of Hamming distances of its
// candidates, reads clamped to the image as in the reference. prior == 0: the whole range;
// previous_map == 0: no temporal prior (else this view's map of the previous frame at this level, with
// the level's gray image now and then).
__kernel void sgm_costs(__global const uint* left0, __global const uint* left1, __global const uint* left2,
                        __global const uint* right0, __global const uint* right1, __global const uint* right2,
                        int code_stride, int words, int width, int height, __global const short* prior,
                        int prior_stride, int prior_width, int prior_height, int dmin, int dmax, int radius,
                        int prior_size, int max_band, int box_half, __global short* lo_plane,
                        __global short* count_plane, int plane_stride, __global ushort* cost, int slot,
                        __global const short* previous_map, int previous_map_stride, __global const uchar* image,
                        int image_stride, __global const uchar* previous_image, int previous_image_stride,
                        int temporal_radius, int temporal_threshold, int byte_costs) {
  const int x = (int)get_global_id(0), y = (int)get_global_id(1);
  if (x >= width || y >= height) return;
  // The temporal prior (previous_map != 0, with a coarser prior only): the previous frame's band.
  const int2 previous_band =
      previous_map != 0 && prior != 0
          ? temporal_band_at(previous_map, previous_map_stride, image, image_stride, previous_image, previous_image_stride,
                             width, height, dmin, dmax, temporal_radius, temporal_threshold, x, y)
          : (int2)(1, 0);
  const int2 band = band_at(prior, prior_stride, prior_width, prior_height, dmin, dmax, radius, prior_size, max_band,
                            width, x, y, previous_band, temporal_radius);
  const int count = band.y - band.x + 1;
  lo_plane[(size_t)y * plane_stride + x] = (short)band.x;
  count_plane[(size_t)y * plane_stride + x] = (short)count;
  const size_t at = ((size_t)y * width + x) * slot;
  __global ushort* out = cost + at;
  __global uchar* out8 = (__global uchar*)cost + at;
  for (int k = 0; k < slot; ++k) {
    if (k >= count) {
      if (byte_costs)
        out8[k] = 255;
      else
        out[k] = SGM_INF;
      continue;
    }
    const int d = band.x + k;
    uint c = 0;
    for (int j = -box_half; j <= box_half; ++j) {
      const size_t row = (size_t)clamp(y + j, 0, height - 1) * code_stride;
      for (int i = -box_half; i <= box_half; ++i) {
        const size_t xl = row + clamp(x + i, 0, width - 1), xr = row + clamp(x + i - d, 0, width - 1);
        c += bits_of(left0[xl] ^ right0[xr]);
        if (words > 1) c += bits_of(left1[xl] ^ right1[xr]);
        if (words > 2) c += bits_of(left2[xl] ^ right2[xr]);
      }
    }
    if (byte_costs)
      out8[k] = (uchar)c;
    else
      out[k] = (ushort)c;
  }
}

// Adaptive P2 (sgm_p2_at): max(P1, P2 k / (k + |a - b|)), constant P2 when k = 0.
int p2_at(int p1, int p2, int p2_k, int a, int b) {
  if (p2_k == 0) return p2;
  return max(p1, (p2 * p2_k) / (p2_k + (int)abs(a - b)));
}

// The first pixel of path line `line` of the step (dx, dy): row `line` (dy = 0), column `line`
// (dx = 0), or for a diagonal the pixel `line` of the first row the path meets, then (line >= W)
// the pixels of its first column after the corner, in the path's order.
int2 line_start(int line, int dx, int dy, int width, int height) {
  const int row0 = dy > 0 ? 0 : height - 1, col0 = dx > 0 ? 0 : width - 1;
  if (dy == 0) return (int2)(col0, line);
  if (dx == 0 || line < width) return (int2)(line, row0);
  return (int2)(col0, row0 + dy * (line - width + 1));
}

// One work-item per path line of the step (dx, dy): a row (dy = 0), a column (dx = 0) or a
// diagonal (w + h - 1 lines: those starting on the first row the path meets, then those starting
// on its first column). The work-item walks its line and keeps the predecessor's values L(q, .)
// in its own two slots of `scratch` (2 x slot entries per line), alternately. The first path
// (first != 0) writes the sums, the others add to them; each pixel lies on exactly one line of a
// direction, so a direction per enqueue races nothing.
__kernel void sgm_aggregate(__global const uchar* gray, int gray_stride, int width, int height,
                            __global const short* lo_plane, __global const short* count_plane, int plane_stride,
                            __global const ushort* cost, __global ushort* sum, int slot, __global ushort* scratch,
                            int dx, int dy, int p1, int p2, int p2_k, int first, int byte_costs) {
  const int line = (int)get_global_id(0);
  if (line >= (dy == 0 ? height : dx == 0 ? width : width + height - 1)) return;
  const int2 start = line_start(line, dx, dy, width, height);
  int x = start.x, y = start.y;
  __global ushort* buf[2] = {scratch + (size_t)line * 2 * slot, scratch + (size_t)line * 2 * slot + slot};
  int q_lo = 0, q_count = 0, q_gray = 0, m = 0, which = 0;
  for (; x >= 0 && x < width && y >= 0 && y < height; x += dx, y += dy) {
    const size_t p = (size_t)y * plane_stride + x;
    const int lo = lo_plane[p], count = count_plane[p];
    const int g = gray[(size_t)y * gray_stride + x];
    const size_t at = ((size_t)y * width + x) * slot;
    const __global ushort* c = cost + at;
    const __global uchar* c8 = (const __global uchar*)cost + at;
    const __global ushort* lq = buf[1 - which];
    __global ushort* lp = buf[which];
    __global ushort* s = sum + ((size_t)y * width + x) * slot;
    // A predecessor with no candidate restarts the path, as the first pixel does (L = C).
    const int pen2 = q_count > 0 ? p2_at(p1, p2, p2_k, g, q_gray) : 0;
    int m_next = 0x7FFFFFFF;
    for (int k = 0; k < count; ++k) {
      int v = byte_costs ? c8[k] : c[k];  // in-band costs: below 255 in bytes
      if (q_count > 0) {
        // Predecessor's values at d, d - 1 and d + 1 by their index in its band; FAR outside it.
        const int j = lo + k - q_lo;
        const int same = j >= 0 && j < q_count ? lq[j] : FAR;
        const int below = j - 1 >= 0 && j - 1 < q_count ? lq[j - 1] + p1 : FAR;
        const int above = j + 1 >= 0 && j + 1 < q_count ? lq[j + 1] + p1 : FAR;
        v += min(min(same, m + pen2), min(below, above)) - m;
      }
      v &= 0xFFFF;  // the reference's cast to uint16
      lp[k] = (ushort)v;
      m_next = min(m_next, v);
      s[k] = first ? (ushort)v : (ushort)(s[k] + v);
    }
    for (int k = count; k < slot; ++k) s[k] = SGM_INF;
    q_lo = lo, q_count = count, q_gray = g, m = m_next, which = 1 - which;
  }
}

// The winner over candidates first .. last (sums via SUM(d), present via PRESENT(d)), as
// select_one() of the reference: ties to the smaller d, second best outside d - 1 .. d + 1,
// uniqueness, margin, sub-pixel (subpixel_offset_q4) where both neighbours are present.
#define SELECT_ONE(FIRST, LAST, PRESENT, SUM, SUBPIXEL, RATIO, MARGIN_OUT, RESULT)                        \
  {                                                                                                    \
    int best = -0x7FFFFFFF, best_sum = 0x7FFFFFFF;                                                     \
    for (int d = (FIRST); d <= (LAST); ++d)                                                            \
      if (PRESENT(d) && SUM(d) < best_sum) best_sum = SUM(d), best = d;                                \
    MARGIN_OUT = 0;                                                                                    \
    if (best == -0x7FFFFFFF) {                                                                         \
      RESULT = DISPARITY_INVALID;                                                                      \
    } else {                                                                                           \
      int second = 0x7FFFFFFF;                                                                         \
      for (int d = (FIRST); d <= (LAST); ++d)                                                          \
        if (PRESENT(d) && (d < best - 1 || d > best + 1)) second = min(second, SUM(d));                \
      if (second == 0x7FFFFFFF) MARGIN_OUT = PRESENT(best - 1) && PRESENT(best + 1) ? 255 : 0;       \
      else if (second > 0) MARGIN_OUT = 255 * (second - best_sum) / second;                           \
      if ((RATIO) > 0 && second != 0x7FFFFFFF && 100 * (second - best_sum) <= (RATIO) * best_sum) {   \
        RESULT = DISPARITY_INVALID;                                                                    \
      } else {                                                                                         \
        int q4 = 16 * best;                                                                            \
        if ((SUBPIXEL) && PRESENT(best - 1) && PRESENT(best + 1)) q4 += subpixel_q4(SUM(best - 1), best_sum, SUM(best + 1)); \
        RESULT = (short)q4;                                                                            \
      }                                                                                                \
    }                                                                                                  \
  }

// subpixel_offset_q4 of stages.hpp: num / den rounded half away from zero.
int subpixel_q4(int c0, int c1, int c2) {
  const int num = 16 * (c0 - c2);
  const int den = 2 * (c0 - 2 * c1 + c2);
  const int q = (2 * (int)abs(num) + den) / (2 * den);
  return num < 0 ? -q : q;
}

// The left map (and the winners' margins when margin != 0), one work-item per pixel.
__kernel void sgm_select_left(int width, int height, __global const short* lo_plane,
                              __global const short* count_plane, int plane_stride, __global const ushort* sum,
                              int slot, int subpixel, int ratio, __global short* left, int left_stride,
                              __global uchar* margin, int margin_stride) {
  const int x = (int)get_global_id(0), y = (int)get_global_id(1);
  if (x >= width || y >= height) return;
  const int lo = lo_plane[(size_t)y * plane_stride + x], count = count_plane[(size_t)y * plane_stride + x];
  const __global ushort* s = sum + ((size_t)y * width + x) * slot;
#define PRESENT_L(d) ((d) >= lo && (d) < lo + count)
#define SUM_L(d) ((int)s[(d) - lo])
  int margin_value;
  short result;
  SELECT_ONE(lo, lo + count - 1, PRESENT_L, SUM_L, subpixel, ratio, margin_value, result);
  left[(size_t)y * left_stride + x] = result;
  if (margin != 0) margin[(size_t)y * margin_stride + x] = (uchar)margin_value;
}

// The right map from the same sums, one work-item per right pixel x: S_R(x, d) = S(x + d, d)
// where the left pixel x + d searched d. d runs over the level range [dmin, dmax], a superset of
// every band: candidates that are not present change nothing in the selection.
__kernel void sgm_select_right(int width, int height, __global const short* lo_plane,
                               __global const short* count_plane, int plane_stride, __global const ushort* sum,
                               int slot, int subpixel, int ratio, int dmin, int dmax, __global short* right,
                               int right_stride) {
  const int x = (int)get_global_id(0), y = (int)get_global_id(1);
  if (x >= width || y >= height) return;
  const __global short* lo_row = lo_plane + (size_t)y * plane_stride;
  const __global short* count_row = count_plane + (size_t)y * plane_stride;
#define PRESENT_R(d) \
  (x + (d) >= 0 && x + (d) < width && (d) >= lo_row[x + (d)] && (d) < lo_row[x + (d)] + count_row[x + (d)])
#define SUM_R(d) ((int)sum[((size_t)y * width + x + (d)) * slot + (d) - lo_row[x + (d)]])
  int unused;
  short result;
  SELECT_ONE(dmin, dmax, PRESENT_R, SUM_R, subpixel, ratio, unused, result);
  right[(size_t)y * right_stride + x] = result;
}

// confidence_at() of stages.hpp, one work-item per pixel; right == 0: agreement 1.
__kernel void confidence(int width, int height, __global const uchar* margin, int margin_stride, int margin_shift,
                         __global const short* checked, int checked_stride, __global const short* right,
                         int right_stride, int threshold, __global uchar* dst, int dst_stride) {
  const int x = (int)get_global_id(0), y = (int)get_global_id(1);
  if (x >= width || y >= height) return;
  const int v = checked[(size_t)y * checked_stride + x];
  uchar out = 0;
  if (v != DISPARITY_INVALID) {
    const int den = 16 * (threshold + 1);
    int num = den;
    if (right != 0) {
      const int xr = x - ((v + 8) >> 4);
      const int r = xr >= 0 && xr < width ? right[(size_t)y * right_stride + xr] : DISPARITY_INVALID;
      num = r == DISPARITY_INVALID ? 0 : max(0, den - (int)abs(v - r));
    }
    out = (uchar)(margin[(size_t)(y >> margin_shift) * margin_stride + (x >> margin_shift)] * num / den);
  }
  dst[(size_t)y * dst_stride + x] = out;
}
