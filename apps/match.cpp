#include "match.hpp"

#include <cstdio>
#include <iostream>
#include <limits>
#include <map>
#include <sstream>
#include <vector>

#include "depth_files.hpp"
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
  --confidence  per pixel in [0, 1]: the winner's margin over the best cost (SGM: path sum)
            outside d-1..d+1 times the left-right agreement; 0 where the checks dropped the pixel and the
            fill guessed it. .pfm float, .png 8-bit round(255 c).
Depth and point clouds (--depth, --ply, --obj) need a calibration: --calib FILE, or --focal and
--baseline (flags override the file). Z = focal x baseline / (d + doffs), X = (x - cx) Z / focal,
Y = (y - cy) Z / focal, in the left rectified camera's frame (X right, Y down, Z forward) and in
the units of the baseline: Middlebury calib.txt is in mm, OpenCV files in m unless they have a
"units" string, --baseline in --units (m by default).
  DEPTH.pfm 32-bit float depth in the units of the baseline, +INF where there is none. Without a
            calibration it holds relative depth 1/d (1/pixels), proportional to depth when doffs = 0.
  DEPTH.png 16-bit PNG, depth in millimetres, 0 where there is none or beyond 65535 mm.
  --ply     binary little-endian PLY: float x y z, uchar red green blue (the left image's colours).
  --obj     Wavefront OBJ: "v x y z r g b", colours in [0, 1].
  Pixels without disparity, with d + doffs <= 0 or deeper than --max-depth have no depth or point.
Unrectified pairs: a calibration file of the raw cameras (K1 D1 K2 D2 without "rectified: 1")
says the images are as the cameras took them; match then rectifies them first (OpenCV remap with
the file's R1 R2 P1 P2, or stereoRectify's), and every output is in the rectified left frame.
--check-rectification measures the vertical offsets of matched features (ORB) between the views
of the pair that is matched (and of the raw pair when match rectified it): in a rectified pair
they are near 0 px; above about 1 px the matching along rows degrades. Without -o it only reports.
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

std::string number_text(double v) {
  std::ostringstream s;
  s.precision(10);
  s << v;
  return s.str();
}

std::string geometry_text(const StereoGeometry& g) {
  std::ostringstream s;
  s.precision(10);
  s << "focal " << g.focal << " px, cx " << g.cx << " px, cy " << g.cy << " px, baseline " << g.baseline << " "
    << g.units << ", doffs " << g.doffs << " px";
  return s.str();
}

void check_pair_size(const cv::Mat& left, const cv::Mat& right, const std::string& left_path,
                     const std::string& right_path) {
  if (left.size() != right.size())
    throw RuntimeError("left image " + in_quotes(left_path) + " is " + std::to_string(left.cols) + "x" +
                       std::to_string(left.rows) + " but right image " + in_quotes(right_path) + " is " +
                       std::to_string(right.cols) + "x" + std::to_string(right.rows) + ": a stereo pair has one size");
}

}  // namespace

