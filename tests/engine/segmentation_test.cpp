// Mesh decomposition along feature lines (the paper's application, Figs. 8 and 12): snap and
// remesh modes against the capsule's exact areas, validity of the remeshed parts, open lines.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <set>
#include <unordered_map>

#include "api/feature_line_json.h"
#include "api/requests.h"
#include "api/segmentation_json.h"
#include "engine/errors.h"
#include "engine/feature_line.h"
#include "engine/internal/geometry.h"
#include "engine/segmentation.h"
#include "tests/support/synthetic_meshes.h"

namespace featureline {
namespace {

using namespace featureline::testing;

FeatureLineResult line_through(const PreparedMesh& mesh, std::vector<std::uint32_t> keys, bool closed) {
  FeatureLineRequest request;
  request.keys = std::move(keys);
  request.closed = closed;
  return detect_feature_line(mesh, request);
}

FeatureLineResult line_of(std::vector<SurfacePoint> points, bool closed) {
  FeatureLineResult line;
  line.closed = closed;
  line.refined = std::move(points);
  return line;
}

// The loop where the plane normal . x = offset meets the mesh: one point where it crosses each
// edge, one in the middle of each face between (so faces are entered and left through edges
// and split in their interior). Exact on the faceted surface. Assumes a single loop and no
// vertex on the plane.
std::vector<SurfacePoint> plane_loop(const PreparedMesh& mesh, const Eigen::Vector3d& normal, double offset) {
  const auto& tris = mesh.triangles();
  std::vector<double> s(mesh.n_vertices());
  for (std::size_t v = 0; v < s.size(); ++v) s[v] = normal.dot(mesh.positions()[v]) - offset;
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::vector<std::uint32_t>> faces_of;
  for (std::uint32_t f = 0; f < tris.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      auto a = tris[f][k], b = tris[f][(k + 1) % 3];
      faces_of[{std::min(a, b), std::max(a, b)}].push_back(f);
    }
  auto crossed = [&](std::uint32_t f) {
    std::vector<int> edges;
    for (int k = 0; k < 3; ++k)
      if (s[tris[f][k]] * s[tris[f][(k + 1) % 3]] < 0) edges.push_back(k);
    return edges;
  };
  auto crossing = [&](std::uint32_t f, int k) {
    SurfacePoint p;
    const auto a = tris[f][k], b = tris[f][(k + 1) % 3];
    const double t = s[a] / (s[a] - s[b]);
    p.face = f;
    p.barycentric = {0, 0, 0};
    p.barycentric[k] = 1 - t;
    p.barycentric[(k + 1) % 3] = t;
    p.position = (1 - t) * mesh.positions()[a] + t * mesh.positions()[b];
    return p;
  };
  std::uint32_t start = 0;
  while (crossed(start).size() != 2) ++start;
  std::vector<SurfacePoint> loop;
  std::uint32_t f = start;
  int entry = crossed(start)[0];
  do {
    const auto edges = crossed(f);
    const int exit = edges[0] == entry ? edges[1] : edges[0];
    const SurfacePoint in = crossing(f, entry), out = crossing(f, exit);
    SurfacePoint mid = in;
    for (int k = 0; k < 3; ++k) mid.barycentric[k] = 0.5 * (in.barycentric[k] + out.barycentric[k]);
    mid.position = 0.5 * (in.position + out.position);
    loop.push_back(in);
    loop.push_back(mid);
    const auto a = tris[f][exit], b = tris[f][(exit + 1) % 3];
    const auto& pair = faces_of[{std::min(a, b), std::max(a, b)}];
    const std::uint32_t g = pair[0] == f ? pair[1] : pair[0];
    entry = -1;
    for (int k = 0; k < 3; ++k)
      if ((tris[g][k] == a && tris[g][(k + 1) % 3] == b) || (tris[g][k] == b && tris[g][(k + 1) % 3] == a)) entry = k;
    f = g;
  } while (f != start);
  return loop;
}

double mesh_area(const std::vector<Eigen::Vector3d>& p, const std::vector<std::array<std::uint32_t, 3>>& t) {
  double area = 0;
  for (const auto& tri : t) area += 0.5 * (p[tri[1]] - p[tri[0]]).cross(p[tri[2]] - p[tri[0]]).norm();
  return area;
}

// Topology of one part: every directed edge at most once (consistent orientation, manifold
// edges), each boundary vertex with one outgoing boundary edge (manifold vertices), the number
// of boundary loops and the Euler characteristic.
struct PartTopology {
  bool consistent = true;
  int boundary_loops = 0;
  long euler = 0;
  std::vector<std::uint32_t> boundary_vertices;
};
PartTopology part_topology(const std::vector<std::array<std::uint32_t, 3>>& tris, const std::vector<int>& labels, int label) {
  PartTopology topo;
  std::set<std::pair<std::uint32_t, std::uint32_t>> directed;
  std::set<std::uint32_t> vertices;
  long faces = 0;
  for (std::size_t f = 0; f < tris.size(); ++f) {
    if (labels[f] != label) continue;
    ++faces;
    for (int k = 0; k < 3; ++k) {
      vertices.insert(tris[f][k]);
      if (!directed.insert({tris[f][k], tris[f][(k + 1) % 3]}).second) topo.consistent = false;
    }
  }
  std::set<std::pair<std::uint32_t, std::uint32_t>> undirected;
  std::unordered_map<std::uint32_t, std::uint32_t> next;
  for (const auto& [a, b] : directed) {
    undirected.insert({std::min(a, b), std::max(a, b)});
    if (directed.count({b, a})) continue;
    if (!next.emplace(a, b).second) topo.consistent = false;  // two boundary edges leave a
  }
  std::set<std::uint32_t> seen;
  for (const auto& [a, b] : next) {
    (void)b;
    topo.boundary_vertices.push_back(a);
    if (seen.count(a)) continue;
    ++topo.boundary_loops;
    for (auto v = a; !seen.count(v);) {
      seen.insert(v);
      const auto it = next.find(v);
      if (it == next.end()) {
        topo.consistent = false;
        break;
      }
      v = it->second;
    }
  }
  topo.euler = long(vertices.size()) - long(undirected.size()) + faces;
  return topo;
}

// A capsule whose cylinder bands are 0.5 high: rings at z = 1, 0.5, 0, -0.5, -1.
struct Capsule {
  double r = 1, h = 2;
  int segments = 48, rings_per_cap = 12, rings_cylinder = 4;
  std::shared_ptr<const PreparedMesh> mesh = prepare_mesh(make_capsule(r, h, segments, rings_per_cap, rings_cylinder));
  /// Key vertices on the vertex ring at height h/2 - m * h / rings_cylinder, every quarter turn.
  std::vector<std::uint32_t> ring_keys(int m) const {
    const auto first = 1 + std::uint32_t(rings_per_cap - 1 + m) * std::uint32_t(segments);
    return {first, first + std::uint32_t(segments) / 4, first + std::uint32_t(segments) / 2,
            first + 3 * std::uint32_t(segments) / 4};
  }
};

double area_where(const SegmentationResult& r, const PreparedMesh& mesh, int label) {
  const auto& p = r.remeshed ? r.positions : mesh.positions();
  const auto& t = r.remeshed ? r.triangles : mesh.triangles();
  double area = 0;
  for (std::size_t f = 0; f < t.size(); ++f)
    if (r.labels[f] == label) area += 0.5 * (p[t[f][1]] - p[t[f][0]]).cross(p[t[f][2]] - p[t[f][0]]).norm();
  return area;
}

// The segment above (higher bbox centre) of a two-segment result.
const Segment& upper(const SegmentationResult& r) {
  const auto& a = r.segments[0];
  const auto& b = r.segments[1];
  return a.bbox_min[2] + a.bbox_max[2] > b.bbox_min[2] + b.bbox_max[2] ? a : b;
}

TEST(Segmentation, SnapCutsCapsuleAtEquatorIntoExactHalves) {
  const int segments = 48, rings_per_cap = 12, rings_cylinder = 8;
  const auto mesh = prepare_mesh(make_capsule(1, 2, segments, rings_per_cap, rings_cylinder));
  const auto equator = capsule_equator(segments, rings_per_cap, rings_cylinder);
  const auto line = line_through(*mesh, {equator[0], equator[12], equator[24], equator[36]}, true);
  const auto r = segment_mesh(*mesh, {line});
  ASSERT_EQ(r.segments.size(), 2u);
  EXPECT_FALSE(r.remeshed);
  EXPECT_TRUE(r.positions.empty());
  ASSERT_EQ(r.labels.size(), mesh->triangles().size());
  const double half = capsule_area_above(1, 2, 0);
  for (const auto& s : r.segments) {
    EXPECT_NEAR(s.area, half, 0.01 * half) << "segment " << s.label;
    EXPECT_NEAR(s.boundary_length, 2 * M_PI, 0.01 * 2 * M_PI);
    EXPECT_EQ(s.faces, mesh->triangles().size() / 2);
    EXPECT_NEAR(s.area, area_where(r, *mesh, s.label), 1e-12);
  }
  EXPECT_NEAR(r.total_area, r.segments[0].area + r.segments[1].area, 1e-12);
  EXPECT_EQ(r.cut_edges, std::size_t(segments));
  EXPECT_NEAR(upper(r).bbox_min[2], 0, 1e-12);  // the cut is the equator ring itself
  EXPECT_NEAR(upper(r).bbox_max[2], 2, 1e-12);
  EXPECT_TRUE(r.warnings.empty()) << r.warnings.front();
}

TEST(Segmentation, RemeshFollowsLoopBetweenVertexRingsWhereSnapCannot) {
  // The plane z = 0.2 lies 40% of the way between the vertex rings at z = 0 and z = 0.5:
  // snapping moves the cut to z = 0 (an error of 2*pi*0.2 in area), remeshing cuts at 0.2.
  const Capsule capsule;
  const auto& mesh = *capsule.mesh;
  const double c = 0.2, above = capsule_area_above(capsule.r, capsule.h, c);
  const auto line = line_of(plane_loop(mesh, {0, 0, 1}, c), true);

  SegmentationOptions remesh;
  remesh.mode = SegmentationMode::remesh;
  const auto r = segment_mesh(mesh, {line}, remesh);
  ASSERT_EQ(r.segments.size(), 2u);
  EXPECT_TRUE(r.remeshed);
  const double remesh_error = std::abs(upper(r).area - above);
  EXPECT_LT(remesh_error, 0.01 * above);
  EXPECT_NEAR(upper(r).boundary_length, 2 * M_PI, 0.01 * 2 * M_PI);
  EXPECT_NEAR(upper(r).bbox_min[2], c, 1e-12);

  const auto s = segment_mesh(mesh, {line});
  ASSERT_EQ(s.segments.size(), 2u);
  const double snap_error = std::abs(upper(s).area - above);
  EXPECT_GT(snap_error, 0.08 * above);  // 2*pi*0.2 / (2*pi*1.8) = 11%
  EXPECT_GT(snap_error, 20 * remesh_error);
}

TEST(Segmentation, RemeshedTiltedLoopIsExactAndValid) {
  // A tilted plane z = 0.1 + 0.3 x through the cylinder part: the area above it is the
  // horizontal plane's at its centre height (the tilt's contribution integrates to zero).
  const Capsule capsule;
  const auto& mesh = *capsule.mesh;
  const auto line = line_of(plane_loop(mesh, Eigen::Vector3d(-0.3, 0, 1), 0.1), true);
  SegmentationOptions options;
  options.mode = SegmentationMode::remesh;
  options.remesh_snap = 0;  // every crossing exactly on the plane
  const auto r = segment_mesh(mesh, {line}, options);
  ASSERT_EQ(r.segments.size(), 2u);
  const double above = capsule_area_above(capsule.r, capsule.h, 0.1);
  EXPECT_NEAR(upper(r).area, above, 0.01 * above);
  EXPECT_NEAR(r.total_area, capsule_area(capsule.r, capsule.h), 0.01 * capsule_area(capsule.r, capsule.h));

  // Area preserved, original vertices kept, new ones appended, faces traced to their source.
  const double original = mesh_area(mesh.positions(), mesh.triangles());
  EXPECT_NEAR(mesh_area(r.positions, r.triangles), original, 1e-9 * original);
  EXPECT_NEAR(r.total_area, original, 1e-9 * original);
  ASSERT_GT(r.positions.size(), mesh.n_vertices());
  for (std::size_t v = 0; v < mesh.n_vertices(); ++v) ASSERT_EQ(r.positions[v], mesh.positions()[v]) << v;
  ASSERT_EQ(r.source_faces.size(), r.triangles.size());
  ASSERT_EQ(r.labels.size(), r.triangles.size());
  std::vector<double> split_area(mesh.triangles().size(), 0);
  for (std::size_t f = 0; f < r.triangles.size(); ++f) {
    const auto& t = r.triangles[f];
    split_area[r.source_faces[f]] += 0.5 * (r.positions[t[1]] - r.positions[t[0]]).cross(r.positions[t[2]] - r.positions[t[0]]).norm();
    if (f < mesh.triangles().size()) {
      EXPECT_EQ(r.source_faces[f], f);
    }
  }
  for (std::size_t f = 0; f < mesh.triangles().size(); ++f) {
    const auto& t = mesh.triangles()[f];
    const double a = 0.5 * (mesh.positions()[t[1]] - mesh.positions()[t[0]]).cross(mesh.positions()[t[2]] - mesh.positions()[t[0]]).norm();
    ASSERT_NEAR(split_area[f], a, 1e-12) << "face " << f;
  }

  // Each part is a disc: consistently oriented, manifold, one boundary loop on the plane.
  for (int label = 0; label < 2; ++label) {
    const auto topo = part_topology(r.triangles, r.labels, label);
    EXPECT_TRUE(topo.consistent) << "part " << label;
    EXPECT_EQ(topo.boundary_loops, 1) << "part " << label;
    EXPECT_EQ(topo.euler, 1) << "part " << label;
    for (auto v : topo.boundary_vertices) {
      ASSERT_GE(v, mesh.n_vertices());
      const auto& p = r.positions[v];
      ASSERT_NEAR(p.z(), 0.1 + 0.3 * p.x(), 1e-12);
    }
  }
}

TEST(Segmentation, RemeshAlongDetectedLineOnVerticesAndEdges) {
  // A detected loop on the equator ring runs through vertices and along edges: the remeshed
  // parts are the same halves, with few or no new vertices.
  const int segments = 48, rings_per_cap = 12, rings_cylinder = 8;
  const auto mesh = prepare_mesh(make_capsule(1, 2, segments, rings_per_cap, rings_cylinder));
  const auto equator = capsule_equator(segments, rings_per_cap, rings_cylinder);
  const auto line = line_through(*mesh, {equator[0], equator[12], equator[24], equator[36]}, true);
  SegmentationOptions options;
  options.mode = SegmentationMode::remesh;
  const auto r = segment_mesh(*mesh, {line}, options);
  ASSERT_EQ(r.segments.size(), 2u);
  const double half = capsule_area_above(1, 2, 0);
  for (int label = 0; label < 2; ++label) {
    EXPECT_NEAR(r.segments[std::size_t(label)].area, half, 0.01 * half);
    const auto topo = part_topology(r.triangles, r.labels, label);
    EXPECT_TRUE(topo.consistent);
    EXPECT_EQ(topo.boundary_loops, 1);
    EXPECT_EQ(topo.euler, 1);
  }
  const double original = mesh_area(mesh->positions(), mesh->triangles());
  EXPECT_NEAR(r.total_area, original, 1e-9 * original);
}

TEST(Segmentation, ThreeLoopsGiveFourSegmentsOrderedByArea) {
  // Long capsule (h = 6, bands 0.5 high) cut at z = 1.5, 0.5 and -1: parts of area
  // 2pi + 2pi*1.5 = 5pi (top), 2pi*1 = 2pi, 2pi*1.5 = 3pi, 2pi + 2pi*2 = 6pi (bottom).
  const int segments = 32, rings_per_cap = 8, rings_cylinder = 12;
  const auto mesh = prepare_mesh(make_capsule(1, 6, segments, rings_per_cap, rings_cylinder));
  auto ring = [&](int m) {  // keys on the vertex ring at z = 3 - m/2
    const auto first = 1 + std::uint32_t(rings_per_cap - 1 + m) * std::uint32_t(segments);
    return std::vector<std::uint32_t>{first, first + 8, first + 16, first + 24};
  };
  const std::vector<FeatureLineResult> lines{line_through(*mesh, ring(3), true), line_through(*mesh, ring(5), true),
                                             line_through(*mesh, ring(8), true)};
  for (auto mode : {SegmentationMode::snap, SegmentationMode::remesh}) {
    SegmentationOptions options;
    options.mode = mode;
    const auto r = segment_mesh(*mesh, lines, options);
    ASSERT_EQ(r.segments.size(), 4u);
    const double expected[4] = {6 * M_PI, 5 * M_PI, 3 * M_PI, 2 * M_PI};
    const double centre_z[4] = {-2.5, 2.75, -0.25, 1.0};  // bbox centres: bottom, top, the two middle ones
    for (int label = 0; label < 4; ++label) {
      const auto& s = r.segments[std::size_t(label)];
      EXPECT_EQ(s.label, label);
      EXPECT_NEAR(s.area, expected[label], 0.01 * expected[label]) << "label " << label;
      EXPECT_NEAR(0.5 * (s.bbox_min[2] + s.bbox_max[2]), centre_z[label], 1e-9) << "label " << label;
      // The middle parts have two boundary loops, the ends one.
      const double loops = label >= 2 ? 2 : 1;
      EXPECT_NEAR(s.boundary_length, loops * 2 * M_PI, 0.01 * loops * 2 * M_PI) << "label " << label;
    }
    EXPECT_TRUE(r.warnings.empty()) << r.warnings.front();
  }
}

TEST(Segmentation, OpenLineThatClosesNothingIsAGeometryError) {
  const Capsule capsule;
  const auto keys = capsule.ring_keys(2);  // the equator
  const auto line = line_through(*capsule.mesh, {keys[0], keys[1], keys[2]}, false);  // half the ring
  for (auto mode : {SegmentationMode::snap, SegmentationMode::remesh}) {
    SegmentationOptions options;
    options.mode = mode;
    try {
      segment_mesh(*capsule.mesh, {line}, options);
      ADD_FAILURE() << "no error";
    } catch (const GeometryError& e) {
      const std::string message = e.what();
      EXPECT_EQ(message.rfind("the lines close no region: ", 0), 0u) << message;
      EXPECT_NE(message.find("line 0 ends at"), std::string::npos) << message;
      EXPECT_NE(message.find("must end on the mesh boundary or on another line"), std::string::npos) << message;
    }
  }
}

TEST(Segmentation, OpenLinesEndingOnTheBoundarySplitATube) {
  // An open tube: one line from the bottom rim to the top rim leaves it in one piece; two
  // lines cut it in halves. Lines ending one ring short of the rims are joined to them.
  const int rings = 8, segments = 32;
  const auto mesh = prepare_mesh(make_cylinder(1, 2, rings, segments, false));
  auto column = [&](std::uint32_t k, int from_ring, int to_ring) {
    return std::vector<std::uint32_t>{std::uint32_t(from_ring) * segments + k, std::uint32_t(rings / 2) * segments + k,
                                      std::uint32_t(to_ring) * segments + k};
  };
  for (auto mode : {SegmentationMode::snap, SegmentationMode::remesh}) {
    SegmentationOptions options;
    options.mode = mode;
    const auto a = line_through(*mesh, column(0, 0, rings), false), b = line_through(*mesh, column(16, 0, rings), false);
    EXPECT_THROW(segment_mesh(*mesh, {a}, options), GeometryError);
    const auto r = segment_mesh(*mesh, {a, b}, options);
    ASSERT_EQ(r.segments.size(), 2u);
    EXPECT_NEAR(r.segments[0].area, r.segments[1].area, 0.01 * r.segments[0].area);
    EXPECT_NEAR(r.segments[0].boundary_length, 4, 0.04);  // two straight cuts of length 2

    const auto a_short = line_through(*mesh, column(0, 1, rings - 1), false);
    const auto b_short = line_through(*mesh, column(16, 1, rings - 1), false);
    const auto joined = segment_mesh(*mesh, {a_short, b_short}, options);
    ASSERT_EQ(joined.segments.size(), 2u);
    EXPECT_NEAR(joined.segments[0].area, joined.segments[1].area, 0.01 * joined.segments[0].area);
    options.attach_distance = 0;
    EXPECT_THROW(segment_mesh(*mesh, {a_short, b_short}, options), GeometryError);
  }
}

TEST(Segmentation, OpenLineEndingOnALoopSplitsItsSide) {
  // The equator loop, and an open line from the equator over the north pole back to the
  // equator: the south half and two north quarters.
  const Capsule capsule;
  const auto& mesh = *capsule.mesh;
  const auto equator = capsule.ring_keys(2);
  const auto loop = line_through(mesh, equator, true);
  const auto arch = line_through(mesh, {equator[0], 0, equator[2]}, false);
  const double half = capsule_area_above(capsule.r, capsule.h, 0);
  for (auto mode : {SegmentationMode::snap, SegmentationMode::remesh}) {
    SegmentationOptions options;
    options.mode = mode;
    const auto r = segment_mesh(mesh, {loop, arch}, options);
    ASSERT_EQ(r.segments.size(), 3u);
    EXPECT_NEAR(r.segments[0].area, half, 0.01 * half);
    EXPECT_NEAR(r.segments[1].area, half / 2, 0.02 * half / 2);
    EXPECT_NEAR(r.segments[2].area, half / 2, 0.02 * half / 2);
    EXPECT_LT(r.segments[0].bbox_max[2], 1e-9);  // the south half
    EXPECT_TRUE(r.warnings.empty()) << r.warnings.front();
    if (mode == SegmentationMode::remesh) {
      for (int label = 0; label < 3; ++label) {
        const auto topo = part_topology(r.triangles, r.labels, label);
        EXPECT_TRUE(topo.consistent);
        EXPECT_EQ(topo.boundary_loops, 1);
        EXPECT_EQ(topo.euler, 1);
      }
    }
  }
}

TEST(Segmentation, CrossingLoopsMeetAtNewVertices) {
  // Two loops on a sphere crossing twice (planes z = 0.1 and x = 0.13): four discs.
  const auto mesh = prepare_mesh(make_icosphere(1, 4));
  const auto a = line_of(plane_loop(*mesh, {0, 0, 1}, 0.1), true);
  const auto b = line_of(plane_loop(*mesh, {1, 0, 0}, 0.13), true);
  SegmentationOptions options;
  options.mode = SegmentationMode::remesh;
  const auto r = segment_mesh(*mesh, {a, b}, options);
  ASSERT_EQ(r.segments.size(), 4u);
  double above = 0;
  for (const auto& s : r.segments) {
    const auto topo = part_topology(r.triangles, r.labels, s.label);
    EXPECT_TRUE(topo.consistent) << s.label;
    EXPECT_EQ(topo.boundary_loops, 1) << s.label;
    EXPECT_EQ(topo.euler, 1) << s.label;
    if (s.bbox_max[2] > 0.5) above += s.area;
  }
  EXPECT_NEAR(above, 2 * M_PI * 0.9, 0.01 * 2 * M_PI * 0.9);  // the sphere's zone above z = 0.1
  const double original = mesh_area(mesh->positions(), mesh->triangles());
  EXPECT_NEAR(r.total_area, original, 1e-9 * original);
}

TEST(Segmentation, TinyRegionsAreReported) {
  // A small loop inside one face (remesh), and a loop around the pole's fan (snap).
  const Capsule capsule;
  const auto& mesh = *capsule.mesh;
  const std::uint32_t face = 2000;
  std::vector<SurfacePoint> points;
  for (const auto& w : {std::array<double, 3>{0.5, 0.25, 0.25}, {0.25, 0.5, 0.25}, {0.25, 0.25, 0.5}}) {
    SurfacePoint p;
    p.face = face;
    p.barycentric = w;
    const auto& t = mesh.triangles()[face];
    p.position = w[0] * mesh.positions()[t[0]] + w[1] * mesh.positions()[t[1]] + w[2] * mesh.positions()[t[2]];
    points.push_back(p);
  }
  SegmentationOptions options;
  options.mode = SegmentationMode::remesh;
  const auto r = segment_mesh(mesh, {line_of(points, true)}, options);
  ASSERT_EQ(r.segments.size(), 2u);
  const auto& t = mesh.triangles()[face];
  const double face_area = 0.5 * (mesh.positions()[t[1]] - mesh.positions()[t[0]]).cross(mesh.positions()[t[2]] - mesh.positions()[t[0]]).norm();
  EXPECT_NEAR(r.segments[1].area, face_area / 16, 1e-12);  // the triangle between the three points
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_EQ(r.warnings[0].rfind("segment 1 is tiny: ", 0), 0u) << r.warnings[0];
  for (int label = 0; label < 2; ++label) EXPECT_EQ(part_topology(r.triangles, r.labels, label).boundary_loops, 1);

  // Merged instead: with the equator loop there are still two halves; alone it closes nothing.
  options.merge_tiny_segments = true;
  const auto merged = segment_mesh(mesh, {line_through(mesh, capsule.ring_keys(2), true), line_of(points, true)}, options);
  ASSERT_EQ(merged.segments.size(), 2u);
  EXPECT_NEAR(merged.segments[0].area, merged.segments[1].area, 0.01 * merged.segments[0].area);
  ASSERT_EQ(merged.warnings.size(), 2u);
  EXPECT_EQ(merged.warnings[0], "line 1 separates no segments from each other (it runs inside one segment)");
  EXPECT_EQ(merged.warnings[1].rfind("1 segment(s) below min_segment_area_fraction were merged", 0), 0u) << merged.warnings[1];
  EXPECT_THROW(segment_mesh(mesh, {line_of(points, true)}, options), GeometryError);

  const auto pole = line_through(mesh, capsule.ring_keys(1 - capsule.rings_per_cap), true);
  SegmentationOptions snap;
  snap.min_segment_area_fraction = 0.01;
  const auto s = segment_mesh(mesh, {pole}, snap);
  ASSERT_EQ(s.segments.size(), 2u);
  EXPECT_EQ(s.segments[1].faces, std::size_t(capsule.segments));  // the fan around the pole
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_EQ(s.warnings[0].rfind("segment 1 is tiny: ", 0), 0u) << s.warnings[0];
}

TEST(Segmentation, ALineAlongTheBorderCutsOffNoSliver) {
  // A line that starts along the border within a fraction of an edge snaps to a border vertex,
  // the inner corner of the border edge's face, and the next border vertex: cut along those
  // two edges, that face would be a one-face segment. Then the line follows the border one more
  // edge and crosses to the far side along a row of vertices.
  const auto mesh = prepare_mesh(make_plane_grid(11, 0, 1));
  auto point_at = [&](double x, double y) {
    for (std::uint32_t f = 0; f < mesh->n_faces(); ++f) {
      const auto& t = mesh->triangles()[f];
      const Eigen::Vector3d a = mesh->positions()[t[0]], b = mesh->positions()[t[1]], c = mesh->positions()[t[2]];
      const double area = (b - a).cross(c - a).z(), p[2] = {x, y};
      auto cross = [&](const Eigen::Vector3d& u, const Eigen::Vector3d& v) {
        return (v.x() - u.x()) * (p[1] - u.y()) - (v.y() - u.y()) * (p[0] - u.x());
      };
      const double wa = cross(b, c) / area, wb = cross(c, a) / area, wc = cross(a, b) / area;
      if (wa >= -1e-12 && wb >= -1e-12 && wc >= -1e-12) {
        SurfacePoint s;
        s.face = f;
        s.barycentric = {wa, wb, wc};
        s.position = mesh->point_at(f, s.barycentric);
        return s;
      }
    }
    throw std::runtime_error("no face holds the point");
  };
  // Border edge (-1, 0) - (-1, -0.2) and its face's inner corner.
  const std::uint32_t a = mesh->nearest_vertex({-1, 0, 0}), c = mesh->nearest_vertex({-1, -0.2, 0});
  ASSERT_TRUE(mesh->are_neighbors(a, c));
  std::uint32_t b = kNoIndex;
  for (const std::uint32_t f : mesh->faces_around(a))
    for (const auto v : mesh->triangles()[f])
      if (v != a && v != c && corner_of(mesh->triangles()[f], c) >= 0) b = v;
  ASSERT_NE(b, kNoIndex);
  ASSERT_FALSE(mesh->boundary_vertex()[b]);
  const std::uint32_t d = mesh->nearest_vertex({-1, -0.4, 0});
  std::vector<SurfacePoint> points;
  for (const auto v : {a, b, c, d}) points.push_back(surface_point_at_vertex(*mesh, v));
  for (double x = -0.9; x <= 1.0001; x += 0.1) points.push_back(point_at(std::min(x, 1.0), -0.4));
  const auto r = segment_mesh(*mesh, {line_of(points, false)}, SegmentationOptions{});
  ASSERT_EQ(r.segments.size(), 2u);
  EXPECT_TRUE(r.warnings.empty()) << r.warnings[0];
  EXPECT_NEAR(r.segments[0].area + r.segments[1].area, 4, 1e-9);
}

TEST(Segmentation, BadInputIsRejected) {
  const Capsule capsule;
  EXPECT_THROW(segment_mesh(*capsule.mesh, {}), InvalidInputError);
  auto line = line_through(*capsule.mesh, capsule.ring_keys(2), true);
  auto bad_face = line;
  bad_face.refined[3].face = std::uint32_t(capsule.mesh->triangles().size());
  EXPECT_THROW(segment_mesh(*capsule.mesh, {bad_face}), InvalidInputError);
  auto bad_weights = line;
  bad_weights.refined[3].barycentric = {0.5, 0.5, 0.5};
  EXPECT_THROW(segment_mesh(*capsule.mesh, {bad_weights}), InvalidInputError);
  SegmentationOptions options;
  options.min_segment_area_fraction = 1.5;
  EXPECT_THROW(segment_mesh(*capsule.mesh, {line}, options), InvalidInputError);
}

// A line as a client sends it back: the "refined" and "closed" of its feature-line answer.
nlohmann::json computed_item(const FeatureLineResult& line) {
  const auto answer = feature_line_to_json(line);
  return {{"refined", answer["refined"]}, {"closed", answer["closed"]}};
}

void expect_same_segmentation(const SegmentationResult& a, const SegmentationResult& b) {
  EXPECT_EQ(a.labels, b.labels);
  ASSERT_EQ(a.segments.size(), b.segments.size());
  for (std::size_t i = 0; i < a.segments.size(); ++i) {
    EXPECT_EQ(a.segments[i].faces, b.segments[i].faces);
    EXPECT_EQ(a.segments[i].area, b.segments[i].area);
    EXPECT_EQ(a.segments[i].boundary_length, b.segments[i].boundary_length);
  }
  EXPECT_EQ(a.warnings, b.warnings);
  EXPECT_EQ(a.cut_edges, b.cut_edges);
  EXPECT_EQ(a.triangles, b.triangles);
  EXPECT_EQ(a.source_faces, b.source_faces);
  ASSERT_EQ(a.positions.size(), b.positions.size());
  for (std::size_t v = 0; v < a.positions.size(); ++v) EXPECT_EQ(a.positions[v], b.positions[v]) << "vertex " << v;
}

TEST(Segmentation, ComputedLinesGiveTheSameSegmentationAsRequests) {
  // The lines a client already has, sent back as their answers' faces and barycentric
  // coordinates (through JSON), segment exactly as the requests that detected them: a closed
  // loop, an open line ending on it, and a tilted plane loop whose points lie inside faces.
  const Capsule capsule;
  const auto& mesh = *capsule.mesh;
  const auto equator = capsule.ring_keys(2);
  const std::vector<FeatureLineResult> detected{
      line_through(mesh, equator, true), line_through(mesh, {equator[0], 0, equator[2]}, false),
      line_of(plane_loop(mesh, Eigen::Vector3d(-0.3, 0, 1), -0.6), true)};
  std::vector<FeatureLineResult> computed;
  for (std::size_t i = 0; i < detected.size(); ++i)
    computed.push_back(parse_computed_line(nlohmann::json::parse(computed_item(detected[i]).dump()), mesh,
                                           "lines[" + std::to_string(i) + "]"));
  for (std::size_t i = 0; i < detected.size(); ++i) {
    ASSERT_EQ(computed[i].refined.size(), detected[i].refined.size());
    EXPECT_EQ(computed[i].closed, detected[i].closed);
  }
  for (auto mode : {SegmentationMode::snap, SegmentationMode::remesh}) {
    SegmentationOptions options;
    options.mode = mode;
    const auto from_requests = segment_mesh(mesh, detected, options);
    EXPECT_EQ(from_requests.segments.size(), 4u);
    expect_same_segmentation(from_requests, segment_mesh(mesh, computed, options));
  }
}

TEST(Segmentation, ARequestsComputedLinesAreKeptAndOnlyItsRequestsDetected) {
  const Capsule capsule;
  const auto& mesh = *capsule.mesh;
  const auto loop = line_through(mesh, capsule.ring_keys(1), true);
  const nlohmann::json body = {{"lines", {computed_item(loop), {{"keys", capsule.ring_keys(3)}, {"closed", true}}, computed_item(loop)}},
                               {"mode", "snap"}};
  SegmentationRequest request = parse_segmentation_request(body, mesh);
  EXPECT_EQ(request.options.mode, SegmentationMode::snap);
  ASSERT_EQ(request.requests.size(), 1u);
  EXPECT_EQ(request.requested_at, std::vector<std::size_t>{1});
  EXPECT_EQ(request.requests[0].keys, capsule.ring_keys(3));
  EXPECT_TRUE(request.requests[0].closed);
  std::vector<FeatureLineResult> detected;
  for (const auto& r : request.requests) detected.push_back(detect_feature_line(mesh, r));
  const auto resolved = std::move(request).lines_with(std::move(detected));
  ASSERT_EQ(resolved.size(), 3u);
  EXPECT_EQ(resolved[1].keys, capsule.ring_keys(3));  // the detected one, in its place
  EXPECT_EQ(resolved[0].refined.size(), loop.refined.size());
  EXPECT_EQ(segment_mesh(mesh, resolved).segments.size(), 3u);  // the duplicate loop cuts nothing new
  // Every line computed: nothing to detect.
  EXPECT_TRUE(parse_segmentation_request({{"lines", {computed_item(loop)}}}, mesh).requests.empty());
}

// The InvalidInputError message of parsing `item` as lines[0].
std::string computed_line_error(const PreparedMesh& mesh, const nlohmann::json& item) {
  try {
    parse_computed_line(item, mesh, "lines[0]");
  } catch (const InvalidInputError& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(Segmentation, ComputedLineErrorsNameTheField) {
  const Capsule capsule;
  const auto& mesh = *capsule.mesh;
  const std::string faces = std::to_string(mesh.triangles().size());
  auto item = [](nlohmann::json face_ids, nlohmann::json barycentric) {
    return nlohmann::json{{"refined", {{"faces", std::move(face_ids)}, {"barycentric", std::move(barycentric)}}}};
  };
  const nlohmann::json w = {0.2, 0.3, 0.5};
  EXPECT_EQ(computed_line_error(mesh, item({1, 2}, {w, w})), "(accepted)");
  EXPECT_EQ(computed_line_error(mesh, item({1, mesh.triangles().size()}, {w, w})),
            "lines[0].refined, point 1: face " + faces + " is out of range (the mesh has " + faces + " faces)");
  EXPECT_EQ(computed_line_error(mesh, item({1, 4294967297ULL}, {w, w})),
            "lines[0].refined, point 1: face 4294967297 is out of range (the mesh has " + faces + " faces)");
  EXPECT_EQ(computed_line_error(mesh, item({1, -2}, {w, w})), "lines[0].refined, point 1: the face must be an integer >= 0");
  EXPECT_EQ(computed_line_error(mesh, item({1, 2}, {w, {0.5, 0.5, 0.5}})),
            "lines[0].refined, point 1: barycentric coordinates must sum to 1");
  EXPECT_EQ(computed_line_error(mesh, item({1, 2}, {{-0.5, 1.0, 0.5}, w})),
            "lines[0].refined, point 0: barycentric coordinates must be finite and non-negative");
  EXPECT_EQ(computed_line_error(mesh, item({1, 2}, {w, {0.5, 0.5}})),
            "lines[0].refined, point 1: barycentric coordinates must be an array of three numbers");
  EXPECT_EQ(computed_line_error(mesh, item({1, 2, 3}, {w, w})), "lines[0].refined has 3 faces but 2 barycentric triples");
  EXPECT_EQ(computed_line_error(mesh, item({1}, {w})), "lines[0].refined needs at least two points");
  EXPECT_EQ(computed_line_error(mesh, {{"refined", {{"faces", {1, 2}}}}}),
            "lines[0].refined.barycentric must be an array of [w0, w1, w2] triples");
  auto with_options = item({1, 2}, {w, w});
  with_options["options"] = nlohmann::json::object();
  EXPECT_EQ(computed_line_error(mesh, with_options),
            "unknown field \"lines[0].options\" in a computed line (it has \"refined\", \"closed\" and \"keys\")");
  auto keys_text = item({1, 2}, {w, w});
  keys_text["keys"] = "1,2";
  EXPECT_EQ(computed_line_error(mesh, keys_text), "lines[0].keys must be an array (the keys the line was detected from)");
  auto with_keys = item({1, 2}, {w, w});
  with_keys["keys"] = {5, 7};
  EXPECT_EQ(computed_line_error(mesh, with_keys), "(accepted)");
  auto closed_text = item({1, 2}, {w, w});
  closed_text["closed"] = "yes";
  EXPECT_EQ(computed_line_error(mesh, closed_text), "lines[0].closed must be true or false");
  // The answer's whole "refined" (with points and length) is accepted; positions come from the faces.
  auto whole = item({1, 2}, {w, w});
  whole["refined"]["points"] = {{9, 9, 9}, {9, 9, 9}};
  whole["refined"]["length"] = 1;
  const auto line = parse_computed_line(whole, mesh, "lines[0]");
  const auto& t = mesh.triangles()[2];
  EXPECT_EQ(line.refined[1].position,
            Eigen::Vector3d(0.2 * mesh.positions()[t[0]] + 0.3 * mesh.positions()[t[1]] + 0.5 * mesh.positions()[t[2]]));
  EXPECT_THROW(parse_segmentation_request({{"lines", nlohmann::json::array()}}, mesh), InvalidInputError);
  EXPECT_THROW(parse_segmentation_request({{"mode", "snap"}}, mesh), InvalidInputError);  // "lines" is required
}

}  // namespace
}  // namespace featureline
