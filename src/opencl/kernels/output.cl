// The maps in the caller's conventions (Matcher's outputs): Q4 with invalid_q4 in place of
// kInvalid and, with -D WITH_FLOAT=1, pixels as float (value / 16, exact) with NaN where invalid.
// 16 pixels of a row per work-item.
#ifndef WITH_FLOAT
#error WITH_FLOAT must be defined (0 or 1)
#endif
#define INVALID ((short)-32768)

// `disparity` is unused (the host passes a null buffer) when WITH_FLOAT is 0.
__kernel void to_output(__global const short* src, int src_stride, int invalid_q4, __global short* q4, int q4_stride,
                        __global float* disparity, int disparity_stride, int width, int height) {
  const int x0 = (int)get_global_id(0) * 16;
  const int y = (int)get_global_id(1);
  if (x0 >= width || y >= height) return;  // the range is rounded up to whole work-groups
  const int n = min(16, width - x0);

  // A whole chunk is read even at the row's end (rows are padded to 16 elements); lanes past the
  // row are not stored.
  const short16 v = vload16(0, src + y * src_stride + x0);
  const short16 invalid = v == (short16)(INVALID);
  const short16 q = select(v, (short16)((short)invalid_q4), invalid);
#if WITH_FLOAT
  // The quiet NaN the host's NAN has (0x7fc00000), written as bits: the NAN macro of a device
  // need not carry the same payload, and outputs are compared bit for bit.
  const float16 f = select(convert_float16(v) * 0.0625f, as_float16((uint16)(0x7fc00000u)), convert_int16(invalid));
#endif

  __global short* q_row = q4 + y * q4_stride + x0;
#if WITH_FLOAT
  __global float* f_row = disparity + y * disparity_stride + x0;
#endif
  if (n == 16) {
    vstore16(q, 0, q_row);
#if WITH_FLOAT
    vstore16(f, 0, f_row);
#endif
  } else {
    short q_tail[16];
    vstore16(q, 0, q_tail);
    for (int i = 0; i < n; ++i) q_row[i] = q_tail[i];
#if WITH_FLOAT
    float f_tail[16];
    vstore16(f, 0, f_tail);
    for (int i = 0; i < n; ++i) f_row[i] = f_tail[i];
#endif
  }
}
