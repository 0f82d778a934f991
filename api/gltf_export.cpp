#include "api/gltf_export.h"

#include <tiny_gltf.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <sstream>

#include "engine/errors.h"

namespace featureline {
namespace {

// Appends raw bytes to the single buffer, 4-byte aligned as glTF requires for accessors.
int add_view(tinygltf::Model& model, const void* data, std::size_t bytes, int target) {
  auto& buffer = model.buffers[0].data;
  while (buffer.size() % 4 != 0) buffer.push_back(0);
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = buffer.size();
  view.byteLength = bytes;
  if (target != 0) view.target = target;
  const auto* p = static_cast<const unsigned char*>(data);
  buffer.insert(buffer.end(), p, p + bytes);
  model.bufferViews.push_back(view);
  return int(model.bufferViews.size() - 1);
}

int add_accessor(tinygltf::Model& model, int view, int component, int type, std::size_t count, bool normalized = false,
                 std::vector<double> min = {}, std::vector<double> max = {}) {
  tinygltf::Accessor a;
  a.bufferView = view;
  a.componentType = component;
  a.type = type;
  a.count = count;
  a.normalized = normalized;
  a.minValues = std::move(min);
  a.maxValues = std::move(max);
  model.accessors.push_back(a);
  return int(model.accessors.size() - 1);
}

int add_positions(tinygltf::Model& model, const std::vector<Eigen::Vector3d>& points) {
  std::vector<float> data;
  data.reserve(points.size() * 3);
  std::vector<double> lo(3, HUGE_VAL), hi(3, -HUGE_VAL);
  for (const auto& p : points)
    for (int k = 0; k < 3; ++k) {
      const float f = float(p[k]);
      data.push_back(f);
      lo[k] = std::min(lo[k], double(f));
      hi[k] = std::max(hi[k], double(f));
    }
  const int view = add_view(model, data.data(), data.size() * sizeof(float), TINYGLTF_TARGET_ARRAY_BUFFER);
  return add_accessor(model, view, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, points.size(), false, lo, hi);
}

void add_line(tinygltf::Model& model, tinygltf::Mesh& mesh, const std::vector<Eigen::Vector3d>& points, bool closed,
              const std::array<unsigned char, 4>& rgba) {
  if (points.size() < 2) return;
  tinygltf::Primitive primitive;
  primitive.mode = closed ? TINYGLTF_MODE_LINE_LOOP : TINYGLTF_MODE_LINE_STRIP;
  primitive.attributes["POSITION"] = add_positions(model, points);
  std::vector<unsigned char> colours;
  for (std::size_t i = 0; i < points.size(); ++i) colours.insert(colours.end(), rgba.begin(), rgba.end());
  const int view = add_view(model, colours.data(), colours.size(), TINYGLTF_TARGET_ARRAY_BUFFER);
  primitive.attributes["COLOR_0"] =
      add_accessor(model, view, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_TYPE_VEC4, points.size(), true);
  mesh.primitives.push_back(primitive);
}

// A mesh of line primitives under a node of the same name in the scene; nothing when it has none.
void add_line_node(tinygltf::Model& model, tinygltf::Scene& scene, tinygltf::Mesh mesh) {
  if (mesh.primitives.empty()) return;
  tinygltf::Node node;
  node.name = mesh.name;
  model.meshes.push_back(std::move(mesh));
  node.mesh = int(model.meshes.size() - 1);
  model.nodes.push_back(node);
  scene.nodes.push_back(int(model.nodes.size() - 1));
}

tinygltf::Model build_model(const PreparedMesh& pm, const std::vector<FeatureLineResult>& results, bool include_mesh) {
  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "featureline";
  model.buffers.emplace_back();
  tinygltf::Scene scene;

  if (include_mesh) {
    tinygltf::Mesh mesh;
    mesh.name = "surface";
    tinygltf::Primitive primitive;
    primitive.mode = TINYGLTF_MODE_TRIANGLES;
    primitive.attributes["POSITION"] = add_positions(model, pm.positions());
    std::vector<float> normals, curvature;
    for (std::size_t v = 0; v < pm.n_vertices(); ++v) {
      Eigen::Vector3d n = pm.vertex_normals()[v];
      if (!(n.norm() > 0.5)) n = Eigen::Vector3d(0, 0, 1);  // isolated vertices still need a unit normal
      for (int k = 0; k < 3; ++k) normals.push_back(float(n[k]));
      curvature.push_back(float(dominant_curvature(pm.curvature(), std::uint32_t(v))));
    }
    int view = add_view(model, normals.data(), normals.size() * sizeof(float), TINYGLTF_TARGET_ARRAY_BUFFER);
    primitive.attributes["NORMAL"] = add_accessor(model, view, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, pm.n_vertices());
    view = add_view(model, curvature.data(), curvature.size() * sizeof(float), TINYGLTF_TARGET_ARRAY_BUFFER);
    primitive.attributes["_CURVATURE"] =
        add_accessor(model, view, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_SCALAR, pm.n_vertices());
    std::vector<std::uint32_t> indices;
    indices.reserve(pm.triangles().size() * 3);
    for (const auto& t : pm.triangles()) indices.insert(indices.end(), t.begin(), t.end());
    view = add_view(model, indices.data(), indices.size() * sizeof(std::uint32_t), TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
    primitive.indices =
        add_accessor(model, view, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR, indices.size());
    tinygltf::Material material;
    material.name = "surface";
    material.pbrMetallicRoughness.baseColorFactor = {0.8, 0.8, 0.8, 1.0};
    material.pbrMetallicRoughness.metallicFactor = 0.0;
    material.pbrMetallicRoughness.roughnessFactor = 0.8;
    material.doubleSided = true;
    model.materials.push_back(material);
    primitive.material = 0;
    mesh.primitives.push_back(primitive);
    model.meshes.push_back(mesh);
    tinygltf::Node node;
    node.name = "surface";
    node.mesh = int(model.meshes.size() - 1);
    model.nodes.push_back(node);
    scene.nodes.push_back(int(model.nodes.size() - 1));
  }

  for (std::size_t i = 0; i < results.size(); ++i) {
    const auto& r = results[i];
    tinygltf::Mesh mesh;
    mesh.name = "feature_line_" + std::to_string(i);
    add_line(model, mesh, r.initial_points, r.closed, {255, 96, 0, 255});
    std::vector<Eigen::Vector3d> refined;
    for (const auto& p : r.refined) refined.push_back(p.position);
    add_line(model, mesh, refined, r.closed, {0, 200, 255, 255});
    add_line_node(model, scene, std::move(mesh));
    if (r.fitted) {
      // Its own node, so a viewer can hide it: it may leave the surface, the other two do not.
      tinygltf::Mesh fitted;
      fitted.name = "fitted_curve_" + std::to_string(i);
      add_line(model, fitted, r.fitted->points, r.fitted->closed, {255, 0, 200, 255});
      add_line_node(model, scene, std::move(fitted));
    }
  }
  if (model.buffers[0].data.empty()) throw InvalidInputError("nothing to write: no mesh and no line");
  model.buffers[0].data.resize((model.buffers[0].data.size() + 3) / 4 * 4, 0);
  model.scenes.push_back(scene);
  model.defaultScene = 0;
  return model;
}

std::string write(const tinygltf::Model& model, bool binary) {
  tinygltf::TinyGLTF writer;
  std::ostringstream out;
  if (!writer.WriteGltfSceneToStream(&model, out, /*prettyPrint=*/!binary, /*writeBinary=*/binary))
    throw Error("writing glTF failed");
  return out.str();
}

// The model's one mesh under one node in its one scene, the buffer padded to 4 bytes, as GLB.
std::string write_single_mesh_glb(tinygltf::Model& model, tinygltf::Node node) {
  node.mesh = 0;
  model.nodes.push_back(std::move(node));
  tinygltf::Scene scene;
  scene.nodes.push_back(0);
  model.scenes.push_back(scene);
  model.defaultScene = 0;
  model.buffers[0].data.resize((model.buffers[0].data.size() + 3) / 4 * 4, 0);
  return write(model, true);
}

// One 8-byte vertex of the compact GLB: x, y, z quantised over the bounding box, and the
// curvature in the 2 bytes that glTF's 4-byte alignment of vertex attributes would otherwise
// leave as padding. An attribute at offset 6 would not be aligned, so `_CURVATURE` is a VEC4
// over the whole vertex whose w is the curvature (x, y, z are POSITION's bytes again).
struct CompactVertex {
  std::uint16_t position[3];
  std::uint16_t curvature;
};
static_assert(sizeof(CompactVertex) == 8);

// u in [0, 65535] for x in [lo, lo + extent]; 0 on a flat axis (extent 0).
std::uint16_t quantise(double x, double lo, double extent) {
  if (!(extent > 0)) return 0;
  return std::uint16_t(std::clamp(std::lround((x - lo) / extent * 65535.0), 0L, 65535L));
}

std::vector<double> as_values(const std::vector<std::uint16_t>& v) { return {v.begin(), v.end()}; }

// The quantised positions, and the node transform that maps their integers back.
void quantise_positions(const PreparedMesh& pm, std::vector<CompactVertex>& vertices, tinygltf::Node& node) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(0), hi = Eigen::Vector3d::Constant(0);
  if (!pm.positions().empty()) lo = hi = pm.positions()[0];
  for (const auto& p : pm.positions()) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  const Eigen::Vector3d extent = hi - lo;
  for (std::size_t v = 0; v < vertices.size(); ++v)
    for (int k = 0; k < 3; ++k) vertices[v].position[k] = quantise(pm.positions()[v][k], lo[k], extent[k]);
  node.translation = {lo[0], lo[1], lo[2]};
  node.scale.clear();
  for (int k = 0; k < 3; ++k) node.scale.push_back(extent[k] > 0 ? extent[k] / 65535.0 : 1.0);
}

// The dominant signed curvature as u / 65535 over its range; returns {offset, scale}.
std::array<double, 2> quantise_curvature(const PreparedMesh& pm, std::vector<CompactVertex>& vertices) {
  double lo = HUGE_VAL, hi = -HUGE_VAL;
  for (std::size_t v = 0; v < vertices.size(); ++v) {
    const double c = dominant_curvature(pm.curvature(), std::uint32_t(v));
    lo = std::min(lo, c), hi = std::max(hi, c);
  }
  if (!(lo <= hi)) lo = hi = 0;
  for (std::size_t v = 0; v < vertices.size(); ++v)
    vertices[v].curvature = quantise(dominant_curvature(pm.curvature(), std::uint32_t(v)), lo, hi - lo);
  return {lo, hi - lo};
}

void add_compact_vertices(tinygltf::Model& model, tinygltf::Primitive& primitive, tinygltf::Node& node,
                          const PreparedMesh& pm) {
  std::vector<CompactVertex> vertices(pm.n_vertices());
  quantise_positions(pm, vertices, node);
  const auto [offset, scale] = quantise_curvature(pm, vertices);
  std::vector<std::uint16_t> q_min(3, 65535), q_max(3, 0);
  for (const auto& v : vertices)
    for (int k = 0; k < 3; ++k) q_min[k] = std::min(q_min[k], v.position[k]), q_max[k] = std::max(q_max[k], v.position[k]);
  const int view = add_view(model, vertices.data(), vertices.size() * sizeof(CompactVertex), TINYGLTF_TARGET_ARRAY_BUFFER);
  model.bufferViews[view].byteStride = sizeof(CompactVertex);
  primitive.attributes["POSITION"] = add_accessor(model, view, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, TINYGLTF_TYPE_VEC3,
                                                  vertices.size(), false, as_values(q_min), as_values(q_max));
  primitive.attributes["_CURVATURE"] =
      add_accessor(model, view, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, TINYGLTF_TYPE_VEC4, vertices.size(), true);
  primitive.extras = tinygltf::Value(tinygltf::Value::Object{{"curvature_offset", tinygltf::Value(offset)},
                                                             {"curvature_scale", tinygltf::Value(scale)}});
}

// The triangles' corners in the smallest index type (glTF forbids the type's largest value,
// the primitive restart index, so a type holds ids below it).
void add_compact_indices(tinygltf::Model& model, tinygltf::Primitive& primitive, const PreparedMesh& pm) {
  const std::size_t n = pm.n_vertices();
  auto add = [&](auto zero, int component) {
    using Index = decltype(zero);
    std::vector<Index> indices;
    indices.reserve(pm.triangles().size() * 3);
    for (const auto& t : pm.triangles())
      for (auto v : t) indices.push_back(Index(v));
    const int view = add_view(model, indices.data(), indices.size() * sizeof(Index), TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
    primitive.indices = add_accessor(model, view, component, TINYGLTF_TYPE_SCALAR, indices.size());
  };
  if (n < 0xff) add(std::uint8_t{}, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE);
  else if (n < 0xffff) add(std::uint16_t{}, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT);
  else add(std::uint32_t{}, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT);
}

// The prepared mesh's crease marks as LINES primitives over the surface's POSITION accessor:
// one for the convex creases, one for the concave ones (each left out when empty, as glTF has no
// empty accessor), an edge as its two vertex ids, lower first, in adjacency order. The page
// draws these rather than guessing creases at a fixed angle, so the outlines it shows are the
// edges the lines follow. Their count and the angle go into the surface primitive's extras, so
// a reader can tell "no creases" from "not sent".
void add_crease_lines(tinygltf::Model& model, tinygltf::Mesh& mesh, const PreparedMesh& pm) {
  const int position = mesh.primitives.at(0).attributes.at("POSITION");
  const int index_component =
      model.accessors[mesh.primitives.at(0).indices].componentType;  // the surface's smallest type fits
  for (const int sign : {1, -1}) {
    std::vector<std::uint32_t> pairs;
    for (std::uint32_t v = 0; v < pm.n_vertices(); ++v)
      for (std::uint32_t i = pm.neighbor_offsets()[v]; i < pm.neighbor_offsets()[v + 1]; ++i)
        if (pm.curvature().crease[i] == sign && v < pm.neighbors()[i]) pairs.insert(pairs.end(), {v, pm.neighbors()[i]});
    if (pairs.empty()) continue;
    tinygltf::Primitive primitive;
    primitive.mode = TINYGLTF_MODE_LINE;
    primitive.attributes["POSITION"] = position;
    const std::size_t size = tinygltf::GetComponentSizeInBytes(index_component);
    std::vector<unsigned char> bytes(pairs.size() * size);
    for (std::size_t k = 0; k < pairs.size(); ++k) std::memcpy(&bytes[k * size], &pairs[k], size);  // little-endian
    const int view = add_view(model, bytes.data(), bytes.size(), TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
    primitive.indices = add_accessor(model, view, index_component, TINYGLTF_TYPE_SCALAR, pairs.size());
    primitive.extras = tinygltf::Value(tinygltf::Value::Object{{"crease", tinygltf::Value(sign)}});
    mesh.primitives.push_back(primitive);
  }
}

// glTF material colours are linear; the palette is sRGB (the sRGB transfer function, IEC 61966-2-1).
double srgb_to_linear(double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); }

}  // namespace

std::array<double, 3> segment_colour(int label) {
  double hue = std::fmod(label * 0.618033988749895, 1.0);
  if (hue < 0) hue += 1;
  const double lightness = label % 2 == 0 ? 0.58 : 0.46, saturation = 0.62;
  // HSL to RGB (the CSS Color 4 formula).
  const double a = saturation * std::min(lightness, 1 - lightness);
  auto channel = [&](double n) {
    const double k = std::fmod(n + hue * 12, 12.0);
    return lightness - a * std::max(-1.0, std::min({k - 3, 9 - k, 1.0}));
  };
  return {channel(0), channel(8), channel(4)};
}

std::string labelled_mesh_to_glb(const std::vector<Eigen::Vector3d>& positions,
                                 const std::vector<std::array<std::uint32_t, 3>>& triangles, const std::vector<int>& labels,
                                 int label_count) {
  if (labels.size() != triangles.size()) throw InvalidInputError("one label per triangle is needed");
  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "featureline";
  model.buffers.emplace_back();
  const int position_accessor = add_positions(model, positions);
  std::vector<Eigen::Vector3d> normals(positions.size(), Eigen::Vector3d::Zero());
  for (const auto& t : triangles) {
    const Eigen::Vector3d n = (positions[t[1]] - positions[t[0]]).cross(positions[t[2]] - positions[t[0]]);
    for (auto v : t) normals[v] += n;
  }
  std::vector<float> normal_data;
  for (auto& n : normals) {
    if (!(n.norm() > 0)) n = Eigen::Vector3d(0, 0, 1);
    n.normalize();
    for (int k = 0; k < 3; ++k) normal_data.push_back(float(n[k]));
  }
  const int normal_view = add_view(model, normal_data.data(), normal_data.size() * sizeof(float), TINYGLTF_TARGET_ARRAY_BUFFER);
  const int normal_accessor =
      add_accessor(model, normal_view, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, positions.size());
  tinygltf::Mesh mesh;
  mesh.name = "segments";
  for (int label = 0; label < label_count; ++label) {
    std::vector<std::uint32_t> indices;
    for (std::size_t f = 0; f < triangles.size(); ++f)
      if (labels[f] == label) indices.insert(indices.end(), triangles[f].begin(), triangles[f].end());
    if (indices.empty()) continue;
    tinygltf::Material material;
    material.name = "segment_" + std::to_string(label);
    const auto colour = segment_colour(label);
    material.pbrMetallicRoughness.baseColorFactor = {srgb_to_linear(colour[0]), srgb_to_linear(colour[1]),
                                                     srgb_to_linear(colour[2]), 1.0};
    material.pbrMetallicRoughness.metallicFactor = 0.0;
    material.pbrMetallicRoughness.roughnessFactor = 0.8;
    material.doubleSided = true;
    model.materials.push_back(material);
    tinygltf::Primitive primitive;
    primitive.mode = TINYGLTF_MODE_TRIANGLES;
    primitive.attributes["POSITION"] = position_accessor;
    primitive.attributes["NORMAL"] = normal_accessor;
    const int view = add_view(model, indices.data(), indices.size() * sizeof(std::uint32_t), TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
    primitive.indices = add_accessor(model, view, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR, indices.size());
    primitive.material = int(model.materials.size() - 1);
    mesh.primitives.push_back(primitive);
  }
  if (mesh.primitives.empty()) throw InvalidInputError("nothing to write: no labelled triangle");
  model.meshes.push_back(mesh);
  tinygltf::Node node;
  node.name = "segments";
  return write_single_mesh_glb(model, std::move(node));
}

std::string feature_line_to_glb(const PreparedMesh& mesh, const std::vector<FeatureLineResult>& results, bool include_mesh) {
  return write(build_model(mesh, results, include_mesh), true);
}

std::string prepared_mesh_to_compact_glb(const PreparedMesh& pm) {
  if (pm.triangles().empty()) throw InvalidInputError("nothing to write: the mesh has no triangle");
  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "featureline";
  model.extensionsUsed = {"KHR_mesh_quantization"};
  model.extensionsRequired = {"KHR_mesh_quantization"};
  model.buffers.emplace_back();
  tinygltf::Primitive primitive;
  primitive.mode = TINYGLTF_MODE_TRIANGLES;
  tinygltf::Node node;
  node.name = "surface";
  add_compact_vertices(model, primitive, node, pm);
  add_compact_indices(model, primitive, pm);
  auto extras = primitive.extras.Get<tinygltf::Value::Object>();
  extras["crease_angle"] = tinygltf::Value(pm.curvature().crease_angle);
  extras["crease_edges"] = tinygltf::Value(int(pm.curvature().crease_edges));
  primitive.extras = tinygltf::Value(std::move(extras));
  tinygltf::Mesh mesh;
  mesh.name = "surface";
  mesh.primitives.push_back(primitive);
  add_crease_lines(model, mesh, pm);
  model.meshes.push_back(mesh);
  return write_single_mesh_glb(model, std::move(node));
}

std::string feature_line_to_gltf_json(const PreparedMesh& mesh, const std::vector<FeatureLineResult>& results,
                                      bool include_mesh) {
  return write(build_model(mesh, results, include_mesh), false);
}

}  // namespace featureline
