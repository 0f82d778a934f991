#include "engine/feature_line.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <exception>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "engine/crease_fit.h"
#include "engine/errors.h"
#include "engine/executor.h"
#include "engine/internal/edge_search.h"
#include "engine/internal/geometry.h"
#include "engine/internal/stopwatch.h"

namespace featureline {
namespace {

using Clock = std::chrono::steady_clock;

struct Piece {
  std::size_t begin, end;  // indices into the (unrolled) line, both ends pinned
  bool exact = false;      // a clean crease run: kept as it is
  bool noisy_crease = false;  // a crease run re-fitted (engine/crease_fit.h): see mark_crease_pieces
};

// The share of the piece's edges that are creases of the line's kind. A clean crease run is kept
// exactly only when every edge is one: a sharp bend sampled by a mesh whose edges do not follow it
// has scattered short runs of sharp edges beside the true bend, which the snake must still refine.
// On a noisy mesh the noise unmarks some edges of a true crease run (a dihedral angle that dips
// under the threshold), so there a run that is mostly crease is re-fitted as one.
double crease_share(const PreparedMesh& pm, const std::vector<std::uint32_t>& line, const Piece& piece, double sign) {
  std::size_t creases = 0;
  for (std::size_t i = piece.begin; i < piece.end; ++i) creases += pm.is_crease(line[i], line[i + 1], sign);
  return piece.end > piece.begin ? double(creases) / double(piece.end - piece.begin) : 0.0;
}

// A piece whose marks noise broke is told from a bend that crosses faces by how its initial line
// turns: a crease along edges runs on smoothly, while a bend crossing faces is drawn as a zigzag
// of the sharp edges beside it (kinks of 60-120 degrees on the synthetic roofs and rings), which
// the snake must straighten.
constexpr double kCreaseRunTurnDegrees = 45;

// Whether no vertex inside the piece turns its initial line by more than kCreaseRunTurnDegrees.
bool runs_on_smoothly(const PreparedMesh& pm, const std::vector<std::uint32_t>& line, const Piece& piece) {
  const auto& P = pm.positions();
  for (std::size_t i = piece.begin + 1; i < piece.end; ++i)
    if (angle_between(P[line[i]] - P[line[i - 1]], P[line[i + 1]] - P[line[i]]) > kCreaseRunTurnDegrees * M_PI / 180)
      return false;
  return true;
}

std::vector<SurfacePoint> vertex_points(const PreparedMesh& pm, const std::vector<std::uint32_t>& vertices) {
  std::vector<SurfacePoint> points;
  for (auto v : vertices) points.push_back(surface_point_at_vertex(pm, v));
  return points;
}

// The line unrolled (a closed line repeats its first vertex at the end) and its keys' indices.
struct UnrolledLine {
  std::vector<std::uint32_t> vertices;
  std::vector<std::size_t> key_at;
};

UnrolledLine unroll(const InitialLineResult& initial, bool closed) {
  UnrolledLine line{initial.vertices, initial.key_indices};
  if (closed) {
    line.vertices.push_back(line.vertices.front());
    line.key_at.push_back(line.vertices.size() - 1);
  }
  return line;
}

// Pieces between pinned points. A closed line always has at least two pieces: a loop laid
// out as one open strip would meet itself at its first key.
std::vector<Piece> pinned_pieces(const UnrolledLine& line, bool pin_interior_keys, bool closed,
                                 std::vector<std::string>& warnings) {
  std::vector<Piece> pieces;
  const std::vector<std::uint32_t>& v = line.vertices;
  if (pin_interior_keys) {
    for (std::size_t k = 0; k + 1 < line.key_at.size(); ++k) pieces.push_back({line.key_at[k], line.key_at[k + 1]});
  } else if (closed) {
    const std::size_t half = (v.size() - 1) / 2;
    pieces.push_back({0, half});
    pieces.push_back({half, v.size() - 1});
    warnings.push_back("the closed line is refined as two halves pinned at its first key and at vertex " +
                       std::to_string(v[half]) + " opposite it");
  } else {
    pieces.push_back({0, v.size() - 1});
  }
  return pieces;
}

// Clean creases are the feature itself: their runs are kept exactly. On a noisy mesh a crease
// run is re-fitted instead of handed to the snake (see engine/crease_fit.h for why), and so is a
// run with unmarked edges on a mesh that reads clean: from 1% noise on, the noise unmarks a few
// edges of a CAD part's creases long before the estimate reaches exact_crease_noise, and the
// snake, in a field the crease runs cut, took such pieces off their creases (bench_accuracy at
// 2% and 5% noise: 16 and 29 of 189 lines worse than their initial line, now 6 and 15).
void mark_crease_pieces(const PreparedMesh& pm, const FeatureLineOptions& options, const std::vector<std::uint32_t>& line,
                        const LineContext& context, std::vector<Piece>& pieces) {
  if (options.exact_crease_edges <= 0) return;
  for (Piece& piece : pieces) {
    const bool long_enough = piece.end - piece.begin >= std::size_t(options.exact_crease_edges);
    const double share = long_enough ? crease_share(pm, line, piece, context.feature_sign) : 0.0;
    piece.exact = !context.noisy_mesh && share == 1.0;
    const bool fit = share >= options.crease_fit.min_crease_share && options.crease_fit.bandwidth > 0;
    piece.noisy_crease = fit && (context.noisy_mesh || (share < 1.0 && runs_on_smoothly(pm, line, piece)));
  }
}

// A stretch of consecutive noisy crease pieces re-fitted as one chain (fit_noisy_crease). The
// keys on it are noisy vertices like any other of the run, picked near the crease, not on it
// (CrestOptions::move_keys): a fit that stops at each one pins the line to the noise there and
// estimates the vertices beside it from one side only. The run's ends stay where the line goes
// on into another piece, and a closed line keeps its first key, where its two ends meet.
struct CreaseRun {
  std::size_t begin = 0, end = 0;    ///< indices into the unrolled line
  std::vector<SurfacePoint> points;  ///< one per line vertex begin..end
};

std::vector<CreaseRun> fit_crease_runs(const PreparedMesh& pm, const FeatureLineOptions& options, bool closed,
                                       const std::vector<std::uint32_t>& line, const std::vector<Piece>& pieces) {
  std::vector<CreaseRun> runs;
  const bool move_keys = options.crest.move_keys;
  for (std::size_t first = 0; first < pieces.size();) {
    if (!pieces[first].noisy_crease) {
      ++first;
      continue;
    }
    std::size_t last = first;
    while (last + 1 < pieces.size() && pieces[last + 1].noisy_crease) ++last;
    CreaseRun run{pieces[first].begin, pieces[last].end, {}};
    const std::vector<std::uint32_t> chain(line.begin() + std::ptrdiff_t(run.begin), line.begin() + std::ptrdiff_t(run.end) + 1);
    std::vector<char> fixed(chain.size(), 0);
    fixed.front() = closed || !move_keys || run.begin > 0;
    fixed.back() = closed || !move_keys || run.end + 1 < line.size();
    if (!move_keys)
      for (std::size_t k = first; k < last; ++k) fixed[pieces[k].end - run.begin] = 1;
    run.points = fit_noisy_crease(pm, chain, options.crease_fit, std::move(fixed)).points;
    runs.push_back(std::move(run));
    first = last + 1;
  }
  return runs;
}

// What refining every piece of one line reads.
struct LineRun {
  const PreparedMesh& pm;
  const FeatureLineOptions& options;
  const LineContext& context;
  const Cancellation* cancel;
  const std::vector<std::uint32_t>& line;  ///< unrolled
  const std::vector<CreaseRun>& crease_runs;
};

// One piece being refined: its vertices, its initial line's points, and what replaces them.
struct PieceWork {
  Piece piece;
  std::vector<std::uint32_t> sub;  ///< the piece's line vertices, ends included
  std::vector<SurfacePoint> initial_points;
  std::vector<SurfacePoint> points;  ///< the piece's answer
  PieceReport report;
  /// Its two ends (front, back): where the piece beside already put them, and whether the crest
  /// localisation may move them (CrestOptions::move_keys).
  std::array<std::optional<SurfacePoint>, 2> placed_ends;
  std::array<bool, 2> movable_ends{false, false};
};

// Where the line passes each of its pinned vertices (keys, split points), indexed by position in
// the unrolled line, as the first piece to reach it decided: the piece on its other side starts
// there, so pieces whose crest localisation moved a key still meet.
class Pins {
 public:
  Pins(std::size_t line_size, bool closed) : at_(line_size), closed_(closed) {}
  std::optional<SurfacePoint>& operator[](std::size_t index) { return at_[slot(index)]; }
  const std::optional<SurfacePoint>& operator[](std::size_t index) const { return at_[slot(index)]; }

