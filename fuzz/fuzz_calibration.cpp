// Calibration files as `--calib FILE` reads them (app::read_calibration): a Middlebury calib.txt or
// an OpenCV FileStorage file in YAML, JSON or XML, told apart by content and extension. The first
// byte picks the file's extension (.txt, .yml, .yaml, .json, .xml or none) and whether the reader
// is given an image size (as match and stream give it); the rest is the file. Every input must
// either give a calibration with finite numbers, or the program's RuntimeError or UsageError (a
// one-line message); any other exception, a crash or a stack overflow in OpenCV's parsers (see
// the nesting check in apps/calibration.cpp) is a finding.
#include <cmath>
#include <cstdint>
#include <cstdlib>

#include "calibration.hpp"
#include "errors.hpp"
#include "fuzz_files.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mctstereo;
  if (size < 1) return 0;
  static const char* const kExtensions[] = {".txt", ".yml", ".yaml", ".json", ".xml", ""};
  const std::uint8_t choice = data[0];
  const std::filesystem::path path = fuzz::scratch_folder() / (std::string("calib") + kExtensions[choice % 6]);
  fuzz::write_file(path, data + 1, size - 1);
  const bool sized = (choice / 6) % 2 == 1;
  try {
    const app::Calibration c = sized ? app::read_calibration(path.string(), 64, 48) : app::read_calibration(path.string());
    const StereoGeometry& g = c.geometry;
    for (double v : {g.focal, g.baseline, g.cx, g.cy, g.doffs})
      if (!std::isfinite(v)) std::abort();
    if (c.width < 0 || c.height < 0) std::abort();
  } catch (const app::RuntimeError&) {
  } catch (const app::UsageError&) {
  }
  std::filesystem::remove(path);
  return 0;
}
