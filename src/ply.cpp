// Reading PLY point clouds: ascii and binary_little_endian, the vertex element's x y z and colours.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <istream>
#include <iterator>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "mctstereo/depth.hpp"

namespace mctstereo {

namespace {

enum class PlyType { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

std::optional<PlyType> ply_type(const std::string& name) {
  if (name == "char" || name == "int8") return PlyType::Int8;
  if (name == "uchar" || name == "uint8") return PlyType::UInt8;
  if (name == "short" || name == "int16") return PlyType::Int16;
  if (name == "ushort" || name == "uint16") return PlyType::UInt16;
  if (name == "int" || name == "int32") return PlyType::Int32;
  if (name == "uint" || name == "uint32") return PlyType::UInt32;
  if (name == "float" || name == "float32") return PlyType::Float32;
  if (name == "double" || name == "float64") return PlyType::Float64;
  return std::nullopt;
}

std::size_t type_size(PlyType type) {
  switch (type) {
    case PlyType::Int8:
    case PlyType::UInt8:
      return 1;
    case PlyType::Int16:
    case PlyType::UInt16:
      return 2;
    case PlyType::Int32:
    case PlyType::UInt32:
    case PlyType::Float32:
      return 4;
    case PlyType::Float64:
      return 8;
  }
  return 1;
}

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::Float32;
  bool is_list = false;
  PlyType count_type = PlyType::UInt8;  // of a list
};

struct PlyElement {
  std::string name;
  std::int64_t count = 0;
  std::vector<PlyProperty> properties;
};

// The values of the body, one at a time, ascii or binary little-endian. Returns false at the end.
class PlyValues {
 public:
  PlyValues(const std::string& bytes, std::size_t start, bool ascii) : bytes_(bytes), at_(start), ascii_(ascii) {}

  bool next(PlyType type, double& value) {
    if (ascii_) return next_text(value);
    const std::size_t n = type_size(type);
    if (bytes_.size() - at_ < n) return false;
    const char* p = bytes_.data() + at_;
    at_ += n;
    // Little-endian on every host: assembled byte by byte.
    std::uint64_t bits = 0;
    for (std::size_t i = 0; i < n; ++i) bits |= static_cast<std::uint64_t>(static_cast<unsigned char>(p[i])) << (8 * i);
    switch (type) {
      case PlyType::Int8:
        value = static_cast<std::int8_t>(bits);
        break;
      case PlyType::UInt8:
        value = static_cast<std::uint8_t>(bits);
        break;
      case PlyType::Int16:
        value = static_cast<std::int16_t>(bits);
        break;
      case PlyType::UInt16:
        value = static_cast<std::uint16_t>(bits);
        break;
      case PlyType::Int32:
        value = static_cast<std::int32_t>(bits);
        break;
      case PlyType::UInt32:
        value = static_cast<std::uint32_t>(bits);
        break;
      case PlyType::Float32: {
        const std::uint32_t b32 = static_cast<std::uint32_t>(bits);
        float f;
        std::memcpy(&f, &b32, sizeof f);
        value = f;
        break;
      }
      case PlyType::Float64: {
        double d;
        std::memcpy(&d, &bits, sizeof d);
        value = d;
        break;
      }
    }
    return true;
  }

  /// The text that failed to read as a number (ascii), for messages; empty at the end of the file.
  std::string bad_token() const { return bad_token_; }

 private:
  bool next_text(double& value) {
    while (at_ < bytes_.size() && std::isspace(static_cast<unsigned char>(bytes_[at_]))) ++at_;
    if (at_ == bytes_.size()) return false;
    std::size_t end = at_;
    while (end < bytes_.size() && !std::isspace(static_cast<unsigned char>(bytes_[end]))) ++end;
    const std::string token = bytes_.substr(at_, end - at_);
    char* stop = nullptr;
    value = std::strtod(token.c_str(), &stop);
    if (stop != token.c_str() + token.size()) {
      bad_token_ = token;
      return false;
    }
    at_ = end;
    return true;
  }

