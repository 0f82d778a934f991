// Private helpers shared by the mesh readers in engine/io/. Not part of the engine API.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "engine/errors.h"
#include "engine/mesh_io.h"

namespace featureline::detail {

/// "OBJ", "OFF", "PLY", "STL", "glTF", "GLB", "Draco": the name used in messages.
const char* display_name(MeshFormat format);

// ---- text ----------------------------------------------------------------------------

bool is_space(char c);
bool starts_with(std::string_view s, std::string_view prefix);
/// Case-insensitive ASCII comparison.
bool iequals(std::string_view a, std::string_view b);
std::string_view trim(std::string_view s);

// ---- strict number parsing (locale independent) ------------------------------------

enum class NumberStatus { ok, not_a_number, non_finite };

/// Parses a decimal real ("-1.5e-3", "2", ".5") to the nearest double. "nan"/"inf" spellings and
/// overflowing values give non_finite; anything else that is not plain decimal (hex floats, "1,5",
/// "") gives not_a_number.
NumberStatus parse_real(std::string_view token, double& value);

/// Parses an optionally signed decimal integer that fits in int64.
bool parse_integer(std::string_view token, std::int64_t& value);

/// Quotes a token for an error message, shortened to a sensible length.
std::string quote_token(std::string_view token);

/// Splits text into whitespace-separated tokens while tracking line numbers.
class TokenScanner {
 public:
  explicit TokenScanner(std::string_view text, std::size_t start = 0, std::size_t first_line = 1)
      : text_(text), pos_(start), line_(first_line) {}
  /// Next token, or std::nullopt at the end. `line()` then is the token's line (1-based).
  std::optional<std::string_view> next();
  /// Skips the rest of the current line (after the last token returned).
  void skip_line();
  std::size_t line() const { return line_; }
  std::size_t position() const { return pos_; }

 private:
  std::string_view text_;
  std::size_t pos_ = 0;
  std::size_t line_ = 1;
};

// ---- welding -------------------------------------------------------------------------

/// Merges positions by exact value (bit-identical doubles, with -0 treated as +0), keeping the
/// order of first occurrence.
class PositionWelder {
 public:
  explicit PositionWelder(std::vector<std::array<double, 3>>& positions) : positions_(positions) {}
  std::uint32_t add(const std::array<double, 3>& p);
  std::size_t size() const { return positions_.size(); }

 private:
  struct Key {
    std::array<std::uint64_t, 3> bits;
    bool operator==(const Key& o) const { return bits == o.bits; }
  };
  struct KeyHash {
    std::size_t operator()(const Key& k) const;
  };
  std::vector<std::array<double, 3>>& positions_;
  std::unordered_map<Key, std::uint32_t, KeyHash> index_;
};

// ---- limits --------------------------------------------------------------------------

void check_vertex_limit(MeshFormat format, std::size_t vertices, const ReadMeshOptions& options);
void check_triangle_limit(MeshFormat format, std::size_t triangles, const ReadMeshOptions& options);

}  // namespace featureline::detail
