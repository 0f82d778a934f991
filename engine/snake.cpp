#include "engine/snake.h"

#include <algorithm>
#include <cmath>

#include "engine/errors.h"
#include "engine/internal/geometry.h"
#include "engine/internal/order_statistics.h"
#include "engine/internal/pentadiagonal.h"
#include "engine/internal/snake_force.h"
#include "engine/internal/strip_walk.h"

namespace featureline {
namespace {


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

// A = alpha D1^T D1 + beta D2^T D2 over all n points, built from the energy sum
// alpha |v_{i+1} - v_i|^2 + beta |v_{i-1} - 2 v_i + v_{i+1}|^2 (Eqs. 5, 6, 12). Building A from the
// energy gives the right rows next to the pinned ends: a truncated fourth difference there would
// act as if v_{-1} = 0 and pull the line towards the origin.
SymmetricPentadiagonal stiffness(std::size_t n, double alpha, double beta) {
  SymmetricPentadiagonal A;
  A.assign_zero(n);
  for (std::size_t i = 0; i + 1 < n; ++i) {  // first differences (-1, 1) at i, i+1
    A.d0[i] += alpha, A.d0[i + 1] += alpha;
    A.d1[i] -= alpha;
  }
  for (std::size_t i = 0; i + 2 < n; ++i) {  // second differences (1, -2, 1) at i, i+1, i+2
    A.d0[i] += beta, A.d0[i + 1] += 4 * beta, A.d0[i + 2] += beta;
    A.d1[i] -= 2 * beta, A.d1[i + 1] -= 2 * beta;
    A.d2[i] += beta;
  }
  return A;
}

// ---------------------------------------------------------------------------------------------
// The stages of refine_with_snake. Distances are in strip edge lengths ("unit") inside the
// linear system and the force, in strip coordinates where points are placed.

// A valid triangle at each strip vertex (and the vertex's corner in it), to start walks from.
struct VertexStarts {
  std::vector<std::int64_t> triangle;  ///< -1: no valid triangle around the vertex
  std::vector<int> corner;
};

VertexStarts vertex_starts(const FeatureStrip& strip, const FlatStrip& flat) {
  VertexStarts starts{std::vector<std::int64_t>(strip.vertices.size(), -1), std::vector<int>(strip.vertices.size(), 0)};
  for (std::size_t t = 0; t < strip.triangles.size(); ++t)
    if (flat.triangle_valid[t])
      for (int k = 0; k < 3; ++k)
        if (starts.triangle[strip.triangles[t][k]] < 0)
          starts.triangle[strip.triangles[t][k]] = std::int64_t(t), starts.corner[strip.triangles[t][k]] = k;
  return starts;
}

StripPoint point_at_vertex(const VertexStarts& starts, const FlatStrip& flat, std::uint32_t v) {
  if (starts.triangle[v] < 0) throw GeometryError("the feature strip could not be flattened around a line vertex");
  StripPoint p;
  p.triangle = std::uint32_t(starts.triangle[v]);
  p.barycentric = Eigen::Vector3d::Zero();
  p.barycentric[starts.corner[v]] = 1;
  p.uv = flat.uv[v];
  return p;
}

// Pieces a gap of `ratio` spacings is cut into: at least 1 and at most `cap`, whatever a
// degenerate strip gives (converting NaN or a huge ratio to int is undefined behaviour).
int piece_count(double ratio, std::size_t cap) {
  if (!(ratio >= 1)) return 1;  // below one spacing, or NaN
  return int(std::min(ratio, double(std::min<std::size_t>(cap, 1 << 20))));
}

// The initial snake v_0 of Eq. (15): the flattened line P* (Eq. 11) resampled at spacing h.
std::vector<StripPoint> initial_snake(const FeatureStrip& strip, const FlatStrip& flat, const VertexStarts& starts, double h) {
  std::vector<StripPoint> points;
  points.push_back(point_at_vertex(starts, flat, strip.line.front()));
  for (std::size_t i = 0; i + 1 < strip.line.size(); ++i) {
    const Eigen::Vector2d a = flat.uv[strip.line[i]], b = flat.uv[strip.line[i + 1]];
    const int pieces = piece_count(std::round((b - a).norm() / h), std::size_t(1) << 16);
    // Restart at each line vertex when it has a valid triangle; otherwise walk on from the
    // previous sample.
    StripPoint last = i == 0 || starts.triangle[strip.line[i]] < 0 ? points.back() : point_at_vertex(starts, flat, strip.line[i]);
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
  points.push_back(point_at_vertex(starts, flat, strip.line.back()));
  return points;
}

// What every stage of one run reads.
struct SnakeRun {
  const FeatureStrip& strip;
  const FlatStrip& flat;
  const SnakeOptions& o;
  const ForceField& force;
  double unit;         ///< strip edge length: the scale of the linear system
  double h;            ///< target spacing of the points (strip coordinates)
  std::size_t max_points;
};

// Paper: points farther apart than 3h/2 get points between them, points closer than h/2 are
// deleted (the varying dimension of Eq. 15). The normal step then spreads them evenly, as it
// never moves them along the line; `damping` is the share of the way it spreads them.
void resample(const SnakeRun& run, std::vector<StripPoint>& points, double damping) {
  const double h = run.h;
  std::vector<StripPoint> next;
  next.reserve(points.size() + 8);
  next.push_back(points.front());
  for (std::size_t i = 1; i < points.size(); ++i) {
    const bool last = i + 1 == points.size();
    const double gap = (points[i].uv - next.back().uv).norm();
    if (!last && gap < 0.5 * h) continue;  // too close: delete
    const int pieces = piece_count(std::ceil(gap / h), run.max_points);
    // Bounded work whatever the options: a line may at most quadruple its initial point count
    // (an extreme kappa once made it 209,204 points and 51 s; ../shared/data/regressions).
    const bool room = next.size() + (points.size() - i) + std::size_t(pieces) <= run.max_points;
    if (gap > 1.5 * h && room) {  // too far: insert evenly
      const StripPoint from = next.back();
      for (int k = 1; k < pieces; ++k) {
        StripPoint p = from;
        walk(run.strip, run.flat, from.triangle, from.uv + (points[i].uv - from.uv) * (double(k) / pieces), p);
        next.push_back(p);
      }
    }
    next.push_back(points[i]);
  }
  // the last kept interior point may now sit too close to the pinned end
  if (next.size() > 2 && (next.back().uv - next[next.size() - 2].uv).norm() < 0.5 * h) next.erase(next.end() - 2);
  points.swap(next);
  if (run.o.normal_step) spread_evenly(run.strip, run.flat, points, damping);
}

// The linear system of Eq. (15) and its buffers, kept across iterations: A is rebuilt only when
// resampling changed the number of points.
struct SnakeSystem {
  PentadiagonalLDLT solver;
  SymmetricPentadiagonal A, M;
  SymmetricPentadiagonal A_interior;  ///< A's block over the interior points
  std::vector<double> diagonal;  ///< 1 + tau K_ii per interior point (normal step)
  std::size_t factored_size = 0;  ///< paper step: the point count M was factorised for
  Eigen::VectorXd x, y, rhs_x, rhs_y;  ///< positions v_k in units, right-hand sides
  Eigen::VectorXd ax, ay;              ///< A v_k (normal step)
  std::vector<Eigen::Vector2d> normal;
};

// Loads v_k (in units) and rebuilds A when the number of points changed.
void load_positions(const SnakeRun& run, const std::vector<StripPoint>& points, SnakeSystem& sys) {
  const std::size_t n = points.size();
  if (n != sys.A.size()) {
    sys.A = stiffness(n, run.o.alpha, run.o.beta);
    if (n > 2) sys.A_interior = sys.A.block(1, n - 2), sys.M = sys.A_interior;
  }
  sys.x.resize(Eigen::Index(n));
  sys.y.resize(Eigen::Index(n));
  for (std::size_t i = 0; i < n; ++i)
    sys.x[Eigen::Index(i)] = points[i].uv.x() / run.unit, sys.y[Eigen::Index(i)] = points[i].uv.y() / run.unit;
}

// Each interior point's normal: the chord between its neighbours turned by 90 degrees.
void chord_normals(SnakeSystem& sys, std::size_t n) {
  sys.normal.assign(n, Eigen::Vector2d::Zero());
  for (std::size_t i = 1; i + 1 < n; ++i) {
    const Eigen::Vector2d chord(sys.x[Eigen::Index(i + 1)] - sys.x[Eigen::Index(i - 1)],
                                sys.y[Eigen::Index(i + 1)] - sys.y[Eigen::Index(i - 1)]);
    const double length = chord.norm();
    if (length > 0) sys.normal[i] = Eigen::Vector2d(-chord.y(), chord.x()) / length;
  }
}

// Eq. (15) restricted to moves s_i along each point's normal n_i (N = diag(n_i)):
//   (I + tau N'AN + tau K) s = tau N'(kappa F - A v),
// K = diag(max(0, -kappa n_i' J n_i)) the smooth force's restoring stiffness (J its Jacobian),
// so steep forces do not overshoot. Assembles M and rhs_x for the interior points; the pinned
// ends enter through A v.
void assemble_normal_system(const SnakeRun& run, const std::vector<StripPoint>& points, SnakeSystem& sys) {
  const SnakeOptions& o = run.o;
  const std::size_t n = points.size(), m = n - 2;
  sys.A.multiply(sys.x, sys.ax);
  sys.A.multiply(sys.y, sys.ay);
  const Eigen::VectorXd &ax = sys.ax, &ay = sys.ay;
  sys.rhs_x.resize(Eigen::Index(m));
  sys.diagonal.resize(m);
  for (std::size_t i = 1; i + 1 < n; ++i) {
    const Eigen::Vector2d residual =
        o.kappa * force_at(run.force, run.strip, points[i]) - Eigen::Vector2d(ax[Eigen::Index(i)], ay[Eigen::Index(i)]);
    sys.rhs_x[Eigen::Index(i - 1)] = o.tau * sys.normal[i].dot(residual);
    double stiffness_i = 0;
    if (!run.force.jacobian.empty())
      stiffness_i = std::max(0.0, -o.kappa * sys.normal[i].dot(run.force.jacobian[points[i].triangle] * sys.normal[i]));
    sys.diagonal[i - 1] = 1.0 + o.tau * stiffness_i;
  }
  const SymmetricPentadiagonal& a = sys.A_interior;
  // tau N'AN: entry (r, c) couples the moves of points r + 1 and c + 1 along their normals.
  auto coupling = [&](double a_rc, std::size_t r, std::size_t c) {
    return o.tau * a_rc * sys.normal[r + 1].dot(sys.normal[c + 1]);
  };
  for (std::size_t r = 0; r < m; ++r) {
    sys.M.d0[r] = sys.diagonal[r] + coupling(a.d0[r], r, r);
    if (r + 1 < m) sys.M.d1[r] = coupling(a.d1[r], r, r + 1);
    if (r + 2 < m) sys.M.d2[r] = coupling(a.d2[r], r, r + 2);
  }
}

// One normal step: each interior point's target, its solved move along its normal, damped and
// held to the trust region max_step.
void normal_step_targets(const SnakeRun& run, const std::vector<StripPoint>& points, double damping, SnakeSystem& sys,
                         std::vector<Eigen::Vector2d>& targets) {
  const std::size_t n = points.size();
  chord_normals(sys, n);
  assemble_normal_system(run, points, sys);
  if (!sys.solver.factorize(sys.M)) throw GeometryError("the snake system could not be factorised");
  Eigen::VectorXd& s = sys.rhs_x;
  sys.solver.solve_in_place(s);
  for (std::size_t i = 1; i + 1 < n; ++i) {
    const double move = std::clamp(damping * s[Eigen::Index(i - 1)], -run.o.max_step, run.o.max_step);
    targets[i] = Eigen::Vector2d(sys.x[Eigen::Index(i)], sys.y[Eigen::Index(i)]) + move * sys.normal[i];
  }
}

// The paper step's force term tau kappa F of Eq. (15) at interior point i, optionally without
// its component along the line, capped so a point never jumps across a crest in one iteration.
Eigen::Vector2d paper_force_step(const SnakeRun& run, const std::vector<StripPoint>& points, std::size_t i) {
  const SnakeOptions& o = run.o;
  Eigen::Vector2d step = o.tau * o.kappa * force_at(run.force, run.strip, points[i]);
  if (o.normal_force_only) {
    const Eigen::Vector2d chord = points[i + 1].uv - points[i - 1].uv;
    const double chord_len = chord.norm();
    if (chord_len > 0) step -= step.dot(chord / chord_len) * (chord / chord_len);
  }
  const double len = step.norm();
  if (len > o.max_step) step *= o.max_step / len;
  return step;
}

// Factors (I + tau A) restricted to the interior points, when the number of points changed.
void factor_paper_system(const SnakeRun& run, std::size_t n, SnakeSystem& sys) {
  if (n == sys.factored_size) return;
  SymmetricPentadiagonal Mi = sys.A_interior;
  for (auto* diagonal : {&Mi.d0, &Mi.d1, &Mi.d2})
    for (double& value : *diagonal) value *= run.o.tau;
  for (double& value : Mi.d0) value += 1.0;
  if (!sys.solver.factorize(Mi)) throw GeometryError("the snake system could not be factorised");
  sys.factored_size = n;
}

// The paper's Eq. (15) on both coordinates: (I + tau A) v_{k+1} = v_k + tau kappa F, explicit in
// the force; the targets are damped towards the solution.
void paper_step_targets(const SnakeRun& run, const std::vector<StripPoint>& points, double damping, SnakeSystem& sys,
                        std::vector<Eigen::Vector2d>& targets) {
  const std::size_t n = points.size();
  const auto last = Eigen::Index(n - 1);
  factor_paper_system(run, n, sys);
  // Pinned ends enter the right-hand side through A's coupling columns.
  Eigen::VectorXd ends_x = Eigen::VectorXd::Zero(Eigen::Index(n)), ends_y = Eigen::VectorXd::Zero(Eigen::Index(n));
  ends_x[0] = sys.x[0], ends_x[last] = sys.x[last];
  ends_y[0] = sys.y[0], ends_y[last] = sys.y[last];
  const Eigen::VectorXd coupling_x = sys.A * ends_x, coupling_y = sys.A * ends_y;
  sys.rhs_x.resize(Eigen::Index(n - 2));
  sys.rhs_y.resize(Eigen::Index(n - 2));
  for (std::size_t i = 1; i + 1 < n; ++i) {
    const Eigen::Vector2d step = paper_force_step(run, points, i);
    const auto r = Eigen::Index(i - 1), at = Eigen::Index(i);
    sys.rhs_x[r] = sys.x[at] + step.x() - run.o.tau * coupling_x[at];
    sys.rhs_y[r] = sys.y[at] + step.y() - run.o.tau * coupling_y[at];
  }
  sys.solver.solve_in_place(sys.rhs_x);
  sys.solver.solve_in_place(sys.rhs_y);
  const Eigen::VectorXd &new_x = sys.rhs_x, &new_y = sys.rhs_y;
  for (std::size_t i = 1; i + 1 < n; ++i) {
    const Eigen::Vector2d target(new_x[Eigen::Index(i - 1)], new_y[Eigen::Index(i - 1)]);
    const Eigen::Vector2d now(sys.x[Eigen::Index(i)], sys.y[Eigen::Index(i)]);
    targets[i] = now + damping * (target - now);
  }
}

// Convergence is judged on the line's shape over windows of an even number of iterations, so a
// point swinging between two states cancels out. A window whose shape change exceeds the
// previous one's means the line is not settling (a point held by the strip's border, a force
// kink); the step is halved then, so the snake always comes to rest.
//
// A window whose change is over kStalled of the last one's has stalled as well: a point swinging
// between the strip's border and the force, moves that resampling undoes. Such a line settles
// only as its moves are damped; waiting for a window that happens to grow took half of the
// 250-300 iterations of snakes on weak fields.
struct ConvergenceWindow {
  int length = 2;
  std::vector<Eigen::Vector2d> start;  ///< the line at the window's start
  double last_change = HUGE_VAL;
  double damping = 1;                  ///< share of each solved move that is taken
};

constexpr double kStalled = 0.9;

// At a window's end: records the shape change per iteration and says whether it is below the
// tolerance (the paper's "total displacement is low enough"); damps the moves when it grew.
bool window_settled(ConvergenceWindow& window, const SnakeRun& run, const std::vector<StripPoint>& points,
                    SnakeResult& result) {
  const double change = mean_distance_to(points, window.start) / run.unit / double(window.length);
  result.last_displacement = change;
  if (change < run.o.tolerance) return true;
  if (change > kStalled * window.last_change) window.damping *= 0.5;
  window.last_change = change;
  return false;
}

// Iterates Eq. (15) until the line settles, the iteration cap, or cancellation.
void iterate_snake(const SnakeRun& run, SnakeResult& result, const Cancellation* cancel) {
  const SnakeOptions& o = run.o;
  std::vector<StripPoint>& points = result.points;
  SnakeSystem sys;
  ConvergenceWindow window;
  window.length = 2 * o.resample_every;
  std::vector<Eigen::Vector2d> targets;
  for (int iteration = 0; iteration < o.max_iterations; ++iteration) {
    throw_if_cancelled(cancel);
    if (iteration % o.resample_every == 0) resample(run, points, window.damping);
    const std::size_t n = points.size();
    if (n <= 2) {
      result.converged = true;
      break;
    }
    if (iteration % window.length == 0) {
      window.start.clear();
      for (const auto& p : points) window.start.push_back(p.uv);
    }
    load_positions(run, points, sys);
    targets.assign(n, Eigen::Vector2d::Zero());
    if (o.normal_step) normal_step_targets(run, points, window.damping, sys, targets);
    else paper_step_targets(run, points, window.damping, sys, targets);
    for (std::size_t i = 1; i + 1 < n; ++i)
      if (targets[i].allFinite()) move_along_segment(run.strip, run.flat, points[i], targets[i] * run.unit);
    result.iterations = iteration + 1;
    if ((iteration + 1) % window.length == 0 && window_settled(window, run, points, result)) {
      result.converged = true;
      break;
    }
  }
}

}  // namespace

double strip_feature_strength(const PreparedMesh& pm, const FeatureStrip& strip, const SnakeOptions& o,
                              const LineContext& line) {
  std::vector<double> strength;
  strength.reserve(strip.vertices.size());
  for (auto v : strip.vertices)
    strength.push_back(std::min(feature_value(pm.curvature(), v, line.feature_sign) / pm.curvature_scale(), o.curvature_cap));
  if (strength.empty()) return 0;
  return value_of_rank(strength, std::size_t(0.9 * double(strength.size() - 1)));
}

void check_snake_options(const SnakeOptions& o) {
  using S = SnakeOptions;
  if (!S::alpha_range.contains(o.alpha) || !S::beta_range.contains(o.beta) || !S::tau_range.contains(o.tau) ||
      !S::kappa_range.contains(o.kappa) || !S::exponent_range.contains(o.exponent) ||
      !S::spacing_range.contains(o.spacing) || !S::max_iterations_range.contains(o.max_iterations) ||
      !S::resample_every_range.contains(o.resample_every) || !S::max_step_range.contains(o.max_step) ||
      !S::curvature_cap_range.contains(o.curvature_cap) || !S::featureless_below_range.contains(o.featureless_below) ||
      !S::max_iterations_range.contains(o.featureless_iterations))
    throw InvalidInputError("snake options out of range (alpha, beta, kappa >= 0; tau, exponent, max_step > 0; spacing > " +
                            format_number(S::spacing_range.min) + ")");
}

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
                              const SnakeOptions& o, const LineContext& line, const Cancellation* cancel) {
  check_snake_options(o);
  SnakeResult result;
  const double unit = strip.mean_edge_length;  // distances below are in strip edge lengths
  const ForceField force = build_force_field(pm, strip, flat, o, line.feature_sign, unit);
  const double h = o.spacing * unit;
  result.points = initial_snake(strip, flat, vertex_starts(strip, flat), h);
  result.strip_strength = strip_feature_strength(pm, strip, o, line);
  SnakeOptions settle = o;
  if (result.strip_strength < o.featureless_below) {
    // Nothing here is more of a feature than the mesh's own surface is (on a scan, its noise):
    // the force has no crest to lead the line to, only bumps to wander between, and on such
    // strips the snake's line came out no stronger than the initial one after 150-270
    // iterations. A few iterations smooth the initial line's zigzag; that is the answer.
    result.featureless = true;
    settle.max_iterations = std::min(o.max_iterations, o.featureless_iterations);
  }
  const SnakeRun run{strip, flat, settle, force, unit, h, 4 * result.points.size() + 16};
  iterate_snake(run, result, cancel);
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
      s.position += p.barycentric[k] * pm.positions()[strip.vertices[tri[k]]];
    }
    out.push_back(s);
  }
  return out;
}

}  // namespace featureline
