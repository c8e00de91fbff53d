// The opencl backend's driver. Reads like Matcher::Impl (src/matcher.cpp), stage for stage, on
// device planes: upload, gray, working-scale reductions and pyramid, then per level coarse to fine
// census, match and refinement, then upscale, output conversion and download. Every stage
// enqueues on the runtime's in-order queue without waiting; the host waits only for speckle
// removal (which runs on the host) and for the download of the results. The stages are made
// (their kernels created) in the constructor: a frame allocates nothing on the host.
#include "opencl/pipeline.hpp"

#include "level_plan.hpp"
#include "stopwatch.hpp"

#include <algorithm>
#include <array>
#include <map>
#include <optional>
#include <stdexcept>
#include <utility>

namespace mctstereo::detail::opencl {

namespace {

// The stage times of a frame, in pipeline order; "frame" last. Kernel labels are those the stage
// functions pass to Runtime::run; upload, speckle, download and frame are host wall times.
constexpr std::array<const char*, 13> kTimingLabels = {"upload", "gray",    "pyramid", "census",   "match",
                                                       "median", "lr_check", "speckle", "fill",     "upscale",
                                                       "output", "download", "frame"};

// Frames of pipelines that share a runtime (one device) take turns: the runtime's profiling
// events are one list per device, and a frame reads back the events it enqueued.
std::mutex& frame_mutex_of(const Runtime& rt) {
  static std::mutex guard;
  static std::map<const Runtime*, std::unique_ptr<std::mutex>> mutexes;  // runtimes live as long as the process
  std::lock_guard<std::mutex> lock(guard);
  auto& m = mutexes[&rt];
  if (!m) m = std::make_unique<std::mutex>();
  return *m;
}

// An OpenCL error as the user should read it: which device, and whether memory ran out.
[[noreturn]] void rethrow_cl(const DeviceInfo& device, const cl::Error& e) {
  if (e.err() == CL_MEM_OBJECT_ALLOCATION_FAILURE || e.err() == CL_OUT_OF_RESOURCES ||
      e.err() == CL_OUT_OF_HOST_MEMORY)
    throw std::runtime_error("OpenCL device " + device.name + " ran out of memory or resources: " + describe(e));
  throw std::runtime_error("OpenCL device " + device.name + ": " + describe(e));
}

std::string device_type(const cl::Device& device) {
  const cl_device_type type = device.getInfo<CL_DEVICE_TYPE>();
  if (type & CL_DEVICE_TYPE_GPU) return "GPU";
  if (type & CL_DEVICE_TYPE_CPU) return "CPU";
  if (type & CL_DEVICE_TYPE_ACCELERATOR) return "accelerator";
  return "other";
}

std::string mib(std::uint64_t bytes) { return std::to_string((bytes + (1u << 20) - 1) >> 20) + " MiB"; }

}  // namespace

std::vector<OpenclDevice> describe_devices() {
  std::vector<OpenclDevice> out;
  for (const DeviceInfo& d : list_devices()) {
    OpenclDevice o;
    o.index = d.index;
    o.name = d.name;
    o.platform = d.platform;
    o.vendor = d.vendor;
    try {
      o.type = device_type(d.device);
    } catch (const cl::Error&) {
      o.type = d.gpu ? "GPU" : "other";
    }
    o.version = d.version;
    o.c_version = d.c_version;
    o.driver = d.driver;
    o.compute_units = d.compute_units;
    o.global_memory = d.global_memory;
    o.max_allocation = d.max_allocation;
    o.has_popcount = d.has_popcount;
    out.push_back(std::move(o));
  }
  return out;
}

// Everything one pyramid level holds for both views, as Matcher::Impl's Level; its plan
// (sizes, range, windows, band) comes from plan_levels().
struct Pipeline::Level : LevelSpec {
  DevicePlane<std::uint8_t> image[2];
  DeviceCodes codes[2];
  DevicePlane<std::int16_t> disparity[2], scratch[2];
  Plane<std::int16_t> host;     // the map on its way through speckle removal
  std::optional<Match> match;   // box aggregation: this level's SHD window, sub-pixel at the finest only
  DeviceSgmVolume sgm;          // band SGM: its band, costs and sums (storage shared by the levels)
  // The temporal prior: this level's maps and images of the previous frame.
  DevicePlane<std::int16_t> previous[2];
  DevicePlane<std::uint8_t> previous_image[2];
};

// The other stages the parameters use, one object per kernel; those they do not use stay empty.
struct Pipeline::Stages {
  ToGray gray_rgb, gray_bgr;  // gray input needs no conversion
  PyramidDown pyramid;
  CensusTransform census;
  std::optional<MedianFilter> median, post_median;
  std::optional<LrCheck> lr_check[2];  // the check of the left view's map, then the right's
  std::optional<GridPartner> grid_partner;  // StereoParams::lr_check_grid
  FillInvalid fill;
  std::optional<Upscale> upscale;
  std::optional<ToOutput> output;  // the right view's, without the float map
  ToOutput output_with_float;
  // Band SGM, instead of the levels' box matching.
  std::optional<SgmCosts> sgm_costs;
  std::optional<SgmAggregate> sgm_aggregate;
  std::optional<SgmSelect> sgm_select;
  std::optional<Confidence> confidence;
  // The colour-weighted median, its channel split and the 3x3 median after it.
  std::optional<SplitChannels> split;
  std::optional<WeightedMedian> weighted_median;
  std::optional<MedianFilter> wm_median;

