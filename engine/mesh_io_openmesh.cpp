// OFF and PLY through OpenMesh 9's readers, made safe for untrusted input.
//
// OpenMesh's readers trust their input: a lying header makes them reserve billions of elements,
// a token that does not parse leaves variables uninitialised (a `nan` in ASCII OFF produced
// garbage indices), list properties in elements they do not know are skipped as if they were
// scalars, and their singletons are not thread-safe. So every file is first parsed and validated
// here (counts against the byte size, every number, every index); the validated content is then
// written as a minimal canonical OFF/PLY stream (positions and face index lists only), which
// OpenMesh reads, under one process-wide mutex, into a recording importer that keeps the raw
// vertex and face arrays exactly as the reader emits them (no topology, nothing dropped). The
// result is checked against the validation pass (counts and a hash of every face) before use.
// Positions therefore come at OpenMesh's single precision.
//
// Triangle strips (a PLY "tristrips" element, which OpenMesh does not read) are decoded here.
#include <OpenMesh/Core/IO/IOManager.hh>
#include <OpenMesh/Core/IO/Options.hh>
#include <OpenMesh/Core/IO/importer/BaseImporter.hh>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <mutex>
#include <sstream>

#include "engine/errors.h"
#include "engine/mesh_io_detail.h"

namespace featureline::detail {

namespace {

// ---- hashing of face lists (validation pass vs. what OpenMesh reports) ------------------

struct FaceHasher {
  std::uint64_t state = 0xcbf29ce484222325ull;
  void add(std::uint64_t v) {
    state ^= v + 0x9e3779b97f4a7c15ull + (state << 6) + (state >> 2);
    state *= 0x100000001b3ull;
  }
};

// ---- the recording importer ------------------------------------------------------------

/// Records what a reader emits: points and face index lists, nothing else. It never builds
/// topology, so OpenMesh cannot drop, reorder or duplicate anything on our behalf.
class RecordingImporter : public OpenMesh::IO::BaseImporter {
 public:
  explicit RecordingImporter(std::size_t expected_vertices, std::size_t expected_corners, std::size_t expected_faces)
      : expected_vertices_(expected_vertices), expected_corners_(expected_corners), expected_faces_(expected_faces) {}

  std::vector<OpenMesh::Vec3f> points;
  std::vector<std::uint32_t> face_sizes;
  std::vector<int> corners;  // concatenated face index lists as the reader passed them
  bool unexpected_call = false;

  OpenMesh::VertexHandle add_vertex(const OpenMesh::Vec3f& p) override {
    points.push_back(p);
    return OpenMesh::VertexHandle(static_cast<int>(points.size() - 1));
  }
  OpenMesh::VertexHandle add_vertex(const OpenMesh::Vec3d& p) override {
    return add_vertex(OpenMesh::Vec3f(static_cast<float>(p[0]), static_cast<float>(p[1]), static_cast<float>(p[2])));
  }
  OpenMesh::VertexHandle add_vertex() override { return add_vertex(OpenMesh::Vec3f(0.f, 0.f, 0.f)); }
  void set_point(OpenMesh::VertexHandle vh, const OpenMesh::Vec3f& p) override {
    if (vh.idx() >= 0 && static_cast<std::size_t>(vh.idx()) < points.size()) {
      points[static_cast<std::size_t>(vh.idx())] = p;
    } else {
      unexpected_call = true;
    }
  }
  OpenMesh::FaceHandle add_face(const VHandles& indices) override {
    face_sizes.push_back(static_cast<std::uint32_t>(indices.size()));
    for (const auto& vh : indices) corners.push_back(vh.idx());
    return OpenMesh::FaceHandle(static_cast<int>(face_sizes.size() - 1));
  }
  // Only the OM format builds faces from halfedges; OFF and PLY never call this.
  OpenMesh::FaceHandle add_face(OpenMesh::HalfedgeHandle) override {
    unexpected_call = true;
    return OpenMesh::FaceHandle();
  }
  OpenMesh::HalfedgeHandle add_edge(OpenMesh::VertexHandle, OpenMesh::VertexHandle) override {
    unexpected_call = true;
    return OpenMesh::HalfedgeHandle();
  }
  void reserve(unsigned int n_vertices, unsigned int, unsigned int n_faces) override {
    // The header counts were validated against the byte size, but never trust them further than that.
    points.reserve(std::min<std::size_t>(n_vertices, expected_vertices_));
    face_sizes.reserve(std::min<std::size_t>(n_faces, expected_faces_));
    corners.reserve(expected_corners_);
  }
  std::size_t n_vertices() const override { return points.size(); }
  std::size_t n_faces() const override { return face_sizes.size(); }
  std::size_t n_edges() const override { return 0; }

