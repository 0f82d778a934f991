// Internal to segmentation: following the straight line between two surface points from face
// to face (the segment between consecutive refined points, unfolded across each edge it
// crosses), recording where it crosses edges.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "engine/internal/geometry.h"
#include "engine/segmentation/stages.h"
#include "engine/surface_point.h"

namespace featureline {

/// One piece of a traced line: from the previous location to `to`, straight inside `face`; or,
/// when `gap`, a jump to `to` (the line crossed between parts of the mesh that share no edge).
struct TraceStep {
  SurfaceLocation to;
  std::uint32_t face = 0;
  bool gap = false;
};

enum class Traced { straight, along_edges, gap };

/// Traces over the prepared mesh's own faces (its vertex-to-faces table). When the walk gets
/// lost (cone vertices, folded geometry) the piece follows the shortest edge path between the
/// points' nearest vertices instead.
class Tracer {
 public:
  /// `snap`: crossings closer than this (barycentric units) to a vertex or edge are moved onto it.
  Tracer(const PreparedMesh& mesh, double snap) : mesh_(mesh), snap_(snap) {}

  /// Appends the steps from `from` to `to` and says how they were found.
  Traced trace(const SurfaceLocation& from, const SurfaceLocation& to, std::vector<TraceStep>& steps) const;

 private:
  std::vector<std::uint32_t> faces_containing(const SurfaceLocation& l) const;
  std::optional<Barycentric> project(std::uint32_t f, const Eigen::Vector3d& x) const;
  std::optional<Barycentric> unfold_into(std::uint32_t f, std::uint32_t g, const SurfaceLocation& to) const;
  std::optional<Barycentric> target_in(std::uint32_t f, const SurfaceLocation& to, const Eigen::Vector3d& target) const;
  bool leave_vertex(const SurfaceLocation& c, const SurfaceLocation& to, const Eigen::Vector3d& target,
                    SurfaceLocation& next, std::uint32_t& face) const;
  bool leave_edge_or_face(const SurfaceLocation& c, std::uint32_t came_from, const SurfaceLocation& to,
                          const Eigen::Vector3d& target, SurfaceLocation& next, std::uint32_t& face) const;
  bool walk(const SurfaceLocation& from, const SurfaceLocation& to, std::vector<TraceStep>& steps) const;
  std::uint32_t nearest_vertex(const SurfaceLocation& l) const;
  std::uint32_t face_with_edge(std::uint32_t a, std::uint32_t b) const;
  Traced along_edges(const SurfaceLocation& from, const SurfaceLocation& to, std::vector<TraceStep>& steps) const;

  const PreparedMesh& mesh_;
  double snap_;
};

}  // namespace featureline