std::string MatchCommand::write_depth_outputs(MapView<const std::int16_t> q4, std::int16_t invalid_q4,
                                              const cv::Mat& left, const std::optional<Calibration>& calibration,
                                              PendingOutputs& outputs) const {
  const double max_depth = max_depth_ > 0.0 ? max_depth_ : std::numeric_limits<double>::infinity();
  std::string wrote;
  if (!depth_output_.empty()) {
    std::vector<float> depth(static_cast<std::size_t>(q4.width) * q4.height);
    const MapView<float> depth_view{depth.data(), q4.width, q4.height, q4.width};
    const MapView<const float> depth_map{depth.data(), q4.width, q4.height, q4.width};
    const DepthFormat format = depth_format_for(depth_output_);
    if (calibration) {
      depth_from_disparity(q4, invalid_q4, calibration->geometry, depth_view, max_depth);
      outputs.add(depth_output_, encode_depth(depth_map, calibration->geometry.units, format));
      wrote += ", " + depth_output_ +
               (format == DepthFormat::Pfm ? " (depth PFM, " + calibration->geometry.units + ", +INF = none)"
                                           : std::string(" (depth 16-bit PNG, mm, 0 = none)"));
    } else {
      relative_depth_from_disparity(q4, invalid_q4, depth_view);
      outputs.add(depth_output_, encode_depth(depth_map, "", format));
      wrote += ", " + depth_output_ + " (relative depth 1/d PFM, +INF = none)";
      std::cerr << "mctstereo: note: no calibration: " << in_quotes(depth_output_)
                << " holds relative depth 1/d; give --calib FILE or --focal and --baseline for depth in units\n";
    }
  }
  if (!ply_output_.empty() || !obj_output_.empty()) {
    const StereoGeometry& geometry = calibration->geometry;
    PointCloud cloud;
    point_cloud_from_disparity(q4, invalid_q4, geometry, image_view(left), cloud, max_depth);
    std::vector<std::string> comments = {
        "mctstereo " MCTSTEREO_VERSION " point cloud, one point per pixel with a depth, in row order",
        "units " + geometry.units,
        "frame left rectified camera: X right, Y down, Z forward",
        "geometry " + geometry_text(geometry) + " (calibration " + calibration->source + ")",
        "left " + left_,
        "right " + right_,
    };
    if (max_depth_ > 0.0) comments.push_back("max depth " + number_text(max_depth_) + " " + geometry.units);
    const std::string points = std::to_string(cloud.size()) + " points, " + geometry.units;
    if (!ply_output_.empty()) {
      outputs.add(ply_output_, encode_point_cloud(cloud, CloudFormat::Ply, comments));
      wrote += ", " + ply_output_ + " (PLY, " + points + ")";
    }
    if (!obj_output_.empty()) {
      outputs.add(obj_output_, encode_point_cloud(cloud, CloudFormat::Obj, comments));
      wrote += ", " + obj_output_ + " (OBJ, " + points + ")";
    }
  }
  return wrote;
}

MatchCommand::MatchCommand(CLI::App& parent)
    : command_(parent.add_subcommand("match", "compute the disparity map of one rectified stereo pair")),
      parameters_(*command_) {
  CLI::App& app = *command_;
  app.footer(kMatchFooter);
  app.add_option("LEFT", left_, "left image (PNG, PPM, PGM, JPEG; 8-bit gray or colour)")->required();
  app.add_option("RIGHT", right_, "right image, the same size as LEFT")->required();
  app.add_option("-o,--output", output_,
                 "disparity file of the left view: .pfm or .png (see --format); needed unless only "
                 "--check-rectification is asked for");
  app.add_option("--format", format_,
                 "encoding of .png outputs: kitti (256 x d, default) or q4 (16 x (d - min + 1)); pfm for .pfm")
      ->check(CLI::IsMember({"kitti", "q4", "pfm"}));
  app.add_option("--right-output", right_output_, "also write the right view's disparity map (same formats)");
  app.add_option("--color", preview_, "write a colour preview (turbo colormap, invalid black), e.g. preview.png");
  app.add_option("--confidence", confidence_,
                 "write the confidence map of the left disparity: .pfm (float, 0 to 1) or .png "
                 "(8-bit, 0 to 255)");
  app.add_option("--repeat", repeat_, "match the pair N times and report the median frame time")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  run_flags_.add_to(app);
  calibration_flags_.add_to(app);
  app.add_option("--depth", depth_output_,
                 "write the depth map: .pfm (float, units of the baseline; 1/d without a calibration) or .png "
                 "(16-bit, millimetres)");
  app.add_option("--ply", ply_output_, "write the point cloud as binary PLY with colours (needs a calibration)");
  app.add_option("--obj", obj_output_, "write the point cloud as Wavefront OBJ with colours (needs a calibration)");
  app.add_option("--max-depth", max_depth_,
                 "leave out of --depth, --ply and --obj what lies deeper than Z (units of the baseline)")
      ->check(positive_number());
  app.add_flag("--check-rectification", check_rectification_,
               "report the vertical offsets of matched features between the views (0 px in a rectified pair)");
}

std::string MatchCommand::report_rectification(const cv::Mat& left, const cv::Mat& right, std::string_view which) {
  const RectificationReport r = check_rectification(left, right);
  std::ostringstream line;
  line.precision(3);
  line << "rectification of " << which << ": " << r.matches << " feature matches (" << r.features_left
       << " features left, " << r.features_right << " right, " << r.outliers << " outliers dropped); dy median "
       << r.median_dy << " px, |dy| median " << r.median_abs_dy << ", p95 " << r.p95_abs_dy << ", max "
       << r.max_abs_dy << "; disparity median " << r.median_dx << " px";
  if (r.negative_disparities * 2 > r.matches)
    line << " (most matches have negative disparity: are LEFT and RIGHT swapped?)";
  line << "; " << r.verdict;
  return line.str();
}

