// Reading triangle meshes from bytes or files into a raw, topology-free form.
//
// Every reader here is written for untrusted input: counts in headers are checked
// against the byte size before anything is reserved, indices are range-checked,
// non-finite coordinates are rejected, and nothing outside the given bytes is ever
// opened (OBJ `mtllib`, glTF buffer URIs). Problems the reader can repair are
// reported in `RawMesh::warnings`, never silently.
//
// Ids: for OBJ, OFF and PLY, vertex i and face j are the file's own i-th vertex
// record and j-th face (after fan triangulation of polygons, in file order). STL,
// glTF/GLB and Draco carry no shared vertex ids, so their vertices are welded by
// exact position (first occurrence order).
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "engine/enum_names.h"

namespace featureline {

enum class MeshFormat { obj, off, ply, stl, gltf, glb, drc };
/// Lower case, as used in `?format=` and file extensions; to_string(MeshFormat) prints them.
template <>
struct EnumNames<MeshFormat> {
  static constexpr std::array<std::pair<MeshFormat, const char*>, 7> entries{
      {{MeshFormat::obj, "obj"}, {MeshFormat::off, "off"}, {MeshFormat::ply, "ply"}, {MeshFormat::stl, "stl"},
       {MeshFormat::gltf, "gltf"}, {MeshFormat::glb, "glb"}, {MeshFormat::drc, "drc"}}};
};

/// Parses "obj", "OFF", "glb", ... in any case (file extensions come in both); std::nullopt
/// for anything else.
std::optional<MeshFormat> parse_mesh_format(std::string_view name);
/// "obj, off, ply, ...": every format's name from EnumNames<MeshFormat>, for errors.
std::string supported_formats();
/// Format from a file name's extension; std::nullopt when unknown.
std::optional<MeshFormat> mesh_format_from_path(std::string_view path);
/// Format from the first bytes (magic numbers, keywords); std::nullopt when unsure.
std::optional<MeshFormat> sniff_mesh_format(std::string_view bytes);

struct ReadMeshOptions {
  /// Refuse meshes with more vertex records than this (LimitExceededError).
  std::size_t max_vertices = 20'000'000;
  /// Refuse meshes with more triangles (after triangulation) than this (LimitExceededError).
  std::size_t max_triangles = 40'000'000;
  /// Refuse files larger than this when reading from a path (LimitExceededError).
  std::size_t max_file_bytes = std::size_t(2) << 30;
  /// What preparing the mesh may hold (see kPreparingBytesPerTriangle); 0: no bound. Formats
  /// that declare their counts before their data (Draco) are refused from those counts when
  /// preparation_bytes_lower_bound exceeds it, before anything is decoded; prepare_mesh is
  /// given the same bound.
  std::size_t memory_budget_bytes = 0;
};

/// What a prepared mesh keeps (PreparedMesh::memory_bytes), at least: per triangle its corners,
/// input index, the faces across its edges, its entries in the faces around its vertices, and
/// at least three adjacency entries with their edge lengths (76 B by prepared_mesh.cpp's count);
/// per vertex its position, normal, curvature, row offsets, component, reported face and path
/// landmark distances (104 B). Both rounded down.
constexpr std::size_t kPreparedBytesPerTriangle = 72;
constexpr std::size_t kPreparedBytesPerVertex = 100;
/// What preparing it holds at its peak, at least: the tables above plus the OpenMesh kernel they
/// are built from (per triangle 3 halfedges, 1.5 edges and the face, 62 B; per vertex its point,
/// halfedge and status, 32 B), released once the tables are built. Budgets are checked against
/// this, so a mesh above the bound can never be prepared within one and is refused before it is
/// decoded or prepared.
constexpr std::size_t kPreparingBytesPerTriangle = 136;
constexpr std::size_t kPreparingBytesPerVertex = 112;
constexpr std::size_t preparation_bytes_lower_bound(std::size_t vertices, std::size_t triangles) {
  constexpr std::size_t cap = std::size_t(1) << 56;  // declared counts may be absurd: no wrap-around
  return std::min(vertices, cap) * kPreparingBytesPerVertex + std::min(triangles, cap) * kPreparingBytesPerTriangle;
}

/// Limits that tie how far a mesh may expand to what the caller accepts. No uncompressed
/// encoding stores a vertex position or a triangle in fewer than 12 bytes (three floats, three
/// 32-bit indices), so an honest input of `max_input_bytes` holds at most max_input_bytes / 12 of
/// each (only Draco compresses further); and preparing a mesh holds at least
/// kPreparingBytesPerTriangle per triangle and kPreparingBytesPerVertex per vertex against
/// `memory_budget_bytes` (which the options also carry), so more of either could never be kept.
/// Inputs that expand further (glTF nodes instancing one mesh many times, primitives sharing one
/// accessor, Draco's declared counts) are then refused with LimitExceededError before their
/// geometry is allocated.
ReadMeshOptions read_limits_for(std::size_t max_input_bytes, std::size_t memory_budget_bytes);

/// A triangle soup with ids as described above; no topology yet (see prepare_mesh).
struct RawMesh {
  MeshFormat format = MeshFormat::obj;
  std::vector<std::array<double, 3>> positions;
  /// Vertex indices into `positions`, every index < positions.size(); may still
  /// contain degenerate (repeated index) or duplicate triangles: prepare_mesh reports them.
  std::vector<std::array<std::uint32_t, 3>> triangles;
  /// Number of polygons in the file before fan triangulation (== triangles.size() for triangle files).
  std::size_t source_faces = 0;
  /// True when vertices were merged by exact position (STL, glTF, Draco).
  bool welded = false;
  /// Repairs and oddities, one human-readable sentence each.
  std::vector<std::string> warnings;
};

/// Reads a mesh of the given format from memory.
/// \throw UnsupportedFormatError, MeshFormatError, LimitExceededError
RawMesh read_mesh(std::string_view bytes, MeshFormat format, const ReadMeshOptions& options = {});

/// A glTF document and the files its buffers are in (file name, bytes: a .gltf with its .bin,
/// uploaded together), packed into one self-contained GLB: the files' buffers laid end to end
/// in its binary chunk, the bufferViews moved to match; buffers given as data: URIs stay. Files
/// the document does not name are ignored; image files are not needed (images are not read).
/// Returns the document itself when no buffer names a file.
/// \throw MeshFormatError when the document is not JSON or names a buffer file not given
std::string pack_gltf_files(std::string_view gltf, const std::vector<std::pair<std::string, std::string>>& files);

/// A mesh file's bytes and format, not parsed yet.
struct MeshFile {
  std::string bytes;
  MeshFormat format = MeshFormat::obj;
};

/// Reads a mesh file's bytes (within options.max_file_bytes); the format comes from the
/// extension, else from sniffing. \throw MeshFormatError, LimitExceededError, UnsupportedFormatError
MeshFile read_mesh_file_bytes(const std::string& path, const ReadMeshOptions& options = {});

/// Reads a mesh from a file; the format comes from the extension, else from sniffing.
/// \throw as read_mesh, and MeshFormatError when the file cannot be opened.
RawMesh read_mesh_file(const std::string& path, const ReadMeshOptions& options = {});

}  // namespace featureline
