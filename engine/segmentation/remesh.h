// Internal to segmentation: splitting faces along a traced line (the paper's Fig. 8).
#pragma once

#include <cstdint>
#include <vector>

#include "engine/internal/geometry.h"
#include "engine/segmentation/stages.h"
#include "engine/surface_point.h"

namespace featureline {

/// The mesh being split. Every new vertex lies on an original edge or inside an original face,
/// and every triangle inside one original face, so all geometric decisions are made in that
/// face's barycentric plane (exact for orientation tests: it is an affine image of the face) and
/// area is preserved. Splits keep the corners' cyclic order, so orientation and manifoldness
/// are kept too. The triangles split off original face F are listed in subs(F): a handful each.
class Remesher {
 public:
  /// `snap`: a crossing closer than this (fraction of a sub-edge) to its end is moved onto it.
  Remesher(const PreparedMesh& mesh, double snap);

  /// Inserts `y` as a vertex (no cut); returns its id.
  std::uint32_t locate(const SurfaceLocation& y);

  /// Inserts the straight segment from vertex x to `y` inside original face f, splitting the
  /// triangles it crosses, and marks its edges cut (for `line`). Returns y's vertex.
  std::uint32_t walk(std::uint32_t x, const SurfaceLocation& y, std::uint32_t f, int line);

  /// The result; the remesher is spent afterwards.
  RemeshedCut take();

 private:
  /// One move of walk(): `done` when y was reached (at `vertex`), else go on from `vertex`.
  struct Move {
    bool done = false;
    std::uint32_t vertex = 0;
  };
  Move move_along_edge(std::uint32_t x, const SurfaceLocation& y, std::uint32_t f, int k, int line);
  Move move_across(std::uint32_t x, const SurfaceLocation& y, std::uint32_t f, int line);
  std::uint32_t locate_on_edge(std::uint32_t f, const SurfaceLocation& y);
  std::uint32_t locate_in_face(std::uint32_t f, const SurfaceLocation& y);

  SurfaceLocation location_of(std::uint32_t v) const;
  Eigen::Vector2d coords(std::uint32_t f, std::uint32_t v) const;
  std::vector<std::uint32_t>& subs(std::uint32_t f);
  int original_edge_of(std::uint32_t f, std::uint32_t b, std::uint32_t c) const;
  SurfaceLocation between(std::uint32_t f, std::uint32_t b, std::uint32_t c, double u) const;
  std::uint32_t add_vertex(const SurfaceLocation& l);
  std::uint32_t add_triangle(const Triangle& t, std::uint32_t source);
  std::uint32_t split_face(std::uint32_t t, const SurfaceLocation& l);
  std::uint32_t split_edge(std::uint32_t f, std::uint32_t b, std::uint32_t c, const SurfaceLocation& l);
  void cut(std::uint32_t a, std::uint32_t b, int line);

  const PreparedMesh& mesh_;
  double snap_;
  RemeshedCut out_;
  std::vector<std::vector<std::uint32_t>> subs_;
  std::vector<SurfaceLocation> origins_;  ///< of vertex n_vertices() + i
};

}  // namespace featureline
