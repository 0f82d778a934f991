// Known answers of the accuracy meshes (tests/support/accuracy_meshes.h): noise with the
// requested RMS, the rounded slab (closed, manifold, outward, its outlines exactly on the
// analytic rounded rectangle, skinny triangles really skinny), exact polyline distances, and
// crease chains on the slab, on hand-made meshes and on fandisk.
#include "tests/support/accuracy_meshes.h"
#include "tests/support/shared_data.h"
#include "tests/support/synthetic_meshes.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <map>
#include <ostream>
#include <set>
#include <stdexcept>
#include <utility>

namespace featureline::testing {

// Readable parameter values in test names and failure messages.
void PrintTo(SlabTessellation tessellation, std::ostream* os) {
  *os << (tessellation == SlabTessellation::skinny ? "skinny" : "fine");
}

namespace {

constexpr double kPi = 3.14159265358979323846;
using Edge = std::pair<std::uint32_t, std::uint32_t>;

Eigen::Vector3d at(const RawMesh& mesh, std::uint32_t v) {
  return {mesh.positions[v][0], mesh.positions[v][1], mesh.positions[v][2]};
}

std::set<Edge> undirected_edges(const RawMesh& mesh) {
  std::set<Edge> edges;
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) {
      const auto a = t[std::size_t(k)], b = t[std::size_t((k + 1) % 3)];
      edges.emplace(std::min(a, b), std::max(a, b));
    }
  return edges;
}

double signed_volume(const RawMesh& mesh) {
  double volume = 0;
  for (const auto& t : mesh.triangles) volume += at(mesh, t[0]).dot(at(mesh, t[1]).cross(at(mesh, t[2]))) / 6;
  return volume;
}

// Longest edge squared over twice the area: longest edge over the altitude onto it (2/sqrt(3)
// for an equilateral triangle, about length/width for a long thin one).
double aspect_ratio(const RawMesh& mesh, const std::array<std::uint32_t, 3>& t) {
  const Eigen::Vector3d a = at(mesh, t[0]), b = at(mesh, t[1]), c = at(mesh, t[2]);
  const double longest = std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()});
  return longest / (b - a).cross(c - a).norm();
}

double max_aspect_ratio(const RawMesh& mesh) {
  double worst = 0;
  for (const auto& t : mesh.triangles) worst = std::max(worst, aspect_ratio(mesh, t));
  return worst;
}

// Closed, consistently oriented and manifold: every directed edge once with its reverse
// present, no degenerate triangle, and the triangles around each vertex form one cycle.
void expect_closed_oriented_manifold(const RawMesh& mesh) {
  std::set<Edge> directed;
  std::map<std::uint32_t, std::map<std::uint32_t, std::uint32_t>> around;  // v -> (a -> b) for corners (v, a, b)
  for (const auto& t : mesh.triangles) {
    ASSERT_TRUE(t[0] != t[1] && t[1] != t[2] && t[0] != t[2]) << "degenerate triangle";
    for (int k = 0; k < 3; ++k) {
      const auto v = t[std::size_t(k)], a = t[std::size_t((k + 1) % 3)], b = t[std::size_t((k + 2) % 3)];
      EXPECT_TRUE(directed.emplace(v, a).second) << "directed edge " << v << "->" << a << " twice";
      EXPECT_TRUE(around[v].emplace(a, b).second) << "vertex " << v << " is not manifold";
    }
  }
  for (const auto& [a, b] : directed) EXPECT_TRUE(directed.count({b, a})) << "edge " << a << "-" << b << " is a boundary";
  EXPECT_EQ(around.size(), mesh.positions.size()) << "unreferenced vertices";
  for (const auto& [v, next] : around) {
    std::size_t steps = 0;
    std::uint32_t current = next.begin()->first;
    do {
      const auto it = next.find(current);
      if (it == next.end()) break;
      current = it->second;
      ++steps;
    } while (current != next.begin()->first && steps <= next.size());
    EXPECT_EQ(steps, next.size()) << "the triangles around vertex " << v << " form more than one fan";
  }
  const auto v = double(mesh.positions.size()), e = double(undirected_edges(mesh).size()), f = double(mesh.triangles.size());
  EXPECT_EQ(v - e + f, 2.0) << "Euler characteristic of a closed genus-0 surface";
}

RawMesh unit_square() {
  RawMesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
  return mesh;
}

