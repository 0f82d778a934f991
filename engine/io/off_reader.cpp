// ASCII OFF in one validating pass, in double precision: vertex i is the file's i-th vertex
// record, polygons are fan-triangulated in file order.
//
// Every count is checked against the byte size before anything is reserved (OpenMesh's reader
// reserved whatever a lying header claimed), and every token must parse (OpenMesh turned a
// garbage token into millions of vertices and a `nan` into garbage indices).
#include <cstdint>
#include <string>
#include <vector>

#include "engine/errors.h"
#include "engine/io/reader_support.h"
#include "engine/io/readers.h"

namespace featureline::detail {

namespace {

/// OFF tokens, with comments ('#' to the end of the line) skipped wherever they appear.
class OffTokens {
 public:
  explicit OffTokens(std::string_view bytes) : bytes_(bytes), tokens_(bytes) {}
  std::optional<std::string_view> next() {
    while (true) {
      auto t = tokens_.next();
      if (!t || t->front() != '#') return t;
      tokens_.skip_line();
    }
  }
  /// Skips what follows a record on its line (vertex normals and colours, face colours).
  void skip_line() { tokens_.skip_line(); }
  std::size_t line() const { return tokens_.line(); }
  std::string line_text() const { return " (line " + std::to_string(tokens_.line()) + ")"; }
  std::size_t remaining_bytes() const { return bytes_.size() - tokens_.position(); }
  std::size_t total_bytes() const { return bytes_.size(); }

