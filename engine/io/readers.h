// The per-format readers behind read_mesh (engine/io/mesh_io.cpp). Private to engine/io/.
//
// Each returns a RawMesh that read_mesh checks once more (non-empty, limits, finite positions,
// indices in range), so the RawMesh contract is enforced in one place whatever a reader does.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "engine/mesh_io.h"

namespace featureline::detail {

RawMesh read_obj(std::string_view bytes, const ReadMeshOptions& options);  // obj_reader.cpp
RawMesh read_stl(std::string_view bytes, const ReadMeshOptions& options);  // stl_reader.cpp
RawMesh read_off(std::string_view bytes, const ReadMeshOptions& options);  // off_reader.cpp
RawMesh read_ply(std::string_view bytes, const ReadMeshOptions& options);  // ply_reader.cpp
RawMesh read_gltf(std::string_view bytes, bool binary, const ReadMeshOptions& options);  // gltf_reader.cpp
RawMesh read_drc(std::string_view bytes, const ReadMeshOptions& options);  // draco_reader.cpp

/// A decoded Draco mesh: positions of its points and triangles of point indices.
struct DracoGeometry {
  std::vector<std::array<double, 3>> positions;
  std::vector<std::array<std::uint32_t, 3>> triangles;
};

/// What a Draco triangle-mesh bitstream says of itself before its data: its version and the
/// counts its connectivity header declares (points for sequential encoding, encoded vertices for
/// Edgebreaker; faces for both), read by the bitstream specification (version 2.2, with its
/// optional metadata). \throw MeshFormatError when the header is cut short or is not a
/// version 2.2 triangle mesh
struct DracoDeclaredCounts {
  int major = 0, minor = 0;
  std::uint64_t vertices = 0, faces = 0;
};
DracoDeclaredCounts read_draco_declared_counts(const unsigned char* data, std::size_t size, const std::string& context);

/// Decodes a Draco triangle-mesh bitstream with draco::Decoder (the only Draco component that
/// is hardened for untrusted input). `position_unique_id` selects the POSITION attribute by its
/// Draco unique id (glTF KHR_draco_mesh_compression); without it the named POSITION attribute
/// is used. `context` names the data in messages ("Draco file", "glTF mesh 3 primitive 0").
/// The declared counts are checked against the options' limits and memory budget first.
/// \throw MeshFormatError, LimitExceededError
DracoGeometry decode_draco(const unsigned char* data, std::size_t size, std::optional<std::uint32_t> position_unique_id,
                           MeshFormat format, const std::string& context, const ReadMeshOptions& options);

}  // namespace featureline::detail
