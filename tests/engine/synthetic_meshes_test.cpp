// Known answers and invariants of the synthetic test meshes: topology (Euler
// characteristic, closed and consistently oriented), areas and volumes against their
// analytic values, the jittered Delaunay height fields, and the crest distances.
#include "tests/support/shared_data.h"
#include "tests/support/synthetic_meshes.h"

#include <gtest/gtest-spi.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <set>
#include <stdexcept>
#include <utility>

namespace featureline::testing {
namespace {

constexpr double kPi = 3.14159265358979323846;
using Vec3 = std::array<double, 3>;

Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
double norm(const Vec3& a) { return std::sqrt(dot(a, a)); }

double triangle_area(const RawMesh& mesh, std::size_t f) {
  const auto& t = mesh.triangles[f];
  const Vec3& p = mesh.positions[t[0]];
  return norm(cross(sub(mesh.positions[t[1]], p), sub(mesh.positions[t[2]], p))) / 2;
}

double total_area(const RawMesh& mesh) {
  double area = 0;
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) area += triangle_area(mesh, f);
  return area;
}

// Signed volume by the divergence theorem; positive when oriented outward.
double signed_volume(const RawMesh& mesh) {
  double volume = 0;
  for (const auto& t : mesh.triangles)
    volume += dot(mesh.positions[t[0]], cross(mesh.positions[t[1]], mesh.positions[t[2]])) / 6;
  return volume;
}

double signed_area_xy(const RawMesh& mesh, const std::array<std::uint32_t, 3>& t) {
  const Vec3 &a = mesh.positions[t[0]], &b = mesh.positions[t[1]], &c = mesh.positions[t[2]];
  return ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])) / 2;
}

struct Topology {
  std::size_t edges = 0;           // undirected edges
  std::size_t boundary_edges = 0;  // edges with one face
  std::size_t bad_edges = 0;       // edges with > 2 faces or two faces of equal orientation
  long euler = 0;                  // V - E + F
};

Topology topology(const RawMesh& mesh) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) ++directed[{t[k], t[(k + 1) % 3]}];
  std::set<std::pair<std::uint32_t, std::uint32_t>> undirected;
  Topology result;
  for (const auto& [edge, count] : directed) {
    undirected.insert(std::minmax(edge.first, edge.second));
    const auto reverse = directed.find({edge.second, edge.first});
    const int reverse_count = reverse == directed.end() ? 0 : reverse->second;
    if (count != 1 || reverse_count > 1) ++result.bad_edges;
    if (reverse_count == 0) ++result.boundary_edges;
  }
  result.edges = undirected.size();
  result.euler = long(mesh.positions.size()) - long(result.edges) + long(mesh.triangles.size());
  return result;
}

// A closed, genus-0, consistently oriented mesh without degenerate triangles.
void expect_closed_sphere_like(const RawMesh& mesh) {
  const Topology topo = topology(mesh);
  EXPECT_EQ(topo.euler, 2);
  EXPECT_EQ(topo.boundary_edges, 0u);
  EXPECT_EQ(topo.bad_edges, 0u);
  EXPECT_EQ(2 * topo.edges, 3 * mesh.triangles.size());  // every edge has exactly two faces
  EXPECT_EQ(mesh.source_faces, mesh.triangles.size());
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    const auto& t = mesh.triangles[f];
    ASSERT_TRUE(t[0] != t[1] && t[1] != t[2] && t[2] != t[0]) << "triangle " << f;
    ASSERT_GT(triangle_area(mesh, f), 0) << "triangle " << f;
  }
  EXPECT_GT(signed_volume(mesh), 0) << "not oriented outward";
}

