// Fills runs of invalid pixels along each row (reference::fill_invalid), in place: a run between
// two valid pixels takes the nearer one (-D NEAREST_LOWER=0; the middle pixel of an odd run takes
// the smaller) or always the smaller one (NEAREST_LOWER=1); a run touching a border takes its one
// neighbour; a row without a valid pixel stays invalid.
//
// One work-item per row. A pixel's value depends on the nearest valid pixels on both sides, which
// may be a whole row away, so per-pixel work-items would scan up to the row's length each (or need
// a segmented scan in local memory); one sequential pass per row does each row in O(width). A map
// has only hundreds of rows, too few work-items to fill a large GPU, but the stage moves one
// small map once and is a small share of the frame, which does not pay for a scan.
#ifndef NEAREST_LOWER
#error NEAREST_LOWER must be defined (0 or 1)
#endif
#define INVALID ((short)-32768)

// Fills [start, end) of `row`; left = row[start - 1] (valid, start > 0) and right = row[end]
// (valid, end < width) as known to the caller.
void fill_run(__global short* row, int start, int end, bool has_left, bool has_right, short left, short right) {
  if (!has_left && !has_right) return;
  const short lower = min(left, right);
  for (int i = start; i < end; ++i) {
    short v;
    if (!has_left) {
      v = right;
    } else if (!has_right) {
      v = left;
    } else {
#if NEAREST_LOWER
      v = lower;
#else
      const int to_left = i - (start - 1), to_right = end - i;
      v = to_left < to_right ? left : (to_right < to_left ? right : lower);
#endif
    }
    row[i] = v;
  }
}

__kernel void fill_invalid(__global short* disparity, int stride, int width, int height) {
  const int y = (int)get_global_id(0);
  if (y >= height) return;  // the range is rounded up to whole work-groups
  __global short* row = disparity + y * stride;
  int run_start = -1;  // first pixel of the current invalid run, -1 outside a run
  short left = INVALID;  // the last valid pixel before it
  for (int x0 = 0; x0 < width; x0 += 16) {
    // Chunks without an invalid pixel (most of them) are passed over with one load and test.
    // A whole chunk is read at the row's end (rows are padded to 16 elements); lanes past the
    // row are masked out of the test and never looked at.
    const short16 chunk = vload16(0, row + x0);
    const int n = min(16, width - x0);
    const short16 lane = (short16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    if (run_start < 0 && !any((chunk == (short16)(INVALID)) & (lane < (short16)(n)))) {
      left = row[x0 + n - 1];
      continue;
    }
    short values[16];
    vstore16(chunk, 0, values);
    for (int i = 0; i < n; ++i) {
      const short v = values[i];
      if (v == INVALID) {
        if (run_start < 0) run_start = x0 + i;
      } else {
        if (run_start >= 0) {
          fill_run(row, run_start, x0 + i, run_start > 0, true, left, v);
          run_start = -1;
        }
        left = v;
      }
    }
  }
  if (run_start > 0) fill_run(row, run_start, width, true, false, left, INVALID);
}
