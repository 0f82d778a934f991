#include "engine/feature_line.h"

#include <chrono>
#include <deque>

#include "engine/crease_fit.h"
#include "engine/errors.h"

namespace featureline {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point start) { return std::chrono::duration<double, std::milli>(Clock::now() - start).count(); }

struct Piece {
  std::size_t begin, end;  // indices into the (unrolled) line, both ends pinned
  bool exact = false;      // a clean crease run: kept as it is
  bool noisy_crease = false;  // a crease run on a noisy mesh: re-fitted (engine/crease_fit.h)
};

// Whether the mesh edge a-b is a crease of the line's kind (any kind when sign is 0).
bool is_crease_edge(const PreparedMesh& pm, std::uint32_t a, std::uint32_t b, double sign) {
  for (auto k = pm.neighbor_offsets[a]; k < pm.neighbor_offsets[a + 1]; ++k)
    if (pm.neighbors[k] == b) {
      const auto crease = pm.curvature.crease[k];
      return crease != 0 && (sign == 0 || crease == sign);
    }
  return false;
}

// The share of the piece's edges that are creases of the line's kind. A clean crease run is kept
// exactly only when every edge is one: a sharp bend sampled by a mesh whose edges do not follow it
// has scattered short runs of sharp edges beside the true bend, which the snake must still refine.
// On a noisy mesh the noise unmarks some edges of a true crease run (a dihedral angle that dips
// under the threshold), so there a run that is mostly crease is re-fitted as one.
double crease_share(const PreparedMesh& pm, const std::vector<std::uint32_t>& line, const Piece& piece, double sign) {
  std::size_t creases = 0;
  for (std::size_t i = piece.begin; i < piece.end; ++i) creases += is_crease_edge(pm, line[i], line[i + 1], sign);
  return piece.end > piece.begin ? double(creases) / double(piece.end - piece.begin) : 0.0;
}

std::vector<SurfacePoint> vertex_points(const PreparedMesh& pm, const std::vector<std::uint32_t>& vertices) {
  std::vector<SurfacePoint> points;
  for (auto v : vertices) points.push_back(surface_point_at_vertex(pm, v));
  return points;
}

}  // namespace

double mean_feature_strength(const PreparedMesh& pm, const std::vector<SurfacePoint>& points, double feature_sign,
                             double cap) {
  auto strength = [&](const SurfacePoint& p) {
    const auto& corners = pm.triangles[p.face];
    double value = 0;
    for (int k = 0; k < 3; ++k)
      value += p.barycentric[k] * std::min(cap, feature_value(pm.curvature, corners[k], feature_sign) / pm.curvature_scale);
    return value;
  };
  double sum = 0, length = 0;
  for (std::size_t i = 1; i < points.size(); ++i) {
    const double l = (points[i].position - points[i - 1].position).norm();
    sum += l * 0.5 * (strength(points[i]) + strength(points[i - 1]));
    length += l;
  }
  if (length > 0) return sum / length;
  return points.empty() ? 0 : strength(points.front());
}

double polyline_length(const std::vector<SurfacePoint>& points, bool closed) {
  double length = 0;
  for (std::size_t i = 1; i < points.size(); ++i) length += (points[i].position - points[i - 1].position).norm();
  if (closed && points.size() > 2) length += (points.front().position - points.back().position).norm();
  return length;
}