// Sum of angle defects 2*pi - (angles at v) equals 2*pi*chi (discrete Gauss-Bonnet).
double total_angle_defect(const RawMesh& mesh) {
  double angles = 0;
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) {
      const Vec3& p = mesh.positions[t[k]];
      const Vec3 u = sub(mesh.positions[t[(k + 1) % 3]], p);
      const Vec3 v = sub(mesh.positions[t[(k + 2) % 3]], p);
      angles += std::atan2(norm(cross(u, v)), dot(u, v));
    }
  return 2 * kPi * double(mesh.positions.size()) - angles;
}

// ----------------------------------------------------------------------------------

TEST(Icosphere, ClosedOutwardOnTheSphere) {
  for (int s = 0; s <= 3; ++s) {
    const RawMesh mesh = make_icosphere(2.5, s);
    const std::size_t faces = std::size_t(20) << (2 * s);
    EXPECT_EQ(mesh.triangles.size(), faces);
    EXPECT_EQ(mesh.positions.size(), faces / 2 + 2);
    expect_closed_sphere_like(mesh);
    for (const Vec3& p : mesh.positions) EXPECT_NEAR(norm(p), 2.5, 1e-12);
    EXPECT_NEAR(total_angle_defect(mesh), 4 * kPi, 1e-9);
  }
}

TEST(Icosphere, AreaAndVolumeConvergeToTheSphere) {
  const double r = 1.7, sphere_area = 4 * kPi * r * r, sphere_volume = 4 * kPi * r * r * r / 3;
  double previous_error = 1;
  for (int s = 1; s <= 4; ++s) {
    const RawMesh mesh = make_icosphere(r, s);
    const double error = std::abs(total_area(mesh) - sphere_area) / sphere_area;
    EXPECT_LT(error, previous_error) << "subdivisions " << s;
    previous_error = error;
    EXPECT_LT(total_area(mesh), sphere_area);  // inscribed polyhedron
  }
  EXPECT_LT(previous_error, 0.01);
  const RawMesh mesh = make_icosphere(r, 4);
  EXPECT_NEAR(signed_volume(mesh), sphere_volume, 0.01 * sphere_volume);
}

TEST(Icosphere, NearlyUniformEdges) {
  // Uniform sampling is what makes the discrete mean curvature ~1/r at every vertex.
  const RawMesh mesh = make_icosphere(1, 4);
  double shortest = 1e9, longest = 0;
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) {
      const double length = norm(sub(mesh.positions[t[k]], mesh.positions[t[(k + 1) % 3]]));
      shortest = std::min(shortest, length);
      longest = std::max(longest, length);
    }
  EXPECT_LT(longest / shortest, 1.5);
}

TEST(UvSphere, ClosedOutwardWithPolesAndIrregularTriangles) {
  const double r = 0.8;
  const int rings = 24, segments = 48;
  const RawMesh mesh = make_uv_sphere(r, rings, segments);
  EXPECT_EQ(mesh.positions.size(), std::size_t((rings - 1) * segments + 2));
  EXPECT_EQ(mesh.triangles.size(), std::size_t(2 * segments * (rings - 1)));
  expect_closed_sphere_like(mesh);
  for (const Vec3& p : mesh.positions) EXPECT_NEAR(norm(p), r, 1e-12);
  EXPECT_EQ(mesh.positions.front(), (Vec3{0, 0, r}));
  EXPECT_EQ(mesh.positions.back(), (Vec3{0, 0, -r}));
  EXPECT_NEAR(total_angle_defect(mesh), 4 * kPi, 1e-9);
  const double sphere_area = 4 * kPi * r * r;
  EXPECT_NEAR(total_area(mesh), sphere_area, 0.01 * sphere_area);

  double smallest = 1e9, largest = 0;
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    smallest = std::min(smallest, triangle_area(mesh, f));
    largest = std::max(largest, triangle_area(mesh, f));
  }
  EXPECT_GT(largest / smallest, 5);
  EXPECT_THROW(make_uv_sphere(r, 1, 8), std::invalid_argument);
}

