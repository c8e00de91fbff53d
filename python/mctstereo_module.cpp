// The Python module mctstereo._mctstereo: the library over numpy arrays (python/mctstereo/__init__.py
// re-exports it). Images are read in place when the engine can read their layout (uint8, pixels
// packed within a row, any row stride: OpenCV images and their ROIs as they come); other layouts are
// copied once into a temporary buffer. Maps come back as new numpy arrays. compute() releases
// the GIL while it matches.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <cmath>
#include <cstdint>
#include <array>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "mctstereo/mctstereo.hpp"

namespace py = pybind11;
using namespace mctstereo;

namespace {

// ---- Enums: Python enums that also accept the program's names ("ct", "sgm4", "nearest-lower").

template <typename E>
void bind_enum(py::module_& m, const char* name, const char* doc, std::initializer_list<std::pair<const char*, E>> values) {
  py::enum_<E> e(m, name, doc);
  std::vector<E> all;
  for (const auto& [n, v] : values) {
    e.value(n, v);
    all.push_back(v);
  }
  e.def(py::init([all, name](const std::string& text) {
          for (E v : all)
            if (text == to_string(v)) return v;
          std::string known;
          for (E v : all) known += (known.empty() ? "" : ", ") + std::string(to_string(v));
          throw py::value_error(std::string(name) + ": unknown value '" + text + "' (known: " + known + ")");
        }),
        py::arg("name"), "From the program's name of the value");
  e.def_property_readonly("label", [](E v) { return std::string(to_string(v)); }, "The program's name of the value");
  py::implicitly_convertible<py::str, E>();
}

// ---- Arrays in and out.

template <typename T>
py::array_t<T> map_to_array(MapView<const T> map) {
  py::array_t<T> out({map.height, map.width});
  auto* dst = out.mutable_data();
  for (int y = 0; y < map.height; ++y)
    std::memcpy(dst + static_cast<std::ptrdiff_t>(y) * map.width, map.row(y), sizeof(T) * map.width);
  return out;
}

std::string shape_text(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s += (i ? ", " : "") + std::to_string(a.shape(i));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

// A numpy image as the engine reads it: in place when its pixels are packed within a row (pixel
// stride = bytes per pixel, channel stride 1) and its row stride is at least a row's bytes;
// otherwise copied into `scratch`.
struct ImageInput {
  ImageView view;
  bool copied = false;
};

ImageInput image_input(const py::array& a, const char* role, int width, int height, PixelFormat colour,
                       std::vector<std::uint8_t>& scratch) {
  if (!py::dtype::of<std::uint8_t>().equal(a.dtype()))
    throw py::type_error(std::string(role) + " image: dtype " + std::string(py::str(a.dtype())) +
                         ", expected uint8 (8-bit gray H x W or colour H x W x 3); convert with "
                         "image.astype(numpy.uint8) after scaling to 0..255");
  const bool gray = a.ndim() == 2 || (a.ndim() == 3 && a.shape(2) == 1);
  const bool rgb = a.ndim() == 3 && a.shape(2) == 3;
  if (!gray && !rgb)
    throw py::value_error(std::string(role) + " image: shape " + shape_text(a) +
                          ", expected H x W (gray) or H x W x 3 (colour)" +
                          (a.ndim() == 3 && a.shape(2) == 4 ? "; drop the alpha channel: image[:, :, :3]" : ""));
  const py::ssize_t h = a.shape(0), w = a.shape(1);
  if (w != width || h != height)
    throw py::value_error(std::string(role) + " image is " + std::to_string(w) + " x " + std::to_string(h) +
                          " (W x H, shape " + shape_text(a) + "), the matcher's size is " + std::to_string(width) +
                          " x " + std::to_string(height));
  ImageInput in;
  in.view.width = width;
  in.view.height = height;
  in.view.format = gray ? PixelFormat::Gray8 : colour;
  const int bpp = gray ? 1 : 3;
  const auto* base = static_cast<const std::uint8_t*>(a.data());
  const py::ssize_t row_stride = a.strides(0), pixel_stride = a.strides(1);
  const py::ssize_t channel_stride = rgb ? a.strides(2) : 1;
  const bool packed = (pixel_stride == bpp || w == 1) && channel_stride == 1;
  if (packed && (row_stride >= static_cast<py::ssize_t>(w) * bpp || h == 1)) {
    in.view.data = base;
    in.view.stride = h == 1 ? static_cast<std::ptrdiff_t>(w) * bpp : row_stride;
    return in;
  }
  // Any other layout (a column step, negative strides, a transposed or channel-first view): one copy.
  scratch.resize(static_cast<std::size_t>(w) * h * bpp);
  for (py::ssize_t y = 0; y < h; ++y)
    for (py::ssize_t x = 0; x < w; ++x)
      for (int c = 0; c < bpp; ++c)
        scratch[(static_cast<std::size_t>(y) * w + x) * bpp + c] =
            base[y * row_stride + x * pixel_stride + c * channel_stride];
  in.view.data = scratch.data();
  in.view.stride = static_cast<std::ptrdiff_t>(w) * bpp;
  in.copied = true;
  return in;
}

// A numpy array, or what numpy makes of another object (a nested list, a buffer): the array itself
// when it is one, so that its memory is read in place.
py::array as_array(const py::object& object, const char* role) {
  if (py::isinstance<py::array>(object)) return py::reinterpret_borrow<py::array>(object);
  py::array a = py::array::ensure(object);
  if (!a) {
    PyErr_Clear();
    throw py::type_error(std::string(role) + " image: expected a numpy uint8 array, not " +
                         std::string(py::str(py::type::handle_of(object).attr("__name__"))));
  }
  return a;
}

PixelFormat parse_channels(const std::string& order) {
  if (order == "bgr" || order == "BGR") return PixelFormat::Bgr8;
  if (order == "rgb" || order == "RGB") return PixelFormat::Rgb8;
  throw py::value_error("channels: '" + order + "', expected 'bgr' (OpenCV's order) or 'rgb'");
}

// A float or Q4 map argument of the depth functions: 2-D, of that dtype, any strides.
template <typename T>
py::array_t<T, py::array::c_style> map_argument(const py::array& a, const char* role, const char* dtype_name) {
  if (!py::dtype::of<T>().equal(a.dtype()))
    throw py::type_error(std::string(role) + ": dtype " + std::string(py::str(a.dtype())) + ", expected " + dtype_name);
  if (a.ndim() != 2) throw py::value_error(std::string(role) + ": shape " + shape_text(a) + ", expected H x W");
  return py::array_t<T, py::array::c_style>::ensure(a);
}

template <typename T>
MapView<const T> map_view(const py::array_t<T, py::array::c_style>& a) {
  return {a.data(), static_cast<int>(a.shape(1)), static_cast<int>(a.shape(0)), static_cast<std::ptrdiff_t>(a.shape(1))};
}

// ---- The matcher: one per Python object, its compute() serialised by a mutex so that a matcher
// shared by Python threads stays correct (matchers of their own run in parallel).

struct PyMatcher {
  std::unique_ptr<Matcher> matcher;
  std::mutex mutex;  // taken with the GIL released, so that a waiting thread never holds the GIL
  int copied_inputs = 0;
  bool has_frame = false;

  // Runs fn on the matcher without the GIL, under the mutex.
  template <typename F>
  void locked(F&& fn) {
    py::gil_scoped_release release;
    std::lock_guard<std::mutex> lock(mutex);
    fn(*matcher);
  }
  void need_frame() const {
    if (!has_frame) throw std::runtime_error("no frame yet: call compute(left, right) first");
  }
};

// A map of the matcher's last frame, copied into a new array: the array is made with the GIL, the
// copy runs without it. get returns the map (null data: none).
template <typename T, typename Get>
py::object last_map(PyMatcher& self, Get get) {
  self.need_frame();
  py::array_t<T> out({self.matcher->height(), self.matcher->width()});
  T* dst = out.mutable_data();
  bool none = false;
  self.locked([&](Matcher& matcher) {
    const MapView<const T> map = get(matcher);
    if (map.data == nullptr) {
      none = true;
      return;
    }
    for (int y = 0; y < map.height; ++y)
      std::memcpy(dst + static_cast<std::ptrdiff_t>(y) * map.width, map.row(y), sizeof(T) * map.width);
  });
  if (none) return py::none();
  return out;
}

std::string params_repr(const std::vector<std::string>& fields, py::handle self) {
  std::string s = "StereoParams(";
  for (std::size_t i = 0; i < fields.size(); ++i)
    s += (i ? ", " : "") + fields[i] + "=" + std::string(py::repr(self.attr(fields[i].c_str())));
  return s + ")";
}

void write_cloud(const std::string& path, const PointCloud& cloud, const std::vector<std::string>& comments, bool ply) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error("cannot open '" + path + "' for writing");
  if (ply)
    write_ply(out, cloud, comments);
  else
    write_obj(out, cloud, comments);
  out.close();
  if (!out) throw std::runtime_error("cannot write '" + path + "'");
}

// ---- Files (PFM, PLY) and OpenCV's matrices of a geometry.

std::string quoted(const std::filesystem::path& path) {
  // Appended piece by piece: "'" + string&& trips a false -Wrestrict warning of GCC 12.
  std::string text(1, '\'');
  text += path.string();
  text += '\'';
  return text;
}

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open " + quoted(path));
  std::string bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  if (in.bad()) throw std::runtime_error("cannot read " + quoted(path));
  return bytes;
}

