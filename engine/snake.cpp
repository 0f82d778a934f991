#include "engine/snake.h"

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>

#include "engine/errors.h"
#include "engine/internal/geometry.h"

namespace featureline {
namespace {


// Barycentric coordinates of q in the plane triangle (a, b, c).
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

// Walks from `start` towards `target`; returns false when the walk does not settle (folded
// layouts can cycle), in which case `out` is left untouched.
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

// Moves `point` straight towards `target` across strip triangles, stopping where the segment
// leaves the valid strip (its border or a folded triangle). Unlike walk(), a point stopped by
// the border stays on the segment instead of sliding to the border point nearest the target,
// so a point pushed outwards iteration after iteration stays put rather than creeping along.
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

// Mean distance of the interior points from the polyline `before` (same units as uv). Each
// point is compared with the segments near its proportional position only, so the cost is
// linear; resampling shifts indices by a few at most.
double mean_distance_to(const std::vector<StripPoint>& points, const std::vector<Eigen::Vector2d>& before) {
  const std::size_t n = points.size(), nb = before.size();
  if (n <= 2 || nb < 2) return 0;
  const std::size_t reach = 8 + (n > nb ? n - nb : nb - n);
  double sum = 0;
  for (std::size_t i = 1; i + 1 < n; ++i) {
    const std::size_t centre = std::size_t(std::lround(double(i) * double(nb - 1) / double(n - 1)));
    const std::size_t first = centre > reach ? centre - reach : 0;
    const std::size_t last = std::min(nb - 2, centre + reach);
    double best = HUGE_VAL;
    for (std::size_t j = first; j <= last; ++j)
      best = std::min(best, (closest_on_segment(points[i].uv, before[j], before[j + 1]) - points[i].uv).squaredNorm());
    sum += std::sqrt(best);
  }
  return sum / double(n - 2);
}

// Moves the interior points along the polyline they form, the fraction `share` of the way to
// even spacing by arc length: a move along the line that keeps its shape (up to the chords) and
// leaves the bending term nothing to pull points together with.
void spread_evenly(const FeatureStrip& strip, const FlatStrip& flat, std::vector<StripPoint>& points, double share) {
  const std::size_t n = points.size();
  if (n <= 2) return;
  std::vector<double> arc(n, 0.0);
  for (std::size_t i = 1; i < n; ++i) arc[i] = arc[i - 1] + (points[i].uv - points[i - 1].uv).norm();
  std::vector<StripPoint> spread(points);
  std::size_t segment = 0;
  for (std::size_t k = 1; k + 1 < n; ++k) {
    const double at = arc[k] + share * (arc.back() * double(k) / double(n - 1) - arc[k]);
    while (segment + 2 < n && arc[segment + 1] < at) ++segment;
    const double length = arc[segment + 1] - arc[segment];
    const double f = length > 0 ? std::clamp((at - arc[segment]) / length, 0.0, 1.0) : 0.0;
    StripPoint p = points[f < 0.5 ? segment : segment + 1];
    move_along_segment(strip, flat, p, points[segment].uv + f * (points[segment + 1].uv - points[segment].uv));
    spread[k] = p;
  }
  points.swap(spread);
}

// (I + tau A) restricted to the interior points, A = alpha D1^T D1 + beta D2^T D2 built from the
// energy sum alpha |v_{i+1} - v_i|^2 + beta |v_{i-1} - 2 v_i + v_{i+1}|^2 (Eqs. 5, 6, 12). Building A
// from the energy gives the right rows next to the pinned ends: a truncated fourth difference
// there would act as if v_{-1} = 0 and pull the line towards the origin.
Eigen::SparseMatrix<double> stiffness(std::size_t n, double alpha, double beta) {
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(n * 9);
  for (std::size_t i = 0; i + 1 < n; ++i) {  // first differences
    const std::size_t j = i + 1;
    triplets.emplace_back(i, i, alpha);
    triplets.emplace_back(j, j, alpha);
    triplets.emplace_back(i, j, -alpha);
    triplets.emplace_back(j, i, -alpha);
  }
  for (std::size_t i = 0; i + 2 < n; ++i) {  // second differences (1, -2, 1) at i, i+1, i+2
    const double w[3] = {1, -2, 1};
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) triplets.emplace_back(i + r, i + c, beta * w[r] * w[c]);
  }
  Eigen::SparseMatrix<double> A{Eigen::Index(n), Eigen::Index(n)};
  A.setFromTriplets(triplets.begin(), triplets.end());
  return A;
}

// At a sharp crest (a crease vertex, where |C| drops steeply on both sides of the line) the
// potential has a kink, and any average of the one-sided gradients points towards the flatter
// side, pushing the line off the crease. There the gradient's component across the line is
// set to zero, so the crest itself is the force's zero. Smooth ridges, whose neighbours drop
// only a little, keep their interpolated gradients and with them sub-edge accuracy.
void zero_gradient_across_sharp_crests(const FeatureStrip& strip, const FlatStrip& flat, const std::vector<double>& potential,
                                       double drop, std::vector<Eigen::Vector2d>& gradient) {
  if (!(drop > 0) || drop >= 1) return;
  const std::size_t nv = strip.vertices.size();
  // Tangent of the line at each line vertex, then at every strip vertex from the nearest line vertex.
  std::vector<Eigen::Vector2d> line_tangent(strip.line.size());
  for (std::size_t i = 0; i < strip.line.size(); ++i) {
    const auto a = strip.line[i == 0 ? 0 : i - 1], b = strip.line[std::min(i + 1, strip.line.size() - 1)];
    line_tangent[i] = (flat.uv[b] - flat.uv[a]).normalized();
  }
  std::vector<double> highest_left(nv, -1), highest_right(nv, -1);
  std::vector<Eigen::Vector2d> normal(nv, Eigen::Vector2d::Zero());
  for (std::size_t v = 0; v < nv; ++v) {
    if (!flat.placed[v]) continue;
    std::size_t nearest = 0;
    double best = HUGE_VAL;
    for (std::size_t i = 0; i < strip.line.size(); ++i) {
      const double d = (flat.uv[strip.line[i]] - flat.uv[v]).squaredNorm();
      if (d < best) best = d, nearest = i;
    }
    normal[v] = Eigen::Vector2d(-line_tangent[nearest].y(), line_tangent[nearest].x());
  }
  // Highest potential among the neighbours on each side of the line (through triangle edges).
  for (std::size_t t = 0; t < strip.triangles.size(); ++t) {
    if (!flat.triangle_valid[t]) continue;
    for (int k = 0; k < 3; ++k)
      for (int j = 0; j < 3; ++j) {
        if (j == k) continue;
        const auto v = strip.triangles[t][k], w = strip.triangles[t][j];
        const Eigen::Vector2d d = (flat.uv[w] - flat.uv[v]).normalized();
        const double across = d.dot(normal[v]);
        if (across > 0.5) highest_left[v] = std::max(highest_left[v], potential[w]);
        if (across < -0.5) highest_right[v] = std::max(highest_right[v], potential[w]);
      }
  }
  for (std::size_t v = 0; v < nv; ++v) {
    if (highest_left[v] < 0 || highest_right[v] < 0 || !(potential[v] > 0)) continue;
    const double limit = (1 - drop) * potential[v];
    if (highest_left[v] <= limit && highest_right[v] <= limit)
      gradient[v] -= gradient[v].dot(normal[v]) * normal[v];
  }
}

}  // namespace