RawMesh cube() {
  RawMesh mesh;
  for (int k = 0; k < 8; ++k) mesh.positions.push_back({double(k & 1), double((k >> 1) & 1), double((k >> 2) & 1)});
  // Quads counter-clockwise seen from outside, each split into two triangles.
  const std::uint32_t quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    mesh.triangles.push_back({q[0], q[1], q[2]});
    mesh.triangles.push_back({q[0], q[2], q[3]});
  }
  return mesh;
}

// ---------------------------------------------------------------------------------
// Edge lengths and noise
// ---------------------------------------------------------------------------------

TEST(AccuracyMeshes, MeanEdgeLengthCountsEachEdgeOnce) {
  EXPECT_NEAR(mean_edge_length(unit_square()), (4 + std::sqrt(2.0)) / 5, 1e-15);
  EXPECT_NEAR(mean_edge_length(cube()), (12 + 6 * std::sqrt(2.0)) / 18, 1e-15);
  EXPECT_EQ(mean_edge_length(RawMesh{}), 0.0);
}

TEST(AccuracyMeshes, NoiseHasTheRequestedRms) {
  const RawMesh clean = make_icosphere(1.0, 5);  // 10,242 vertices
  const double e = mean_edge_length(clean);
  for (double fraction : {0.1, 0.3}) {
    const RawMesh noisy = with_noise(clean, fraction, 7);
    ASSERT_EQ(noisy.positions.size(), clean.positions.size());
    EXPECT_EQ(noisy.triangles, clean.triangles);
    double squared = 0, per_axis[3] = {0, 0, 0}, mean_axis[3] = {0, 0, 0};
    for (std::size_t v = 0; v < clean.positions.size(); ++v)
      for (int k = 0; k < 3; ++k) {
        const double d = noisy.positions[v][std::size_t(k)] - clean.positions[v][std::size_t(k)];
        squared += d * d;
        per_axis[k] += d * d;
        mean_axis[k] += d;
      }
    const double n = double(clean.positions.size());
    EXPECT_NEAR(std::sqrt(squared / n) / (fraction * e), 1.0, 0.02) << "fraction " << fraction;
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(std::sqrt(per_axis[k] / n) / (fraction * e / std::sqrt(3.0)), 1.0, 0.04) << "axis " << k;
      EXPECT_NEAR(mean_axis[k] / n, 0.0, 0.05 * fraction * e) << "axis " << k;
    }
  }
}

TEST(AccuracyMeshes, NoiseIsDeterministic) {
  const RawMesh clean = make_icosphere(1.0, 3);
  EXPECT_EQ(with_noise(clean, 0.2, 11).positions, with_noise(clean, 0.2, 11).positions);
  EXPECT_NE(with_noise(clean, 0.2, 11).positions, with_noise(clean, 0.2, 12).positions);
  EXPECT_EQ(with_noise(clean, 0.0, 11).positions, clean.positions);
  EXPECT_THROW(with_noise(clean, -0.1, 1), std::invalid_argument);
  EXPECT_THROW(with_noise(clean, std::nan(""), 1), std::invalid_argument);
}

// ---------------------------------------------------------------------------------
// The rounded slab
// ---------------------------------------------------------------------------------

class RoundedSlab : public ::testing::TestWithParam<SlabTessellation> {};

TEST_P(RoundedSlab, IsClosedManifoldAndOutward) {
  RoundedSlabOptions options;
  options.tessellation = GetParam();
  const CadPart part = make_rounded_slab(options);
  expect_closed_oriented_manifold(part.mesh);
  const double a = options.half_x, b = options.half_y, r = options.corner_radius, h = options.height;
  const double exact = (4 * a * b - (4 - kPi) * r * r) * h;  // the polygon is inscribed: slightly less
  const double volume = signed_volume(part.mesh);
  EXPECT_GT(volume, 0) << "inward oriented";
  EXPECT_LT(volume, exact);
  EXPECT_GT(volume, 0.995 * exact);
  EXPECT_NEAR(part.mean_edge_length, mean_edge_length(part.mesh), 0);
}

