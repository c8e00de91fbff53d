// The driver: builds the pyramid and runs the stage list coarse to fine. Reads like the recipe of
// docs/PIPELINE.md; every stage lives in src/<backend>/<stage>.cpp.
#include "mctstereo/matcher.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <thread>
#include <utility>

#include "cpu/load_policy.hpp"
#include "cpu/parallel.hpp"
#include "cpu/sgm_segments.hpp"
#include "level_plan.hpp"
#include "stages.hpp"
#include "stopwatch.hpp"
#ifdef MCTSTEREO_HAVE_OPENCL
#include "opencl/pipeline.hpp"
#endif

namespace mctstereo {

using detail::CensusCodes;
using detail::kInvalid;
using detail::Plane;
using detail::Stopwatch;

namespace {

// The threads of MatcherOptions::threads = 0: OpenMP's count (OMP_NUM_THREADS, else the cores the
// process may use), but no more than the machine's hardware threads. More only share the same
// cores, and OMP_NUM_THREADS=100000 would start that many threads, with scratch for each, and crash.
int default_threads() {
  const int hardware = static_cast<int>(std::thread::hardware_concurrency());  // 0: unknown
  const int openmp = omp_get_max_threads();
  return std::max(1, hardware > 0 ? std::min(openmp, hardware) : openmp);
}

// The stage list of one backend as a table, so that the recipe below is written once.
struct StageTable {
  decltype(&detail::reference::to_gray) to_gray;
  decltype(&detail::reference::pyramid_down) pyramid_down;
  decltype(&detail::reference::census_transform) census_transform;
  decltype(&detail::reference::census_match) census_match;
  decltype(&detail::reference::census_match_scratch_bytes) census_match_scratch_bytes;
  decltype(&detail::reference::median_filter) median_filter;
  decltype(&detail::reference::lr_check) lr_check;
  decltype(&detail::reference::remove_speckles) remove_speckles;
  decltype(&detail::reference::speckle_label_width) speckle_label_width;
  decltype(&detail::reference::fill_invalid) fill_invalid;
  decltype(&detail::reference::grid_partner) grid_partner;
  decltype(&detail::reference::grid_partner_scratch_bytes) grid_partner_scratch_bytes;
  decltype(&detail::reference::refine_left_map) refine_left_map;
  decltype(&detail::reference::refine_left_map_scratch_bytes) refine_left_map_scratch_bytes;
  decltype(&detail::reference::output_q4) output_q4;
  decltype(&detail::reference::upscale) upscale;
  decltype(&detail::reference::sgm_costs) sgm_costs;
  decltype(&detail::reference::sgm_aggregate) sgm_aggregate;
  decltype(&detail::reference::sgm_scratch_bytes) sgm_scratch_bytes;
  decltype(&detail::reference::sgm_select) sgm_select;
  decltype(&detail::reference::confidence) confidence;
  decltype(&detail::reference::split_channels) split_channels;
  decltype(&detail::reference::weighted_median) weighted_median;
};

#define MCTSTEREO_STAGE_TABLE(ns)                                                                \
  StageTable {                                                                                   \
    &ns::to_gray, &ns::pyramid_down, &ns::census_transform, &ns::census_match,                   \
        &ns::census_match_scratch_bytes, &ns::median_filter, &ns::lr_check, &ns::remove_speckles, \
        &ns::speckle_label_width, &ns::fill_invalid, &ns::grid_partner,                           \
        &ns::grid_partner_scratch_bytes, &ns::refine_left_map,                                    \
        &ns::refine_left_map_scratch_bytes, &ns::output_q4, &ns::upscale, &ns::sgm_costs,         \
        &ns::sgm_aggregate, &ns::sgm_scratch_bytes, &ns::sgm_select, &ns::confidence,             \
        &ns::split_channels, &ns::weighted_median                                                 \
  }
const StageTable kReferenceStages = MCTSTEREO_STAGE_TABLE(detail::reference);
const StageTable kCpuStages = MCTSTEREO_STAGE_TABLE(detail::cpu);
#undef MCTSTEREO_STAGE_TABLE

// Whole planes of census codes at a level: band SGM's costs read them, and the reference
// backend's census_match makes its codes in them. The cpu backend's census_match makes the codes
// of a box level strip by strip in its scratch and needs none.
bool whole_code_planes(const detail::LevelSpec& level, Backend backend) {
  return level.is_sgm || backend == Backend::Reference;
}

// Whether refine() runs the finest level's stages in one, refine_left_map(): the left map alone
// is kept (no right map asked for, none kept for the temporal prior) and nothing between the LR
// check and the end needs whole maps (speckle removal, the confidence, the weighted median), and
// every level matches with box sums (the stage borrows their scratch; band SGM makes the confidence).
bool refines_left_map_at_once(const StereoParams& p, const MatcherOptions& o) {
  return p.lr_check && !o.compute_right && !o.compute_confidence && !p.sgm() && !p.temporal &&
         p.speckle_size <= 1 && !p.weighted_median;
}

// Bytes per thread of the scratch that census_match() (box levels), refine_left_map() and
// grid_partner() share: they run one after the other.
template <class Stages>
std::size_t match_scratch_bytes(const StereoParams& p, const MatcherOptions& o, const detail::LevelPlan& plan,
                                const Stages& stages) {
  const int w0 = plan.finest().width;
  std::size_t bytes = 0;
  if (plan.box_range > 0)
    bytes = stages.census_match_scratch_bytes(w0, plan.box_range, std::max(p.shd_window, p.coarse_shd_window),
                                              plan.census_words);
  if (plan.box_range > 0 && refines_left_map_at_once(p, o)) bytes = std::max(bytes, stages.refine_left_map_scratch_bytes(w0));
  if (p.lr_check_on_grid()) bytes = std::max(bytes, stages.grid_partner_scratch_bytes(w0));
  return bytes;
}

// Row states of band SGM on the cpu backend with `threads` threads: the checkpoints of levels in
// segments, or the two sweeps' states of whole volumes on 2 threads, whichever takes more.
std::size_t sgm_row_state_bytes(const detail::LevelPlan& plan, const StereoParams& p, int threads) {
  std::size_t bytes = plan.sgm_row_state_bytes;
  if (plan.sgm_levels > 0 && detail::cpu::sgm_two_sweeps_for(p.sgm_paths(), threads))
    bytes = std::max(bytes, detail::cpu::sgm_sweep_state_bytes(plan.finest_sgm().width, plan.sgm_max_stride));
  return bytes;
}

// Everything one pyramid level holds for both views; its plan (sizes, range, windows, band)
// comes from plan_levels().
struct Level : detail::LevelSpec {
  Plane<std::uint8_t> image[2];
  CensusCodes codes[2];
  Plane<std::int16_t> disparity[2], scratch[2];
  // The temporal prior: this level's maps and images of the previous frame.
  Plane<std::int16_t> previous[2];
  Plane<std::uint8_t> previous_image[2];
  detail::SgmVolume sgm;  // band SGM: candidates, costs and sums (storage shared by the levels)
};

// "wmedian" is the colour-weighted median with its 3x3 median (0 without them), apart from the
// rest of the refinement.
enum StageSlot { kGray, kPyramid, kCensus, kMatch, kRefine, kWeightedMedian, kOutput, kFrame, kSlotCount };
constexpr const char* kSlotNames[kSlotCount] = {"gray",    "pyramid", "census", "match",
                                                "refine",  "wmedian", "output", "frame"};

}  // namespace

struct Matcher::Impl {
  int width, height;
  StereoParams params;
  Backend backend;
  MatcherOptions options;
  const StageTable* stages;
  int threads = 1;
  int host_threads() const { return backend == Backend::Cpu ? threads : 1; }
  bool need_right = false;
  bool want_confidence = false;  // band SGM always, box aggregation when the options ask for it
  std::string notice;  // how Backend::Auto fell back, if it did
#ifdef MCTSTEREO_HAVE_OPENCL
  std::unique_ptr<detail::opencl::Pipeline> device;  // the opencl backend's driver and buffers
#endif
  // The float map is made when disparity() asks for it, from the last frame's map: most callers
  // take one of the two forms, and the conversion is a full pass over W x H (5 % of a realtime
  // frame at 640 x 480).
  bool float_current = true;                         // out_float holds the last frame's map
  const Plane<std::int16_t>* float_source = nullptr;  // host backends: the last frame's internal map

