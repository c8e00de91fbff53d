// k x k median of a disparity map (reference::median_filter), k = K (-D K=3 or 5): 16 output
// pixels of a row per work-item, one short16 lane per pixel. Invalid pixels are the smallest
// short (-32768), so they take part as the smallest value through plain min/max, as in the
// reference; borders repeat the edge pixel.
//
// Each lane's window is K column vectors of K rows: column i of the window is the row loaded 16
// wide at x0 - R + i. Sorting each column and then a selection network over the sorted columns
// (the networks of src/cpu/median_filter.cpp, where their construction and checks are described)
// gives the median with min/max only, identically in every lane and without branches.
#if K != 3 && K != 5
#error K must be 3 or 5
#endif
#define R (K / 2)

// One comparator: afterwards v[a] <= v[b]. KEEP_MIN / KEEP_MAX compute only the half that is
// read later.
#define SORT(a, b)                     \
  {                                    \
    const short16 lo_ = min(v[a], v[b]); \
    v[b] = max(v[a], v[b]);            \
    v[a] = lo_;                        \
  }
#define KEEP_MIN(a, b) v[a] = min(v[a], v[b])
#define KEEP_MAX(a, b) v[b] = max(v[a], v[b])

short16 med3(short16 a, short16 b, short16 c) { return max(min(a, b), min(max(a, b), c)); }

__kernel void median_filter(__global const short* src, int src_stride, __global short* dst, int dst_stride, int width,
                            int height) {
  const int x0 = (int)get_global_id(0) * 16;
  const int y = (int)get_global_id(1);
  if (x0 >= width || y >= height) return;  // the range is rounded up to whole work-groups

  // The window rows, each as 16 + 2R values starting at column x0 - R. Interior work-items read
  // the rows in place; those that touch a border (or every work-item of a narrow map) read a copy
  // with clamped columns, so that the padding after a row is never read as data.
  const bool interior = x0 >= R && x0 + 16 + R <= width;
  short border[K][16 + 2 * R];
  __global const short* rows[K];
  for (int j = 0; j < K; ++j) {
    rows[j] = src + clamp(y + j - R, 0, height - 1) * src_stride;
    if (!interior)
      for (int i = 0; i < 16 + 2 * R; ++i) border[j][i] = rows[j][clamp(x0 - R + i, 0, width - 1)];
  }
#define WINDOW(j, i) (interior ? vload16(0, rows[j] + x0 - R + (i)) : vload16(0, &border[j][i]))

#if K == 3
  // Sorting the three columns (lo <= mid <= hi) gives the exact shortcut
  // median = med3(max of the lows, med3 of the mids, min of the highs).
  short16 lo[3], mid[3], hi[3];
  for (int i = 0; i < 3; ++i) {
    const short16 a = WINDOW(0, i), b = WINDOW(1, i), c = WINDOW(2, i);
    const short16 ab_lo = min(a, b), ab_hi = max(a, b);
    const short16 t = max(ab_lo, c);
    lo[i] = min(ab_lo, c);
    mid[i] = min(ab_hi, t);
    hi[i] = max(ab_hi, t);
  }
  const short16 m = med3(max(max(lo[0], lo[1]), lo[2]), med3(mid[0], mid[1], mid[2]), min(min(hi[0], hi[1]), hi[2]));
#else
  // Wire 5 r + c holds rank r of column c once the columns are sorted.
  short16 v[25];
  for (int c = 0; c < 5; ++c) {
    short16 col[5];
    for (int j = 0; j < 5; ++j) col[j] = WINDOW(j, c);
    // Optimal 5-sorter (9 comparators) on col[].
#define CSORT(a, b)                          \
  {                                          \
    const short16 lo_ = min(col[a], col[b]); \
    col[b] = max(col[a], col[b]);            \
    col[a] = lo_;                            \
  }
    CSORT(0, 1); CSORT(2, 3); CSORT(0, 2); CSORT(1, 3); CSORT(1, 2); CSORT(0, 4); CSORT(2, 4); CSORT(1, 2); CSORT(3, 4);
#undef CSORT
    for (int j = 0; j < 5; ++j) v[5 * j + c] = col[j];
  }
  // The median of 25 values whose columns are sorted (67 comparators): it ends in wire 21.
  SORT(0, 1); SORT(2, 3); SORT(0, 2); SORT(1, 3); KEEP_MAX(1, 2); KEEP_MAX(0, 4); KEEP_MAX(2, 4); SORT(3, 4);
  SORT(5, 6); SORT(7, 8); SORT(5, 7); SORT(6, 8); SORT(6, 7); KEEP_MAX(5, 9); SORT(7, 9); KEEP_MAX(6, 7);
  SORT(8, 9); SORT(10, 11); SORT(12, 13); SORT(10, 12); SORT(11, 13); SORT(11, 12); KEEP_MAX(10, 14);
  SORT(12, 14); SORT(11, 12); KEEP_MIN(13, 14); SORT(15, 16); SORT(17, 18); SORT(15, 17); KEEP_MIN(16, 18);
  SORT(16, 17); SORT(15, 19); KEEP_MIN(17, 19); SORT(16, 17); SORT(20, 21); SORT(22, 23); SORT(20, 22);
  KEEP_MIN(21, 23); SORT(21, 22); SORT(20, 24); KEEP_MIN(22, 24); KEEP_MIN(21, 22); SORT(11, 3); SORT(7, 15);
  SORT(20, 13); SORT(21, 4); SORT(16, 12); KEEP_MAX(11, 7); SORT(3, 15); SORT(20, 21); KEEP_MIN(13, 4);
  SORT(8, 16); KEEP_MIN(9, 12); KEEP_MAX(3, 7); SORT(13, 21); SORT(9, 16); KEEP_MAX(7, 20); SORT(15, 13);
  KEEP_MIN(16, 17); SORT(15, 20); SORT(13, 21); KEEP_MAX(20, 8); KEEP_MIN(13, 9); KEEP_MIN(21, 16);
  KEEP_MAX(15, 13); KEEP_MIN(21, 8); KEEP_MAX(13, 21);
  const short16 m = v[21];
#endif

  __global short* out = dst + y * dst_stride + x0;
  if (x0 + 16 <= width) {
    vstore16(m, 0, out);
  } else {
    // The row's last, partial chunk: the padding after the row is not written.
    short tail[16];
    vstore16(m, 0, tail);
    for (int i = 0; i < width - x0; ++i) out[i] = tail[i];
  }
}