TEST(Cylinder, CappedIsClosedWithExactPolygonalAreaAndVolume) {
  const double r = 0.6, h = 2.2;
  const int rings = 5, segments = 40;
  const RawMesh mesh = make_cylinder(r, h, rings, segments, true);
  expect_closed_sphere_like(mesh);
  EXPECT_EQ(mesh.positions.size(), std::size_t((rings + 1) * segments + 2));
  // The mesh is a prism over an inscribed regular polygon: area and volume are exact.
  const double polygon_area = segments / 2.0 * r * r * std::sin(2 * kPi / segments);
  const double perimeter = segments * 2 * r * std::sin(kPi / segments);
  EXPECT_NEAR(total_area(mesh), perimeter * h + 2 * polygon_area, 1e-12);
  EXPECT_NEAR(signed_volume(mesh), polygon_area * h, 1e-12);
  EXPECT_EQ(mesh.positions[(rings + 1) * segments], (Vec3{0, 0, -h / 2}));
  EXPECT_EQ(mesh.positions.back(), (Vec3{0, 0, h / 2}));
  for (int q = 0; q <= rings; ++q)
    EXPECT_NEAR(mesh.positions[q * segments][2], -h / 2 + h * q / rings, 1e-15);
}

TEST(Cylinder, UncappedIsAnOrientedTubeWithTwoBoundaryLoops) {
  const int rings = 3, segments = 16;
  const RawMesh mesh = make_cylinder(1, 1, rings, segments, false);
  const Topology topo = topology(mesh);
  EXPECT_EQ(topo.euler, 0);
  EXPECT_EQ(topo.bad_edges, 0u);
  EXPECT_EQ(topo.boundary_edges, std::size_t(2 * segments));
  // Outward: each face normal points away from the axis.
  for (const auto& t : mesh.triangles) {
    const Vec3 &a = mesh.positions[t[0]], &b = mesh.positions[t[1]], &c = mesh.positions[t[2]];
    const Vec3 normal = cross(sub(b, a), sub(c, a));
    const Vec3 radial{a[0] + b[0] + c[0], a[1] + b[1] + c[1], 0};
    EXPECT_GT(dot(normal, radial), 0);
  }
}

TEST(Capsule, ClosedOutwardWithAnalyticArea) {
  const double r = 0.5, h = 1.6;
  const int segments = 64, rings_per_cap = 16, rings_cylinder = 10;
  const RawMesh mesh = make_capsule(r, h, segments, rings_per_cap, rings_cylinder);
  expect_closed_sphere_like(mesh);
  EXPECT_EQ(mesh.positions.size(),
            std::size_t((2 * rings_per_cap + rings_cylinder - 1) * segments + 2));
  EXPECT_NEAR(total_angle_defect(mesh), 4 * kPi, 1e-9);
  EXPECT_DOUBLE_EQ(capsule_area(r, h), 4 * kPi * r * r + 2 * kPi * r * h);
  EXPECT_NEAR(total_area(mesh), capsule_area(r, h), 0.01 * capsule_area(r, h));
  const double volume = kPi * r * r * h + 4 * kPi * r * r * r / 3;
  EXPECT_NEAR(signed_volume(mesh), volume, 0.01 * volume);
  EXPECT_EQ(mesh.positions.front(), (Vec3{0, 0, h / 2 + r}));
  EXPECT_EQ(mesh.positions.back(), (Vec3{0, 0, -h / 2 - r}));
  // Every vertex lies on the smooth capsule: at distance r from the axis segment.
  for (const Vec3& p : mesh.positions) {
    const double axis_z = std::clamp(p[2], -h / 2, h / 2);
    EXPECT_NEAR(norm({p[0], p[1], p[2] - axis_z}), r, 1e-12);
  }
}

