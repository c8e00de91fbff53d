// Left-right consistency check (reference::lr_check): 16 pixels of a row per work-item. A pixel
// keeps its disparity v when the other view's map, at the pixel it matches (x + DIR * round(v),
// -D DIR=-1 or +1), holds a valid value within threshold_q4 of v; otherwise it becomes invalid.
#if DIR != -1 && DIR != 1
#error DIR must be -1 or +1
#endif
#define INVALID ((short)-32768)

__kernel void lr_check(__global const short* src, int src_stride, __global const short* other, int other_stride,
                       __global short* dst, int dst_stride, int width, int height, int threshold_q4) {
  const int x0 = (int)get_global_id(0) * 16;
  const int y = (int)get_global_id(1);
  if (x0 >= width || y >= height) return;  // the range is rounded up to whole work-groups
  const int n = min(16, width - x0);

  // A whole chunk is read even at the row's end (rows are padded to 16 elements); lanes past the
  // row are neither looked up nor stored.
  const int16 v = convert_int16(vload16(0, src + y * src_stride + x0));
  // Rounded to whole pixels in int: v + 8 overflows a short near 32767. >> of a negative signed
  // value is arithmetic in OpenCL C, so this is floor((v + 8) / 16) as on the host.
  const int16 xo = (int16)(x0) + (int16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15) + DIR * ((v + 8) >> 4);

  // The partners lie anywhere in the row: a gather, one lane at a time. Lanes whose partner is
  // outside the image read kInvalid, which rejects them below like an invalid partner.
  int xs[16];
  vstore16(xo, 0, xs);
  __global const short* other_row = other + y * other_stride;
  short partner[16];
  for (int i = 0; i < 16; ++i) partner[i] = i < n && xs[i] >= 0 && xs[i] < width ? other_row[xs[i]] : INVALID;
  const int16 o = convert_int16(vload16(0, partner));

  // abs() of an int is unsigned; |v - o| <= 65535 fits an int again. A negative threshold keeps
  // nothing, as on the host.
  const int16 keep = (v != (int16)(INVALID)) & (o != (int16)(INVALID)) & (convert_int16(abs(v - o)) <= threshold_q4);
  const short16 out = select((short16)(INVALID), convert_short16(v), convert_short16(keep));

  __global short* dst_row = dst + y * dst_stride + x0;
  if (n == 16) {
    vstore16(out, 0, dst_row);
  } else {
    short tail[16];
    vstore16(out, 0, tail);
    for (int i = 0; i < n; ++i) dst_row[i] = tail[i];
  }
}