void MatchCommand::report_rectification_only() const {
  if (!right_output_.empty() || !preview_.empty() || !depth_output_.empty() || !ply_output_.empty() ||
      !obj_output_.empty() || !confidence_.empty())
    throw UsageError("-o,--output is required with --right-output, --color, --confidence, --depth, --ply and --obj");
  const cv::Mat left = read_input_image(left_, "left image");
  const cv::Mat right = read_input_image(right_, "right image");
  check_pair_size(left, right, left_, right_);
  const std::optional<Calibration> calibration =
      calibration_flags_.resolve(left.cols, left.rows, "left image " + in_quotes(left_));
  std::cout << report_rectification(left, right, "the input pair") << "\n";
  if (calibration && calibration->needs_rectification) {
    const Rectifier rectifier(*calibration, left.cols, left.rows);
    cv::Mat left_rectified, right_rectified;
    rectifier.rectify(left, right, left_rectified, right_rectified);
    std::cout << report_rectification(left_rectified, right_rectified,
                                      "the pair rectified with " + in_quotes(calibration->source))
              << "\n";
  }
}

MatchCommand::OutputFormats MatchCommand::check_outputs(const StereoParams& requested) const {
  std::vector<std::string> inputs = {left_, right_};
  for (const std::string& file : calibration_flags_.files()) inputs.push_back(file);
  OutputFormats formats;
  formats.left = disparity_format_for(output_, format_);
  check_output_path(output_, inputs, "disparity output");
  formats.right = formats.left;
  if (!right_output_.empty()) {
    formats.right = disparity_format_for(right_output_, format_);
    check_output_path(right_output_, inputs, "right disparity output");
  }
  if (!preview_.empty()) {
    check_preview_path(preview_);
    check_output_path(preview_, inputs, "colour preview");
  }
  if (!confidence_.empty()) {
    check_confidence_path(confidence_);
    check_output_path(confidence_, inputs, "confidence map");
  }
  // Depth and point clouds: their paths and whether the calibration they need was given.
  const bool calibrated = calibration_flags_.given();
  if (!depth_output_.empty()) {
    formats.depth = depth_format_for(depth_output_);
    if (formats.depth == DepthFormat::PngMillimetres && !calibrated)
      throw UsageError("--depth " + in_quotes(depth_output_) +
                       ": a PNG depth map holds millimetres and needs a calibration: give --calib FILE or --focal and "
                       "--baseline (or write relative depth 1/d to a .pfm file)");
    check_output_path(depth_output_, inputs, "depth output");
  }
  for (const auto& [flag, path] : {std::pair<std::string, std::string>{"--ply", ply_output_}, {"--obj", obj_output_}}) {
    if (path.empty()) continue;
    if (!calibrated)
      throw UsageError(flag + " " + in_quotes(path) +
                       ": a point cloud needs a calibration: give --calib FILE or --focal and --baseline");
    check_output_path(path, inputs, flag == "--ply" ? "point cloud (PLY)" : "point cloud (OBJ)");
  }
  if (max_depth_ > 0.0) {
    if (depth_output_.empty() && ply_output_.empty() && obj_output_.empty())
      throw UsageError("--max-depth cuts --depth, --ply and --obj, and none of them was given");
    if (!calibrated)
      throw UsageError("--max-depth is in the units of the baseline and needs a calibration: give --calib FILE or "
                       "--focal and --baseline");
  }
  check_distinct_outputs({{"-o", output_},
                          {"--right-output", right_output_},
                          {"--color", preview_},
                          {"--confidence", confidence_},
                          {"--depth", depth_output_},
                          {"--ply", ply_output_},
                          {"--obj", obj_output_}});
  check_format_range(formats.left, requested, output_);
  if (!right_output_.empty()) check_format_range(formats.right, requested, right_output_);
  return formats;
}

