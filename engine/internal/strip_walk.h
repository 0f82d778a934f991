// Moving points over a flattened strip (snake.h's StripPoint): locating a plane position in the
// strip's triangles, as the snake (engine/snake.cpp) and the crest localisation
// (engine/crest_localization.cpp) do. Private to the engine.
#pragma once

#include <cstdint>

#include <Eigen/Core>

#include "engine/feature_strip.h"
#include "engine/snake.h"

namespace featureline {

/// Barycentric coordinates of q in the plane triangle (a, b, c); (1, 0, 0) when it is degenerate.
Eigen::Vector3d barycentric_of(const Eigen::Vector2d& q, const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                               const Eigen::Vector2d& c);

/// The point of segment a-b nearest q.
Eigen::Vector2d closest_on_segment(const Eigen::Vector2d& q, const Eigen::Vector2d& a, const Eigen::Vector2d& b);

/// Walks from triangle `start` towards `target`, over valid triangles; at the strip's border (or
/// a fold) it stops on the nearest point of the last triangle. False when the walk does not
/// settle (folded layouts can cycle); `out` is then left untouched.
bool walk(const FeatureStrip& strip, const FlatStrip& flat, std::uint32_t start, const Eigen::Vector2d& target, StripPoint& out);

/// Moves `point` straight towards `target` across strip triangles, stopping where the segment
/// leaves the valid strip (its border or a folded triangle). Unlike walk(), a point stopped by
/// the border stays on the segment instead of sliding to the border point nearest the target,
/// so a point pushed outwards again and again stays put rather than creeping along.
void move_along_segment(const FeatureStrip& strip, const FlatStrip& flat, StripPoint& point, const Eigen::Vector2d& target);

}  // namespace featureline