  std::vector<Plane<std::uint8_t>> full_gray[2];  // input size, then each working-scale reduction
  std::vector<Level> levels;                      // levels[0] is the finest (working scale)
  // Colour-weighted median: the left view's channels at the input size, then each working-scale
  // reduction (colour input; gray input uses full_gray), its weight table, and what the last frame
  // gave it.
  std::vector<std::array<Plane<std::uint8_t>, 3>> full_colour;
  detail::WeightedMedianConfig wm_config;
  detail::ColourPlanes wm_colour;
  detail::MatchScratch match_scratch;
  detail::SpeckleScratch speckle_scratch;
  // Band SGM: the cost and sum storage every level's volume uses and the scratch of its stages.
  std::unique_ptr<std::uint8_t[], detail::FreeDeleter> sgm_cost;
  std::unique_ptr<std::uint16_t[], detail::FreeDeleter> sgm_sum;
  std::unique_ptr<std::uint16_t[], detail::FreeDeleter> sgm_row_states;  // in segments or two sweeps
  detail::SgmScratch sgm_scratch;
  // The winner margins of the level the confidence takes them from (the plan's margin_level: the
  // finest, or the finest SGM level under box levels), the finest level's confidence, and the
  // confidence at the output size.
  int margin_level = 0;
  Plane<std::uint8_t> margin, confidence_q8;
  Plane<float> out_confidence;
  bool confidence_current = false;  // out_confidence holds the last frame's
  bool confidence_q8_current = false;  // confidence_q8 does (the opencl backend: downloaded)
  bool has_frame = false;  // compute() has run
  // The temporal prior: the levels' maps of the last frame can serve the next one (none after
  // construction and reset_temporal()), and the last frame was matched with them.
  bool temporal_history = false;
  bool used_previous = false;
  Plane<std::int16_t> upscaled[2];
  Plane<std::int16_t> out_q4[2];
  Plane<float> out_float;
  std::vector<StageTime> timings;
  double slot_ms[kSlotCount] = {};
  std::unique_ptr<detail::cpu::WorkerPool> pool;  // cpu backend with more than one thread
  Plane<std::int16_t> grid_partners;               // the left map's partners beside the right map
  detail::cpu::LoadPolicy load_policy;             // MatcherOptions::adapt_threads
  long frames_alone = 0;                           // frames the pool's matcher ran on one thread
  bool single_threaded = false;                    // Matcher::set_single_threaded

