// The PLY header: format, elements and their properties (Greg Turk's PLY 1.0). Private to
// engine/io/.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace featureline::detail {

enum class PlyType { int8, uint8, int16, uint16, int32, uint32, float32, float64 };

/// "char"/"int8", "uchar"/"uint8", ... "double"/"float64"; std::nullopt for anything else.
std::optional<PlyType> parse_ply_type(std::string_view name);
/// Bytes per value in the binary encodings.
std::size_t ply_type_size(PlyType type);
bool is_integer_type(PlyType type);

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::float32;  ///< the value type, or a list's item type
  bool is_list = false;
  PlyType count_type = PlyType::uint8;  ///< a list's length type
};

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::vector<PlyProperty> properties;
};

enum class PlyEncoding { ascii, binary_little_endian, binary_big_endian };

struct PlyHeader {
  PlyEncoding encoding = PlyEncoding::ascii;
  std::vector<PlyElement> elements;
  std::size_t data_start = 0;    ///< byte offset of the body, after "end_header\n"
  std::size_t header_lines = 0;  ///< lines of the header, so ASCII body lines can be numbered
};

/// Parses and checks the header (at most 1 MiB, 64 elements, 256 properties per element).
/// \throw MeshFormatError
PlyHeader parse_ply_header(std::string_view bytes);

}  // namespace featureline::detail
