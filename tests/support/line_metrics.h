// Measures of lines used by the tests and benchmarks: distance to an analytic crest,
// total turning angle, adjacency of vertex paths.
#pragma once

#include <functional>
#include <vector>

#include <Eigen/Core>

#include "engine/feature_line.h"
#include "tests/support/synthetic_meshes.h"

namespace featureline::testing {

/// Sum of the angles between consecutive segments (radians): 0 for a straight line.
double total_turning(const std::vector<Eigen::Vector3d>& points);

/// Mean and maximum xy distance of points to the field's crest curve.
struct CrestDistance {
  double mean = 0, max = 0;
};
CrestDistance crest_distance(const HeightField& field, const std::vector<Eigen::Vector3d>& points);

/// The arc-length mean (Simpson's rule per segment) and the maximum (at points and segment
/// midpoints) of `distance` along a polyline (closing segment included when `closed`); a
/// polyline without length averages its points.
struct LineDistance {
  double mean = 0, max = 0;
};
LineDistance arc_length_distance(const std::vector<Eigen::Vector3d>& points, bool closed,
                                 const std::function<double(const Eigen::Vector3d&)>& distance);

/// Positions of a result's refined points.
std::vector<Eigen::Vector3d> refined_positions(const FeatureLineResult& result);

/// Positions of surface points.
std::vector<Eigen::Vector3d> positions_of(const std::vector<SurfacePoint>& points);

/// Mean over `points` (each point once, not along arc length) of their distance to `polyline`
/// (closing segment included when `closed`); 0 for no points.
double mean_distance_to_polyline(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& polyline,
                                 bool closed);

/// True when consecutive vertices of `path` are mesh neighbours.
bool is_edge_path(const PreparedMesh& mesh, const std::vector<std::uint32_t>& path);

/// Height of the mesh surface above (x, y) (NaN outside the mesh), by locating the triangle.
double surface_height(const RawMesh& mesh, double x, double y);

/// The field's analytic crest between x0 and x1 as `count` points evenly spaced along it and
/// laid on the faceted surface: what a line exactly on the crest looks like on this mesh.
std::vector<Eigen::Vector3d> crest_on_surface(const HeightField& field, double x0, double x1, std::size_t count);

}  // namespace featureline::testing
