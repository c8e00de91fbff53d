// `mctstereo render CLOUD.ply -o VIEW.png`: a picture of a point cloud from a chosen viewpoint.
#pragma once

#include <CLI/CLI.hpp>

#include <string>

namespace mctstereo::app {

class RenderCommand {
 public:
  /// Adds the subcommand and its flags to `parent`; must stay where it is until run().
  explicit RenderCommand(CLI::App& parent);
  RenderCommand(const RenderCommand&) = delete;
  RenderCommand& operator=(const RenderCommand&) = delete;

  bool selected() const { return command_->parsed(); }
  /// Reads the cloud, draws it and writes the picture. Throws UsageError / RuntimeError.
  void run() const;

 private:
  CLI::App* command_;
  std::string cloud_, output_, size_ = "800x600", background_ = "black";
  double yaw_ = 25.0, pitch_ = -15.0, distance_ = 1.0, focal_ = 0.0;
  int point_size_ = 2;
};

}  // namespace mctstereo::app
