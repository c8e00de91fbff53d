// Band SGM on the device: kernels/sgm.cl. Costs, aggregation, winners and confidence, each a
// stage of its own as on the host; their kernels run under the label "match" (the confidence
// under "confidence").
#include <stdexcept>
#include <string>

#include "opencl/stages.hpp"

namespace mctstereo::detail::opencl {

namespace {

std::size_t round_up(std::size_t n, std::size_t multiple) { return (n + multiple - 1) / multiple * multiple; }

std::string sgm_options(Popcount popcount) {
  return std::string("-DPOPCOUNT_SWAR=") + (popcount == Popcount::Swar ? "1" : "0");
}

// The SGM kernels' program: one per popcount form (only sgm_costs counts bits).
std::string options_of(Runtime& rt) { return sgm_options(pick_popcount(rt.device())); }

// One work-item per pixel, in groups of 16 x 4.
cl::NDRange pixels_of(int w, int h) { return cl::NDRange(round_up(w, 16), round_up(h, 4)); }

void check_size(const char* stage, const char* what, int w, int h, int want_w, int want_h) {
  if (w != want_w || h != want_h)
    throw std::invalid_argument(std::string(stage) + ": " + what + " is " + std::to_string(w) + "x" +
                                std::to_string(h) + ", the volume " + std::to_string(want_w) + "x" +
                                std::to_string(want_h));
}

}  // namespace

SgmCosts::SgmCosts(Runtime& rt, Popcount popcount) : StageKernel(rt, "sgm", "sgm_costs", sgm_options(popcount)) {}

void SgmCosts::run(const DeviceCodes& left, const DeviceCodes& right, const DevicePlane<std::int16_t>* prior,
                   const SgmBandConfig& config, int shd_window, DeviceSgmVolume& volume,
                   const DeviceTemporal* temporal) {
  const int w = volume.width, h = volume.height;
  for (const DeviceCodes* codes : {&left, &right})
    for (int k = 0; k < codes->words; ++k) {
      check_size("sgm_costs", "a code plane", codes->plane[k].width, codes->plane[k].height, w, h);
      if (codes->plane[k].stride != left.plane[0].stride)
        throw std::invalid_argument("sgm_costs: code planes of different strides");
    }
  if (left.words != right.words || left.words < 1 || left.words > 3)
    throw std::invalid_argument("sgm_costs: census codes of " + std::to_string(left.words) + " and " +
                                std::to_string(right.words) + " words");
  if (config.max_band > volume.band)
    throw std::invalid_argument("sgm_costs: bands of " + std::to_string(config.max_band) + " for a volume of " +
                                std::to_string(volume.band));
  if (temporal != nullptr) check_temporal("sgm_costs", *temporal, w, h);
  if (w == 0 || h == 0) return;
  const auto word = [](const DeviceCodes& codes, int k) -> const cl::Buffer& {
    return codes.plane[k < codes.words ? k : 0].buffer;
  };
  set_args(word(left, 0), word(left, 1), word(left, 2), word(right, 0), word(right, 1), word(right, 2),
           left.plane[0].stride, left.words, w, h);
  if (prior != nullptr)
    set_args_from(10, prior->buffer, prior->stride, prior->width, prior->height);
  else
    set_args_from(10, NoBuffer{}, 0, 0, 0);
  set_args_from(14, config.dmin, config.dmax, config.radius, config.prior_size, config.max_band, shd_window / 2,
                volume.lo.buffer, volume.count.buffer, volume.lo.stride, volume.cost, volume.stride);
  set_temporal_args(25, temporal);
  set_args_from(33, volume.byte_costs ? 1 : 0);
  enqueue(pixels_of(w, h), cl::NDRange(16, 4), "match");
}

SgmAggregate::SgmAggregate(Runtime& rt) : StageKernel(rt, "sgm", "sgm_aggregate", options_of(rt)) {}

void SgmAggregate::run(const DevicePlane<std::uint8_t>& gray, const SgmPathConfig& config, DeviceSgmVolume& volume) {
  const int w = volume.width, h = volume.height;
  check_size("sgm_aggregate", "the gray image", gray.width, gray.height, w, h);
  if (config.paths != 4 && config.paths != 8)
    throw std::invalid_argument("sgm_aggregate: " + std::to_string(config.paths) + " paths (4 or 8)");
  if (w == 0 || h == 0) return;
  set_args(gray.buffer, gray.stride, w, h, volume.lo.buffer, volume.count.buffer, volume.lo.stride, volume.cost,
           volume.sum, volume.stride, volume.scratch);
  set_args_from(13, config.p1, config.p2, config.p2_k);
  set_args_from(17, volume.byte_costs ? 1 : 0);
  // The in-order queue runs the directions one after the other: each adds into the sums.
  for (int r = 0; r < config.paths; ++r) {
    const int dx = kSgmSteps[r][0], dy = kSgmSteps[r][1];
    const int lines = dy == 0 ? h : dx == 0 ? w : w + h - 1;
    set_args_from(11, dx, dy);
    set_args_from(16, r == 0 ? 1 : 0);
    enqueue(cl::NDRange(round_up(lines, 16)), cl::NDRange(16), "match");
  }
}

class SgmSelect::Left : StageKernel {
 public:
  explicit Left(Runtime& rt) : StageKernel(rt, "sgm", "sgm_select_left", options_of(rt)) {}
  void run(const DeviceSgmVolume& v, const SgmSelectConfig& config, DevicePlane<std::int16_t>& left,
           DevicePlane<std::uint8_t>* margin) {
    set_args(v.width, v.height, v.lo.buffer, v.count.buffer, v.lo.stride, v.sum, v.stride, config.subpixel ? 1 : 0,
             config.uniqueness_ratio, left.buffer, left.stride);
    if (margin != nullptr)
      set_args_from(11, margin->buffer, margin->stride);
    else
      set_args_from(11, NoBuffer{}, 0);
    enqueue(pixels_of(v.width, v.height), cl::NDRange(16, 4), "match");
  }
};

class SgmSelect::Right : StageKernel {
 public:
  explicit Right(Runtime& rt) : StageKernel(rt, "sgm", "sgm_select_right", options_of(rt)) {}
  void run(const DeviceSgmVolume& v, const SgmSelectConfig& config, int dmin, int dmax,
           DevicePlane<std::int16_t>& right) {
    set_args(v.width, v.height, v.lo.buffer, v.count.buffer, v.lo.stride, v.sum, v.stride, config.subpixel ? 1 : 0,
             config.uniqueness_ratio, dmin, dmax, right.buffer, right.stride);
    enqueue(pixels_of(v.width, v.height), cl::NDRange(16, 4), "match");
  }
};

SgmSelect::SgmSelect(Runtime& rt) : left_(std::make_unique<Left>(rt)), right_(std::make_unique<Right>(rt)) {}
SgmSelect::~SgmSelect() = default;

void SgmSelect::run(const DeviceSgmVolume& volume, const SgmSelectConfig& config, int dmin, int dmax,
                    DevicePlane<std::int16_t>& left, DevicePlane<std::int16_t>* right,
                    DevicePlane<std::uint8_t>* margin) {
  const int w = volume.width, h = volume.height;
  check_size("sgm_select", "the left map", left.width, left.height, w, h);
  if (right != nullptr) check_size("sgm_select", "the right map", right->width, right->height, w, h);
  if (margin != nullptr) check_size("sgm_select", "the margin plane", margin->width, margin->height, w, h);
  if (w == 0 || h == 0) return;
  left_->run(volume, config, left, margin);
  if (right != nullptr) right_->run(volume, config, dmin, dmax, *right);
}

Confidence::Confidence(Runtime& rt) : StageKernel(rt, "sgm", "confidence", options_of(rt)) {}

void Confidence::run(const DevicePlane<std::uint8_t>& margin, int margin_shift,
                     const DevicePlane<std::int16_t>& checked,
                     const DevicePlane<std::int16_t>* right, int threshold, DevicePlane<std::uint8_t>& dst) {
  const int w = checked.width, h = checked.height;
  // A margin plane 2^margin_shift times smaller: the sizes of the level halvings (rounded up).
  const auto reduced = [margin_shift](int n) { return n == 0 ? 0 : ((n - 1) >> margin_shift) + 1; };
  check_size("confidence", "the margin plane", margin.width, margin.height, reduced(w), reduced(h));
  check_size("confidence", "the destination", dst.width, dst.height, w, h);
  if (right != nullptr) check_size("confidence", "the right map", right->width, right->height, w, h);
  if (w == 0 || h == 0) return;
  set_args(w, h, margin.buffer, margin.stride, margin_shift, checked.buffer, checked.stride);
  if (right != nullptr)
    set_args_from(7, right->buffer, right->stride);
  else
    set_args_from(7, NoBuffer{}, 0);
  set_args_from(9, threshold, dst.buffer, dst.stride);
  enqueue(pixels_of(w, h), cl::NDRange(16, 4), "confidence");
}

}  // namespace mctstereo::detail::opencl
