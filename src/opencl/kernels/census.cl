// Census codes (reference::census_transform), CT or MCT, planar 32-bit words.
//
// Options: -DWINDOW=n (3, 5, 7 or 9); -DMODIFIED=0 (CT) or 1 (MCT); for MCT, -DGAUSSIAN=0 (box mean,
// norm 9) or 1 (1 2 1 / 2 4 2 / 1 2 1, norm 16).
//
// Bits: neighbour b of the window in row-major order (the centre skipped) is string position b,
// position 0 the most significant bit; word k holds positions 32k .. 32k + 31, the last word
// right-aligned. Shifting each new bit in at the bottom of the current word and starting the next
// word after 32 bits gives exactly this layout, the short last word right-aligned by itself.
//
// MCT compares I(P') * norm with the weighted 3x3 sum S(P): the mean test without rounding, so the
// bits equal the reference's. CT is the same test with norm 1 and S(P) = I(P).
//
// One work-item codes 16 pixels x0 .. x0 + 15 of one row. Where the window's columns
// x0 - r .. x0 + 15 + r all lie inside the row, each neighbour offset is one vload16 and one vector
// compare for all 16 pixels; work-items at the left and right borders (and every one of an image
// narrower than the window) clamp pixel by pixel. Rows are clamped once per window row.

#define RADIUS (WINDOW / 2)
#define BITS (WINDOW * WINDOW - 1)
#if MODIFIED
#define NORM (GAUSSIAN ? 16 : 9)
#else
#define NORM 1
#endif

const __global uchar* clamped_row(const __global uchar* image, int y, int height, int stride) {
  return image + (size_t)clamp(y, 0, height - 1) * stride;
}

__kernel void census_transform(__global const uchar* image, int width, int height, int stride,
                               __global uint* word0, __global uint* word1, __global uint* word2, int code_stride) {
  const int x0 = (int)get_global_id(0) * 16;
  const int y = (int)get_global_id(1);
  if (x0 >= width || y >= height) return;
  const size_t out = (size_t)y * code_stride;

  if (x0 - RADIUS >= 0 && x0 + 15 + RADIUS < width) {
#if MODIFIED
    ushort16 centre = (ushort16)(0);
    for (int j = -1; j <= 1; ++j) {
      const __global uchar* row = clamped_row(image, y + j, height, stride) + x0;
      const ushort16 left = convert_ushort16(vload16(0, row - 1)), middle = convert_ushort16(vload16(0, row)),
                     right = convert_ushort16(vload16(0, row + 1));
#if GAUSSIAN
      centre += (ushort16)(j == 0 ? 2 : 1) * (left + (ushort16)(2) * middle + right);
#else
      centre += left + middle + right;
#endif
    }
#else
    const ushort16 centre = convert_ushort16(vload16(0, clamped_row(image, y, height, stride) + x0));
#endif
    uint16 word = (uint16)(0);
    int b = 0;  // bits so far
    for (int j = -RADIUS; j <= RADIUS; ++j) {
      const __global uchar* row = clamped_row(image, y + j, height, stride) + x0;
#pragma unroll
      for (int i = -RADIUS; i <= RADIUS; ++i) {
        if (i == 0 && j == 0) continue;
        const ushort16 neighbour = (ushort16)(NORM) * convert_ushort16(vload16(0, row + i));
        // A vector compare gives -1 (all bits set) where true.
        word = (word << (uint16)(1)) | (convert_uint16(neighbour < centre) & (uint16)(1));
        ++b;
        if (b % 32 == 0 || b == BITS) {
          __global uint* plane = b <= 32 ? word0 : b <= 64 ? word1 : word2;
          vstore16(word, 0, plane + out + x0);
          word = (uint16)(0);
        }
      }
    }
  } else {
    const int end = min(x0 + 16, width), last_column = width - 1;
    for (int x = x0; x < end; ++x) {
#if MODIFIED
      int centre = 0;
      for (int j = -1; j <= 1; ++j) {
        const __global uchar* row = clamped_row(image, y + j, height, stride);
        const int left = row[clamp(x - 1, 0, last_column)], middle = row[x], right = row[min(x + 1, last_column)];
#if GAUSSIAN
        centre += (j == 0 ? 2 : 1) * (left + 2 * middle + right);
#else
        centre += left + middle + right;
#endif
      }
#else
      const int centre = clamped_row(image, y, height, stride)[x];
#endif
      uint word = 0;
      int b = 0;
      for (int j = -RADIUS; j <= RADIUS; ++j) {
        const __global uchar* row = clamped_row(image, y + j, height, stride);
        for (int i = -RADIUS; i <= RADIUS; ++i) {
          if (i == 0 && j == 0) continue;
          word = (word << 1) | (NORM * row[clamp(x + i, 0, last_column)] < centre ? 1u : 0u);
          ++b;
          if (b % 32 == 0 || b == BITS) {
            __global uint* plane = b <= 32 ? word0 : b <= 64 ? word1 : word2;
            plane[out + x] = word;
            word = 0;
          }
        }
      }
    }
  }
}