  Impl(int w, int h, const StereoParams& p, Backend b, const MatcherOptions& o)
      : width(w), height(h), params(p), backend(b), options(o) {
    const std::string err = p.validate(w, h);
    if (!err.empty()) throw std::invalid_argument(err);
    if (o.threads < 0) throw std::invalid_argument("threads = " + std::to_string(o.threads) + " must be >= 0");
    resolve_backend();
    stages = backend == Backend::Reference ? &kReferenceStages : &kCpuStages;
    threads = backend == Backend::Reference ? 1 : (o.threads > 0 ? o.threads : default_threads());
    if (backend == Backend::Cpu && threads > 1) {
      pool = std::make_unique<detail::cpu::WorkerPool>(threads);
      threads = pool->size();  // fewer when the system could not start them all
    }
    need_right = p.lr_check || o.compute_right;
    want_confidence = p.sgm() || o.compute_confidence;
    if (backend == Backend::OpenCL) {
      // The device holds the pyramid; the host keeps only the maps the caller reads.
      for (int v = 0; v < (o.compute_right ? 2 : 1); ++v) out_q4[v].reset(w, h);
      out_float.reset(w, h);
      if (want_confidence) {
        // The confidence comes down at the working scale and is replicated here.
        int cw = w, ch = h;
        for (int s = 1; s < p.working_scale; s *= 2) cw = (cw + 1) / 2, ch = (ch + 1) / 2;
        confidence_q8.reset(cw, ch);
        out_confidence.reset(w, h);
      }
      return;
    }

    const detail::LevelPlan plan =
        detail::plan_levels(p, w, h, need_right, backend == Backend::Cpu ? o.sgm_volume_limit : SIZE_MAX);
    // Working-scale reductions of the input: full_gray[v][0] is the input size.
    for (int v = 0; v < 2; ++v)
      for (const detail::Size2& s : plan.working) full_gray[v].emplace_back(s.width, s.height);
    if (p.weighted_median) {
      full_colour.resize(plan.working.size());
      for (std::size_t s = 0; s < plan.working.size(); ++s)
        for (auto& channel : full_colour[s]) channel.reset(plan.working[s].width, plan.working[s].height);
      wm_config.radius = p.wm_radius;
      wm_config.step = p.wm_step;
      wm_config.lut = detail::weighted_median_lut(p.wm_sigma);
    }
    for (const detail::LevelSpec& spec : plan.levels) {
      Level& L = levels.emplace_back();
      static_cast<detail::LevelSpec&>(L) = spec;
      const int lw = L.width, lh = L.height;
      for (int v = 0; v < 2; ++v) {
        // Level 0 of the pyramid is the last working-scale reduction itself.
        if (levels.size() > 1) L.image[v].reset(lw, lh);
        L.codes[v].words = plan.census_words;
        if (whole_code_planes(L, backend))
          for (int k = 0; k < L.codes[v].words; ++k) L.codes[v].plane[k].reset(lw, lh, detail::kCodePad);
      }
      // The maps a level makes, and the scratch maps of its refinement.
      for (int v = 0; v < (L.right_map ? 2 : 1); ++v) {
        L.disparity[v].reset(lw, lh);
        if (L.refine) L.scratch[v].reset(lw, lh);
      }
      for (int v = 0; v < L.temporal_views(); ++v) {
        L.previous[v].reset(lw, lh);
        L.previous_image[v].reset(lw, lh);
      }
      if (L.is_sgm) L.sgm.reset(lw, lh, L.sgm_band, plan.census_words, nullptr, nullptr, L.sgm_mirror_rows());
    }
    const int scale_steps = static_cast<int>(plan.working.size()) - 1;
    if (plan.sgm_levels > 0) {
      // One storage of costs for every level, bytes or 16-bit entries as each level's costs need.
      sgm_cost = detail::allocate_aligned<std::uint8_t>(plan.sgm_cost_bytes);
      sgm_sum = detail::allocate_aligned<std::uint16_t>(plan.sgm_entries);
      if (const std::size_t bytes = sgm_row_state_bytes(plan, params, host_threads()); bytes > 0)
        sgm_row_states = detail::allocate_aligned<std::uint16_t>(bytes / sizeof(std::uint16_t));
      for (Level& L : levels) {
        if (!L.is_sgm) continue;
        if (L.sgm_byte_costs)
          L.sgm.use_byte_costs(sgm_cost.get());
        else
          L.sgm.cost = reinterpret_cast<std::uint16_t*>(sgm_cost.get());
        L.sgm.sum = sgm_sum.get();
      }
      sgm_scratch.threads = threads;
      sgm_scratch.bytes_per_thread =
          (stages->sgm_scratch_bytes(plan.finest_sgm().width, plan.finest_sgm().height, plan.sgm_max_stride) + 63) /
          64 * 64;
      sgm_scratch.data = detail::allocate_aligned<std::uint8_t>(sgm_scratch.bytes_per_thread * threads);
    }
    if (want_confidence) {
      margin_level = plan.margin_level();
      margin.reset(levels[margin_level].width, levels[margin_level].height);
      confidence_q8.reset(levels[0].width, levels[0].height);
      out_confidence.reset(w, h);
    }
    if (const std::size_t bytes = match_scratch_bytes(p, o, plan, *stages); bytes > 0) {
      match_scratch.threads = threads;
      match_scratch.bytes_per_thread = (bytes + 63) / 64 * 64;
      match_scratch.data = detail::allocate_aligned<std::uint8_t>(match_scratch.bytes_per_thread * threads);
    }
    if (p.lr_check_on_grid() && o.compute_right) grid_partners.reset(levels[0].width, levels[0].height);
    if (p.speckle_size > 0) {
      speckle_scratch.label.reset(stages->speckle_label_width(levels[0].width), levels[0].height);
      speckle_scratch.stack =
          detail::allocate_aligned<std::int32_t>(static_cast<std::size_t>(levels[0].width) * levels[0].height);
    }
    for (int v = 0; v < (o.compute_right ? 2 : 1); ++v) {
      if (scale_steps > 0) upscaled[v].reset(w, h);
      out_q4[v].reset(w, h);
    }
    out_float.reset(w, h);
    timings.reserve(kSlotCount);
  }

