// Points on the surface of a prepared mesh, in the two forms the engine uses:
//  - SurfacePoint: what results carry (a face, barycentric coordinates in its corner order and
//    the 3D position), as the snake maps its line back and as the JSON answers print it;
//  - SurfaceLocation: the same point in the simplest form that holds it (on a vertex, on an
//    edge, inside a face), so that code deciding whether two faces share a point (tracing a line
//    across faces, splitting faces along it) compares ids and one parameter, not rounded
//    coordinates.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "engine/prepared_mesh.h"

namespace featureline {

using Barycentric = std::array<double, 3>;

/// A point of a line on the original surface.
struct SurfacePoint {
  Eigen::Vector3d position;
  std::uint32_t face = 0;  ///< mesh face id
  Barycentric barycentric;  ///< w.r.t. PreparedMesh::triangles[face], sums to 1
};

/// A surface point in the simplest form that holds it.
struct SurfaceLocation {
  enum Kind : std::uint8_t { vertex, edge, face } kind = vertex;
  std::uint32_t a = 0, b = 0;  ///< vertex: a; edge: its ends, a < b; face: a is the face
  double t = 0;                ///< edge: weight of b
  Barycentric w{0, 0, 0};      ///< face: barycentric w.r.t. PreparedMesh::triangles[a]
  std::uint32_t home = 0;      ///< a face whose closure holds the point
};

/// Two locations closer than this (barycentric units, or edge parameter) are the same point.
constexpr double kSameLocation = 1e-9;

bool same_location(const SurfaceLocation& x, const SurfaceLocation& y);

/// The location of vertex v, with `home` one of its faces.
SurfaceLocation vertex_location(std::uint32_t v, std::uint32_t home);

/// The point with barycentric coordinates w in face f of `triangles`, in its simplest form:
/// coordinates below `snap` are snapped to 0 (onto an edge or a vertex); negative ones are
/// clamped to 0 and the rest renormalised.
SurfaceLocation locate_in_face(const std::vector<std::array<std::uint32_t, 3>>& triangles, std::uint32_t f,
                               Barycentric w, double snap);

/// Barycentric coordinates of `l` in face f, when f's closure holds it.
std::optional<Barycentric> barycentric_in(const std::vector<std::array<std::uint32_t, 3>>& triangles, std::uint32_t f,
                                          const SurfaceLocation& l);

/// Is `l` on the edge (p, q) (an end included)?
bool lies_on_edge(const SurfaceLocation& l, std::uint32_t p, std::uint32_t q);

/// Position of `l` along the edge from min(p, q) to max(p, q), l on that edge.
double edge_parameter(const SurfaceLocation& l, std::uint32_t p, std::uint32_t q);

Eigen::Vector3d position_of(const PreparedMesh& mesh, const SurfaceLocation& l);

/// The surface point sitting exactly on mesh vertex v (barycentric 1 on one face corner).
SurfacePoint surface_point_at_vertex(const PreparedMesh& mesh, std::uint32_t v);

/// The corner of p's face with the largest barycentric weight: the vertex p lies nearest.
std::uint32_t nearest_corner(const PreparedMesh& mesh, const SurfacePoint& p);

/// Checks a surface point given from outside (a client's line): the face exists and the
/// barycentric coordinates are finite, non-negative (to 1e-6) and sum to 1 (to 1e-6).
/// \throw InvalidInputError "<where>: face F is out of range (the mesh has N faces)",
///        "<where>: barycentric coordinates must be finite and non-negative" or
///        "<where>: barycentric coordinates must sum to 1".
void check_surface_point(const PreparedMesh& mesh, std::uint32_t face, const Barycentric& barycentric,
                         const std::string& where);


}  // namespace featureline
