// The tables prepare_mesh builds once for every request: faces around vertices, the face across
// each edge, boundary vertices, the face reported for points on vertices (checked against
// OpenMesh's own halfedge structure, built from the same triangles), and the
// nearest-vertex index (checked against known nearest vertices and a scan over every vertex).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <vector>

#include "engine/prepared_mesh.h"
#include "engine/tri_mesh.h"
#include "tests/support/synthetic_meshes.h"

namespace featureline {
namespace {

using namespace featureline::testing;
constexpr std::uint32_t kNone = UINT32_MAX;

// Every table entry against OpenMesh: the face across each directed face edge, the faces
// around each vertex, and which vertices are on the boundary.
void expect_tables_match_openmesh(const PreparedMesh& pm) {
  TriMesh mesh;
  for (const auto& p : pm.positions()) mesh.add_vertex(TriMesh::Point(p.x(), p.y(), p.z()));
  for (const auto& t : pm.triangles())
    ASSERT_TRUE(mesh.add_face(TriMesh::VertexHandle(int(t[0])), TriMesh::VertexHandle(int(t[1])), TriMesh::VertexHandle(int(t[2])))
                    .is_valid());
  ASSERT_EQ(pm.face_neighbors().size(), pm.triangles().size());
  for (std::uint32_t f = 0; f < pm.triangles().size(); ++f)
    for (int k = 0; k < 3; ++k) {
      const auto& t = pm.triangles()[f];
      const auto h = mesh.find_halfedge(TriMesh::VertexHandle(int(t[k])), TriMesh::VertexHandle(int(t[(k + 1) % 3])));
      ASSERT_TRUE(h.is_valid());
      ASSERT_EQ(mesh.face_handle(h).idx(), int(f));
      const auto across = mesh.opposite_face_handle(h);
      EXPECT_EQ(pm.face_neighbors()[f][k], across.is_valid() ? std::uint32_t(across.idx()) : kNone) << "face " << f;
    }
  for (auto v : mesh.vertices()) {
    std::vector<std::uint32_t> expected;
    for (auto f : mesh.vf_range(v)) expected.push_back(std::uint32_t(f.idx()));
    std::sort(expected.begin(), expected.end());
    const auto id = std::uint32_t(v.idx());
    EXPECT_EQ(std::vector<std::uint32_t>(pm.faces_around(id).begin(), pm.faces_around(id).end()), expected) << "vertex " << id;
    if (!expected.empty()) {
      EXPECT_EQ(pm.boundary_vertex()[id] != 0, mesh.is_boundary(v)) << "vertex " << id;
      EXPECT_EQ(pm.vertex_face()[id], std::uint32_t((*mesh.vf_range(v).begin()).idx())) << "vertex " << id;
    } else {
      EXPECT_EQ(pm.vertex_face()[id], kNone) << "vertex " << id;
    }
  }
}

TEST(PreparedMesh, FaceTablesMatchOpenMeshOnClosedAndOpenMeshes) {
  const auto closed = prepare_mesh(make_capsule(1, 2, 24, 6, 4));
  expect_tables_match_openmesh(*closed);
  EXPECT_EQ(std::count(closed->boundary_vertex().begin(), closed->boundary_vertex().end(), 1), 0);
  const auto tube = prepare_mesh(make_cylinder(1, 2, 5, 16, false));
  expect_tables_match_openmesh(*tube);
  EXPECT_EQ(std::count(tube->boundary_vertex().begin(), tube->boundary_vertex().end(), 1), 32);  // two rims of 16
}

TEST(PreparedMesh, NonManifoldInputGetsSeparateFacesInTheTables) {
  // Three triangles on edge (0, 1): the third gets its own vertex copies (3, 4, 5 -> 5, 6, 7),
  // so every edge of the tables has at most two faces.
  RawMesh raw;
  raw.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}};
  raw.triangles = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
  raw.source_faces = 3;
  const auto pm = prepare_mesh(raw);
  ASSERT_EQ(pm->n_vertices(), 8u);
  expect_tables_match_openmesh(*pm);
  EXPECT_EQ(pm->face_neighbors()[0][0], 1u);
  EXPECT_EQ(pm->face_neighbors()[2], (std::array<std::uint32_t, 3>{kNone, kNone, kNone}));
  // The copies sit on their originals: the nearest vertex is the original (the lowest id);
  // vertex 4's only triangle took the copy 7, so 4 belongs to no triangle and 7 answers.
  EXPECT_EQ(pm->nearest_vertex(Eigen::Vector3d(0, 0, 0)), 0u);
  EXPECT_EQ(pm->nearest_vertex(Eigen::Vector3d(1.2, 0.01, 0.01)), 1u);
  EXPECT_EQ(pm->component()[4], -1);
  EXPECT_EQ(pm->nearest_vertex(Eigen::Vector3d(0, 0, 2)), 7u);
}

