// Mesh reading: format names and sniffing, the read_mesh entry points, shared helpers, and the
// OBJ and STL readers.
//
// OBJ and STL are parsed here rather than through OpenMesh 9's readers, because those readers
// change the connectivity we must preserve: the OBJ reader removes repeated vertices from every
// face before adding it (so "f 1 1 3" disappears and "f 1 2 1 3" becomes a triangle), drops
// vertices whose coordinates do not parse (shifting later indices) and opens `mtllib` paths; the
// STL reader drops facets with two coinciding corners. OFF and PLY do go through OpenMesh
// (mesh_io_openmesh.cpp), glTF/GLB through tinygltf (mesh_io_gltf.cpp), Draco through
// draco::Decoder (mesh_io_draco.cpp).
#include "engine/mesh_io.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <new>
#include <sstream>
#include <system_error>

#include "engine/errors.h"
#include "engine/mesh_io_detail.h"

namespace featureline {

namespace {

char lower(char c) { return static_cast<char>(std::tolower(static_cast<unsigned char>(c))); }

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

std::uint32_t read_le32(const char* p) {
  const auto* u = reinterpret_cast<const unsigned char*>(p);
  return std::uint32_t(u[0]) | (std::uint32_t(u[1]) << 8) | (std::uint32_t(u[2]) << 16) | (std::uint32_t(u[3]) << 24);
}

float read_le_float(const char* p) {
  const std::uint32_t bits = read_le32(p);
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

// First token of an OFF header line: [ST][C][N][4][n]OFF, optionally followed by BINARY.
bool looks_like_off_keyword(std::string_view token) {
  std::string_view t = token;
  if (starts_with(t, "ST")) t.remove_prefix(2);
  if (starts_with(t, "C")) t.remove_prefix(1);
  if (starts_with(t, "N")) t.remove_prefix(1);
  if (starts_with(t, "4")) t.remove_prefix(1);
  if (starts_with(t, "n")) t.remove_prefix(1);
  return t == "OFF";
}

bool is_obj_keyword(std::string_view w) {
  static constexpr std::string_view keywords[] = {"v",      "vt",     "vn",  "vp",  "f",    "l",     "p",
                                                  "o",      "g",      "s",   "mtllib", "usemtl", "cstype", "deg",
                                                  "curv",   "curv2",  "surf", "parm", "trim", "hole",  "scrv",
                                                  "sp",     "end",    "con", "mg",  "bmat", "step",  "lod",
                                                  "maplib", "usemap", "shadow_obj", "trace_obj", "bevel", "c_interp",
                                                  "d_interp", "ctech", "stech"};
  return std::find(std::begin(keywords), std::end(keywords), w) != std::end(keywords);
}

std::optional<MeshFormat> sniff_obj(std::string_view bytes) {
  // Look at up to 400 lines / 64 KiB: every non-empty line must start with an OBJ keyword or
  // '#', and at least one must be a vertex or face line.
  const std::string_view window = bytes.substr(0, 64 * 1024);
  std::size_t pos = 0;
  bool geometry = false;
  for (int lines = 0; lines < 400 && pos < window.size(); ++lines) {
    std::size_t end = window.find('\n', pos);
    const bool complete = end != std::string_view::npos;
    if (!complete) end = window.size();
    std::string_view line = trim(window.substr(pos, end - pos));
    pos = end + 1;
    if (line.empty() || line.front() == '#') continue;
    std::size_t word_end = 0;
    while (word_end < line.size() && !is_space(line[word_end])) ++word_end;
    const std::string_view word = line.substr(0, word_end);
    if (!is_obj_keyword(word)) {
      // A truncated last line of the window is not evidence against OBJ.
      if (!complete && window.size() < bytes.size()) break;
      return std::nullopt;
    }
    if (word == "v" || word == "f") geometry = true;
  }
  if (geometry) return MeshFormat::obj;
  return std::nullopt;
}

}  // namespace

// ---- format names ---------------------------------------------------------------------

std::string to_string(MeshFormat format) {
  switch (format) {
    case MeshFormat::obj: return "obj";
    case MeshFormat::off: return "off";
    case MeshFormat::ply: return "ply";
    case MeshFormat::stl: return "stl";
    case MeshFormat::gltf: return "gltf";
    case MeshFormat::glb: return "glb";
    case MeshFormat::drc: return "drc";
  }
  return "unknown";
}

std::optional<MeshFormat> parse_mesh_format(std::string_view name) {
  static constexpr MeshFormat all[] = {MeshFormat::obj,  MeshFormat::off, MeshFormat::ply, MeshFormat::stl,
                                       MeshFormat::gltf, MeshFormat::glb, MeshFormat::drc};
  for (MeshFormat f : all) {
    if (iequals(name, to_string(f))) return f;
  }
  return std::nullopt;
}

std::optional<MeshFormat> mesh_format_from_path(std::string_view path) {
  const std::size_t slash = path.find_last_of("/\\");
  const std::string_view file = slash == std::string_view::npos ? path : path.substr(slash + 1);
  const std::size_t dot = file.rfind('.');
  if (dot == std::string_view::npos || dot + 1 >= file.size()) return std::nullopt;
  return parse_mesh_format(file.substr(dot + 1));
}

std::optional<MeshFormat> sniff_mesh_format(std::string_view bytes) {
  if (starts_with(bytes, "glTF")) return MeshFormat::glb;
  if (starts_with(bytes, "DRACO")) return MeshFormat::drc;
  if (bytes.size() >= 84) {
    const std::uint64_t triangles = read_le32(bytes.data() + 80);
    if (84 + 50 * triangles == bytes.size()) return MeshFormat::stl;
  }
  if (starts_with(bytes, "ply") && bytes.size() > 3 && (bytes[3] == '\n' || bytes[3] == '\r')) return MeshFormat::ply;

  const std::string_view text = trim(bytes.substr(0, 64 * 1024));
  std::size_t first_end = 0;
  while (first_end < text.size() && !is_space(text[first_end])) ++first_end;
  const std::string_view first = text.substr(0, first_end);
  if (looks_like_off_keyword(first)) return MeshFormat::off;
  if (!text.empty() && text.front() == '{' && text.find("\"asset\"") != std::string_view::npos) return MeshFormat::gltf;
  if (first == "solid" && text.find("facet") != std::string_view::npos) return MeshFormat::stl;
  return sniff_obj(bytes);
}

// ---- shared helpers -------------------------------------------------------------------

namespace detail {

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

// ---- OBJ ------------------------------------------------------------------------------

RawMesh read_obj(std::string_view bytes, const ReadMeshOptions& options) {
  RawMesh mesh;
  mesh.format = MeshFormat::obj;

  // Largest positive (absolute) index seen, kept to report forward references past the end.
  std::int64_t max_index = 0;
  std::size_t max_index_face = 0, max_index_line = 0;
  std::size_t ignored_lines = 0, ignored_points = 0;
  std::vector<std::uint32_t> polygon;

  std::size_t pos = 0, line_no = 0;
  while (pos < bytes.size()) {
    std::size_t end = bytes.find('\n', pos);
    if (end == std::string_view::npos) end = bytes.size();
    std::string_view line = bytes.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    const std::size_t hash = line.find('#');
    if (hash != std::string_view::npos) line = line.substr(0, hash);

    TokenScanner tokens(line);
    const auto keyword = tokens.next();
    if (!keyword) continue;

    if (*keyword == "v") {
      std::array<double, 3> p{};
      const std::size_t vertex = mesh.positions.size() + 1;
      for (int c = 0; c < 3; ++c) {
        const auto token = tokens.next();
        if (!token) {
          throw MeshFormatError("OBJ vertex " + std::to_string(vertex) + " (line " + std::to_string(line_no) +
                                ") has fewer than 3 coordinates.");
        }
        const NumberStatus status = parse_real(*token, p[c]);
        if (status == NumberStatus::non_finite) {
          throw MeshFormatError("OBJ vertex " + std::to_string(vertex) + " (line " + std::to_string(line_no) +
                                ") has a non-finite coordinate " + quote_token(*token) + ".");
        }
        if (status != NumberStatus::ok) {
          throw MeshFormatError("OBJ vertex " + std::to_string(vertex) + " (line " + std::to_string(line_no) +
                                ") has a coordinate " + quote_token(*token) + " that is not a number.");
        }
      }
      check_vertex_limit(MeshFormat::obj, mesh.positions.size() + 1, options);
      mesh.positions.push_back(p);
    } else if (*keyword == "f") {
      const std::size_t face = mesh.source_faces + 1;
      polygon.clear();
      while (const auto token = tokens.next()) {
        const std::string_view index_text = token->substr(0, token->find('/'));
        std::int64_t index = 0;
        if (!parse_integer(index_text, index)) {
          throw MeshFormatError("OBJ face " + std::to_string(face) + " (line " + std::to_string(line_no) +
                                ") has a vertex reference " + quote_token(*token) + " that is not an index.");
        }
        const auto defined = static_cast<std::int64_t>(mesh.positions.size());
        if (index == 0) {
          throw MeshFormatError("OBJ face " + std::to_string(face) + " (line " + std::to_string(line_no) +
                                ") uses vertex index 0, but OBJ indices start at 1.");
        }
        if (index < 0) {
          // Compared as index < -defined: negating index itself overflows for INT64_MIN.
          if (index < -defined) {
            throw MeshFormatError("OBJ face " + std::to_string(face) + " (line " + std::to_string(line_no) +
                                  ") uses relative vertex index " + std::to_string(index) + " but only " +
                                  std::to_string(defined) + " vertices precede it.");
          }
          index = defined + index + 1;
        }
        if (index > max_index) {
          max_index = index;
          max_index_face = face;
          max_index_line = line_no;
        }
        if (index > static_cast<std::int64_t>(std::numeric_limits<std::uint32_t>::max())) {
          throw MeshFormatError("OBJ face " + std::to_string(face) + " (line " + std::to_string(line_no) +
                                ") refers to vertex " + std::to_string(index) + ", which does not exist.");
        }
        polygon.push_back(static_cast<std::uint32_t>(index - 1));
      }
      if (polygon.size() < 3) {
        throw MeshFormatError("OBJ face " + std::to_string(face) + " (line " + std::to_string(line_no) + ") has " +
                              std::to_string(polygon.size()) + " vertices; a face needs at least 3.");
      }
      check_triangle_limit(MeshFormat::obj, mesh.triangles.size() + polygon.size() - 2, options);
      for (std::size_t k = 1; k + 1 < polygon.size(); ++k) {
        mesh.triangles.push_back({polygon[0], polygon[k], polygon[k + 1]});
      }
      ++mesh.source_faces;
    } else if (*keyword == "l") {
      ++ignored_lines;
    } else if (*keyword == "p") {
      ++ignored_points;
    }
    // Everything else (vt, vn, o, g, s, mtllib, usemtl, ...) carries nothing we need. `mtllib`
    // in particular is never opened.
  }

  if (max_index > static_cast<std::int64_t>(mesh.positions.size())) {
    throw MeshFormatError("OBJ face " + std::to_string(max_index_face) + " (line " + std::to_string(max_index_line) +
                          ") refers to vertex " + std::to_string(max_index) + " but the file has only " +
                          std::to_string(mesh.positions.size()) + " vertices.");
  }
  if (ignored_lines > 0) {
    mesh.warnings.push_back("OBJ file has " + std::to_string(ignored_lines) +
                            " line elements ('l'), which were ignored.");
  }
  if (ignored_points > 0) {
    mesh.warnings.push_back("OBJ file has " + std::to_string(ignored_points) +
                            " point elements ('p'), which were ignored.");
  }
  return mesh;
}

// ---- STL ------------------------------------------------------------------------------

namespace {

RawMesh read_stl_binary(std::string_view bytes, const ReadMeshOptions& options) {
  RawMesh mesh;
  mesh.format = MeshFormat::stl;
  mesh.welded = true;
  const std::uint32_t count = read_le32(bytes.data() + 80);
  const std::uint64_t needed = 84 + 50 * std::uint64_t(count);
  if (needed > bytes.size()) {
    throw MeshFormatError("Binary STL header claims " + std::to_string(count) + " triangles (" +
                          std::to_string(needed) + " bytes) but the file has only " + std::to_string(bytes.size()) +
                          " bytes.");
  }
  if (needed < bytes.size()) {
    mesh.warnings.push_back("Binary STL has " + std::to_string(bytes.size() - needed) + " bytes after its " +
                            std::to_string(count) + " triangles; they were ignored.");
  }
  check_triangle_limit(MeshFormat::stl, count, options);
  mesh.triangles.reserve(count);
  PositionWelder welder(mesh.positions);
  for (std::uint32_t t = 0; t < count; ++t) {
    const char* record = bytes.data() + 84 + 50 * std::size_t(t);
    std::array<std::uint32_t, 3> triangle{};
    for (int corner = 0; corner < 3; ++corner) {
      std::array<double, 3> p{};
      for (int c = 0; c < 3; ++c) {
        p[c] = read_le_float(record + 12 + 12 * corner + 4 * c);
        if (!std::isfinite(p[c])) {
          throw MeshFormatError("Binary STL triangle " + std::to_string(t + 1) + " has a non-finite coordinate at corner " +
                                std::to_string(corner + 1) + ".");
        }
      }
      triangle[corner] = welder.add(p);
    }
    mesh.triangles.push_back(triangle);
    if (welder.size() > options.max_vertices) check_vertex_limit(MeshFormat::stl, welder.size(), options);
  }
  mesh.source_faces = count;
  return mesh;
}

RawMesh read_stl_ascii(std::string_view bytes, const ReadMeshOptions& options) {
  RawMesh mesh;
  mesh.format = MeshFormat::stl;
  mesh.welded = true;
  PositionWelder welder(mesh.positions);
  TokenScanner tokens(bytes);
  bool in_facet = false;
  std::size_t facet_line = 0;
  std::vector<std::uint32_t> corners;
  const auto where = [&] { return "ASCII STL line " + std::to_string(tokens.line()); };
  while (const auto token = tokens.next()) {
    if (*token == "solid" || *token == "endsolid") {
      if (in_facet) throw MeshFormatError(where() + ": '" + std::string(*token) + "' inside a facet.");
      tokens.skip_line();  // the solid's name
    } else if (*token == "facet") {
      if (in_facet) throw MeshFormatError(where() + ": a facet starts before the previous one ended.");
      in_facet = true;
      facet_line = tokens.line();
      corners.clear();
      tokens.skip_line();  // "normal nx ny nz": not needed
    } else if (*token == "outer" || *token == "loop" || *token == "endloop") {
      if (!in_facet) throw MeshFormatError(where() + ": " + quote_token(*token) + " outside a facet.");
    } else if (*token == "vertex") {
      if (!in_facet) throw MeshFormatError(where() + ": a vertex outside a facet.");
      std::array<double, 3> p{};
      for (int c = 0; c < 3; ++c) {
        const auto value = tokens.next();
        const NumberStatus status = value ? parse_real(*value, p[c]) : NumberStatus::not_a_number;
        if (status == NumberStatus::non_finite) {
          throw MeshFormatError(where() + ": vertex of facet " + std::to_string(mesh.triangles.size() + 1) +
                                " has a non-finite coordinate " + quote_token(*value) + ".");
        }
        if (status != NumberStatus::ok) {
          throw MeshFormatError(where() + ": vertex of facet " + std::to_string(mesh.triangles.size() + 1) +
                                " needs 3 numeric coordinates.");
        }
      }
      corners.push_back(welder.add(p));
      if (welder.size() > options.max_vertices) check_vertex_limit(MeshFormat::stl, welder.size(), options);
    } else if (*token == "endfacet") {
      if (!in_facet) throw MeshFormatError(where() + ": 'endfacet' without a facet.");
      if (corners.size() != 3) {
        throw MeshFormatError("ASCII STL facet " + std::to_string(mesh.triangles.size() + 1) + " (line " +
                              std::to_string(facet_line) + ") has " + std::to_string(corners.size()) +
                              " vertices; STL facets are triangles.");
      }
      check_triangle_limit(MeshFormat::stl, mesh.triangles.size() + 1, options);
      mesh.triangles.push_back({corners[0], corners[1], corners[2]});
      in_facet = false;
    } else {
      throw MeshFormatError(where() + ": unexpected " + quote_token(*token) + ".");
    }
  }
  if (in_facet) throw MeshFormatError("ASCII STL ends inside a facet (started on line " + std::to_string(facet_line) + ").");
  mesh.source_faces = mesh.triangles.size();
  return mesh;
}

}  // namespace

RawMesh read_stl(std::string_view bytes, const ReadMeshOptions& options) {
  // Binary when the size matches the triangle count exactly (some binary files start with
  // "solid" too); ASCII when it starts with "solid"; otherwise binary with a checked header.
  if (bytes.size() >= 84 && 84 + 50 * std::uint64_t(read_le32(bytes.data() + 80)) == bytes.size()) {
    return read_stl_binary(bytes, options);
  }
  // ASCII only when the start reads as text: binary files may also begin with "solid".
  const std::string_view head = bytes.substr(0, 1024);
  const std::string_view text = trim(head);
  const bool textual = std::none_of(head.begin(), head.end(), [](char c) {
    const auto u = static_cast<unsigned char>(c);
    return u < 0x20 && !is_space(c);
  });
  if (textual && starts_with(text, "solid") && (text.size() == 5 || is_space(text[5]))) return read_stl_ascii(bytes, options);
  if (bytes.size() < 84) {
    throw MeshFormatError("STL file has only " + std::to_string(bytes.size()) +
                          " bytes: too short for a binary STL header (84 bytes) and it does not start with 'solid'.");
  }
  return read_stl_binary(bytes, options);
}

}  // namespace detail

// ---- entry points ---------------------------------------------------------------------

ReadMeshOptions read_limits_for(std::size_t max_input_bytes, std::size_t memory_budget_bytes) {
  constexpr std::size_t min_bytes_per_element = 12;
  constexpr std::size_t min_prepared_bytes_per_triangle = 128;
  const std::size_t elements =
      std::max<std::size_t>(1, std::min(max_input_bytes / min_bytes_per_element, memory_budget_bytes / min_prepared_bytes_per_triangle));
  ReadMeshOptions options;
  options.max_vertices = std::min(options.max_vertices, elements);
  options.max_triangles = std::min(options.max_triangles, elements);
  options.max_file_bytes = max_input_bytes;
  return options;
}

RawMesh read_mesh(std::string_view bytes, MeshFormat format, const ReadMeshOptions& options) {
  const std::string name = detail::display_name(format);
  if (bytes.empty()) throw MeshFormatError(name + " input is empty.");

  RawMesh mesh;
  try {
    switch (format) {
      case MeshFormat::obj: mesh = detail::read_obj(bytes, options); break;
      case MeshFormat::off: mesh = detail::read_off(bytes, options); break;
      case MeshFormat::ply: mesh = detail::read_ply(bytes, options); break;
      case MeshFormat::stl: mesh = detail::read_stl(bytes, options); break;
      case MeshFormat::gltf: mesh = detail::read_gltf(bytes, false, options); break;
      case MeshFormat::glb: mesh = detail::read_gltf(bytes, true, options); break;
      case MeshFormat::drc: mesh = detail::read_drc(bytes, options); break;
      default: throw UnsupportedFormatError("Mesh format " + std::to_string(static_cast<int>(format)) + " is not supported.");
    }
  } catch (const Error&) {
    throw;
  } catch (const std::bad_alloc&) {
    // Every count is checked against the input size first, so this means the input is simply too big.
    throw LimitExceededError(name + " input needs more memory than is available.");
  } catch (const std::exception& e) {
    // Third-party code (tinygltf, Draco, OpenMesh) may throw its own exceptions on malformed input.
    throw MeshFormatError(name + " input could not be read (" + std::string(e.what()) + ").");
  }
  mesh.format = format;

  // The readers check all of this already; checking once more here keeps the RawMesh contract
  // in one place whatever a reader does.
  if (mesh.positions.empty()) throw MeshFormatError(name + " input contains no vertices.");
  if (mesh.triangles.empty()) throw MeshFormatError(name + " input contains no triangles.");
  detail::check_vertex_limit(format, mesh.positions.size(), options);
  detail::check_triangle_limit(format, mesh.triangles.size(), options);
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    const auto& p = mesh.positions[v];
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) {
      throw MeshFormatError(name + " vertex " + std::to_string(v + 1) + " has a non-finite coordinate.");
    }
  }
  const std::size_t n = mesh.positions.size();
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    for (std::uint32_t i : mesh.triangles[t]) {
      if (i >= n) {
        throw MeshFormatError(name + " triangle " + std::to_string(t + 1) + " refers to vertex " + std::to_string(i + 1) +
                              " but there are only " + std::to_string(n) + " vertices.");
      }
    }
  }
  return mesh;
}