TEST_P(RoundedSlab, OutlinesAreEdgeLoopsOnTheRoundedRectangle) {
  RoundedSlabOptions options;
  options.tessellation = GetParam();
  const CadPart part = make_rounded_slab(options);
  const int ny = int(std::lround(options.side_segments * (options.half_y - options.corner_radius) /
                                 (options.half_x - options.corner_radius)));
  const std::size_t n = std::size_t(2 * options.side_segments + 2 * ny + 4 * options.corner_segments);
  ASSERT_EQ(part.top_outline.size(), n);
  ASSERT_EQ(part.bottom_outline.size(), n);
  const auto edges = undirected_edges(part.mesh);
  for (const auto* loop : {&part.top_outline, &part.bottom_outline}) {
    const double z = loop == &part.top_outline ? options.height : 0.0;
    double area = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const auto v = (*loop)[i], w = (*loop)[(i + 1) % n];
      const auto& p = part.mesh.positions[v];
      EXPECT_EQ(p[2], z) << "vertex " << v;
      EXPECT_NEAR(rounded_rectangle_distance(options.half_x, options.half_y, options.corner_radius, p[0], p[1]), 0, 1e-15)
          << "vertex " << v;
      EXPECT_TRUE(edges.count({std::min(v, w), std::max(v, w)})) << v << "-" << w << " is not a mesh edge";
      area += p[0] * part.mesh.positions[w][1] - part.mesh.positions[w][0] * p[1];
    }
    EXPECT_GT(area, 0) << "the outline runs counter-clockwise seen from +z";
  }
  for (std::size_t i = 0; i < n; ++i) {
    EXPECT_EQ(part.mesh.positions[part.top_outline[i]][0], part.mesh.positions[part.bottom_outline[i]][0]);
    EXPECT_EQ(part.mesh.positions[part.top_outline[i]][1], part.mesh.positions[part.bottom_outline[i]][1]);
  }
  // The outline starts at the bottom end of the side x = +a.
  EXPECT_EQ(part.mesh.positions[part.top_outline[0]][0], options.half_x);
  EXPECT_EQ(part.mesh.positions[part.top_outline[0]][1], -(options.half_y - options.corner_radius));
}

TEST_P(RoundedSlab, CornersAreTight) {
  RoundedSlabOptions options;
  options.tessellation = GetParam();
  const CadPart part = make_rounded_slab(options);
  double outline = 0;
  const auto& loop = part.top_outline;
  for (std::size_t i = 0; i < loop.size(); ++i)
    outline += (at(part.mesh, loop[i]) - at(part.mesh, loop[(i + 1) % loop.size()])).norm();
  const double edge = outline / double(loop.size());
  EXPECT_GE(options.corner_radius / edge, 1.0);
  EXPECT_LE(options.corner_radius / edge, 2.5);
}

INSTANTIATE_TEST_SUITE_P(AccuracyMeshes, RoundedSlab, ::testing::Values(SlabTessellation::skinny, SlabTessellation::fine),
                         [](const auto& param_info) { return param_info.param == SlabTessellation::skinny ? "skinny" : "fine"; });

TEST(AccuracyMeshes, SkinnySlabHasLongThinTrianglesAndNoInteriorVertex) {
  const CadPart part = make_rounded_slab({});
  EXPECT_EQ(part.mesh.positions.size(), 2 * part.top_outline.size());
  EXPECT_GT(max_aspect_ratio(part.mesh), 8.0);
  // Every side triangle spans the whole height: one row of quads.
  for (const auto& t : part.mesh.triangles) {
    const double z0 = part.mesh.positions[t[0]][2], z1 = part.mesh.positions[t[1]][2], z2 = part.mesh.positions[t[2]][2];
    if (z0 == z1 && z1 == z2) continue;  // a cap triangle
    EXPECT_EQ(std::min({z0, z1, z2}), 0.0);
    EXPECT_EQ(std::max({z0, z1, z2}), 0.4);
  }
}

TEST(AccuracyMeshes, FineSlabHasReasonableTrianglesAndInteriorVertices) {
  RoundedSlabOptions options;
  options.tessellation = SlabTessellation::fine;
  const CadPart part = make_rounded_slab(options);
  EXPECT_GT(part.mesh.positions.size(), 4 * part.top_outline.size());
  EXPECT_LT(max_aspect_ratio(part.mesh), 4.0);
  const CadPart skinny = make_rounded_slab({});
  EXPECT_LT(part.mean_edge_length, 0.3 * skinny.mean_edge_length);
}

TEST(AccuracyMeshes, SlabRejectsBadOptions) {
  RoundedSlabOptions options;
  options.corner_radius = 0.6;  // = half_y
  EXPECT_THROW(make_rounded_slab(options), std::invalid_argument);
  options = {};
  options.corner_segments = 0;
  EXPECT_THROW(make_rounded_slab(options), std::invalid_argument);
  options = {};
  options.height = 0;
  EXPECT_THROW(make_rounded_slab(options), std::invalid_argument);
}

