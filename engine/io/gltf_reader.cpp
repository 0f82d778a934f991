// glTF/GLB scenes into a raw mesh: every triangle primitive of every mesh instance of the default
// scene, transformed by its node's world matrix and welded by exact position. The document is
// parsed by gltf_loading.cpp; here every accessor and bufferView is bounds-checked (tinygltf does
// not), and the expansion through node instances and primitives is counted from the declared
// accessor counts before any geometry is read.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <set>
#include <tuple>

#include "engine/errors.h"
#include "engine/io/byte_order.h"
#include "engine/io/gltf_loading.h"
#include "engine/io/reader_support.h"
#include "engine/io/readers.h"
#include "engine/io/triangle_strip.h"

namespace featureline::detail {

namespace {

// ---- accessors ------------------------------------------------------------------------

struct ByteRange {
  const unsigned char* data = nullptr;
  std::size_t size = 0;
};

ByteRange buffer_view_bytes(const tinygltf::Model& model, int index, const std::string& context) {
  if (index < 0 || static_cast<std::size_t>(index) >= model.bufferViews.size()) {
    throw MeshFormatError(context + " refers to bufferView " + std::to_string(index) + ", which does not exist.");
  }
  const tinygltf::BufferView& view = model.bufferViews[static_cast<std::size_t>(index)];
  if (view.buffer < 0 || static_cast<std::size_t>(view.buffer) >= model.buffers.size()) {
    throw MeshFormatError(context + ": bufferView " + std::to_string(index) + " refers to buffer " +
                          std::to_string(view.buffer) + ", which does not exist.");
  }
  const auto& data = model.buffers[static_cast<std::size_t>(view.buffer)].data;
  if (view.byteOffset > data.size() || view.byteLength > data.size() - view.byteOffset) {
    throw MeshFormatError(context + ": bufferView " + std::to_string(index) + " (offset " + std::to_string(view.byteOffset) +
                          ", length " + std::to_string(view.byteLength) + ") extends past the end of buffer " +
                          std::to_string(view.buffer) + " (" + std::to_string(data.size()) + " bytes).");
  }
  return {data.data() + view.byteOffset, view.byteLength};
}

std::size_t component_size(int component_type) {
  switch (component_type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
    default: return 0;
  }
}

/// A bounds-checked view of an accessor's elements.
struct AccessorView {
  const unsigned char* data = nullptr;
  std::size_t stride = 0;
  std::size_t count = 0;
  int component_type = 0;
  int components = 0;
  bool normalized = false;