TEST(Capsule, EquatorIsAVertexLoopAtZeroAndSplitsTheArea) {
  const double r = 0.5, h = 1.6;
  const int segments = 64, rings_per_cap = 16, rings_cylinder = 10;
  const RawMesh mesh = make_capsule(r, h, segments, rings_per_cap, rings_cylinder);
  const auto equator = capsule_equator(segments, rings_per_cap, rings_cylinder);
  ASSERT_EQ(equator.size(), std::size_t(segments));
  std::set<std::pair<std::uint32_t, std::uint32_t>> edges;
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) edges.insert(std::minmax(t[k], t[(k + 1) % 3]));
  for (std::size_t k = 0; k < equator.size(); ++k) {
    const Vec3& p = mesh.positions.at(equator[k]);
    EXPECT_EQ(p[2], 0.0);
    EXPECT_NEAR(std::hypot(p[0], p[1]), r, 1e-15);
    EXPECT_NEAR(std::atan2(p[1], p[0]), std::remainder(2 * kPi * k / segments, 2 * kPi), 1e-12);
    EXPECT_TRUE(edges.count(std::minmax(equator[k], equator[(k + 1) % equator.size()])));
  }
  // Triangles never straddle a vertex ring, so their centroids split the area exactly
  // at every ring; compare with the analytic part above the plane.
  auto area_above = [&](double c) {
    double area = 0;
    for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
      const auto& t = mesh.triangles[f];
      const double z = (mesh.positions[t[0]][2] + mesh.positions[t[1]][2] +
                        mesh.positions[t[2]][2]) / 3;
      if (z > c) area += triangle_area(mesh, f);
    }
    return area;
  };
  EXPECT_DOUBLE_EQ(capsule_area_above(r, h, 0), capsule_area(r, h) / 2);
  for (double c : {0.0, h / 2 - h / rings_cylinder, -h / 2 + 3 * h / rings_cylinder}) {
    const double expected = capsule_area_above(r, h, c);
    EXPECT_NEAR(area_above(c), expected, 0.01 * expected) << "c = " << c;
  }
  EXPECT_THROW(capsule_area_above(r, h, h / 2), std::invalid_argument);
  EXPECT_THROW(make_capsule(r, h, segments, rings_per_cap, 3), std::invalid_argument);
  EXPECT_THROW(capsule_equator(segments, rings_per_cap, 3), std::invalid_argument);
}

TEST(HeightField, JitteredDelaunayGridOverTheSquare) {
  const int n = 21;
  const double jitter = 0.2;
  auto z = [](double x, double y) { return 0.3 * x * x - 0.2 * x * y + std::sin(y); };
  const HeightField field = make_height_field(z, n, jitter, 7);
  const RawMesh& mesh = field.mesh;
  ASSERT_EQ(mesh.positions.size(), std::size_t(n * n));
  ASSERT_EQ(mesh.triangles.size(), std::size_t(2 * (n - 1) * (n - 1)));
  EXPECT_DOUBLE_EQ(field.spacing, 0.1);
  EXPECT_EQ(field.n, n);
  EXPECT_FALSE(field.crest);

  // A disk: Euler characteristic 1, boundary = the square's 4(n-1) edges.
  const Topology topo = topology(mesh);
  EXPECT_EQ(topo.euler, 1);
  EXPECT_EQ(topo.bad_edges, 0u);
  EXPECT_EQ(topo.boundary_edges, std::size_t(4 * (n - 1)));

  double area_xy = 0;
  for (const auto& t : mesh.triangles) {
    EXPECT_GT(signed_area_xy(mesh, t), 0);
    area_xy += signed_area_xy(mesh, t);
  }
  EXPECT_NEAR(area_xy, 4, 1e-12);

  int moved_x = 0, moved_y = 0, interior = 0;
  double largest_move = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const Vec3& p = mesh.positions[j * n + i];
      EXPECT_DOUBLE_EQ(p[2], z(p[0], p[1]));
      const double dx = p[0] - (-1 + field.spacing * i), dy = p[1] - (-1 + field.spacing * j);
      EXPECT_LE(std::abs(dx), jitter * field.spacing + 1e-15);
      EXPECT_LE(std::abs(dy), jitter * field.spacing + 1e-15);
      const bool x_border = i == 0 || i == n - 1, y_border = j == 0 || j == n - 1;
      if (x_border) {
        EXPECT_EQ(std::abs(p[0]), 1.0);
        EXPECT_TRUE(y_border || dy != 0) << "slides along the border";
      }
      if (y_border) {
        EXPECT_EQ(std::abs(p[1]), 1.0);
        EXPECT_TRUE(x_border || dx != 0) << "slides along the border";
      }
      if (x_border || y_border) continue;
      ++interior;
      moved_x += std::abs(dx) > 0.01 * field.spacing;
      moved_y += std::abs(dy) > 0.01 * field.spacing;
      largest_move = std::max({largest_move, std::abs(dx), std::abs(dy)});
    }
  EXPECT_GT(moved_x, interior * 9 / 10);
  EXPECT_GT(moved_y, interior * 9 / 10);
  EXPECT_GT(largest_move, 0.8 * jitter * field.spacing);
}

