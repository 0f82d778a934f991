#include "engine/io/ply_header.h"

#include <limits>

#include "engine/errors.h"
#include "engine/io/reader_support.h"

namespace featureline::detail {

std::optional<PlyType> parse_ply_type(std::string_view name) {
  if (name == "char" || name == "int8") return PlyType::int8;
  if (name == "uchar" || name == "uint8") return PlyType::uint8;
  if (name == "short" || name == "int16") return PlyType::int16;
  if (name == "ushort" || name == "uint16") return PlyType::uint16;
  if (name == "int" || name == "int32") return PlyType::int32;
  if (name == "uint" || name == "uint32") return PlyType::uint32;
  if (name == "float" || name == "float32") return PlyType::float32;
  if (name == "double" || name == "float64") return PlyType::float64;
  return std::nullopt;
}

std::size_t ply_type_size(PlyType type) {
  switch (type) {
    case PlyType::int8:
    case PlyType::uint8: return 1;
    case PlyType::int16:
    case PlyType::uint16: return 2;
    case PlyType::int32:
    case PlyType::uint32:
    case PlyType::float32: return 4;
    case PlyType::float64: return 8;
  }
  return 1;
}

bool is_integer_type(PlyType type) { return type != PlyType::float32 && type != PlyType::float64; }

namespace {

void parse_format_line(TokenScanner& line, const std::string& where, PlyHeader& header) {
  const auto kind = line.next();
  const auto version = line.next();
  if (!kind || !version) throw MeshFormatError(where + ": incomplete format line.");
  if (*kind == "ascii") {
    header.encoding = PlyEncoding::ascii;
  } else if (*kind == "binary_little_endian") {
    header.encoding = PlyEncoding::binary_little_endian;
  } else if (*kind == "binary_big_endian") {
    header.encoding = PlyEncoding::binary_big_endian;
  } else {
    throw MeshFormatError(where + ": unknown format " + quote_token(*kind) + ".");
  }
  if (*version != "1.0") throw MeshFormatError(where + ": unsupported PLY version " + quote_token(*version) + ".");
}

void parse_element_line(TokenScanner& line, const std::string& where, PlyHeader& header) {
  const auto name = line.next();
  const auto count = line.next();
  std::int64_t n = 0;
  if (!name || !count || !parse_integer(*count, n) || n < 0) throw MeshFormatError(where + ": malformed element line.");
  if (static_cast<std::uint64_t>(n) > std::numeric_limits<std::uint32_t>::max()) {
    throw MeshFormatError("PLY header claims " + std::to_string(n) + " " + std::string(*name) +
                          " elements, more than a PLY reader can index.");
  }
  if (header.elements.size() >= 64) throw MeshFormatError("PLY header declares too many elements.");
  header.elements.push_back({std::string(*name), static_cast<std::uint64_t>(n), {}});
}

void parse_property_line(TokenScanner& line, const std::string& where, PlyHeader& header) {
  if (header.elements.empty()) throw MeshFormatError(where + ": property before any element.");
  PlyProperty property;
  const auto type = line.next();
  if (!type) throw MeshFormatError(where + ": malformed property line.");
  if (*type == "list") {
    const auto count_type = line.next();
    const auto item_type = line.next();
    const auto ct = count_type ? parse_ply_type(*count_type) : std::nullopt;
    const auto it = item_type ? parse_ply_type(*item_type) : std::nullopt;
    if (!ct || !it) throw MeshFormatError(where + ": unknown list property types.");
    if (!is_integer_type(*ct)) throw MeshFormatError(where + ": a list count must have an integer type.");
    property.is_list = true;
    property.count_type = *ct;
    property.type = *it;
  } else {
    const auto pt = parse_ply_type(*type);
    if (!pt) throw MeshFormatError(where + ": unknown property type " + quote_token(*type) + ".");
    property.type = *pt;
  }
  const auto name = line.next();
  if (!name) throw MeshFormatError(where + ": property without a name.");
  property.name = std::string(*name);
  if (header.elements.back().properties.size() >= 256) throw MeshFormatError(where + ": too many properties.");
  header.elements.back().properties.push_back(std::move(property));
}

}  // namespace

PlyHeader parse_ply_header(std::string_view bytes) {
  PlyHeader header;
  std::size_t pos = 0;
  std::size_t line_no = 0;
  bool have_format = false;
  constexpr std::size_t max_header_bytes = 1 << 20;
  while (true) {
    const std::size_t end = pos > max_header_bytes ? std::string_view::npos : bytes.find('\n', pos);
    if (end == std::string_view::npos) throw MeshFormatError("PLY header has no 'end_header' line.");
    std::string_view text = bytes.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    if (!text.empty() && text.back() == '\r') text.remove_suffix(1);
    TokenScanner line(text);
    const auto word = line.next();
    const std::string where = "PLY header line " + std::to_string(line_no);
    if (line_no == 1) {
      if (!word || *word != "ply" || line.next()) throw MeshFormatError("PLY file does not start with 'ply'.");
      continue;
    }
    if (!word || *word == "comment" || *word == "obj_info") continue;
    if (*word == "format") {
      parse_format_line(line, where, header);
      have_format = true;
    } else if (*word == "element") {
      parse_element_line(line, where, header);
    } else if (*word == "property") {
      parse_property_line(line, where, header);
    } else if (*word == "end_header") {
      break;
    } else {
      throw MeshFormatError(where + ": unexpected keyword " + quote_token(*word) + ".");
    }
  }
  if (!have_format) throw MeshFormatError("PLY header has no format line.");
  header.data_start = pos;
  header.header_lines = line_no;
  return header;
}

}  // namespace featureline::detail