  /// Component `c` of element `element` (glTF buffers are little-endian), normalised if declared so.
  double component(std::size_t element, int c) const {
    const unsigned char* p = data + element * stride + std::size_t(c) * component_size(component_type);
    switch (component_type) {
      case TINYGLTF_COMPONENT_TYPE_FLOAT: return load_little_endian<float>(p);
      case TINYGLTF_COMPONENT_TYPE_BYTE: {
        const double v = static_cast<std::int8_t>(p[0]);
        return normalized ? std::max(v / 127.0, -1.0) : v;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return normalized ? p[0] / 255.0 : double(p[0]);
      case TINYGLTF_COMPONENT_TYPE_SHORT: {
        const double v = load_little_endian<std::int16_t>(p);
        return normalized ? std::max(v / 32767.0, -1.0) : v;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        const double v = load_little_endian<std::uint16_t>(p);
        return normalized ? v / 65535.0 : v;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: return load_little_endian<std::uint32_t>(p);
      default: return 0.0;
    }
  }
};

AccessorView view_accessor(const tinygltf::Model& model, int index, int expected_type, const std::string& context) {
  if (index < 0 || static_cast<std::size_t>(index) >= model.accessors.size()) {
    throw MeshFormatError(context + " refers to accessor " + std::to_string(index) + ", which does not exist.");
  }
  const tinygltf::Accessor& accessor = model.accessors[static_cast<std::size_t>(index)];
  const std::string name = context + ": accessor " + std::to_string(index);
  if (accessor.sparse.isSparse) throw MeshFormatError(name + " is sparse, which is not supported for geometry.");
  if (accessor.type != expected_type) throw MeshFormatError(name + " has the wrong element type.");
  AccessorView view;
  view.component_type = accessor.componentType;
  view.components = tinygltf::GetNumComponentsInType(static_cast<std::uint32_t>(accessor.type));
  view.count = accessor.count;
  view.normalized = accessor.normalized;
  const std::size_t csize = component_size(accessor.componentType);
  if (csize == 0 || view.components <= 0) throw MeshFormatError(name + " has an invalid component type.");
  if (view.count == 0) throw MeshFormatError(name + " has no elements.");
  const std::size_t element_size = csize * std::size_t(view.components);
  // Without a bufferView the spec means "all zeros": useless as geometry, and its count would be
  // the only thing bounding the allocation, so it is refused.
  if (accessor.bufferView < 0) throw MeshFormatError(name + " has no bufferView (all-zero data is not usable geometry).");
  const ByteRange range = buffer_view_bytes(model, accessor.bufferView, name);
  const tinygltf::BufferView& buffer_view = model.bufferViews[static_cast<std::size_t>(accessor.bufferView)];
  view.stride = buffer_view.byteStride != 0 ? buffer_view.byteStride : element_size;
  if (view.stride < element_size) {
    throw MeshFormatError(name + " has a byte stride of " + std::to_string(view.stride) + ", smaller than its " +
                          std::to_string(element_size) + "-byte elements.");
  }
  // offset + stride * (count - 1) + element_size <= view length, without overflow.
  const std::size_t length = range.size;
  const std::size_t offset = accessor.byteOffset;
  bool fits = offset <= length && element_size <= length - offset;
  if (fits) {
    const std::size_t room = length - offset - element_size;
    fits = (view.count - 1) <= room / view.stride;
  }
  if (!fits) {
    throw MeshFormatError(name + " (" + std::to_string(view.count) + " elements of " + std::to_string(element_size) +
                          " bytes, stride " + std::to_string(view.stride) + ", offset " + std::to_string(offset) +
                          ") points past the end of its bufferView (" + std::to_string(length) + " bytes).");
  }
  view.data = range.data + offset;
  return view;
}

// ---- per-primitive geometry (untransformed) ---------------------------------------------

struct PrimitiveGeometry {
  std::vector<std::array<double, 3>> positions;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  bool skipped = false;
};

std::optional<int> value_as_int(const tinygltf::Value& v) {
  if (v.IsInt()) return v.GetNumberAsInt();
  if (v.IsReal()) {
    const double d = v.GetNumberAsDouble();
    if (std::floor(d) == d && d >= 0 && d <= double(std::numeric_limits<int>::max())) return static_cast<int>(d);
  }
  return std::nullopt;
}

struct Counters {
  std::size_t skipped_primitives = 0;
  std::size_t dropped_index_remainder = 0;
  std::size_t skipped_degenerate = 0;
};

PrimitiveGeometry load_primitive(const tinygltf::Model& model, const tinygltf::Primitive& primitive, MeshFormat format,
                                 const std::string& context, const ReadMeshOptions& options, Counters& counters) {
  PrimitiveGeometry g;
  const int mode = primitive.mode < 0 ? TINYGLTF_MODE_TRIANGLES : primitive.mode;
  if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP && mode != TINYGLTF_MODE_TRIANGLE_FAN) {
    if (mode < 0 || mode > 6) throw MeshFormatError(context + " has an invalid mode " + std::to_string(mode) + ".");
    g.skipped = true;
    ++counters.skipped_primitives;
    return g;
  }

  const auto draco = primitive.extensions.find(std::string(draco_extension));
  if (draco != primitive.extensions.end()) {
    const tinygltf::Value& ext = draco->second;
    if (!ext.IsObject() || !ext.Has("bufferView")) {
      throw MeshFormatError(context + " has a " + std::string(draco_extension) + " extension without a bufferView.");
    }
    const auto view_index = value_as_int(ext.Get("bufferView"));
    if (!view_index) throw MeshFormatError(context + " has a Draco bufferView that is not an index.");
    std::optional<std::uint32_t> position_id;
    if (ext.Has("attributes") && ext.Get("attributes").IsObject() && ext.Get("attributes").Has("POSITION")) {
      const auto id = value_as_int(ext.Get("attributes").Get("POSITION"));
      if (!id) throw MeshFormatError(context + " has a Draco POSITION attribute id that is not an integer.");
      position_id = static_cast<std::uint32_t>(*id);
    }
    const ByteRange bytes = buffer_view_bytes(model, *view_index, context);
    DracoGeometry decoded = decode_draco(bytes.data, bytes.size, position_id, format, context + " (Draco)", options);
    g.positions = std::move(decoded.positions);
    g.triangles = std::move(decoded.triangles);
    return g;
  }

  const auto position_attribute = primitive.attributes.find("POSITION");
  if (position_attribute == primitive.attributes.end()) throw MeshFormatError(context + " has no POSITION attribute.");
  const AccessorView positions = view_accessor(model, position_attribute->second, TINYGLTF_TYPE_VEC3, context + " POSITION");
  check_vertex_limit(format, positions.count, options);
  g.positions.resize(positions.count);
  for (std::size_t i = 0; i < positions.count; ++i) {
    for (int c = 0; c < 3; ++c) {
      const double v = positions.component(i, c);
      if (!std::isfinite(v)) {
        throw MeshFormatError(context + " vertex " + std::to_string(i) + " has a non-finite coordinate.");
      }
      g.positions[i][c] = v;
    }
  }

  std::vector<std::uint32_t> indices;
  if (primitive.indices >= 0) {
    const AccessorView index_view = view_accessor(model, primitive.indices, TINYGLTF_TYPE_SCALAR, context + " indices");
    if (index_view.component_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
        index_view.component_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
        index_view.component_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT) {
      throw MeshFormatError(context + " has indices that are not unsigned integers.");
    }
    check_triangle_limit(format, index_view.count / 3, options);
    indices.resize(index_view.count);
    for (std::size_t i = 0; i < index_view.count; ++i) {
      const double v = index_view.component(i, 0);
      if (v >= double(positions.count)) {
        throw MeshFormatError(context + " index " + std::to_string(i) + " refers to vertex " +
                              std::to_string(static_cast<std::uint64_t>(v)) + " but the primitive has only " +
                              std::to_string(positions.count) + " vertices.");
      }
      indices[i] = static_cast<std::uint32_t>(v);
    }
  } else {
    check_triangle_limit(format, positions.count / 3, options);
    indices.resize(positions.count);
    for (std::size_t i = 0; i < positions.count; ++i) indices[i] = static_cast<std::uint32_t>(i);
  }

  if (mode == TINYGLTF_MODE_TRIANGLES) {
    counters.dropped_index_remainder += indices.size() % 3;
    g.triangles.reserve(indices.size() / 3);
    for (std::size_t i = 0; i + 2 < indices.size(); i += 3) g.triangles.push_back({indices[i], indices[i + 1], indices[i + 2]});
  } else {
    const TriangleRun kind = mode == TINYGLTF_MODE_TRIANGLE_FAN ? TriangleRun::fan : TriangleRun::strip;
    counters.skipped_degenerate += append_run_triangles(indices.data(), indices.size(), kind, g.triangles);
  }
  return g;
}

// ---- expansion through instances and shared accessors -----------------------------------

/// What a primitive adds to the scene, from its accessors' counts alone (nothing is read or
/// allocated), so that a scene instancing one mesh many times, or listing many primitives over one
/// accessor, is refused before it is expanded. Counts that do not add up (missing or invalid
/// accessors) give 0 here; load_primitive reports them. Draco primitives are checked again once
/// decoded, since their accessors' counts are only declarations.
struct PrimitiveExtent {
  std::size_t vertex_records = 0;
  std::size_t triangles = 0;
};

// Declared counts come from the file and may be near SIZE_MAX: sums saturate instead of wrapping.
std::size_t saturating_add(std::size_t a, std::size_t b) { return b > SIZE_MAX - a ? SIZE_MAX : a + b; }

std::size_t accessor_count(const tinygltf::Model& model, int index) {
  if (index < 0 || static_cast<std::size_t>(index) >= model.accessors.size()) return 0;
  return model.accessors[static_cast<std::size_t>(index)].count;
}

PrimitiveExtent primitive_extent(const tinygltf::Model& model, const tinygltf::Primitive& primitive) {
  const int mode = primitive.mode < 0 ? TINYGLTF_MODE_TRIANGLES : primitive.mode;
  if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP && mode != TINYGLTF_MODE_TRIANGLE_FAN) return {};
  const auto position = primitive.attributes.find("POSITION");
  PrimitiveExtent extent;
  extent.vertex_records = position == primitive.attributes.end() ? 0 : accessor_count(model, position->second);
  const std::size_t corners = primitive.indices >= 0 ? accessor_count(model, primitive.indices) : extent.vertex_records;
  extent.triangles = mode == TINYGLTF_MODE_TRIANGLES ? corners / 3 : (corners >= 3 ? corners - 2 : 0);
  return extent;
}

/// Refuses a scene whose expansion passes the configured limits, saying that it is the expansion.
void check_expansion(MeshFormat format, std::size_t vertex_records, std::size_t triangles, std::size_t instances,
                     const ReadMeshOptions& options) {
  if (instances <= 1) {  // nothing is multiplied: the reader's plain limits and messages
    check_vertex_limit(format, vertex_records, options);
    check_triangle_limit(format, triangles, options);
    return;
  }
  const auto refuse = [&](std::size_t limit, const char* what, const char* flag) {
    throw LimitExceededError(std::string(display_name(format)) + " scene expands to more than " + std::to_string(limit) + " " +
                             what + " through its node instances and primitives (" + std::to_string(instances) +
                             " primitive instances so far); the configured limit is " + std::to_string(limit) + " (" + flag + ").");
  };
  const std::size_t vertex_limit = std::min<std::size_t>(options.max_vertices, std::numeric_limits<std::uint32_t>::max());
  if (vertex_records > vertex_limit) refuse(vertex_limit, "vertices", "--max-vertices");
  if (triangles > options.max_triangles) refuse(options.max_triangles, "triangles", "--max-triangles");
}

/// Primitives that read the same data decode to the same geometry: the cache key is the data, not
/// the primitive, so a file listing one accessor under many primitives holds one copy.
struct GeometryKey {
  int draco_view = -1;
  int draco_position = -1;
  int position_accessor = -1;
  int index_accessor = -1;
  int mode = TINYGLTF_MODE_TRIANGLES;
  bool operator<(const GeometryKey& o) const {
    return std::tie(draco_view, draco_position, position_accessor, index_accessor, mode) <
           std::tie(o.draco_view, o.draco_position, o.position_accessor, o.index_accessor, o.mode);
  }
};

GeometryKey geometry_key(const tinygltf::Primitive& primitive) {
  GeometryKey key;
  key.mode = primitive.mode < 0 ? TINYGLTF_MODE_TRIANGLES : primitive.mode;
  const auto draco = primitive.extensions.find(std::string(draco_extension));
  if (draco != primitive.extensions.end() && draco->second.IsObject()) {
    const tinygltf::Value& ext = draco->second;
    if (ext.Has("bufferView")) key.draco_view = value_as_int(ext.Get("bufferView")).value_or(-2);
    if (ext.Has("attributes") && ext.Get("attributes").IsObject() && ext.Get("attributes").Has("POSITION")) {
      key.draco_position = value_as_int(ext.Get("attributes").Get("POSITION")).value_or(-2);
    }
    return key;
  }
  const auto position = primitive.attributes.find("POSITION");
  key.position_accessor = position == primitive.attributes.end() ? -1 : position->second;
  key.index_accessor = primitive.indices;
  return key;
}

// ---- node transforms ------------------------------------------------------------------

Eigen::Matrix4d local_transform(const tinygltf::Node& node, int index, MeshFormat format) {
  const std::string name = std::string(display_name(format)) + " node " + std::to_string(index);
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  if (!node.matrix.empty()) {
    if (node.matrix.size() != 16) throw MeshFormatError(name + " has a matrix with " + std::to_string(node.matrix.size()) + " values instead of 16.");
    for (int c = 0; c < 4; ++c) {
      for (int r = 0; r < 4; ++r) m(r, c) = node.matrix[std::size_t(c * 4 + r)];  // column-major
    }
  } else {
    Eigen::Vector3d t = Eigen::Vector3d::Zero(), s = Eigen::Vector3d::Ones();
    Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
    if (!node.translation.empty()) {
      if (node.translation.size() != 3) throw MeshFormatError(name + " has a translation that is not 3 values.");
      t = Eigen::Vector3d(node.translation[0], node.translation[1], node.translation[2]);
    }
    if (!node.scale.empty()) {
      if (node.scale.size() != 3) throw MeshFormatError(name + " has a scale that is not 3 values.");
      s = Eigen::Vector3d(node.scale[0], node.scale[1], node.scale[2]);
    }
    if (!node.rotation.empty()) {
      if (node.rotation.size() != 4) throw MeshFormatError(name + " has a rotation that is not 4 values.");
      q = Eigen::Quaterniond(node.rotation[3], node.rotation[0], node.rotation[1], node.rotation[2]);  // stored x, y, z, w
      if (!(q.norm() > 0.0)) throw MeshFormatError(name + " has a zero rotation quaternion.");
      q.normalize();
    }
    m.block<3, 3>(0, 0) = q.toRotationMatrix() * s.asDiagonal();
    m.block<3, 1>(0, 3) = t;
  }
  if (!m.allFinite()) throw MeshFormatError(name + " has a non-finite transform.");
  return m;
}

/// Calls visit(mesh index, world transform) for every mesh instance of `scene` (or every mesh
/// once when the file has no scene, `scene` < 0).
template <typename Visit>
void for_each_instance(const tinygltf::Model& model, int scene, MeshFormat format, const Visit& visit) {
  const std::string name = display_name(format);
  if (scene < 0) {
    for (std::size_t m = 0; m < model.meshes.size(); ++m) visit(static_cast<int>(m), Eigen::Matrix4d::Identity());
    return;
  }
  // Depth-first over the scene's node trees with an explicit stack; a node reached twice means
  // the hierarchy is not a tree (cycles, shared children), which glTF forbids.
  std::vector<char> visited(model.nodes.size(), 0);
  std::vector<std::pair<int, Eigen::Matrix4d>> stack;
  const auto& roots = model.scenes[static_cast<std::size_t>(scene)].nodes;
  for (auto r = roots.rbegin(); r != roots.rend(); ++r) stack.emplace_back(*r, Eigen::Matrix4d::Identity());
  while (!stack.empty()) {
    const auto [index, parent] = stack.back();
    stack.pop_back();
    if (index < 0 || static_cast<std::size_t>(index) >= model.nodes.size()) {
      throw MeshFormatError(name + " scene refers to node " + std::to_string(index) + ", which does not exist.");
    }
    if (visited[static_cast<std::size_t>(index)]) {
      throw MeshFormatError(name + " node " + std::to_string(index) + " is reached twice; the node hierarchy is not a tree.");
    }
    visited[static_cast<std::size_t>(index)] = 1;
    const tinygltf::Node& node = model.nodes[static_cast<std::size_t>(index)];
    const Eigen::Matrix4d world = parent * local_transform(node, index, format);
    if (node.mesh >= 0) visit(node.mesh, world);
    for (auto c = node.children.rbegin(); c != node.children.rend(); ++c) stack.emplace_back(*c, world);
  }
}

/// Refuses the scene from its declared size, so that a small file instancing a mesh many times
/// is refused before any geometry is read or allocated.
void check_declared_expansion(const tinygltf::Model& model, int scene, MeshFormat format, const ReadMeshOptions& options) {
  PrimitiveExtent declared;
  std::size_t declared_instances = 0;
  for_each_instance(model, scene, format, [&](int mesh_index, const Eigen::Matrix4d&) {
    if (mesh_index < 0 || static_cast<std::size_t>(mesh_index) >= model.meshes.size()) return;  // reported when read
    for (const tinygltf::Primitive& primitive : model.meshes[static_cast<std::size_t>(mesh_index)].primitives) {
      const PrimitiveExtent extent = primitive_extent(model, primitive);
      declared.vertex_records = saturating_add(declared.vertex_records, extent.vertex_records);
      declared.triangles = saturating_add(declared.triangles, extent.triangles);
      ++declared_instances;
    }
    check_expansion(format, declared.vertex_records, declared.triangles, declared_instances, options);
  });
}

/// Builds the welded raw mesh instance by instance; primitives reading the same data are decoded once.
class SceneAssembler {
 public:
  SceneAssembler(const tinygltf::Model& model, MeshFormat format, const ReadMeshOptions& options)
      : model_(model), format_(format), name_(display_name(format)), options_(options), welder_(mesh_.positions) {
    mesh_.format = format;
    mesh_.welded = true;
  }

