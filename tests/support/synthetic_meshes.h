// Synthetic triangle meshes with known analytic answers, for the engine's tests and
// benchmarks: spheres (mean curvature 1/r), cylinders and capsules (exact areas, a
// vertex ring at z = 0), and height fields over [-1,1]^2 on irregular, jittered
// Delaunay grids whose ridge, valley and crease crests do not follow mesh edges.
//
// Every generator is deterministic: the same arguments give the same mesh, bit for
// bit, on every standard library (randomness comes from std::mt19937_64 with the
// given seed and our own mapping to [-1, 1)). Triangles are oriented counter-clockwise
// seen from outside (closed meshes) or from +z (height fields). Invalid arguments
// throw std::invalid_argument.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <initializer_list>
#include <vector>

#include "engine/mesh_io.h"

namespace featureline::testing {

// ---------------------------------------------------------------------------------
// Closed surfaces
// ---------------------------------------------------------------------------------

/// The unit cube [0,1]^3 with each face an n x n grid of quads (split along one diagonal),
/// outward oriented. Each cube edge is a run of n mesh edges between two corners, where three
/// 90-degree creases meet.
/// \param n  quads per face side, >= 1
RawMesh make_subdivided_cube(int n);

/// Icosahedron centred at the origin, each face split into 4 `subdivisions` times,
/// with every vertex projected onto the sphere. Closed, genus 0, outward oriented;
/// nearly uniform triangles, so the mean curvature is 1/radius everywhere.
/// 10*4^s + 2 vertices and 20*4^s triangles.
/// \param radius        sphere radius, > 0
/// \param subdivisions  number of 1-to-4 splits of the icosahedron, 0..8
RawMesh make_icosphere(double radius, int subdivisions);

/// Latitude/longitude sphere centred at the origin: vertex 0 is the north pole
/// (0,0,radius), then `rings - 1` latitude rings of `segments` vertices from north to
/// south, then the south pole (last vertex). Triangle shapes vary strongly (slivers
/// fanning around the poles). Closed, genus 0, outward oriented.
/// \param radius    sphere radius, > 0
/// \param rings     number of latitude bands between the poles, >= 2
/// \param segments  number of vertices around each latitude ring, >= 3
RawMesh make_uv_sphere(double radius, int rings, int segments);

/// Cylinder around the z axis from z = -height/2 to z = +height/2: `rings + 1` rings
/// of `segments` vertices from bottom to top (vertex id = ring * segments + k, k
/// counter-clockwise seen from +z, angle 2*pi*k/segments). When capped, the centre of
/// the bottom cap (id (rings+1)*segments) and of the top cap (the last id) close the
/// ends with triangle fans, giving a closed genus-0 mesh with sharp rims; uncapped, it
/// is an open tube with two boundary loops (Euler characteristic 0). Outward oriented.
/// \param radius    cylinder radius, > 0
/// \param height    length along z, > 0
/// \param rings     number of bands along z, >= 1
/// \param segments  number of vertices around each ring, >= 3
/// \param capped    true to close both ends with flat caps
RawMesh make_cylinder(double radius, double height, int rings, int segments, bool capped);

/// Capsule (a cylinder closed by two hemispheres) with its axis along z, centred at
/// the origin: the cylinder part spans |z| <= cylinder_height/2 and the caps reach
/// z = +-(cylinder_height/2 + radius). Closed, genus 0, outward oriented, smooth
/// (G1) everywhere; mean curvature 1/radius on the caps and 1/(2*radius) on the
/// cylinder.
///
/// Layout: vertex 0 is the north pole, then rings of `segments` vertices from north to
/// south (vertex id = 1 + ring * segments + k, k counter-clockwise seen from +z, angle
/// 2*pi*k/segments), then the south pole (last vertex). There are
/// 2*rings_per_cap + rings_cylinder - 1 rings; ring rings_per_cap - 1 is the upper
/// junction z = cylinder_height/2, and ring rings_per_cap - 1 + rings_cylinder/2 lies
/// exactly at z = 0 (see capsule_equator).
///
/// Analytic answers (see capsule_area, capsule_area_above): total area
/// 4*pi*r^2 + 2*pi*r*h; area above the plane z = c for |c| < h/2 is
/// 2*pi*r^2 + 2*pi*r*(h/2 - c).
/// \param radius           radius of the cylinder and of the hemispheres, > 0
/// \param cylinder_height  length h of the cylinder part along z, > 0
/// \param segments         number of vertices around each ring, >= 3
/// \param rings_per_cap    number of latitude bands in each hemisphere, >= 1
/// \param rings_cylinder   number of bands along the cylinder part; even and >= 2 so a
///                         vertex ring lies at z = 0
RawMesh make_capsule(double radius, double cylinder_height, int segments, int rings_per_cap,
                     int rings_cylinder);

/// Vertex ids of make_capsule's ring at z = 0 (same arguments as make_capsule), in
/// order counter-clockwise seen from +z; consecutive ids (and last to first) are mesh
/// edges, so they form a closed loop on vertices and edges.
/// \param segments        as in make_capsule
/// \param rings_per_cap   as in make_capsule
/// \param rings_cylinder  as in make_capsule (even, >= 2)
std::vector<std::uint32_t> capsule_equator(int segments, int rings_per_cap, int rings_cylinder);

/// Exact area of the smooth capsule: 4*pi*r^2 + 2*pi*r*h.
/// \param radius           capsule radius r
/// \param cylinder_height  cylinder length h
double capsule_area(double radius, double cylinder_height);

/// Exact area of the smooth capsule's part above the plane z = c:
/// 2*pi*r^2 + 2*pi*r*(h/2 - c); requires |c| < h/2 (the plane cuts the cylinder part).
/// \param radius           capsule radius r
/// \param cylinder_height  cylinder length h
/// \param c                height of the cutting plane, |c| < h/2
double capsule_area_above(double radius, double cylinder_height, double c);

// ---------------------------------------------------------------------------------
// Height fields over [-1,1]^2
// ---------------------------------------------------------------------------------

/// A triangulated height field z = height(x, y) over the square [-1,1]^2.
///
/// Layout: vertex id = j*n + i for grid column i (x) and row j (y), 0 <= i, j < n;
/// grid cell (i, j) with corners a = (i,j), b = (i+1,j), c = (i+1,j+1), d = (i,j+1)
/// holds triangles 2*(j*(n-1)+i) and 2*(j*(n-1)+i)+1, split along the diagonal a-c or
/// b-d, whichever satisfies the Delaunay criterion in the xy plane.
struct HeightField {
  RawMesh mesh;                                ///< the triangulation, CCW seen from +z
  std::function<double(double, double)> height;  ///< z as a function of (x, y)
  int n = 0;                                   ///< grid points per side
  double spacing = 0;                          ///< unjittered grid spacing 2/(n-1)
  /// The crest curve y = crest(x) of ridge, valley and crease fields (defined for all
  /// x, not only on [-1,1]); empty for other height fields.
  std::function<double(double)> crest;
};

/// Height field on a jittered n x n grid over [-1,1]^2. Interior grid points move by
/// up to `jitter` times the grid spacing in x and in y independently; boundary points
/// move only along the square's border and the four corners stay fixed. Each cell is
/// split along the diagonal whose opposite angles sum to at most pi in the xy plane
/// (the empty-circumcircle criterion; ties, as on an unjittered grid, take a-c), so the
/// triangulation is irregular and its edges follow no particular curve.
/// \param z       the height function; vertex z = z(x, y) at the jittered (x, y)
/// \param n       grid points per side, >= 2
/// \param jitter  displacement bound in grid spacings, 0 <= jitter < 0.25 (keeps every
///                cell convex, so all triangles have positive area in xy)
/// \param seed    seed of the std::mt19937_64 that draws the jitter
HeightField make_height_field(std::function<double(double, double)> z, int n, double jitter,
                              std::uint64_t seed);

/// Offset of the ridge crest: crest(x) = bend * sin(pi*x/2) + kRidgeCrestOffset, so the
/// crest never lies on a grid line or a grid diagonal.
constexpr double kRidgeCrestOffset = 0.1234;

/// Ridge (amplitude > 0) or valley (amplitude < 0): z = amplitude * exp(-(d/width)^2)
/// with the vertical offset d = y - crest(x) and crest(x) = bend*sin(pi*x/2) + 0.1234.
/// The field's `crest` member is that curve; distance_to_crest measures from it.
/// \param n          grid points per side, as in make_height_field
/// \param jitter     as in make_height_field
/// \param seed       as in make_height_field
/// \param amplitude  crest height (> 0 ridge, < 0 valley)
/// \param width      decay length of the Gaussian profile across the crest, > 0
/// \param bend       amplitude of the crest's sine bend (0 = straight line y = 0.1234)
HeightField make_ridge_field(int n, double jitter, std::uint64_t seed, double amplitude,
                             double width, double bend);

/// Slope and offset of the crease line y = kCreaseSlope * x + kCreaseOffset.
constexpr double kCreaseSlope = 0.37;
constexpr double kCreaseOffset = 0.1;

/// Sharp crease (a roof): z = amplitude * max(0, 1 - |d|/width) where d is the signed
/// perpendicular distance to the line y = 0.37 x + 0.1. The crest (d = 0) is a
/// convex crease for amplitude > 0 (concave for < 0); the roof's feet |d| = width are
/// creases of the opposite kind. The field's `crest` member is the line.
/// \param n          grid points per side, as in make_height_field
/// \param jitter     as in make_height_field
/// \param seed       as in make_height_field
/// \param amplitude  roof height (> 0 convex crest, < 0 concave)
/// \param width      half-width of the roof across the crest, > 0
HeightField make_crease_field(int n, double jitter, std::uint64_t seed, double amplitude,
                              double width);

/// Closed-form distance in the xy plane from (x, y) to the crease line
/// y = 0.37 x + 0.1: |y - 0.37 x - 0.1| / sqrt(1 + 0.37^2).
/// \param x  query x
/// \param y  query y
double distance_to_crease_line(double x, double y);

/// Distance in the xy plane from (x, y) to the curve y = field.crest(x') (over all x'),
/// by dense sampling of the 1-D squared distance followed by golden-section
/// refinement; accurate to ~1e-12 for smooth crests.
/// \param field  a ridge, valley or crease field (its `crest` must be set)
/// \param x      query x
/// \param y      query y
/// \throw std::invalid_argument when field.crest is empty
double distance_to_crest(const HeightField& field, double x, double y);

/// Flat jittered Delaunay grid at z = 0 over [-1,1]^2 (make_height_field with z = 0);
/// any strip of it flattens isometrically.
/// \param n       grid points per side, >= 2
/// \param jitter  as in make_height_field
/// \param seed    as in make_height_field
RawMesh make_plane_grid(int n, double jitter, std::uint64_t seed);

/// Ids of the vertices nearest to the field's crest at each given x (keys for lines on it).
/// \param field  a ridge, valley or crease field (its `crest` must be set)
/// \param xs     x positions along the crest
std::vector<std::uint32_t> keys_on_crest(const HeightField& field, std::initializer_list<double> xs);

/// Id of the vertex nearest to (x, y) in the xy plane (ties: the smallest id).
/// \param mesh  a mesh with at least one vertex
/// \param x     query x
/// \param y     query y
std::uint32_t nearest_vertex(const RawMesh& mesh, double x, double y);

// ---------------------------------------------------------------------------------
// Transforms
// ---------------------------------------------------------------------------------

/// The mesh with every position multiplied by s (about the origin).
/// \param mesh  the mesh to scale
/// \param s     scale factor, > 0 (so orientation is kept)
RawMesh scaled(RawMesh mesh, double s);

/// The mesh with every position moved by (dx, dy, dz).
/// \param mesh  the mesh to move
/// \param dx    offset along x
/// \param dy    offset along y
/// \param dz    offset along z
RawMesh translated(RawMesh mesh, double dx, double dy, double dz);

}  // namespace featureline::testing