TEST(AccuracyMeshes, RoundedRectangleDistance) {
  EXPECT_DOUBLE_EQ(rounded_rectangle_distance(1, 0.5, 0.1, 0, 0), -0.5);
  EXPECT_DOUBLE_EQ(rounded_rectangle_distance(1, 0.5, 0.1, 2, 0), 1.0);
  EXPECT_DOUBLE_EQ(rounded_rectangle_distance(1, 0.5, 0.1, 0.9 + 0.3, 0.4 + 0.4), 0.4);  // beyond a corner
}

// ---------------------------------------------------------------------------------
// distance_to_polyline
// ---------------------------------------------------------------------------------

TEST(AccuracyMeshes, DistanceToPolylineKnownAnswers) {
  const std::vector<Eigen::Vector3d> chain{{0, 0, 0}, {2, 0, 0}, {2, 2, 0}};
  EXPECT_DOUBLE_EQ(distance_to_polyline(chain, false, {1, 1, 0}), 1.0);
  EXPECT_DOUBLE_EQ(distance_to_polyline(chain, false, {1, 0, 5}), 5.0);          // above a segment's interior
  EXPECT_DOUBLE_EQ(distance_to_polyline(chain, false, {3, -1, 0}), std::sqrt(2.0));  // nearest: a vertex
  EXPECT_DOUBLE_EQ(distance_to_polyline(chain, false, {-3, 0, 4}), 5.0);         // beyond the first end
  EXPECT_DOUBLE_EQ(distance_to_polyline(chain, false, {2, 1, 0}), 0.0);
  // The closing segment (2,2,0)-(0,0,0) counts only for a closed chain.
  EXPECT_DOUBLE_EQ(distance_to_polyline(chain, false, {0.5, 1.5, 0}), 1.5);
  EXPECT_NEAR(distance_to_polyline(chain, true, {0.5, 1.5, 0}), 1 / std::sqrt(2.0), 1e-15);
  // A single point, and a chain with a repeated point.
  EXPECT_DOUBLE_EQ(distance_to_polyline({{1, 2, 3}}, false, {1, 2, 7}), 4.0);
  EXPECT_DOUBLE_EQ(distance_to_polyline({{0, 0, 0}, {0, 0, 0}, {0, 3, 0}}, false, {1, 1, 0}), 1.0);
  EXPECT_THROW(distance_to_polyline({}, false, {0, 0, 0}), std::invalid_argument);
}

// ---------------------------------------------------------------------------------
// Crease chains
// ---------------------------------------------------------------------------------

TEST(AccuracyMeshes, CubeCreasesAreTwelveSingleEdges) {
  // Three sharp edges meet at every corner, so every edge is its own chain.
  const auto chains = find_crease_chains(cube(), 30, 1);
  ASSERT_EQ(chains.size(), 12u);
  for (const auto& c : chains) {
    EXPECT_FALSE(c.closed);
    EXPECT_EQ(c.edges(), 1u);
  }
  EXPECT_TRUE(find_crease_chains(cube(), 30, 2).empty());
  EXPECT_TRUE(find_crease_chains(cube(), 91, 1).empty());  // the cube's dihedral angles are 90 degrees
  EXPECT_TRUE(find_crease_chains(unit_square(), 0, 1).empty());  // boundary edges are never sharp
}

TEST(AccuracyMeshes, SlabCreasesAreItsTwoOutlines) {
  // Default slab: 4 edges per quarter arc, so the outline turns by 22.5 degrees at arc
  // vertices (below the 60-degree split) and the side band's vertical edges there have a
  // 22.5-degree dihedral (below 30): the only sharp edges are the two outlines, two loops.
  for (auto tessellation : {SlabTessellation::skinny, SlabTessellation::fine}) {
    RoundedSlabOptions options;
    options.tessellation = tessellation;
    const CadPart part = make_rounded_slab(options);
    const auto chains = find_crease_chains(part.mesh, 30, 10);
    ASSERT_EQ(chains.size(), 2u);
    for (const auto& c : chains) EXPECT_TRUE(c.closed);
    EXPECT_TRUE(same_cycle(chains[0].vertices, part.bottom_outline));
    EXPECT_TRUE(same_cycle(chains[1].vertices, part.top_outline));
    // At 20 degrees the vertical edges at the 3 interior vertices of each arc (dihedral 22.5
    // degrees; 11.25 at the arcs' tangent points) are sharp too, so those vertices have 3 sharp
    // edges and split the outlines: per loop 4 pieces of a side plus an arc edge at each end
    // (26 and 15 edges) and 8 single arc edges, plus 12 vertical chains: 36 chains.
    const auto split = find_crease_chains(part.mesh, 20, 1);
    EXPECT_EQ(split.size(), 36u);
    std::size_t vertical = 0;
    std::multiset<std::size_t> lengths;
    for (const auto& c : split) {
      EXPECT_FALSE(c.closed);
      if (part.mesh.positions[c.vertices.front()][2] != part.mesh.positions[c.vertices.back()][2]) ++vertical;
      else lengths.insert(c.edges());
    }
    EXPECT_EQ(vertical, 12u);
    EXPECT_EQ(lengths.count(26), 4u);
    EXPECT_EQ(lengths.count(15), 4u);
    EXPECT_EQ(lengths.count(1), 16u);
  }
}