MatchCommand::InputPair MatchCommand::read_pair(const StereoParams& requested, const OutputFormats& formats) const {
  const cv::Mat input_left = read_input_image(left_, "left image");
  const cv::Mat input_right = read_input_image(right_, "right image");
  check_pair_size(input_left, input_right, left_, right_);
  check_parameters(requested, input_left.cols, input_left.rows);
  InputPair pair;
  std::optional<Calibration>& calibration = pair.calibration;
  calibration = calibration_flags_.resolve(input_left.cols, input_left.rows, "left image " + in_quotes(left_));
  // A calibration of the raw cameras: the pair is remapped into the rectified frame first, and its
  // geometry (focal, principal point, baseline) becomes that of the rectified cameras.
  if (calibration && calibration->needs_rectification) {
    if (check_rectification_) std::cout << report_rectification(input_left, input_right, "the input pair") << "\n";
    const Rectifier rectifier(*calibration, input_left.cols, input_left.rows);
    rectifier.rectify(input_left, input_right, pair.left, pair.right);
    calibration->geometry = rectifier.geometry();
    pair.rectified_note = ", rectified with " + in_quotes(calibration->source);
  } else {
    pair.left = input_left;
    pair.right = input_right;
  }
  if (check_rectification_)
    std::cout << report_rectification(pair.left, pair.right,
                                      pair.rectified_note.empty() ? "the input pair" : "the rectified pair")
              << "\n";
  if (calibration && !depth_output_.empty() && formats.depth == DepthFormat::PngMillimetres)
    (void)millimetres_per_unit(calibration->geometry.units);  // a unit a PNG of millimetres cannot convert
  return pair;
}

std::string MatchCommand::queue_outputs(const Matcher& matcher, const OutputFormats& formats, const InputPair& pair,
                                        PendingOutputs& outputs) const {
  const StereoParams& params = matcher.params();
  const std::int16_t invalid = matcher.invalid_q4();
  outputs.add(output_, encode_disparity(matcher.disparity_q4(), invalid, params.min_disparity, formats.left));
  std::string wrote = output_ + " (" + describe_format(formats.left, params.min_disparity) + ")";
  if (!right_output_.empty()) {
    outputs.add(right_output_,
                encode_disparity(matcher.right_disparity_q4(), invalid, params.min_disparity, formats.right));
    wrote += ", " + right_output_ + " (right view, " + describe_format(formats.right, params.min_disparity) + ")";
  }
  if (!preview_.empty()) {
    outputs.add(preview_, encode_preview(matcher.disparity_q4(), invalid, params.min_disparity,
                                         params.max_disparity(), preview_));
    wrote += ", " + preview_ + " (colour preview)";
  }
  if (!confidence_.empty()) {
    outputs.add(confidence_, encode_confidence(matcher.confidence(), confidence_));
    wrote += ", " + confidence_ + " (confidence, 0 to 1" + (lower_extension(confidence_) == ".png" ? " as 0 to 255)" : ")");
  }
  if (!depth_output_.empty() || !ply_output_.empty() || !obj_output_.empty())
    wrote += write_depth_outputs(matcher.disparity_q4(), invalid, pair.left, pair.calibration, outputs);
  return wrote;
}

void MatchCommand::run() const {
  const StereoParams requested = parameters_.resolve();
  check_parameters(requested);
  (void)run_flags_.parsed_backend();  // a misspelt backend or misplaced --device costs no image reading

  // Every check that needs no pixels comes first, so a mistake costs no matching.
  if (output_.empty()) {
    if (!check_rectification_)
      throw UsageError("-o,--output is required: give the disparity file to write (or --check-rectification alone "
                       "to only measure the rectification)");
    report_rectification_only();
    return;
  }
  const OutputFormats formats = check_outputs(requested);
  const InputPair pair = read_pair(requested, formats);
  const cv::Mat& left = pair.left;

  Matcher matcher =
      run_flags_.make_matcher(left.cols, left.rows, requested, !right_output_.empty(), !confidence_.empty());
  const StereoParams& params = matcher.params();

  // Stage times per frame; with --repeat each stage reports its median over the frames.
  std::vector<std::string> stage_order;
  std::map<std::string, std::vector<double>> stage_ms;
  for (int frame = 0; frame < repeat_; ++frame) {
    matcher.compute(image_view(left), image_view(pair.right));
    for (const StageTime& t : matcher.timings()) {
      if (frame == 0) stage_order.push_back(t.stage);
      stage_ms[t.stage].push_back(t.ms);
    }
  }

  PendingOutputs outputs;
  const std::string wrote = queue_outputs(matcher, formats, pair, outputs);
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
            << parameters_.preset_name() << pair.rectified_note << ", backend " << to_string(matcher.backend())
            << where << "; ms:" << stages << "; frame " << frame << "; valid "
            << fixed(valid_percent(matcher.disparity_q4(), matcher.invalid_q4()), 1) << " %; wrote " << wrote << "\n";
}

}  // namespace mctstereo::app
