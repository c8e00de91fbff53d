// A small JSON value for the reports of `eval` and `bench`: built in memory, written once.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

namespace mctstereo::app {

class Json {
 public:
  using Array = std::vector<Json>;
  /// Members keep their insertion order, so reports read in the order they were built.
  using Object = std::vector<std::pair<std::string, Json>>;

  Json() = default;  // null
  Json(std::nullptr_t) {}
  Json(bool v) : value_(v) {}
  Json(int v) : value_(static_cast<std::int64_t>(v)) {}
  Json(long v) : value_(static_cast<std::int64_t>(v)) {}
  Json(long long v) : value_(static_cast<std::int64_t>(v)) {}
  Json(unsigned long v) : value_(static_cast<std::int64_t>(v)) {}
  Json(unsigned long long v) : value_(static_cast<std::int64_t>(v)) {}
  Json(double v) : value_(v) {}
  Json(const char* v) : value_(std::string(v)) {}
  Json(std::string v) : value_(std::move(v)) {}
  Json(std::string_view v) : value_(std::string(v)) {}
  Json(Array v) : value_(std::move(v)) {}
  Json(Object v) : value_(std::move(v)) {}

  static Json array() { return Json(Array{}); }
  static Json object() { return Json(Object{}); }

  /// Appends to an array.
  Json& push_back(Json v);
  /// Sets (or replaces) a member of an object.
  Json& set(std::string_view key, Json v);

  /// The text, indented by two spaces per level; non-finite numbers are written as null.
  std::string dump() const;

 private:
  void write(std::string& out, int depth) const;
  std::variant<std::nullptr_t, bool, std::int64_t, double, std::string, Array, Object> value_;
};

/// Writes `json.dump()` to `path` through a temporary file renamed into place.
void write_json_file(const std::string& path, const Json& json);

}  // namespace mctstereo::app
