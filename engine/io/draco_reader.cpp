// Draco bitstreams (.drc files and KHR_draco_mesh_compression primitives) through draco::Decoder,
// the only Draco component meant for untrusted input. Draco's own OBJ/PLY/glTF readers are never used.
#include <draco/compression/decode.h>
#include <draco/core/decoder_buffer.h>
#include <draco/mesh/mesh.h>

#include <cmath>
#include <memory>
#include <string_view>

#include "engine/errors.h"
#include "engine/io/reader_support.h"
#include "engine/io/readers.h"

namespace featureline::detail {

namespace {

// Reads the bitstream's header fields in order; every read is bounds-checked.
class DracoHeaderReader {
 public:
  DracoHeaderReader(const unsigned char* data, std::size_t size, const std::string& context)
      : data_(data), size_(size), context_(context) {}

  std::uint8_t u8() {
    if (pos_ >= size_) cut_short();
    return data_[pos_++];
  }
  std::uint16_t u16() {
    const std::uint16_t low = u8();
    return std::uint16_t(low | (std::uint16_t(u8()) << 8));
  }
  /// Draco's varUI32: little-endian base-128, at most 5 bytes.
  std::uint64_t var_u32() {
    std::uint64_t value = 0;
    for (int i = 0; i < 5; ++i) {
      const std::uint8_t byte = u8();
      value |= std::uint64_t(byte & 0x7F) << (7 * i);
      if ((byte & 0x80) == 0) return value;
    }
    throw MeshFormatError(context_ + " has a malformed variable-length number in its header.");
  }
  void skip(std::size_t n) {
    if (n > size_ - pos_) cut_short();
    pos_ += n;
  }
  /// A metadata element (spec: DecodeMetadataElement): entries of sized keys and values, then
  /// named sub-elements, nested at most `depth` levels. Skipped: only the counts after it matter.
  void skip_metadata_element(int depth) {
    if (depth == 0) throw MeshFormatError(context_ + " nests its metadata too deeply.");
    const std::uint64_t entries = var_u32();
    for (std::uint64_t i = 0; i < entries; ++i) {
      skip(u8());  // key
      skip(u8());  // value
    }
    const std::uint64_t children = var_u32();
    for (std::uint64_t i = 0; i < children; ++i) {
      skip(u8());  // name
      skip_metadata_element(depth - 1);
    }
  }

