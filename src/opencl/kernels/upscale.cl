// Upscale of a disparity map by FACTOR (-D FACTOR=n, n >= 1; reference::upscale): each source pixel
// becomes FACTOR x FACTOR pixels of FACTOR times its value, clamped to [lo_q4, hi_q4]; invalid
// pixels stay invalid. 16 destination pixels of a row per work-item; the destination may be
// smaller than FACTOR x the source (the excess is never computed).
#if FACTOR < 1
#error FACTOR must be at least 1
#endif
#define INVALID ((short)-32768)

__kernel void upscale(__global const short* src, int src_stride, __global short* dst, int dst_stride, int dst_width,
                      int dst_height, int lo_q4, int hi_q4) {
  const int x0 = (int)get_global_id(0) * 16;
  const int y = (int)get_global_id(1);
  if (x0 >= dst_width || y >= dst_height) return;  // the range is rounded up to whole work-groups

  // Destination pixel x0 + i reads source pixel (x0 + i) / FACTOR, at most 15 past x0 / FACTOR:
  // one 16-wide load at x0 / FACTOR and a shuffle. That load stays inside the source row's
  // padding (x0 / FACTOR < source width); lanes past the destination row are not stored.
  const int sx0 = x0 / FACTOR;
  const short16 s = vload16(0, src + (y / FACTOR) * src_stride + sx0);
  const int16 dx = (int16)(x0) + (int16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  const short16 v = shuffle(s, convert_ushort16(dx / FACTOR - sx0));

  // As std::clamp(v * FACTOR, lo, hi): lo when below it, else hi when above it (also when
  // lo > hi), in int so that v * FACTOR cannot overflow.
  const int16 scaled = convert_int16(v) * FACTOR;
  const int16 clamped = select(select(scaled, (int16)(hi_q4), (int16)(hi_q4) < scaled), (int16)(lo_q4),
                               scaled < (int16)(lo_q4));
  const short16 out = select(convert_short16(clamped), (short16)(INVALID), v == (short16)(INVALID));

  __global short* dst_row = dst + y * dst_stride + x0;
  if (x0 + 16 <= dst_width) {
    vstore16(out, 0, dst_row);
  } else {
    short tail[16];
    vstore16(out, 0, tail);
    for (int i = 0; i < dst_width - x0; ++i) dst_row[i] = tail[i];
  }
}