  // Backend::OpenCL opens its device (errors propagate); Backend::Auto takes an OpenCL GPU (or
  // the device options.device names) when one is there and works, else the cpu backend with a
  // notice.
  void resolve_backend() {
#ifdef MCTSTEREO_HAVE_OPENCL
    namespace ocl = detail::opencl;
    if (backend == Backend::OpenCL) {
      device = std::make_unique<ocl::Pipeline>(ocl::choose_device(options.device), width, height, params, options);
    } else if (backend == Backend::Auto) {
      backend = Backend::Cpu;
      std::optional<ocl::DeviceInfo> chosen;
      if (options.device.empty()) {
        for (const ocl::DeviceInfo& d : ocl::list_devices())
          if (d.gpu) {
            chosen = d;
            break;
          }
        if (!chosen) notice = "no OpenCL GPU found: running on the cpu backend";
      } else {
        try {
          chosen = ocl::choose_device(options.device);
        } catch (const std::runtime_error&) {
          notice = "no OpenCL device matches '" + options.device + "': running on the cpu backend";
        }
      }
      if (chosen) {
        try {
          device = std::make_unique<ocl::Pipeline>(*chosen, width, height, params, options);
          backend = Backend::OpenCL;
        } catch (const std::runtime_error& e) {
          // A build log runs over many lines: the notice keeps the first.
          const std::string what = e.what();
          notice = "OpenCL device " + chosen->name + " failed (" + what.substr(0, what.find('\n')) +
                   "): running on the cpu backend";
        }
      }
    }
#else
    if (backend == Backend::OpenCL)
      throw std::invalid_argument(
          "this build has no opencl backend (it was built without OpenCL: install the OpenCL headers and ICD "
          "loader, e.g. ocl-icd-opencl-dev opencl-clhpp-headers, and rebuild)");
    if (backend == Backend::Auto) {
      backend = Backend::Cpu;
      notice = "this build has no opencl backend: running on the cpu backend";
    }
#endif
  }

  const Plane<std::uint8_t>& level_image(int l, int v) const {
    return l == 0 ? full_gray[v].back() : levels[l].image[v];
  }

  static void copy_map(const Plane<std::int16_t>& src, Plane<std::int16_t>& dst) {
    detail::cpu::parallel_lines(src.height(), [&](int y0, int y1) {
      for (int y = y0; y < y1; ++y) std::copy_n(src.row(y), src.width(), dst.row(y));
    });
  }

  // Host backends: whether the confidence pass waits for confidence() (a frame of balanced spends
  // some 4 % on it). It reads the finest maps as the checks left them, before the fill guesses: the
  // left map is copied into the right view's scratch map, which the frame no longer uses after the
  // LR check, and the right map stays as it is, since only the left map is refined further. With
  // compute_right the frame refines the right map too, and without the LR check there is no spare
  // map: then the frame makes the confidence itself.
  bool lazy_confidence() const {
    return need_right && !options.compute_right && levels[0].scratch[1].width() == levels[0].width;
  }

  // Refines the maps of one level. At the finest level the right map only serves the left map's
  // LR check, so unless the caller asked for it, its refinement stops there.
  void refine(Level& L, bool finest) {
    if (finest && refines_left_map_at_once(params, options)) {
      const detail::LeftMapRefinement config{params.median_size, 16 * params.lr_threshold, params.fill,
                                             params.post_median_size, params.lr_check_on_grid()};
      stages->refine_left_map(L.disparity[0], L.disparity[1], config, match_scratch, L.scratch[1], L.scratch[0]);
      std::swap(L.disparity[0], L.scratch[0]);
      return;
    }
    const int views = need_right ? 2 : 1;
    const int kept = finest && !options.compute_right ? 1 : views;
    // With the LR check on the grid (StereoParams::lr_check_grid) the left map's partners come from
    // the raw right map: in its place when it serves nothing else (then it needs no median), else
    // beside it. The confidence then reads the partners too.
    const bool grid = finest && params.lr_check_on_grid();
    int median_views = views;
    if (grid) {
      if (options.compute_right) {
        stages->grid_partner(L.disparity[1], params.median_size, match_scratch, grid_partners);
      } else {
        stages->grid_partner(L.disparity[1], params.median_size, match_scratch, L.scratch[1]);
        std::swap(L.disparity[1], L.scratch[1]);
        median_views = 1;
      }
    }
    const Plane<std::int16_t>& right_of_left = grid && options.compute_right ? grid_partners : L.disparity[1];
    if (params.median_size > 0) {
      for (int v = 0; v < median_views; ++v) {
        stages->median_filter(L.disparity[v], params.median_size, L.scratch[v]);
        std::swap(L.disparity[v], L.scratch[v]);
      }
    }
    if (params.lr_check) {
      // Both checks read the maps as they were before either was checked.
      for (int v = 0; v < kept; ++v)
        stages->lr_check(L.disparity[v], v == 0 ? right_of_left : L.disparity[0], v == 0 ? -1 : +1,
                         16 * params.lr_threshold, L.scratch[v]);
      for (int v = 0; v < kept; ++v) std::swap(L.disparity[v], L.scratch[v]);
    }
    if (L.speckle > 1)
      for (int v = 0; v < kept; ++v) stages->remove_speckles(L.disparity[v], L.speckle, 16, speckle_scratch);
    // The confidence of the final map takes what survived the checks, before the fill guesses.
    if (finest && want_confidence) {
      if (lazy_confidence()) {
        copy_map(L.disparity[0], L.scratch[1]);
      } else {
        stages->confidence(margin, margin_level, L.disparity[0], need_right ? &right_of_left : nullptr,
                           params.lr_threshold, confidence_q8);
        confidence_q8_current = true;
      }
    }
    for (int v = 0; v < kept; ++v) stages->fill_invalid(L.disparity[v], params.fill);
    // The colour-weighted median and its 3x3 median take the place of the post-fill median in the
    // left map of the finest level.
    int first_post = 0;
    if (finest && params.weighted_median) {
      Stopwatch clock;
      stages->weighted_median(L.disparity[0], wm_colour, wm_config, L.scratch[0]);
      stages->median_filter(L.scratch[0], 3, L.disparity[0]);
      first_post = 1;
      slot_ms[kWeightedMedian] += clock.lap_ms();
    }
    if (params.post_median_size > 0) {
      for (int v = first_post; v < kept; ++v) {
        stages->median_filter(L.disparity[v], params.post_median_size, L.scratch[v]);
        std::swap(L.disparity[v], L.scratch[v]);
      }
    }
  }