  // Attributes we do not need: accepted and ignored.
  void add_face_texcoords(OpenMesh::FaceHandle, OpenMesh::VertexHandle, const std::vector<OpenMesh::Vec2f>&) override {}
  void add_face_texcoords(OpenMesh::FaceHandle, OpenMesh::VertexHandle, const std::vector<OpenMesh::Vec3f>&) override {}
  void set_face_texindex(OpenMesh::FaceHandle, int) override {}
  void set_halfedge(OpenMesh::VertexHandle, OpenMesh::HalfedgeHandle) override {}
  void set_normal(OpenMesh::VertexHandle, const OpenMesh::Vec3f&) override {}
  void set_normal(OpenMesh::VertexHandle, const OpenMesh::Vec3d&) override {}
  void set_color(OpenMesh::VertexHandle, const OpenMesh::Vec3uc&) override {}
  void set_color(OpenMesh::VertexHandle, const OpenMesh::Vec4uc&) override {}
  void set_color(OpenMesh::VertexHandle, const OpenMesh::Vec3f&) override {}
  void set_color(OpenMesh::VertexHandle, const OpenMesh::Vec4f&) override {}
  void set_texcoord(OpenMesh::VertexHandle, const OpenMesh::Vec2f&) override {}
  void set_status(OpenMesh::VertexHandle, const OpenMesh::Attributes::StatusInfo&) override {}
  void set_next(OpenMesh::HalfedgeHandle, OpenMesh::HalfedgeHandle) override {}
  void set_face(OpenMesh::HalfedgeHandle, OpenMesh::FaceHandle) override {}
  void request_face_texcoords2D() override {}
  void set_texcoord(OpenMesh::HalfedgeHandle, const OpenMesh::Vec2f&) override {}
  void set_texcoord(OpenMesh::VertexHandle, const OpenMesh::Vec3f&) override {}
  void set_texcoord(OpenMesh::HalfedgeHandle, const OpenMesh::Vec3f&) override {}
  void set_status(OpenMesh::HalfedgeHandle, const OpenMesh::Attributes::StatusInfo&) override {}
  void set_color(OpenMesh::EdgeHandle, const OpenMesh::Vec3uc&) override {}
  void set_color(OpenMesh::EdgeHandle, const OpenMesh::Vec4uc&) override {}
  void set_color(OpenMesh::EdgeHandle, const OpenMesh::Vec3f&) override {}
  void set_color(OpenMesh::EdgeHandle, const OpenMesh::Vec4f&) override {}
  void set_status(OpenMesh::EdgeHandle, const OpenMesh::Attributes::StatusInfo&) override {}
  void set_normal(OpenMesh::FaceHandle, const OpenMesh::Vec3f&) override {}
  void set_normal(OpenMesh::FaceHandle, const OpenMesh::Vec3d&) override {}
  void set_color(OpenMesh::FaceHandle, const OpenMesh::Vec3uc&) override {}
  void set_color(OpenMesh::FaceHandle, const OpenMesh::Vec4uc&) override {}
  void set_color(OpenMesh::FaceHandle, const OpenMesh::Vec3f&) override {}
  void set_color(OpenMesh::FaceHandle, const OpenMesh::Vec4f&) override {}
  void set_status(OpenMesh::FaceHandle, const OpenMesh::Attributes::StatusInfo&) override {}
  void add_texture_information(int, std::string) override {}

 private:
  std::size_t expected_vertices_;
  std::size_t expected_corners_;
  std::size_t expected_faces_;
};

/// What the validation pass established; OpenMesh's output must agree with it.
struct Expected {
  std::size_t vertices = 0;
  std::size_t faces = 0;
  std::size_t corners = 0;
  std::uint64_t face_hash = 0;
};

/// OpenMesh's reader singletons keep per-read state in members: one read at a time, process-wide.
std::mutex& openmesh_mutex() {
  static std::mutex mutex;
  return mutex;
}

/// Runs OpenMesh on a canonical stream and converts its output, checking it against `expected`.
RawMesh read_canonical_with_openmesh(const std::string& canonical, const char* extension, MeshFormat format,
                                     const Expected& expected) {
  const std::string name = display_name(format);
  RecordingImporter importer(expected.vertices, expected.corners, expected.faces);
  bool ok = false;
  {
    std::istringstream in(canonical);
    OpenMesh::IO::Options opt;  // positions only; binary/endianness come from the (canonical) header
    std::lock_guard<std::mutex> lock(openmesh_mutex());
    ok = OpenMesh::IO::IOManager().read(in, extension, importer, opt);
  }
  if (!ok) throw MeshFormatError(name + " reader (OpenMesh) rejected the file after it passed validation.");

  FaceHasher hash;
  std::size_t corner = 0;
  for (std::uint32_t size : importer.face_sizes) {
    hash.add(size);
    for (std::uint32_t k = 0; k < size; ++k) hash.add(static_cast<std::uint64_t>(static_cast<std::int64_t>(importer.corners[corner++])));
  }
  if (importer.unexpected_call || importer.points.size() != expected.vertices ||
      importer.face_sizes.size() != expected.faces || importer.corners.size() != expected.corners ||
      hash.state != expected.face_hash) {
    throw MeshFormatError(name + " reader (OpenMesh) returned " + std::to_string(importer.points.size()) +
                          " vertices and " + std::to_string(importer.face_sizes.size()) + " faces, but the file has " +
                          std::to_string(expected.vertices) + " vertices and " + std::to_string(expected.faces) +
                          " faces; refusing a mesh whose ids would not match the file.");
  }

  RawMesh mesh;
  mesh.format = format;
  mesh.positions.reserve(importer.points.size());
  for (std::size_t v = 0; v < importer.points.size(); ++v) {
    const auto& p = importer.points[v];
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) {
      throw MeshFormatError(name + " vertex " + std::to_string(v + 1) + " has a non-finite coordinate.");
    }
    mesh.positions.push_back({double(p[0]), double(p[1]), double(p[2])});
  }
  mesh.triangles.reserve(expected.corners - 2 * expected.faces);
  corner = 0;
  for (std::uint32_t size : importer.face_sizes) {
    const int* f = importer.corners.data() + corner;
    for (std::uint32_t k = 1; k + 1 < size; ++k) {
      mesh.triangles.push_back({static_cast<std::uint32_t>(f[0]), static_cast<std::uint32_t>(f[k]),
                                static_cast<std::uint32_t>(f[k + 1])});
    }
    corner += size;
  }
  mesh.source_faces = importer.face_sizes.size();
  return mesh;
}

void append_number(std::string& out, std::uint64_t v) { out += std::to_string(v); }

/// Checks a coordinate that OpenMesh will store as float.
void check_float_coordinate(MeshFormat format, double value, std::size_t vertex, const std::string& where) {
  if (std::fabs(value) > double(FLT_MAX)) {
    throw MeshFormatError(std::string(display_name(format)) + " vertex " + std::to_string(vertex) + where +
                          " has a coordinate outside the single-precision range.");
  }
}

}  // namespace