  // check_right: some level checks the right view's map too.
  Stages(Runtime& rt, const StereoParams& p, bool check_right, bool compute_right, bool confidence_map)
      : gray_rgb(rt, PixelFormat::Rgb8),
        gray_bgr(rt, PixelFormat::Bgr8),
        pyramid(rt),
        census(rt, {p.census, p.census_window, p.mct_kernel}),
        fill(rt, p.fill),
        output_with_float(rt, true) {
    if (p.median_size > 0) median.emplace(rt, p.median_size);
    if (p.post_median_size > 0) post_median.emplace(rt, p.post_median_size);
    if (p.lr_check) lr_check[0].emplace(rt, -1);
    if (p.lr_check && check_right) lr_check[1].emplace(rt, +1);
    if (p.lr_check_on_grid()) grid_partner.emplace(rt, p.median_size);
    if (p.working_scale > 1) upscale.emplace(rt, p.working_scale);
    if (compute_right) output.emplace(rt, false);
    if (p.weighted_median) {
      WeightedMedianConfig config;
      config.radius = p.wm_radius;
      config.step = p.wm_step;
      config.lut = weighted_median_lut(p.wm_sigma);
      split.emplace(rt);
      weighted_median.emplace(rt, config);
      wm_median.emplace(rt, 3);
    }
    if (p.sgm()) {
      sgm_costs.emplace(rt, pick_popcount(rt.device()));
      sgm_aggregate.emplace(rt);
      sgm_select.emplace(rt);
    }
    if (confidence_map) confidence.emplace(rt);
  }
  ToGray& to_gray(PixelFormat format) { return format == PixelFormat::Rgb8 ? gray_rgb : gray_bgr; }
};

Pipeline::Pipeline(const DeviceInfo& device, int width, int height, const StereoParams& params,
                   const MatcherOptions& options)
    : rt_(runtime_for(device)),
      frame_mutex_(&frame_mutex_of(*rt_)),
      width_(width),
      height_(height),
      params_(params),
      options_(options),
      need_right_(params.lr_check || options.compute_right),
      want_confidence_(params.sgm() || options.compute_confidence),
      popcount_(pick_popcount(rt_->device())),
      invalid_q4_(static_cast<std::int16_t>((params.min_disparity - 1) * kDisparityScale)) {
  std::lock_guard<std::mutex> lock(*frame_mutex_);
  try {
    allocate();
    // The right view's map is checked at the finest level only when it is an output, and at the
    // others when they are refined.
    const bool check_right = options.compute_right || (params.refine_all_levels && params.pyramid_levels > 1);
    stages_ = std::make_unique<Stages>(*rt_, params, check_right, options.compute_right, want_confidence_);
    for (int l = 0; l < params.pyramid_levels; ++l) {
      if (levels_[l].is_sgm) continue;
      const MatchConfig config{-1, levels_[l].shd_window, params.subpixel && l == 0, params.uniqueness_ratio};
      // Margins only where the confidence takes them (under SGM levels it takes theirs).
      const bool margins = l == 0 && want_confidence_ && margin_level_ == 0;
      levels_[l].match.emplace(*rt_, census_words(params.census_window), config, margins, popcount_,
                               rt_->device().gpu);
    }
    // Buffers are allocated lazily by most drivers: a sum beyond the device is caught here, with
    // the numbers, rather than as an allocation failure in some kernel of the first frame.
    const std::uint64_t have = rt_->device().global_memory;
    if (have != 0 && device_bytes_ > have)
      throw std::runtime_error("the opencl backend needs " + mib(device_bytes_) + " of device memory for " +
                               std::to_string(width) + "x" + std::to_string(height) + " images; OpenCL device " +
                               rt_->device().name + " has " + mib(have));
    // A blank frame, colour conversion of both byte orders included, touches every buffer once
    // (drivers commit memory on first use) and runs every kernel once (PoCL compiles a kernel's
    // work-group function when it is first enqueued).
    const std::vector<std::uint8_t> zeros(input_[0].width * std::size_t{3} * input_[0].height, 0);
    for (int v = 0; v < 2; ++v) {
      rt_->queue().enqueueWriteBuffer(input_[v].bytes, CL_TRUE, 0, zeros.size(), zeros.data());
      for (PixelFormat format : {PixelFormat::Rgb8, PixelFormat::Bgr8}) {
        input_[v].format = format;
        input_[v].stride = static_cast<std::size_t>(width_) * 3;
        stages_->to_gray(format).run(input_[v], full_gray_[v][0]);
      }
      if (v == 0 && params.weighted_median) {
        stages_->split->run(input_[0], full_colour_[0]);
        colour_input_ = true;
      }
    }
    rt_->reset_times();
    run_levels();
    write_outputs();
    rt_->queue().finish();
    rt_->reset_times();
  } catch (const cl::Error& e) {
    rethrow_cl(rt_->device(), e);
  }
  timings_.reserve(kTimingLabels.size() + 4);
  for (const char* label : kTimingLabels) {
    timings_.push_back({label, 0.0});
    // The confidence comes after speckle removal, as in the frame.
    if (want_confidence_ && std::string_view(label) == "speckle") timings_.push_back({"confidence", 0.0});
    if (params.weighted_median && std::string_view(label) == "fill") timings_.push_back({"weighted_median", 0.0});
  }
}

Pipeline::~Pipeline() = default;

template <typename T>
void Pipeline::plane(DevicePlane<T>& p, int w, int h) {
  p.reset(*rt_, w, h);
  device_bytes_ += p.bytes();
}

void Pipeline::allocate() {
  const StereoParams& p = params_;
  // Colour input arrives as the caller's bytes, in packed rows of the widest format; gray input
  // goes straight into the first gray plane.
  for (int v = 0; v < 2; ++v) {
    const std::size_t bytes = static_cast<std::size_t>(width_) * 3 * height_;
    input_[v].bytes = rt_->buffer(bytes, CL_MEM_READ_ONLY);
    input_[v].width = width_;
    input_[v].height = height_;
    device_bytes_ += bytes;
  }
  const LevelPlan plan = plan_levels(p, width_, height_, need_right_);
  const int scale_steps = static_cast<int>(plan.working.size()) - 1;
  for (int v = 0; v < 2; ++v) {
    full_gray_[v].resize(plan.working.size());
    for (std::size_t s = 0; s < plan.working.size(); ++s) plane(full_gray_[v][s], plan.working[s].width, plan.working[s].height);
  }
  if (p.weighted_median) {
    full_colour_.resize(plan.working.size());
    for (std::size_t s = 0; s < plan.working.size(); ++s)
      for (auto& channel : full_colour_[s]) plane(channel, plan.working[s].width, plan.working[s].height);
  }
  levels_.resize(plan.levels.size());
  for (std::size_t l = 0; l < plan.levels.size(); ++l) {
    Level& L = levels_[l];
    static_cast<LevelSpec&>(L) = plan.levels[l];
    const int lw = L.width, lh = L.height;
    for (int v = 0; v < 2; ++v) {
      // Level 0 of the pyramid is the last working-scale reduction itself.
      if (l > 0) plane(L.image[v], lw, lh);
      L.codes[v].words = plan.census_words;
      for (int k = 0; k < L.codes[v].words; ++k) plane(L.codes[v].plane[k], lw, lh);
    }
    // The maps a level makes, and the scratch maps of its refinement.
    for (int v = 0; v < (L.right_map ? 2 : 1); ++v) {
      plane(L.disparity[v], lw, lh);
      if (L.refine) plane(L.scratch[v], lw, lh);
    }
    for (int v = 0; v < L.temporal_views(); ++v) {
      plane(L.previous[v], lw, lh);
      plane(L.previous_image[v], lw, lh);
    }
    if (L.refine && L.speckle > 1) L.host.reset(lw, lh);
    if (L.is_sgm) allocate_sgm_planes(L);
  }
  if (plan.sgm_levels > 0) allocate_sgm_storage();
  if (p.lr_check_on_grid() && options_.compute_right) plane(grid_partners_, plan.finest().width, plan.finest().height);
  if (want_confidence_) {
    margin_level_ = plan.margin_level();
    plane(margin_, levels_[margin_level_].width, levels_[margin_level_].height);
    plane(confidence_, levels_[0].width, levels_[0].height);
  }
  if (p.speckle_size > 0) {
    speckle_scratch_.label.reset(cpu::speckle_label_width(levels_[0].width), levels_[0].height);
    speckle_scratch_.stack =
        allocate_aligned<std::int32_t>(static_cast<std::size_t>(levels_[0].width) * levels_[0].height);
  }
  for (int v = 0; v < (options_.compute_right ? 2 : 1); ++v) {
    if (scale_steps > 0) plane(upscaled_[v], width_, height_);
    plane(out_q4_[v], width_, height_);
  }
  plane(out_float_, width_, height_);
}

// A level's band SGM planes; the band comes from the plan.
void Pipeline::allocate_sgm_planes(Level& L) {
  L.sgm.width = L.width;
  L.sgm.height = L.height;
  L.sgm.band = L.sgm_band;
  L.sgm.stride = L.sgm_stride;
  L.sgm.byte_costs = L.sgm_byte_costs;
  plane(L.sgm.lo, L.width, L.height);
  plane(L.sgm.count, L.width, L.height);
}

// The cost, sum and line scratch buffers every level's volume uses, sized for the largest.
void Pipeline::allocate_sgm_storage() {
  std::size_t entries = 1, cost_bytes = 1, scratch = 1;
  for (const Level& L : levels_) {
    if (!L.is_sgm) continue;
    const std::size_t level_entries = SgmVolume::entries_for(L.width, L.height, L.sgm.band);
    entries = std::max(entries, level_entries);
    cost_bytes = std::max(cost_bytes, level_entries * (L.sgm.byte_costs ? 1 : 2));
    scratch = std::max(scratch, DeviceSgmVolume::scratch_entries_for(L.width, L.height, L.sgm.band));
  }
  const cl::Buffer cost = rt_->buffer(cost_bytes);
  const cl::Buffer sum = rt_->buffer(entries * sizeof(std::uint16_t));
  const cl::Buffer lines = rt_->buffer(scratch * sizeof(std::uint16_t));
  device_bytes_ += cost_bytes + (entries + scratch) * sizeof(std::uint16_t);
  for (Level& L : levels_) {
    if (!L.is_sgm) continue;
    L.sgm.cost = cost;
    L.sgm.sum = sum;
    L.sgm.scratch = lines;
  }
}

const DevicePlane<std::uint8_t>& Pipeline::level_image(int l, int v) const {
  return l == 0 ? full_gray_[v].back() : levels_[l].image[v];
}

// One view to its gray plane: gray bytes straight into the plane (the device has nothing to
// convert), colour bytes into the input buffer and through to_gray. Blocking, so the caller may
// reuse its pixels as soon as compute() returns.
void Pipeline::upload_input(const ImageView& image, int v) {
  const std::array<std::size_t, 3> origin{0, 0, 0};
  const std::size_t row_bytes = static_cast<std::size_t>(width_) * bytes_per_pixel(image.format);
  const std::array<std::size_t, 3> region{row_bytes, static_cast<std::size_t>(height_), 1};
  const std::size_t host_pitch = static_cast<std::size_t>(image.stride);
  if (v == 0) colour_input_ = image.format != PixelFormat::Gray8;
  if (image.format == PixelFormat::Gray8) {
    DevicePlane<std::uint8_t>& gray = full_gray_[v][0];
    rt_->queue().enqueueWriteBufferRect(gray.buffer, CL_TRUE, origin, origin, region, gray.stride, 0, host_pitch,
                                        0, image.data);
    return;
  }
  DeviceImage& in = input_[v];
  in.format = image.format;
  in.stride = row_bytes;
  rt_->queue().enqueueWriteBufferRect(in.bytes, CL_TRUE, origin, origin, region, in.stride, 0, host_pitch, 0,
                                      image.data);
  stages_->to_gray(in.format).run(in, full_gray_[v][0]);
  // The weighted median's colour: the left view's channels.
  if (v == 0 && params_.weighted_median) stages_->split->run(in, full_colour_[0]);
}

void Pipeline::run_levels() {
  for (int v = 0; v < 2; ++v) {
    for (std::size_t s = 1; s < full_gray_[v].size(); ++s) stages_->pyramid.run(full_gray_[v][s - 1], full_gray_[v][s]);
    for (std::size_t l = 1; l < levels_.size(); ++l)
      stages_->pyramid.run(level_image(static_cast<int>(l) - 1, v), levels_[l].image[v]);
  }
  if (params_.weighted_median) {
    if (colour_input_)
      for (std::size_t s = 1; s < full_colour_.size(); ++s)
        for (int c = 0; c < 3; ++c) stages_->pyramid.run(full_colour_[s - 1][c], full_colour_[s][c]);
    wm_colour_.channels = colour_input_ ? 3 : 1;
    for (int c = 0; c < 3; ++c) wm_colour_.plane[c] = colour_input_ ? &full_colour_.back()[c] : &full_gray_[0].back();
  }

  for (int l = static_cast<int>(levels_.size()) - 1; l >= 0; --l) {
    Level& L = levels_[l];
    for (int v = 0; v < 2; ++v) stages_->census.run(level_image(l, v), L.codes[v]);

    const bool coarsest = l + 1 == static_cast<int>(levels_.size());
    if (L.is_sgm) {
      match_sgm(l, coarsest ? nullptr : &levels_[l + 1].disparity[0]);
      if (L.refine) refine(L, l == 0);
      continue;
    }
    for (int v = 0; v < (L.right_map ? 2 : 1); ++v) {
      // Each view searches around the coarser level's map of the same view.
      const DevicePlane<std::int16_t>* prior = coarsest ? nullptr : &levels_[l + 1].disparity[v];
      const bool margins_here = v == 0 && l == 0 && want_confidence_ && margin_level_ == 0;
      DevicePlane<std::uint8_t>* margin = margins_here ? &margin_ : nullptr;
      const DeviceTemporal temporal = temporal_prior(l, v);
      L.match->run(L.codes[v], L.codes[1 - v], prior, L.dmin, L.dmax, L.radius, v == 0 ? -1 : +1, L.disparity[v],
                   margin, temporal.map != nullptr ? &temporal : nullptr);
    }
    if (L.refine) refine(L, l == 0);
  }
}

// The temporal prior of view v at level l (Matcher::Impl::temporal_prior): none (a null map)
// unless this frame has the last one's maps.
DeviceTemporal Pipeline::temporal_prior(int l, int v) const {
  const Level& L = levels_[l];
  if (!used_previous_ || v >= L.temporal_views()) return {};
  return {&L.previous[v], &level_image(l, v), &L.previous_image[v], params_.temporal_radius,
          params_.temporal_threshold};
}

// The last frame's maps and images of the levels the temporal prior narrows become this frame's
// previous ones (Matcher::Impl::take_previous_maps): swaps of the device planes, before the upload
// writes the new gray images.
void Pipeline::take_previous_maps() {
  used_previous_ = params_.temporal && temporal_history_;
  if (used_previous_)
    swap_in_previous_maps(levels_, [&](int v) -> DevicePlane<std::uint8_t>& { return full_gray_[v].back(); });
}

// Band SGM at level l (Matcher::Impl::match_sgm): band costs around the coarser left map, the
// paths over the left gray image, the winners of both views from the same sums.
void Pipeline::match_sgm(int l, const DevicePlane<std::int16_t>* prior) {
  Level& L = levels_[l];
  const SgmBandConfig band{L.dmin, L.dmax, L.radius, params_.prior_size, L.sgm.band, {}};
  const DeviceTemporal temporal = temporal_prior(l, 0);
  stages_->sgm_costs->run(L.codes[0], L.codes[1], prior, band, L.shd_window, L.sgm,
                          temporal.map != nullptr ? &temporal : nullptr);
  const SgmPathConfig paths{params_.sgm_paths(), params_.sgm_p1, params_.sgm_p2, params_.sgm_p2_k};
  stages_->sgm_aggregate->run(level_image(l, 0), paths, L.sgm);
  const SgmSelectConfig select{params_.subpixel && l == 0, params_.uniqueness_ratio};
  stages_->sgm_select->run(L.sgm, select, L.dmin, L.dmax, L.disparity[0], L.right_map ? &L.disparity[1] : nullptr,
                           l == margin_level_ ? &margin_ : nullptr);
}

// Matcher::Impl::refine on the device. At the finest level the right map only serves the left
// map's LR check, so unless the caller asked for it, its refinement stops there.
void Pipeline::refine(Level& L, bool finest) {
  const int views = need_right_ ? 2 : 1;
  const int kept = finest && !options_.compute_right ? 1 : views;
  // The LR check on the grid, as Matcher::Impl::refine makes it: the left map's partners in the
  // right map's place, or beside it when it is an output.
  const bool grid = finest && params_.lr_check_on_grid();
  int median_views = views;
  if (grid) {
    if (options_.compute_right) {
      stages_->grid_partner->run(L.disparity[1], grid_partners_);
    } else {
      stages_->grid_partner->run(L.disparity[1], L.scratch[1]);
      std::swap(L.disparity[1], L.scratch[1]);
      median_views = 1;
    }
  }
  const DevicePlane<std::int16_t>& right_of_left = grid && options_.compute_right ? grid_partners_ : L.disparity[1];
  if (params_.median_size > 0) {
    for (int v = 0; v < median_views; ++v) {
      stages_->median->run(L.disparity[v], L.scratch[v]);
      std::swap(L.disparity[v], L.scratch[v]);
    }
  }
  if (params_.lr_check) {
    // Both checks read the maps as they were before either was checked.
    for (int v = 0; v < kept; ++v)
      stages_->lr_check[v]->run(L.disparity[v], v == 0 ? right_of_left : L.disparity[0], 16 * params_.lr_threshold,
                                L.scratch[v]);
    for (int v = 0; v < kept; ++v) std::swap(L.disparity[v], L.scratch[v]);
  }
  if (L.speckle > 1)
    for (int v = 0; v < kept; ++v) remove_speckles_on_host(L, v, L.speckle);
  // The confidence of the final map: what survived the checks, before the fill guesses.
  if (finest && want_confidence_)
    stages_->confidence->run(margin_, margin_level_, L.disparity[0], need_right_ ? &right_of_left : nullptr,
                             params_.lr_threshold, confidence_);
  for (int v = 0; v < kept; ++v) stages_->fill.run(L.disparity[v]);
  // The colour-weighted median and its 3x3 median take the place of the post-fill median in the
  // left map of the finest level.
  int first_post = 0;
  if (finest && params_.weighted_median) {
    stages_->weighted_median->run(L.disparity[0], wm_colour_, L.scratch[0]);
    stages_->wm_median->run(L.scratch[0], L.disparity[0]);
    first_post = 1;
  }
  if (params_.post_median_size > 0) {
    for (int v = first_post; v < kept; ++v) {
      stages_->post_median->run(L.disparity[v], L.scratch[v]);
      std::swap(L.disparity[v], L.scratch[v]);
    }
  }
}

// Connected components are a poor fit for a device (a flood fill is sequential; a parallel
// labelling needs many passes), so speckle removal runs on the host with the cpu backend's stage:
// the map comes down, loses its small regions and goes back. The download waits for the kernels
// before it; the upload is blocking, so `host` is free again when this returns.
void Pipeline::remove_speckles_on_host(Level& L, int v, int speckle) {
  // The kernels before it are the kernels' time, not this step's.
  rt_->queue().finish();
  Stopwatch clock;
  download(*rt_, L.disparity[v], L.host);
  cpu::remove_speckles(L.host, speckle, 16, speckle_scratch_);
  upload(*rt_, L.host, L.disparity[v]);
  speckle_ms_ += clock.lap_ms();
}

void Pipeline::write_outputs() {
  const int scale = params_.working_scale;
  for (int v = 0; v < (options_.compute_right ? 2 : 1); ++v) {
    const DevicePlane<std::int16_t>* result = &levels_[0].disparity[v];
    if (scale > 1) {
      stages_->upscale->run(*result, 16 * params_.min_disparity, 16 * params_.max_disparity(), upscaled_[v]);
      result = &upscaled_[v];
    }
    // The float map exists for the left view only, as the Matcher's disparity().
    if (v == 0) stages_->output_with_float.run(*result, invalid_q4_, out_q4_[v], &out_float_);
    else stages_->output->run(*result, invalid_q4_, out_q4_[v], nullptr);
  }
}

void Pipeline::compute(const ImageView& left, const ImageView& right, Plane<std::int16_t> (&q4)[2]) {
  std::lock_guard<std::mutex> lock(*frame_mutex_);
  Stopwatch frame, clock;
  double upload_ms = 0, download_ms = 0, frame_ms = 0;
  try {
    rt_->reset_times();
    speckle_ms_ = 0;
    take_previous_maps();
    upload_input(left, 0);
    upload_input(right, 1);
    upload_ms = clock.lap_ms();
    run_levels();
    write_outputs();
    // Waiting here first keeps the kernels' tail out of the download's time.
    rt_->queue().finish();
    clock.lap_ms();
    for (int v = 0; v < (options_.compute_right ? 2 : 1); ++v) download(*rt_, out_q4_[v], q4[v]);
    download_ms = clock.lap_ms();
    frame_ms = frame.lap_ms();
    temporal_history_ = params_.temporal;
  } catch (const cl::Error& e) {
    rethrow_cl(rt_->device(), e);
  }

  for (StageTime& t : timings_) t.ms = 0;
  auto add = [&](std::string_view label, double ms) {
    auto it = std::find_if(timings_.begin(), timings_.end(), [&](const StageTime& t) { return t.stage == label; });
    // A kernel label outside the list gets a place of its own, before "frame".
    if (it == timings_.end()) it = timings_.insert(timings_.end() - 1, {std::string(label), 0.0});
    it->ms += ms;
  };
  add("upload", upload_ms);
  add("speckle", speckle_ms_);
  add("download", download_ms);
  rt_->for_each_kernel_time(add);
  timings_.back().ms = frame_ms;
}

void Pipeline::download_float(Plane<float>& disparity) {
  std::lock_guard<std::mutex> lock(*frame_mutex_);
  try {
    download(*rt_, out_float_, disparity);
  } catch (const cl::Error& e) {
    rethrow_cl(rt_->device(), e);
  }
}

void Pipeline::download_confidence(Plane<std::uint8_t>& confidence) {
  std::lock_guard<std::mutex> lock(*frame_mutex_);
  try {
    download(*rt_, confidence_, confidence);
  } catch (const cl::Error& e) {
    rethrow_cl(rt_->device(), e);
  }
}

std::string Pipeline::device_name() const { return rt_->device().name + " (" + rt_->device().platform + ")"; }

}  // namespace mctstereo::detail::opencl