TEST(AccuracyMeshes, ChamferedSlabSplitsAtItsCornerEdges) {
  // One edge per quarter arc: a chamfer. The outline turns by 45 degrees at each chamfer end
  // and the vertical edges there have a 45-degree dihedral, so with 30 degrees 8 vertical
  // single-edge chains split each outline into 4 sides and 4 chamfers: 24 chains.
  RoundedSlabOptions options;
  options.corner_segments = 1;
  const CadPart part = make_rounded_slab(options);
  const auto chains = find_crease_chains(part.mesh, 30, 1);
  EXPECT_EQ(chains.size(), 24u);
  std::multiset<std::size_t> lengths;
  for (const auto& c : chains) lengths.insert(c.edges());
  EXPECT_EQ(lengths.count(1), 16u);   // 8 chamfers, 8 vertical edges
  EXPECT_EQ(lengths.count(24), 4u);   // the sides along x, top and bottom
  EXPECT_EQ(lengths.count(13), 4u);   // the sides along y
}

TEST(AccuracyMeshes, CreaseTurningByNinetyDegreesSplits) {
  // z = 0.7 * (distance to the quadrant x <= 0, y <= 0): creases of 35 degrees along the
  // quadrant's two half-axes, meeting at the origin with a 90-degree turn and nothing else
  // sharp there (beyond it a smooth cone). Two chains of 10 edges, both ending at the origin.
  const HeightField field = make_height_field(
      [](double x, double y) { return 0.7 * std::hypot(std::max(x, 0.0), std::max(y, 0.0)); }, 21, 0.0, 1);
  const auto chains = find_crease_chains(field.mesh, 30, 1);
  const std::uint32_t origin = 10 * 21 + 10;
  ASSERT_EQ(chains.size(), 2u);
  std::vector<std::uint32_t> down, left;  // from (0,-1) and from (-1,0) to the origin
  for (std::uint32_t j = 0; j <= 10; ++j) down.push_back(j * 21 + 10);
  for (std::uint32_t i = 0; i <= 10; ++i) left.push_back(10 * 21 + i);
  EXPECT_EQ(chains[0].vertices, down);
  EXPECT_EQ(chains[1].vertices, left);
  EXPECT_FALSE(chains[0].closed);
  EXPECT_EQ(chains[0].vertices.back(), origin);
}

TEST(AccuracyMeshes, FandiskCreaseChains) {
  const RawMesh mesh = read_mesh_file(require_shared_mesh("fandisk.off"));
  const auto chains = find_crease_chains(mesh, 30, 10);
  const auto edges = undirected_edges(mesh);
  std::set<std::uint32_t> used;
  for (const auto& c : chains) {
    EXPECT_GE(c.edges(), 10u);
    for (std::size_t i = 0; i < c.edges(); ++i) {
      const auto a = c.vertices[i], b = c.vertices[(i + 1) % c.vertices.size()];
      EXPECT_TRUE(edges.count({std::min(a, b), std::max(a, b)}));
    }
    for (auto v : c.vertices) EXPECT_TRUE(used.insert(v).second || v == c.vertices.front() || v == c.vertices.back());
  }
  // Measured once and checked by its structure: 19 open chains of 20 to 58 edges (corners of
  // the part split the crease network; fandisk has no closed crease loop).
  EXPECT_EQ(chains.size(), 19u);
  std::size_t longest = 0, closed = 0;
  for (const auto& c : chains) longest = std::max(longest, c.edges()), closed += c.closed;
  EXPECT_EQ(longest, 58u);
  EXPECT_EQ(closed, 0u);
}

}  // namespace
}  // namespace featureline::testing
