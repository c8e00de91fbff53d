// mctstereo: the stereo matcher. Configured once per (size, parameters, backend), run per frame.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "mctstereo/image.hpp"
#include "mctstereo/params.hpp"

namespace mctstereo {

/// Where the pipeline runs.
enum class Backend {
  Reference,  ///< scalar, one plain loop per stage: the specification in code; single thread
  Cpu,        ///< SIMD (Highway, dispatched at run time) and the matcher's threads over chunks of rows
  OpenCL,     ///< OpenCL kernels on a GPU or any other OpenCL device; equals the others bit for bit
  Auto,       ///< resolved when the matcher is built: opencl on a GPU if there is one, else cpu
};

std::string_view to_string(Backend backend);
/// Parses "reference", "cpu", "opencl" or "auto"; throws std::invalid_argument naming the
/// accepted values.
Backend parse_backend(std::string_view name);

/// Fixed-point scale of the int16 disparity maps: value = 16 x disparity (as OpenCV's DISP_SHIFT 4).
inline constexpr int kDisparityShift = 4;
inline constexpr int kDisparityScale = 1 << kDisparityShift;

/// Options of a matcher that do not change its result.
struct MatcherOptions {
  /// Threads of the cpu backend, the caller's included; 0 = the OpenMP default (OMP_NUM_THREADS,
  /// else all cores), at most the machine's hardware threads. The matcher starts the others when it
  /// is built and keeps them until it is destroyed; each stage hands its rows out to them in small
  /// chunks and waits only for chunks that started, never for a thread that the OS has put off the
  /// CPU. Fewer when the system cannot start them all (see threads()). Ignored by reference.
  int threads = 0;
  /// Also produce the refined right-view disparity map (the LR check computes a raw one anyway).
  bool compute_right = false;
  /// Also produce the confidence map with box aggregation, where it costs the second-best search
  /// of every pixel of the finest level (a few percent of a frame). Band SGM always produces it:
  /// its winner selection finds the second best anyway.
  bool compute_confidence = false;
  /// Band SGM (4 paths) on the cpu backend: the most bytes of costs and path sums of a level held
  /// whole. A frame whose largest SGM level needs more (SGM at every level with 32 candidates at
  /// the finest, from about 1024 x 768 on; quality, whose largest SGM level is the middle one of
  /// three, from about four times as many pixels) is aggregated in segments of rows, with the same
  /// maps: every cost is made twice and one vertical path runs twice, and the memory for costs and
  /// sums falls to one segment's (SGM at every level at 1280 x 720: 84 MiB whole, 2.6 MiB in
  /// segments). SIZE_MAX: always whole.
  std::size_t sgm_volume_limit = std::size_t{32} << 20;
  /// The cpu backend with more than one thread: the matcher keeps the recent frame times (the
  /// median of the last 8) on its threads and on the caller's thread alone, runs frames the faster
  /// way, and tries the other for 3 frames (their median): after the first 3 frames, 16 frames
  /// after a trial that changed the way, twice as many after each that confirmed it (at most 256),
  /// and sooner (16 frames after the last trial) once the way it runs has become slower than the
  /// other was when last tried.
  /// On a CPU that other processes keep busy the threads wait for each other and one thread can
  /// be faster. The maps are the same either way. false: every frame on all the threads.
  /// frames_alone() counts the frames run alone.
  bool adapt_threads = true;
  /// Frames a new matcher of several threads with adapt_threads runs before its first trial of one
  /// thread has ended (3 on its threads, then the 3 of the trial): a benchmark that warms up fewer
  /// would time the trial's frames as if they were the matcher's way.
  static constexpr int kFramesToFirstChoice = 6;
  /// The OpenCL device of the opencl and auto backends: "" prefers the first GPU, else the first
  /// device; a number is an index into opencl_devices(); other text picks the first device whose
  /// name or platform contains it (case-insensitive).
  std::string device;
};

/// Wall time of one stage of the last frame, milliseconds.
struct StageTime {
  std::string stage;
  double ms = 0.0;
};

/// What the matching stage examined at one pyramid level of the last frame.
struct LevelWork {
  int width = 0, height = 0;  ///< the level's size
  /// Views matched: 2 when the LR check (or compute_right) needs the right map of box
  /// aggregation; 1 with band SGM, whose right map comes from the same sums.
  int views = 0;
  /// Disparities examined per pixel and view, mean over the level (a pixel that is not matched
  /// counts 0: the right view's odd rows at the finest level under StereoParams::lr_check_grid).
  double candidates = 0.0;
  /// Pixel-disparity pairs examined at the level, all views: width x height x views x candidates.
  double pairs() const { return static_cast<double>(width) * height * views * candidates; }
};

/// Dense stereo matcher on the (modified) census transform with multi-resolution search.
///
/// The constructor validates the parameters (std::invalid_argument with the message of
/// StereoParams::validate) and allocates every buffer; compute() allocates nothing. On the
/// opencl backend that holds for the library's own host and device memory; what an OpenCL driver
/// does inside its calls is the driver's (PoCL allocates nothing through operator new there).
/// Not thread-safe: use one matcher per thread of the caller.
///
/// Backend::OpenCL opens the device of MatcherOptions::device, allocates every device buffer and
/// builds the kernels once (a matcher of the same device and parameters reuses the builds);
/// std::runtime_error when there is no such device, when a kernel does not build (with the build
/// log) or when the device memory does not suffice. A build without OpenCL throws
/// std::invalid_argument. Backend::Auto never fails for want of a device: see notice().
class Matcher {
 public:
  Matcher(int width, int height, const StereoParams& params, Backend backend = Backend::Cpu,
          const MatcherOptions& options = {});
  ~Matcher();
  Matcher(Matcher&&) noexcept;
  Matcher& operator=(Matcher&&) noexcept;
  Matcher(const Matcher&) = delete;
  Matcher& operator=(const Matcher&) = delete;