  void add_instance(int mesh_index, const Eigen::Matrix4d& world) {
    if (mesh_index < 0 || static_cast<std::size_t>(mesh_index) >= model_.meshes.size()) {
      throw MeshFormatError(name_ + " node refers to mesh " + std::to_string(mesh_index) + ", which does not exist.");
    }
    const tinygltf::Mesh& gmesh = model_.meshes[static_cast<std::size_t>(mesh_index)];
    for (std::size_t p = 0; p < gmesh.primitives.size(); ++p) {
      const tinygltf::Primitive& primitive = gmesh.primitives[p];
      const PrimitiveExtent declared = primitive_extent(model_, primitive);
      check_expansion(format_, saturating_add(vertex_records_, declared.vertex_records),
                      saturating_add(mesh_.triangles.size(), declared.triangles), instances_ + 1, options_);
      const GeometryKey key = geometry_key(primitive);
      auto it = cache_.find(key);
      const bool loaded_now = it == cache_.end();
      if (loaded_now) {
        const std::string context = name_ + " mesh " + std::to_string(mesh_index) + " primitive " + std::to_string(p);
        it = cache_.emplace(key, load_primitive(model_, primitive, format_, context, options_, counters_)).first;
      }
      const PrimitiveGeometry& g = it->second;
      if (g.skipped) {
        // Counted once per primitive of the file (load_primitive counted the first one).
        if (skipped_seen_.insert({mesh_index, static_cast<int>(p)}).second && !loaded_now) ++counters_.skipped_primitives;
        continue;
      }
      ++instances_;
      vertex_records_ += g.positions.size();
      check_expansion(format_, vertex_records_, mesh_.triangles.size() + g.triangles.size(), instances_, options_);
      append_transformed(g, world, mesh_index, p);
    }
  }