// =========================================================================================
// OFF
// =========================================================================================

RawMesh read_off(std::string_view bytes, const ReadMeshOptions& options) {
  TokenScanner tokens(bytes);
  // Comments ('#' to the end of the line) may appear anywhere between records.
  const auto next = [&]() -> std::optional<std::string_view> {
    while (true) {
      auto t = tokens.next();
      if (!t || t->front() != '#') return t;
      tokens.skip_line();
    }
  };
  const auto line_text = [&] { return " (line " + std::to_string(tokens.line()) + ")"; };

  const auto keyword = next();
  if (!keyword) throw MeshFormatError("OFF input is empty.");
  {
    std::string_view k = *keyword;
    if (k.substr(0, 2) == "ST") k.remove_prefix(2);
    if (k.substr(0, 1) == "C") k.remove_prefix(1);
    if (k.substr(0, 1) == "N") k.remove_prefix(1);
    if (k.substr(0, 1) == "4" || k.substr(0, 1) == "n") {
      throw MeshFormatError("OFF variant " + quote_token(*keyword) + " (vertex dimension other than 3) is not supported.");
    }
    if (k != "OFF") throw MeshFormatError("OFF file does not start with an OFF keyword (found " + quote_token(*keyword) + ").");
  }
  const std::size_t header_line = tokens.line();

  std::int64_t counts[3] = {0, 0, 0};
  for (int i = 0; i < 3; ++i) {
    const auto t = next();
    if (t && i == 0 && *t == "BINARY" && tokens.line() == header_line) {
      throw MeshFormatError("Binary OFF is not supported; use ASCII OFF or PLY.");
    }
    if (!t) throw MeshFormatError("OFF header ends before its vertex, face and edge counts.");
    if (!parse_integer(*t, counts[i]) || counts[i] < 0) {
      throw MeshFormatError("OFF header has an invalid count " + quote_token(*t) + line_text() + ".");
    }
  }
  const auto n_vertices = static_cast<std::uint64_t>(counts[0]);
  const auto n_faces = static_cast<std::uint64_t>(counts[1]);
  const std::size_t remaining = bytes.size() - tokens.position();
  // Each ASCII vertex needs at least 6 bytes ("0 0 0\n"), each face at least 8 ("3 0 1 2\n").
  if (n_vertices > (remaining + 1) / 6) {
    throw MeshFormatError("OFF header claims " + std::to_string(n_vertices) + " vertices but the file has only " +
                          std::to_string(bytes.size()) + " bytes.");
  }
  if (n_faces > (remaining + 1) / 8 || 6 * n_vertices + 8 * n_faces > remaining + 2) {
    throw MeshFormatError("OFF header claims " + std::to_string(n_vertices) + " vertices and " + std::to_string(n_faces) +
                          " faces but the file has only " + std::to_string(bytes.size()) + " bytes.");
  }
  check_vertex_limit(MeshFormat::off, n_vertices, options);
  check_triangle_limit(MeshFormat::off, n_faces, options);
  if (n_vertices == 0) throw MeshFormatError("OFF input contains no vertices.");
  if (n_faces == 0) throw MeshFormatError("OFF input contains no faces.");

  std::string canonical;
  canonical.reserve(bytes.size() + 64);
  canonical += "OFF\n";
  append_number(canonical, n_vertices);
  canonical += ' ';
  append_number(canonical, n_faces);
  canonical += " 0\n";

  for (std::uint64_t v = 0; v < n_vertices; ++v) {
    for (int c = 0; c < 3; ++c) {
      const auto t = next();
      if (!t) {
        throw MeshFormatError("OFF file ends after " + std::to_string(v) + " of its " + std::to_string(n_vertices) +
                              " vertices.");
      }
      double value = 0.0;
      const NumberStatus status = parse_real(*t, value);
      if (status == NumberStatus::non_finite) {
        throw MeshFormatError("OFF vertex " + std::to_string(v + 1) + line_text() + " has a non-finite coordinate " +
                              quote_token(*t) + ".");
      }
      if (status != NumberStatus::ok) {
        throw MeshFormatError("OFF vertex " + std::to_string(v + 1) + line_text() + " has a coordinate " +
                              quote_token(*t) + " that is not a number.");
      }
      check_float_coordinate(MeshFormat::off, value, v + 1, line_text());
      canonical += *t;
      canonical += c < 2 ? ' ' : '\n';
    }
    tokens.skip_line();  // normals, colours, texture coordinates
  }

  Expected expected;
  expected.vertices = n_vertices;
  expected.faces = n_faces;
  FaceHasher hash;
  std::uint64_t triangles = 0;
  for (std::uint64_t f = 0; f < n_faces; ++f) {
    const auto t = next();
    if (!t) {
      throw MeshFormatError("OFF file ends after " + std::to_string(f) + " of its " + std::to_string(n_faces) + " faces.");
    }
    const std::size_t face_line = tokens.line();
    const auto face_where = [&] { return " (line " + std::to_string(face_line) + ")"; };
    std::int64_t size = 0;
    if (!parse_integer(*t, size) || size < 0) {
      throw MeshFormatError("OFF face " + std::to_string(f + 1) + face_where() + " has an invalid vertex count " +
                            quote_token(*t) + ".");
    }
    if (size < 3) {
      throw MeshFormatError("OFF face " + std::to_string(f + 1) + face_where() + " has " + std::to_string(size) +
                            " vertices; a face needs at least 3.");
    }
    if (static_cast<std::uint64_t>(size) > (bytes.size() - tokens.position()) / 2 + 1) {
      throw MeshFormatError("OFF face " + std::to_string(f + 1) + face_where() + " claims " + std::to_string(size) +
                            " vertices, more than the rest of the file can hold.");
    }
    triangles += static_cast<std::uint64_t>(size) - 2;
    check_triangle_limit(MeshFormat::off, triangles, options);
    hash.add(static_cast<std::uint64_t>(size));
    append_number(canonical, static_cast<std::uint64_t>(size));
    for (std::int64_t k = 0; k < size; ++k) {
      const auto it = next();
      std::int64_t index = 0;
      if (!it || !parse_integer(*it, index)) {
        throw MeshFormatError("OFF face " + std::to_string(f + 1) + face_where() + " has " +
                              (it ? "an invalid vertex index " + quote_token(*it) : std::string("too few vertex indices")) +
                              ".");
      }
      if (index < 0 || static_cast<std::uint64_t>(index) >= n_vertices) {
        throw MeshFormatError("OFF face " + std::to_string(f + 1) + face_where() + " refers to vertex index " +
                              std::to_string(index) + " but the file has only " + std::to_string(n_vertices) +
                              " vertices (indices start at 0).");
      }
      hash.add(static_cast<std::uint64_t>(index));
      canonical += ' ';
      append_number(canonical, static_cast<std::uint64_t>(index));
    }
    canonical += '\n';
    expected.corners += static_cast<std::size_t>(size);
    tokens.skip_line();  // face colours
  }
  expected.face_hash = hash.state;
  return read_canonical_with_openmesh(canonical, ".off", MeshFormat::off, expected);
}