TEST(HeightField, EveryCellSatisfiesTheDelaunayCriterion) {
  const int n = 30;
  const RawMesh mesh = make_plane_grid(n, 0.24, 99);
  int diagonal_ac = 0, diagonal_bd = 0;
  auto angle = [&](std::uint32_t at, std::uint32_t p, std::uint32_t q) {
    const Vec3 u = sub(mesh.positions[p], mesh.positions[at]);
    const Vec3 v = sub(mesh.positions[q], mesh.positions[at]);
    return std::atan2(norm(cross(u, v)), dot(u, v));
  };
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const auto a = std::uint32_t(j * n + i), b = a + 1, c = a + n + 1, d = a + n;
      const std::size_t f = 2 * std::size_t(j * (n - 1) + i);
      std::set<std::uint32_t> first(mesh.triangles[f].begin(), mesh.triangles[f].end());
      std::set<std::uint32_t> second(mesh.triangles[f + 1].begin(), mesh.triangles[f + 1].end());
      std::set<std::uint32_t> all = first;
      all.insert(second.begin(), second.end());
      ASSERT_EQ(all, (std::set<std::uint32_t>{a, b, c, d})) << "cell " << i << "," << j;
      // The diagonal is the pair both triangles share; the angles opposite it sum to <= pi.
      const bool uses_ac = first.count(a) && first.count(c) && second.count(a) && second.count(c);
      const bool uses_bd = first.count(b) && first.count(d) && second.count(b) && second.count(d);
      ASSERT_NE(uses_ac, uses_bd);
      if (uses_ac) {
        ++diagonal_ac;
        EXPECT_LE(angle(b, a, c) + angle(d, a, c), kPi + 1e-12);
      } else {
        ++diagonal_bd;
        EXPECT_LE(angle(a, b, d) + angle(c, b, d), kPi + 1e-12);
      }
    }
  // Irregular: both diagonals occur often, so edges follow no direction.
  EXPECT_GT(diagonal_ac, (n - 1) * (n - 1) / 5);
  EXPECT_GT(diagonal_bd, (n - 1) * (n - 1) / 5);
}

TEST(HeightField, DeterministicPerSeed) {
  auto z = [](double x, double y) { return x * y; };
  const HeightField one = make_height_field(z, 12, 0.2, 123);
  const HeightField again = make_height_field(z, 12, 0.2, 123);
  const HeightField other = make_height_field(z, 12, 0.2, 124);
  EXPECT_EQ(one.mesh.positions, again.mesh.positions);
  EXPECT_EQ(one.mesh.triangles, again.mesh.triangles);
  EXPECT_NE(one.mesh.positions, other.mesh.positions);
  // Pins the jitter stream (mt19937_64 and our own mapping to [-1, 1), both fully
  // specified): the first interior point of seed 123.
  const Vec3& p = one.mesh.positions[12 + 1];
  EXPECT_EQ(p[0], -0x1.9ac37451628afp-1);
  EXPECT_EQ(p[1], -0x1.aada50f9b9ce7p-1);
  // No jitter: the regular grid.
  const RawMesh regular = make_plane_grid(5, 0, 1);
  EXPECT_EQ(regular.positions[5 + 1], (Vec3{-0.5, -0.5, 0}));
  EXPECT_THROW(make_height_field(z, 12, 0.25, 1), std::invalid_argument);
  EXPECT_THROW(make_height_field(z, 1, 0.1, 1), std::invalid_argument);
}

