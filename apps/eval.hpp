// `mctstereo eval DATA`: scores of every scene folder under DATA against its ground truth
// (Middlebury v2 and v3, KITTI D1), for one or more presets and the OpenCV peers, optionally under
// changes of the right image's exposure (--radiometric).
#pragma once

#include <CLI/CLI.hpp>
#include <opencv2/core.hpp>

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "options.hpp"

namespace mctstereo::app {

/// The key=value lines of a scene.txt ('#' starts a comment line). RuntimeError if unreadable.
std::map<std::string, std::string> read_scene_file(const std::filesystem::path& path);

/// A scene folder as eval reads it before matching it.
struct SceneSummary {
  std::string name;
  int width = 0, height = 0;                   ///< of its images
  int min_disparity = 0, num_disparities = 0;  ///< the range its scene.txt gives
  std::string mask_source;                     ///< "files", "derived-lr-check" or "ground-truth-only"
};

/// Reads the scene in `folder` as eval does: scene.txt, both images, the ground truth (PFM, or an
/// 8- or 16-bit image with gt_scale), the masks or gt_right, and the disparity range. RuntimeError
/// naming the file and the problem otherwise.
SceneSummary read_scene(const std::filesystem::path& folder);

/// A scene's pair and the truth to score its left map against, as eval reads them.
struct ScenePair {
  std::string name;
  cv::Mat left, right;   ///< 8-bit gray or BGR, as the matcher takes them
  cv::Mat ground_truth;  ///< CV_32F pixels, NaN where unknown
  cv::Mat nonocc;        ///< CV_8U, 255 = scored as non-occluded (the scene's nonocc mask, else its known pixels)
  int min_disparity = 0, num_disparities = 0;
};

/// read_scene() with the pixels. RuntimeError as read_scene().
ScenePair read_scene_pair(const std::filesystem::path& folder);

/// Folders holding a scene.txt: `data` itself and every folder below it, sorted by path.
/// RuntimeError when `data` is not a folder.
std::vector<std::filesystem::path> find_scene_folders(const std::filesystem::path& data);

class EvalCommand {
 public:
  /// Adds the subcommand and its flags to `parent`; must stay where it is until run().
  explicit EvalCommand(CLI::App& parent);
  EvalCommand(const EvalCommand&) = delete;
  EvalCommand& operator=(const EvalCommand&) = delete;

  bool selected() const { return command_->parsed(); }
  /// Scores every scene, prints the tables, writes --json and --save. Throws UsageError / RuntimeError.
  void run() const;

 private:
  /// The preset `name` with the parameter flags that were given on top.
  StereoParams resolve_preset(const std::string& name) const;

  CLI::App* command_;
  ParameterFlags parameters_;
  RunFlags run_flags_;
  std::string data_, json_, save_dir_;
  float threshold_ = 1.0f;
  int repeat_ = 1;
  bool peers_ = false, radiometric_ = false, quiet_ = false;
};

}  // namespace mctstereo::app