// =========================================================================================
// PLY
// =========================================================================================

namespace {

enum class PlyType { int8, uint8, int16, uint16, int32, uint32, float32, float64 };

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

const char* ply_type_name(PlyType t) {
  switch (t) {
    case PlyType::int8: return "char";
    case PlyType::uint8: return "uchar";
    case PlyType::int16: return "short";
    case PlyType::uint16: return "ushort";
    case PlyType::int32: return "int";
    case PlyType::uint32: return "uint";
    case PlyType::float32: return "float";
    case PlyType::float64: return "double";
  }
  return "?";
}

std::size_t ply_type_size(PlyType t) {
  switch (t) {
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

bool is_integer_type(PlyType t) { return t != PlyType::float32 && t != PlyType::float64; }

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::float32;
  bool is_list = false;
  PlyType count_type = PlyType::uint8;
};

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::vector<PlyProperty> properties;
};

enum class PlyEncoding { ascii, binary_le, binary_be };

struct PlyHeader {
  PlyEncoding encoding = PlyEncoding::ascii;
  std::vector<PlyElement> elements;
  std::size_t data_start = 0;
  std::size_t header_lines = 0;
};

PlyHeader parse_ply_header(std::string_view bytes) {
  PlyHeader header;
  std::size_t pos = 0;
  std::size_t line_no = 0;
  bool have_format = false;
  constexpr std::size_t max_header_bytes = 1 << 20;
  while (true) {
    if (pos >= bytes.size() || pos > max_header_bytes) {
      throw MeshFormatError("PLY header has no 'end_header' line.");
    }
    std::size_t end = bytes.find('\n', pos);
    if (end == std::string_view::npos) throw MeshFormatError("PLY header has no 'end_header' line.");
    std::string_view line = bytes.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    TokenScanner t(line);
    const auto word = t.next();
    const std::string where = "PLY header line " + std::to_string(line_no);
    if (line_no == 1) {
      if (!word || *word != "ply" || t.next()) throw MeshFormatError("PLY file does not start with 'ply'.");
      continue;
    }
    if (!word || *word == "comment" || *word == "obj_info") continue;
    if (*word == "format") {
      const auto kind = t.next();
      const auto version = t.next();
      if (!kind || !version) throw MeshFormatError(where + ": incomplete format line.");
      if (*kind == "ascii") {
        header.encoding = PlyEncoding::ascii;
      } else if (*kind == "binary_little_endian") {
        header.encoding = PlyEncoding::binary_le;
      } else if (*kind == "binary_big_endian") {
        header.encoding = PlyEncoding::binary_be;
      } else {
        throw MeshFormatError(where + ": unknown format " + quote_token(*kind) + ".");
      }
      if (*version != "1.0") throw MeshFormatError(where + ": unsupported PLY version " + quote_token(*version) + ".");
      have_format = true;
    } else if (*word == "element") {
      const auto name = t.next();
      const auto count = t.next();
      std::int64_t n = 0;
      if (!name || !count || !parse_integer(*count, n) || n < 0) {
        throw MeshFormatError(where + ": malformed element line.");
      }
      if (static_cast<std::uint64_t>(n) > std::numeric_limits<std::uint32_t>::max()) {
        throw MeshFormatError("PLY header claims " + std::to_string(n) + " " + std::string(*name) +
                              " elements, more than a PLY reader can index.");
      }
      if (header.elements.size() >= 64) throw MeshFormatError("PLY header declares too many elements.");
      header.elements.push_back({std::string(*name), static_cast<std::uint64_t>(n), {}});
    } else if (*word == "property") {
      if (header.elements.empty()) throw MeshFormatError(where + ": property before any element.");
      PlyProperty property;
      auto type = t.next();
      if (!type) throw MeshFormatError(where + ": malformed property line.");
      if (*type == "list") {
        const auto count_type = t.next();
        const auto item_type = t.next();
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
      const auto name = t.next();
      if (!name) throw MeshFormatError(where + ": property without a name.");
      property.name = std::string(*name);
      if (header.elements.back().properties.size() >= 256) throw MeshFormatError(where + ": too many properties.");
      header.elements.back().properties.push_back(std::move(property));
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

/// Reads the PLY body record by record (binary or ASCII) with bounds checks.
class PlyBodyReader {
 public:
  PlyBodyReader(std::string_view bytes, const PlyHeader& header)
      : bytes_(bytes),
        encoding_(header.encoding),
        pos_(header.data_start),
        tokens_(bytes, header.data_start, header.header_lines + 1) {}

  bool binary() const { return encoding_ != PlyEncoding::ascii; }

  /// A scalar as double (for coordinates). `what` names it for messages.
  double read_real(PlyType type, const std::function<std::string()>& what, std::string_view* token_out = nullptr) {
    if (binary()) {
      const unsigned char* p = take(ply_type_size(type), what);
      return decode(p, type);
    }
    const auto t = next_token(what);
    if (token_out) *token_out = t;
    double value = 0.0;
    const NumberStatus status = parse_real(t, value);
    if (status == NumberStatus::non_finite) throw MeshFormatError("PLY " + what() + " has a non-finite value " + quote_token(t) + ".");
    if (status != NumberStatus::ok) throw MeshFormatError("PLY " + what() + " has a value " + quote_token(t) + " that is not a number.");
    return value;
  }

  /// An integer (list counts, indices): binary integer types only, ASCII integer tokens.
  std::int64_t read_integer(PlyType type, const std::function<std::string()>& what) {
    if (binary()) {
      const unsigned char* p = take(ply_type_size(type), what);
      return static_cast<std::int64_t>(decode(p, type));
    }
    const auto t = next_token(what);
    std::int64_t value = 0;
    if (!parse_integer(t, value)) throw MeshFormatError("PLY " + what() + " has a value " + quote_token(t) + " that is not an integer.");
    return value;
  }

  /// Skips one scalar value.
  void skip(PlyType type, const std::function<std::string()>& what) {
    if (binary()) {
      take(ply_type_size(type), what);
    } else {
      next_token(what);
    }
  }

  /// Skips `count` records of a fixed binary size at once.
  void skip_bytes(std::uint64_t n, const std::function<std::string()>& what) {
    if (n > bytes_.size() - pos_) throw MeshFormatError("PLY file ends in the middle of " + what() + ".");
    pos_ += static_cast<std::size_t>(n);
  }

  /// Checks a list length read from the file against the bytes that remain.
  void check_list_length(std::int64_t n, PlyType item, const std::function<std::string()>& what) const {
    if (n < 0) throw MeshFormatError("PLY " + what() + " has a negative list length " + std::to_string(n) + ".");
    const std::uint64_t per_item = binary() ? ply_type_size(item) : 2;
    if (static_cast<std::uint64_t>(n) > (remaining() + 1) / per_item) {
      throw MeshFormatError("PLY " + what() + " claims a list of " + std::to_string(n) +
                            " values, more than the rest of the file holds.");
    }
  }

  std::size_t remaining() const { return bytes_.size() - (binary() ? pos_ : tokens_.position()); }
  std::string location() const { return binary() ? std::string() : " (line " + std::to_string(tokens_.line()) + ")"; }

 private:
  const unsigned char* take(std::size_t n, const std::function<std::string()>& what) {
    if (n > bytes_.size() - pos_) throw MeshFormatError("PLY file ends in the middle of " + what() + ".");
    const auto* p = reinterpret_cast<const unsigned char*>(bytes_.data() + pos_);
    pos_ += n;
    return p;
  }
  std::string_view next_token(const std::function<std::string()>& what) {
    const auto t = tokens_.next();
    if (!t) throw MeshFormatError("PLY file ends in the middle of " + what() + ".");
    return *t;
  }
  double decode(const unsigned char* p, PlyType type) const {
    unsigned char b[8];
    const std::size_t n = ply_type_size(type);
    for (std::size_t i = 0; i < n; ++i) b[i] = encoding_ == PlyEncoding::binary_be ? p[n - 1 - i] : p[i];
    // The host is little-endian (x86-64/aarch64 Linux); b now holds little-endian bytes.
    switch (type) {
      case PlyType::int8: return double(static_cast<std::int8_t>(b[0]));
      case PlyType::uint8: return double(b[0]);
      case PlyType::int16: { std::int16_t v; std::memcpy(&v, b, 2); return double(v); }
      case PlyType::uint16: { std::uint16_t v; std::memcpy(&v, b, 2); return double(v); }
      case PlyType::int32: { std::int32_t v; std::memcpy(&v, b, 4); return double(v); }
      case PlyType::uint32: { std::uint32_t v; std::memcpy(&v, b, 4); return double(v); }
      case PlyType::float32: { float v; std::memcpy(&v, b, 4); return double(v); }
      case PlyType::float64: { double v; std::memcpy(&v, b, 8); return v; }
    }
    return 0.0;
  }

  std::string_view bytes_;
  PlyEncoding encoding_;
  std::size_t pos_;
  TokenScanner tokens_;
};

/// Writes a value of `type` in the file's binary encoding (for the canonical stream).
void append_binary(std::string& out, PlyType type, double value, PlyEncoding encoding) {
  unsigned char b[8] = {};
  const std::size_t n = ply_type_size(type);
  switch (type) {
    case PlyType::int8: { auto v = static_cast<std::int8_t>(value); std::memcpy(b, &v, 1); break; }
    case PlyType::uint8: { auto v = static_cast<std::uint8_t>(value); std::memcpy(b, &v, 1); break; }
    case PlyType::int16: { auto v = static_cast<std::int16_t>(value); std::memcpy(b, &v, 2); break; }
    case PlyType::uint16: { auto v = static_cast<std::uint16_t>(value); std::memcpy(b, &v, 2); break; }
    case PlyType::int32: { auto v = static_cast<std::int32_t>(value); std::memcpy(b, &v, 4); break; }
    case PlyType::uint32: { auto v = static_cast<std::uint32_t>(value); std::memcpy(b, &v, 4); break; }
    case PlyType::float32: { auto v = static_cast<float>(value); std::memcpy(b, &v, 4); break; }
    case PlyType::float64: { std::memcpy(b, &value, 8); break; }
  }
  if (encoding == PlyEncoding::binary_be) std::reverse(b, b + n);
  out.append(reinterpret_cast<const char*>(b), n);
}

std::uint64_t min_record_bytes(const PlyElement& e, bool binary) {
  std::uint64_t n = 0;
  for (const auto& p : e.properties) n += binary ? (p.is_list ? ply_type_size(p.count_type) : ply_type_size(p.type)) : 2;
  return n;
}

bool is_fixed_size(const PlyElement& e) {
  return std::none_of(e.properties.begin(), e.properties.end(), [](const PlyProperty& p) { return p.is_list; });
}

const PlyProperty* find_property(const PlyElement& e, std::initializer_list<std::string_view> names) {
  for (const auto& p : e.properties) {
    for (auto n : names) {
      if (p.name == n) return &p;
    }
  }
  return nullptr;
}

}  // namespace

RawMesh read_ply(std::string_view bytes, const ReadMeshOptions& options) {
  const PlyHeader header = parse_ply_header(bytes);
  const bool binary = header.encoding != PlyEncoding::ascii;

  const PlyElement* vertex = nullptr;
  const PlyElement* face = nullptr;
  const PlyElement* strips = nullptr;
  for (const auto& e : header.elements) {
    if (e.name == "vertex" && !vertex) vertex = &e;
    if (e.name == "face" && !face) face = &e;
    if (e.name == "tristrips" && !strips) strips = &e;
  }
  if (!vertex) throw MeshFormatError("PLY header declares no vertex element.");
  const PlyProperty* px = find_property(*vertex, {"x"});
  const PlyProperty* py = find_property(*vertex, {"y"});
  const PlyProperty* pz = find_property(*vertex, {"z"});
  if (!px || !py || !pz || px->is_list || py->is_list || pz->is_list) {
    throw MeshFormatError("PLY vertex element lacks scalar x, y and z properties.");
  }
  const PlyProperty* face_list = face ? find_property(*face, {"vertex_indices", "vertex_index"}) : nullptr;
  const PlyProperty* strip_list = strips ? find_property(*strips, {"vertex_indices", "vertex_index"}) : nullptr;
  if (face && (!face_list || !face_list->is_list || !is_integer_type(face_list->type))) {
    throw MeshFormatError("PLY face element has no integer list property 'vertex_indices'.");
  }
  if (!face && strips && (!strip_list || !strip_list->is_list || !is_integer_type(strip_list->type))) {
    throw MeshFormatError("PLY tristrips element has no integer list property 'vertex_indices'.");
  }
  if (!face && !strips) throw MeshFormatError("PLY file has no face or tristrips element (a point cloud is not a mesh).");

  // Lying headers: every element's records must fit in the bytes that are there.
  {
    const std::uint64_t available = bytes.size() - header.data_start;
    std::uint64_t needed = 0;
    for (const auto& e : header.elements) {
      const std::uint64_t per_record = std::max<std::uint64_t>(min_record_bytes(e, binary), e.properties.empty() ? 0 : 1);
      if (per_record > 0 && e.count > (available + 1) / per_record) {
        throw MeshFormatError("PLY header claims " + std::to_string(e.count) + " " + e.name + " elements but the file has only " +
                              std::to_string(bytes.size()) + " bytes.");
      }
      needed += e.count * per_record;
    }
    if (needed > available + 1) {
      throw MeshFormatError("PLY header declares elements needing at least " + std::to_string(needed) +
                            " bytes but the file has only " + std::to_string(available) + " bytes after its header.");
    }
  }
  check_vertex_limit(MeshFormat::ply, vertex->count, options);
  if (face) check_triangle_limit(MeshFormat::ply, face->count, options);
  if (vertex->count == 0) throw MeshFormatError("PLY input contains no vertices.");

  // Canonical stream for OpenMesh: vertex x y z, then face vertex_indices, nothing else.
  const PlyEncoding out_encoding = header.encoding;
  std::string canonical;
  canonical.reserve(bytes.size() / 2 + 256);
  canonical += "ply\nformat ";
  canonical += binary ? (out_encoding == PlyEncoding::binary_be ? "binary_big_endian" : "binary_little_endian") : "ascii";
  canonical += " 1.0\nelement vertex " + std::to_string(vertex->count) + "\n";
  // OpenMesh 9 reads coordinates only from float/double properties and list counts only as
  // uchar/uint8/int, so the canonical stream uses float coordinates (OpenMesh stores floats
  // anyway; ASCII keeps the validated tokens) and int counts and indices.
  canonical += "property float x\nproperty float y\nproperty float z\n";
  const PlyType index_type = vertex->count <= std::uint64_t(std::numeric_limits<std::int32_t>::max()) ? PlyType::int32 : PlyType::uint32;
  if (face) {
    canonical += "element face " + std::to_string(face->count) + "\nproperty list int " + ply_type_name(index_type) +
                 " vertex_indices\n";
  }
  canonical += "end_header\n";

  PlyBodyReader body(bytes, header);
  Expected expected;
  expected.vertices = vertex->count;
  FaceHasher hash;
  std::vector<std::array<std::uint32_t, 3>> strip_triangles;
  std::size_t strip_degenerate = 0;
  std::uint64_t triangles = 0;
  bool vertex_done = false, faces_done = false, strips_done = false;

  for (const auto& element : header.elements) {
    const bool is_vertex = &element == vertex;
    const bool is_face = &element == face;
    const bool is_strip = !face && &element == strips;
    if (!is_vertex && !is_face && !is_strip) {
      if (element.properties.empty()) continue;  // records without properties occupy no bytes
      if (vertex_done && (face ? faces_done : strips_done)) break;  // nothing needed after this
      const std::string name = element.name;
      std::uint64_t r = 0;
      const auto what = [&] { return "element '" + name + "' record " + std::to_string(r + 1) + body.location(); };
      if (binary && is_fixed_size(element)) {
        body.skip_bytes(element.count * min_record_bytes(element, true), what);
        continue;
      }
      for (r = 0; r < element.count; ++r) {
        for (const auto& p : element.properties) {
          if (p.is_list) {
            const std::int64_t n = body.read_integer(p.count_type, what);
            body.check_list_length(n, p.type, what);
            for (std::int64_t k = 0; k < n; ++k) body.skip(p.type, what);
          } else {
            body.skip(p.type, what);
          }
        }
      }
      continue;
    }

    if (is_vertex) {
      for (std::uint64_t v = 0; v < element.count; ++v) {
        double xyz[3] = {0, 0, 0};
        std::string_view tok[3];
        const auto what = [&] { return "vertex " + std::to_string(v + 1) + body.location(); };
        for (const auto& p : element.properties) {
          const int axis = &p == px ? 0 : &p == py ? 1 : &p == pz ? 2 : -1;
          if (p.is_list) {
            const std::int64_t n = body.read_integer(p.count_type, what);
            body.check_list_length(n, p.type, what);
            for (std::int64_t k = 0; k < n; ++k) body.skip(p.type, what);
          } else if (axis >= 0) {
            std::string_view* token = binary ? nullptr : &tok[axis];
            xyz[axis] = body.read_real(p.type, what, token);
            if (!std::isfinite(xyz[axis])) throw MeshFormatError("PLY " + what() + " has a non-finite coordinate.");
            check_float_coordinate(MeshFormat::ply, xyz[axis], v + 1, body.location());
          } else {
            body.skip(p.type, what);
          }
        }
        if (binary) {
          for (double c : xyz) append_binary(canonical, PlyType::float32, c, out_encoding);
        } else {
          canonical += tok[0];
          canonical += ' ';
          canonical += tok[1];
          canonical += ' ';
          canonical += tok[2];
          canonical += '\n';
        }
      }
      expected.vertices = element.count;
      vertex_done = true;
      continue;
    }

    // face or tristrips element
    const PlyProperty* list = is_face ? face_list : strip_list;
    const std::uint64_t n_vertices = vertex->count;
    std::vector<std::int64_t> strip;
    for (std::uint64_t r = 0; r < element.count; ++r) {
      const auto what = [&] {
        return std::string(is_face ? "face " : "triangle strip ") + std::to_string(r + 1) + body.location();
      };
      for (const auto& p : element.properties) {
        if (&p != list) {
          if (p.is_list) {
            const std::int64_t n = body.read_integer(p.count_type, what);
            body.check_list_length(n, p.type, what);
            for (std::int64_t k = 0; k < n; ++k) body.skip(p.type, what);
          } else {
            body.skip(p.type, what);
          }
          continue;
        }
        const std::int64_t n = body.read_integer(p.count_type, what);
        body.check_list_length(n, p.type, what);
        if (is_face) {
          if (n < 3) {
            throw MeshFormatError("PLY " + what() + " has " + std::to_string(n) + " vertices; a face needs at least 3.");
          }
          triangles += static_cast<std::uint64_t>(n) - 2;
          check_triangle_limit(MeshFormat::ply, triangles, options);
          hash.add(static_cast<std::uint64_t>(n));
          expected.corners += static_cast<std::size_t>(n);
          if (binary) {
            append_binary(canonical, PlyType::int32, double(n), out_encoding);
          } else {
            canonical += std::to_string(n);
          }
          for (std::int64_t k = 0; k < n; ++k) {
            const std::int64_t index = body.read_integer(p.type, what);
            if (index < 0 || static_cast<std::uint64_t>(index) >= n_vertices) {
              throw MeshFormatError("PLY " + what() + " refers to vertex index " + std::to_string(index) +
                                    " but the file has only " + std::to_string(n_vertices) + " vertices (indices start at 0).");
            }
            hash.add(static_cast<std::uint64_t>(index));
            if (binary) {
              append_binary(canonical, index_type, double(index), out_encoding);
            } else {
              canonical += ' ';
              canonical += std::to_string(index);
            }
          }
          if (!binary) canonical += '\n';
        } else {
          // Triangle strip with -1 restarts (or the type's maximum for unsigned types), alternating winding.
          const std::int64_t unsigned_restart =
              p.type == PlyType::uint8 ? 0xff : p.type == PlyType::uint16 ? 0xffff : p.type == PlyType::uint32 ? 0xffffffffll : -1;
          strip.clear();
          const auto flush = [&] {
            for (std::size_t k = 0; k + 2 < strip.size(); ++k) {
              std::array<std::uint32_t, 3> t{};
              if (k % 2 == 0) {
                t = {std::uint32_t(strip[k]), std::uint32_t(strip[k + 1]), std::uint32_t(strip[k + 2])};
              } else {
                t = {std::uint32_t(strip[k + 1]), std::uint32_t(strip[k]), std::uint32_t(strip[k + 2])};
              }
              // Repeated indices in a strip stitch its pieces together; they are not faces.
              if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
                ++strip_degenerate;
                continue;
              }
              check_triangle_limit(MeshFormat::ply, strip_triangles.size() + 1, options);
              strip_triangles.push_back(t);
            }
            strip.clear();
          };
          for (std::int64_t k = 0; k < n; ++k) {
            const std::int64_t index = body.read_integer(p.type, what);
            if (index == -1 || index == unsigned_restart) {
              flush();
              continue;
            }
            if (index < 0 || static_cast<std::uint64_t>(index) >= n_vertices) {
              throw MeshFormatError("PLY " + what() + " refers to vertex index " + std::to_string(index) +
                                    " but the file has only " + std::to_string(n_vertices) + " vertices (indices start at 0).");
            }
            strip.push_back(index);
          }
          flush();
        }
      }
    }
    if (is_face) {
      expected.faces = element.count;
      faces_done = true;
    } else {
      strips_done = true;
    }
  }
  expected.face_hash = hash.state;

  RawMesh mesh = read_canonical_with_openmesh(canonical, ".ply", MeshFormat::ply, expected);
  if (!face) {
    mesh.triangles = std::move(strip_triangles);
    mesh.source_faces = mesh.triangles.size();
    if (strip_degenerate > 0) {
      mesh.warnings.push_back("PLY triangle strips contain " + std::to_string(strip_degenerate) +
                              " degenerate stitching triangles, which were skipped.");
    }
  } else if (strips) {
    mesh.warnings.push_back("PLY file has both face and tristrips elements; the tristrips were ignored.");
  }
  return mesh;
}

}  // namespace featureline::detail