 private:
  std::string_view bytes_;
  TokenScanner tokens_;
};

struct OffCounts {
  std::uint64_t vertices = 0;
  std::uint64_t faces = 0;
};

/// [ST][C][N]OFF: texture coordinates, colours and normals follow the coordinates on each vertex
/// line and are skipped; 4OFF and nOFF (other vertex dimensions) are refused.
void check_off_keyword(std::string_view keyword) {
  std::string_view k = keyword;
  if (starts_with(k, "ST")) k.remove_prefix(2);
  if (starts_with(k, "C")) k.remove_prefix(1);
  if (starts_with(k, "N")) k.remove_prefix(1);
  if (starts_with(k, "4") || starts_with(k, "n")) {
    throw MeshFormatError("OFF variant " + quote_token(keyword) + " (vertex dimension other than 3) is not supported.");
  }
  if (k != "OFF") throw MeshFormatError("OFF file does not start with an OFF keyword (found " + quote_token(keyword) + ").");
}

/// The keyword and the vertex, face and edge counts, checked against the bytes that follow.
OffCounts read_off_header(OffTokens& tokens, const ReadMeshOptions& options) {
  const auto keyword = tokens.next();
  if (!keyword) throw MeshFormatError("OFF input is empty.");
  check_off_keyword(*keyword);
  const std::size_t header_line = tokens.line();

  std::int64_t counts[3] = {0, 0, 0};
  for (int i = 0; i < 3; ++i) {
    const auto t = tokens.next();
    if (t && i == 0 && *t == "BINARY" && tokens.line() == header_line) {
      throw MeshFormatError("Binary OFF is not supported; use ASCII OFF or PLY.");
    }
    if (!t) throw MeshFormatError("OFF header ends before its vertex, face and edge counts.");
    if (!parse_integer(*t, counts[i]) || counts[i] < 0) {
      throw MeshFormatError("OFF header has an invalid count " + quote_token(*t) + tokens.line_text() + ".");
    }
  }
  const OffCounts n{static_cast<std::uint64_t>(counts[0]), static_cast<std::uint64_t>(counts[1])};
  const std::size_t remaining = tokens.remaining_bytes();
  const std::string file_bytes = std::to_string(tokens.total_bytes());
  // Each ASCII vertex needs at least 6 bytes ("0 0 0\n"), each face at least 8 ("3 0 1 2\n").
  if (n.vertices > (remaining + 1) / 6) {
    throw MeshFormatError("OFF header claims " + std::to_string(n.vertices) + " vertices but the file has only " +
                          file_bytes + " bytes.");
  }
  if (n.faces > (remaining + 1) / 8 || 6 * n.vertices + 8 * n.faces > remaining + 2) {
    throw MeshFormatError("OFF header claims " + std::to_string(n.vertices) + " vertices and " + std::to_string(n.faces) +
                          " faces but the file has only " + file_bytes + " bytes.");
  }
  check_vertex_limit(MeshFormat::off, n.vertices, options);
  check_triangle_limit(MeshFormat::off, n.faces, options);
  if (n.vertices == 0) throw MeshFormatError("OFF input contains no vertices.");
  if (n.faces == 0) throw MeshFormatError("OFF input contains no faces.");
  return n;
}

void read_off_vertices(OffTokens& tokens, std::uint64_t count, std::vector<std::array<double, 3>>& positions) {
  positions.reserve(count);  // bounded by the byte size (read_off_header)
  for (std::uint64_t v = 0; v < count; ++v) {
    std::array<double, 3> p{};
    for (int c = 0; c < 3; ++c) {
      const auto t = tokens.next();
      if (!t) {
        throw MeshFormatError("OFF file ends after " + std::to_string(v) + " of its " + std::to_string(count) + " vertices.");
      }
      const NumberStatus status = parse_real(*t, p[c]);
      if (status == NumberStatus::non_finite) {
        throw MeshFormatError("OFF vertex " + std::to_string(v + 1) + tokens.line_text() + " has a non-finite coordinate " +
                              quote_token(*t) + ".");
      }
      if (status != NumberStatus::ok) {
        throw MeshFormatError("OFF vertex " + std::to_string(v + 1) + tokens.line_text() + " has a coordinate " +
                              quote_token(*t) + " that is not a number.");
      }
    }
    positions.push_back(p);
    tokens.skip_line();  // normals, colours, texture coordinates
  }
}

/// Reads face `face` (0-based), whose vertex count `size_token` was just read, into `corners`
/// (checked indices). `triangles` counts the triangles before it, for the limit.
void read_off_face(OffTokens& tokens, std::string_view size_token, std::uint64_t face, std::uint64_t n_vertices,
                   std::size_t triangles, const ReadMeshOptions& options, std::vector<std::uint32_t>& corners) {
  const std::size_t line = tokens.line();  // messages name the line where the face starts
  const auto where = [&] { return "OFF face " + std::to_string(face + 1) + " (line " + std::to_string(line) + ")"; };
  std::int64_t size = 0;
  if (!parse_integer(size_token, size) || size < 0) {
    throw MeshFormatError(where() + " has an invalid vertex count " + quote_token(size_token) + ".");
  }
  if (size < 3) throw MeshFormatError(where() + " has " + std::to_string(size) + " vertices; a face needs at least 3.");
  if (static_cast<std::uint64_t>(size) > tokens.remaining_bytes() / 2 + 1) {
    throw MeshFormatError(where() + " claims " + std::to_string(size) + " vertices, more than the rest of the file can hold.");
  }
  check_triangle_limit(MeshFormat::off, triangles + static_cast<std::size_t>(size) - 2, options);
  corners.clear();
  for (std::int64_t k = 0; k < size; ++k) {
    const auto it = tokens.next();
    std::int64_t index = 0;
    if (!it || !parse_integer(*it, index)) {
      throw MeshFormatError(where() + " has " +
                            (it ? "an invalid vertex index " + quote_token(*it) : std::string("too few vertex indices")) + ".");
    }
    if (index < 0 || static_cast<std::uint64_t>(index) >= n_vertices) {
      throw MeshFormatError(where() + " refers to vertex index " + std::to_string(index) + " but the file has only " +
                            std::to_string(n_vertices) + " vertices (indices start at 0).");
    }
    corners.push_back(static_cast<std::uint32_t>(index));
  }
  tokens.skip_line();  // face colours
}

}  // namespace

RawMesh read_off(std::string_view bytes, const ReadMeshOptions& options) {
  OffTokens tokens(bytes);
  const OffCounts counts = read_off_header(tokens, options);
  RawMesh mesh;
  mesh.format = MeshFormat::off;
  read_off_vertices(tokens, counts.vertices, mesh.positions);

  mesh.triangles.reserve(counts.faces);  // bounded by the byte size (read_off_header)
  std::vector<std::uint32_t> corners;
  for (std::uint64_t f = 0; f < counts.faces; ++f) {
    const auto size_token = tokens.next();
    if (!size_token) {
      throw MeshFormatError("OFF file ends after " + std::to_string(f) + " of its " + std::to_string(counts.faces) + " faces.");
    }
    read_off_face(tokens, *size_token, f, counts.vertices, mesh.triangles.size(), options, corners);
    for (std::size_t k = 1; k + 1 < corners.size(); ++k) mesh.triangles.push_back({corners[0], corners[k], corners[k + 1]});
  }
  mesh.source_faces = counts.faces;
  return mesh;
}

}  // namespace featureline::detail
