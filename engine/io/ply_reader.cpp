// PLY (ascii, binary_little_endian, binary_big_endian) in one validating pass, in double
// precision: vertex i is the file's i-th vertex record, faces are fan-triangulated in file order,
// a "tristrips" element (when there is no face element) is decoded with alternating winding, and
// every other element and property is skipped by its declared type.
//
// Every element count is checked against the byte size before anything is reserved, every list
// length against the bytes that remain, every index against the vertex count.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "engine/errors.h"
#include "engine/io/byte_order.h"
#include "engine/io/ply_header.h"
#include "engine/io/reader_support.h"
#include "engine/io/readers.h"
#include "engine/io/triangle_strip.h"

namespace featureline::detail {

namespace {

using Triangle = std::array<std::uint32_t, 3>;

/// Reads the PLY body value by value (binary or ASCII) with bounds checks. Every read takes
/// `what`, a callable naming the record for messages, called only when one is thrown.
class PlyBodyReader {
 public:
  PlyBodyReader(std::string_view bytes, const PlyHeader& header)
      : bytes_(bytes),
        encoding_(header.encoding),
        pos_(header.data_start),
        tokens_(bytes, header.data_start, header.header_lines + 1) {}

  bool binary() const { return encoding_ != PlyEncoding::ascii; }

  /// A scalar as double (coordinates), exactly as stored.
  template <typename What>
  double read_real(PlyType type, const What& what) {
    if (binary()) return decode(take(ply_type_size(type), what), type);
    const std::string_view t = next_token(what);
    double value = 0.0;
    const NumberStatus status = parse_real(t, value);
    if (status == NumberStatus::non_finite) throw MeshFormatError("PLY " + what() + " has a non-finite value " + quote_token(t) + ".");
    if (status != NumberStatus::ok) throw MeshFormatError("PLY " + what() + " has a value " + quote_token(t) + " that is not a number.");
    return value;
  }

  /// An integer (list lengths, indices): a binary integer type, or an ASCII integer token.
  template <typename What>
  std::int64_t read_integer(PlyType type, const What& what) {
    if (binary()) return static_cast<std::int64_t>(decode(take(ply_type_size(type), what), type));
    const std::string_view t = next_token(what);
    std::int64_t value = 0;
    if (!parse_integer(t, value)) throw MeshFormatError("PLY " + what() + " has a value " + quote_token(t) + " that is not an integer.");
    return value;
  }

  /// A list's length, checked against the bytes that remain.
  template <typename What>
  std::int64_t read_list_length(const PlyProperty& list, const What& what) {
    const std::int64_t n = read_integer(list.count_type, what);
    if (n < 0) throw MeshFormatError("PLY " + what() + " has a negative list length " + std::to_string(n) + ".");
    const std::uint64_t per_item = binary() ? ply_type_size(list.type) : 2;
    if (static_cast<std::uint64_t>(n) > (remaining() + 1) / per_item) {
      throw MeshFormatError("PLY " + what() + " claims a list of " + std::to_string(n) +
                            " values, more than the rest of the file holds.");
    }
    return n;
  }

  /// Skips one property of a record, scalar or list: what every reader does with what it does not need.
  template <typename What>
  void skip_property(const PlyProperty& property, const What& what) {
    const std::int64_t n = property.is_list ? read_list_length(property, what) : 1;
    for (std::int64_t k = 0; k < n; ++k) skip_value(property.type, what);
  }

  /// Skips `n` bytes of binary records at once.
  template <typename What>
  void skip_bytes(std::uint64_t n, const What& what) {
    if (n > bytes_.size() - pos_) throw MeshFormatError("PLY file ends in the middle of " + what() + ".");
    pos_ += static_cast<std::size_t>(n);
  }

  /// " (line N)" for ASCII bodies, where the line helps; nothing for binary ones.
  std::string location() const { return binary() ? std::string() : " (line " + std::to_string(tokens_.line()) + ")"; }

 private:
  std::size_t remaining() const { return bytes_.size() - (binary() ? pos_ : tokens_.position()); }

