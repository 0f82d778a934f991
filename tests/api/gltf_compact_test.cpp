// The compact mesh download (prepared_mesh_to_compact_glb): decoded the way a glTF reader
// does (node translation and scale over the 16-bit integers), every position is within
// 1/65535 of the bounding box per axis of the prepared mesh's, the curvature within 1/65535 of
// its range, the triangles are the same corners in the same order, and the index type is the
// smallest that holds the vertex ids. Its crease edges (LINES primitives over the same
// positions, one per sign) are exactly the prepared mesh's crease marks.
#include <gtest/gtest.h>
#include <tiny_gltf.h>

#include <cstring>
#include <set>
#include <tuple>

#include "api/gltf_export.h"
#include "engine/mesh_io.h"
#include "tests/support/accuracy_meshes.h"
#include "tests/support/shared_data.h"
#include "tests/support/synthetic_meshes.h"

namespace featureline {
namespace {

tinygltf::Model parse(const std::string& glb) {
  tinygltf::TinyGLTF loader;
  tinygltf::Model model;
  std::string error, warning;
  const bool ok = loader.LoadBinaryFromMemory(&model, &error, &warning, reinterpret_cast<const unsigned char*>(glb.data()),
                                              unsigned(glb.size()));
  EXPECT_TRUE(ok) << error;
  return model;
}

// Component `k` of element `i` of an accessor as stored (integers, not normalised).
double read(const tinygltf::Model& model, int accessor_index, std::size_t i, int k = 0) {
  const auto& a = model.accessors[accessor_index];
  const auto& view = model.bufferViews[a.bufferView];
  const int size = tinygltf::GetComponentSizeInBytes(a.componentType);
  const std::size_t stride = view.byteStride ? view.byteStride : size * tinygltf::GetNumComponentsInType(a.type);
  const unsigned char* p = model.buffers[view.buffer].data.data() + view.byteOffset + a.byteOffset + i * stride + k * size;
  std::uint32_t value = 0;
  std::memcpy(&value, p, size);  // little-endian, as glTF and this machine are
  return double(value);
}

struct Decoded {
  std::vector<Eigen::Vector3d> positions;
  std::vector<double> curvature;
  std::vector<std::uint32_t> indices;
  int index_component = 0;
};

Decoded decode(const tinygltf::Model& model) {
  EXPECT_EQ(model.extensionsRequired, std::vector<std::string>{"KHR_mesh_quantization"});
  const auto& node = model.nodes.at(0);
  const auto& primitive = model.meshes.at(node.mesh).primitives.at(0);
  EXPECT_EQ(primitive.attributes.count("NORMAL"), 0u) << "the page computes normals";
  const int position = primitive.attributes.at("POSITION"), curvature = primitive.attributes.at("_CURVATURE");
  EXPECT_TRUE(model.accessors[curvature].normalized);
  EXPECT_EQ(model.accessors[curvature].type, TINYGLTF_TYPE_VEC4);
  const double offset = primitive.extras.Get("curvature_offset").GetNumberAsDouble();
  const double scale = primitive.extras.Get("curvature_scale").GetNumberAsDouble();
  Decoded out;
  for (std::size_t v = 0; v < model.accessors[position].count; ++v) {
    Eigen::Vector3d p;
    for (int k = 0; k < 3; ++k) p[k] = node.translation.at(k) + node.scale.at(k) * read(model, position, v, k);
    out.positions.push_back(p);
    out.curvature.push_back(offset + scale * read(model, curvature, v, 3) / 65535.0);  // w
  }
  out.index_component = model.accessors[primitive.indices].componentType;
  for (std::size_t i = 0; i < model.accessors[primitive.indices].count; ++i)
    out.indices.push_back(std::uint32_t(read(model, primitive.indices, i)));
  return out;
}

// Decodes the compact GLB of `raw` and checks it against the prepared mesh; returns the
// index component type.
int check_round_trip(RawMesh raw) {
  const auto pm = prepare_mesh(std::move(raw));
  const Decoded d = decode(parse(prepared_mesh_to_compact_glb(*pm)));
  EXPECT_EQ(d.positions.size(), pm->n_vertices());
  Eigen::Vector3d lo = pm->positions()[0], hi = pm->positions()[0];
  for (const auto& p : pm->positions()) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  const Eigen::Vector3d tolerance = (hi - lo) / 65535.0;
  double c_lo = HUGE_VAL, c_hi = -HUGE_VAL;
  for (std::uint32_t v = 0; v < pm->n_vertices(); ++v)
    c_lo = std::min(c_lo, dominant_curvature(pm->curvature(), v)), c_hi = std::max(c_hi, dominant_curvature(pm->curvature(), v));
  for (std::size_t v = 0; v < d.positions.size(); ++v) {
    for (int k = 0; k < 3; ++k)
      EXPECT_LE(std::abs(d.positions[v][k] - pm->positions()[v][k]), tolerance[k] + 1e-12 * (1 + std::abs(lo[k])))
          << "vertex " << v << " axis " << k;
    EXPECT_LE(std::abs(d.curvature[v] - dominant_curvature(pm->curvature(), std::uint32_t(v))), (c_hi - c_lo) / 65535.0 + 1e-12)
        << "vertex " << v;
  }
  std::vector<std::uint32_t> expected;
  for (const auto& t : pm->triangles()) expected.insert(expected.end(), t.begin(), t.end());
  EXPECT_EQ(d.indices, expected);
  return d.index_component;
}

TEST(CompactGlb, BunnyPositionsWithinOneStepOfTheBoxAndSmallerThanTheFloatGlb) {
  const auto pm = prepare_mesh(read_mesh_file(testing::require_shared_mesh("bunny_closed.off")));
  const std::string compact = prepared_mesh_to_compact_glb(*pm), full = feature_line_to_glb(*pm, {}, true);
  // 8 bytes a vertex and 2 an index instead of 28 and 4 (before HTTP compression).
  EXPECT_LT(double(compact.size()), 0.4 * double(full.size()));
  EXPECT_EQ(check_round_trip(read_mesh_file(testing::require_shared_mesh("bunny_closed.off"))),
            TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT);
}

TEST(CompactGlb, SmallMeshFarFromTheOriginUsesByteIndices) {
  EXPECT_EQ(check_round_trip(testing::translated(testing::make_icosphere(1.0, 1), 1e6, -2e6, 3.5)),
            TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE);
}

TEST(CompactGlb, FlatMeshWithMoreThan65534VerticesUses32BitIndices) {
  // A plane: z has no extent (scale 1, every z quantised to 0) and the ids need 32 bits.
  EXPECT_EQ(check_round_trip(testing::make_plane_grid(260, 0.2, 7)), TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT);
}

// (lower vertex, higher vertex, sign) of every crease edge.
using CreaseSet = std::set<std::tuple<std::uint32_t, std::uint32_t, int>>;

CreaseSet marked_creases(const PreparedMesh& pm) {
  CreaseSet out;
  for (std::uint32_t v = 0; v < pm.n_vertices(); ++v)
    for (std::uint32_t i = pm.neighbor_offsets()[v]; i < pm.neighbor_offsets()[v + 1]; ++i)
      if (pm.curvature().crease[i] != 0 && v < pm.neighbors()[i]) out.emplace(v, pm.neighbors()[i], pm.curvature().crease[i]);
  return out;
}

// The LINES primitives' edges with their "crease" sign; checks each shares the surface's positions.
CreaseSet glb_creases(const tinygltf::Model& model, std::size_t* edge_count) {
  const auto& primitives = model.meshes.at(model.nodes.at(0).mesh).primitives;
  CreaseSet out;
  *edge_count = 0;
  for (std::size_t p = 1; p < primitives.size(); ++p) {
    const auto& primitive = primitives[p];
    EXPECT_EQ(primitive.mode, TINYGLTF_MODE_LINE);
    EXPECT_EQ(primitive.attributes.at("POSITION"), primitives[0].attributes.at("POSITION"));
    const int sign = primitive.extras.Get("crease").GetNumberAsInt();
    const std::size_t count = model.accessors[primitive.indices].count;
    EXPECT_EQ(count % 2, 0u);
    for (std::size_t i = 0; i + 1 < count; i += 2) {
      const auto a = std::uint32_t(read(model, primitive.indices, i)), b = std::uint32_t(read(model, primitive.indices, i + 1));
      EXPECT_LT(a, b);
      out.emplace(a, b, sign);
      ++*edge_count;
    }
  }
  return out;
}

void check_creases(RawMesh raw, std::size_t expected_at_least) {
  const auto pm = prepare_mesh(std::move(raw));
  const tinygltf::Model model = parse(prepared_mesh_to_compact_glb(*pm));
  const auto& extras = model.meshes.at(0).primitives.at(0).extras;
  EXPECT_EQ(std::size_t(extras.Get("crease_edges").GetNumberAsInt()), pm->curvature().crease_edges);
  EXPECT_DOUBLE_EQ(extras.Get("crease_angle").GetNumberAsDouble(), pm->curvature().crease_angle);
  std::size_t edges = 0;
  const CreaseSet sent = glb_creases(model, &edges), marked = marked_creases(*pm);
  EXPECT_EQ(edges, sent.size()) << "an edge sent twice";
  EXPECT_EQ(sent, marked);
  EXPECT_EQ(sent.size(), pm->curvature().crease_edges);
  EXPECT_GE(sent.size(), expected_at_least);
}

TEST(CompactGlb, CreaseEdgesOfFandiskAreThePreparedMeshsMarksWithTheirSigns) {
  check_creases(read_mesh_file(testing::require_shared_mesh("fandisk.off")), 100);
}

TEST(CompactGlb, CreaseEdgesOfACubeAreItsTwelveEdges) {
  // 12 cube edges of 4 mesh edges each, all convex; the faces' diagonals are flat.
  const auto pm = prepare_mesh(testing::make_subdivided_cube(4));
  std::size_t edges = 0;
  const CreaseSet sent = glb_creases(parse(prepared_mesh_to_compact_glb(*pm)), &edges);
  EXPECT_EQ(sent.size(), 48u);
  for (const auto& e : sent) EXPECT_EQ(std::get<2>(e), 1);
  check_creases(testing::make_subdivided_cube(4), 48);
}

TEST(CompactGlb, NoisyCubeSendsTheCreasesOfTheAdaptiveAngleAndASmoothMeshNone) {
  // Noise along every axis: preparation raises the crease angle above 30 degrees, and the
  // edges sent are those it marked at that angle, not those past 30 degrees.
  const RawMesh noisy = testing::with_noise(testing::make_subdivided_cube(12), 0.15, 3);
  EXPECT_GT(prepare_mesh(noisy)->curvature().crease_angle, 30.0);
  check_creases(noisy, 12 * 12 / 2);
  const auto pm = prepare_mesh(testing::make_icosphere(1.0, 3));
  const tinygltf::Model model = parse(prepared_mesh_to_compact_glb(*pm));
  EXPECT_EQ(model.meshes.at(0).primitives.size(), 1u);
  EXPECT_EQ(model.meshes.at(0).primitives[0].extras.Get("crease_edges").GetNumberAsInt(), 0);
}

}  // namespace
}  // namespace featureline