  // refine() of a level that refines, timed: the weighted median's share goes to its own slot.
  void refine_level(Level& L, bool finest, Stopwatch& clock) {
    const double wm_before = slot_ms[kWeightedMedian];
    if (L.refine) refine(L, finest);
    slot_ms[kRefine] += clock.lap_ms() - (slot_ms[kWeightedMedian] - wm_before);
  }

  // Band SGM at level l: band costs around the coarser left map, paths, winners of both views.
  void match_sgm(int l, const Plane<std::int16_t>* prior) {
    Level& L = levels[l];
    const detail::SgmBandConfig band{L.dmin, L.dmax, L.radius, params.prior_size, L.sgm.band, temporal_prior(l, 0)};
    const detail::SgmPathConfig paths{params.sgm_paths(), params.sgm_p1, params.sgm_p2, params.sgm_p2_k};
    const detail::SgmSelectConfig select{params.subpixel && l == 0, params.uniqueness_ratio};
    Plane<std::int16_t>* right = L.right_map ? &L.disparity[1] : nullptr;
    Plane<std::uint8_t>* level_margin = l == margin_level ? &margin : nullptr;
    if (L.sgm_segment_rows > 0) {
      const detail::cpu::SgmSegmentJob job{&L.codes[0], &L.codes[1], prior, band, L.shd_window, &level_image(l, 0),
                                           paths, select, L.sgm_segment_rows, sgm_row_states.get(),
                                           &L.disparity[0], right, level_margin};
      detail::cpu::sgm_segmented(job, sgm_scratch, L.sgm);
      return;
    }
    if (detail::cpu::sgm_two_sweeps_for(paths.paths, detail::cpu::stage_threads()) &&
        detail::sgm_volume_bytes(L, L.height) <= detail::cpu::kSweepVolumeLimit) {
      const detail::cpu::SgmSegmentJob job{&L.codes[0], &L.codes[1], prior, band, L.shd_window, &level_image(l, 0),
                                           paths, select, detail::cpu::kSweepRows, sgm_row_states.get(),
                                           &L.disparity[0], right, level_margin};
      detail::cpu::sgm_two_sweeps(job, sgm_scratch, L.sgm);
      return;
    }
    stages->sgm_costs(L.codes[0], L.codes[1], prior, band, L.shd_window, sgm_scratch, L.sgm);
    stages->sgm_aggregate(level_image(l, 0), paths, sgm_scratch, L.sgm);
    stages->sgm_select(L.sgm, select, sgm_scratch, L.disparity[0], right, level_margin);
  }

  // The last frame's confidence at the working scale (lazy_confidence()), from the maps refine()
  // left for it.
  void compute_confidence_q8() {
    const detail::cpu::PoolScope scope(pool.get());
    const Level& L = levels[0];
    stages->confidence(margin, margin_level, L.scratch[1], &L.disparity[1], params.lr_threshold, confidence_q8);
    confidence_q8_current = true;
  }

  // The confidence at the output size (pixels of the working scale replicated s x s).
  void write_confidence() {
    const detail::cpu::PoolScope scope(pool.get());
    const int s = params.working_scale;
    detail::cpu::parallel_lines(
        height,
        [&](int y0, int y1) {
          for (int y = y0; y < y1; ++y) {
            const std::uint8_t* src = confidence_q8.row(std::min(y / s, confidence_q8.height() - 1));
            float* dst = out_confidence.row(y);
            for (int x = 0; x < width; ++x) dst[x] = src[std::min(x / s, confidence_q8.width() - 1)] * (1.0f / 255.0f);
          }
        },
        host_threads());
    confidence_current = true;
  }

  // Internal maps (kInvalid) to the caller's conventions: Q4 with (dmin - 1) * 16, float with NaN.
  void write_outputs(const Plane<std::int16_t>& result, int v) {
    stages->output_q4(result, invalid_q4(), out_q4[v]);
    if (v == 0) {
      float_source = &result;
      float_current = false;
    }
  }

  void write_float() {
    const detail::cpu::PoolScope scope(pool.get());
    detail::cpu::parallel_lines(
        height,
        [&](int y0, int y1) {
          for (int y = y0; y < y1; ++y) {
            const std::int16_t* src = float_source->row(y);
            float* f = out_float.row(y);
            for (int x = 0; x < width; ++x)
              f[x] = src[x] == kInvalid ? NAN : static_cast<float>(src[x]) * (1.0f / kDisparityScale);
          }
        },
        host_threads());
    float_current = true;
  }