  template <typename What>
  void skip_value(PlyType type, const What& what) {
    if (binary()) {
      take(ply_type_size(type), what);
    } else {
      next_token(what);
    }
  }
  template <typename What>
  const unsigned char* take(std::size_t n, const What& what) {
    if (n > bytes_.size() - pos_) throw MeshFormatError("PLY file ends in the middle of " + what() + ".");
    const auto* p = reinterpret_cast<const unsigned char*>(bytes_.data() + pos_);
    pos_ += n;
    return p;
  }
  template <typename What>
  std::string_view next_token(const What& what) {
    const auto t = tokens_.next();
    if (!t) throw MeshFormatError("PLY file ends in the middle of " + what() + ".");
    return *t;
  }
  double decode(const unsigned char* p, PlyType type) const {
    const ByteOrder order = encoding_ == PlyEncoding::binary_big_endian ? ByteOrder::big_endian : ByteOrder::little_endian;
    switch (type) {
      case PlyType::int8: return load<std::int8_t>(p, order);
      case PlyType::uint8: return load<std::uint8_t>(p, order);
      case PlyType::int16: return load<std::int16_t>(p, order);
      case PlyType::uint16: return load<std::uint16_t>(p, order);
      case PlyType::int32: return load<std::int32_t>(p, order);
      case PlyType::uint32: return load<std::uint32_t>(p, order);
      case PlyType::float32: return load<float>(p, order);
      case PlyType::float64: return load<double>(p, order);
    }
    return 0.0;
  }

