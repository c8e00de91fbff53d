// One pyramid reduction (reference::pyramid_down): the 5-tap binomial 1 4 6 4 1 in both directions
// with clamped borders, keeping the even pixels:
//   dst(x, y) = (sum_ij w_i w_j src(2x + i - 2, 2y + j - 2) + 128) >> 8,   dst ceil(W/2) x ceil(H/2).
// The filter is separable and the sums are exact integers, so summing columns first (vertical taps)
// and then the column sums (horizontal taps) gives the reference's value.
//
// One work-item computes 16 output pixels x0 .. x0 + 15 of one row, from source columns
// 2 x0 - 2 .. 2 x0 + 32. Where the 36 columns 2 x0 - 2 .. 2 x0 + 33 that three pairs of vload16
// cover all lie inside the row (the last one loaded but unused), it takes whole vectors:
//   out[k] = E(k) + 4 O(k) + 6 E(k + 1) + 4 O(k + 1) + E(k + 2),
// with E(m) the column sum at 2 x0 - 2 + 2m and O(m) the one at 2 x0 - 1 + 2m. The even and odd lanes
// of 32 column sums starting at 2 x0 - 2 are E(k) and O(k); starting at 2 x0, E(k + 1) and O(k + 1);
// starting at 2 x0 + 2, E(k + 2). Three 32-column loads per row thus replace every lane shuffle.
// Work-items at the left and right borders (and every one of a narrow image) clamp pixel by pixel.

// Column sums 1 4 6 4 1 of 16 columns starting at column c of the five rows; at most 16 * 255.
ushort16 column_sums(const __global uchar* r0, const __global uchar* r1, const __global uchar* r2,
                     const __global uchar* r3, const __global uchar* r4, int c) {
  return convert_ushort16(vload16(0, r0 + c)) + convert_ushort16(vload16(0, r4 + c)) +
         (ushort16)(4) * (convert_ushort16(vload16(0, r1 + c)) + convert_ushort16(vload16(0, r3 + c))) +
         (ushort16)(6) * convert_ushort16(vload16(0, r2 + c));
}

__kernel void pyramid_down(__global const uchar* src, int src_width, int src_height, int src_stride,
                           __global uchar* dst, int dst_width, int dst_height, int dst_stride) {
  const int x0 = (int)get_global_id(0) * 16;
  const int y = (int)get_global_id(1);
  if (x0 >= dst_width || y >= dst_height) return;
  const int last_row = src_height - 1;
  const __global uchar* r0 = src + (size_t)clamp(2 * y - 2, 0, last_row) * src_stride;
  const __global uchar* r1 = src + (size_t)clamp(2 * y - 1, 0, last_row) * src_stride;
  const __global uchar* r2 = src + (size_t)clamp(2 * y, 0, last_row) * src_stride;
  const __global uchar* r3 = src + (size_t)clamp(2 * y + 1, 0, last_row) * src_stride;
  const __global uchar* r4 = src + (size_t)clamp(2 * y + 2, 0, last_row) * src_stride;
  __global uchar* d = dst + (size_t)y * dst_stride;

  if (2 * x0 - 2 >= 0 && 2 * x0 + 33 < src_width) {
    // Then x0 + 16 < dst_width too: the whole chunk is stored.
    const int c = 2 * x0 - 2;
    const ushort16 lo0 = column_sums(r0, r1, r2, r3, r4, c), hi0 = column_sums(r0, r1, r2, r3, r4, c + 16);
    const ushort16 lo1 = column_sums(r0, r1, r2, r3, r4, c + 2), hi1 = column_sums(r0, r1, r2, r3, r4, c + 18);
    const ushort16 lo2 = column_sums(r0, r1, r2, r3, r4, c + 4), hi2 = column_sums(r0, r1, r2, r3, r4, c + 20);
    const ushort16 e0 = (ushort16)(lo0.even, hi0.even), o0 = (ushort16)(lo0.odd, hi0.odd);
    const ushort16 e1 = (ushort16)(lo1.even, hi1.even), o1 = (ushort16)(lo1.odd, hi1.odd);
    const ushort16 e2 = (ushort16)(lo2.even, hi2.even);
    // At most 256 * 255 + 128 = 65408: a ushort holds it.
    const ushort16 sum = e0 + (ushort16)(4) * (o0 + o1) + (ushort16)(6) * e1 + e2 + (ushort16)(128);
    vstore16(convert_uchar16(sum >> (ushort16)(8)), 0, d + x0);
  } else {
    const int end = min(x0 + 16, dst_width), last_column = src_width - 1;
    for (int x = x0; x < end; ++x) {
      int sum = 0;
      for (int i = 0; i < 5; ++i) {
        const int cx = clamp(2 * x + i - 2, 0, last_column);
        const int column = r0[cx] + 4 * r1[cx] + 6 * r2[cx] + 4 * r3[cx] + r4[cx];
        sum += (i == 0 || i == 4 ? 1 : i == 2 ? 6 : 4) * column;
      }
      d[x] = (uchar)((sum + 128) >> 8);
    }
  }
}