py::array_t<float> float_map_array(const FloatMap& map) {
  py::array_t<float> out({map.height, map.width});
  std::memcpy(out.mutable_data(), map.values.data(), map.values.size() * sizeof(float));
  return out;
}

py::bytes pfm_bytes(const py::array& map) {
  const auto values = map_argument<float>(map, "map", "float32");
  std::vector<std::uint8_t> bytes;
  {
    py::gil_scoped_release release;
    bytes = encode_pfm(map_view(values));
  }
  return {reinterpret_cast<const char*>(bytes.data()), bytes.size()};
}

// A matrix argument of `rows` x `cols` (or as many values flat), as doubles row by row.
template <std::size_t N>
std::array<double, N> matrix_argument(const py::object& object, const char* name, int rows, int cols) {
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(object);
  if (!a || static_cast<std::size_t>(a.size()) != N || (a.ndim() == 2 && (a.shape(0) != rows || a.shape(1) != cols)) ||
      a.ndim() > 2)
    throw py::value_error(std::string(name) + ": expected a " + std::to_string(rows) + " x " + std::to_string(cols) +
                          " matrix");
  std::array<double, N> values{};
  std::memcpy(values.data(), a.data(), sizeof(double) * N);
  return values;
}

template <std::size_t N>
py::array_t<double> matrix_array(const std::array<double, N>& values, int rows, int cols) {
  py::array_t<double> out({rows, cols});
  std::memcpy(out.mutable_data(), values.data(), sizeof(double) * N);
  return out;
}

