// The colour-weighted median (reference::weighted_median) and the channel split that feeds it.
//
// weighted_median: 16 pixels of a row per work-item, one pixel after the other. For a pixel p the
// samples q lie at the multiples of `step` in [-reach, reach] around it (coordinates clamped);
// each weighs lut[max over the channels |C(p) - C(q)|], the host's integer table, and an invalid
// sample weighs 0. The median is the smallest whole disparity d with S(d) >= ceil(total / 2),
// S(d) the weight of the samples whose whole disparity (v + 8) >> 4 is <= d: S is monotone, so a
// binary search over [smallest, largest sampled d] finds it, recomputing the weights in each pass
// (nothing per sample is kept, whatever the window). Where d is the pixel's own whole disparity
// it keeps its Q4 value, else it becomes 16 d; a pixel with total weight 0 stays as it is.
#define INVALID ((short)-32768)

// The weight of sample (qx, qy) for the pixel whose channels are p0, p1, p2; 0 when invalid.
int sample_weight(__global const short* src, int src_stride, __global const uchar* c0, __global const uchar* c1,
                  __global const uchar* c2, int colour_stride, __global const uchar* lut, int channels, int p0,
                  int p1, int p2, int qx, int qy, int* d) {
  const short v = src[qy * src_stride + qx];
  if (v == INVALID) return 0;
  const int q = qy * colour_stride + qx;
  int k = (int)abs(p0 - (int)c0[q]);
  if (channels == 3) k = max(k, (int)max(abs(p1 - (int)c1[q]), abs(p2 - (int)c2[q])));
  *d = ((int)v + 8) >> 4;  // >> of a negative value is arithmetic in OpenCL C: floor((v + 8) / 16)
  return lut[k];
}

__kernel void weighted_median(__global const short* src, int src_stride, __global const uchar* c0,
                              __global const uchar* c1, __global const uchar* c2, int colour_stride, int channels,
                              __global const uchar* lut, int reach, int step, __global short* dst, int dst_stride,
                              int width, int height) {
  const int x0 = (int)get_global_id(0) * 16;
  const int y = (int)get_global_id(1);
  if (x0 >= width || y >= height) return;  // the range is rounded up to whole work-groups
  const int x1 = min(x0 + 16, width);
  for (int x = x0; x < x1; ++x) {
    const int at = y * colour_stride + x;
    const int p0 = c0[at], p1 = channels == 3 ? c1[at] : 0, p2 = channels == 3 ? c2[at] : 0;
    int total = 0, lo = 1 << 20, hi = -(1 << 20);
    for (int dy = -reach; dy <= reach; dy += step) {
      const int qy = clamp(y + dy, 0, height - 1);
      for (int dx = -reach; dx <= reach; dx += step) {
        int d = 0;
        const int w = sample_weight(src, src_stride, c0, c1, c2, colour_stride, lut, channels, p0, p1, p2,
                                    clamp(x + dx, 0, width - 1), qy, &d);
        if (w == 0) continue;
        total += w;
        lo = min(lo, d);
        hi = max(hi, d);
      }
    }
    const short own = src[y * src_stride + x];
    if (total == 0) {
      dst[y * dst_stride + x] = own;
      continue;
    }
    const int need = (total + 1) >> 1;  // ceil(total / 2)
    // Invariant: the answer lies in [lo, hi] (S(hi) = total >= need).
    while (lo < hi) {
      const int mid = (lo + hi) >> 1;  // floor
      int sum = 0;
      for (int dy = -reach; dy <= reach; dy += step) {
        const int qy = clamp(y + dy, 0, height - 1);
        for (int dx = -reach; dx <= reach; dx += step) {
          int d = 0;
          const int w = sample_weight(src, src_stride, c0, c1, c2, colour_stride, lut, channels, p0, p1, p2,
                                      clamp(x + dx, 0, width - 1), qy, &d);
          if (w != 0 && d <= mid) sum += w;
        }
      }
      if (sum >= need) hi = mid;
      else lo = mid + 1;
    }
    dst[y * dst_stride + x] = own != INVALID && (((int)own + 8) >> 4) == lo ? own : (short)(16 * lo);
  }
}

// Interleaved 3-byte pixels (RGB or BGR, the byte order kept) into three planes: 16 pixels of a
// row per work-item. The source rows carry no slack, so the bytes are read one by one.
__kernel void split_channels(__global const uchar* src, uint src_stride, int width, int height, __global uchar* d0,
                             __global uchar* d1, __global uchar* d2, int dst_stride) {
  const int x0 = (int)get_global_id(0) * 16;
  const int y = (int)get_global_id(1);
  if (x0 >= width || y >= height) return;
  const __global uchar* s = src + (size_t)y * src_stride;
  for (int x = x0; x < min(x0 + 16, width); ++x) {
    d0[y * dst_stride + x] = s[3 * x];
    d1[y * dst_stride + x] = s[3 * x + 1];
    d2[y * dst_stride + x] = s[3 * x + 2];
  }
}