TEST(PreparedMesh, FansMeetingOnlyAtAVertexAreKeptAndReported) {
  // Two triangles tip to tip at vertex 0 (a bowtie): each fan has a free border there, so both
  // are taken as they are and vertex 0 stays one vertex of two fans; a warning names it. The
  // edge-sharing case above is split, and no such warning comes with it.
  RawMesh bowtie;
  bowtie.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {-1, 0, 0}, {-1, -1, 0}};
  bowtie.triangles = {{0, 1, 2}, {0, 3, 4}};
  bowtie.source_faces = 2;
  const auto pm = prepare_mesh(bowtie);
  EXPECT_EQ(pm->n_vertices(), 5u);
  EXPECT_EQ(pm->statistics().non_manifold_vertices, 1u);
  EXPECT_EQ(pm->statistics().duplicated_vertices, 0u);
  ASSERT_EQ(pm->warnings().size(), 1u);
  EXPECT_NE(pm->warnings()[0].find("1 vertex(es) join fans of triangles that meet only there (first: vertex 0)"),
            std::string::npos)
      << pm->warnings()[0];

  RawMesh split;
  split.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}};
  split.triangles = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
  split.source_faces = 3;
  const auto split_pm = prepare_mesh(split);
  for (const auto& warning : split_pm->warnings()) EXPECT_EQ(warning.find("join fans"), std::string::npos);
}

TEST(PreparedMesh, NearestVertexIsTheGridPointNearest) {
  // A regular 11 x 11 grid over [-1, 1]^2 (spacing 0.2): the point just off grid point (i, j)
  // is nearest vertex j * 11 + i.
  const auto pm = prepare_mesh(make_plane_grid(11, 0, 1));
  for (int j = 0; j < 11; ++j)
    for (int i = 0; i < 11; ++i) {
      const Eigen::Vector3d p(-1 + 0.2 * i + 0.07, -1 + 0.2 * j - 0.06, 0.3);
      EXPECT_EQ(pm->nearest_vertex(p), std::uint32_t(j * 11 + i)) << i << ", " << j;
    }
}

TEST(PreparedMesh, NearestVertexAgreesWithAScanAndSkipsUnreferencedVertices) {
  RawMesh raw = make_capsule(1, 2, 32, 8, 6);
  // An unreferenced vertex at the query point itself is never the answer.
  raw.positions.push_back({0.05, 0.05, 3.0});
  const auto pm = prepare_mesh(raw);
  const auto unreferenced = std::uint32_t(raw.positions.size() - 1);
  EXPECT_NE(pm->nearest_vertex(Eigen::Vector3d(0.05, 0.05, 3.0)), unreferenced);
  EXPECT_EQ(pm->nearest_vertex(Eigen::Vector3d(0.05, 0.05, 3.0)), 0u);  // the north pole
  std::mt19937_64 random(7);
  std::uniform_real_distribution<double> coordinate(-2.5, 2.5);
  for (int q = 0; q < 2000; ++q) {
    const Eigen::Vector3d p(coordinate(random), coordinate(random), coordinate(random));
    std::uint32_t best = 0;
    double best_d = HUGE_VAL;
    for (std::uint32_t v = 0; v < pm->n_vertices(); ++v) {
      if (pm->component()[v] < 0) continue;
      const double d = (pm->positions()[v] - p).squaredNorm();
      if (d < best_d) best_d = d, best = v;
    }
    ASSERT_EQ(pm->nearest_vertex(p), best) << "query " << q;
  }
}

TEST(PreparedMesh, MemoryCountsTheTables) {
  const auto pm = prepare_mesh(make_capsule(1, 2, 32, 8, 6));
  const std::size_t tables = (pm->vertex_faces().offsets.size() + pm->vertex_faces().faces.size()) * 4 +
                             pm->face_neighbors().size() * 12 + pm->boundary_vertex().size();
  EXPECT_GE(pm->memory_bytes(), tables + pm->vertex_index().memory_bytes());
  EXPECT_GT(pm->vertex_index().memory_bytes(), pm->n_vertices() * 4);  // at least the id list
}