  const std::string& bytes_;
  std::size_t at_;
  bool ascii_;
  std::string bad_token_;
};

std::uint8_t colour_channel(double value, PlyType type) {
  // Floating-point colours are in [0, 1]; integer ones in [0, 255] (wider types are clamped).
  if (type == PlyType::Float32 || type == PlyType::Float64) value *= 255.0;
  if (!(value > 0.0)) return 0;
  return static_cast<std::uint8_t>(std::lround(std::min(value, 255.0)));
}

struct PlyHeader {
  std::string format;  // ascii or binary_little_endian
  std::vector<PlyElement> elements;
  std::size_t body = 0;  // where the values begin
};

PlyProperty parse_property(std::istringstream& words, const std::string& line, const std::string& name) {
  PlyProperty property;
  std::string type;
  words >> type;
  if (type == "list") {
    std::string count_type, item_type;
    words >> count_type >> item_type >> property.name;
    const auto c = ply_type(count_type), i = ply_type(item_type);
    if (!c || !i) throw std::runtime_error(name + ": unknown type in '" + line + "'");
    if (*c == PlyType::Float32 || *c == PlyType::Float64)
      throw std::runtime_error(name + ": the length of a list must have an integer type: '" + line + "'");
    property.is_list = true;
    property.count_type = *c;
    property.type = *i;
  } else {
    words >> property.name;
    const auto t = ply_type(type);
    if (!t) throw std::runtime_error(name + ": unknown type '" + type + "' in '" + line + "'");
    property.type = *t;
  }
  if (property.name.empty()) throw std::runtime_error(name + ": malformed header line '" + line + "'");
  return property;
}

// Applies one header line to `header`; true at end_header.
bool parse_header_line(const std::string& line, PlyHeader& header, const std::string& name) {
  std::istringstream words(line);
  std::string keyword;
  words >> keyword;
  if (keyword == "end_header") return true;
  if (keyword == "format") {
    std::string version;
    words >> header.format >> version;
    if (header.format != "ascii" && header.format != "binary_little_endian")
      throw std::runtime_error(name + " is in the format '" + header.format +
                               "': only ascii and binary_little_endian are read (convert it, e.g. with MeshLab)");
  } else if (keyword == "element") {
    PlyElement element;
    if (!(words >> element.name >> element.count) || element.count < 0)
      throw std::runtime_error(name + ": malformed header line '" + line + "'");
    header.elements.push_back(element);
  } else if (keyword == "property") {
    if (header.elements.empty()) throw std::runtime_error(name + ": property before any element: '" + line + "'");
    header.elements.back().properties.push_back(parse_property(words, line, name));
  } else if (keyword != "comment" && keyword != "obj_info" && !keyword.empty()) {
    throw std::runtime_error(name + ": unknown header line '" + line + "'");
  }
  return false;
}

// The header: lines from "ply" up to "end_header".
PlyHeader parse_header(const std::string& bytes, const std::string& name) {
  if (bytes.rfind("ply\n", 0) != 0 && bytes.rfind("ply\r\n", 0) != 0)
    throw std::runtime_error(name + " is not a PLY file (it does not start with 'ply')");
  PlyHeader header;
  std::size_t at = bytes.find('\n') + 1;
  for (bool ended = false; !ended;) {
    const std::size_t end = bytes.find('\n', at);
    if (end == std::string::npos) throw std::runtime_error(name + ": the header has no end_header line");
    std::string line = bytes.substr(at, end - at);
    at = end + 1;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    ended = parse_header_line(line, header, name);
  }
  if (header.format.empty()) throw std::runtime_error(name + ": the header has no format line");
  header.body = at;
  return header;
}

// Which vertex property is x, y, z, red, green, blue (kNone: none).
constexpr int kNone = -1;
constexpr const char* kVertexNames[6] = {"x", "y", "z", "red", "green", "blue"};

struct VertexLayout {
  int index[6] = {kNone, kNone, kNone, kNone, kNone, kNone};  // property of each of kVertexNames
  std::vector<int> role;  // which of kVertexNames each property is
  bool colours = false;
};

VertexLayout vertex_layout(const PlyElement& vertices, const std::string& name) {
  VertexLayout layout;
  for (std::size_t p = 0; p < vertices.properties.size(); ++p)
    for (int k = 0; k < 6; ++k)
      if (vertices.properties[p].name == kVertexNames[k]) {
        if (vertices.properties[p].is_list)
          throw std::runtime_error(name + ": the vertex property " + kVertexNames[k] + " is a list");
        layout.index[k] = static_cast<int>(p);
      }
  for (int k = 0; k < 3; ++k)
    if (layout.index[k] == kNone) throw std::runtime_error(name + ": the vertices have no property " + kVertexNames[k]);
  layout.colours = layout.index[3] != kNone && layout.index[4] != kNone && layout.index[5] != kNone;
  layout.role.assign(vertices.properties.size(), kNone);
  for (int k = 0; k < 6; ++k)
    if (layout.index[k] != kNone) layout.role[static_cast<std::size_t>(layout.index[k])] = k;
  return layout;
}

// The body's values, with the messages of a short or malformed body.
class PlyBody {
 public:
  PlyBody(const std::string& bytes, const PlyHeader& header, const std::string& name)
      : values_(bytes, header.body, header.format == "ascii"), size_(bytes.size()), name_(name) {}

