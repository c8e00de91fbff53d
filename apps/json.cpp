#include "json.hpp"

#include <charconv>
#include <cmath>
#include <stdexcept>

#include "output_files.hpp"

namespace mctstereo::app {

Json& Json::push_back(Json v) {
  auto* array = std::get_if<Array>(&value_);
  if (!array) throw std::logic_error("Json::push_back on a value that is not an array");
  array->push_back(std::move(v));
  return array->back();
}

Json& Json::set(std::string_view key, Json v) {
  auto* object = std::get_if<Object>(&value_);
  if (!object) throw std::logic_error("Json::set on a value that is not an object");
  for (auto& [k, member] : *object)
    if (k == key) return member = std::move(v);
  object->emplace_back(std::string(key), std::move(v));
  return object->back().second;
}

namespace {

void write_string(std::string& out, std::string_view s) {
  out += '"';
  for (const char c : s) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          static constexpr char kHex[] = "0123456789abcdef";
          out += "\\u00";
          out += kHex[(c >> 4) & 0xf];
          out += kHex[c & 0xf];
        } else {
          out += c;
        }
    }
  }
  out += '"';
}

void write_number(std::string& out, double v) {
  if (!std::isfinite(v)) {
    out += "null";
    return;
  }
  // Shortest text that reads back to the same double.
  char buf[32];
  const auto result = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, result.ptr);
}

void newline(std::string& out, int depth) {
  out += '\n';
  out.append(2 * depth, ' ');
}

}  // namespace

void Json::write(std::string& out, int depth) const {
  if (std::holds_alternative<std::nullptr_t>(value_)) {
    out += "null";
  } else if (const bool* b = std::get_if<bool>(&value_)) {
    out += *b ? "true" : "false";
  } else if (const auto* i = std::get_if<std::int64_t>(&value_)) {
    out += std::to_string(*i);
  } else if (const double* d = std::get_if<double>(&value_)) {
    write_number(out, *d);
  } else if (const auto* s = std::get_if<std::string>(&value_)) {
    write_string(out, *s);
  } else if (const auto* a = std::get_if<Array>(&value_)) {
    if (a->empty()) {
      out += "[]";
      return;
    }
    out += '[';
    for (std::size_t k = 0; k < a->size(); ++k) {
      if (k) out += ',';
      newline(out, depth + 1);
      (*a)[k].write(out, depth + 1);
    }
    newline(out, depth);
    out += ']';
  } else if (const auto* o = std::get_if<Object>(&value_)) {
    if (o->empty()) {
      out += "{}";
      return;
    }
    out += '{';
    for (std::size_t k = 0; k < o->size(); ++k) {
      if (k) out += ',';
      newline(out, depth + 1);
      write_string(out, (*o)[k].first);
      out += ": ";
      (*o)[k].second.write(out, depth + 1);
    }
    newline(out, depth);
    out += '}';
  }
}

std::string Json::dump() const {
  std::string out;
  write(out, 0);
  out += '\n';
  return out;
}

void write_json_file(const std::string& path, const Json& json) {
  const std::string text = json.dump();
  PendingOutputs outputs;
  outputs.add(path, std::vector<std::uint8_t>(text.begin(), text.end()));
  outputs.commit();
}

}  // namespace mctstereo::app
