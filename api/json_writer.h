// A JSON document written straight into a string, for answers too large to be worth a DOM: a
// feature line's hundreds of points cost nlohmann::json a heap array each, more than the engine's
// crest localisation of the same line. Numbers are the shortest text that reads back to the same
// double (std::to_chars); strings are escaped by nlohmann::json, so both writers agree on them.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

namespace featureline {

class JsonWriter {
 public:
  JsonWriter& begin_object() { return open('{'); }
  JsonWriter& end_object() { return close('}'); }
  JsonWriter& begin_array() { return open('['); }
  JsonWriter& end_array() { return close(']'); }
  /// The next member's name, inside an object; its value follows.
  JsonWriter& key(std::string_view name);

  /// A finite number as the shortest text that reads back to it, with ".0" when that text reads
  /// as an integer (as nlohmann::json prints doubles); NaN and infinities as null (JSON has none).
  JsonWriter& value(double x);
  JsonWriter& value(std::int64_t x);
  JsonWriter& value(std::uint64_t x);
  JsonWriter& value(int x) { return value(std::int64_t(x)); }
  JsonWriter& value(std::uint32_t x) { return value(std::uint64_t(x)); }
  JsonWriter& value(bool b);
  JsonWriter& value(std::string_view s);
  JsonWriter& value(const char* s) { return value(std::string_view(s)); }
  JsonWriter& value(const std::string& s) { return value(std::string_view(s)); }
  /// [x, y, z]
  JsonWriter& value(const Eigen::Vector3d& p);
  /// An array of the values.
  template <class T>
  JsonWriter& value(const std::vector<T>& values) {
    begin_array();
    for (const auto& v : values) value(v);
    return end_array();
  }
  /// A document already written (nested as one value).
  JsonWriter& raw(std::string_view json);

  /// key(name) then value(v).
  template <class T>
  JsonWriter& member(std::string_view name, const T& v) {
    return key(name).value(v);
  }

  const std::string& text() const { return out_; }
  std::string take() { return std::move(out_); }

 private:
  void separate();  ///< the comma before a value or key, unless it opens its container
  JsonWriter& open(char bracket);
  JsonWriter& close(char bracket);

  std::string out_;
  bool first_ = true;   ///< nothing written yet in the innermost container
  bool after_key_ = false;
};

}  // namespace featureline