 private:
  [[noreturn]] void cut_short() const { throw MeshFormatError(context_ + " ends inside its header."); }
  const unsigned char* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
  const std::string& context_;
};

}  // namespace

DracoDeclaredCounts read_draco_declared_counts(const unsigned char* data, std::size_t size, const std::string& context) {
  DracoHeaderReader in(data, size, context);
  for (const char c : std::string_view("DRACO"))
    if (in.u8() != std::uint8_t(c)) throw MeshFormatError(context + " is not a Draco bitstream.");
  DracoDeclaredCounts counts;
  counts.major = in.u8();
  counts.minor = in.u8();
  // Every encoder since Draco 1.3 (2018) writes 2.2; older layouts differ field by field.
  if (counts.major != 2 || counts.minor != 2)
    throw MeshFormatError(context + " is a Draco bitstream of version " + std::to_string(counts.major) + "." +
                          std::to_string(counts.minor) + "; only version 2.2 (Draco 1.3 and later) is read.");
  if (in.u8() != 1) throw MeshFormatError(context + " holds a Draco point cloud, not a triangle mesh.");
  const std::uint8_t method = in.u8();
  const std::uint16_t flags = in.u16();
  if (flags & 0x8000) {  // metadata: per-attribute elements, then the file's
    const std::uint64_t attribute_elements = in.var_u32();
    for (std::uint64_t i = 0; i < attribute_elements; ++i) {
      in.var_u32();  // attribute id
      in.skip_metadata_element(32);
    }
    in.skip_metadata_element(32);
  }
  if (method == 0) {  // sequential: faces, then points
    counts.faces = in.var_u32();
    counts.vertices = in.var_u32();
  } else if (method == 1) {  // Edgebreaker: traversal type, encoded vertices, faces
    in.u8();
    counts.vertices = in.var_u32();
    counts.faces = in.var_u32();
  } else {
    throw MeshFormatError(context + " uses an unknown Draco encoding method " + std::to_string(method) + ".");
  }
  return counts;
}

DracoGeometry decode_draco(const unsigned char* data, std::size_t size, std::optional<std::uint32_t> position_unique_id,
                           MeshFormat format, const std::string& context, const ReadMeshOptions& options) {
  if (size == 0) throw MeshFormatError(context + " is empty.");
  draco::DecoderBuffer buffer;
  buffer.Init(reinterpret_cast<const char*>(data), size);
  const auto type = draco::Decoder::GetEncodedGeometryType(&buffer);
  if (!type.ok()) {
    throw MeshFormatError(context + " is not a valid Draco bitstream (" + type.status().error_msg_string() + ").");
  }
  if (type.value() != draco::TRIANGULAR_MESH) {
    throw MeshFormatError(context + " holds a Draco point cloud, not a triangle mesh.");
  }
  // Refused from what the header declares, before Draco allocates for it: a 53 KB file had
  // declared 33.5 million faces and taken 2.3 GB to decode before any limit applied.
  const DracoDeclaredCounts declared = read_draco_declared_counts(data, size, context);
  check_vertex_limit(format, declared.vertices, options);
  check_triangle_limit(format, declared.faces, options);
  const std::size_t needed = preparation_bytes_lower_bound(declared.vertices, declared.faces);
  if (options.memory_budget_bytes != 0 && needed > options.memory_budget_bytes)
    throw LimitExceededError(context + " declares " + std::to_string(declared.faces) + " faces and " +
                             std::to_string(declared.vertices) + " vertices, which need more than " + std::to_string(needed >> 20) +
                             " MiB prepared, more than the " + std::to_string(options.memory_budget_bytes >> 20) + " MiB allowed.");
  buffer.Init(reinterpret_cast<const char*>(data), size);
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
  if (!decoded.ok()) {
    throw MeshFormatError(context + " could not be decoded by Draco (" + decoded.status().error_msg_string() + ").");
  }
  const std::unique_ptr<draco::Mesh> mesh = std::move(decoded).value();
  if (!mesh) throw MeshFormatError(context + " could not be decoded by Draco.");

  const draco::PointAttribute* position = nullptr;
  if (position_unique_id) {
    position = mesh->GetAttributeByUniqueId(*position_unique_id);
    if (!position) {
      throw MeshFormatError(context + " has no Draco attribute with id " + std::to_string(*position_unique_id) +
                            " for POSITION.");
    }
  } else {
    position = mesh->GetNamedAttribute(draco::GeometryAttribute::POSITION);
    if (!position) throw MeshFormatError(context + " has no POSITION attribute.");
  }
  if (position->num_components() != 3) {
    throw MeshFormatError(context + " has a POSITION attribute with " + std::to_string(position->num_components()) +
                          " components instead of 3.");
  }

  const std::size_t n_points = mesh->num_points();
  const std::size_t n_faces = mesh->num_faces();
  check_vertex_limit(format, n_points, options);
  check_triangle_limit(format, n_faces, options);
  if (!position->is_mapping_identity() && position->indices_map_size() < n_points) {
    throw MeshFormatError(context + " has a POSITION attribute that does not cover all of its points.");
  }

  DracoGeometry out;
  out.positions.resize(n_points);
  for (std::size_t p = 0; p < n_points; ++p) {
    const draco::AttributeValueIndex value = position->mapped_index(draco::PointIndex(static_cast<std::uint32_t>(p)));
    if (value.value() >= position->size()) {
      throw MeshFormatError(context + " point " + std::to_string(p) + " maps to a missing POSITION value.");
    }
    double xyz[3] = {0, 0, 0};
    if (!position->ConvertValue<double>(value, 3, xyz)) {
      throw MeshFormatError(context + " has a POSITION attribute of a type that cannot be read.");
    }
    if (!std::isfinite(xyz[0]) || !std::isfinite(xyz[1]) || !std::isfinite(xyz[2])) {
      throw MeshFormatError(context + " point " + std::to_string(p) + " has a non-finite coordinate.");
    }
    out.positions[p] = {xyz[0], xyz[1], xyz[2]};
  }
  out.triangles.resize(n_faces);
  for (std::size_t f = 0; f < n_faces; ++f) {
    const draco::Mesh::Face& face = mesh->face(draco::FaceIndex(static_cast<std::uint32_t>(f)));
    for (int c = 0; c < 3; ++c) {
      const std::uint32_t p = face[c].value();
      if (p >= n_points) {
        throw MeshFormatError(context + " face " + std::to_string(f) + " refers to point " + std::to_string(p) +
                              " but there are only " + std::to_string(n_points) + " points.");
      }
      out.triangles[f][c] = p;
    }
  }
  return out;
}

RawMesh read_drc(std::string_view bytes, const ReadMeshOptions& options) {
  DracoGeometry geometry = decode_draco(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size(), std::nullopt,
                                        MeshFormat::drc, "Draco file", options);
  RawMesh mesh;
  mesh.format = MeshFormat::drc;
  mesh.welded = true;
  PositionWelder welder(mesh.positions);
  std::vector<std::uint32_t> remap(geometry.positions.size());
  for (std::size_t p = 0; p < geometry.positions.size(); ++p) remap[p] = welder.add(geometry.positions[p]);
  mesh.triangles.reserve(geometry.triangles.size());
  for (const auto& t : geometry.triangles) mesh.triangles.push_back({remap[t[0]], remap[t[1]], remap[t[2]]});
  mesh.source_faces = mesh.triangles.size();
  return mesh;
}

}  // namespace featureline::detail