FeatureLineResult detect_feature_line(const PreparedMesh& pm, const FeatureLineRequest& request) {
  const auto start = Clock::now();
  const FeatureLineOptions& options = request.options;
  if (options.min_piece_edges < 2) throw InvalidInputError("min_piece_edges must be at least 2");
  FeatureLineResult result;
  result.keys = request.keys;
  result.closed = request.closed;

  result.initial = find_initial_line(pm, request.keys, request.closed, options.initial, request.cancel);
  result.warnings = result.initial.warnings;
  for (auto v : result.initial.vertices) result.initial_points.push_back(pm.positions[v]);
  result.timings.initial_ms = ms_since(start);

  // The line unrolled: a closed line repeats its first vertex at the end.
  std::vector<std::uint32_t> line = result.initial.vertices;
  std::vector<std::size_t> key_at = result.initial.key_indices;
  if (request.closed) {
    line.push_back(line.front());
    key_at.push_back(line.size() - 1);
  }

  if (!options.refine || line.size() < 3) {
    for (std::size_t i = 0; i < result.initial.vertices.size(); ++i)
      result.refined.push_back(surface_point_at_vertex(pm, result.initial.vertices[i]));
    result.refined_length = polyline_length(result.refined, request.closed);
    result.timings.total_ms = ms_since(start);
    return result;
  }

  // Pieces between pinned points. A closed line always has at least two pieces: a loop laid
  // out as one open strip would meet itself at its first key.
  std::deque<Piece> pieces;
  if (options.pin_interior_keys) {
    for (std::size_t k = 0; k + 1 < key_at.size(); ++k) pieces.push_back({key_at[k], key_at[k + 1]});
  } else if (request.closed) {
    const std::size_t half = (line.size() - 1) / 2;
    pieces.push_back({0, half});
    pieces.push_back({half, line.size() - 1});
    result.warnings.push_back("the closed line is refined as two halves pinned at its first key and at vertex " +
                              std::to_string(line[half]) + " opposite it");
  } else {
    pieces.push_back({0, line.size() - 1});
  }

  SnakeOptions snake_options = options.snake;
  if (snake_options.feature_sign == 0 && options.initial.sign_aware)
    snake_options.feature_sign = keys_feature_sign(pm, request.keys, options.initial);
  // Clean creases are the feature itself: their runs are kept exactly. On a noisy mesh a crease
  // run is re-fitted instead of handed to the snake (see engine/crease_fit.h for why).
  if (options.exact_crease_edges > 0) {
    const bool clean = pm.curvature.noise < options.exact_crease_noise;
    for (Piece& piece : pieces) {
      const bool long_enough = piece.end - piece.begin >= std::size_t(options.exact_crease_edges);
      const double share = long_enough ? crease_share(pm, line, piece, snake_options.feature_sign) : 0.0;
      piece.exact = clean && share == 1.0;
      piece.noisy_crease = !clean && share >= options.crease_fit.min_crease_share && options.crease_fit.bandwidth > 0;
    }
  }

  std::vector<SurfacePoint>& refined = result.refined;
  while (!pieces.empty()) {
    throw_if_cancelled(request.cancel);
    const Piece piece = pieces.front();
    pieces.pop_front();
    const std::vector<std::uint32_t> sub(line.begin() + std::ptrdiff_t(piece.begin), line.begin() + std::ptrdiff_t(piece.end) + 1);
    std::vector<SurfacePoint> points;
    PieceReport report;
    report.from = sub.front();
    report.to = sub.back();
    report.edges = sub.size() - 1;
    const auto initial_points = vertex_points(pm, sub);
    report.initial_strength = mean_feature_strength(pm, initial_points, snake_options.feature_sign, snake_options.curvature_cap);
    if (piece.exact) {
      points = initial_points;
      report.kept = "crease";
    } else if (piece.noisy_crease) {
      points = fit_noisy_crease(pm, sub, options.crease_fit).points;
      report.kept = "crease fit";
      report.refined_strength = mean_feature_strength(pm, points, snake_options.feature_sign, snake_options.curvature_cap);
    } else if (sub.size() < 3) {
      // a single edge is already straight on the surface
      points = initial_points;
      report.kept = "initial";
      report.reason = "a single edge";
    } else {
      auto t0 = Clock::now();
      const FeatureStrip strip = extract_feature_strip(pm, sub, options.strip);
      result.timings.strip_ms += ms_since(t0);
      t0 = Clock::now();
      const FlatStrip flat = flatten_strip(pm, strip, options.strip);
      result.timings.flatten_ms += ms_since(t0);
      const std::size_t edges = piece.end - piece.begin;
      if (flat.flipped_near_line > 0 && edges >= 2 * std::size_t(options.min_piece_edges)) {
        // Split where the layout folded, keeping both halves at least min_piece_edges long.
        std::size_t at = piece.begin + flat.worst_flip_line_index;
        at = std::clamp(at, piece.begin + std::size_t(options.min_piece_edges), piece.end - std::size_t(options.min_piece_edges));
        pieces.push_front({at, piece.end, false});
        pieces.push_front({piece.begin, at, false});
        ++result.splits;
        continue;
      }
      if (flat.flipped_near_line > 0)
        result.warnings.push_back("the strip around line vertices " + std::to_string(sub.front()) + ".." +
                                  std::to_string(sub.back()) + " folds over when flattened; refined where it is valid");
      t0 = Clock::now();
      try {
        const SnakeResult snake = refine_with_snake(pm, strip, flat, snake_options, request.cancel);
        points = map_to_surface(pm, strip, snake.points);
        result.iterations += snake.iterations;
        report.iterations = snake.iterations;
        report.iteration_cap = !snake.converged && snake.iterations >= snake_options.max_iterations;
        report.refined_strength = mean_feature_strength(pm, points, snake_options.feature_sign, snake_options.curvature_cap);
        if (report.refined_strength < options.keep_initial_below * report.initial_strength) {
          // Never worse: the snake left the feature (cut a corner, was drawn to another
          // feature); the initial line is the better answer for this piece.
          points = initial_points;
          report.kept = "initial";
          report.reason = "the refined line was weaker on the feature than the initial line";
        } else {
          result.refined_by_snake = true;
        }
      } catch (const GeometryError& e) {
        // A pinned end whose every strip triangle folded or distorted: keep this piece's
        // initial line rather than failing the whole line, and say so.
        points = initial_points;
        report.kept = "initial";
        report.reason = e.what();
        result.warnings.push_back("line vertices " + std::to_string(sub.front()) + ".." + std::to_string(sub.back()) +
                                  " were not refined: " + e.what());
      }
      result.timings.snake_ms += ms_since(t0);
      result.strip_faces += strip.triangles.size();
    }
    ++result.pieces;
    result.piece_reports.push_back(std::move(report));
    // Pieces meet at pinned vertices: keep the shared point once.
    refined.insert(refined.end(), points.begin() + (refined.empty() ? 0 : 1), points.end());
  }
  if (request.closed && refined.size() > 1) refined.pop_back();  // back at the first key
  result.refined_length = polyline_length(refined, request.closed);
  result.timings.total_ms = ms_since(start);
  return result;
}

}  // namespace featureline
