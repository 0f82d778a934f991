// OBJ: vertices and polygon faces (fan-triangulated in file order), read line by line in
// double precision. Ids are the file's own: vertex i is the i-th `v` line, and a face with a
// repeated corner is kept (prepare_mesh reports it), unlike OpenMesh's reader, which removes
// repeated corners, drops vertices it cannot parse (shifting later indices) and opens `mtllib`.
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "engine/errors.h"
#include "engine/io/reader_support.h"
#include "engine/io/readers.h"

namespace featureline::detail {

namespace {

/// What the line-by-line pass carries from line to line.
struct ObjReadState {
  RawMesh mesh;
  /// Largest positive (absolute) index seen, kept to report forward references past the end.
  std::int64_t max_index = 0;
  std::size_t max_index_face = 0, max_index_line = 0;
  std::size_t ignored_lines = 0, ignored_points = 0;
  std::vector<std::uint32_t> polygon;  // reused for every face
};

void read_obj_vertex(TokenScanner& tokens, std::size_t line_no, const ReadMeshOptions& options, RawMesh& mesh) {
  std::array<double, 3> p{};
  // Messages are built only when one is thrown: this runs once per vertex.
  const auto where = [&] {
    return "OBJ vertex " + std::to_string(mesh.positions.size() + 1) + " (line " + std::to_string(line_no) + ")";
  };
  for (int c = 0; c < 3; ++c) {
    const auto token = tokens.next();
    if (!token) throw MeshFormatError(where() + " has fewer than 3 coordinates.");
    const NumberStatus status = parse_real(*token, p[c]);
    if (status == NumberStatus::non_finite) {
      throw MeshFormatError(where() + " has a non-finite coordinate " + quote_token(*token) + ".");
    }
    if (status != NumberStatus::ok) {
      throw MeshFormatError(where() + " has a coordinate " + quote_token(*token) + " that is not a number.");
    }
  }
  check_vertex_limit(MeshFormat::obj, mesh.positions.size() + 1, options);
  mesh.positions.push_back(p);
}

/// The 1-based absolute index a face corner token ("7", "-2", "7/3/1") refers to; `where()` names
/// the face in messages.
template <typename Where>
std::int64_t obj_corner_index(std::string_view token, std::int64_t defined, const Where& where) {
  const std::string_view index_text = token.substr(0, token.find('/'));
  std::int64_t index = 0;
  if (!parse_integer(index_text, index)) {
    throw MeshFormatError(where() + " has a vertex reference " + quote_token(token) + " that is not an index.");
  }
  if (index == 0) throw MeshFormatError(where() + " uses vertex index 0, but OBJ indices start at 1.");
  if (index < 0) {
    // Compared as index < -defined: negating index itself overflows for INT64_MIN.
    if (index < -defined) {
      throw MeshFormatError(where() + " uses relative vertex index " + std::to_string(index) + " but only " +
                            std::to_string(defined) + " vertices precede it.");
    }
    index = defined + index + 1;
  }
  if (index > static_cast<std::int64_t>(std::numeric_limits<std::uint32_t>::max())) {
    throw MeshFormatError(where() + " refers to vertex " + std::to_string(index) + ", which does not exist.");
  }
  return index;
}

void read_obj_face(TokenScanner& tokens, std::size_t line_no, const ReadMeshOptions& options, ObjReadState& state) {
  RawMesh& mesh = state.mesh;
  const std::size_t face = mesh.source_faces + 1;
  const auto where = [&] { return "OBJ face " + std::to_string(face) + " (line " + std::to_string(line_no) + ")"; };
  state.polygon.clear();
  while (const auto token = tokens.next()) {
    const std::int64_t index = obj_corner_index(*token, static_cast<std::int64_t>(mesh.positions.size()), where);
    if (index > state.max_index) {
      state.max_index = index;
      state.max_index_face = face;
      state.max_index_line = line_no;
    }
    state.polygon.push_back(static_cast<std::uint32_t>(index - 1));
  }
  const auto& polygon = state.polygon;
  if (polygon.size() < 3) {
    throw MeshFormatError(where() + " has " + std::to_string(polygon.size()) + " vertices; a face needs at least 3.");
  }
  check_triangle_limit(MeshFormat::obj, mesh.triangles.size() + polygon.size() - 2, options);
  for (std::size_t k = 1; k + 1 < polygon.size(); ++k) mesh.triangles.push_back({polygon[0], polygon[k], polygon[k + 1]});
  ++mesh.source_faces;
}

}  // namespace

RawMesh read_obj(std::string_view bytes, const ReadMeshOptions& options) {
  ObjReadState state;
  state.mesh.format = MeshFormat::obj;
  std::size_t pos = 0, line_no = 0;
  while (pos < bytes.size()) {
    std::size_t end = bytes.find('\n', pos);
    if (end == std::string_view::npos) end = bytes.size();
    std::string_view line = bytes.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    line = line.substr(0, line.find('#'));

    TokenScanner tokens(line);
    const auto keyword = tokens.next();
    if (!keyword) continue;
    if (*keyword == "v") {
      read_obj_vertex(tokens, line_no, options, state.mesh);
    } else if (*keyword == "f") {
      read_obj_face(tokens, line_no, options, state);
    } else if (*keyword == "l") {
      ++state.ignored_lines;
    } else if (*keyword == "p") {
      ++state.ignored_points;
    }
    // Everything else (vt, vn, o, g, s, mtllib, usemtl, ...) carries nothing we need. `mtllib`
    // in particular is never opened.
  }

  RawMesh& mesh = state.mesh;
  if (state.max_index > static_cast<std::int64_t>(mesh.positions.size())) {
    throw MeshFormatError("OBJ face " + std::to_string(state.max_index_face) + " (line " +
                          std::to_string(state.max_index_line) + ") refers to vertex " + std::to_string(state.max_index) +
                          " but the file has only " + std::to_string(mesh.positions.size()) + " vertices.");
  }
  if (state.ignored_lines > 0) {
    mesh.warnings.push_back("OBJ file has " + std::to_string(state.ignored_lines) +
                            " line elements ('l'), which were ignored.");
  }
  if (state.ignored_points > 0) {
    mesh.warnings.push_back("OBJ file has " + std::to_string(state.ignored_points) +
                            " point elements ('p'), which were ignored.");
  }
  return std::move(state.mesh);
}

}  // namespace featureline::detail