  void compute(const ImageView& left, const ImageView& right) {
    const ImageView* input[2] = {&left, &right};
    for (int v = 0; v < 2; ++v) {
      const ImageView& in = *input[v];
      const char* name = v == 0 ? "left" : "right";
      if (in.data == nullptr) throw std::invalid_argument(std::string(name) + " image has no pixels (null data)");
      if (in.width != width || in.height != height)
        throw std::invalid_argument(std::string(name) + " image is " + std::to_string(in.width) + " x " +
                                    std::to_string(in.height) + ", the matcher was configured for " +
                                    std::to_string(width) + " x " + std::to_string(height));
      if (in.stride < static_cast<std::ptrdiff_t>(in.width) * bytes_per_pixel(in.format))
        throw std::invalid_argument(std::string(name) + " image stride " + std::to_string(in.stride) +
                                    " is shorter than a row");
    }
    // The stages' parallel regions take the calling thread's OpenMP thread count: set it for this
    // frame and give the caller's setting back afterwards.
    const int caller_threads = omp_get_max_threads();
    struct RestoreThreads {
      int n;
      ~RestoreThreads() { omp_set_num_threads(n); }
    } restore{caller_threads};
    omp_set_num_threads(backend == Backend::Reference ? 1 : threads);
#ifdef MCTSTEREO_HAVE_OPENCL
    if (device) {
      float_current = false;
      confidence_current = confidence_q8_current = false;
      device->compute(left, right, out_q4);
      has_frame = true;
      return;
    }
#endif
    if (!pool) {
      // A matcher of one thread: its stages run on the caller's thread.
      const detail::cpu::SerialScope alone;
      run_frame(left, right);
      return;
    }
    if (single_threaded) {
      const detail::cpu::SerialScope alone;
      run_frame(left, right);
      ++frames_alone;
      return;
    }
    const bool on_threads = !options.adapt_threads || load_policy.use_threads();
    if (on_threads) {
      // The stages hand their chunks to the matcher's threads (src/cpu/parallel.hpp).
      const detail::cpu::PoolScope scope(pool.get());
      run_frame(left, right);
    } else {
      // On the calling thread alone: faster of late (a loaded CPU), or a trial (LoadPolicy).
      const detail::cpu::SerialScope alone;
      run_frame(left, right);
      ++frames_alone;
    }
    if (options.adapt_threads) load_policy.record(on_threads, slot_ms[kFrame]);  // run_frame's own time
  }

  // The search of view v at box level l: around its own coarser map, and with the temporal prior
  // around its map of the previous frame too.
  detail::SearchRanges search_ranges(int l, int v) const {
    const Level& L = levels[l];
    const Plane<std::int16_t>* prior = L.coarsest ? nullptr : &levels[l + 1].disparity[v];
    detail::SearchRanges ranges = detail::SearchRanges::around(prior, L.dmin, L.dmax, L.radius);
    ranges.temporal = temporal_prior(l, v);
    return ranges;
  }

  // The temporal prior of view v at level l: none unless this frame has the last one's maps.
  detail::TemporalPrior temporal_prior(int l, int v) const {
    const Level& L = levels[l];
    if (!used_previous || v >= L.temporal_views()) return {};
    return {&L.previous[v], &level_image(l, v), &L.previous_image[v], params.temporal_radius,
            params.temporal_threshold};
  }

  // The temporal prior: the last frame's maps and images of the levels it narrows become this
  // frame's previous ones (swaps: the planes this frame writes next held the frame before).
  void take_previous_maps() {
    used_previous = params.temporal && temporal_history;
    if (used_previous)
      detail::swap_in_previous_maps(levels, [&](int v) -> Plane<std::uint8_t>& { return full_gray[v].back(); });
  }

  // Whether view v of level l is matched at its even rows only: the right view at the finest level
  // when the LR check reads it on its grid (grid_partner()) and nothing else reads it.
  bool matches_even_rows_only(int l, int v) const {
    return l == 0 && v == 1 && params.lr_check_on_grid() && !options.compute_right;
  }

  // Census and local matching of level l: each view searches around its own coarser map.
  detail::CensusMatchJob census_match_job(int l, const detail::CensusConfig& census, int views) {
    Level& L = levels[l];
    detail::CensusMatchJob job;
    job.census = census;
    job.views = views;
    job.codes = L.codes;
    for (int v = 0; v < 2; ++v) {
      job.image[v] = &level_image(l, v);
      if (v >= views) continue;
      job.ranges[v] = search_ranges(l, v);
      job.config[v] = {v == 0 ? -1 : +1, L.shd_window, params.subpixel && l == 0, params.uniqueness_ratio,
                       matches_even_rows_only(l, v)};
      job.disparity[v] = &L.disparity[v];
    }
    job.margin = l == 0 && want_confidence && margin_level == 0 ? &margin : nullptr;
    return job;
  }

  // The recipe of one frame on the host backends (reference, cpu).
  void run_frame(const ImageView& left, const ImageView& right) {
    const ImageView* input[2] = {&left, &right};
    for (double& t : slot_ms) t = 0;
    confidence_current = confidence_q8_current = false;
    Stopwatch frame, clock;
    take_previous_maps();

    for (int v = 0; v < 2; ++v) stages->to_gray(*input[v], full_gray[v][0]);
    // The weighted median's colour: the left view's channels (gray input: the gray plane itself).
    const bool colour = params.weighted_median && left.format != PixelFormat::Gray8;
    if (colour) stages->split_channels(left, full_colour[0]);
    slot_ms[kGray] += clock.lap_ms();
    for (int v = 0; v < 2; ++v) {
      for (std::size_t s = 1; s < full_gray[v].size(); ++s) stages->pyramid_down(full_gray[v][s - 1], full_gray[v][s]);
      for (std::size_t l = 1; l < levels.size(); ++l) stages->pyramid_down(level_image(l - 1, v), levels[l].image[v]);
    }
    if (colour)
      for (std::size_t s = 1; s < full_colour.size(); ++s)
        for (int c = 0; c < 3; ++c) stages->pyramid_down(full_colour[s - 1][c], full_colour[s][c]);
    if (params.weighted_median) {
      wm_colour.channels = colour ? 3 : 1;
      for (int c = 0; c < 3; ++c) wm_colour.plane[c] = colour ? &full_colour.back()[c] : &full_gray[0].back();
    }
    slot_ms[kPyramid] += clock.lap_ms();

    const detail::CensusConfig census{params.census, params.census_window, params.mct_kernel};
    for (int l = static_cast<int>(levels.size()) - 1; l >= 0; --l) {
      Level& L = levels[l];
      if (L.is_sgm) {
        for (int v = 0; v < 2; ++v) stages->census_transform(level_image(l, v), census, L.codes[v]);
        slot_ms[kCensus] += clock.lap_ms();
        match_sgm(l, L.coarsest ? nullptr : &levels[l + 1].disparity[0]);
      } else {
        // The codes are made inside the stage (strip by strip on the cpu backend): its time is
        // the match stage's.
        stages->census_match(census_match_job(l, census, L.right_map ? 2 : 1), match_scratch);
      }
      slot_ms[kMatch] += clock.lap_ms();
      refine_level(levels[l], l == 0, clock);
    }

    const int scale = params.working_scale;
    for (int v = 0; v < (options.compute_right ? 2 : 1); ++v) {
      const Plane<std::int16_t>* result = &levels[0].disparity[v];
      if (scale > 1) {
        stages->upscale(*result, scale, 16 * params.min_disparity, 16 * params.max_disparity(), upscaled[v]);
        result = &upscaled[v];
      }
      write_outputs(*result, v);
    }
    slot_ms[kOutput] += clock.lap_ms();
    slot_ms[kFrame] = frame.lap_ms();
    timings.clear();
    for (int s = 0; s < kSlotCount; ++s) timings.push_back({kSlotNames[s], slot_ms[s]});
    has_frame = true;
    temporal_history = params.temporal;
  }

