// match on the device: kernels/match.cl, one program per (SHD window, census words, sub-pixel,
// uniqueness on/off, popcount form, work layout).
#include <stdexcept>
#include <string>

#include "opencl/stages.hpp"

namespace mctstereo::detail::opencl {

namespace {

// How the work is cut, per kind of device (see match.cl).
struct Layout {
  // Image rows per work-item: more rows share more Hamming rows between the windows of a strip,
  // at the price of the winner-takes-all state of 16 more pixels per row.
  int rows;
  // Loops over rows fully unrolled, so that the state is registers.
  bool unroll;
  // Work-items per work-group. They are independent (no local memory, no barriers), so the size
  // only matters for scheduling.
  cl::NDRange local;
};

// GPUs: 1 row, unrolled. The state of 16 pixels (up to 10 short16 vectors with sub-pixel and
// uniqueness) with the 24-column vertical sum already takes most of the registers a work-item
// can have before it spills; the a Hamming rows of each window are then summed afresh, ALU work
// a GPU has to spare. 640 x 480 gives 19200 work-items, in groups of 64 (two warps, one
// wavefront). CPU devices: 16 rows, so that a candidate costs (16 + a - 1) / 16 Hamming rows per
// output row (the state sits in the L1 cache); not unrolled, since PoCL takes seconds to compile
// the unrolled loops and runs them no faster; one work-item per group, since PoCL compiles a
// work-group function per local size it meets and with the size fixed one program serves every
// image size.
Layout layout_for(bool gpu) { return gpu ? Layout{1, true, cl::NDRange(16, 4)} : Layout{16, false, cl::NDRange(1, 1)}; }

std::size_t round_up(std::size_t n, std::size_t multiple) { return (n + multiple - 1) / multiple * multiple; }

std::string size_text(int w, int h) { return std::to_string(w) + " x " + std::to_string(h); }

}  // namespace

// match() with the layout of a GPU (gpu_layout) or of a CPU device, whatever the device is;
// tests/opencl/match_test.cpp declares it too, to test both layouts on any device.
void match_with_layout(Runtime& rt, const DeviceCodes& ref, const DeviceCodes& other,
                       const DevicePlane<std::int16_t>* prior, int dmin, int dmax, int radius,
                       const MatchConfig& config, Popcount popcount, bool gpu_layout,
                       DevicePlane<std::int16_t>& disparity) {
  const int a = config.shd_window;
  if (a < 1 || a > 9 || a % 2 == 0)
    throw std::invalid_argument("match: SHD window " + std::to_string(a) + " is not 1, 3, 5, 7 or 9");
  if (config.dir != -1 && config.dir != 1)
    throw std::invalid_argument("match: dir " + std::to_string(config.dir) + " is not -1 or +1");
  if (ref.words < 1 || ref.words > 3 || other.words != ref.words)
    throw std::invalid_argument("match: census codes of " + std::to_string(ref.words) + " and " +
                                std::to_string(other.words) + " words");
  const int w = ref.plane[0].width, h = ref.plane[0].height;
  // The kernel addresses every code plane with the stride of the first.
  for (const DeviceCodes* codes : {&ref, &other})
    for (int k = 0; k < codes->words; ++k) {
      const DevicePlane<std::uint32_t>& plane = codes->plane[k];
      if (plane.width != w || plane.height != h || plane.stride != ref.plane[0].stride)
        throw std::invalid_argument("match: code plane " + std::to_string(k) + " is " +
                                    size_text(plane.width, plane.height) + ", the first " + size_text(w, h));
    }
  if (disparity.width != w || disparity.height != h)
    throw std::invalid_argument("match: disparity map " + size_text(disparity.width, disparity.height) +
                                " for codes " + size_text(w, h));
  if (prior != nullptr && (prior->width < 1 || prior->height < 1))
    throw std::invalid_argument("match: empty prior " + size_text(prior->width, prior->height));
  if (w == 0 || h == 0) return;

  const Layout layout = layout_for(gpu_layout);
  const std::string options = "-DSHD_A=" + std::to_string(a) + " -DCODE_WORDS=" + std::to_string(ref.words) +
                              " -DSUBPIXEL=" + (config.subpixel ? "1" : "0") +
                              " -DUNIQUENESS=" + (config.uniqueness_ratio > 0 ? "1" : "0") +
                              " -DPOPCOUNT_SWAR=" + (popcount == Popcount::Swar ? "1" : "0") +
                              " -DROWS=" + std::to_string(layout.rows) +
                              " -DFULL_UNROLL=" + (layout.unroll ? "1" : "0");
  cl::Kernel kernel = rt.kernel("match", "match", options);
  int arg = 0;
  // Planes beyond `words` are never read; the first stands in for them.
  for (const DeviceCodes* codes : {&ref, &other})
    for (int k = 0; k < 3; ++k) kernel.setArg(arg++, codes->plane[k < codes->words ? k : 0].buffer);
  kernel.setArg(arg++, ref.plane[0].stride);
  kernel.setArg(arg++, w);
  kernel.setArg(arg++, h);
  if (prior != nullptr)
    kernel.setArg(arg++, prior->buffer);
  else
    kernel.setArg(arg++, sizeof(cl_mem), nullptr);  // a null pointer: the whole range everywhere
  kernel.setArg(arg++, prior != nullptr ? prior->stride : 0);
  kernel.setArg(arg++, prior != nullptr ? prior->width : 0);
  kernel.setArg(arg++, prior != nullptr ? prior->height : 0);
  kernel.setArg(arg++, dmin);
  kernel.setArg(arg++, dmax);
  kernel.setArg(arg++, radius);
  kernel.setArg(arg++, config.dir);
  kernel.setArg(arg++, config.uniqueness_ratio);
  kernel.setArg(arg++, disparity.buffer);
  kernel.setArg(arg++, disparity.stride);
  // One work-item per 16 columns x `rows` rows; the kernel skips work-items beyond the image.
  const std::size_t strips_x = (w + 15) / 16, strips_y = (h + layout.rows - 1) / layout.rows;
  rt.run(kernel, cl::NDRange(round_up(strips_x, layout.local[0]), round_up(strips_y, layout.local[1])), layout.local,
         "match");
}

void match(Runtime& rt, const DeviceCodes& ref, const DeviceCodes& other, const DevicePlane<std::int16_t>* prior,
           int dmin, int dmax, int radius, const MatchConfig& config, Popcount popcount,
           DevicePlane<std::int16_t>& disparity) {
  match_with_layout(rt, ref, other, prior, dmin, dmax, radius, config, popcount, rt.device().gpu, disparity);
}

}  // namespace mctstereo::detail::opencl
