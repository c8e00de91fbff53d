#include "options.hpp"


#include <cctype>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "calibration.hpp"
#include "errors.hpp"

namespace mctstereo::app {

namespace {

constexpr const char* kParameterGroup = "Parameters (default: the preset's value)";

// StereoParams field -> the flag that sets it; used to point validate()'s messages at a flag.
struct FieldFlag {
  const char* field;
  const char* flag;
};
constexpr FieldFlag kFieldFlags[] = {
    {"min_disparity", "--min-disparity"},
    {"num_disparities", "--num-disparities"},
    {"census_window", "--census-window"},
    {"shd_window", "--shd-window"},
    {"coarse_shd_window", "--coarse-shd-window"},
    {"pyramid_levels", "--levels"},
    {"search_radius", "--search-radius"},
    {"median_size", "--median"},
    {"post_median_size", "--post-median"},
    {"lr_threshold", "--lr-threshold"},
    {"speckle_size", "--speckle-size"},
    {"uniqueness_ratio", "--uniqueness"},
    {"working_scale", "--scale"},
    {"sgm_p1", "--p1"},
    {"sgm_p2", "--p2"},
    {"sgm_p2_k", "--p2-k"},
    {"prior_size", "--prior-size"},
    {"box_levels", "--box-levels"},
    {"finest_search_radius", "--finest-radius"},
    {"sgm_max_band", "--max-band"},
    {"wm_radius", "--wm-radius"},
    {"wm_step", "--wm-step"},
    {"wm_sigma", "--wm-sigma"},
};

bool is_identifier_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

// Whether `word` occurs in `line` as a whole identifier (so "shd_window" does not match inside
// "coarse_shd_window").
bool contains_word(std::string_view line, std::string_view word) {
  for (std::size_t at = line.find(word); at != std::string_view::npos; at = line.find(word, at + 1)) {
    const bool starts = at == 0 || !is_identifier_char(line[at - 1]);
    const bool ends = at + word.size() == line.size() || !is_identifier_char(line[at + word.size()]);
    if (starts && ends) return true;
  }
  return false;
}

template <typename Enum>
Enum parse_enum(const std::string& text, std::initializer_list<Enum> values) {
  for (Enum v : values)
    if (to_string(v) == text) return v;
  throw UsageError("unexpected value '" + text + "'");  // CLI11's IsMember check runs first
}

}  // namespace

template <typename T>
void ParameterFlags::add(CLI::App& app, const std::string& names, T& storage, const std::string& help,
                         std::function<void(StereoParams&)> apply) {
  CLI::Option* option;
  if constexpr (std::is_same_v<T, bool>)
    option = app.add_flag(names, storage, help);
  else
    option = app.add_option(names, storage, help);
  option->group(kParameterGroup);
  overrides_.push_back({names.substr(0, names.find(',')), option, std::move(apply)});
}

ParameterFlags::ParameterFlags(CLI::App& app) {
  std::string presets;
  for (const std::string& name : preset_names())
    presets += "\n  " + name + ": " + std::string(preset_description(name));
  app.add_option("--preset", preset_name_,
                 "named parameter set, applied before the other parameter flags (default balanced):" + presets)
      ->group(kParameterGroup);

  StereoParams& v = values_;
  add(app, "--min-disparity", v.min_disparity,
      "smallest disparity searched, pixels; may be negative; [-1024, 1024]. Disparity d: left pixel x matches "
      "right pixel x - d",
      [&v](StereoParams& p) { p.min_disparity = v.min_disparity; });
  add(app, "--num-disparities", v.num_disparities,
      "number of disparities searched (any count, [1, 2048]): min .. min + N - 1, with min + N - 1 <= 2039 (the "
      "output holds 16 x d in 16 bits)",
      [&v](StereoParams& p) { p.num_disparities = v.num_disparities; });
  app.add_option("--census", census_, "local transform: ct (census) or mct (modified census, 3x3 mean reference)")
      ->check(CLI::IsMember({"ct", "mct"}))
      ->group(kParameterGroup);
  overrides_.push_back({"--census", app.get_option("--census"), [this](StereoParams& p) {
                          p.census = parse_enum(census_, {CensusKind::Census, CensusKind::ModifiedCensus});
                        }});
  add(app, "--census-window", v.census_window, "census window side: 3, 5, 7 or 9 pixels",
      [&v](StereoParams& p) { p.census_window = v.census_window; });
  app.add_option("--mct-kernel", mct_kernel_, "3x3 kernel of the MCT mean: mean (box) or gaussian (1 2 1)")
      ->check(CLI::IsMember({"mean", "gaussian"}))
      ->group(kParameterGroup);
  overrides_.push_back({"--mct-kernel", app.get_option("--mct-kernel"), [this](StereoParams& p) {
                          p.mct_kernel = parse_enum(mct_kernel_, {MeanKernel::Box, MeanKernel::Gaussian});
                        }});
  add(app, "--shd-window", v.shd_window,
      "side of the window summing Hamming distances at the finest level: 1, 3, 5, 7 or 9",
      [&v](StereoParams& p) { p.shd_window = v.shd_window; });
  add(app, "--coarse-shd-window", v.coarse_shd_window, "the same at the coarser pyramid levels: 1, 3, 5, 7 or 9",
      [&v](StereoParams& p) { p.coarse_shd_window = v.coarse_shd_window; });
  add(app, "--levels", v.pyramid_levels, "pyramid levels, [1, 5]; 1 = one level with the full search",
      [&v](StereoParams& p) { p.pyramid_levels = v.pyramid_levels; });
  add(app, "--search-radius", v.search_radius,
      "extra search around the coarser level's disparity, pixels of the level, [0, 16]",
      [&v](StereoParams& p) { p.search_radius = v.search_radius; });
  add(app, "--subpixel,!--no-subpixel", v.subpixel, "sub-pixel refinement by a parabola (1/16 px steps)",
      [&v](StereoParams& p) { p.subpixel = v.subpixel; });
  add(app, "--median", v.median_size, "median filter side: 0 (off), 3 or 5",
      [&v](StereoParams& p) { p.median_size = v.median_size; });
  add(app, "--post-median", v.post_median_size,
      "median filter side after filling (smooths the fill's streaks): 0 (off), 3 or 5",
      [&v](StereoParams& p) { p.post_median_size = v.post_median_size; });
  add(app, "--lr-check,!--no-lr-check", v.lr_check, "left-right consistency check",
      [&v](StereoParams& p) { p.lr_check = v.lr_check; });
  add(app, "--lr-threshold", v.lr_threshold, "largest left-right difference kept, pixels of the level, [0, 16]",
      [&v](StereoParams& p) { p.lr_threshold = v.lr_threshold; });
  add(app, "--lr-check-grid,!--no-lr-check-grid", v.lr_check_grid,
      "finest level: check the left map against the right map on the grid of even rows and columns (the right "
      "view's median on that grid)",
      [&v](StereoParams& p) { p.lr_check_grid = v.lr_check_grid; });
  add(app, "--speckle-size", v.speckle_size,
      "regions smaller than this many pixels become invalid; 0 = off; [0, 1000000]",
      [&v](StereoParams& p) { p.speckle_size = v.speckle_size; });
  add(app, "--uniqueness", v.uniqueness_ratio,
      "invalid where the second best cost is within this percent of the best; 0 = off; [0, 100]",
      [&v](StereoParams& p) { p.uniqueness_ratio = v.uniqueness_ratio; });
  app.add_option("--fill", fill_,
                 "filling of invalid pixels along the row: none, nearest, or nearest-lower (background wins)")
      ->check(CLI::IsMember({"none", "nearest", "nearest-lower"}))
      ->group(kParameterGroup);
  overrides_.push_back({"--fill", app.get_option("--fill"), [this](StereoParams& p) {
                          p.fill = parse_enum(fill_, {FillMode::None, FillMode::Nearest, FillMode::NearestLower});
                        }});
  add(app, "--refine-all-levels,!--finest-only", v.refine_all_levels,
      "refine (median, LR check, speckles, fill) at every pyramid level, or at the finest only",
      [&v](StereoParams& p) { p.refine_all_levels = v.refine_all_levels; });
  add(app, "--scale", v.working_scale,
      "working scale: 1, 2 or 4; match on the image reduced this many times, output at full size",
      [&v](StereoParams& p) { p.working_scale = v.working_scale; });
  app.add_option("--aggregation", aggregation_,
                 "cost aggregation: box (box sums of Hamming distances), sgm4 or sgm8 (semi-global paths inside "
                 "the coarse-to-fine band, 4 or 8 paths)")
      ->check(CLI::IsMember({"box", "sgm4", "sgm8"}))
      ->group(kParameterGroup);
  // Box aggregation searches around the 3x3 prior at every level: switching an SGM preset to box
  // takes that prior and no SGM levels (an explicit --prior-size, applied after this, still decides).
  overrides_.push_back({"--aggregation", app.get_option("--aggregation"), [this](StereoParams& p) {
                          p.aggregation = parse_enum(aggregation_, {Aggregation::Box, Aggregation::Sgm4, Aggregation::Sgm8});
                          if (p.aggregation == Aggregation::Box) {
                            p.prior_size = 3;
                            p.box_levels = 0;
                          }
                        }});
  add(app, "--p1", v.sgm_p1, "SGM penalty of a one-disparity step along a path, cost units (Hamming bits); [0, 16383]",
      [&v](StereoParams& p) { p.sgm_p1 = v.sgm_p1; });
  add(app, "--p2", v.sgm_p2, "SGM penalty of a larger jump, cost units; [--p1, 16383]",
      [&v](StereoParams& p) { p.sgm_p2 = v.sgm_p2; });
  add(app, "--p2-k", v.sgm_p2_k,
      "adaptive P2: P2' = max(P1, P2 k / (k + |I(p) - I(q)|)); 0 = constant P2; [0, 255]",
      [&v](StereoParams& p) { p.sgm_p2_k = v.sgm_p2_k; });
  add(app, "--prior-size", v.prior_size,
      "coarse neighbourhood whose priors span a pixel's search: 3 or 5 (5: SGM only)",
      [&v](StereoParams& p) { p.prior_size = v.prior_size; });
  add(app, "--box-levels", v.box_levels,
      "SGM: the finest this many levels match locally with box sums around the coarser SGM levels' maps "
      "(the coarsest level is always SGM's); 0 = SGM at every level; [0, 4]",
      [&v](StereoParams& p) { p.box_levels = v.box_levels; });
  add(app, "--finest-radius", v.finest_search_radius,
      "search radius at the finest level, pixels; -1 = --search-radius; [-1, 16]",
      [&v](StereoParams& p) { p.finest_search_radius = v.finest_search_radius; });
  add(app, "--max-band", v.sgm_max_band,
      "SGM: most candidates per pixel at the levels with a prior (memory W x H x this); [1, 255]",
      [&v](StereoParams& p) { p.sgm_max_band = v.sgm_max_band; });
  app.add_option("--weighted-median", weighted_median_,
                 "colour-weighted median at the finest level after the fill, then a 3x3 median (in place of "
                 "--post-median there): on or off")
      ->check(CLI::IsMember({"on", "off"}))
      ->group(kParameterGroup);
  overrides_.push_back({"--weighted-median", app.get_option("--weighted-median"),
                        [this](StereoParams& p) { p.weighted_median = weighted_median_ == "on"; }});
  add(app, "--wm-radius", v.wm_radius, "weighted median: window radius, pixels of the working scale; [1, 15]",
      [&v](StereoParams& p) { p.wm_radius = v.wm_radius; });
  add(app, "--wm-step", v.wm_step,
      "weighted median: sample every this many pixels in x and y (9 and 3: 7 x 7 samples); [1, --wm-radius]",
      [&v](StereoParams& p) { p.wm_step = v.wm_step; });
  add(app, "--wm-sigma", v.wm_sigma,
      "weighted median: colour scale of the weights 64 exp(-k / sigma), k the largest channel difference; "
      "[1, 255]",
      [&v](StereoParams& p) { p.wm_sigma = v.wm_sigma; });
}

StereoParams ParameterFlags::resolve() const {
  StereoParams params;
  try {
    params = preset(preset_name_);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--preset: ") + e.what());
  }
  for (const Override& o : overrides_)
    if (o.option->count() > 0) o.apply(params);
  return params;
}

bool ParameterFlags::given(std::string_view flag) const {
  for (const Override& o : overrides_)
    if (o.flag == flag) return o.option->count() > 0;
  return false;
}

const char* const kBackendHelp =
    "where the pipeline runs: cpu (SIMD + threads), reference (scalar), opencl (an OpenCL device, see --device "
    "and 'mctstereo devices') or auto (opencl on a GPU if there is one, else cpu)";
const char* const kDeviceHelp =
    "OpenCL device of --backend opencl or auto: an index or a part of the name of a device 'mctstereo devices' "
    "lists (default: the first GPU, else the first device)";

void RunFlags::add_to(CLI::App& app) {
  app.add_option("--backend", backend, kBackendHelp)->capture_default_str();
  app.add_option("--device", device, kDeviceHelp);
  app.add_option("--threads", threads,
                 "threads of the cpu backend (and of opencl's host steps); 0 = OpenMP's default (OMP_NUM_THREADS, "
                 "else all cores), at most the hardware threads")
      ->check(CLI::Range(0, 4096))
      ->capture_default_str();
  app.add_flag("--fixed-threads", fixed_threads,
               "run every frame on all --threads; by default the matcher runs its frames on all of them or on the "
               "calling thread alone, whichever its recent frames found faster (on a CPU that other processes keep "
               "busy, one can be; the same maps)");
  app.add_option("--sgm-volume-limit", sgm_volume_limit_mib,
                 "MiB: band SGM (4 paths, cpu backend) holds a level's costs and path sums whole up to this size, "
                 "and aggregates larger frames in segments of rows (the same maps, about a tenth of the memory, "
                 "some more time); 0 = always in segments")
      ->check(CLI::Range(0.0, 1048576.0))
      ->capture_default_str();
}

Backend RunFlags::parsed_backend() const {
  Backend parsed;
  try {
    parsed = parse_backend(backend);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--backend: ") + e.what());
  }
  if (!device.empty() && parsed != Backend::OpenCL && parsed != Backend::Auto)
    throw UsageError("--device " + device + ": only --backend opencl and auto run on an OpenCL device");
  return parsed;
}

MatcherOptions RunFlags::matcher_options(bool compute_right, bool compute_confidence) const {
  MatcherOptions options;
  options.threads = threads;
  options.compute_right = compute_right;
  options.compute_confidence = compute_confidence;
  options.device = device;
  options.sgm_volume_limit = static_cast<std::size_t>(sgm_volume_limit_mib * 1048576.0);
  options.adapt_threads = !fixed_threads;
  return options;
}

namespace {

std::string mebibytes(std::size_t bytes) { return std::to_string((bytes + (1u << 20) - 1) >> 20) + " MiB"; }

}  // namespace

Matcher RunFlags::make_matcher(int width, int height, const StereoParams& params, bool compute_right,
                               bool compute_confidence) const {
  Matcher matcher = construct_matcher(width, height, params, compute_right, compute_confidence, threads);
  // The cpu backend starts its threads with the matcher and keeps those that started (a memory
  // limit, ulimit -v, leaves no room for more stacks).
  if (matcher.backend() == Backend::Cpu && threads > 1 && matcher.threads() < threads)
    std::cerr << "mctstereo: note: only " << matcher.threads() << " of " << threads
              << " threads could be started (memory limit?); matching with " << matcher.threads() << "\n";
  return matcher;
}

Matcher RunFlags::construct_matcher(int width, int height, const StereoParams& params, bool compute_right,
                                    bool compute_confidence, int thread_count) const {
  const Backend requested = parsed_backend();
  MatcherOptions options = matcher_options(compute_right, compute_confidence);
  options.threads = thread_count;
  try {
    Matcher matcher(width, height, params, requested, options);
    if (!matcher.notice().empty()) std::cerr << "mctstereo: note: " << matcher.notice() << "\n";
    return matcher;
  } catch (const std::bad_alloc&) {
    throw RuntimeError("out of memory: matching " + std::to_string(width) + "x" + std::to_string(height) +
                       " needs about " + mebibytes(estimate_memory(params, width, height, options)) +
                       " (fewer --threads, a larger --scale or fewer --num-disparities need less)");
  } catch (const std::invalid_argument& e) {
    // No opencl backend in this build: the command asked for what cannot be.
    if (requested == Backend::OpenCL && !have_opencl()) throw UsageError(std::string("--backend opencl: ") + e.what());
    throw;
  } catch (const std::runtime_error& e) {
    // Only the OpenCL device fails at run time here: say which flag led to it.
    const std::string flag = device.empty() ? "--backend " + backend : "--device " + device;
    throw RuntimeError(flag + ": " + e.what());
  }
}

namespace {

// One line from validate()'s messages (one per problem), each followed by the flags it concerns.
[[noreturn]] void throw_invalid_parameters(const std::string& problems, std::string message) {
  std::istringstream lines(problems);
  std::string line;
  bool first = true;
  while (std::getline(lines, line)) {
    std::string flags;
    for (const FieldFlag& f : kFieldFlags)
      if (contains_word(line, f.field)) flags += (flags.empty() ? "" : ", ") + std::string(f.flag);
    message += (first ? "" : "; ") + line + (flags.empty() ? "" : " (" + flags + ")");
    first = false;
  }
  throw UsageError(message);
}

}  // namespace

void check_parameters(const StereoParams& params) {
  const std::string problems = params.validate();
  if (!problems.empty()) throw_invalid_parameters(problems, "invalid parameters: ");
}

void check_parameters(const StereoParams& params, int width, int height) {
  const std::string problems = params.validate(width, height);
  if (!problems.empty())
    throw_invalid_parameters(problems, "invalid parameters for the " + std::to_string(width) + "x" +
                                           std::to_string(height) + " image: ");
}

void refuse_empty_and_non_finite_numbers(CLI::App& app) {
  const CLI::Validator not_empty(
      [](std::string& text) -> std::string { return text.empty() ? "the value is empty" : ""; }, "");
  const CLI::Validator finite(
      [](std::string& text) -> std::string {
        double value = 0.0;
        const std::string problem = number_problem(text, value);
        return problem.empty() ? "" : "'" + text + "' " + problem;
      },
      "");
  for (CLI::Option* option : app.get_options()) {
    const std::string type = option->get_type_name();
    const bool integer = type.rfind("INT", 0) == 0 || type.rfind("UINT", 0) == 0;
    const bool floating = type.rfind("FLOAT", 0) == 0;
    if (floating) option->transform(finite);  // transform: before the option's own checks
    if (integer || floating) option->transform(not_empty);
  }
  for (CLI::App* subcommand : app.get_subcommands({})) refuse_empty_and_non_finite_numbers(*subcommand);
}

Json parameters_json(const StereoParams& p) {
  Json j = Json::object();
  j.set("min_disparity", p.min_disparity);
  j.set("num_disparities", p.num_disparities);
  j.set("census", to_string(p.census));
  j.set("census_window", p.census_window);
  j.set("mct_kernel", to_string(p.mct_kernel));
  j.set("shd_window", p.shd_window);
  j.set("coarse_shd_window", p.coarse_shd_window);
  j.set("pyramid_levels", p.pyramid_levels);
  j.set("search_radius", p.search_radius);
  j.set("subpixel", p.subpixel);
  j.set("median_size", p.median_size);
  j.set("lr_check", p.lr_check);
  j.set("lr_threshold", p.lr_threshold);
  j.set("speckle_size", p.speckle_size);
  j.set("uniqueness_ratio", p.uniqueness_ratio);
  j.set("fill", to_string(p.fill));
  j.set("post_median_size", p.post_median_size);
  j.set("refine_all_levels", p.refine_all_levels);
  j.set("lr_check_grid", p.lr_check_grid);
  j.set("working_scale", p.working_scale);
  j.set("aggregation", to_string(p.aggregation));
  j.set("sgm_p1", p.sgm_p1);
  j.set("sgm_p2", p.sgm_p2);
  j.set("sgm_p2_k", p.sgm_p2_k);
  j.set("prior_size", p.prior_size);
  j.set("box_levels", p.box_levels);
  j.set("finest_search_radius", p.finest_search_radius);
  j.set("sgm_max_band", p.sgm_max_band);
  j.set("weighted_median", p.weighted_median);
  j.set("wm_radius", p.wm_radius);
  j.set("wm_step", p.wm_step);
  j.set("wm_sigma", p.wm_sigma);
  return j;
}

}  // namespace mctstereo::app
