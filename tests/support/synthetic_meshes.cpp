#include "tests/support/synthetic_meshes.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>

#include "tests/support/generator_detail.h"

namespace featureline::testing {
namespace {

using detail::kPi;
using detail::positive_finite;
using detail::require;
using detail::Triangle;
using detail::Vec3;

RawMesh finish(std::vector<Vec3> positions, std::vector<Triangle> triangles) {
  RawMesh mesh;
  mesh.positions = std::move(positions);
  mesh.triangles = std::move(triangles);
  mesh.source_faces = mesh.triangles.size();
  return mesh;
}

// Uniform value in [-1, 1) from the top 53 bits, identical on every standard library
// (std::uniform_real_distribution is not).
double uniform_signed(std::mt19937_64& rng) {
  const double unit = std::ldexp(static_cast<double>(rng() >> 11), -53);  // [0, 1)
  return 2.0 * unit - 1.0;
}

// Angle at vertex p of the triangle (p, q, r) in the xy plane.
double angle_xy(const Vec3& p, const Vec3& q, const Vec3& r) {
  const double ux = q[0] - p[0], uy = q[1] - p[1];
  const double vx = r[0] - p[0], vy = r[1] - p[1];
  return std::atan2(std::abs(ux * vy - uy * vx), ux * vx + uy * vy);
}

// Triangles between a ring `upper` and the ring below it, `lower`, both of
// `segments` vertices counter-clockwise seen from +z starting at ids upper/lower.
void add_band(std::vector<Triangle>& triangles, std::uint32_t upper, std::uint32_t lower,
              int segments) {
  const auto n = static_cast<std::uint32_t>(segments);
  for (std::uint32_t k = 0; k < n; ++k) {
    const std::uint32_t next = (k + 1) % n;
    const std::uint32_t a = upper + k, b = upper + next, c = lower + next, d = lower + k;
    triangles.push_back({a, d, c});
    triangles.push_back({a, c, b});
  }
}

// Fan from `apex` to a ring seen from +z (apex above the ring) or from -z.
void add_fan(std::vector<Triangle>& triangles, std::uint32_t apex, std::uint32_t ring,
             int segments, bool apex_on_top) {
  const auto n = static_cast<std::uint32_t>(segments);
  for (std::uint32_t k = 0; k < n; ++k) {
    const std::uint32_t next = (k + 1) % n;
    if (apex_on_top)
      triangles.push_back({apex, ring + k, ring + next});
    else
      triangles.push_back({apex, ring + next, ring + k});
  }
}

void add_ring(std::vector<Vec3>& positions, double rho, double z, int segments) {
  for (int k = 0; k < segments; ++k) {
    const double phi = 2.0 * kPi * k / segments;
    positions.push_back({rho * std::cos(phi), rho * std::sin(phi), z});
  }
}

void check_capsule_rings(const char* function, int segments, int rings_per_cap,
                         int rings_cylinder) {
  require(segments >= 3, function, "segments must be >= 3");
  require(rings_per_cap >= 1, function, "rings_per_cap must be >= 1");
  require(rings_cylinder >= 2 && rings_cylinder % 2 == 0, function,
          "rings_cylinder must be even and >= 2 (a ring lies at z = 0)");
}

HeightField make_crest_field(std::function<double(double, double)> z,
                             std::function<double(double)> crest, int n, double jitter,
                             std::uint64_t seed) {
  HeightField field = make_height_field(std::move(z), n, jitter, seed);
  field.crest = std::move(crest);
  return field;
}

}  // namespace

RawMesh make_icosphere(double radius, int subdivisions) {
  require(positive_finite(radius), "make_icosphere", "radius must be positive and finite");
  require(subdivisions >= 0 && subdivisions <= 8, "make_icosphere",
          "subdivisions must be in 0..8");

  // Icosahedron: vertices are the cyclic permutations of (0, +-1, +-phi).
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Vec3> positions = {{-1, t, 0}, {1, t, 0},  {-1, -t, 0}, {1, -t, 0},
                                 {0, -1, t}, {0, 1, t},  {0, -1, -t}, {0, 1, -t},
                                 {t, 0, -1}, {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
  std::vector<Triangle> triangles = {
      {0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
      {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
      {3, 8, 9},  {4, 9, 5},  {2, 4, 11},  {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};

  auto project = [radius](Vec3 p) {
    const double norm = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    return Vec3{radius * p[0] / norm, radius * p[1] / norm, radius * p[2] / norm};
  };
  for (Vec3& p : positions) p = project(p);

  for (int level = 0; level < subdivisions; ++level) {
    std::unordered_map<std::uint64_t, std::uint32_t> midpoints;
    auto midpoint = [&](std::uint32_t a, std::uint32_t b) {
      const std::uint64_t key = (std::uint64_t(std::min(a, b)) << 32) | std::max(a, b);
      const auto found = midpoints.find(key);
      if (found != midpoints.end()) return found->second;
      const Vec3& p = positions[a];
      const Vec3& q = positions[b];
      positions.push_back(project({p[0] + q[0], p[1] + q[1], p[2] + q[2]}));
      const auto id = static_cast<std::uint32_t>(positions.size() - 1);
      midpoints.emplace(key, id);
      return id;
    };
    std::vector<Triangle> finer;
    finer.reserve(4 * triangles.size());
    for (const Triangle& f : triangles) {
      const std::uint32_t ab = midpoint(f[0], f[1]);
      const std::uint32_t bc = midpoint(f[1], f[2]);
      const std::uint32_t ca = midpoint(f[2], f[0]);
      finer.push_back({f[0], ab, ca});
      finer.push_back({f[1], bc, ab});
      finer.push_back({f[2], ca, bc});
      finer.push_back({ab, bc, ca});
    }
    triangles = std::move(finer);
  }
  return finish(std::move(positions), std::move(triangles));
}

RawMesh make_uv_sphere(double radius, int rings, int segments) {
  require(positive_finite(radius), "make_uv_sphere", "radius must be positive and finite");
  require(rings >= 2, "make_uv_sphere", "rings must be >= 2");
  require(segments >= 3, "make_uv_sphere", "segments must be >= 3");

  std::vector<Vec3> positions;
  positions.push_back({0, 0, radius});
  for (int q = 1; q < rings; ++q) {
    const double theta = kPi * q / rings;
    add_ring(positions, radius * std::sin(theta), radius * std::cos(theta), segments);
  }
  positions.push_back({0, 0, -radius});

  std::vector<Triangle> triangles;
  const auto n = static_cast<std::uint32_t>(segments);
  const auto south = static_cast<std::uint32_t>(positions.size() - 1);
  add_fan(triangles, 0, 1, segments, true);
  for (int q = 1; q + 1 < rings; ++q)
    add_band(triangles, 1 + (q - 1) * n, 1 + q * n, segments);
  add_fan(triangles, south, 1 + (rings - 2) * n, segments, false);
  return finish(std::move(positions), std::move(triangles));
}

RawMesh make_cylinder(double radius, double height, int rings, int segments, bool capped) {
  require(positive_finite(radius), "make_cylinder", "radius must be positive and finite");
  require(positive_finite(height), "make_cylinder", "height must be positive and finite");
  require(rings >= 1, "make_cylinder", "rings must be >= 1");
  require(segments >= 3, "make_cylinder", "segments must be >= 3");

  std::vector<Vec3> positions;
  for (int q = 0; q <= rings; ++q) {
    const double z = q == rings ? height / 2 : -height / 2 + height * q / rings;
    add_ring(positions, radius, z, segments);
  }
  std::vector<Triangle> triangles;
  const auto n = static_cast<std::uint32_t>(segments);
  for (int q = 0; q < rings; ++q) add_band(triangles, (q + 1) * n, q * n, segments);
  if (capped) {
    const auto bottom = static_cast<std::uint32_t>(positions.size());
    positions.push_back({0, 0, -height / 2});
    positions.push_back({0, 0, height / 2});
    add_fan(triangles, bottom, 0, segments, false);
    add_fan(triangles, bottom + 1, rings * n, segments, true);
  }
  return finish(std::move(positions), std::move(triangles));
}

RawMesh make_capsule(double radius, double cylinder_height, int segments, int rings_per_cap,
                     int rings_cylinder) {
  require(positive_finite(radius), "make_capsule", "radius must be positive and finite");
  require(positive_finite(cylinder_height), "make_capsule",
          "cylinder_height must be positive and finite");
  check_capsule_rings("make_capsule", segments, rings_per_cap, rings_cylinder);

  const double half = cylinder_height / 2;
  const int rings = 2 * rings_per_cap + rings_cylinder - 1;
  const int upper_junction = rings_per_cap - 1;
  const int lower_junction = upper_junction + rings_cylinder;
  const int equator = upper_junction + rings_cylinder / 2;

  std::vector<Vec3> positions;
  positions.push_back({0, 0, half + radius});
  for (int q = 0; q < rings; ++q) {
    double rho = radius, z = 0;
    if (q < upper_junction) {
      const double theta = (kPi / 2) * (q + 1) / rings_per_cap;
      rho = radius * std::sin(theta);
      z = half + radius * std::cos(theta);
    } else if (q > lower_junction) {
      const double theta = (kPi / 2) * (q - lower_junction) / rings_per_cap;
      rho = radius * std::cos(theta);
      z = -half - radius * std::sin(theta);
    } else if (q == upper_junction) {
      z = half;
    } else if (q == lower_junction) {
      z = -half;
    } else if (q != equator) {
      z = half - cylinder_height * (q - upper_junction) / rings_cylinder;
    }  // the equator ring keeps z = 0 exactly
    add_ring(positions, rho, z, segments);
  }
  positions.push_back({0, 0, -half - radius});

  std::vector<Triangle> triangles;
  const auto n = static_cast<std::uint32_t>(segments);
  const auto south = static_cast<std::uint32_t>(positions.size() - 1);
  add_fan(triangles, 0, 1, segments, true);
  for (int q = 0; q + 1 < rings; ++q) add_band(triangles, 1 + q * n, 1 + (q + 1) * n, segments);
  add_fan(triangles, south, 1 + (rings - 1) * n, segments, false);
  return finish(std::move(positions), std::move(triangles));
}

std::vector<std::uint32_t> capsule_equator(int segments, int rings_per_cap, int rings_cylinder) {
  check_capsule_rings("capsule_equator", segments, rings_per_cap, rings_cylinder);
  const auto n = static_cast<std::uint32_t>(segments);
  const auto first = 1 + static_cast<std::uint32_t>(rings_per_cap - 1 + rings_cylinder / 2) * n;
  std::vector<std::uint32_t> ids(n);
  for (std::uint32_t k = 0; k < n; ++k) ids[k] = first + k;
  return ids;
}

double capsule_area(double radius, double cylinder_height) {
  return 4 * kPi * radius * radius + 2 * kPi * radius * cylinder_height;
}

double capsule_area_above(double radius, double cylinder_height, double c) {
  require(std::abs(c) < cylinder_height / 2, "capsule_area_above",
          "the plane must cut the cylinder part (|c| < cylinder_height/2)");
  return 2 * kPi * radius * radius + 2 * kPi * radius * (cylinder_height / 2 - c);
}

HeightField make_height_field(std::function<double(double, double)> z, int n, double jitter,
                              std::uint64_t seed) {
  require(static_cast<bool>(z), "make_height_field", "the height function is empty");
  require(n >= 2, "make_height_field", "n must be >= 2");
  require(std::isfinite(jitter) && jitter >= 0 && jitter < 0.25, "make_height_field",
          "jitter must be in [0, 0.25)");

  HeightField field;
  field.n = n;
  field.spacing = 2.0 / (n - 1);
  const double reach = jitter * field.spacing;
  const auto un = static_cast<std::uint32_t>(n);

  std::mt19937_64 rng(seed);
  std::vector<Vec3> positions;
  positions.reserve(std::size_t(n) * n);
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      // Two draws per point, always, so the stream does not depend on the point's kind.
      const double u = uniform_signed(rng);
      const double v = uniform_signed(rng);
      const bool x_border = i == 0 || i == n - 1;
      const bool y_border = j == 0 || j == n - 1;
      double x = i == 0 ? -1.0 : i == n - 1 ? 1.0 : -1.0 + field.spacing * i;
      double y = j == 0 ? -1.0 : j == n - 1 ? 1.0 : -1.0 + field.spacing * j;
      if (!x_border) x += reach * u;  // on a y border only x moves (along it)
      if (!y_border) y += reach * v;
      positions.push_back({x, y, z(x, y)});
    }
  }

  std::vector<Triangle> triangles;
  triangles.reserve(2 * std::size_t(n - 1) * (n - 1));
  for (std::uint32_t j = 0; j + 1 < un; ++j) {
    for (std::uint32_t i = 0; i + 1 < un; ++i) {
      const std::uint32_t a = j * un + i, b = a + 1, c = a + un + 1, d = a + un;
      const Vec3 &pa = positions[a], &pb = positions[b], &pc = positions[c], &pd = positions[d];
      // Diagonal a-c is Delaunay when the angles opposite it (at b and d) sum to at
      // most pi, i.e. to at most the angles at a and c in a convex quad.
      const double opposite_ac = angle_xy(pb, pc, pa) + angle_xy(pd, pa, pc);
      const double opposite_bd = angle_xy(pa, pb, pd) + angle_xy(pc, pd, pb);
      if (opposite_ac <= opposite_bd) {
        triangles.push_back({a, b, c});
        triangles.push_back({a, c, d});
      } else {
        triangles.push_back({a, b, d});
        triangles.push_back({b, c, d});
      }
    }
  }
  field.mesh = finish(std::move(positions), std::move(triangles));
  field.height = std::move(z);
  return field;
}

HeightField make_ridge_field(int n, double jitter, std::uint64_t seed, double amplitude,
                             double width, double bend) {
  require(std::isfinite(amplitude), "make_ridge_field", "amplitude must be finite");
  require(positive_finite(width), "make_ridge_field", "width must be positive and finite");
  require(std::isfinite(bend), "make_ridge_field", "bend must be finite");
  auto crest = [bend](double x) { return bend * std::sin(kPi * x / 2) + kRidgeCrestOffset; };
  auto z = [crest, amplitude, width](double x, double y) {
    const double d = (y - crest(x)) / width;
    return amplitude * std::exp(-d * d);
  };
  return make_crest_field(z, crest, n, jitter, seed);
}

HeightField make_crease_field(int n, double jitter, std::uint64_t seed, double amplitude,
                              double width) {
  require(std::isfinite(amplitude), "make_crease_field", "amplitude must be finite");
  require(positive_finite(width), "make_crease_field", "width must be positive and finite");
  auto crest = [](double x) { return kCreaseSlope * x + kCreaseOffset; };
  auto z = [amplitude, width](double x, double y) {
    return amplitude * std::max(0.0, 1.0 - distance_to_crease_line(x, y) / width);
  };
  return make_crest_field(z, crest, n, jitter, seed);
}

double distance_to_crease_line(double x, double y) {
  return std::abs(y - kCreaseSlope * x - kCreaseOffset) /
         std::sqrt(1.0 + kCreaseSlope * kCreaseSlope);
}

double distance_to_crest(const HeightField& field, double x, double y) {
  require(static_cast<bool>(field.crest), "distance_to_crest", "the field has no crest curve");
  const auto& crest = field.crest;
  // The vertical offset bounds the distance, so the nearest curve point has its x'
  // within that bound of x.
  const double bound = std::abs(y - crest(x));
  if (bound == 0) return 0;
  auto squared = [&](double t) {
    const double dx = t - x, dy = crest(t) - y;
    return dx * dx + dy * dy;
  };

  constexpr int kSamples = 4096;
  const double lo = x - bound, step = 2 * bound / kSamples;
  int best = 0;
  double best_value = squared(lo);
  for (int s = 1; s <= kSamples; ++s) {
    const double value = squared(lo + step * s);
    if (value < best_value) best_value = value, best = s;
  }

  // Golden-section search in the bracket of the best sample's neighbours.
  const double inv_phi = (std::sqrt(5.0) - 1) / 2;
  double a = lo + step * std::max(best - 1, 0), b = lo + step * std::min(best + 1, kSamples);
  double c = b - inv_phi * (b - a), d = a + inv_phi * (b - a);
  double fc = squared(c), fd = squared(d);
  for (int iteration = 0; iteration < 200 && b - a > 1e-15 * (1 + std::abs(x)); ++iteration) {
    if (fc < fd) {
      b = d, d = c, fd = fc;
      c = b - inv_phi * (b - a), fc = squared(c);
    } else {
      a = c, c = d, fc = fd;
      d = a + inv_phi * (b - a), fd = squared(d);
    }
  }
  best_value = std::min({best_value, fc, fd, squared((a + b) / 2)});
  return std::sqrt(best_value);
}

RawMesh make_subdivided_cube(int n) {
  require(n >= 1, "make_subdivided_cube", "n must be at least 1");
  RawMesh mesh;
  std::map<std::array<int, 3>, std::uint32_t> ids;
  auto id = [&](std::array<int, 3> p) {
    const auto [it, inserted] = ids.emplace(p, std::uint32_t(mesh.positions.size()));
    if (inserted) mesh.positions.push_back({double(p[0]) / n, double(p[1]) / n, double(p[2]) / n});
    return it->second;
  };
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      // u x v = +axis; the face at side 0 faces -axis, so its quads run v, u instead.
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
          auto corner = [&](int di, int dj) {
            std::array<int, 3> p{};
            p[axis] = side * n;
            p[u] = i + di;
            p[v] = j + dj;
            return id(p);
          };
          const auto a = corner(0, 0), b = corner(1, 0), c = corner(1, 1), d = corner(0, 1);
          if (side == 1) {
            mesh.triangles.push_back({a, b, c});
            mesh.triangles.push_back({a, c, d});
          } else {
            mesh.triangles.push_back({a, c, b});
            mesh.triangles.push_back({a, d, c});
          }
        }
    }
  mesh.source_faces = mesh.triangles.size();
  return mesh;
}

RawMesh make_plane_grid(int n, double jitter, std::uint64_t seed) {
  return make_height_field([](double, double) { return 0.0; }, n, jitter, seed).mesh;
}

std::uint32_t nearest_vertex(const RawMesh& mesh, double x, double y) {
  require(!mesh.positions.empty(), "nearest_vertex", "the mesh has no vertices");
  std::uint32_t best = 0;
  double best_squared = std::numeric_limits<double>::infinity();
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    const double dx = mesh.positions[v][0] - x, dy = mesh.positions[v][1] - y;
    const double squared = dx * dx + dy * dy;
    if (squared < best_squared) best_squared = squared, best = static_cast<std::uint32_t>(v);
  }
  return best;
}

RawMesh scaled(RawMesh mesh, double s) {
  require(positive_finite(s), "scaled", "the scale factor must be positive and finite");
  for (Vec3& p : mesh.positions)
    for (double& coordinate : p) coordinate *= s;
  return mesh;
}

RawMesh translated(RawMesh mesh, double dx, double dy, double dz) {
  for (Vec3& p : mesh.positions) {
    p[0] += dx;
    p[1] += dy;
    p[2] += dz;
  }
  return mesh;
}

std::vector<std::uint32_t> keys_on_crest(const HeightField& field, std::initializer_list<double> xs) {
  std::vector<std::uint32_t> keys;
  for (double x : xs) keys.push_back(nearest_vertex(field.mesh, x, field.crest(x)));
  return keys;
}

}  // namespace featureline::testing