 private:
  // A closed line's last vertex is its first, repeated.
  std::size_t slot(std::size_t index) const { return closed_ && index + 1 == at_.size() ? 0 : index; }
  std::vector<std::optional<SurfacePoint>> at_;
  bool closed_;
};

// The piece's ends as the pieces before it left them. A pin shared with a crease piece stays on
// its vertex: the crease run is kept exactly (or re-fitted) through it.
void read_pins(const Pins& pins, const std::vector<std::size_t>& crease_pins, PieceWork& work) {
  const std::size_t at[2] = {work.piece.begin, work.piece.end};
  for (int e = 0; e < 2; ++e) {
    work.placed_ends[e] = pins[at[e]];
    work.movable_ends[e] = std::find(crease_pins.begin(), crease_pins.end(), at[e]) == crease_pins.end();
  }
}

// The first piece to reach a pin decides where the line passes it; a later piece meets it there
// (a piece that kept its initial line or a crease run keeps its inner points and ends on it).
void write_pins(Pins& pins, PieceWork& work) {
  const std::size_t at[2] = {work.piece.begin, work.piece.end};
  for (int e = 0; e < 2; ++e) {
    SurfacePoint& end = e == 0 ? work.points.front() : work.points.back();
    if (pins[at[e]]) end = *pins[at[e]];
    else pins[at[e]] = end;
  }
}

PieceWork start_piece(const LineRun& run, const Piece& piece) {
  PieceWork work;
  work.piece = piece;
  work.sub.assign(run.line.begin() + std::ptrdiff_t(piece.begin), run.line.begin() + std::ptrdiff_t(piece.end) + 1);
  work.report.from = work.sub.front();
  work.report.to = work.sub.back();
  work.report.edges = work.sub.size() - 1;
  work.initial_points = vertex_points(run.pm, work.sub);
  work.report.initial_strength =
      mean_feature_strength(run.pm, work.initial_points, run.context.feature_sign, run.options.snake.curvature_cap);
  return work;
}

void keep_initial(PieceWork& work, std::string reason) {
  work.points = work.initial_points;
  work.report.kept = PieceKept::initial;
  work.report.reason = std::move(reason);
}

// The halves to split a piece into where its layout folded, each at least min_piece_edges long
// (the paper's remedy for highly curved lines); none when it did not fold or is too short.
std::optional<std::array<Piece, 2>> split_where_folded(const LineRun& run, const Piece& piece, const FlatStrip& flat) {
  const std::size_t shortest = std::size_t(run.options.min_piece_edges);
  if (flat.flipped_near_line == 0 || piece.end - piece.begin < 2 * shortest) return std::nullopt;
  const std::size_t at = std::clamp(piece.begin + flat.first_flip_line_index, piece.begin + shortest, piece.end - shortest);
  return std::array<Piece, 2>{Piece{piece.begin, at}, Piece{at, piece.end}};
}

// A surface point in the strip's plane, or none when its face is not laid out (two look-ups per
// piece at most: a scan, not an index).
std::optional<StripPoint> strip_point_of(const FeatureStrip& strip, const FlatStrip& flat, const SurfacePoint& p) {
  for (std::size_t t = 0; t < strip.faces.size(); ++t) {
    const auto& corners = strip.triangles[t];
    if (strip.faces[t] != p.face || !flat.placed[corners[0]] || !flat.placed[corners[1]] || !flat.placed[corners[2]]) continue;
    StripPoint q;
    q.triangle = std::uint32_t(t);
    q.barycentric = Eigen::Vector3d(p.barycentric[0], p.barycentric[1], p.barycentric[2]);
    q.uv = Eigen::Vector2d::Zero();
    for (int k = 0; k < 3; ++k) q.uv += p.barycentric[k] * flat.uv[corners[k]];
    return q;
  }
  return std::nullopt;
}

// How much weaker than the snake's line the crest-localised line may read and still be kept.
// The strength interpolates per-vertex values linearly, so on a clean mesh a line along a crest
// that passes between vertices reads weaker than one drawn through them: on a clean 5,000-triangle
// arc the localised piece read 0.13% weaker and was dropped, leaving its keys 0.3 grid spacings
// off. On a noisy mesh a weaker line is one that followed the noise (a 1% slack there put a 24k
// sine at 20% noise 0.101 -> 0.143 off), so the guard stays tight.
double crest_strength_slack(const PreparedMesh& pm) {
  constexpr double kCleanNoise = 0.02;  // local edge lengths; clean fields estimate 0.004, 10% noise 0.037
  return pm.curvature().noise < kCleanNoise ? 1e-2 : 1e-3;
}

// Stage 3b on the snake's line, kept only where it is not weaker on the feature than the snake's
// own (the never-worse guard, applied to this step too, within crest_strength_slack).
void localize_on_crest(const LineRun& run, const FeatureStrip& strip, const FlatStrip& flat, const SnakeResult& snake,
                       PieceWork& work) {
  if (!run.options.crest.enabled) return;
  std::array<CrestEnd, 2> ends;
  for (int e = 0; e < 2; ++e) {
    ends[e].movable = work.movable_ends[e];
    if (work.placed_ends[e]) {
      ends[e].placed = strip_point_of(strip, flat, *work.placed_ends[e]);
      // Not in this strip's layout: the end stays, and write_pins joins it to the pin.
      if (!ends[e].placed) ends[e].movable = false;
    }
  }
  const CrestResult crest = localize_crest(run.pm, strip, flat, snake.points, run.context.feature_sign, run.options.crest, ends);
  if (crest.moved == 0) return;
  std::vector<SurfacePoint> points = map_to_surface(run.pm, strip, crest.points);
  const double strength = mean_feature_strength(run.pm, points, run.context.feature_sign, run.options.snake.curvature_cap);
  if (strength < work.report.refined_strength * (1 - crest_strength_slack(run.pm))) return;
  work.points = std::move(points);
  work.report.refined_strength = strength;
}

// How deep into its strip a snake's line reaches at which the strip is taken as too narrow for it,
// as a share of the strip's rings (and at least past the middle of the outermost ring): near the
// border the snake reads a field cut off on one side. A clean 245,000-triangle arc crest whose
// initial line lay up to 10 grid spacings off settled 7 of 8 rings deep with two bumps 0.19 and
// 0.33 grid spacings off; refined again in a strip around that line it lies within 0.035.
// bench_accuracy at 0.85 against the outermost ring alone: 8 cells nearer (clean 245,000-triangle
// arcs 0.017 -> 0.007, at 10% 0.051-0.065 -> 0.048-0.057), 2 further by 0.002 (the arc ridge of
// 245,000 triangles at 20 and 30%); at 0.75 one 20% line 0.120 -> 0.168.
constexpr double kSecondStripDepth = 0.85;

// Whether the snake's line went as far from its initial line as the strip lets it (the deepest
// point's ring, interpolated over its triangle, beyond kSecondStripDepth of the rings or nearer
// the outermost ring than the ring inside it), so that the feature may lie further out.
bool reaches_border(const FeatureStrip& strip, const std::vector<StripPoint>& points) {
  const double border_depth = std::min(strip.rings - 0.5, kSecondStripDepth * strip.rings);
  for (const StripPoint& p : points) {
    double depth = 0;
    for (int k = 0; k < 3; ++k) depth += strip.ring[strip.triangles[p.triangle][k]] * p.barycentric[k];
    if (depth > border_depth) return true;
  }
  return false;
}

// A pinned end whose every strip triangle folded or distorted: the piece keeps its initial line
// rather than failing the whole line, and says so.
void keep_initial_unrefined(PieceWork& work, const std::string& why, FeatureLineResult& result) {
  keep_initial(work, why);
  result.warnings.push_back("line vertices " + std::to_string(work.sub.front()) + ".." + std::to_string(work.sub.back()) +
                            " were not refined: " + why);
}

// Stage 3b and the map back (stage 4) on the snake's line of one piece, never worse than the
// initial line. True when the snake's line reached the strip's border.
bool settle_snake_line(const LineRun& run, const FeatureStrip& strip, const FlatStrip& flat, const SnakeResult& snake,
                       PieceWork& work, FeatureLineResult& result) {
  const bool border = reaches_border(strip, snake.points);
  try {
    work.points = map_to_surface(run.pm, strip, snake.points);
    result.iterations += snake.iterations;
    work.report.iterations = snake.iterations;
    work.report.featureless = snake.featureless;
    work.report.iteration_cap =
        !snake.converged && !snake.featureless && snake.iterations >= run.options.snake.max_iterations;
    work.report.refined_strength = mean_feature_strength(run.pm, work.points, run.context.feature_sign, run.options.snake.curvature_cap);
    localize_on_crest(run, strip, flat, snake, work);
    if (work.report.refined_strength < run.options.keep_initial_below * work.report.initial_strength) {
      // Never worse: the snake left the feature (cut a corner, was drawn to another
      // feature); the initial line is the better answer for this piece.
      keep_initial(work, "the refined line was weaker on the feature than the initial line");
    } else {
      result.refined_by_snake = true;
    }
  } catch (const GeometryError& e) {
    keep_initial_unrefined(work, e.what(), result);
  }
  return border;
}

// Stages 3-4 on one piece's strip; true when the snake's line reached the strip's border.
bool snake_on_strip(const LineRun& run, const FeatureStrip& strip, const FlatStrip& flat, PieceWork& work,
                    FeatureLineResult& result) {
  std::optional<SnakeResult> snake;
  try {
    snake.emplace(refine_with_snake(run.pm, strip, flat, run.options.snake, run.context, run.cancel));
  } catch (const GeometryError& e) {
    keep_initial_unrefined(work, e.what(), result);
    return false;
  }
  return settle_snake_line(run, strip, flat, *snake, work, result);
}

// The mesh vertices nearest a refined line, from `first` to `last`: each point's nearest corner,
// consecutive ones joined by the shortest edge path, loops cut out (a simple open path, as a
// strip needs).
std::vector<std::uint32_t> vertex_path_along(const PreparedMesh& pm, const std::vector<SurfacePoint>& points,
                                             std::uint32_t first, std::uint32_t last) {
  std::vector<std::uint32_t> path{first};
  std::unordered_map<std::uint32_t, std::size_t> index{{first, 0}};
  auto push = [&](std::uint32_t v) {
    if (const auto it = index.find(v); it != index.end()) {  // back at v: cut the loop out
      for (std::size_t k = it->second + 1; k < path.size(); ++k) index.erase(path[k]);
      path.resize(it->second + 1);
      return;
    }
    index.emplace(v, path.size());
    path.push_back(v);
  };
  auto join = [&](std::uint32_t v) {
    if (v == path.back()) return true;
    const auto steps = shortest_path_between(pm, path.back(), v, HUGE_VAL);
    if (steps.empty()) return false;
    for (std::size_t k = 1; k < steps.size(); ++k) push(steps[k]);
    return true;
  };
  for (std::size_t i = 1; i + 1 < points.size(); ++i) {
    if (!join(nearest_corner(pm, points[i]))) return {};
  }
  if (!join(last)) return {};
  return path;
}

// A second strip around the vertices nearest the snake's line, when that line reached the border
// of its strip: on fine meshes the initial edge path cuts bends by up to 12 edges, where 8 rings do
// not reach the crest (a 245k-triangle sine crest: the line lay along the border, 1-4 grid
// spacings inside the bends). The second line is kept unless it is weaker on the feature (beyond
// crest_strength_slack).
void refine_again_nearer(const LineRun& run, PieceWork& work, FeatureLineResult& result) {
  const std::vector<std::uint32_t> path = vertex_path_along(run.pm, work.points, work.sub.front(), work.sub.back());
  if (path.size() < 3 || path == work.sub) return;
  PieceWork second = work;
  second.sub = path;
  const FeatureStrip strip = extract_feature_strip(run.pm, path, run.options.strip);
  const FlatStrip flat = flatten_strip(run.pm, strip, run.options.strip, run.context);
  if (flat.flipped_near_line > 0) return;
  FeatureLineResult tally;  // the second pass's iterations and warnings count only when it is kept
  snake_on_strip(run, strip, flat, second, tally);
  // Within the localisation's slack, as the localised line itself is kept: on a clean mesh a
  // line along a crest between vertices reads weaker than one through them, and at a tight bend
  // the first line, held at its strip's border where no crest fit had room, can read a little
  // stronger than the second line on the crest (a clean 24,200-triangle sine's peak: 0.25 grid
  // spacings off, 0.1% stronger).
  const double needed = work.report.refined_strength * (1 - crest_strength_slack(run.pm));
  if (second.report.kept != PieceKept::refined || !(second.report.refined_strength > needed)) return;
  second.report.iterations += work.report.iterations;
  second.report.second_strip = true;
  work = std::move(second);
  result.iterations += tally.iterations;
  result.strip_faces += strip.triangles.size();
  result.warnings.insert(result.warnings.end(), tally.warnings.begin(), tally.warnings.end());
}

// A piece after the stages that read nothing another piece decides (strip, flattening, snake),
// which run for several pieces side by side; the crest localisation, which meets the pins the
// piece before placed, and the map back follow in line order (finish_piece).
struct SnakedPiece {
  Piece piece;
  std::optional<FeatureStrip> strip;
  std::optional<FlatStrip> flat;
  std::optional<SnakeResult> snake;
  std::string unrefined;     ///< why the snake could not run on the strip (a GeometryError)
  std::exception_ptr error;  ///< anything else (cancellation, options): rethrown in the piece's turn
};

// One pinned piece's parts after any splits where its layout folded, in line order, and what
// making them cost.
struct SnakedPieces {
  std::vector<SnakedPiece> parts;
  double strip_ms = 0, flatten_ms = 0, snake_ms = 0;
  int splits = 0;
};

bool needs_snake(const Piece& piece) { return !piece.exact && !piece.noisy_crease && piece.end - piece.begin >= 2; }

// Stages 2-3 on one piece, or on its halves when its layout folded near the line.
void snake_piece(const LineRun& run, const Piece& piece, SnakedPieces& out) {
  SnakedPiece part;
  part.piece = piece;
  try {
    if (needs_snake(piece)) {
      const std::vector<std::uint32_t> sub(run.line.begin() + std::ptrdiff_t(piece.begin),
                                           run.line.begin() + std::ptrdiff_t(piece.end) + 1);
      auto t0 = Clock::now();
      part.strip.emplace(extract_feature_strip(run.pm, sub, run.options.strip));
      out.strip_ms += ms_since(t0);
      t0 = Clock::now();
      // A featureless strip's snake only smooths the line: the paper's layout serves it as well
      // as the conformal solve, which cost such lines (keys off any feature) most of their
      // flattening.
      StripOptions layout = run.options.strip;
      if (layout.flattening == StripFlattening::automatic &&
          strip_feature_strength(run.pm, *part.strip, run.options.snake, run.context) < run.options.snake.featureless_below)
        layout.flattening = StripFlattening::similar_triangles;
      part.flat.emplace(flatten_strip(run.pm, *part.strip, layout, run.context));
      out.flatten_ms += ms_since(t0);
      if (const auto halves = split_where_folded(run, piece, *part.flat)) {
        ++out.splits;
        for (const Piece& half : *halves) snake_piece(run, half, out);
        return;
      }
      t0 = Clock::now();
      try {
        part.snake.emplace(refine_with_snake(run.pm, *part.strip, *part.flat, run.options.snake, run.context, run.cancel));
      } catch (const GeometryError& e) {
        part.unrefined = e.what();
      }
      out.snake_ms += ms_since(t0);
    }
  } catch (...) {
    part.error = std::current_exception();
  }
  out.parts.push_back(std::move(part));
}

// The edges of the pieces in [first, last) that the snake will refine.
std::size_t snake_edges(const std::vector<Piece>& pieces, std::size_t first, std::size_t last) {
  std::size_t edges = 0;
  for (std::size_t i = first; i < last; ++i) edges += needs_snake(pieces[i]) ? pieces[i].end - pieces[i].begin : 0;
  return edges;
}

// snake_piece on pieces [first, last), side by side on the executor's idle threads (a 3-key
// line's two pieces at once); none throws. The caller keeps the half with more snake edges: a
// helper starts a fraction of a millisecond later, and the line waits for the slower half. When
// one half has nothing for the snake (kept creases, single edges), waking a helper costs more
// than that half.
void snake_side_by_side(const LineRun& run, Executor& executor, const std::vector<Piece>& pieces, std::size_t first,
                        std::size_t last, SnakedPieces* out) {
  if (last - first == 1) return snake_piece(run, pieces[first], out[0]);
  const std::size_t middle = first + (last - first) / 2;
  auto front = [&] { snake_side_by_side(run, executor, pieces, first, middle, out); };
  auto back = [&] { snake_side_by_side(run, executor, pieces, middle, last, out + (middle - first)); };
  const std::size_t front_edges = snake_edges(pieces, first, middle), back_edges = snake_edges(pieces, middle, last);
  if (front_edges == 0 || back_edges == 0) front(), back();
  else if (front_edges >= back_edges) executor.run_beside(back, front);
  else executor.run_beside(front, back);
}

// A noisy crease piece's points: its share of the run it belongs to.
std::vector<SurfacePoint> crease_fit_points(const LineRun& run, const PieceWork& work) {
  for (const CreaseRun& crease : run.crease_runs)
    if (crease.begin <= work.piece.begin && work.piece.end <= crease.end)
      return {crease.points.begin() + std::ptrdiff_t(work.piece.begin - crease.begin),
              crease.points.begin() + std::ptrdiff_t(work.piece.end - crease.begin) + 1};
  throw std::logic_error("a noisy crease piece outside every crease run");
}

// Stages 3b-4 on a snaked piece: the snake's line crest-localised from the pins placed so far
// (and, when it reached its strip's border, refined again nearer), or the piece's kept crease,
// re-fitted crease or initial line.
void finish_piece(const LineRun& run, SnakedPiece& part, PieceWork& work, FeatureLineResult& result) {
  if (part.error) std::rethrow_exception(part.error);
  if (work.piece.exact) {
    work.points = work.initial_points;
    work.report.kept = PieceKept::crease;
  } else if (work.piece.noisy_crease) {
    work.points = crease_fit_points(run, work);
    work.report.kept = PieceKept::crease_fit;
    work.report.refined_strength = mean_feature_strength(run.pm, work.points, run.context.feature_sign, run.options.snake.curvature_cap);
  } else if (!needs_snake(work.piece)) {
    keep_initial(work, "a single edge");  // a single edge is already straight on the surface
  } else {
    if (part.flat->flipped_near_line > 0)
      result.warnings.push_back("the strip around line vertices " + std::to_string(work.sub.front()) + ".." +
                                std::to_string(work.sub.back()) + " folds over when flattened; refined where it is valid");
    const auto t0 = Clock::now();
    bool border = false;
    if (part.snake) border = settle_snake_line(run, *part.strip, *part.flat, *part.snake, work, result);
    else keep_initial_unrefined(work, part.unrefined, result);
    if (border && work.report.kept == PieceKept::refined && run.options.second_strip) refine_again_nearer(run, work, result);
    result.timings.snake_ms += ms_since(t0);
    result.strip_faces += part.strip->triangles.size();
  }
}

// The line's feature sign (the request's, else the traced feature's, else that of the keys'
// feature) and whether it treats the mesh as noisy.
LineContext line_context(const PreparedMesh& pm, const FeatureLineRequest& request, const FeatureLineResult& result) {
  const FeatureLineOptions& options = request.options;
  LineContext context;
  context.noisy_mesh = pm.curvature().noise >= options.exact_crease_noise;
  context.feature_sign = options.snake.feature_sign;
  if (context.feature_sign != 0) return context;
  if (result.trace)
    context.feature_sign = result.trace->sign == FeatureSign::ridge ? 1.0 : -1.0;
  else if (options.initial.sign_aware)
    context.feature_sign = keys_feature_sign(pm, request.keys, options.initial);
  return context;
}

void check_min_piece_edges(const FeatureLineOptions& options) {
  if (!FeatureLineOptions::min_piece_edges_range.contains(options.min_piece_edges))
    throw InvalidInputError("min_piece_edges must be at least " + format_number(FeatureLineOptions::min_piece_edges_range.min));
}

}  // namespace

void check_feature_line_options(const FeatureLineOptions& options) {
  check_min_piece_edges(options);
  check_fitted_curve_options(options.fitted);
  check_strip_options(options.strip);
  check_snake_options(options.snake);
  check_crest_options(options.crest);
  check_trace_options(options.trace);
}

double mean_feature_strength(const PreparedMesh& pm, const std::vector<SurfacePoint>& points, double feature_sign,
                             double cap) {
  auto strength = [&](const SurfacePoint& p) {
    const auto& corners = pm.triangles()[p.face];
    double value = 0;
    for (int k = 0; k < 3; ++k)
      value += p.barycentric[k] * std::min(cap, feature_value(pm.curvature(), corners[k], feature_sign) / pm.curvature_scale());
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

namespace {

// A traced line as stage 1's result: its ends are its keys (a loop is pinned at its first vertex
// and half way round, so it is refined as two open pieces like any closed line).
InitialLineResult initial_line_from_trace(const PreparedMesh& pm, const TraceResult& trace) {
  InitialLineResult initial;
  initial.vertices = trace.vertices;
  const std::size_t n = trace.vertices.size();
  initial.key_indices = trace.closed ? std::vector<std::size_t>{0, n / 2} : std::vector<std::size_t>{0, n - 1};
  initial.length = path_length(pm, initial.vertices, trace.closed);
  return initial;
}

void trace_initial_line(const PreparedMesh& pm, const FeatureLineRequest& request, FeatureLineResult& result) {
  if (request.keys.size() != 1)
    throw InvalidInputError("a traced line starts from exactly one key (" + std::to_string(request.keys.size()) + " given)");
  if (request.closed) throw InvalidInputError("a traced line is closed when its feature closes: \"closed\" must be left out");
  // initial.max_edges bounds the trace too: a bound it leaves no trace under is named as set.
  const int initial_max_edges = request.options.initial.max_edges;
  if (!TraceOptions::max_edges_range.contains(initial_max_edges))
    throw InvalidInputError("initial.max_edges must be at least " + format_number(TraceOptions::max_edges_range.min) +
                            " for a traced line (" + std::to_string(initial_max_edges) + " given)");
  TraceOptions options = request.options.trace;
  options.max_edges = std::min(options.max_edges, initial_max_edges);
  result.trace = trace_feature(pm, request.keys.front(), options, request.cancel);
  result.initial = initial_line_from_trace(pm, *result.trace);
  result.closed = result.trace->closed;
  result.keys.clear();
  for (auto i : result.initial.key_indices) result.keys.push_back(result.initial.vertices[i]);
}

// The space curve beside the surface line (engine/fitted_curve.h); `exact` and `noisy_crease`
// mark the refined points of exact and of noisy crease runs (empty: none).
FittedCurveResult fit_curve(const PreparedMesh& pm, const FeatureLineOptions& options, double feature_sign,
                            std::vector<char> exact, std::vector<char> noisy_crease, const FeatureLineResult& result) {
  FittedCurveLine line{result.refined, result.closed, feature_sign, std::move(exact), std::move(noisy_crease), 0};
  const std::size_t edges = result.initial.vertices.size() - (result.closed ? 0 : 1);
  if (edges > 0) line.edge_length = result.initial.length / double(edges);
  return fit_feature_curve(pm, line, options.fitted);
}

// The curve when asked for, and the refined points inside noisy crease runs pulled toward it
// (CreaseFitOptions::curve_pull), which needs it whether asked for or not. The curve is fitted
// beside the crease fit's line, so it is the same either way. True when points were pulled.
bool fit_curve_and_pull_creases(const PreparedMesh& pm, const FeatureLineOptions& options, double feature_sign,
                                std::vector<char> exact, std::vector<char> noisy_crease, const std::vector<char>& pullable,
                                FeatureLineResult& result) {
  const bool pull = options.crease_fit.curve_pull > 0 && std::find(pullable.begin(), pullable.end(), 1) != pullable.end();
  if (!options.fitted.enabled && !pull) return false;
  FittedCurveResult curve = fit_curve(pm, options, feature_sign, std::move(exact), std::move(noisy_crease), result);
  if (pull) {
    pull_toward_curve(pm, curve.points, curve.closed, pullable, options.crease_fit.curve_pull, result.refined);
    result.refined_length = polyline_length(result.refined, result.closed);
  }
  if (options.fitted.enabled) result.fitted = std::move(curve);
  return pull;
}

// Where the refined line passes each key (its pin, or the refined point nearest an unpinned
// interior key) and how far that is from the key's vertex.
void report_key_points(const PreparedMesh& pm, const UnrolledLine& line, const Pins& pins, FeatureLineResult& result) {
  const std::size_t keys = line.key_at.size() - (result.closed && !line.key_at.empty() ? 1 : 0);
  for (std::size_t k = 0; k < keys; ++k) {
    const Eigen::Vector3d vertex = pm.positions()[line.vertices[line.key_at[k]]];
    Eigen::Vector3d at = vertex;
    if (const auto& pin = pins[line.key_at[k]]) {
      at = pin->position;
    } else {
      double best = HUGE_VAL;
      for (const SurfacePoint& p : result.refined)
        if (const double d = (p.position - vertex).squaredNorm(); d < best) best = d, at = p.position;
    }
    result.key_points.push_back(at);
    result.key_moves.push_back((at - vertex).norm());
  }
}

// The pins shared with crease pieces: the crease run is kept exactly (or re-fitted) through them.
std::vector<std::size_t> crease_pins_of(const std::vector<Piece>& pieces, bool closed, std::size_t line_size) {
  std::vector<std::size_t> pins;
  for (const Piece& piece : pieces)
    if (piece.exact || piece.noisy_crease) pins.insert(pins.end(), {piece.begin, piece.end});
  if (closed)  // the first vertex is also the last
    for (const std::size_t index : std::vector<std::size_t>(pins))
      if (index == 0 || index + 1 == line_size) pins.insert(pins.end(), {0, line_size - 1});
  return pins;
}

// Where the pieces meet, as they are finished in line order.
struct PieceJoin {
  Pins pins;
  std::vector<std::size_t> crease_pins;
  std::vector<char> exact;  ///< per refined point: on an exact crease run (the fitted curve keeps those)
  std::vector<char> noisy_crease;  ///< per refined point: on a noisy mesh's crease run (the fitted curve averages those)
  std::vector<char> pullable;      ///< per refined point: inside a noisy crease run, not its ends (CreaseFitOptions::curve_pull)
};

// One pinned piece's parts finished in line order and appended to the refined line.
void finish_pieces(const LineRun& run, SnakedPieces& group, PieceJoin& join, FeatureLineResult& result) {
  result.timings.strip_ms += group.strip_ms;
  result.timings.flatten_ms += group.flatten_ms;
  result.timings.snake_ms += group.snake_ms;
  result.splits += group.splits;
  for (SnakedPiece& part : group.parts) {
    throw_if_cancelled(run.cancel);
    PieceWork work = start_piece(run, part.piece);
    read_pins(join.pins, join.crease_pins, work);
    finish_piece(run, part, work, result);
    write_pins(join.pins, work);
    ++result.pieces;
    result.piece_reports.push_back(std::move(work.report));
    // Pieces meet at pinned vertices: keep the shared point once.
    std::vector<SurfacePoint>& refined = result.refined;
    const std::size_t first = refined.empty() ? 0 : 1;
    refined.insert(refined.end(), work.points.begin() + std::ptrdiff_t(first), work.points.end());
    join.exact.resize(refined.size(), work.piece.exact);
    join.noisy_crease.resize(refined.size(), work.piece.noisy_crease);
    join.pullable.resize(refined.size(), work.piece.noisy_crease);
    join.pullable.back() = 0;                 // the piece's end: a pin the next piece starts from
    if (first == 0) join.pullable.front() = 0;  // the line's first point: a pin as well
  }
}

}  // namespace

FeatureLineResult detect_feature_line(const PreparedMesh& pm, const FeatureLineRequest& request) {
  const auto start = Clock::now();
  const FeatureLineOptions& options = request.options;
  check_min_piece_edges(options);
  if (options.fitted.enabled) check_fitted_curve_options(options.fitted);
  FeatureLineResult result;
  result.keys = request.keys;
  result.closed = request.closed;

  if (request.trace)
    trace_initial_line(pm, request, result);
  else
    result.initial = find_initial_line(pm, request.keys, request.closed, options.initial, request.cancel);
  result.warnings = result.initial.warnings;
  for (auto v : result.initial.vertices) result.initial_points.push_back(pm.positions()[v]);
  result.timings.initial_ms = ms_since(start);

  const bool closed = result.closed;
  const UnrolledLine line = unroll(result.initial, closed);
  if (!options.refine || line.vertices.size() < 3) {
    result.refined = vertex_points(pm, result.initial.vertices);
    result.refined_length = polyline_length(result.refined, closed);
    report_key_points(pm, line, Pins(line.vertices.size(), closed), result);
    result.timings.total_ms = ms_since(start);
    if (options.fitted.enabled) result.fitted = fit_curve(pm, options, line_context(pm, request, result).feature_sign, {}, {}, result);
    return result;
  }

  std::vector<Piece> pieces = pinned_pieces(line, options.pin_interior_keys, closed, result.warnings);
  const LineContext context = line_context(pm, request, result);
  mark_crease_pieces(pm, options, line.vertices, context, pieces);
  PieceJoin join{Pins(line.vertices.size(), closed), crease_pins_of(pieces, closed, line.vertices.size()), {}, {}, {}};
  const std::vector<CreaseRun> crease_runs = fit_crease_runs(pm, options, closed, line.vertices, pieces);
  const LineRun run{pm, options, context, request.cancel, line.vertices, crease_runs};
  // As many pieces at a time as the executor has participants: their strips and snakes are held
  // until their turn, so a line of many keys holds no more than that many at once.
  Executor& executor = executor_or_default(request.executor);
  const std::size_t window = std::max<std::size_t>(1, executor.workers());
  for (std::size_t first = 0; first < pieces.size(); first += window) {
    throw_if_cancelled(request.cancel);
    const std::size_t last = std::min(pieces.size(), first + window);
    std::vector<SnakedPieces> snaked(last - first);
    snake_side_by_side(run, executor, pieces, first, last, snaked.data());
    for (SnakedPieces& group : snaked) finish_pieces(run, group, join, result);
  }
  std::vector<SurfacePoint>& refined = result.refined;
  if (closed && refined.size() > 1) refined.pop_back();  // back at the first key
  join.exact.resize(refined.size()), join.noisy_crease.resize(refined.size()), join.pullable.resize(refined.size());
  report_key_points(pm, line, join.pins, result);
  result.refined_length = polyline_length(refined, closed);
  result.timings.total_ms = ms_since(start);
  // Pulled, the curve was part of the refined line's work.
  if (fit_curve_and_pull_creases(pm, options, context.feature_sign, std::move(join.exact), std::move(join.noisy_crease),
                                 join.pullable, result))
    result.timings.total_ms = ms_since(start);
  return result;
}

}  // namespace featureline