  // The next value of an element's row (1-based in messages) of `count`.
  double next(PlyType type, const std::string& element, std::int64_t row, std::int64_t count) {
    double value = 0;
    if (values_.next(type, value)) return value;
    if (!values_.bad_token().empty())
      throw std::runtime_error(name_ + ": '" + values_.bad_token() + "' in " + element + " " +
                               std::to_string(row + 1) + " is not a number");
    throw std::runtime_error(name_ + " is truncated: it ends in " + element + " " + std::to_string(row + 1) + " of " +
                             std::to_string(count));
  }

  // Reads past a list whose length has been read.
  void skip_list(double length, PlyType type, const std::string& element, std::int64_t row, std::int64_t count) {
    // Each item takes at least a byte: a longer list cannot be in the file.
    if (!(length >= 0.0 && length <= static_cast<double>(size_)))
      throw std::runtime_error(name_ + ": a list of " + element + " " + std::to_string(row + 1) + " has the length " +
                               std::to_string(length));
    for (auto i = static_cast<std::int64_t>(length); i > 0; --i) next(type, element, row, count);
  }

 private:
  PlyValues values_;
  std::size_t size_;
  const std::string& name_;
};

// Reads one row of an element; values[p] is property p's value (a list's length for a list).
void read_row(PlyBody& body, const PlyElement& element, std::int64_t row, std::vector<double>& values) {
  values.resize(element.properties.size());
  for (std::size_t p = 0; p < element.properties.size(); ++p) {
    const PlyProperty& property = element.properties[p];
    values[p] = body.next(property.is_list ? property.count_type : property.type, element.name, row, element.count);
    if (property.is_list) body.skip_list(values[p], property.type, element.name, row, element.count);
  }
}

void append_vertex(const std::vector<double>& values, const PlyElement& vertices, const VertexLayout& layout,
                   PointCloud& cloud) {
  for (int k = 0; k < 3; ++k) {  // beyond the range of float: not a point
    const double v = values[static_cast<std::size_t>(layout.index[k])];
    cloud.xyz.push_back(std::abs(v) <= std::numeric_limits<float>::max() ? static_cast<float>(v)
                                                                           : std::numeric_limits<float>::quiet_NaN());
  }
  if (!layout.colours) return;
  for (int k = 3; k < 6; ++k) {
    const auto p = static_cast<std::size_t>(layout.index[k]);
    cloud.rgb.push_back(colour_channel(values[p], vertices.properties[p].type));
  }
}

}  // namespace

PointCloud read_ply(std::istream& in, const std::string& name) {
  const std::string bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  if (in.bad()) throw std::runtime_error("cannot read " + name);
  const PlyHeader header = parse_header(bytes, name);
  const auto vertex = std::find_if(header.elements.begin(), header.elements.end(),
                                   [](const PlyElement& e) { return e.name == "vertex"; });
  if (vertex == header.elements.end()) throw std::runtime_error(name + " has no vertex element");
  if (vertex->count == 0) throw std::runtime_error(name + " has no vertices");
  const VertexLayout layout = vertex_layout(*vertex, name);

  PlyBody body(bytes, header, name);
  std::vector<double> values;
  // Elements before the vertices are read past. One without properties has nothing to read: its
  // rows are skipped at once, not counted one by one (a count of 10^18 would never end; found by
  // fuzz/fuzz_ply.cpp).
  for (auto e = header.elements.begin(); e != vertex; ++e)
    if (!e->properties.empty())
      for (std::int64_t row = 0; row < e->count; ++row) read_row(body, *e, row, values);
  PointCloud cloud;
  cloud.units.clear();  // a PLY file does not say
  // No more than the file can hold: a huge count in a small file is truncated, not out of memory.
  const std::size_t plausible =
      std::min<std::size_t>(static_cast<std::size_t>(vertex->count), bytes.size() - header.body);
  cloud.xyz.reserve(3 * plausible);
  if (layout.colours) cloud.rgb.reserve(3 * plausible);
  for (std::int64_t row = 0; row < vertex->count; ++row) {
    read_row(body, *vertex, row, values);
    append_vertex(values, *vertex, layout, cloud);
  }
  return cloud;
}

}  // namespace mctstereo