void bind_files(py::module_& m) {
  m.def("encode_pfm", &pfm_bytes, py::arg("map"),
        "The bytes of a one-channel PFM of a float32 H x W map, as the program writes it (little-endian, bottom row "
        "first, +INF where the value is not finite)");
  m.def("write_pfm", [](const std::filesystem::path& path, const py::array& map) {
        const std::string data = pfm_bytes(map);
        std::ofstream out(path, std::ios::binary);
        out.write(data.data(), static_cast<std::streamsize>(data.size()));
        out.close();
        if (!out) throw std::runtime_error("cannot write " + quoted(path));
      }, py::arg("path"), py::arg("map"), "encode_pfm(map) written to path");
  m.def("decode_pfm", [](const py::bytes& data) { return float_map_array(decode_pfm(std::string_view(data))); },
        py::arg("data"), "The map of a one-channel PFM's bytes: float32 H x W, top row first; RuntimeError if damaged");
  m.def("read_pfm", [](const std::filesystem::path& path) { return float_map_array(decode_pfm(read_file(path), quoted(path))); },
        py::arg("path"), "The map of a one-channel PFM file: float32 H x W, top row first (+INF kept)");
  m.def("read_ply", [](const std::filesystem::path& path) {
        std::istringstream in(read_file(path));
        return read_ply(in, "point cloud " + quoted(path));
      }, py::arg("path"), "A PointCloud of a PLY file (ascii or binary little-endian; x y z, red green blue)");
  m.def("geometry_from_projections", [](const py::object& P1, const py::object& P2, const std::string& units) {
        return geometry_from_projections(matrix_argument<12>(P1, "P1", 3, 4), matrix_argument<12>(P2, "P2", 3, 4), units);
      }, py::arg("P1"), py::arg("P2"), py::arg("units") = "m",
      "StereoGeometry of OpenCV's 3 x 4 P1, P2 (stereoRectify); ValueError naming the matrix that gives none");
  m.def("geometry_from_reprojection", [](const py::object& Q, const std::string& units) {
        return geometry_from_reprojection(matrix_argument<16>(Q, "Q", 4, 4), units);
      }, py::arg("Q"), py::arg("units") = "m", "StereoGeometry of OpenCV's 4 x 4 Q; ValueError when it gives none");
  m.def("projection_matrices", [](const StereoGeometry& g) {
        return py::make_tuple(matrix_array(left_projection(g), 3, 4), matrix_array(right_projection(g), 3, 4));
      }, py::arg("geometry"), "(P1, P2) of a geometry, float64 3 x 4, as OpenCV's stereoRectify gives them");
  m.def("reprojection_matrix", [](const StereoGeometry& g) { return matrix_array(reprojection_matrix(g), 4, 4); },
        py::arg("geometry"), "Q of a geometry, float64 4 x 4 (reprojectImageTo3D's)");
}

}  // namespace