  /// The mesh with a warning per kind of thing skipped. \throw MeshFormatError when it has no triangles.
  RawMesh finish(int scene) {
    if (counters_.skipped_primitives > 0) {
      mesh_.warnings.push_back(name_ + " file has " + std::to_string(counters_.skipped_primitives) +
                               " point or line primitives, which were skipped.");
    }
    if (counters_.dropped_index_remainder > 0) {
      mesh_.warnings.push_back(name_ + " file has triangle index lists whose length is not a multiple of 3; " +
                               std::to_string(counters_.dropped_index_remainder) + " trailing indices were ignored.");
    }
    if (counters_.skipped_degenerate > 0) {
      mesh_.warnings.push_back(name_ + " triangle strips or fans contain " + std::to_string(counters_.skipped_degenerate) +
                               " degenerate stitching triangles, which were skipped.");
    }
    if (mesh_.triangles.empty()) {
      throw MeshFormatError(name_ + " file contains no triangles" +
                            (scene >= 0 ? " in scene " + std::to_string(scene) : std::string()) + ".");
    }
    mesh_.source_faces = mesh_.triangles.size();
    return std::move(mesh_);
  }

 private:
  void append_transformed(const PrimitiveGeometry& g, const Eigen::Matrix4d& world, int mesh_index, std::size_t p) {
    const bool flip = world.block<3, 3>(0, 0).determinant() < 0.0;  // mirrored instance: winding flips
    std::vector<std::uint32_t> remap(g.positions.size());
    for (std::size_t v = 0; v < g.positions.size(); ++v) {
      const Eigen::Vector4d q = world * Eigen::Vector4d(g.positions[v][0], g.positions[v][1], g.positions[v][2], 1.0);
      if (!std::isfinite(q[0]) || !std::isfinite(q[1]) || !std::isfinite(q[2])) {
        throw MeshFormatError(name_ + " mesh " + std::to_string(mesh_index) + " primitive " + std::to_string(p) + " vertex " +
                              std::to_string(v) + " is non-finite after its node transform.");
      }
      remap[v] = welder_.add({q[0], q[1], q[2]});
    }
    for (const auto& t : g.triangles) {
      if (flip) {
        mesh_.triangles.push_back({remap[t[0]], remap[t[2]], remap[t[1]]});
      } else {
        mesh_.triangles.push_back({remap[t[0]], remap[t[1]], remap[t[2]]});
      }
    }
  }

