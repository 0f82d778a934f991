// Mesh reading: format names and sniffing, and the read_mesh entry points that dispatch to the
// per-format readers of engine/io/ and check their result once more.
//
// OBJ, STL, OFF and PLY are parsed by our own readers in one validating pass (double precision,
// file order kept, every count checked against the byte size): OpenMesh 9's readers change the
// connectivity we must preserve (its OBJ reader drops repeated corners, its STL reader drops
// facets with coinciding corners), read OFF and PLY coordinates as float, trust lying headers
// and are not thread-safe. glTF/GLB go through tinygltf (gltf_reader.cpp), Draco through
// draco::Decoder (draco_reader.cpp).
#include "engine/mesh_io.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <new>
#include <system_error>

#include "engine/errors.h"
#include "engine/io/byte_order.h"
#include "engine/io/reader_support.h"
#include "engine/io/readers.h"

namespace featureline {

namespace {

using detail::is_space;

std::string format_number(double x) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", x);
  return text;
}
using detail::starts_with;
using detail::trim;

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

std::optional<MeshFormat> parse_mesh_format(std::string_view name) {
  // EnumNames' table, in any case: file extensions and ?format= come in both.
  for (const auto& entry : EnumNames<MeshFormat>::entries)
    if (detail::iequals(name, entry.second)) return entry.first;
  return std::nullopt;
}

std::string supported_formats() {
  std::string names;
  for (const auto& entry : EnumNames<MeshFormat>::entries) names += (names.empty() ? "" : ", ") + std::string(entry.second);
  return names;
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
    const std::uint64_t triangles = detail::load_little_endian<std::uint32_t>(bytes.data() + 80);
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


// ---- entry points ---------------------------------------------------------------------

ReadMeshOptions read_limits_for(std::size_t max_input_bytes, std::size_t memory_budget_bytes) {
  constexpr std::size_t min_bytes_per_element = 12;
  const std::size_t by_input = max_input_bytes / min_bytes_per_element;
  ReadMeshOptions options;
  options.max_vertices = std::max<std::size_t>(1, std::min({options.max_vertices, by_input, memory_budget_bytes / kPreparingBytesPerVertex}));
  options.max_triangles =
      std::max<std::size_t>(1, std::min({options.max_triangles, by_input, memory_budget_bytes / kPreparingBytesPerTriangle}));
  options.max_file_bytes = max_input_bytes;
  options.memory_budget_bytes = memory_budget_bytes;
  return options;
}

namespace {

// The engine squares and multiplies coordinate differences (normals, jets to third order,
// areas): within these bounds none of that overflows or underflows to zero. A mesh with 1e300
// coordinates had been accepted and answered lines whose lengths were NaN.
constexpr double kMaxCoordinate = 1e15;
constexpr double kMinExtent = 1e-30;

void check_coordinate_range(const std::string& name, const std::vector<std::array<double, 3>>& positions) {
  std::array<double, 3> low = positions.front(), high = positions.front();
  for (std::size_t v = 0; v < positions.size(); ++v) {
    const auto& p = positions[v];
    for (int k = 0; k < 3; ++k) {
      if (!std::isfinite(p[k])) throw MeshFormatError(name + " vertex " + std::to_string(v + 1) + " has a non-finite coordinate.");
      if (std::abs(p[k]) > kMaxCoordinate)
        throw MeshFormatError(name + " vertex " + std::to_string(v + 1) + " has a coordinate of magnitude " + format_number(std::abs(p[k])) +
                              ", above the 1e15 this engine computes with; scale the mesh.");
      low[k] = std::min(low[k], p[k]);
      high[k] = std::max(high[k], p[k]);
    }
  }
  const double extent = std::hypot(high[0] - low[0], high[1] - low[1], high[2] - low[2]);
  if (extent > 0 && extent < kMinExtent)  // no extent at all: every triangle is degenerate, as prepare_mesh reports
    throw MeshFormatError(name + " input spans " + format_number(extent) + " units, less than the 1e-30 this engine computes with; scale the mesh.");
}

}  // namespace

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
    // Third-party code (tinygltf, Draco, nlohmann::json) may throw its own exceptions on malformed input.
    throw MeshFormatError(name + " input could not be read (" + std::string(e.what()) + ").");
  }
  mesh.format = format;

  // The readers check all of this already; checking once more here keeps the RawMesh contract
  // in one place whatever a reader does.
  if (mesh.positions.empty()) throw MeshFormatError(name + " input contains no vertices.");
  if (mesh.triangles.empty()) throw MeshFormatError(name + " input contains no triangles.");
  detail::check_vertex_limit(format, mesh.positions.size(), options);
  detail::check_triangle_limit(format, mesh.triangles.size(), options);
  check_coordinate_range(name, mesh.positions);
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

MeshFile read_mesh_file_bytes(const std::string& path, const ReadMeshOptions& options) {
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
  MeshFile file;
  std::string& bytes = file.bytes;
  bytes.assign(static_cast<std::size_t>(size), '\0');
  in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (in.gcount() != static_cast<std::streamsize>(bytes.size())) {
    throw MeshFormatError("Cannot read mesh file '" + path + "': it ended early.");
  }
  std::optional<MeshFormat> format = mesh_format_from_path(path);
  if (!format) format = sniff_mesh_format(bytes);
  if (!format) {
    throw UnsupportedFormatError("Cannot tell the format of mesh file '" + path +
                                 "' from its extension or content (supported: " + supported_formats() + ").");
  }
  file.format = *format;
  return file;
}

RawMesh read_mesh_file(const std::string& path, const ReadMeshOptions& options) {
  const MeshFile file = read_mesh_file_bytes(path, options);
  return read_mesh(file.bytes, file.format, options);
}

}  // namespace featureline