StripPoint locate_by_walking(const FeatureStrip& strip, const FlatStrip& flat, std::uint32_t start,
                             const Eigen::Vector2d& target) {
  StripPoint point;
  point.triangle = start;
  const auto& tri = strip.triangles[start];
  point.uv = (flat.uv[tri[0]] + flat.uv[tri[1]] + flat.uv[tri[2]]) / 3.0;
  point.barycentric = Eigen::Vector3d::Constant(1.0 / 3.0);
  walk(strip, flat, start, target, point);
  return point;
}

SnakeResult refine_with_snake(const PreparedMesh& pm, const FeatureStrip& strip, const FlatStrip& flat,
                              const SnakeOptions& o, const Cancellation* cancel) {
  if (!(o.alpha >= 0) || !(o.beta >= 0) || !(o.tau > 0) || !(o.kappa >= 0) || !(o.exponent > 0) || !(o.spacing > 0.01) ||
      o.max_iterations < 0 || o.resample_every < 1 || !(o.max_step > 0) || !(o.curvature_cap > 0))
    throw InvalidInputError("snake options out of range (alpha, beta, kappa >= 0; tau, exponent, max_step > 0; spacing > 0.01)");
  SnakeResult result;
  const double unit = strip.mean_edge_length;  // distances below are in strip edge lengths
  const std::size_t nv = strip.vertices.size();
  const std::size_t nt = strip.triangles.size();

  // Potential |C|^p per strip vertex (Eq. 13 with the exponent of Eq. 15).
  std::vector<double> potential(nv, 0.0);
  for (std::size_t v = 0; v < nv; ++v) {
    const double s = std::min(feature_value(pm.curvature, strip.vertices[v], o.feature_sign) / pm.curvature_scale, o.curvature_cap);
    potential[v] = std::pow(s, o.exponent);
  }
  // Gradient of the barycentric interpolant, constant per triangle (scaled coordinates).
  std::vector<Eigen::Vector2d> triangle_gradient(nt, Eigen::Vector2d::Zero());
  std::vector<double> triangle_area(nt, 0.0);
  for (std::size_t t = 0; t < nt; ++t) {
    if (!flat.triangle_valid[t]) continue;
    const auto& tri = strip.triangles[t];
    const Eigen::Vector2d p[3] = {flat.uv[tri[0]] / unit, flat.uv[tri[1]] / unit, flat.uv[tri[2]] / unit};
    const double twice_area = cross2(p[1] - p[0], p[2] - p[0]);
    Eigen::Vector2d g = Eigen::Vector2d::Zero();
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector2d e = p[(k + 2) % 3] - p[(k + 1) % 3];  // edge opposite corner k
      g += potential[tri[k]] * Eigen::Vector2d(-e.y(), e.x()) / twice_area;
    }
    triangle_gradient[t] = g;
    triangle_area[t] = 0.5 * twice_area;
  }
  std::vector<Eigen::Vector2d> vertex_gradient;
  if (o.force == SnakeForce::smooth) {
    vertex_gradient.assign(nv, Eigen::Vector2d::Zero());
    std::vector<double> weight(nv, 0.0);
    for (std::size_t t = 0; t < nt; ++t) {
      if (!flat.triangle_valid[t]) continue;
      for (auto v : strip.triangles[t]) {
        vertex_gradient[v] += triangle_area[t] * triangle_gradient[t];
        weight[v] += triangle_area[t];
      }
    }
    for (std::size_t v = 0; v < nv; ++v)
      if (weight[v] > 0) vertex_gradient[v] /= weight[v];
    zero_gradient_across_sharp_crests(strip, flat, potential, o.sharp_crest_drop, vertex_gradient);
  }
  // The smooth force F = sum_k lambda_k g_k is linear in each triangle; its Jacobian
  // sum_k g_k grad(lambda_k)^T gives the force's restoring stiffness for the normal step.
  std::vector<Eigen::Matrix2d> force_jacobian;
  if (o.force == SnakeForce::smooth) {
    force_jacobian.assign(nt, Eigen::Matrix2d::Zero());
    for (std::size_t t = 0; t < nt; ++t) {
      if (!flat.triangle_valid[t]) continue;
      const auto& tri = strip.triangles[t];
      const Eigen::Vector2d p[3] = {flat.uv[tri[0]] / unit, flat.uv[tri[1]] / unit, flat.uv[tri[2]] / unit};
      const double twice_area = cross2(p[1] - p[0], p[2] - p[0]);
      for (int k = 0; k < 3; ++k) {
        const Eigen::Vector2d e = p[(k + 2) % 3] - p[(k + 1) % 3];
        force_jacobian[t] += vertex_gradient[tri[k]] * (Eigen::Vector2d(-e.y(), e.x()) / twice_area).transpose();
      }
    }
  }
  auto force_at = [&](const StripPoint& p) -> Eigen::Vector2d {
    if (o.force == SnakeForce::paper) return triangle_gradient[p.triangle];
    const auto& tri = strip.triangles[p.triangle];
    return p.barycentric[0] * vertex_gradient[tri[0]] + p.barycentric[1] * vertex_gradient[tri[1]] +
           p.barycentric[2] * vertex_gradient[tri[2]];
  };

  // A valid triangle at each line vertex, to start walks from.
  std::vector<std::int64_t> triangle_at(nv, -1);
  std::vector<int> corner_at(nv, 0);
  for (std::size_t t = 0; t < nt; ++t)
    if (flat.triangle_valid[t])
      for (int k = 0; k < 3; ++k)
        if (triangle_at[strip.triangles[t][k]] < 0) triangle_at[strip.triangles[t][k]] = std::int64_t(t), corner_at[strip.triangles[t][k]] = k;
  auto point_at_vertex = [&](std::uint32_t v) {
    if (triangle_at[v] < 0) throw GeometryError("the feature strip could not be flattened around a line vertex");
    StripPoint p;
    p.triangle = std::uint32_t(triangle_at[v]);
    p.barycentric = Eigen::Vector3d::Zero();
    p.barycentric[corner_at[v]] = 1;
    p.uv = flat.uv[v];
    return p;
  };

  // Initial snake: the flattened line resampled at the target spacing.
  const double h = o.spacing * unit;
  std::vector<StripPoint>& points = result.points;
  points.push_back(point_at_vertex(strip.line.front()));
  for (std::size_t i = 0; i + 1 < strip.line.size(); ++i) {
    const Eigen::Vector2d a = flat.uv[strip.line[i]], b = flat.uv[strip.line[i + 1]];
    const int pieces = std::max(1, int(std::lround((b - a).norm() / h)));
    // Restart at each line vertex when it has a valid triangle; otherwise walk on from the
    // previous sample.
    StripPoint last = i == 0 || triangle_at[strip.line[i]] < 0 ? points.back() : point_at_vertex(strip.line[i]);
    for (int k = 1; k < pieces; ++k) {
      StripPoint p = last;
      walk(strip, flat, last.triangle, a + (b - a) * (double(k) / pieces), p);
      points.push_back(p);
      last = p;
    }
    if (i + 2 < strip.line.size()) {
      // interior line vertices are ordinary, free snake points
      StripPoint p = last;
      walk(strip, flat, last.triangle, b, p);
      points.push_back(p);
    }
  }
  points.push_back(point_at_vertex(strip.line.back()));

  const std::size_t max_points = 4 * points.size() + 16;
  // Damping of the moves (see the convergence test below).
  double damping = 1;
  // Paper: points farther apart than 3h/2 get points between them, points closer than h/2 are
  // deleted. The normal step then spreads them evenly, as it never moves them along the line.
  auto resample = [&]() {
    std::vector<StripPoint> next;
    next.reserve(points.size() + 8);
    next.push_back(points.front());
    for (std::size_t i = 1; i < points.size(); ++i) {
      const bool last = i + 1 == points.size();
      const double gap = (points[i].uv - next.back().uv).norm();
      if (!last && gap < 0.5 * h) continue;  // too close: delete
      const int pieces = int(std::ceil(gap / h));
      // Bounded work whatever the options: a line may at most quadruple its initial point count
      // (an extreme kappa once made it 209,204 points and 51 s; ../shared/data/regressions).
      const bool room = next.size() + (points.size() - i) + std::size_t(pieces) <= max_points;
      if (gap > 1.5 * h && room) {             // too far: insert evenly
        const StripPoint from = next.back();
        for (int k = 1; k < pieces; ++k) {
          StripPoint p = from;
          walk(strip, flat, from.triangle, from.uv + (points[i].uv - from.uv) * (double(k) / pieces), p);
          next.push_back(p);
        }
      }
      next.push_back(points[i]);
    }
    // the last kept interior point may now sit too close to the pinned end
    if (next.size() > 2 && (next.back().uv - next[next.size() - 2].uv).norm() < 0.5 * h) next.erase(next.end() - 2);
    points.swap(next);
    if (o.normal_step) spread_evenly(strip, flat, points, damping);
  };

  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::NaturalOrdering<int>> solver;
  Eigen::SparseMatrix<double> A, M;
  std::vector<Eigen::Triplet<double>> triplets;
  std::size_t factored_size = 0;
  Eigen::VectorXd x, y, rhs_x, rhs_y;
  std::vector<Eigen::Vector2d> normal, targets;
  // Convergence is judged on the line's shape over windows of an even number of iterations, so
  // a point swinging between two states cancels out. A window whose shape change exceeds the
  // previous one's means the line is not settling (a point held by the strip's border, a force
  // kink); the step is halved then, so the snake always comes to rest.
  const int window = 2 * o.resample_every;
  std::vector<Eigen::Vector2d> window_start;
  double last_change = HUGE_VAL;
  for (int iteration = 0; iteration < o.max_iterations; ++iteration) {
    throw_if_cancelled(cancel);
    if (iteration % o.resample_every == 0) resample();
    const std::size_t n = points.size();
    if (n <= 2) {
      result.converged = true;
      break;
    }
    if (iteration % window == 0) {
      window_start.clear();
      for (const auto& p : points) window_start.push_back(p.uv);
    }
    const std::size_t m = n - 2;  // interior unknowns
    if (Eigen::Index(n) != A.rows()) A = stiffness(n, o.alpha, o.beta);
    x.resize(Eigen::Index(n));
    y.resize(Eigen::Index(n));
    for (std::size_t i = 0; i < n; ++i) x[Eigen::Index(i)] = points[i].uv.x() / unit, y[Eigen::Index(i)] = points[i].uv.y() / unit;
    targets.assign(n, Eigen::Vector2d::Zero());
    if (o.normal_step) {
      // Eq. (15) restricted to moves s_i along each point's normal n_i (N = diag(n_i)):
      //   (I + tau N'AN + tau K) s = tau N'(kappa F - A v),
      // K = diag(max(0, -kappa n_i' J n_i)) the smooth force's restoring stiffness (J its
      // Jacobian), so steep forces do not overshoot. Tangential moves would only slide points
      // along the line; the pinned ends enter through A v.
      normal.assign(n, Eigen::Vector2d::Zero());
      for (std::size_t i = 1; i + 1 < n; ++i) {
        const Eigen::Vector2d chord(x[Eigen::Index(i + 1)] - x[Eigen::Index(i - 1)], y[Eigen::Index(i + 1)] - y[Eigen::Index(i - 1)]);
        const double length = chord.norm();
        if (length > 0) normal[i] = Eigen::Vector2d(-chord.y(), chord.x()) / length;
      }
      const Eigen::VectorXd ax = A * x, ay = A * y;
      rhs_x.resize(Eigen::Index(m));
      triplets.clear();
      for (std::size_t i = 1; i + 1 < n; ++i) {
        const Eigen::Vector2d residual = o.kappa * force_at(points[i]) - Eigen::Vector2d(ax[Eigen::Index(i)], ay[Eigen::Index(i)]);
        rhs_x[Eigen::Index(i - 1)] = o.tau * normal[i].dot(residual);
        double stiffness_i = 0;
        if (!force_jacobian.empty())
          stiffness_i = std::max(0.0, -o.kappa * normal[i].dot(force_jacobian[points[i].triangle] * normal[i]));
        triplets.emplace_back(i - 1, i - 1, 1.0 + o.tau * stiffness_i);
      }
      for (Eigen::Index k = 0; k < A.outerSize(); ++k)
        for (Eigen::SparseMatrix<double>::InnerIterator it(A, k); it; ++it) {
          const auto r = std::size_t(it.row()), c = std::size_t(it.col());
          if (r == 0 || c == 0 || r + 1 == n || c + 1 == n) continue;
          triplets.emplace_back(r - 1, c - 1, o.tau * it.value() * normal[r].dot(normal[c]));
        }
      M.resize(Eigen::Index(m), Eigen::Index(m));
      M.setFromTriplets(triplets.begin(), triplets.end());
      if (n != factored_size) solver.analyzePattern(M);
      factored_size = n;
      solver.factorize(M);
      if (solver.info() != Eigen::Success) throw GeometryError("the snake system could not be factorised");
      const Eigen::VectorXd s = solver.solve(rhs_x);
      for (std::size_t i = 1; i + 1 < n; ++i) {
        const double move = std::clamp(damping * s[Eigen::Index(i - 1)], -o.max_step, o.max_step);
        targets[i] = Eigen::Vector2d(x[Eigen::Index(i)], y[Eigen::Index(i)]) + move * normal[i];
      }
    } else {
      // The paper's Eq. (15) on both coordinates: (I + tau A) v_{k+1} = v_k + tau kappa F, the
      // force step capped so a point never jumps across a crest in one iteration.
      if (n != factored_size) {
        Eigen::SparseMatrix<double> Mi = A.block(1, 1, Eigen::Index(m), Eigen::Index(m)) * o.tau;
        for (Eigen::Index i = 0; i < Eigen::Index(m); ++i) Mi.coeffRef(i, i) += 1.0;
        solver.compute(Mi);
        if (solver.info() != Eigen::Success) throw GeometryError("the snake system could not be factorised");
        factored_size = n;
      }
      // Pinned ends enter the right-hand side through A's coupling columns.
      Eigen::VectorXd ends_x = Eigen::VectorXd::Zero(Eigen::Index(n)), ends_y = Eigen::VectorXd::Zero(Eigen::Index(n));
      ends_x[0] = x[0], ends_x[Eigen::Index(n - 1)] = x[Eigen::Index(n - 1)];
      ends_y[0] = y[0], ends_y[Eigen::Index(n - 1)] = y[Eigen::Index(n - 1)];
      const Eigen::VectorXd coupling_x = A * ends_x, coupling_y = A * ends_y;
      rhs_x.resize(Eigen::Index(m));
      rhs_y.resize(Eigen::Index(m));
      for (std::size_t i = 1; i + 1 < n; ++i) {
        Eigen::Vector2d step = o.tau * o.kappa * force_at(points[i]);
        if (o.normal_force_only) {
          const Eigen::Vector2d chord = points[i + 1].uv - points[i - 1].uv;
          const double chord_len = chord.norm();
          if (chord_len > 0) step -= step.dot(chord / chord_len) * (chord / chord_len);
        }
        const double len = step.norm();
        if (len > o.max_step) step *= o.max_step / len;
        const auto r = Eigen::Index(i - 1);
        rhs_x[r] = x[Eigen::Index(i)] + step.x() - o.tau * coupling_x[Eigen::Index(i)];
        rhs_y[r] = y[Eigen::Index(i)] + step.y() - o.tau * coupling_y[Eigen::Index(i)];
      }
      const Eigen::VectorXd new_x = solver.solve(rhs_x), new_y = solver.solve(rhs_y);
      for (std::size_t i = 1; i + 1 < n; ++i) {
        const Eigen::Vector2d target(new_x[Eigen::Index(i - 1)], new_y[Eigen::Index(i - 1)]);
        const Eigen::Vector2d now(x[Eigen::Index(i)], y[Eigen::Index(i)]);
        targets[i] = now + damping * (target - now);
      }
    }
    for (std::size_t i = 1; i + 1 < n; ++i)
      if (targets[i].allFinite()) move_along_segment(strip, flat, points[i], targets[i] * unit);
    result.iterations = iteration + 1;
    if ((iteration + 1) % window == 0) {
      const double change = mean_distance_to(points, window_start) / unit / double(window);
      result.last_displacement = change;
      if (change < o.tolerance) {
        result.converged = true;
        break;
      }
      if (change > last_change) damping *= 0.5;
      last_change = change;
    }
  }
  return result;
}

std::vector<SurfacePoint> map_to_surface(const PreparedMesh& pm, const FeatureStrip& strip,
                                         const std::vector<StripPoint>& points) {
  std::vector<SurfacePoint> out;
  out.reserve(points.size());
  for (const auto& p : points) {
    SurfacePoint s;
    s.face = strip.faces[p.triangle];
    const auto& tri = strip.triangles[p.triangle];
    s.position = Eigen::Vector3d::Zero();
    for (int k = 0; k < 3; ++k) {
      s.barycentric[k] = p.barycentric[k];
      s.position += p.barycentric[k] * pm.positions[strip.vertices[tri[k]]];
    }
    out.push_back(s);
  }
  return out;
}

}  // namespace featureline
