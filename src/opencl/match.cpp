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

std::string match_options(int code_words, const MatchConfig& config, bool margin, Popcount popcount,
                          const Layout& layout) {
  const int a = config.shd_window;
  if (a < 1 || a > 9 || a % 2 == 0)
    throw std::invalid_argument("match: SHD window " + std::to_string(a) + " is not 1, 3, 5, 7 or 9");
  if (code_words < 1 || code_words > 3)
    throw std::invalid_argument("match: census codes of " + std::to_string(code_words) + " words");
  return "-DSHD_A=" + std::to_string(a) + " -DCODE_WORDS=" + std::to_string(code_words) +
         " -DSUBPIXEL=" + (config.subpixel ? "1" : "0") + " -DUNIQUENESS=" + (config.uniqueness_ratio > 0 ? "1" : "0") +
         " -DMARGIN=" + (margin ? "1" : "0") +
         " -DPOPCOUNT_SWAR=" + (popcount == Popcount::Swar ? "1" : "0") + " -DROWS=" + std::to_string(layout.rows) +
         " -DFULL_UNROLL=" + (layout.unroll ? "1" : "0");
}

}  // namespace

Match::Match(Runtime& rt, int code_words, const MatchConfig& config, bool margin, Popcount popcount, bool gpu_layout)
    : StageKernel(rt, "match", "match", match_options(code_words, config, margin, popcount, layout_for(gpu_layout))),
      code_words_(code_words),
      config_(config),
      margin_(margin),
      rows_(layout_for(gpu_layout).rows),
      local_(layout_for(gpu_layout).local) {}

void Match::run(const DeviceCodes& ref, const DeviceCodes& other, const DevicePlane<std::int16_t>* prior, int dmin,
                int dmax, int radius, int dir, DevicePlane<std::int16_t>& disparity,
                DevicePlane<std::uint8_t>* margin, const DeviceTemporal* temporal) {
  if (dir != -1 && dir != 1) throw std::invalid_argument("match: dir " + std::to_string(dir) + " is not -1 or +1");
  if (ref.words != code_words_ || other.words != code_words_)
    throw std::invalid_argument("match: census codes of " + std::to_string(ref.words) + " and " +
                                std::to_string(other.words) + " words for a kernel of " +
                                std::to_string(code_words_));
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
  if (margin != nullptr && !margin_)
    throw std::invalid_argument("match: margins asked of a kernel built without them");
  if (margin != nullptr && (margin->width != w || margin->height != h))
    throw std::invalid_argument("match: margin plane " + size_text(margin->width, margin->height) + " for codes " +
                                size_text(w, h));
  if (prior != nullptr && (prior->width < 1 || prior->height < 1))
    throw std::invalid_argument("match: empty prior " + size_text(prior->width, prior->height));
  if (temporal != nullptr) check_temporal("match", *temporal, w, h);
  if (w == 0 || h == 0) return;

  // Planes beyond `words` are never read; the first stands in for them.
  const auto word = [](const DeviceCodes& codes, int k) -> const cl::Buffer& {
    return codes.plane[k < codes.words ? k : 0].buffer;
  };
  set_args(word(ref, 0), word(ref, 1), word(ref, 2), word(other, 0), word(other, 1), word(other, 2),
           ref.plane[0].stride, w, h);
  // Without a prior, a null pointer: the whole range everywhere.
  if (prior != nullptr)
    set_args_from(9, prior->buffer, prior->stride, prior->width, prior->height);
  else
    set_args_from(9, NoBuffer{}, 0, 0, 0);
  set_args_from(13, dmin, dmax, radius, dir, config_.uniqueness_ratio, disparity.buffer, disparity.stride);
  if (margin != nullptr)
    set_args_from(20, margin->buffer, margin->stride);
  else
    set_args_from(20, NoBuffer{}, 0);
  set_temporal_args(22, temporal);
  // One work-item per 16 columns x `rows_` rows; the kernel skips work-items beyond the image.
  const std::size_t strips_x = (w + 15) / 16, strips_y = (h + rows_ - 1) / rows_;
  enqueue(cl::NDRange(round_up(strips_x, local_[0]), round_up(strips_y, local_[1])), local_, "match");
}

// match() with the layout of a GPU (gpu_layout) or of a CPU device, whatever the device is;
// tests/opencl/match_test.cpp declares it too, to test both layouts on any device.
void match_with_layout(Runtime& rt, const DeviceCodes& ref, const DeviceCodes& other,
                       const DevicePlane<std::int16_t>* prior, int dmin, int dmax, int radius,
                       const MatchConfig& config, Popcount popcount, bool gpu_layout,
                       DevicePlane<std::int16_t>& disparity, DevicePlane<std::uint8_t>* margin,
                       const DeviceTemporal* temporal) {
  Match(rt, ref.words, config, margin != nullptr, popcount, gpu_layout)
      .run(ref, other, prior, dmin, dmax, radius, config.dir, disparity, margin, temporal);
}

void match(Runtime& rt, const DeviceCodes& ref, const DeviceCodes& other, const DevicePlane<std::int16_t>* prior,
           int dmin, int dmax, int radius, const MatchConfig& config, Popcount popcount,
           DevicePlane<std::int16_t>& disparity, DevicePlane<std::uint8_t>* margin, const DeviceTemporal* temporal) {
  match_with_layout(rt, ref, other, prior, dmin, dmax, radius, config, popcount, rt.device().gpu, disparity, margin,
                    temporal);
}

}  // namespace mctstereo::detail::opencl