  std::string_view bytes_;
  PlyEncoding encoding_;
  std::size_t pos_;
  TokenScanner tokens_;
};

const PlyProperty* find_property(const PlyElement& e, std::initializer_list<std::string_view> names) {
  for (const auto& p : e.properties) {
    if (std::find(names.begin(), names.end(), p.name) != names.end()) return &p;
  }
  return nullptr;
}

/// The elements and properties that make the mesh.
struct PlyMeshLayout {
  const PlyElement* vertex = nullptr;
  const PlyProperty* axes[3] = {nullptr, nullptr, nullptr};  ///< x, y, z
  const PlyElement* face = nullptr;
  const PlyProperty* face_list = nullptr;
  const PlyElement* strips = nullptr;  ///< "tristrips", read only when there is no face element
  const PlyProperty* strip_list = nullptr;
};

PlyMeshLayout find_mesh_layout(const PlyHeader& header) {
  PlyMeshLayout layout;
  for (const auto& e : header.elements) {
    if (e.name == "vertex" && !layout.vertex) layout.vertex = &e;
    if (e.name == "face" && !layout.face) layout.face = &e;
    if (e.name == "tristrips" && !layout.strips) layout.strips = &e;
  }
  if (!layout.vertex) throw MeshFormatError("PLY header declares no vertex element.");
  const char* axis_names[3] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a) {
    layout.axes[a] = find_property(*layout.vertex, {axis_names[a]});
    if (!layout.axes[a] || layout.axes[a]->is_list) throw MeshFormatError("PLY vertex element lacks scalar x, y and z properties.");
  }
  const auto index_list = [](const PlyElement* e) { return e ? find_property(*e, {"vertex_indices", "vertex_index"}) : nullptr; };
  const auto usable = [](const PlyProperty* p) { return p && p->is_list && is_integer_type(p->type); };
  layout.face_list = index_list(layout.face);
  layout.strip_list = index_list(layout.strips);
  if (layout.face && !usable(layout.face_list)) {
    throw MeshFormatError("PLY face element has no integer list property 'vertex_indices'.");
  }
  if (!layout.face && layout.strips && !usable(layout.strip_list)) {
    throw MeshFormatError("PLY tristrips element has no integer list property 'vertex_indices'.");
  }
  if (!layout.face && !layout.strips) throw MeshFormatError("PLY file has no face or tristrips element (a point cloud is not a mesh).");
  return layout;
}

std::uint64_t min_record_bytes(const PlyElement& e, bool binary) {
  std::uint64_t n = 0;
  for (const auto& p : e.properties) n += binary ? ply_type_size(p.is_list ? p.count_type : p.type) : 2;
  return n;
}

/// Lying headers: every element's records must fit in the bytes that are there.
void check_element_sizes(const PlyHeader& header, std::string_view bytes) {
  const bool binary = header.encoding != PlyEncoding::ascii;
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

void skip_element(PlyBodyReader& body, const PlyElement& element) {
  std::uint64_t r = 0;
  const auto what = [&] { return "element '" + element.name + "' record " + std::to_string(r + 1) + body.location(); };
  const bool fixed_size =
      std::none_of(element.properties.begin(), element.properties.end(), [](const PlyProperty& p) { return p.is_list; });
  if (body.binary() && fixed_size) {
    body.skip_bytes(element.count * min_record_bytes(element, true), what);
    return;
  }
  for (r = 0; r < element.count; ++r) {
    for (const auto& p : element.properties) body.skip_property(p, what);
  }
}

void read_vertices(PlyBodyReader& body, const PlyMeshLayout& layout, std::vector<std::array<double, 3>>& positions) {
  const PlyElement& element = *layout.vertex;
  positions.resize(element.count);  // bounded by the byte size (check_element_sizes)
  for (std::uint64_t v = 0; v < element.count; ++v) {
    const auto what = [&] { return "vertex " + std::to_string(v + 1) + body.location(); };
    for (const auto& p : element.properties) {
      const int axis = &p == layout.axes[0] ? 0 : &p == layout.axes[1] ? 1 : &p == layout.axes[2] ? 2 : -1;
      if (axis < 0) {
        body.skip_property(p, what);
        continue;
      }
      const double value = body.read_real(p.type, what);
      if (!std::isfinite(value)) throw MeshFormatError("PLY " + what() + " has a non-finite coordinate.");
      positions[v][static_cast<std::size_t>(axis)] = value;
    }
  }
}

/// Reads the `n` indices of face or strip `what()` into `out`, each checked against the vertex
/// count; a strip's restart marker (-1 or `restart`) is passed on as UINT32_MAX, which no valid
/// index reaches (element counts are below 2^32).
template <typename What>
void read_index_list(PlyBodyReader& body, const PlyProperty& list, std::int64_t n, std::uint64_t n_vertices,
                     std::optional<std::int64_t> restart, const What& what, std::vector<std::uint32_t>& out) {
  out.clear();
  for (std::int64_t k = 0; k < n; ++k) {
    const std::int64_t index = body.read_integer(list.type, what);
    if (restart && (index == -1 || index == *restart)) {
      out.push_back(std::numeric_limits<std::uint32_t>::max());
      continue;
    }
    if (index < 0 || static_cast<std::uint64_t>(index) >= n_vertices) {
      throw MeshFormatError("PLY " + what() + " refers to vertex index " + std::to_string(index) + " but the file has only " +
                            std::to_string(n_vertices) + " vertices (indices start at 0).");
    }
    out.push_back(static_cast<std::uint32_t>(index));
  }
}

/// Walks the records of a face or strip element: every property but `list` is skipped, and
/// on_list(what, n) reads the n indices of each record's `list` (`what()` names the record).
template <typename OnList>
void for_each_index_list(PlyBodyReader& body, const PlyElement& element, const PlyProperty* list, const char* record_name,
                         const OnList& on_list) {
  for (std::uint64_t r = 0; r < element.count; ++r) {
    const auto what = [&] { return record_name + std::to_string(r + 1) + body.location(); };
    for (const auto& p : element.properties) {
      if (&p == list) {
        on_list(what, body.read_list_length(p, what));
      } else {
        body.skip_property(p, what);
      }
    }
  }
}

void read_faces(PlyBodyReader& body, const PlyMeshLayout& layout, const ReadMeshOptions& options, RawMesh& mesh) {
  mesh.triangles.reserve(layout.face->count);  // bounded by the byte size (check_element_sizes)
  std::vector<std::uint32_t> corners;
  for_each_index_list(body, *layout.face, layout.face_list, "face ", [&](const auto& what, std::int64_t n) {
    if (n < 3) throw MeshFormatError("PLY " + what() + " has " + std::to_string(n) + " vertices; a face needs at least 3.");
    check_triangle_limit(MeshFormat::ply, mesh.triangles.size() + static_cast<std::size_t>(n) - 2, options);
    read_index_list(body, *layout.face_list, n, layout.vertex->count, std::nullopt, what, corners);
    for (std::size_t k = 1; k + 1 < corners.size(); ++k) mesh.triangles.push_back({corners[0], corners[k], corners[k + 1]});
  });
  mesh.source_faces = layout.face->count;
}

/// Decodes the triangle strips (split at restart markers: -1, or the maximum of an unsigned
/// index type); returns the number of degenerate stitching triangles skipped.
std::size_t read_strips(PlyBodyReader& body, const PlyMeshLayout& layout, const ReadMeshOptions& options,
                        std::vector<Triangle>& triangles) {
  const PlyType index_type = layout.strip_list->type;
  const std::int64_t restart = index_type == PlyType::uint8    ? 0xff
                               : index_type == PlyType::uint16 ? 0xffff
                               : index_type == PlyType::uint32 ? 0xffffffffll
                                                               : -1;
  std::size_t degenerate = 0;
  std::vector<std::uint32_t> indices;
  for_each_index_list(body, *layout.strips, layout.strip_list, "triangle strip ", [&](const auto& what, std::int64_t n) {
    read_index_list(body, *layout.strip_list, n, layout.vertex->count, restart, what, indices);
    // Each run between restart markers is a strip of its own (its winding starts afresh).
    auto run = indices.begin();
    while (run != indices.end()) {
      const auto run_end = std::find(run, indices.end(), std::numeric_limits<std::uint32_t>::max());
      degenerate += append_run_triangles(&*run, static_cast<std::size_t>(run_end - run), TriangleRun::strip, triangles);
      check_triangle_limit(MeshFormat::ply, triangles.size(), options);
      run = run_end == indices.end() ? run_end : run_end + 1;
    }
  });
  return degenerate;
}

}  // namespace

RawMesh read_ply(std::string_view bytes, const ReadMeshOptions& options) {
  const PlyHeader header = parse_ply_header(bytes);
  const PlyMeshLayout layout = find_mesh_layout(header);
  check_element_sizes(header, bytes);
  check_vertex_limit(MeshFormat::ply, layout.vertex->count, options);
  if (layout.face) check_triangle_limit(MeshFormat::ply, layout.face->count, options);
  if (layout.vertex->count == 0) throw MeshFormatError("PLY input contains no vertices.");

  RawMesh mesh;
  mesh.format = MeshFormat::ply;
  PlyBodyReader body(bytes, header);
  const PlyElement* triangles_from = layout.face ? layout.face : layout.strips;
  std::size_t strip_degenerate = 0;
  bool vertices_read = false, triangles_read = false;
  for (const auto& element : header.elements) {
    if (&element == layout.vertex) {
      read_vertices(body, layout, mesh.positions);
      vertices_read = true;
    } else if (&element == triangles_from) {
      if (layout.face) {
        read_faces(body, layout, options, mesh);
      } else {
        strip_degenerate = read_strips(body, layout, options, mesh.triangles);
      }
      triangles_read = true;
    } else if (!element.properties.empty()) {  // records without properties occupy no bytes
      if (vertices_read && triangles_read) break;  // nothing needed after this
      skip_element(body, element);
    }
  }

  if (!layout.face) {
    mesh.source_faces = mesh.triangles.size();
    if (strip_degenerate > 0) {
      mesh.warnings.push_back("PLY triangle strips contain " + std::to_string(strip_degenerate) +
                              " degenerate stitching triangles, which were skipped.");
    }
  } else if (layout.strips) {
    mesh.warnings.push_back("PLY file has both face and tristrips elements; the tristrips were ignored.");
  }
  return mesh;
}

}  // namespace featureline::detail