TEST(HeightField, NearestVertex) {
  const RawMesh mesh = make_plane_grid(15, 0.2, 5);
  for (std::uint32_t v = 0; v < mesh.positions.size(); v += 7)
    EXPECT_EQ(nearest_vertex(mesh, mesh.positions[v][0] + 1e-4, mesh.positions[v][1] - 1e-4), v);
  EXPECT_EQ(nearest_vertex(mesh, -2, -2), 0u);
  EXPECT_EQ(nearest_vertex(mesh, 2, 2), std::uint32_t(15 * 15 - 1));
}

TEST(RidgeField, HeightPeaksOnTheCrestAndValleysAreNegative) {
  const double amplitude = 0.4, width = 0.2, bend = 0.3;
  const HeightField ridge = make_ridge_field(41, 0.2, 3, amplitude, width, bend);
  const HeightField valley = make_ridge_field(41, 0.2, 3, -amplitude, width, bend);
  ASSERT_TRUE(ridge.crest);
  EXPECT_DOUBLE_EQ(ridge.crest(0), kRidgeCrestOffset);
  EXPECT_DOUBLE_EQ(ridge.crest(1), bend + kRidgeCrestOffset);
  for (double x = -1; x <= 1; x += 0.125) {
    const double y = ridge.crest(x);
    EXPECT_DOUBLE_EQ(ridge.height(x, y), amplitude);
    EXPECT_DOUBLE_EQ(valley.height(x, y), -amplitude);
    EXPECT_LT(ridge.height(x, y + 0.05), amplitude);
    EXPECT_NEAR(ridge.height(x, y + width), amplitude / std::exp(1.0), 1e-15);
  }
  // The crest passes through no vertex: edges cannot follow it.
  for (const Vec3& p : ridge.mesh.positions)
    EXPECT_GT(distance_to_crest(ridge, p[0], p[1]), 1e-6);
}

TEST(RidgeField, DistanceToCrest) {
  const HeightField ridge = make_ridge_field(9, 0.1, 1, 1, 0.2, 0.35);
  for (double x = -1.2; x <= 1.2; x += 0.1) {
    const double y = ridge.crest(x);
    EXPECT_NEAR(distance_to_crest(ridge, x, y), 0, 1e-14);
    // Unit normal of y = crest(x): (-c', 1) / |.|.
    const double slope = 0.35 * (kPi / 2) * std::cos(kPi * x / 2);
    const double length = std::hypot(slope, 1.0);
    for (double delta : {1e-3, 0.02, 0.1, 0.3}) {
      for (double side : {-1.0, 1.0}) {
        const double px = x - side * delta * slope / length, py = y + side * delta / length;
        EXPECT_NEAR(distance_to_crest(ridge, px, py), delta, 1e-10)
            << "x " << x << " delta " << side * delta;
      }
    }
  }
  const HeightField plain = make_height_field([](double, double) { return 0.0; }, 4, 0, 1);
  EXPECT_THROW(distance_to_crest(plain, 0, 0), std::invalid_argument);
}

