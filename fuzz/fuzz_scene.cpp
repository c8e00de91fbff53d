// scene.txt as `eval` reads a scene folder (app::read_scene: the key=value lines, the images, the
// ground truth of PFM or PNG, masks, gt_scale, gt_invalid, min_disp and max_disp). The input is the
// scene.txt of a folder that also holds a small valid scene: imL.png, imR.png (8 x 6), gt.pfm,
// gt_right.pfm, gt.png, nonocc.png, all.png, disc.png, so that the fuzzer reaches every key. The
// scene must read with a range of at least one disparity within [-4096, 4096], or fail with the
// program's RuntimeError or UsageError.
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cstdint>
#include <cstdlib>
#include <utility>

#include "errors.hpp"
#include "eval.hpp"
#include "fuzz_files.hpp"
#include "mctstereo/pfm.hpp"

namespace {

const std::filesystem::path& scene_folder() {
  static const std::filesystem::path folder = [] {
    namespace fuzz = mctstereo::fuzz;
    const std::filesystem::path f = fuzz::scratch_folder() / "scene";
    std::filesystem::create_directories(f);
    cv::Mat left(6, 8, CV_8U), right(6, 8, CV_8U), mask(6, 8, CV_8U, cv::Scalar(255)), gt8(6, 8, CV_8U);
    cv::randu(left, 0, 256);
    cv::randu(right, 0, 256);
    cv::randu(gt8, 0, 16);
    cv::imwrite((f / "imL.png").string(), left);
    cv::imwrite((f / "imR.png").string(), right);
    cv::imwrite((f / "gt.png").string(), gt8);
    for (const char* m : {"nonocc.png", "all.png", "disc.png"}) cv::imwrite((f / m).string(), mask);
    mctstereo::FloatMap gt{8, 6, std::vector<float>(48, 2.5f)};
    gt.values[5] = mctstereo::kPfmNone;
    const std::vector<std::uint8_t> pfm = mctstereo::encode_pfm(std::as_const(gt).view());
    fuzz::write_file(f / "gt.pfm", pfm.data(), pfm.size());
    fuzz::write_file(f / "gt_right.pfm", pfm.data(), pfm.size());
    return f;
  }();
  return folder;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  cv::setNumThreads(1);
  (void)scene_folder();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mctstereo;
  fuzz::write_file(scene_folder() / "scene.txt", data, size);
  try {
    const app::SceneSummary s = app::read_scene(scene_folder());
    if (s.width != 8 || s.height != 6 || s.num_disparities < 1 || s.min_disparity < -4096 ||
        s.min_disparity + s.num_disparities - 1 > 4096)
      std::abort();
  } catch (const app::RuntimeError&) {
  } catch (const app::UsageError&) {
  }
  return 0;
}
