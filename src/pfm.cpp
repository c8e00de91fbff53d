#include "mctstereo/pfm.hpp"

#include <cctype>
#include <cmath>
#include <cstring>
#include <istream>
#include <iterator>
#include <ostream>
#include <stdexcept>

namespace mctstereo {

namespace {

std::uint32_t load_bits(const unsigned char* p, bool little_endian) {
  return little_endian ? std::uint32_t{p[0]} | std::uint32_t{p[1]} << 8 | std::uint32_t{p[2]} << 16 |
                             std::uint32_t{p[3]} << 24
                       : std::uint32_t{p[3]} | std::uint32_t{p[2]} << 8 | std::uint32_t{p[1]} << 16 |
                             std::uint32_t{p[0]} << 24;
}

// The header's fields, whitespace-separated, read from `at` on.
struct HeaderReader {
  std::string_view bytes;
  std::size_t at = 0;

  std::string token() {
    while (at < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[at]))) ++at;
    std::string t;
    while (at < bytes.size() && !std::isspace(static_cast<unsigned char>(bytes[at])) && t.size() < 32) t += bytes[at++];
    return t;
  }
};

// Width, height and scale of the header; width 0 when a field is not a whole number (or the scale
// not a number).
void parse_size(const std::string& w, const std::string& h, const std::string& s, long& width, long& height,
                double& scale) {
  try {
    std::size_t used_w = 0, used_h = 0, used_s = 0;
    width = std::stol(w, &used_w);
    height = std::stol(h, &used_h);
    scale = std::stod(s, &used_s);
    if (used_w != w.size() || used_h != h.size() || used_s != s.size()) width = 0;
  } catch (const std::exception&) {
    width = 0;
  }
}

}  // namespace

std::vector<std::uint8_t> encode_pfm(MapView<const float> map) {
  const int w = map.width, h = map.height;
  const std::string header = "Pf\n" + std::to_string(w) + " " + std::to_string(h) + "\n-1.0\n";
  std::vector<std::uint8_t> bytes(header.begin(), header.end());
  bytes.reserve(header.size() + static_cast<std::size_t>(w) * h * 4);
  for (int y = h - 1; y >= 0; --y) {  // PFM stores the bottom row first
    const float* row = map.row(y);
    for (int x = 0; x < w; ++x) {
      const float v = std::isfinite(row[x]) ? row[x] : kPfmNone;
      std::uint32_t bits;
      std::memcpy(&bits, &v, 4);
      for (int b = 0; b < 4; ++b) bytes.push_back(static_cast<std::uint8_t>(bits >> (8 * b)));
    }
  }
  return bytes;
}

FloatMap decode_pfm(std::string_view bytes, const std::string& name) {
  HeaderReader header{bytes};
  const std::string magic = header.token();
  if (magic == "PF") throw std::runtime_error(name + " is a colour PFM (PF): only one-channel PFM (Pf) is read");
  if (magic != "Pf") throw std::runtime_error(name + " is not a PFM file: it must start with 'Pf'");
  const std::string width_text = header.token(), height_text = header.token(), scale_text = header.token();
  long width = 0, height = 0;
  double scale = 0.0;
  parse_size(width_text, height_text, scale_text, width, height, scale);
  const std::string header_text = "'" + magic + " " + width_text + " " + height_text + " " + scale_text + "'";
  if (width < 1 || height < 1 || !std::isfinite(scale) || scale == 0.0)
    throw std::runtime_error(name + ": bad PFM header " + header_text +
                             " (expected 'Pf WIDTH HEIGHT SCALE', a non-zero scale whose sign is the byte order)");
  // A well-formed header of a map larger than any image the matcher takes (StereoParams::validate).
  constexpr long kMaxSide = 32768;
  if (width > kMaxSide || height > kMaxSide)
    throw std::runtime_error(name + ": PFM header " + header_text + ": " + width_text + "x" + height_text +
                             " is too large (at most " + std::to_string(kMaxSide) + " x " + std::to_string(kMaxSide) +
                             ", the largest image matched)");
  // Exactly one whitespace byte ends the header: the samples may begin with a byte that looks like one.
  std::size_t at = header.at;
  if (at >= bytes.size() || !std::isspace(static_cast<unsigned char>(bytes[at])))
    throw std::runtime_error(name + ": bad PFM header: no line break after the scale");
  ++at;
  const std::size_t expected = static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 4;
  if (bytes.size() - at < expected)
    throw std::runtime_error(name + ": truncated PFM: " + std::to_string(width) + "x" + std::to_string(height) +
                             " needs " + std::to_string(expected) + " bytes of samples, the file has " +
                             std::to_string(bytes.size() - at));
  FloatMap map;
  map.width = static_cast<int>(width);
  map.height = static_cast<int>(height);
  map.values.resize(static_cast<std::size_t>(width) * height);
  const auto* samples = reinterpret_cast<const unsigned char*>(bytes.data()) + at;
  for (int y = 0; y < map.height; ++y) {
    const unsigned char* src = samples + static_cast<std::size_t>(map.height - 1 - y) * width * 4;
    float* dst = map.values.data() + static_cast<std::size_t>(y) * width;
    for (int x = 0; x < map.width; ++x, src += 4) {
      const std::uint32_t bits = load_bits(src, scale < 0);
      std::memcpy(&dst[x], &bits, 4);
    }
  }
  return map;
}

void write_pfm(std::ostream& out, MapView<const float> map) {
  const std::vector<std::uint8_t> bytes = encode_pfm(map);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (!out) throw std::runtime_error("write_pfm: the stream failed");
}

FloatMap read_pfm(std::istream& in, const std::string& name) {
  const std::string bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  if (in.bad()) throw std::runtime_error("cannot read " + name);
  return decode_pfm(bytes, name);
}

}  // namespace mctstereo
