// `mctstereo match LEFT RIGHT -o OUT`: one rectified pair to a disparity file.
#pragma once

#include <CLI/CLI.hpp>

#include <opencv2/core.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "calibration.hpp"
#include "depth_files.hpp"
#include "io.hpp"
#include "options.hpp"
#include "output_files.hpp"

namespace mctstereo::app {

class MatchCommand {
 public:
  /// Adds the subcommand and its flags to `parent`; must stay where it is until run().
  explicit MatchCommand(CLI::App& parent);
  MatchCommand(const MatchCommand&) = delete;
  MatchCommand& operator=(const MatchCommand&) = delete;

  bool selected() const { return command_->parsed(); }
  /// Matches, writes the outputs and prints the summary line. Throws UsageError / RuntimeError.
  void run() const;

 private:
  // The encodings of the outputs, from their names and --format.
  struct OutputFormats {
    DisparityFormat left = DisparityFormat::Kitti, right = DisparityFormat::Kitti;
    DepthFormat depth = DepthFormat::Pfm;
  };
  // The pair as it is matched: rectified first where the calibration is of the raw cameras.
  struct InputPair {
    cv::Mat left, right;
    std::optional<Calibration> calibration;  // with the rectified geometry
    std::string rectified_note;              // ", rectified with FILE" or empty
  };

  // Without -o: the rectification report of the pair (and of the rectified pair) alone.
  void report_rectification_only() const;
  // Every check of the output paths and their flags that needs no pixels.
  OutputFormats check_outputs(const StereoParams& requested) const;
  // Reads, checks and (with a raw calibration) rectifies the pair.
  InputPair read_pair(const StereoParams& requested, const OutputFormats& formats) const;
  // Adds every requested output of the last frame to `outputs`; what they are, for the summary.
  std::string queue_outputs(const Matcher& matcher, const OutputFormats& formats, const InputPair& pair,
                            PendingOutputs& outputs) const;

  // Adds the --depth, --ply and --obj files of the last frame to `outputs`; what it wrote, for the summary.
  std::string write_depth_outputs(MapView<const std::int16_t> q4, std::int16_t invalid_q4, const cv::Mat& left,
                                  const std::optional<Calibration>& calibration, PendingOutputs& outputs) const;

  // One line on the vertical offsets of matched features between the views; `which` names the pair.
  static std::string report_rectification(const cv::Mat& left, const cv::Mat& right, std::string_view which);

  CLI::App* command_;
  ParameterFlags parameters_;
  RunFlags run_flags_;
  CalibrationFlags calibration_flags_;
  std::string left_, right_, output_, right_output_, preview_, format_, confidence_;
  std::string depth_output_, ply_output_, obj_output_;
  double max_depth_ = 0.0;  // 0 = no cut
  int repeat_ = 1;
  bool check_rectification_ = false;
};

}  // namespace mctstereo::app