  /// Matches one rectified pair. Both views must have the configured size; formats may differ
  /// (colour is converted to luma, BT.601). Throws std::invalid_argument on a size mismatch or a
  /// null pointer.
  void compute(const ImageView& left, const ImageView& right);
  /// With StereoParams::temporal: the next compute() matches its frame alone, as the first of a
  /// sequence (call it at a cut the caller knows of, or when frames were skipped). The prior
  /// guards itself against motion and cuts pixel by pixel; this drops it for a whole frame.
  void reset_temporal();
  /// Whether the last compute() used the previous frame's maps (StereoParams::temporal, a frame
  /// before it, no reset_temporal() between).
  bool used_temporal_prior() const;

  /// Left disparity of the last frame, Q4 (16 x pixels); invalid pixels hold invalid_q4().
  /// The view belongs to the matcher and is overwritten by the next compute().
  MapView<const std::int16_t> disparity_q4() const;
  /// Left disparity in pixels, NaN where invalid. Made from the Q4 map by the first call after
  /// each compute() (a pass over the map, or a download from the OpenCL device), so a caller that
  /// only reads disparity_q4() does not pay for it; allocates nothing.
  MapView<const float> disparity() const;
  /// Confidence of each pixel of the left map in [0, 1] (docs/PIPELINE.md, "Confidence"): the
  /// winner's margin over the best sum outside d-1..d+1, times the left-right agreement; 0 where the
  /// checks invalidated the pixel and the fill guessed its value. Made by the first call after each
  /// compute(); allocates nothing. Empty (null data) before the first frame, and with box aggregation
  /// unless MatcherOptions::compute_confidence.
  MapView<const float> confidence() const;
  /// Right-view disparity (Q4; the right pixel x matches left x + d), refined like the left one.
  /// Empty (null data) unless MatcherOptions::compute_right.
  MapView<const std::int16_t> right_disparity_q4() const;

  /// The Q4 value of invalid pixels: (min_disparity - 1) * 16, as OpenCV.
  std::int16_t invalid_q4() const;

