// Input bytes -> luma plane (reference::to_gray): Y = (77 R + 150 G + 29 B + 128) >> 8.
//
// Options: -DBYTES_PER_PIXEL=1 (gray: a copy) or -DBYTES_PER_PIXEL=3 with -DWEIGHT_0, -DWEIGHT_1,
// -DWEIGHT_2, the weights of the three bytes of a pixel in memory order (RGB: 77 150 29; BGR: 29 150 77).
//
// One work-item converts 16 pixels of one row. The source is the caller's image as uploaded: rows
// `src_stride` bytes apart and no slack after the last pixel, so a 16-pixel chunk is loaded whole
// (vload16) only when it lies inside its row; the tail of a row goes pixel by pixel. The tail is
// also where the destination's row padding begins, which is never written.

__kernel void to_gray(__global const uchar* src, uint src_stride, int width, int height, __global uchar* dst,
                      int dst_stride) {
  const int x0 = (int)get_global_id(0) * 16;
  const int y = (int)get_global_id(1);
  if (x0 >= width || y >= height) return;
  const __global uchar* s = src + (size_t)y * src_stride;
  __global uchar* d = dst + (size_t)y * dst_stride;

  if (x0 + 16 <= width) {
#if BYTES_PER_PIXEL == 1
    vstore16(vload16(0, s + x0), 0, d + x0);
#else
    // 48 interleaved bytes; byte c of pixel p is byte 3p + c, i.e. lane (3p + c) % 16 of vector
    // (3p + c) / 16. The three channel vectors are gathered lane by lane.
    const __global uchar* p = s + 3 * x0;
    const uchar16 a = vload16(0, p), b = vload16(1, p), c = vload16(2, p);
    const ushort16 c0 = convert_ushort16((uchar16)(a.s0, a.s3, a.s6, a.s9, a.sc, a.sf, b.s2, b.s5, b.s8, b.sb, b.se,
                                                   c.s1, c.s4, c.s7, c.sa, c.sd));
    const ushort16 c1 = convert_ushort16((uchar16)(a.s1, a.s4, a.s7, a.sa, a.sd, b.s0, b.s3, b.s6, b.s9, b.sc, b.sf,
                                                   c.s2, c.s5, c.s8, c.sb, c.se));
    const ushort16 c2 = convert_ushort16((uchar16)(a.s2, a.s5, a.s8, a.sb, a.se, b.s1, b.s4, b.s7, b.sa, b.sd, c.s0,
                                                   c.s3, c.s6, c.s9, c.sc, c.sf));
    // The weights sum to 256: at most 256 * 255 + 128 = 65408, which a ushort holds.
    const ushort16 sum = (ushort16)(WEIGHT_0) * c0 + (ushort16)(WEIGHT_1) * c1 + (ushort16)(WEIGHT_2) * c2 +
                         (ushort16)(128);
    vstore16(convert_uchar16(sum >> (ushort16)(8)), 0, d + x0);
#endif
  } else {
    for (int x = x0; x < width; ++x) {
#if BYTES_PER_PIXEL == 1
      d[x] = s[x];
#else
      const __global uchar* p = s + 3 * x;
      d[x] = (uchar)((WEIGHT_0 * p[0] + WEIGHT_1 * p[1] + WEIGHT_2 * p[2] + 128) >> 8);
#endif
    }
  }
}