TEST(CreaseField, RoofProfileAndDistance) {
  const double amplitude = 0.25, width = 0.3;
  const HeightField crease = make_crease_field(31, 0.2, 11, amplitude, width);
  ASSERT_TRUE(crease.crest);
  const double normal_length = std::hypot(kCreaseSlope, 1.0);
  for (double x = -1; x <= 1; x += 0.1) {
    const double y = kCreaseSlope * x + kCreaseOffset;
    EXPECT_DOUBLE_EQ(crease.crest(x), y);
    EXPECT_NEAR(crease.height(x, y), amplitude, 1e-15);
    for (double delta : {0.05, 0.15, 0.29}) {
      const double px = x - delta * kCreaseSlope / normal_length, py = y + delta / normal_length;
      EXPECT_NEAR(distance_to_crease_line(px, py), delta, 1e-14);
      EXPECT_NEAR(distance_to_crest(crease, px, py), delta, 1e-12);
      EXPECT_NEAR(crease.height(px, py), amplitude * (1 - delta / width), 1e-14);
    }
    EXPECT_EQ(crease.height(x, y + 2 * width * normal_length), 0.0);
  }
  for (const Vec3& p : crease.mesh.positions) {
    EXPECT_NEAR(distance_to_crest(crease, p[0], p[1]), distance_to_crease_line(p[0], p[1]), 1e-12);
    EXPECT_DOUBLE_EQ(p[2], crease.height(p[0], p[1]));
  }
}

TEST(PlaneGrid, FlatAndSameTriangulationAsTheHeightField) {
  const RawMesh plane = make_plane_grid(17, 0.2, 8);
  const HeightField field = make_height_field([](double x, double) { return x; }, 17, 0.2, 8);
  ASSERT_EQ(plane.positions.size(), field.mesh.positions.size());
  for (std::size_t v = 0; v < plane.positions.size(); ++v) {
    EXPECT_EQ(plane.positions[v][2], 0.0);
    EXPECT_EQ(plane.positions[v][0], field.mesh.positions[v][0]);
    EXPECT_EQ(plane.positions[v][1], field.mesh.positions[v][1]);
  }
  EXPECT_EQ(plane.triangles, field.mesh.triangles);
  EXPECT_NEAR(total_area(plane), 4, 1e-12);
}

TEST(Transforms, ScaledAndTranslated) {
  const RawMesh sphere = make_icosphere(1, 2);
  for (double s : {1e-6, 3.0, 1e6}) {
    const RawMesh big = scaled(sphere, s);
    EXPECT_NEAR(total_area(big), s * s * total_area(sphere), 1e-12 * s * s);
    EXPECT_EQ(big.triangles, sphere.triangles);
    expect_closed_sphere_like(big);
  }
  const RawMesh moved = translated(sphere, 1, -2, 3.5);
  for (std::size_t v = 0; v < sphere.positions.size(); ++v) {
    EXPECT_DOUBLE_EQ(moved.positions[v][0], sphere.positions[v][0] + 1);
    EXPECT_DOUBLE_EQ(moved.positions[v][1], sphere.positions[v][1] - 2);
    EXPECT_DOUBLE_EQ(moved.positions[v][2], sphere.positions[v][2] + 3.5);
  }
  EXPECT_NEAR(total_area(moved), total_area(sphere), 1e-12);
  EXPECT_THROW(scaled(sphere, 0), std::invalid_argument);
  EXPECT_THROW(scaled(sphere, -1), std::invalid_argument);
}

TEST(SharedData, PathAndLoudFailureWhenMissing) {
  EXPECT_EQ(shared_mesh_path("cube.obj"),
            std::string(FEATURELINE_SHARED_DIR) + "/data/meshes/cube.obj");
  EXPECT_NONFATAL_FAILURE(
      EXPECT_THROW(require_shared_mesh("no_such_mesh_for_featureline.obj"), std::runtime_error),
      "missing test mesh");
  EXPECT_EQ(require_shared_mesh("cube.obj"), shared_mesh_path("cube.obj"));
}

}  // namespace
}  // namespace featureline::testing
