// The left map's LR partners on the right map's grid of even rows and columns
// (reference::grid_partner), K = the median's side (-D K=0, 3 or 5): 16 pixels of a row per
// work-item. Pixel (x, y) takes the median of the K x K grid samples around (x / 2, y / 2), each
// the right map at twice its grid coordinates (clamped to the grid), by an insertion sort of at
// most 25 values in private memory; K = 0 takes the one sample. Invalid pixels are the smallest
// short, so they enter as the smallest value, as in the reference.
#if K != 0 && K != 3 && K != 5
#error K must be 0, 3 or 5
#endif
#define R (K / 2)
#define SAMPLES ((2 * R + 1) * (2 * R + 1))

__kernel void grid_partner(__global const short* right, int right_stride, __global short* dst, int dst_stride,
                           int width, int height) {
  const int x0 = (int)get_global_id(0) * 16;
  const int y = (int)get_global_id(1);
  if (x0 >= width || y >= height) return;  // the range is rounded up to whole work-groups
  const int gw = (width + 1) / 2, gh = (height + 1) / 2, j = y / 2;
  const int n = min(16, width - x0);
  for (int lane = 0; lane < n; ++lane) {
    const int i = (x0 + lane) / 2;
    short v[SAMPLES];
    int count = 0;
    for (int b = -R; b <= R; ++b) {
      __global const short* row = right + 2 * clamp(j + b, 0, gh - 1) * right_stride;
      for (int a = -R; a <= R; ++a) {
        const short s = row[2 * clamp(i + a, 0, gw - 1)];
        int p = count++;
        for (; p > 0 && v[p - 1] > s; --p) v[p] = v[p - 1];
        v[p] = s;
      }
    }
    dst[y * dst_stride + x0 + lane] = v[SAMPLES / 2];
  }
}