RawMesh read_mesh_file(const std::string& path, const ReadMeshOptions& options) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(status)) throw MeshFormatError("Cannot open mesh file '" + path + "': it does not exist.");
  if (!std::filesystem::is_regular_file(status)) {
    throw MeshFormatError("Cannot open mesh file '" + path + "': it is not a regular file.");
  }
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) throw MeshFormatError("Cannot open mesh file '" + path + "': " + ec.message() + ".");
  if (size > options.max_file_bytes) {
    throw LimitExceededError("Mesh file '" + path + "' has " + std::to_string(size) + " bytes, more than the limit of " +
                             std::to_string(options.max_file_bytes) + " bytes.");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw MeshFormatError("Cannot open mesh file '" + path + "'.");
  std::string bytes(static_cast<std::size_t>(size), '\0');
  in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (in.gcount() != static_cast<std::streamsize>(bytes.size())) {
    throw MeshFormatError("Cannot read mesh file '" + path + "': it ended early.");
  }
  std::optional<MeshFormat> format = mesh_format_from_path(path);
  if (!format) format = sniff_mesh_format(bytes);
  if (!format) {
    throw UnsupportedFormatError("Cannot tell the format of mesh file '" + path +
                                 "' from its extension or content (supported: obj, off, ply, stl, gltf, glb, drc).");
  }
  return read_mesh(bytes, *format, options);
}

}  // namespace featureline
