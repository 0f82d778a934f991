#include "engine/internal/strip_walk.h"

#include <algorithm>
#include <cmath>

#include "engine/internal/geometry.h"

namespace featureline {

Eigen::Vector3d barycentric_of(const Eigen::Vector2d& q, const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                               const Eigen::Vector2d& c) {
  const double area = cross2(b - a, c - a);
  if (area == 0) return {1, 0, 0};
  const double l1 = cross2(c - b, q - b) / area;
  const double l2 = cross2(a - c, q - c) / area;
  return {l1, l2, 1 - l1 - l2};
}

Eigen::Vector2d closest_on_segment(const Eigen::Vector2d& q, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector2d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0 ? std::clamp((q - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return a + t * ab;
}

bool walk(const FeatureStrip& strip, const FlatStrip& flat, std::uint32_t start, const Eigen::Vector2d& target,
          StripPoint& out) {
  std::uint32_t t = start;
  const std::size_t guard = 4 * strip.triangles.size() + 16;
  for (std::size_t step = 0; step < guard; ++step) {
    const auto& tri = strip.triangles[t];
    const Eigen::Vector2d& a = flat.uv[tri[0]];
    const Eigen::Vector2d& b = flat.uv[tri[1]];
    const Eigen::Vector2d& c = flat.uv[tri[2]];
    const Eigen::Vector3d lambda = barycentric_of(target, a, b, c);
    int worst = 0;
    for (int k = 1; k < 3; ++k)
      if (lambda[k] < lambda[worst]) worst = k;
    if (lambda[worst] >= -1e-12) {
      out.triangle = t;
      out.barycentric = lambda.cwiseMax(0.0) / lambda.cwiseMax(0.0).sum();
      out.uv = target;
      return true;
    }
    const std::int32_t next = strip.triangle_neighbors[t][worst];
    if (next >= 0 && flat.triangle_valid[std::size_t(next)]) {
      t = std::uint32_t(next);
      continue;
    }
    // The strip's border (or a fold) is in the way: stop on the nearest point of this triangle.
    Eigen::Vector2d best = closest_on_segment(target, a, b);
    for (const auto& candidate : {closest_on_segment(target, b, c), closest_on_segment(target, c, a)})
      if ((candidate - target).squaredNorm() < (best - target).squaredNorm()) best = candidate;
    const Eigen::Vector3d clamped = barycentric_of(best, a, b, c).cwiseMax(0.0);
    out.triangle = t;
    out.barycentric = clamped / clamped.sum();
    out.uv = out.barycentric[0] * a + out.barycentric[1] * b + out.barycentric[2] * c;
    return true;
  }
  return false;
}

void move_along_segment(const FeatureStrip& strip, const FlatStrip& flat, StripPoint& point, const Eigen::Vector2d& target) {
  std::uint32_t t = point.triangle;
  Eigen::Vector3d at_q = point.barycentric;  // of the current position q in triangle t
  const std::size_t guard = 4 * strip.triangles.size() + 16;
  for (std::size_t step = 0; step < guard; ++step) {
    const auto& tri = strip.triangles[t];
    const Eigen::Vector2d& a = flat.uv[tri[0]];
    const Eigen::Vector2d& b = flat.uv[tri[1]];
    const Eigen::Vector2d& c = flat.uv[tri[2]];
    const Eigen::Vector3d at_target = barycentric_of(target, a, b, c);
    if (at_target.minCoeff() >= -1e-12) {
      point.triangle = t;
      point.barycentric = at_target.cwiseMax(0.0) / at_target.cwiseMax(0.0).sum();
      point.uv = target;
      return;
    }
    // Leave through the edge whose barycentric coordinate reaches zero first along q -> target.
    at_q = at_q.cwiseMax(0.0);
    int exit = -1;
    double exit_at = HUGE_VAL;
    for (int k = 0; k < 3; ++k) {
      if (at_target[k] >= 0) continue;
      const double s = at_q[k] / (at_q[k] - at_target[k]);
      if (s < exit_at) exit_at = s, exit = k;
    }
    Eigen::Vector3d at_exit = (at_q + exit_at * (at_target - at_q)).cwiseMax(0.0);
    at_exit /= at_exit.sum();
    const Eigen::Vector2d q = at_exit[0] * a + at_exit[1] * b + at_exit[2] * c;
    const std::int32_t next = strip.triangle_neighbors[t][exit];
    if (next < 0 || !flat.triangle_valid[std::size_t(next)]) {
      point.triangle = t;
      point.barycentric = at_exit;
      point.uv = q;
      return;
    }
    t = std::uint32_t(next);
    const auto& n = strip.triangles[t];
    at_q = barycentric_of(q, flat.uv[n[0]], flat.uv[n[1]], flat.uv[n[2]]);
  }
  // A folded layout made the walk cycle: the point stays where it was.
}

}  // namespace featureline