  const tinygltf::Model& model_;
  MeshFormat format_;
  std::string name_;
  const ReadMeshOptions& options_;
  RawMesh mesh_;
  PositionWelder welder_;
  Counters counters_;
  std::map<GeometryKey, PrimitiveGeometry> cache_;
  std::size_t vertex_records_ = 0;
  std::size_t instances_ = 0;
  std::set<std::pair<int, int>> skipped_seen_;
};

}  // namespace

RawMesh read_gltf(std::string_view bytes, bool binary, const ReadMeshOptions& options) {
  const MeshFormat format = binary ? MeshFormat::glb : MeshFormat::gltf;
  const std::string name = display_name(format);
  const tinygltf::Model model = load_gltf_model(bytes, binary);
  for (const std::string& required : model.extensionsRequired) {
    if (required == "EXT_meshopt_compression" || required == "KHR_meshopt_compression" ||
        required == "EXT_mesh_gpu_instancing") {
      throw UnsupportedFormatError(name + " file requires the extension " + required + ", which is not supported.");
    }
  }
  int scene = model.defaultScene;
  if (scene >= static_cast<int>(model.scenes.size())) {
    throw MeshFormatError(name + " file's default scene " + std::to_string(scene) + " does not exist.");
  }
  if (scene < 0 && !model.scenes.empty()) scene = 0;

  check_declared_expansion(model, scene, format, options);
  SceneAssembler assembler(model, format, options);
  for_each_instance(model, scene, format, [&](int mesh_index, const Eigen::Matrix4d& world) {
    assembler.add_instance(mesh_index, world);
  });
  return assembler.finish(scene);
}

}  // namespace featureline::detail