TEST(PreparedMesh, StageTimingsAreConsecutivePartsOfTheWhole) {
  // The serial stages are timed with one clock, lap after lap, so they cannot add up to more
  // than the whole, and the curvature stage's parts not to more than the curvature stage. The
  // face tables and the k-d tree are built beside them: each on its own is within the whole.
  const auto pm = prepare_mesh(make_capsule(1, 2, 32, 8, 6));
  const PrepareTimings& t = pm->timings();
  const CurvatureTimings& c = pm->curvature().timings;
  for (double ms : {t.triangles_ms, t.adjacency_ms, t.tables_ms, t.index_ms, t.normals_ms, t.curvature_ms, c.mean_ms,
                    c.creases_ms, c.noise_ms, c.jet_ms, c.smoothing_ms})
    EXPECT_GE(ms, 0);
  EXPECT_LE(t.triangles_ms + t.adjacency_ms + t.normals_ms + t.curvature_ms, pm->prepare_ms());
  EXPECT_LE(t.tables_ms, pm->prepare_ms());
  EXPECT_LE(t.index_ms, pm->prepare_ms());
  EXPECT_LE(c.mean_ms + c.creases_ms + c.noise_ms + c.jet_ms + c.smoothing_ms, t.curvature_ms);
  EXPECT_GT(c.jet_ms, 0);  // the default field is the jet: its fits ran
}

// The cube with every face's winding reversed: a closed part whose faces point inward.
RawMesh inside_out(RawMesh mesh) {
  for (auto& t : mesh.triangles) std::swap(t[1], t[2]);
  return mesh;
}

// The crease sign of every edge along the cube's edge y = z = 0 (+1 convex).
std::vector<int> crease_signs_along_x_edge(const PreparedMesh& mesh) {
  std::vector<int> signs;
  for (std::uint32_t v = 0; v < mesh.n_vertices(); ++v)
    for (auto k = mesh.neighbor_offsets()[v]; k < mesh.neighbor_offsets()[v + 1]; ++k) {
      const auto w = mesh.neighbors()[k];
      const auto &p = mesh.positions()[v], &q = mesh.positions()[w];
      if (v < w && p.y() == 0 && p.z() == 0 && q.y() == 0 && q.z() == 0) signs.push_back(mesh.curvature().crease[k]);
    }
  return signs;
}

TEST(PreparedMesh, InwardClosedPartsAreTurnedOutwardAndReported) {
  const int n = 4;
  const auto outward = prepare_mesh(make_subdivided_cube(n));
  EXPECT_EQ(outward->statistics().closed_components, 1u);
  EXPECT_EQ(outward->statistics().inward_components, 0u);
  EXPECT_EQ(outward->statistics().flipped_faces, 0u);
  EXPECT_EQ(crease_signs_along_x_edge(*outward), std::vector<int>(n, 1));

  const auto turned = prepare_mesh(inside_out(make_subdivided_cube(n)));
  EXPECT_EQ(turned->statistics().inward_components, 1u);
  EXPECT_EQ(turned->statistics().flipped_faces, std::size_t(12 * n * n));
  EXPECT_EQ(crease_signs_along_x_edge(*turned), std::vector<int>(n, 1)) << "convex edges read as ridges again";
  EXPECT_EQ(turned->triangles(), outward->triangles()) << "the turned faces are the outward cube's, corner for corner";
  EXPECT_EQ(turned->face_neighbors(), outward->face_neighbors());
  ASSERT_EQ(turned->warnings().size(), 1u);
  EXPECT_NE(turned->warnings()[0].find("pointed inward"), std::string::npos);

  PrepareOptions keep;
  keep.orient_outward = false;
  const auto kept = prepare_mesh(inside_out(make_subdivided_cube(n)), keep);
  EXPECT_EQ(kept->statistics().inward_components, 1u);
  EXPECT_EQ(kept->statistics().flipped_faces, 0u);
  EXPECT_EQ(crease_signs_along_x_edge(*kept), std::vector<int>(n, -1)) << "kept inward: convex edges read as valleys";
  ASSERT_EQ(kept->warnings().size(), 1u);
  EXPECT_NE(kept->warnings()[0].find("convex edges read as valleys"), std::string::npos);
}

TEST(PreparedMesh, OnlyTheInwardPartOfTwoIsTurnedAndOpenPartsAreNotClosed) {
  RawMesh two = make_subdivided_cube(2);
  const RawMesh second = translated(inside_out(make_subdivided_cube(2)), 3, 0, 0);
  const auto offset = std::uint32_t(two.positions.size());
  two.positions.insert(two.positions.end(), second.positions.begin(), second.positions.end());
  for (auto t : second.triangles) two.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  two.source_faces = two.triangles.size();
  const auto mesh = prepare_mesh(two);
  EXPECT_EQ(mesh->statistics().closed_components, 2u);
  EXPECT_EQ(mesh->statistics().inward_components, 1u);
  EXPECT_EQ(mesh->statistics().flipped_faces, 48u);
  for (std::uint32_t f = 0; f < 48; ++f) EXPECT_EQ(mesh->triangles()[f], two.triangles[f]) << "the outward cube keeps its faces";

  const auto open = prepare_mesh(make_plane_grid(5, 0, 1));
  EXPECT_EQ(open->statistics().closed_components, 0u);
  EXPECT_EQ(open->statistics().inward_components, 0u);
}

}  // namespace
}  // namespace featureline
