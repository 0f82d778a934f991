// Helpers shared by the mesh readers: message names, strict number parsing, tokenising,
// welding by exact position and the vertex/triangle limits.
#include "engine/io/reader_support.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <system_error>

namespace featureline::detail {

namespace {

char lower(char c) { return static_cast<char>(std::tolower(static_cast<unsigned char>(c))); }

}  // namespace

const char* display_name(MeshFormat format) {
  switch (format) {
    case MeshFormat::obj: return "OBJ";
    case MeshFormat::off: return "OFF";
    case MeshFormat::ply: return "PLY";
    case MeshFormat::stl: return "STL";
    case MeshFormat::gltf: return "glTF";
    case MeshFormat::glb: return "GLB";
    case MeshFormat::drc: return "Draco";
  }
  return "mesh";
}

bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (lower(a[i]) != lower(b[i])) return false;
  }
  return true;
}

bool starts_with(std::string_view s, std::string_view prefix) { return s.substr(0, prefix.size()) == prefix; }

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f'; }

std::string_view trim(std::string_view s) {
  while (!s.empty() && is_space(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_space(s.back())) s.remove_suffix(1);
  return s;
}

NumberStatus parse_real(std::string_view token, double& value) {
  if (token.empty()) return NumberStatus::not_a_number;
  std::size_t i = (token[0] == '+' || token[0] == '-') ? 1 : 0;
  const std::string_view body = token.substr(i);
  if (body.size() >= 3 && (iequals(body.substr(0, 3), "nan") || iequals(body.substr(0, 3), "inf"))) {
    return NumberStatus::non_finite;
  }
  if (body.find("#INF") != std::string_view::npos || body.find("#IND") != std::string_view::npos ||
      body.find("#QNAN") != std::string_view::npos || body.find("#SNAN") != std::string_view::npos) {
    return NumberStatus::non_finite;  // MSVC spellings such as 1.#INF or -1.#IND
  }
  // Strict decimal grammar: digits [. digits] [e [sign] digits], at least one mantissa digit.
  std::size_t mantissa_digits = 0;
  while (i < token.size() && std::isdigit(static_cast<unsigned char>(token[i]))) ++i, ++mantissa_digits;
  if (i < token.size() && token[i] == '.') {
    ++i;
    while (i < token.size() && std::isdigit(static_cast<unsigned char>(token[i]))) ++i, ++mantissa_digits;
  }
  if (mantissa_digits == 0) return NumberStatus::not_a_number;
  if (i < token.size() && (token[i] == 'e' || token[i] == 'E')) {
    ++i;
    if (i < token.size() && (token[i] == '+' || token[i] == '-')) ++i;
    std::size_t exponent_digits = 0;
    while (i < token.size() && std::isdigit(static_cast<unsigned char>(token[i]))) ++i, ++exponent_digits;
    if (exponent_digits == 0) return NumberStatus::not_a_number;
  }
  if (i != token.size()) return NumberStatus::not_a_number;

  const char* begin = token.data() + (token[0] == '+' ? 1 : 0);
  const char* end = token.data() + token.size();
  double parsed = 0.0;
  const auto result = std::from_chars(begin, end, parsed);
  if (result.ec == std::errc::result_out_of_range) {
    // Overflow is non-finite; underflow rounds to (nearly) zero, which is fine. strtod tells them apart.
    const std::string copy(begin, end);
    parsed = std::strtod(copy.c_str(), nullptr);
  } else if (result.ec != std::errc() || result.ptr != end) {
    return NumberStatus::not_a_number;
  }
  if (!std::isfinite(parsed)) return NumberStatus::non_finite;
  value = parsed;
  return NumberStatus::ok;
}

bool parse_integer(std::string_view token, std::int64_t& value) {
  if (token.empty()) return false;
  const char* begin = token.data() + (token[0] == '+' ? 1 : 0);
  const char* end = token.data() + token.size();
  if (begin == end) return false;
  std::int64_t parsed = 0;
  const auto result = std::from_chars(begin, end, parsed);
  if (result.ec != std::errc() || result.ptr != end) return false;
  value = parsed;
  return true;
}

std::string quote_token(std::string_view token) {
  std::string out = "'";
  const std::size_t shown = std::min<std::size_t>(token.size(), 40);
  for (std::size_t i = 0; i < shown; ++i) {
    const unsigned char c = static_cast<unsigned char>(token[i]);
    out += (c >= 0x20 && c < 0x7f) ? static_cast<char>(c) : '?';
  }
  if (shown < token.size()) out += "...";
  out += "'";
  return out;
}

std::optional<std::string_view> TokenScanner::next() {
  while (pos_ < text_.size() && is_space(text_[pos_])) {
    if (text_[pos_] == '\n') ++line_;
    ++pos_;
  }
  if (pos_ >= text_.size()) return std::nullopt;
  const std::size_t start = pos_;
  while (pos_ < text_.size() && !is_space(text_[pos_])) ++pos_;
  return text_.substr(start, pos_ - start);
}

void TokenScanner::skip_line() {
  while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
  if (pos_ < text_.size()) {
    ++pos_;
    ++line_;
  }
}

std::size_t PositionWelder::KeyHash::operator()(const Key& k) const {
  std::uint64_t h = 0x9e3779b97f4a7c15ull;
  for (std::uint64_t b : k.bits) {
    h ^= b + 0x9e3779b97f4a7c15ull + (h << 6) + (h >> 2);
    h *= 0xff51afd7ed558ccdull;
    h ^= h >> 33;
  }
  return static_cast<std::size_t>(h);
}

std::uint32_t PositionWelder::add(const std::array<double, 3>& p) {
  std::array<double, 3> q = p;
  Key key{};
  for (int i = 0; i < 3; ++i) {
    if (q[i] == 0.0) q[i] = 0.0;  // -0 and +0 are the same position
    std::memcpy(&key.bits[i], &q[i], sizeof q[i]);
  }
  const auto [it, inserted] = index_.try_emplace(key, static_cast<std::uint32_t>(positions_.size()));
  if (inserted) positions_.push_back(q);
  return it->second;
}

void check_vertex_limit(MeshFormat format, std::size_t vertices, const ReadMeshOptions& options) {
  const std::size_t limit = std::min<std::size_t>(options.max_vertices, std::numeric_limits<std::uint32_t>::max());
  if (vertices > limit) {
    throw LimitExceededError(std::string(display_name(format)) + " mesh has more than " + std::to_string(limit) +
                             " vertices, the configured limit.");
  }
}

void check_triangle_limit(MeshFormat format, std::size_t triangles, const ReadMeshOptions& options) {
  if (triangles > options.max_triangles) {
    throw LimitExceededError(std::string(display_name(format)) + " mesh has more than " +
                             std::to_string(options.max_triangles) + " triangles, the configured limit.");
  }
}
}  // namespace featureline::detail