  std::int16_t invalid_q4() const { return static_cast<std::int16_t>((params.min_disparity - 1) * kDisparityScale); }

  // The candidates of each level's matching: the band SGM volume's counts, or the search range
  // that match() derives from the coarser level's map of the same view (which no later level
  // overwrites).
  std::vector<LevelWork> level_work() const {
    std::vector<LevelWork> work;
    if (!has_frame || levels.empty()) return work;
    for (std::size_t l = 0; l < levels.size(); ++l) {
      const Level& L = levels[l];
      LevelWork& w = work.emplace_back();
      w.width = L.width;
      w.height = L.height;
      double total = 0.0;
      if (L.is_sgm) {
        w.views = 1;
        for (int y = 0; y < L.height; ++y)
          for (int x = 0; x < L.width; ++x) total += L.sgm.count.at(x, y);
      } else {
        w.views = L.right_map ? 2 : 1;
        for (int v = 0; v < w.views; ++v) {
          const detail::SearchRanges ranges = search_ranges(static_cast<int>(l), v);
          const int row_step = matches_even_rows_only(static_cast<int>(l), v) ? 2 : 1;
          for (int y = 0; y < L.height; y += row_step)
            for (int x = 0; x < L.width; ++x) {
              const detail::Interval r = ranges.at(x, y);
              total += std::max(r.hi - r.lo + 1, 0);
            }
        }
      }
      const double pixels = static_cast<double>(L.width) * L.height * w.views;
      w.candidates = pixels > 0 ? total / pixels : 0.0;
    }
    return work;
  }
};

Matcher::Matcher(int width, int height, const StereoParams& params, Backend backend, const MatcherOptions& options)
    : impl_(std::make_unique<Impl>(width, height, params, backend, options)) {}
Matcher::~Matcher() = default;
Matcher::Matcher(Matcher&&) noexcept = default;
Matcher& Matcher::operator=(Matcher&&) noexcept = default;

void Matcher::compute(const ImageView& left, const ImageView& right) { impl_->compute(left, right); }
void Matcher::reset_temporal() {
  impl_->temporal_history = false;
#ifdef MCTSTEREO_HAVE_OPENCL
  if (impl_->device) impl_->device->reset_temporal();
#endif
}
bool Matcher::used_temporal_prior() const {
#ifdef MCTSTEREO_HAVE_OPENCL
  if (impl_->device) return impl_->device->used_temporal_prior();
#endif
  return impl_->used_previous;
}

MapView<const std::int16_t> Matcher::disparity_q4() const {
  const auto& p = impl_->out_q4[0];
  return {p.row(0), p.width(), p.height(), p.stride()};
}
MapView<const float> Matcher::disparity() const {
#ifdef MCTSTEREO_HAVE_OPENCL
  // The opencl backend brings the float map down only when it is asked for.
  if (impl_->device && !impl_->float_current) {
    impl_->device->download_float(impl_->out_float);
    impl_->float_current = true;
  }
#endif
  if (!impl_->float_current && impl_->float_source != nullptr) impl_->write_float();
  const auto& p = impl_->out_float;
  return {p.row(0), p.width(), p.height(), p.stride()};
}
MapView<const float> Matcher::confidence() const {
  if (!impl_->want_confidence || !impl_->has_frame) return {};
#ifdef MCTSTEREO_HAVE_OPENCL
  // The opencl backend brings the confidence down only when it is asked for.
  if (impl_->device && !impl_->confidence_q8_current) {
    impl_->device->download_confidence(impl_->confidence_q8);
    impl_->confidence_q8_current = true;
  }
#endif
  if (!impl_->confidence_q8_current) impl_->compute_confidence_q8();
  if (!impl_->confidence_current) impl_->write_confidence();
  const auto& p = impl_->out_confidence;
  return {p.row(0), p.width(), p.height(), p.stride()};
}
MapView<const std::int16_t> Matcher::right_disparity_q4() const {
  if (!impl_->options.compute_right) return {};
  const auto& p = impl_->out_q4[1];
  return {p.row(0), p.width(), p.height(), p.stride()};
}
std::int16_t Matcher::invalid_q4() const { return impl_->invalid_q4(); }
int Matcher::width() const { return impl_->width; }
int Matcher::height() const { return impl_->height; }
const StereoParams& Matcher::params() const { return impl_->params; }
Backend Matcher::backend() const { return impl_->backend; }
std::string Matcher::notice() const { return impl_->notice; }
std::string Matcher::device_name() const {
#ifdef MCTSTEREO_HAVE_OPENCL
  if (impl_->device) return impl_->device->device_name();
#endif
  return {};
}
int Matcher::threads() const { return impl_->threads; }
long Matcher::frames_alone() const { return impl_->frames_alone; }
void Matcher::set_single_threaded(bool single) { impl_->single_threaded = single; }
bool Matcher::single_threaded() const { return impl_->single_threaded; }
std::string Matcher::simd_target() const {
  return impl_->backend == Backend::Reference ? "scalar" : detail::cpu::simd_target_name();
}
std::vector<LevelWork> Matcher::level_work() const { return impl_->level_work(); }
const std::vector<StageTime>& Matcher::timings() const {
#ifdef MCTSTEREO_HAVE_OPENCL
  if (impl_->device) return impl_->device->timings();
#endif
  return impl_->timings;
}

std::string_view to_string(Backend backend) {
  switch (backend) {
    case Backend::Reference: return "reference";
    case Backend::Cpu: return "cpu";
    case Backend::OpenCL: return "opencl";
    case Backend::Auto: return "auto";
  }
  return "unknown";
}

Backend parse_backend(std::string_view name) {
  for (Backend b : {Backend::Reference, Backend::Cpu, Backend::OpenCL, Backend::Auto})
    if (name == to_string(b)) return b;
  throw std::invalid_argument("unknown backend '" + std::string(name) + "' (known: reference, cpu, opencl, auto)");
}

bool have_opencl() {
#ifdef MCTSTEREO_HAVE_OPENCL
  return true;
#else
  return false;
#endif
}

std::vector<OpenclDevice> opencl_devices() {
#ifdef MCTSTEREO_HAVE_OPENCL
  return detail::opencl::describe_devices();
#else
  return {};
#endif
}

std::size_t estimate_memory(const StereoParams& params, int width, int height, const MatcherOptions& options) {
  // Mirrors the allocations of Matcher::Impl without making them.
  const std::string err = params.validate(width, height);
  if (!err.empty()) throw std::invalid_argument(err);
  const auto gray_bytes = [](int w, int h) { return Plane<std::uint8_t>::bytes_for(w, h); };
  const auto map_bytes = [](int w, int h) { return Plane<std::int16_t>::bytes_for(w, h); };
  const bool need_right = params.lr_check || options.compute_right;
  const detail::LevelPlan plan = detail::plan_levels(params, width, height, need_right, options.sgm_volume_limit);
  const int scale_steps = static_cast<int>(plan.working.size()) - 1;
  const int words = plan.census_words;
  std::size_t total = 0;
  // The input's reductions, with the left view's three channels when the weighted median runs.
  for (const detail::Size2& s : plan.working) total += (params.weighted_median ? 5 : 2) * gray_bytes(s.width, s.height);
  for (const detail::LevelSpec& L : plan.levels) {
    if (L.scale_log2 > scale_steps) total += 2 * gray_bytes(L.width, L.height);
    if (whole_code_planes(L, Backend::Cpu))
      total += 2 * words * Plane<std::uint32_t>::bytes_for(L.width, L.height, detail::kCodePad);
    total += ((L.right_map ? 2 : 1) * (L.refine ? 2 : 1) + L.temporal_views()) * map_bytes(L.width, L.height) +
             L.temporal_views() * gray_bytes(L.width, L.height);
    if (L.is_sgm) total += detail::SgmVolume::plane_bytes_for(L.width, L.height, L.sgm_band, words, L.sgm_mirror_rows());
  }
  const int w0 = plan.finest().width, h0 = plan.finest().height;
  const int threads = options.threads > 0 ? options.threads : default_threads();
  struct CpuStages {
    decltype(&detail::cpu::census_match_scratch_bytes) census_match_scratch_bytes = &detail::cpu::census_match_scratch_bytes;
    decltype(&detail::cpu::refine_left_map_scratch_bytes) refine_left_map_scratch_bytes =
        &detail::cpu::refine_left_map_scratch_bytes;
    decltype(&detail::cpu::grid_partner_scratch_bytes) grid_partner_scratch_bytes = &detail::cpu::grid_partner_scratch_bytes;
  };
  if (const std::size_t bytes = match_scratch_bytes(params, options, plan, CpuStages{}); bytes > 0)
    total += threads * ((bytes + 63) / 64 * 64);
  if (params.lr_check_on_grid() && options.compute_right) total += map_bytes(w0, h0);
  if (params.speckle_size > 0)
    total += Plane<std::int32_t>::bytes_for(detail::cpu::speckle_label_width(w0), h0) +
             static_cast<std::size_t>(w0) * h0 * 4;
  if (plan.sgm_levels > 0) {
    // The cost and sum storage every SGM level shares and the stages' scratch.
    const detail::LevelSpec& s = plan.finest_sgm();
    total += plan.sgm_cost_bytes + plan.sgm_entries * sizeof(std::uint16_t) + sgm_row_state_bytes(plan, params, threads);
    total += threads * ((detail::cpu::sgm_scratch_bytes(s.width, s.height, plan.sgm_max_stride) + 63) / 64 * 64);
  }
  // Margins (at the plan's margin level), confidence at the working scale and at the output size.
  if (params.sgm() || options.compute_confidence) {
    const detail::LevelSpec& m = plan.levels[static_cast<std::size_t>(plan.margin_level())];
    total += Plane<std::uint8_t>::bytes_for(m.width, m.height) + Plane<std::uint8_t>::bytes_for(w0, h0) +
             Plane<float>::bytes_for(width, height);
  }
  const int outputs = options.compute_right ? 2 : 1;
  total += outputs * map_bytes(width, height) * (scale_steps > 0 ? 2 : 1) + Plane<float>::bytes_for(width, height);
  return total;
}

}  // namespace mctstereo