  int width() const;
  int height() const;
  const StereoParams& params() const;
  /// The backend that runs: never Backend::Auto (resolved at construction).
  Backend backend() const;
  /// One line on how Backend::Auto was resolved when it fell back ("no OpenCL GPU found: running
  /// on the cpu backend"); "" otherwise.
  std::string notice() const;
  /// The OpenCL device of the opencl backend, "NAME (PLATFORM)"; "" for the other backends.
  std::string device_name() const;
  /// Threads the cpu backend uses (1 for reference; for opencl, the host threads of speckle
  /// removal, which runs on the host). On the cpu backend, fewer than MatcherOptions::threads when
  /// the system could not start them all (a memory limit).
  int threads() const;
  /// Frames so far that a matcher of several threads ran on the caller's thread alone
  /// (MatcherOptions::adapt_threads: its trials, and frames where one thread was the faster way;
  /// and the frames of set_single_threaded(true)).
  long frames_alone() const;
  /// true: the next frames run on the caller's thread alone, whatever MatcherOptions say, until
  /// set_single_threaded(false). For a pipeline whose bottleneck is elsewhere (a video encoder, a
  /// writer): a frame that would wait for it anyway gains nothing from the matcher's threads, and
  /// they take CPU from it. The maps are the same either way; no effect on one thread, reference
  /// or opencl. These frames do not enter adapt_threads' frame times.
  void set_single_threaded(bool single);
  bool single_threaded() const;
  /// SIMD target chosen at run time ("AVX3", "AVX2", "NEON", ... ; "scalar" for reference; for
  /// opencl, the host's, used by speckle removal).
  std::string simd_target() const;
  /// Per-stage times of the last compute(); the last entry is "frame", the whole call.
  /// reference and cpu: gray, pyramid, census, match, refine, output, frame (host wall ms).
  /// opencl: upload, gray, pyramid, census, match, median, lr_check, speckle, fill, upscale, output,
  /// download, frame (with SGM aggregation, "confidence" after speckle; the SGM stages' kernels
  /// count as match): the kernels' device ms from profiling events (summed per stage; 0 for a
  /// stage that did not run), except upload, download and speckle (on the host, its transfers
  /// included) and frame (the whole call), which are host wall ms.
  const std::vector<StageTime>& timings() const;
  /// The candidates of the last frame's matching stage, per level (finest first): with timings(),
  /// the time per pixel and disparity. Counted on request from the last frame's priors (a pass over
  /// each level's pixels), so a caller that does not ask pays nothing. Empty before the first frame
  /// and on the opencl backend.
  std::vector<LevelWork> level_work() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// An OpenCL device, as opencl_devices() lists it.
struct OpenclDevice {
  int index = -1;  ///< what MatcherOptions::device and --device take
  std::string name, platform, vendor;
  std::string type;  ///< "GPU", "CPU", "accelerator" or "other"
  std::string version, c_version, driver;  ///< "OpenCL 3.0 ...", "OpenCL C 1.2 ...", driver version
  int compute_units = 0;
  std::uint64_t global_memory = 0;   ///< bytes
  std::uint64_t max_allocation = 0;  ///< bytes of the largest buffer
  bool has_popcount = false;         ///< OpenCL C 1.2 or later: the kernels count bits with popcount()
};

/// Whether this build has the opencl backend (built with OpenCL's headers and ICD loader).
bool have_opencl();
/// Every OpenCL device of every platform; empty without a platform (no driver installed) or in a
/// build without the opencl backend.
std::vector<OpenclDevice> opencl_devices();

/// Bytes the matcher of the cpu backend allocates for (params, width, height): grows with W x H x
/// (search width at the finest level), not with W x H x D. Band SGM adds W x H x (its band, rounded
/// up to 16) x 3 bytes (4 with 16-bit costs) at the finest level (the whole range with one level, as
/// sgm-full), or, above options.sgm_volume_limit, a segment of rows of that and its checkpoints.
std::size_t estimate_memory(const StereoParams& params, int width, int height,
                            const MatcherOptions& options = {});

}  // namespace mctstereo