PYBIND11_MODULE(_mctstereo, m) {
  m.doc() = "mctstereo: dense stereo matching on the (modified) census transform, coarse to fine";
  m.attr("__version__") = std::string(version());

  bind_enum<CensusKind>(m, "CensusKind", "Census transform: ct (centre pixel) or mct (3x3 mean)",
                        {{"CT", CensusKind::Census}, {"MCT", CensusKind::ModifiedCensus}});
  bind_enum<MeanKernel>(m, "MeanKernel", "Kernel of the MCT mean: mean (box) or gaussian",
                        {{"MEAN", MeanKernel::Box}, {"GAUSSIAN", MeanKernel::Gaussian}});
  bind_enum<FillMode>(m, "FillMode", "Filling of invalid pixels: none, nearest, nearest-lower",
                      {{"NONE", FillMode::None}, {"NEAREST", FillMode::Nearest}, {"NEAREST_LOWER", FillMode::NearestLower}});
  bind_enum<Aggregation>(m, "Aggregation", "Cost aggregation: box, sgm4, sgm8",
                         {{"BOX", Aggregation::Box}, {"SGM4", Aggregation::Sgm4}, {"SGM8", Aggregation::Sgm8}});

  // ---- StereoParams: every field, as in include/mctstereo/params.hpp.
  py::class_<StereoParams> params(m, "StereoParams",
                                  "Every parameter of the pipeline (include/mctstereo/params.hpp). StereoParams() is "
                                  "the library's default (box pipeline); preset('balanced') is the program's. "
                                  "Keywords set fields: StereoParams(num_disparities=16).");
  auto fields = std::make_shared<std::vector<std::string>>();
#define MCTSTEREO_FIELD(name, doc)               \
  params.def_readwrite(#name, &StereoParams::name, doc); \
  fields->push_back(#name)
  MCTSTEREO_FIELD(min_disparity, "Smallest disparity searched, pixels, [-1024, 1024]");
  MCTSTEREO_FIELD(num_disparities, "Number of disparities searched, [1, 2048]");
  MCTSTEREO_FIELD(census, "CensusKind (or 'ct', 'mct')");
  MCTSTEREO_FIELD(census_window, "Census window side: 3, 5, 7 or 9");
  MCTSTEREO_FIELD(mct_kernel, "MeanKernel of MCT (or 'mean', 'gaussian')");
  MCTSTEREO_FIELD(shd_window, "Hamming sum window at the finest level: 1, 3, 5, 7 or 9");
  MCTSTEREO_FIELD(coarse_shd_window, "Hamming sum window at the coarser levels: 1, 3, 5, 7 or 9");
  MCTSTEREO_FIELD(pyramid_levels, "Pyramid levels, [1, 5]");
  MCTSTEREO_FIELD(search_radius, "Search around the coarser prior, pixels of the level, [0, 16]");
  MCTSTEREO_FIELD(subpixel, "Parabola sub-pixel refinement at the finest level");
  MCTSTEREO_FIELD(median_size, "Median side: 0 (off), 3 or 5");
  MCTSTEREO_FIELD(lr_check, "Left-right consistency check");
  MCTSTEREO_FIELD(lr_threshold, "Allowed left-right difference, pixels of the level, [0, 16]");
  MCTSTEREO_FIELD(speckle_size, "Smallest region kept, pixels, [0, 1000000], 0 = off");
  MCTSTEREO_FIELD(uniqueness_ratio, "Best must beat the second best by this percent, [0, 100], 0 = off");
  MCTSTEREO_FIELD(fill, "FillMode (or 'none', 'nearest', 'nearest-lower')");
  MCTSTEREO_FIELD(post_median_size, "Median after filling: 0, 3 or 5");
  MCTSTEREO_FIELD(lr_check_grid, "LR check of the left map against the right map on the grid of even rows and columns (its median on that grid)");
  MCTSTEREO_FIELD(refine_all_levels, "Refine at every level rather than the finest only");
  MCTSTEREO_FIELD(aggregation, "Aggregation (or 'box', 'sgm4', 'sgm8')");
  MCTSTEREO_FIELD(sgm_p1, "SGM penalty of a 1-disparity step, [0, 16383]");
  MCTSTEREO_FIELD(sgm_p2, "SGM penalty of a larger jump, [sgm_p1, 16383]");
  MCTSTEREO_FIELD(sgm_p2_k, "Adaptive P2: P2 k / (k + |I(p) - I(q)|), [0, 255], 0 = constant");
  MCTSTEREO_FIELD(prior_size, "Coarse neighbourhood spanning the search: 3 or 5");
  MCTSTEREO_FIELD(box_levels, "SGM: finest levels matched locally with box sums around the SGM levels' maps");
  MCTSTEREO_FIELD(finest_search_radius, "Search radius at the finest level, [-1, 16], -1 = search_radius");
  MCTSTEREO_FIELD(sgm_max_band, "SGM candidates per pixel below the coarsest level, [1, 255]");
  MCTSTEREO_FIELD(weighted_median, "Colour-weighted median after the fill at the finest level, then a 3x3 median");
  MCTSTEREO_FIELD(wm_radius, "Weighted median window radius, [1, 15] pixels");
  MCTSTEREO_FIELD(wm_step, "Weighted median sample step, [1, wm_radius] pixels");
  MCTSTEREO_FIELD(wm_sigma, "Weighted median colour scale of the weights, [1, 255] levels");
  MCTSTEREO_FIELD(working_scale, "Working scale: 1, 2 or 4");
  MCTSTEREO_FIELD(temporal, "Temporal prior: the finer levels also search around the previous frame's map");
  MCTSTEREO_FIELD(temporal_radius, "Temporal prior: radius of its narrowed bands, [0, 16] pixels");
  MCTSTEREO_FIELD(temporal_threshold, "Temporal prior: largest gray change of a still pixel, [0, 255]");
#undef MCTSTEREO_FIELD
  m.attr("_PARAM_FIELDS") = *fields;
  // The fields as a dict, enums by their program names: to_dict() and pickling's state.
  const auto as_dict = [fields](py::object self) {
    py::dict d;
    for (const auto& f : *fields) {
      py::object v = self.attr(f.c_str());
      d[f.c_str()] = py::hasattr(v, "label") ? v.attr("label") : v;
    }
    return d;
  };
  params.def(py::init([fields](const py::kwargs& kwargs) {
               auto p = std::make_unique<StereoParams>();
               py::object self = py::cast(p.get(), py::return_value_policy::reference);
               for (const auto& [key, value] : kwargs) {
                 const std::string name = py::str(key);
                 if (std::find(fields->begin(), fields->end(), name) == fields->end())
                   throw py::type_error("StereoParams: no field '" + name + "'");
                 self.attr(name.c_str()) = value;
               }
               return p;
             }),
             "StereoParams(**fields): the library's defaults, with the given fields set")
      .def("max_disparity", &StereoParams::max_disparity, "min_disparity + num_disparities - 1")
      .def("sgm", &StereoParams::sgm, "Whether the aggregation is semi-global")
      .def("sgm_paths", &StereoParams::sgm_paths, "SGM paths: 4 or 8 (0 for box)")
      .def("finest_radius", &StereoParams::finest_radius, "The search radius of the finest level")
      .def(
          "validate",
          [](const StereoParams& p, std::optional<int> width, std::optional<int> height) {
            if (width.has_value() != height.has_value())
              throw py::type_error("validate: give both width and height, or neither");
            const std::string problems = width ? p.validate(*width, *height) : p.validate();
            if (!problems.empty()) throw py::value_error(problems);
          },
          py::arg("width") = py::none(), py::arg("height") = py::none(),
          "Raises ValueError with the library's message (one line per problem) when a parameter or their "
          "combination is invalid; with width and height, also against that image size")
      .def(
          "problems",
          [](const StereoParams& p, std::optional<int> width, std::optional<int> height) {
            const std::string s = width && height ? p.validate(*width, *height) : p.validate();
            std::vector<std::string> lines;
            std::istringstream in(s);
            for (std::string line; std::getline(in, line);)
              if (!line.empty()) lines.push_back(line);
            return lines;
          },
          py::arg("width") = py::none(), py::arg("height") = py::none(),
          "validate()'s messages as a list (empty when valid)")
      .def("__repr__", [fields](py::object self) { return params_repr(*fields, self); })
      .def("__eq__",
           [fields](py::object self, py::object other) {
             if (!py::isinstance<StereoParams>(other)) return false;
             for (const auto& f : *fields)
               if (!self.attr(f.c_str()).equal(other.attr(f.c_str()))) return false;
             return true;
           })
      .def("__copy__", [](const StereoParams& p) { return StereoParams(p); })
      .def("__deepcopy__", [](const StereoParams& p, py::dict) { return StereoParams(p); }, py::arg("memo"))
      .def("to_dict", as_dict, "The fields as a dict (enums by their program names)")
      .def(py::pickle(
          as_dict,
          [fields](py::dict d) {
            StereoParams p;
            py::object self = py::cast(&p, py::return_value_policy::reference);
            for (const auto& [key, value] : d) self.attr(py::str(key).cast<std::string>().c_str()) = value;
            return p;
          }));
  params.attr("__hash__") = py::none();

  m.def(
      "preset",
      [](const std::string& name, const py::kwargs& overrides) {
        StereoParams p = preset(name);
        py::object self = py::cast(&p, py::return_value_policy::reference);
        for (const auto& [key, value] : overrides) {
          const std::string field = py::str(key);
          if (!py::hasattr(self, field.c_str())) throw py::type_error("preset: StereoParams has no field '" + field + "'");
          self.attr(field.c_str()) = value;
        }
        return p;
      },
      py::arg("name"),
      "The parameters of a named preset (preset_names()); keywords override fields: "
      "preset('balanced', num_disparities=16). ValueError naming the presets for an unknown name.");
  m.def("preset_names", &preset_names, "The names preset() accepts, in a stable order");
  m.def(
      "preset_description", [](const std::string& name) { return std::string(preset_description(name)); },
      py::arg("name"), "One line on what the preset is for");

  // ---- Matcher.
  py::class_<PyMatcher>(m, "Matcher",
                        "Matcher(width, height, params=None, backend='cpu', threads=0, device='', compute_right=False, "
                        "compute_confidence=False, sgm_volume_limit=None, adapt_threads=True): "
                        "allocates everything once for one image size; compute(left, right) per frame. params None is "
                        "preset('balanced'), the program's default. backend: 'reference', 'cpu', 'opencl' or 'auto'. "
                        "sgm_volume_limit: bytes of band SGM costs and sums a level holds whole (None: the library's "
                        "default, 32 MiB); larger frames are aggregated in segments of rows, with the same maps. "
                        "adapt_threads: run frames on all threads or on one, whichever the recent frames found faster "
                        "(on a loaded CPU, one can be; the same maps); False: every frame on all threads.")
      .def(py::init([](int width, int height, std::optional<StereoParams> p, const std::string& backend, int threads,
                       const std::string& device, bool compute_right, bool compute_confidence,
                       std::optional<std::size_t> sgm_volume_limit, bool adapt_threads) {
             MatcherOptions options;
             options.adapt_threads = adapt_threads;
             options.threads = threads;
             options.device = device;
             options.compute_right = compute_right;
             options.compute_confidence = compute_confidence;
             if (sgm_volume_limit) options.sgm_volume_limit = *sgm_volume_limit;
             const Backend b = parse_backend(backend);
             const StereoParams used = p ? *p : preset("balanced");
             auto pm = std::make_unique<PyMatcher>();
             {
               py::gil_scoped_release release;  // the opencl backend builds kernels here
               pm->matcher = std::make_unique<Matcher>(width, height, used, b, options);
             }
             return pm;
           }),
           py::arg("width"), py::arg("height"), py::arg("params") = py::none(), py::arg("backend") = "cpu",
           py::arg("threads") = 0, py::arg("device") = "", py::arg("compute_right") = false,
           py::arg("compute_confidence") = false, py::arg("sgm_volume_limit") = py::none(),
           py::arg("adapt_threads") = true)
      .def(
          "compute",
          [](PyMatcher& self, const py::object& left_object, const py::object& right_object, const std::string& channels) {
            const PixelFormat colour = parse_channels(channels);
            const int w = self.matcher->width(), h = self.matcher->height();
            const py::array left = as_array(left_object, "left"), right = as_array(right_object, "right");
            std::vector<std::uint8_t> scratch[2];  // only for layouts the engine cannot read
            const ImageInput l = image_input(left, "left", w, h, colour, scratch[0]);
            const ImageInput r = image_input(right, "right", w, h, colour, scratch[1]);
            py::array_t<float> out({h, w});
            float* dst = out.mutable_data();
            self.locked([&](Matcher& matcher) {
              matcher.compute(l.view, r.view);
              const MapView<const float> d = matcher.disparity();
              for (int y = 0; y < h; ++y) std::memcpy(dst + static_cast<std::ptrdiff_t>(y) * w, d.row(y), sizeof(float) * w);
              self.copied_inputs = int(l.copied) + int(r.copied);
              self.has_frame = true;
            });
            return out;
          },
          py::arg("left"), py::arg("right"), py::arg("channels") = "bgr",
          "Matches a rectified pair: numpy uint8 arrays, H x W (gray) or H x W x 3 (colour; channels 'bgr', "
          "OpenCV's order, or 'rgb'), any strides. Returns the left disparity, float32 H x W, NaN where invalid. "
          "The layouts the engine reads (pixels packed within a row, any row stride) are not copied.")
      .def(
          "disparity",
          [](PyMatcher& self) { return last_map<float>(self, [](Matcher& m) { return m.disparity(); }); },
          "The last frame's left disparity, float32 H x W, NaN where invalid (a new array)")
      .def(
          "disparity_q4",
          [](PyMatcher& self) { return last_map<std::int16_t>(self, [](Matcher& m) { return m.disparity_q4(); }); },
          "The last frame's left disparity, int16 H x W, 16 x d; invalid pixels hold invalid_q4")
      .def(
          "confidence",
          [](PyMatcher& self) { return last_map<float>(self, [](Matcher& m) { return m.confidence(); }); },
          "The last frame's confidence, float32 H x W in [0, 1]; None for box aggregation unless "
          "compute_confidence=True")
      .def(
          "right_disparity_q4",
          [](PyMatcher& self) {
            return last_map<std::int16_t>(self, [](Matcher& m) { return m.right_disparity_q4(); });
          },
          "The last frame's right-view disparity (Q4), or None unless compute_right=True")
      .def(
          "reset_temporal", [](PyMatcher& self) { self.locked([](Matcher& m) { m.reset_temporal(); }); },
          "With params.temporal: the next compute() matches its frame alone (a cut in the sequence)")
      .def_property_readonly(
          "used_temporal_prior",
          [](PyMatcher& self) {
            bool used = false;
            self.locked([&](Matcher& m) { used = m.used_temporal_prior(); });
            return used;
          },
          "Whether the last compute() used the previous frame's maps (params.temporal)")
      .def_property_readonly("width", [](const PyMatcher& s) { return s.matcher->width(); })
      .def_property_readonly("height", [](const PyMatcher& s) { return s.matcher->height(); })
      .def_property_readonly("params", [](const PyMatcher& s) { return s.matcher->params(); },
                             "A copy of the parameters the matcher runs")
      .def_property_readonly("backend", [](const PyMatcher& s) { return std::string(to_string(s.matcher->backend())); },
                             "The backend that runs ('auto' resolved)")
      .def_property_readonly("invalid_q4", [](const PyMatcher& s) { return s.matcher->invalid_q4(); },
                             "The Q4 value of invalid pixels: (min_disparity - 1) x 16")
      .def_property_readonly("notice", [](const PyMatcher& s) { return s.matcher->notice(); })
      .def_property_readonly("device_name", [](const PyMatcher& s) { return s.matcher->device_name(); })
      .def_property_readonly("threads", [](const PyMatcher& s) { return s.matcher->threads(); })
      .def_property_readonly(
          "frames_alone", [](const PyMatcher& s) { return s.matcher->frames_alone(); },
          "frames run on one thread: by adapt_threads (its trials, or where one thread was faster) and by single_threaded")
      .def_property(
          "single_threaded", [](const PyMatcher& s) { return s.matcher->single_threaded(); },
          [](PyMatcher& s, bool single) { s.matcher->set_single_threaded(single); },
          "True: the next frames run on the calling thread alone (the same maps), e.g. while a consumer of the maps is the bottleneck")
      .def_property_readonly("simd_target", [](const PyMatcher& s) { return s.matcher->simd_target(); })
      .def_property_readonly("copied_inputs", [](const PyMatcher& s) { return s.copied_inputs; },
                             "How many of the last compute()'s two images had to be copied (0: both read in place)")
      .def_property_readonly(
          "timings",
          [](PyMatcher& self) {
            std::vector<StageTime> times;
            self.locked([&](Matcher& m) { times = m.timings(); });
            py::dict d;
            for (const StageTime& t : times) d[t.stage.c_str()] = t.ms;
            return d;
          },
          "Milliseconds per stage of the last compute(); 'frame' is the whole call")
      .def("__repr__", [](const PyMatcher& s) {
        return "Matcher(" + std::to_string(s.matcher->width()) + ", " + std::to_string(s.matcher->height()) +
               ", backend='" + std::string(to_string(s.matcher->backend())) + "')";
      });

  m.def("have_opencl", &have_opencl, "Whether this build has the opencl backend");
  m.def(
      "opencl_devices",
      [] {
        py::list out;
        for (const OpenclDevice& d : opencl_devices()) {
          py::dict e;
          e["index"] = d.index;
          e["name"] = d.name;
          e["platform"] = d.platform;
          e["vendor"] = d.vendor;
          e["type"] = d.type;
          e["version"] = d.version;
          e["c_version"] = d.c_version;
          e["driver"] = d.driver;
          e["compute_units"] = d.compute_units;
          e["global_memory"] = d.global_memory;
          e["max_allocation"] = d.max_allocation;
          e["has_popcount"] = d.has_popcount;
          out.append(e);
        }
        return out;
      },
      "Every OpenCL device (dicts); empty without a driver or in a build without OpenCL");
  m.def(
      "estimate_memory",
      [](const StereoParams& p, int width, int height, int threads, std::optional<std::size_t> sgm_volume_limit) {
        MatcherOptions o;
        o.threads = threads;
        if (sgm_volume_limit) o.sgm_volume_limit = *sgm_volume_limit;
        return estimate_memory(p, width, height, o);
      },
      py::arg("params"), py::arg("width"), py::arg("height"), py::arg("threads") = 0,
      py::arg("sgm_volume_limit") = py::none(),
      "Bytes a cpu matcher of these parameters and size allocates");
  m.def("version", [] { return std::string(version()); }, "The version of the library");

  // ---- Depth and point clouds.
  py::class_<StereoGeometry>(m, "StereoGeometry",
                             "The geometry of a rectified pair in pixels of the matched images: "
                             "Z = focal * baseline / (d + doffs), X = (x - cx) Z / focal, Y = (y - cy) Z / focal")
      .def(py::init([](double focal, double baseline, double cx, double cy, double doffs, const std::string& units) {
             StereoGeometry g;
             g.focal = focal;
             g.baseline = baseline;
             g.cx = cx;
             g.cy = cy;
             g.doffs = doffs;
             g.units = units;
             return g;
           }),
           py::arg("focal") = 0.0, py::arg("baseline") = 0.0, py::arg("cx") = 0.0, py::arg("cy") = 0.0,
           py::arg("doffs") = 0.0, py::arg("units") = "m")
      .def_readwrite("focal", &StereoGeometry::focal)
      .def_readwrite("cx", &StereoGeometry::cx)
      .def_readwrite("cy", &StereoGeometry::cy)
      .def_readwrite("baseline", &StereoGeometry::baseline)
      .def_readwrite("doffs", &StereoGeometry::doffs)
      .def_readwrite("units", &StereoGeometry::units)
      .def("validate", &StereoGeometry::validate, "ValueError naming the field when the geometry is invalid")
      .def("scaled", &StereoGeometry::scaled, py::arg("factor"), "The geometry of the images scaled by factor")
      .def("depth", &StereoGeometry::depth, py::arg("disparity"), "Depth of one disparity, in units")
      .def("__repr__", [](const StereoGeometry& g) {
        std::ostringstream s;
        s << "StereoGeometry(focal=" << g.focal << ", baseline=" << g.baseline << ", cx=" << g.cx << ", cy=" << g.cy
          << ", doffs=" << g.doffs << ", units='" << g.units << "')";
        return s.str();
      });

  m.def(
      "depth_from_disparity",
      [](const py::array& disparity, const StereoGeometry& geometry, double max_depth, std::optional<int> invalid_q4) {
        py::array_t<float> out;
        if (py::dtype::of<std::int16_t>().equal(disparity.dtype())) {
          if (!invalid_q4) throw py::type_error("depth_from_disparity: a Q4 (int16) map needs invalid_q4");
          auto q4 = map_argument<std::int16_t>(disparity, "disparity", "float32 (pixels) or int16 (Q4)");
          const auto v = map_view(q4);
          out = py::array_t<float>({v.height, v.width});
          MapView<float> d{out.mutable_data(), v.width, v.height, v.width};
          py::gil_scoped_release release;
          depth_from_disparity(v, static_cast<std::int16_t>(*invalid_q4), geometry, d, max_depth);
        } else {
          auto f = map_argument<float>(disparity, "disparity", "float32 (pixels) or int16 (Q4)");
          const auto v = map_view(f);
          out = py::array_t<float>({v.height, v.width});
          MapView<float> d{out.mutable_data(), v.width, v.height, v.width};
          py::gil_scoped_release release;
          depth_from_disparity(v, geometry, d, max_depth);
        }
        return out;
      },
      py::arg("disparity"), py::arg("geometry"), py::arg("max_depth") = std::numeric_limits<double>::infinity(),
      py::arg("invalid_q4") = py::none(),
      "Depth of every pixel (float32, NaN where none) from a float disparity map (NaN invalid) or a Q4 int16 map "
      "with its invalid_q4");
  m.def(
      "relative_depth_from_disparity",
      [](const py::array& q4_map, int invalid_q4) {
        auto q4 = map_argument<std::int16_t>(q4_map, "q4", "int16 (Q4)");
        const auto v = map_view(q4);
        py::array_t<float> out({v.height, v.width});
        MapView<float> d{out.mutable_data(), v.width, v.height, v.width};
        relative_depth_from_disparity(v, static_cast<std::int16_t>(invalid_q4), d);
        return out;
      },
      py::arg("q4"), py::arg("invalid_q4"), "1 / d of a Q4 map (float32, NaN where invalid or d <= 0)");

  py::class_<PointCloud>(m, "PointCloud", "Points of the valid pixels, in row-major pixel order")
      .def(py::init<>())
      .def_property_readonly("xyz",
                             [](const PointCloud& c) {
                               py::array_t<float> a({static_cast<py::ssize_t>(c.size()), py::ssize_t{3}});
                               if (c.size()) std::memcpy(a.mutable_data(), c.xyz.data(), c.xyz.size() * sizeof(float));
                               return a;
                             },
                             "float32 N x 3, in units")
      .def_property_readonly("rgb",
                             [](const PointCloud& c) -> py::object {
                               if (!c.has_colours()) return py::none();
                               py::array_t<std::uint8_t> a({static_cast<py::ssize_t>(c.size()), py::ssize_t{3}});
                               if (c.size()) std::memcpy(a.mutable_data(), c.rgb.data(), c.rgb.size());
                               return a;
                             },
                             "uint8 N x 3 (R, G, B), or None for a cloud without colours")
      .def_property_readonly("pixel",
                             [](const PointCloud& c) {
                               py::array_t<std::int32_t> a(static_cast<py::ssize_t>(c.size()));
                               if (c.size()) std::memcpy(a.mutable_data(), c.pixel.data(), c.pixel.size() * 4);
                               return a;
                             },
                             "int32 N: y * width + x of each point's left pixel")
      .def_readwrite("units", &PointCloud::units)
      .def("__len__", &PointCloud::size)
      .def("write_ply", [](const PointCloud& c, const std::string& path, const std::vector<std::string>& comments) {
             write_cloud(path, c, comments, true);
           }, py::arg("path"), py::arg("comments") = std::vector<std::string>{},
           "Binary little-endian PLY (x y z, and red green blue with colours)")
      .def("write_obj", [](const PointCloud& c, const std::string& path, const std::vector<std::string>& comments) {
             write_cloud(path, c, comments, false);
           }, py::arg("path"), py::arg("comments") = std::vector<std::string>{}, "Wavefront OBJ");

  m.def(
      "point_cloud_from_disparity",
      [](const py::array& q4_map, int invalid_q4, const StereoGeometry& geometry, const py::object& colours,
         double max_depth, const std::string& channels) {
        auto q4 = map_argument<std::int16_t>(q4_map, "q4", "int16 (Q4)");
        const auto v = map_view(q4);
        std::vector<std::uint8_t> scratch;
        ImageView image;  // null data: no colours
        py::array colour_array;
        if (!colours.is_none()) {
          colour_array = as_array(colours, "colours");
          image = image_input(colour_array, "colours", v.width, v.height, parse_channels(channels), scratch).view;
        }
        PointCloud cloud;
        {
          py::gil_scoped_release release;
          point_cloud_from_disparity(v, static_cast<std::int16_t>(invalid_q4), geometry, image, cloud, max_depth);
        }
        return cloud;
      },
      py::arg("q4"), py::arg("invalid_q4"), py::arg("geometry"), py::arg("colours") = py::none(),
      py::arg("max_depth") = std::numeric_limits<double>::infinity(), py::arg("channels") = "bgr",
      "Back-projects every valid pixel of a Q4 map with a depth; colours: the left image (uint8 H x W or "
      "H x W x 3, channels 'bgr' or 'rgb') or None");

  bind_files(m);
}
