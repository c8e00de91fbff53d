#include "match.hpp"

#include <cstdio>
#include <iostream>
#include <map>
#include <vector>

#include "errors.hpp"
#include "io.hpp"
#include "output_files.hpp"
#include "statistics.hpp"

namespace mctstereo::app {

namespace {

constexpr const char* kMatchFooter = R"(Units and output scaling:
  Disparity d is in pixels of the input: the left pixel (x, y) matches the right pixel (x - d, y).
  The search covers d = min .. min + N - 1 (--min-disparity, --num-disparities); results have
  1/16 px steps with --subpixel.
  OUT.pfm   32-bit float d, +INF where there is no disparity, rows bottom to top, little-endian.
  OUT.png   16-bit PNG, 0 where there is no disparity, by --format:
              kitti (default): value = 256 x d; needs 0 <= d <= 255, and d = 0 reads as invalid.
              q4: value = 16 x (d - min + 1), so d = value / 16 + min - 1; negative d allowed.
  --color   8-bit turbo colormap over the fixed range [min, min + N - 1], black = invalid.
  --right-output holds the right view's map: the right pixel x matches the left pixel x + d.
The summary line gives the stage times of the frame in milliseconds. With --backend opencl they
are the kernels' device times from profiling events, next to the host's wall times of upload,
download, speckle (speckle removal runs on the host) and frame (the whole call).
)";

std::string fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

double valid_percent(MapView<const std::int16_t> q4, std::int16_t invalid) {
  std::int64_t valid = 0;
  for (int y = 0; y < q4.height; ++y)
    for (int x = 0; x < q4.width; ++x) valid += q4.row(y)[x] != invalid ? 1 : 0;
  return 100.0 * static_cast<double>(valid) / (static_cast<double>(q4.width) * q4.height);
}

}  // namespace

MatchCommand::MatchCommand(CLI::App& parent)
    : command_(parent.add_subcommand("match", "compute the disparity map of one rectified stereo pair")),
      parameters_(*command_) {
  CLI::App& app = *command_;
  app.footer(kMatchFooter);
  app.add_option("LEFT", left_, "left image (PNG, PPM, PGM, JPEG; 8-bit gray or colour)")->required();
  app.add_option("RIGHT", right_, "right image, the same size as LEFT")->required();
  app.add_option("-o,--output", output_, "disparity file of the left view: .pfm or .png (see --format)")
      ->required();
  app.add_option("--format", format_,
                 "encoding of .png outputs: kitti (256 x d, default) or q4 (16 x (d - min + 1)); pfm for .pfm")
      ->check(CLI::IsMember({"kitti", "q4", "pfm"}));
  app.add_option("--right-output", right_output_, "also write the right view's disparity map (same formats)");
  app.add_option("--color", preview_, "write a colour preview (turbo colormap, invalid black), e.g. preview.png");
  app.add_option("--repeat", repeat_, "match the pair N times and report the median frame time")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  run_flags_.add_to(app);
}

void MatchCommand::run() const {
  const StereoParams requested = parameters_.resolve();
  check_parameters(requested);
  (void)run_flags_.parsed_backend();  // a misspelt backend or misplaced --device costs no image reading

  // Every check that needs no pixels comes first, so a mistake costs no matching.
  const std::vector<std::string> inputs = {left_, right_};
  const DisparityFormat format = disparity_format_for(output_, format_);
  check_output_path(output_, inputs, "disparity output");
  DisparityFormat right_format = format;
  if (!right_output_.empty()) {
    right_format = disparity_format_for(right_output_, format_);
    check_output_path(right_output_, inputs, "right disparity output");
  }
  if (!preview_.empty()) {
    check_preview_path(preview_);
    check_output_path(preview_, inputs, "colour preview");
  }
  check_distinct_outputs({{"-o", output_}, {"--right-output", right_output_}, {"--color", preview_}});
  check_format_range(format, requested, output_);
  if (!right_output_.empty()) check_format_range(right_format, requested, right_output_);

  const cv::Mat left = read_input_image(left_, "left image");
  const cv::Mat right = read_input_image(right_, "right image");
  if (left.size() != right.size())
    throw RuntimeError("left image " + in_quotes(left_) + " is " + std::to_string(left.cols) + "x" +
                       std::to_string(left.rows) + " but right image " + in_quotes(right_) + " is " +
                       std::to_string(right.cols) + "x" + std::to_string(right.rows) +
                       ": a rectified pair has one size");
  check_parameters(requested, left.cols, left.rows);

  Matcher matcher = run_flags_.make_matcher(left.cols, left.rows, requested, !right_output_.empty());
  const StereoParams& params = matcher.params();

  // Stage times per frame; with --repeat each stage reports its median over the frames.
  std::vector<std::string> stage_order;
  std::map<std::string, std::vector<double>> stage_ms;
  for (int frame = 0; frame < repeat_; ++frame) {
    matcher.compute(image_view(left), image_view(right));
    for (const StageTime& t : matcher.timings()) {
      if (frame == 0) stage_order.push_back(t.stage);
      stage_ms[t.stage].push_back(t.ms);
    }
  }

  PendingOutputs outputs;
  const std::int16_t invalid = matcher.invalid_q4();
  outputs.add(output_, encode_disparity(matcher.disparity_q4(), invalid, params.min_disparity, format));
  std::string wrote = output_ + " (" + describe_format(format, params.min_disparity) + ")";
  if (!right_output_.empty()) {
    outputs.add(right_output_,
                encode_disparity(matcher.right_disparity_q4(), invalid, params.min_disparity, right_format));
    wrote += ", " + right_output_ + " (right view, " + describe_format(right_format, params.min_disparity) + ")";
  }
  if (!preview_.empty()) {
    outputs.add(preview_, encode_preview(matcher.disparity_q4(), invalid, params.min_disparity,
                                         params.max_disparity(), preview_));
    wrote += ", " + preview_ + " (colour preview)";
  }
  outputs.commit();

  std::string stages;
  for (const std::string& stage : stage_order)
    if (stage != "frame") stages += " " + stage + " " + fixed(median(stage_ms[stage]), 2);
  const std::string frame = fixed(median(stage_ms["frame"]), 2) + " ms" +
                            (repeat_ > 1 ? " (median of " + std::to_string(repeat_) + ")" : "");
  // The opencl backend names its device; its SIMD target and threads serve speckle removal only.
  const std::string where = matcher.backend() == Backend::OpenCL
                                ? ", device " + matcher.device_name()
                                : ", SIMD " + matcher.simd_target() + ", threads " + std::to_string(matcher.threads());
  std::cout << left.cols << "x" << left.rows << ", disparities " << params.min_disparity << ".."
            << params.max_disparity() << " (" << params.num_disparities << "), preset "
            << parameters_.preset_name() << ", backend " << to_string(matcher.backend()) << where << "; ms:"
            << stages << "; frame "
            << frame << "; valid " << fixed(valid_percent(matcher.disparity_q4(), invalid), 1)
            << " %; wrote " << wrote << "\n";
}

}  // namespace mctstereo::app
