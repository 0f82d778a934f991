// Draco bitstreams (.drc files and KHR_draco_mesh_compression primitives) through draco::Decoder,
// the only Draco component meant for untrusted input. Draco's own OBJ/PLY/glTF readers are never used.
#include <draco/compression/decode.h>
#include <draco/core/decoder_buffer.h>
#include <draco/mesh/mesh.h>

#include <cmath>
#include <memory>

#include "engine/errors.h"
#include "engine/io/reader_support.h"
#include "engine/io/readers.h"

namespace featureline::detail {

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
