// Accuracy of the initial and the refined line against known answers, clean and noisy (the
// refined line must never be worse than the initial one on noisy scans and CAD creases).
//
// Cases:
//   ridge / valley n=N   make_ridge_field(n, jitter 0.2, seed, +-0.3, width 0.25, bend 0.3); one
//                        line through the crest's nearest vertices at x = -0.8, 0, 0.8 (picked on
//                        the clean mesh; the noisy mesh keeps the ids); truth: xy distance to the
//                        field's feature crest (ridge_field_feature_crest: the curvature's peak
//                        across the curve y = crest(x), up to 0.06 grid spacings beside it in bends
//                        at n = 351); unit: the grid spacing 2/(n-1).
//   arc|sine ridge|valley n=N
//                        make_curved_crest_field: a Gaussian profile (amplitude +-0.3, width 0.25)
//                        across an arc (radius of curvature 3 widths) or a sine (2.7 widths at its
//                        bends), measured along the curve's normal, so the truth is the curve
//                        exactly; keys nearest the crest at both ends of the span and half way;
//                        unit: the grid spacing. Also the refined line's
//                        mean offset into the bends (inward, > 0 inside).
//   slab skinny|fine, corner / loop
//                        make_rounded_slab: per corner an open line along the top outline over
//                        about a quarter of the loop (keys: both ends and the corner's middle),
//                        and a closed line round the whole top outline (4 keys); truth: the clean
//                        top outline, closed; unit: its mean edge length.
//   fandisk.off, ...     every chain of >= 10 edges that find_crease_chains(30 degrees) finds on
//                        the clean mesh: keys its first, middle and last vertex (closed chains: 3
//                        keys spread round, a closed line); truth: the clean chain; unit: the
//                        mean length of its edges.
// Noise: with_noise, the RMS displacement given in % of the case's unit (grid spacing; slab
// outline edge, because the skinny slab's mean edge is dominated by its long cap diagonals), and
// for the real CAD meshes in % of the mesh's mean edge length (one noisy mesh serves all chains).
//
// Distances are in units of the case's unit. A line's mean distance is its arc-length mean
// (Simpson's rule on each segment: ends and midpoint), its max the largest of those samples.
// Columns: mean/max of the initial and the refined line (mean over lines of a line's mean; max
// over lines of a line's max); ratio = refined mean / initial mean of the row; worse = lines whose
// refined mean exceeds the initial mean by more than 0.001 units; turn = total turning of the
// refined line (rad, mean over lines); fallbk = marching fallbacks (segments, summed); iters =
// snake iterations per line (mean); ms = detect_feature_line's total per line (median); err =
// lines that threw. The fitted curve's table adds, for CAD chains, how far the truth itself
// zigzags about a smooth curve (truth_zigzag; a scanned part's chain does, and no smooth curve
// can follow it), and sums the noisy CAD lines twice: all, and those on smooth creases; the lines
// whose truth zigzags are measured against that truth smoothed along itself too (smoothed_chain).
//
// usage: bench_accuracy [--seeds N] [--quick] [--variant NAME] [--worst K] [--sizes N,..] [--no-cad]
//   --sizes N,..    only these field sizes (n x n grids)
//   --no-cad        smooth fields only
//   --cad-only      CAD cases only
//   --no-curved     no arc and sine crests
//   --curved-only   arc and sine crests only
//   --trace         per line on stderr: its keys and distances, each piece's outcome, points along
//                   the line and along its fitted curve
//   --seeds N       seeds for jitter and noise (default 3)
//   --quick         fields n = 51 and 111 only, one seed, fandisk.off only (a few seconds)
//   --variant NAME  run one variant of the table below
//   --worst K       list the K lines where refining made the line worst (default 12)
// The default variant (fields n = 51, 111, 201, 351, i.e. 5k to 245k triangles, straight and
// curved crests, 3 seeds everywhere) takes about two minutes on the 2-core development machine.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Dense>

#include "engine/feature_line.h"
#include "engine/mesh_io.h"
#include "engine/prepared_mesh.h"
#include "tests/support/accuracy_meshes.h"
#include "tests/support/curved_crests.h"
#include "tests/support/line_metrics.h"
#include "tests/support/synthetic_meshes.h"

namespace {

using namespace featureline;
using namespace featureline::testing;

// ---------------------------------------------------------------------------------
// Variants: one line each.
// ---------------------------------------------------------------------------------

struct Variant {
  std::string name;
  PrepareOptions prepare;
  FeatureLineOptions line;
};

Variant variant(std::string name, const std::function<void(PrepareOptions&, FeatureLineOptions&)>& edit) {
  Variant v{std::move(name), {}, {}};
  edit(v.prepare, v.line);
  return v;
}

std::vector<Variant> all_variants() {
  return {
      variant("default (jet, auto radius)", [](PrepareOptions&, FeatureLineOptions&) {}),
      variant("cotangent (paper)", [](PrepareOptions& p, FeatureLineOptions&) {
        p.curvature.method = CurvatureMethod::cotangent;
        p.curvature.smoothing_passes = 0;
      }),
      variant("cotangent, smoothing 3", [](PrepareOptions& p, FeatureLineOptions&) {
        p.curvature.method = CurvatureMethod::cotangent;
        p.curvature.smoothing_passes = 3;
      }),
      variant("marching", [](PrepareOptions&, FeatureLineOptions& o) { o.initial.method = InitialMethod::marching; }),
      variant("jet, no smoothing", [](PrepareOptions& p, FeatureLineOptions&) { p.curvature.smoothing_passes = 0; }),
      variant("quadric jets everywhere (jet_degree quadric)",
              [](PrepareOptions& p, FeatureLineOptions&) { p.curvature.jet_degree = JetDegree::quadric; }),
      variant("paper's strip layout", [](PrepareOptions&, FeatureLineOptions& o) {
        o.strip.flattening = StripFlattening::similar_triangles;
      }),
      variant("jet, fixed radius 6", [](PrepareOptions& p, FeatureLineOptions&) { p.curvature.radius = 6; }),
      variant("jet, fixed radius 3", [](PrepareOptions& p, FeatureLineOptions&) { p.curvature.radius = 3; }),
      variant("no crest localisation (the snake's line)", [](PrepareOptions&, FeatureLineOptions& o) { o.crest.enabled = false; }),
      variant("keys on their vertices (crest.move_keys off)", [](PrepareOptions&, FeatureLineOptions& o) { o.crest.move_keys = false; }),
      variant("keys within half an edge (crest.max_key_shift 0.5)",
              [](PrepareOptions&, FeatureLineOptions& o) { o.crest.max_key_shift = 0.5; }),
      variant("tangent-frame crest fits (crest.follow_bend off)", [](PrepareOptions&, FeatureLineOptions& o) { o.crest.follow_bend = false; }),
      variant("the field's blur left in bends (crest.unblur off)", [](PrepareOptions&, FeatureLineOptions& o) { o.crest.unblur = false; }),
      variant("one strip per piece (second_strip off)", [](PrepareOptions&, FeatureLineOptions& o) { o.second_strip = false; }),
      variant("before bent fits, moving keys and second strips", [](PrepareOptions&, FeatureLineOptions& o) {
        o.crest.move_keys = false;
        o.crest.follow_bend = false;
        o.second_strip = false;
      }),
      variant("fitted curve: the spline alone (fitted.run_averaging 0)",
              [](PrepareOptions&, FeatureLineOptions& o) { o.fitted.run_averaging = 0; }),
      variant("noisy crease runs pulled toward the fitted curve (crease_fit.curve_pull 0.5)",
              [](PrepareOptions&, FeatureLineOptions& o) { o.crease_fit.curve_pull = 0.5; }),
  };
}

// Meshes are prepared once per distinct PrepareOptions: list every field here.
std::string prepare_key(const PrepareOptions& p) {
  const auto& c = p.curvature;
  return to_string(c.method) + " r=" + std::to_string(c.radius) + " s=" + std::to_string(c.smoothing_passes) +
         " a=" + std::to_string(c.crease_angle) + " d=" + to_string(c.jet_degree) +
         " t=" + std::to_string(c.smoothing_tolerance);
}

// ---------------------------------------------------------------------------------
// Cases
// ---------------------------------------------------------------------------------

struct LineSpec {
  std::vector<std::uint32_t> keys;
  bool closed = false;
  std::function<double(const Eigen::Vector3d&)> distance;  ///< to the truth, in units
  /// Curved crests: signed offset from the truth towards its bend's centre of curvature, in units.
  std::function<double(const Eigen::Vector3d&)> inward;
  /// CAD chains: the truth's vertex ids and positions (on the clean mesh), and the unit. The
  /// noisy mesh keeps the ids, so the truth's distance to the noisy surface (the best any line on
  /// that surface can do) is measured near each of them.
  std::vector<std::uint32_t> truth_vertices;
  std::vector<Eigen::Vector3d> truth_points;
  double unit = 1;
  /// CAD chains: how far the truth itself zigzags (truth_zigzag), in units; -1 otherwise.
  double zigzag = -1;
  /// CAD chains: distance to the truth smoothed along itself (smoothed_chain), in units.
  std::function<double(const Eigen::Vector3d&)> smoothed_distance;
};

/// The quadratic (against arc length, least squares) through the vertices of `chain` up to
/// `reach` on either side of vertex i (fewer near an open chain's ends), and vertex i itself when
/// `with_self`, evaluated at vertex i; nothing when it is undetermined.
std::optional<Eigen::Vector3d> chain_quadratic_at(const std::vector<Eigen::Vector3d>& chain, bool closed, std::size_t i,
                                                  int reach, bool with_self) {
  const std::ptrdiff_t n = std::ptrdiff_t(chain.size());
  Eigen::Matrix3d normal = Eigen::Matrix3d::Zero(), rhs = Eigen::Matrix3d::Zero();
  auto add = [&](double t, const Eigen::Vector3d& x) {
    const Eigen::Vector3d basis(1, t, t * t);
    normal += basis * basis.transpose();
    rhs += basis * x.transpose();
  };
  if (with_self) add(0, chain[i]);
  for (const int direction : {-1, 1}) {
    double t = 0;
    for (std::ptrdiff_t step = 1; step <= reach; ++step) {
      const std::ptrdiff_t j = std::ptrdiff_t(i) + direction * step, previous = j - direction;
      if (!closed && (j < 0 || j >= n)) break;
      const auto& b = chain[std::size_t((j + n) % n)];
      t += direction * (b - chain[std::size_t((previous + n) % n)]).norm();
      add(t, b);
    }
  }
  const Eigen::FullPivLU<Eigen::Matrix3d> solver(normal);
  if (solver.rank() < 3) return std::nullopt;
  return Eigen::Vector3d(solver.solve(rhs).row(0).transpose());
}

/// Mean distance (in units) of each truth vertex from the quadratic through the two vertices on
/// either side of it (least squares against arc length, the vertex itself left out): near 0 on a
/// crease that is a smooth curve, however it bends; a scanned part's crease chain that zigzags
/// about its curve reads that zigzag, which no smooth curve can follow.
double truth_zigzag(const std::vector<Eigen::Vector3d>& chain, bool closed, double unit) {
  const std::size_t n = chain.size();
  if (n < 5) return 0;
  double sum = 0;
  std::size_t count = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!closed && (i < 2 || i + 2 >= n)) continue;
    if (const auto at_i = chain_quadratic_at(chain, closed, i, 2, false)) {
      sum += (*at_i - chain[i]).norm() / unit;
      ++count;
    }
  }
  return count > 0 ? sum / double(count) : 0;
}

/// The chain smoothed along itself: each vertex replaced by the quadratic through it and up to
/// three vertices on either side (chain_quadratic_at), evaluated there (a Savitzky-Golay filter: a
/// zigzag that alternates from vertex to vertex keeps 24% of its amplitude, a smooth curve's bends
/// are kept). What a scanned part's zigzagging crease chain says of the smooth crease it samples.
std::vector<Eigen::Vector3d> smoothed_chain(const std::vector<Eigen::Vector3d>& chain, bool closed) {
  std::vector<Eigen::Vector3d> out = chain;
  if (chain.size() < 5) return out;
  for (std::size_t i = 0; i < chain.size(); ++i)
    if (const auto at_i = chain_quadratic_at(chain, closed, i, 3, true)) out[i] = *at_i;
  return out;
}

/// Mean distance from the truth chain's vertices to the nearest point of the (noisy) surface
/// around the same vertex: a floor under the mean distance of any line lying on that surface.
double surface_floor(const PreparedMesh& mesh, const LineSpec& spec) {
  if (spec.truth_vertices.empty()) return -1;
  double sum = 0;
  for (std::size_t i = 0; i < spec.truth_vertices.size(); ++i)
    sum += (nearest_surface_point_near(mesh, spec.truth_vertices[i], spec.truth_points[i]).position - spec.truth_points[i]).norm();
  return sum / double(spec.truth_vertices.size()) / spec.unit;
}

/// One clean mesh with its lines (a case at one seed).
struct Scenario {
  RawMesh mesh;
  double noise_reference = 1;  ///< the length the noise % refers to
  std::vector<LineSpec> lines;
};

struct Case {
  std::string name;
  std::string group;         ///< "smooth" or "cad"
  bool seeded_mesh = false;  ///< the clean mesh depends on the seed (otherwise one clean run)
  std::vector<double> noise_levels;
  std::function<Scenario(std::uint64_t seed)> build;
};

Case ridge_case(bool ridge, int n, const std::vector<double>& noise) {
  Case c;
  c.name = std::string(ridge ? "ridge" : "valley") + " n=" + std::to_string(n);
  c.group = "smooth";
  c.seeded_mesh = true;
  c.noise_levels = noise;
  c.build = [ridge, n](std::uint64_t seed) {
    auto field = std::make_shared<HeightField>(make_ridge_field(n, 0.2, seed, ridge ? 0.3 : -0.3, 0.25, 0.3));
    Scenario s;
    s.mesh = field->mesh;
    s.noise_reference = field->spacing;
    LineSpec line;
    for (double x : {-0.8, 0.0, 0.8}) line.keys.push_back(nearest_vertex(field->mesh, x, field->crest(x)));
    // The field's feature crest, not the curve y = crest(x): its profile is vertical, so in bends
    // the curvature peaks up to 0.06 grid spacings (n = 351) beside the curve.
    auto truth = std::make_shared<std::vector<Eigen::Vector3d>>(ridge_field_feature_crest(*field, -1, 1, 0.001));
    const double unit = field->spacing;
    line.distance = [truth, unit](const Eigen::Vector3d& p) {
      return distance_to_polyline(*truth, false, Eigen::Vector3d(p.x(), p.y(), 0)) / unit;
    };
    s.lines.push_back(std::move(line));
    return s;
  };
  return c;
}

// A Gaussian ridge or valley across an arc or a sine (tests/support/curved_crests.h: the profile
// follows the curve's normal, so the truth is the curve exactly, bends included); one line
// through the crest's nearest vertices at both ends of the keys' span and half way along it.
Case curved_case(CrestCurve curve, bool ridge, int n, const std::vector<double>& noise) {
  Case c;
  c.name = std::string(to_string(curve)) + (ridge ? " ridge" : " valley") + " n=" + std::to_string(n);
  c.group = "curved";
  c.seeded_mesh = true;
  c.noise_levels = noise;
  c.build = [curve, ridge, n](std::uint64_t seed) {
    CurvedCrestOptions options;
    options.curve = curve;
    options.n = n;
    options.seed = seed;
    options.amplitude = ridge ? 0.3 : -0.3;
    auto field = std::make_shared<CurvedCrestField>(make_curved_crest_field(options));
    Scenario s;
    s.mesh = field->field.mesh;
    const double unit = field->field.spacing;
    s.noise_reference = unit;
    LineSpec line;
    line.keys = keys_on_curved_crest(*field, {0.0, 0.5, 1.0});
    line.distance = [field, unit](const Eigen::Vector3d& p) { return field->distance(p.x(), p.y()) / unit; };
    line.inward = [field, unit](const Eigen::Vector3d& p) { return field->inward_offset(p.x(), p.y()) / unit; };
    s.lines.push_back(std::move(line));
    return s;
  };
  return c;
}

// CAD parts are measured clean, at the noise the targets name (10% of an edge), and lightly
// noisy: from 1% on the noise unmarks some crease edges while the mesh still reads clean.
constexpr double kCadTargetNoise = 10;
const std::vector<double> kCadNoiseLevels = {0, 2, 5, kCadTargetNoise};

LineSpec chain_line(const RawMesh& mesh, const std::vector<std::uint32_t>& chain, bool closed,
                    std::vector<std::uint32_t> keys, bool line_closed) {
  auto truth = std::make_shared<std::vector<Eigen::Vector3d>>(positions_of(mesh, chain));
  double length = 0;
  const std::size_t edges = closed ? truth->size() : truth->size() - 1;
  for (std::size_t i = 0; i < edges; ++i) length += ((*truth)[(i + 1) % truth->size()] - (*truth)[i]).norm();
  const double unit = length / double(edges);
  LineSpec line;
  line.keys = std::move(keys);
  line.closed = line_closed;
  line.distance = [truth, closed, unit](const Eigen::Vector3d& p) { return distance_to_polyline(*truth, closed, p) / unit; };
  line.truth_vertices = chain;
  line.truth_points = *truth;
  line.unit = unit;
  line.zigzag = truth_zigzag(*truth, closed, unit);
  auto smoothed = std::make_shared<std::vector<Eigen::Vector3d>>(smoothed_chain(*truth, closed));
  line.smoothed_distance = [smoothed, closed, unit](const Eigen::Vector3d& p) {
    return distance_to_polyline(*smoothed, closed, p) / unit;
  };
  return line;
}

Case slab_case(SlabTessellation tessellation, bool loop) {
  Case c;
  c.name = std::string("slab ") + (tessellation == SlabTessellation::skinny ? "skinny" : "fine") + (loop ? ", loop" : ", corner");
  c.group = "cad";
  c.noise_levels = kCadNoiseLevels;
  c.build = [tessellation, loop](std::uint64_t) {
    RoundedSlabOptions options;
    options.tessellation = tessellation;
    const CadPart part = make_rounded_slab(options);
    const auto& top = part.top_outline;
    const std::size_t n = top.size();
    Scenario s;
    s.mesh = part.mesh;
    if (loop) {
      s.lines.push_back(chain_line(part.mesh, top, true, {top[0], top[n / 4], top[n / 2], top[3 * n / 4]}, true));
    } else {
      const double a = options.half_x, b = options.half_y, r = options.corner_radius;
      for (double sx : {1.0, -1.0})
        for (double sy : {1.0, -1.0}) {
          // The outline vertex nearest the middle of this corner's arc.
          const Eigen::Vector3d mid(sx * (a - r + r * std::sqrt(0.5)), sy * (b - r + r * std::sqrt(0.5)), options.height);
          std::size_t corner = 0;
          double best = 1e300;
          for (std::size_t i = 0; i < n; ++i) {
            const auto& p = part.mesh.positions[top[i]];
            const double d = (Eigen::Vector3d(p[0], p[1], p[2]) - mid).norm();
            if (d < best) best = d, corner = i;
          }
          const std::size_t half = n / 8;
          s.lines.push_back(chain_line(part.mesh, top, true, {top[(corner + n - half) % n], top[corner], top[(corner + half) % n]}, false));
        }
    }
    const auto outline = positions_of(part.mesh, top);
    double length = 0;
    for (std::size_t i = 0; i < n; ++i) length += (outline[(i + 1) % n] - outline[i]).norm();
    s.noise_reference = length / double(n);  // the outline's mean edge
    return s;
  };
  return c;
}

std::string shared_mesh(const std::string& name) { return std::string(FEATURELINE_SHARED_DIR) + "/data/meshes/" + name; }

Case cad_case(const std::string& file) {
  Case c;
  c.name = file;
  c.group = "cad";
  c.noise_levels = kCadNoiseLevels;
  auto cache = std::make_shared<std::unique_ptr<Scenario>>();
  c.build = [file, cache](std::uint64_t) {
    if (!*cache) {
      auto s = std::make_unique<Scenario>();
      s->mesh = read_mesh_file(shared_mesh(file));
      s->noise_reference = mean_edge_length(s->mesh);
      for (const auto& chain : find_crease_chains(s->mesh, 30, 10)) {
        const auto& v = chain.vertices;
        const std::size_t n = v.size();
        if (chain.closed)
          s->lines.push_back(chain_line(s->mesh, v, true, {v[0], v[n / 3], v[2 * n / 3]}, true));
        else
          s->lines.push_back(chain_line(s->mesh, v, false, {v.front(), v[n / 2], v.back()}, false));
      }
      *cache = std::move(s);
    }
    return **cache;
  };
  return c;
}

// ---------------------------------------------------------------------------------
// Measures
// ---------------------------------------------------------------------------------

double closed_turning(std::vector<Eigen::Vector3d> points, bool closed) {
  if (closed && points.size() >= 3) {
    points.push_back(points[0]);
    points.push_back(points[1]);
  }
  return total_turning(points);
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

constexpr double kWorseTolerance = 1e-3;

// The fitted space curve (engine/fitted_curve.h) beside the surface line: its distance to the
// same truth, and where its points came from.
struct FittedOutcome {
  bool present = false;
  LineDistance distance;
  double crease_share = 0, fallback_share = 0, averaged_share = 0, ms = 0;
};

FittedOutcome measure_fitted(const FeatureLineResult& r, const std::function<double(const Eigen::Vector3d&)>& distance) {
  FittedOutcome out;
  if (!r.fitted || r.fitted->points.empty()) return out;
  out.present = true;
  out.distance = arc_length_distance(r.fitted->points, r.fitted->closed, distance);
  out.crease_share = r.fitted->crease_share;
  out.fallback_share = r.fitted->fallback_share;
  out.averaged_share = r.fitted->averaged_share;
  out.ms = r.fitted->elapsed_ms;
  return out;
}

struct LineOutcome {
  std::uint64_t seed = 0;
  std::vector<std::uint32_t> keys;
  bool failed = false;
  std::string error;
  LineDistance initial, refined;
  double turning = 0, ms = 0;
  int iterations = 0;
  std::size_t fallbacks = 0;
  double floor = -1;  ///< surface_floor (CAD chains), -1 otherwise
  double zigzag = -1; ///< LineSpec::zigzag
  FittedOutcome fitted;
  /// CAD chains: the initial, refined and fitted lines' mean distances to the smoothed truth
  /// (LineSpec::smoothed_distance); -1 otherwise.
  double initial_smoothed = -1, refined_smoothed = -1, fitted_smoothed = -1;
  double inward = std::nan("");  ///< curved crests: the refined line's arc-length mean offset into the bend
  bool worse() const { return !failed && refined.mean > initial.mean + kWorseTolerance; }
};

struct Row {
  std::size_t triangles = 0;
  std::vector<LineOutcome> lines;
};

struct RowKey {
  std::size_t case_index, noise_index, variant_index;
  bool operator<(const RowKey& o) const {
    return std::tie(case_index, noise_index, variant_index) < std::tie(o.case_index, o.noise_index, o.variant_index);
  }
};

struct RowSummary {
  std::size_t lines = 0, ok = 0, worse = 0, failed = 0, fallbacks = 0;
  double initial_mean = 0, initial_max = 0, refined_mean = 0, refined_max = 0, turning = 0, iterations = 0, ms = 0;
  double floor = 0;  ///< mean surface floor over the lines that have one; -1 when none has
};

RowSummary summarize(const Row& row) {
  RowSummary s;
  std::vector<double> ms;
  for (const auto& l : row.lines) {
    ++s.lines;
    if (l.failed) {
      ++s.failed;
      continue;
    }
    ++s.ok;
    s.initial_mean += l.initial.mean;
    s.refined_mean += l.refined.mean;
    s.initial_max = std::max(s.initial_max, l.initial.max);
    s.refined_max = std::max(s.refined_max, l.refined.max);
    s.turning += l.turning;
    s.iterations += l.iterations;
    s.fallbacks += l.fallbacks;
    s.worse += l.worse();
    s.floor += l.floor;
    ms.push_back(l.ms);
  }
  if (s.ok) {
    s.floor = row.lines.front().floor < 0 ? -1 : s.floor / double(s.ok);
    s.initial_mean /= double(s.ok);
    s.refined_mean /= double(s.ok);
    s.turning /= double(s.ok);
    s.iterations /= double(s.ok);
  }
  s.ms = median(ms);
  return s;
}

std::string ratio_text(double refined, double initial) {
  char buffer[32];
  // A line exactly on the truth (clean creases) has mean 0 up to rounding: no ratio then.
  if (initial > kWorseTolerance) std::snprintf(buffer, sizeof buffer, "%.2f", refined / initial);
  else std::snprintf(buffer, sizeof buffer, refined > kWorseTolerance ? "inf" : "-");
  return buffer;
}

using Clock = std::chrono::steady_clock;

}  // namespace

// --trace: what happened to one line, for finding out why it is off.
void trace_line(const std::string& name, double noise, int seed, double estimated_noise, const FeatureLineResult& r,
                const std::vector<Eigen::Vector3d>& refined, const LineSpec& spec, double floor) {
  std::string keys;
  for (const auto k : spec.keys) keys += (keys.empty() ? "" : ",") + std::to_string(k);
  std::fprintf(stderr, "%s, noise %g%% (estimated %.3f), seed %d, keys %s: initial %.3f, refined %.3f, floor %.3f\n",
               name.c_str(), noise, estimated_noise, seed, keys.c_str(),
               arc_length_distance(r.initial_points, r.closed, spec.distance).mean,
               arc_length_distance(refined, r.closed, spec.distance).mean, floor);
  for (const auto& w : r.warnings) std::fprintf(stderr, "  warning: %s\n", w.c_str());
  for (const auto& p : r.piece_reports)
    std::fprintf(stderr, "  piece %u..%u (%zu edges): %s%s%s, %d iterations%s\n", p.from, p.to, p.edges, to_string(p.kept).c_str(),
                 p.reason.empty() ? "" : ": ", p.reason.c_str(), p.iterations, p.iteration_cap ? " (cap)" : "");
  const std::size_t step = std::max<std::size_t>(1, refined.size() / 40);
  for (std::size_t i = 0; i < refined.size(); i += step)
    std::fprintf(stderr, "  (%.3f, %.3f, %.3f) distance %.3f\n", refined[i].x(), refined[i].y(), refined[i].z(), spec.distance(refined[i]));
  if (!r.fitted || r.fitted->points.empty()) return;
  const auto& fitted = r.fitted->points;
  std::fprintf(stderr, "  fitted curve %.3f (crease share %.2f, fallback share %.2f, %zu corners)\n",
               arc_length_distance(fitted, r.fitted->closed, spec.distance).mean, r.fitted->crease_share,
               r.fitted->fallback_share, r.fitted->corners);
  const std::size_t fitted_step = std::max<std::size_t>(1, fitted.size() / 40);
  for (std::size_t i = 0; i < fitted.size(); i += fitted_step)
    std::fprintf(stderr, "  fitted (%.3f, %.3f, %.3f) distance %.3f\n", fitted[i].x(), fitted[i].y(), fitted[i].z(),
                 spec.distance(fitted[i]));
}

// "51,351" -> {51, 351}; grid sizes n (an n x n field has about 2 n^2 triangles).
std::vector<int> parse_sizes(const std::string& text) {
  std::vector<int> sizes;
  std::size_t start = 0;
  while (start < text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    const int n = std::atoi(text.substr(start, comma - start).c_str());
    if (n >= 11 && n <= 1001) sizes.push_back(n);
    start = comma + 1;
  }
  return sizes;
}

namespace {

struct BenchArgs {
  int seeds = 3, worst_count = 12;
  bool quick = false, no_cad = false, cad_only = false, trace = false;
  bool no_curved = false, curved_only = false;
  std::vector<int> only_sizes;
  std::string only;  ///< --variant: run this variant only
};

// The command line; std::nullopt (after printing the usage) when it is not understood.
std::optional<BenchArgs> parse_args(int argc, char** argv) {
  BenchArgs a;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--seeds" && i + 1 < argc) a.seeds = std::max(1, std::atoi(argv[++i]));
    else if (arg == "--quick") a.quick = true;
    else if (arg == "--sizes" && i + 1 < argc) a.only_sizes = parse_sizes(argv[++i]);
    else if (arg == "--no-cad") a.no_cad = true;
    else if (arg == "--cad-only") a.cad_only = true;
    else if (arg == "--no-curved") a.no_curved = true;
    else if (arg == "--curved-only") a.curved_only = true, a.no_cad = true;
    else if (arg == "--trace") a.trace = true;
    else if (arg == "--variant" && i + 1 < argc) a.only = argv[++i];
    else if (arg == "--worst" && i + 1 < argc) a.worst_count = std::max(0, std::atoi(argv[++i]));
    else {
      std::fprintf(stderr, "usage: bench_accuracy [--seeds N] [--quick] [--variant NAME] [--worst K] [--sizes 51,351] [--no-cad | --cad-only]\n"
                           "                      [--no-curved | --curved-only] [--trace]\n"
                           "  --quick    n=51 and 111 fields, one seed, fandisk only\n");
      return std::nullopt;
    }
  }
  if (a.quick) a.seeds = 1;
  return a;
}

// The variants to run (all, or the one named); empty (after listing them) for an unknown name.
std::vector<Variant> selected_variants(const std::string& only) {
  std::vector<Variant> variants;
  for (auto& v : all_variants())
    if (only.empty() || v.name == only) variants.push_back(std::move(v));
  if (variants.empty()) {
    std::fprintf(stderr, "unknown variant '%s'; variants:\n", only.c_str());
    for (const auto& v : all_variants()) std::fprintf(stderr, "  %s\n", v.name.c_str());
  }
  return variants;
}

// About 5k, 24k, 80k and 245k triangles.
std::vector<int> field_sizes(const BenchArgs& a) {
  return !a.only_sizes.empty() ? a.only_sizes : a.quick ? std::vector<int>{51, 111} : std::vector<int>{51, 111, 201, 351};
}

// Arc and sine crests of about 5k, 24k and 245k triangles (--sizes: those), ridges and valleys;
// every size with --seeds seeds (the targets are judged on those; the 245k fields are half the
// default variant's run).
void add_curved_cases(const BenchArgs& a, std::vector<Case>& cases) {
  const std::vector<int> sizes = !a.only_sizes.empty() ? a.only_sizes : a.quick ? std::vector<int>{51, 111} : std::vector<int>{51, 111, 201, 351};
  for (CrestCurve curve : {CrestCurve::arc, CrestCurve::sine})
    for (bool ridge : {true, false})
      for (int n : sizes) cases.push_back(curved_case(curve, ridge, n, {0, 2, 5, 10, 20, 30}));
}

// Ridge and valley fields, slabs, real CAD meshes; false (after saying which) when a mesh is missing.
bool build_cases(const BenchArgs& a, const std::vector<int>& sizes, std::vector<Case>& cases) {
  for (bool ridge : {true, false})
    for (int n : sizes)
      if (!a.cad_only && !a.curved_only) cases.push_back(ridge_case(ridge, n, {0, 2, 5, 10, 20, 30}));
  if (!a.cad_only && !a.no_curved) add_curved_cases(a, cases);
  for (auto t : {SlabTessellation::skinny, SlabTessellation::fine})
    for (bool loop : {false, true})
      if (!a.no_cad) cases.push_back(slab_case(t, loop));
  const std::vector<std::string> cad_files =
      a.no_cad  ? std::vector<std::string>{}
      : a.quick ? std::vector<std::string>{"fandisk.off"}
                : std::vector<std::string>{"fandisk.off", "fandisk_aimatshape.off", "rocker-arm.obj", "wingnut.obj"};
  for (const auto& file : cad_files) {
    const std::string path = shared_mesh(file);
    if (!std::ifstream(path)) {
      std::fprintf(stderr, "missing test mesh %s (expected beside the repository in ../shared/data/meshes)\n", path.c_str());
      return false;
    }
    cases.push_back(cad_case(file));
  }
  return true;
}

// Where one scenario's line is run: its case, noise and seed.
struct LineRunContext {
  const Case& c;
  double noise;
  int seed;
  bool trace;
};

LineOutcome run_line(const PreparedMesh& mesh, const LineSpec& spec, const Variant& v, const LineRunContext& at) {
  LineOutcome out;
  out.seed = std::uint64_t(at.seed);
  out.keys = spec.keys;
  FeatureLineRequest request;
  request.keys = spec.keys;
  request.closed = spec.closed;
  request.options = v.line;
  request.options.fitted.enabled = true;  // measured beside the surface line; it changes nothing else
  try {
    const auto r = detect_feature_line(mesh, request);
    const auto refined = refined_positions(r);
    out.initial = arc_length_distance(r.initial_points, r.closed, spec.distance);
    out.refined = arc_length_distance(refined, r.closed, spec.distance);
    out.turning = closed_turning(refined, r.closed);
    out.iterations = r.iterations;
    out.fallbacks = r.initial.fallbacks.size();
    out.ms = r.timings.total_ms;
    out.floor = surface_floor(mesh, spec);
    out.zigzag = spec.zigzag;
    out.fitted = measure_fitted(r, spec.distance);
    if (spec.smoothed_distance) {
      out.initial_smoothed = arc_length_distance(r.initial_points, r.closed, spec.smoothed_distance).mean;
      out.refined_smoothed = arc_length_distance(refined, r.closed, spec.smoothed_distance).mean;
      if (out.fitted.present)
        out.fitted_smoothed = arc_length_distance(r.fitted->points, r.fitted->closed, spec.smoothed_distance).mean;
    }
    if (spec.inward) out.inward = arc_length_distance(refined, r.closed, spec.inward).mean;
    if (at.trace) trace_line(at.c.name, at.noise, at.seed, mesh.statistics().noise, r, refined, spec, out.floor);
  } catch (const std::exception& e) {
    out.failed = true;
    out.error = e.what();
  }
  return out;
}

struct BenchResults {
  std::map<RowKey, Row> rows;
  std::map<std::string, std::size_t> chains_per_mesh;
};

// Every variant on one noisy copy of a scenario (meshes prepared once per preparation).
void run_scenario(const RawMesh& noisy, const Scenario& scenario, const std::vector<Variant>& variants,
                  const LineRunContext& at, std::size_t ci, std::size_t ni, BenchResults& results) {
  std::map<std::string, std::shared_ptr<const PreparedMesh>> prepared;
  for (std::size_t vi = 0; vi < variants.size(); ++vi) {
    const Variant& v = variants[vi];
    auto& mesh = prepared[prepare_key(v.prepare)];
    if (!mesh) mesh = prepare_mesh(noisy, v.prepare);
    Row& row = results.rows[{ci, ni, vi}];
    row.triangles = mesh->statistics().faces;
    for (const auto& spec : scenario.lines) row.lines.push_back(run_line(*mesh, spec, v, at));
  }
}

BenchResults run_cases(const std::vector<Case>& cases, const std::vector<Variant>& variants, const BenchArgs& a) {
  BenchResults results;
  for (std::size_t ci = 0; ci < cases.size(); ++ci) {
    const Case& c = cases[ci];
    for (std::size_t ni = 0; ni < c.noise_levels.size(); ++ni) {
      const double noise = c.noise_levels[ni];
      const int runs = (noise == 0 && !c.seeded_mesh) ? 1 : a.seeds;  // a clean fixed mesh needs one run
      for (int seed = 1; seed <= runs; ++seed) {
        const Scenario scenario = c.build(std::uint64_t(seed));
        if (c.group == "cad" && c.name.rfind("slab", 0) != 0) results.chains_per_mesh[c.name] = scenario.lines.size();
        const double fraction = noise / 100 * scenario.noise_reference / mean_edge_length(scenario.mesh);
        const RawMesh noisy = with_noise(scenario.mesh, fraction, 1000003ull * std::uint64_t(seed) + 7);
        run_scenario(noisy, scenario, variants, {c, noise, seed, a.trace}, ci, ni, results);
      }
    }
  }
  return results;
}

void print_header(int seeds, const std::vector<int>& sizes, const std::map<std::string, std::size_t>& chains_per_mesh) {
  std::printf("# bench_accuracy: %d seed%s, fields n = ", seeds, seeds == 1 ? "" : "s");
  for (std::size_t i = 0; i < sizes.size(); ++i) std::printf("%s%d", i ? ", " : "", sizes[i]);
  std::printf("\n\nCrease chains of >= 10 edges (find_crease_chains, 30 degrees):");
  for (const auto& [name, count] : chains_per_mesh) std::printf(" %s %zu;", name.c_str(), count);
  std::printf("\n\nDistances in units (grid spacing / truth chain's mean edge); noise: RMS displacement in %% of the\n"
              "grid spacing (fields), outline edge (slab) or mesh mean edge (real CAD); worse: refined mean >\n"
              "initial mean + %.3f; floor (CAD): mean distance from the true crease to the nearest point of the\n"
              "(noisy) surface, under which no line lying on that surface can go; noisy CAD above floor: the\n"
              "summed distance above that floor, refined over initial.\n\n", kWorseTolerance);
}

// One row per variant, case and noise level.
void print_rows(const BenchResults& results, const std::vector<Variant>& variants, const std::vector<Case>& cases) {
  std::printf("| variant | case | triangles | noise %% | lines | init mean | init max | ref mean | ref max | ref/init | floor | worse | turn | fallbk | iters | ms | err |\n");
  std::printf("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  for (const auto& [key, row] : results.rows) {
    const RowSummary s = summarize(row);
    char floor[16] = "-";
    if (s.floor >= 0) std::snprintf(floor, sizeof floor, "%.3f", s.floor);
    std::printf("| %s | %s | %zu | %.0f | %zu | %.3f | %.3f | %.3f | %.3f | %s | %s | %zu | %.2f | %zu | %.0f | %.2f | %zu |\n",
                variants[key.variant_index].name.c_str(), cases[key.case_index].name.c_str(), row.triangles,
                cases[key.case_index].noise_levels[key.noise_index], s.lines, s.initial_mean, s.initial_max,
                s.refined_mean, s.refined_max, ratio_text(s.refined_mean, s.initial_mean).c_str(), floor, s.worse, s.turning,
                s.fallbacks, s.iterations, s.ms, s.failed);
  }
}

// One variant's worst cases, smooth fields and CAD apart.
struct VariantSummary {
  double smooth_clean = -1, smooth_noisy = -1, cad_clean = -1, cad_noisy_ref = 0, cad_noisy_init = 0, cad_noisy_floor = 0;
  std::string smooth_clean_case, smooth_noisy_case, cad_clean_case;
  std::size_t smooth_worse = 0, smooth_lines = 0, cad_worse = 0, cad_lines = 0, errors = 0;
};

VariantSummary summarize_variant(const BenchResults& results, const std::vector<Case>& cases, std::size_t vi) {
  VariantSummary v;
  for (const auto& [key, row] : results.rows) {
    if (key.variant_index != vi) continue;
    const Case& c = cases[key.case_index];
    const double noise = c.noise_levels[key.noise_index];
    const RowSummary s = summarize(row);
    v.errors += s.failed;
    const std::string label = c.name + " @" + std::to_string(int(noise)) + "%";
    if (c.group == "curved") continue;  // print_curved_summary
    if (c.group == "smooth") {
      v.smooth_worse += s.worse, v.smooth_lines += s.lines;
      if (noise == 0 && s.refined_mean > v.smooth_clean) v.smooth_clean = s.refined_mean, v.smooth_clean_case = label;
      if (noise >= 10 && noise <= 20 && s.refined_mean > v.smooth_noisy) v.smooth_noisy = s.refined_mean, v.smooth_noisy_case = label;
    } else {
      v.cad_worse += s.worse, v.cad_lines += s.lines;
      if (noise == 0 && s.refined_mean > v.cad_clean) v.cad_clean = s.refined_mean, v.cad_clean_case = label;
      if (noise == kCadTargetNoise)
        for (const auto& l : row.lines)
          if (!l.failed)
            v.cad_noisy_ref += l.refined.mean, v.cad_noisy_init += l.initial.mean, v.cad_noisy_floor += std::max(0.0, l.floor);
    }
  }
  return v;
}

void print_summary(const BenchResults& results, const std::vector<Variant>& variants, const std::vector<Case>& cases) {
  std::printf("\n## Summary per variant\n\n");
  std::printf("| variant | smooth: worst clean ref mean | smooth: worst noisy (10-20%%) ref mean | smooth: worse lines |"
              " CAD: worst clean ref mean | CAD: noisy ref/init | CAD: noisy above floor, ref/init | CAD: worse lines | errors |\n");
  std::printf("|---|---|---|---:|---|---:|---:|---:|---:|\n");
  for (std::size_t vi = 0; vi < variants.size(); ++vi) {
    const VariantSummary v = summarize_variant(results, cases, vi);
    const double floor = v.cad_noisy_floor;
    std::printf("| %s | %.3f (%s) | %.3f (%s) | %zu/%zu | %.3f (%s) | %s | %s | %zu/%zu | %zu |\n", variants[vi].name.c_str(),
                v.smooth_clean, v.smooth_clean_case.c_str(), v.smooth_noisy, v.smooth_noisy_case.c_str(), v.smooth_worse,
                v.smooth_lines, v.cad_clean, v.cad_clean_case.c_str(), ratio_text(v.cad_noisy_ref, v.cad_noisy_init).c_str(),
                ratio_text(v.cad_noisy_ref - floor, v.cad_noisy_init - floor).c_str(), v.cad_worse, v.cad_lines, v.errors);
  }
}

// Summed over a variant's noisy CAD lines: the fitted curve's, the initial and the refined line's
// mean distances.
struct NoisyCadSums {
  double fitted = 0, initial = 0, refined = 0, above_floor = 0;
  std::size_t lines = 0, worse = 0;
  std::size_t refined_worse = 0;  ///< refined lines worse than their initial line
};

// A truth chain zigzagging less than this (units, truth_zigzag) is a smooth crease: the fandisks',
// wing nut's and slabs' chains read 0.002-0.021 on average, the rocker arm's (a scanned part) 0.16.
constexpr double kSmoothTruth = 0.1;

// The fitted curve beside the surface lines, per row: its mean distance, its ratio to the initial
// and the refined line's, the lines where it is worse than the refined line, and (noisy CAD, per
// variant) the summed ratio to the initial lines.
void print_fitted_rows(const BenchResults& results, const std::vector<Variant>& variants, const std::vector<Case>& cases) {
  std::printf("\n## Fitted curve (fitted.enabled, defaults)\n\n");
  std::printf("| variant | case | noise %% | lines | init mean | ref mean | fitted mean | fitted max | fitted/init | fitted/ref |"
              " floor | truth zigzag | fitted worse than ref | crease share | fallback share | averaged share | fitted ms |\n");
  std::printf("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  // By variant; zigzag_smoothed: the lines whose truth zigzags, against the truth smoothed.
  std::map<std::size_t, NoisyCadSums> noisy_cad, smooth_truth, zigzag_smoothed;
  std::map<std::pair<std::size_t, double>, NoisyCadSums> lightly_noisy;  // by variant and noise under the target's
  for (const auto& [key, row] : results.rows) {
    const Case& c = cases[key.case_index];
    const double noise = c.noise_levels[key.noise_index];
    double initial = 0, refined = 0, fitted = 0, fitted_max = 0, crease = 0, fallback = 0, averaged = 0, floor = 0, zigzag = 0;
    double above_floor = 0;
    std::size_t n = 0, worse = 0;
    std::vector<double> ms;
    for (const auto& l : row.lines) {
      if (l.failed || !l.fitted.present) continue;
      ++n;
      initial += l.initial.mean, refined += l.refined.mean, fitted += l.fitted.distance.mean, floor += l.floor;
      zigzag += l.zigzag;
      above_floor += l.refined.mean - l.floor;
      if (c.group == "cad" && noise > 0 && noise < kCadTargetNoise) {
        NoisyCadSums& sums = lightly_noisy[{key.variant_index, noise}];
        sums.fitted += l.fitted.distance.mean, sums.initial += l.initial.mean, sums.refined += l.refined.mean;
        ++sums.lines;
        sums.refined_worse += l.refined.mean > l.initial.mean + kWorseTolerance;
      }
      if (c.group == "cad" && noise == kCadTargetNoise && l.zigzag >= 0 && l.zigzag < kSmoothTruth) {
        NoisyCadSums& sums = smooth_truth[key.variant_index];
        sums.fitted += l.fitted.distance.mean, sums.initial += l.initial.mean, sums.refined += l.refined.mean;
        sums.above_floor += l.refined.mean - l.floor;
        ++sums.lines;
        sums.worse += l.fitted.distance.mean > l.refined.mean + kWorseTolerance;
      }
      if (c.group == "cad" && noise == kCadTargetNoise && l.zigzag >= kSmoothTruth && l.fitted_smoothed >= 0) {
        NoisyCadSums& sums = zigzag_smoothed[key.variant_index];
        sums.fitted += l.fitted_smoothed, sums.initial += l.initial_smoothed, sums.refined += l.refined_smoothed;
        ++sums.lines;
        sums.worse += l.fitted_smoothed > l.refined_smoothed + kWorseTolerance;
        sums.refined_worse += l.refined_smoothed > l.initial_smoothed + kWorseTolerance;
      }
      fitted_max = std::max(fitted_max, l.fitted.distance.max);
      crease += l.fitted.crease_share, fallback += l.fitted.fallback_share, averaged += l.fitted.averaged_share;
      worse += l.fitted.distance.mean > l.refined.mean + kWorseTolerance;
      ms.push_back(l.fitted.ms);
    }
    if (n == 0) continue;
    if (c.group == "cad" && noise == kCadTargetNoise) {
      NoisyCadSums& sums = noisy_cad[key.variant_index];
      sums.fitted += fitted, sums.initial += initial, sums.refined += refined, sums.lines += n, sums.worse += worse;
      sums.above_floor += above_floor;
    }
    const double k = double(n);
    char floor_text[16] = "-", zigzag_text[16] = "-";
    if (row.lines.front().floor >= 0) std::snprintf(floor_text, sizeof floor_text, "%.3f", floor / k);
    if (row.lines.front().zigzag >= 0) std::snprintf(zigzag_text, sizeof zigzag_text, "%.3f", zigzag / k);
    std::printf("| %s | %s | %.0f | %zu | %.3f | %.3f | %.3f | %.3f | %s | %s | %s | %s | %zu | %.2f | %.2f | %.2f | %.2f |\n",
                variants[key.variant_index].name.c_str(), c.name.c_str(), noise, n, initial / k, refined / k, fitted / k,
                fitted_max, ratio_text(fitted, initial).c_str(), ratio_text(fitted, refined).c_str(), floor_text, zigzag_text,
                worse, crease / k, fallback / k, averaged / k, median(ms));
  }
  if (!noisy_cad.empty()) std::printf("\n");
  auto print_sums = [&](const char* which, const std::map<std::size_t, NoisyCadSums>& by_variant) {
    for (const auto& [variant, sums] : by_variant)
      std::printf("Noisy CAD at 10%%, %s (%zu), %s: fitted / initial %.3f, refined / initial %.3f, fitted worse than refined %zu, "
                  "refined above the floor %.4f per line\n", which, sums.lines, variants[variant].name.c_str(),
                  sums.fitted / sums.initial, sums.refined / sums.initial, sums.worse,
                  sums.above_floor / double(std::max<std::size_t>(1, sums.lines)));
  };
  print_sums("all lines", noisy_cad);
  print_sums("lines on smooth creases, truth zigzag < 0.1", smooth_truth);
  // No floor against a truth that is not the clean mesh's own chain.
  for (const auto& [variant, sums] : zigzag_smoothed)
    std::printf("Noisy CAD at 10%%, lines whose truth zigzags (>= 0.1) against it smoothed (smoothed_chain) (%zu), %s: "
                "initial %.3f, refined %.3f, fitted %.3f per line; fitted / initial %.3f, refined / initial %.3f, "
                "refined worse than initial %zu, fitted worse than refined %zu\n",
                sums.lines, variants[variant].name.c_str(), sums.initial / double(sums.lines), sums.refined / double(sums.lines),
                sums.fitted / double(sums.lines), sums.fitted / sums.initial, sums.refined / sums.initial, sums.refined_worse,
                sums.worse);
  for (const auto& [at, sums] : lightly_noisy)
    std::printf("Lightly noisy CAD at %.0f%% (%zu lines), %s: refined worse than initial %zu, refined / initial %.3f, "
                "fitted / initial %.3f\n", at.second, sums.lines, variants[at.first].name.c_str(), sums.refined_worse,
                sums.refined / sums.initial, sums.fitted / sums.initial);
}

// Mean over a row's lines of their mean offset into the bend (curved crests).
double mean_inward(const Row& row) {
  double sum = 0;
  std::size_t count = 0;
  for (const auto& l : row.lines)
    if (!l.failed && std::isfinite(l.inward)) sum += l.inward, ++count;
  return count ? sum / double(count) : std::nan("");
}

// Curved crests on their own: distances, and the refined line's offset into the bends (> 0: the
// line cuts inside them, as a snake's elasticity pulls it).
void print_curved_rows(const BenchResults& results, const std::vector<Variant>& variants, const std::vector<Case>& cases) {
  bool any = false;
  for (const auto& [key, row] : results.rows) any = any || cases[key.case_index].group == "curved";
  if (!any) return;
  std::printf("\n## Curved crests (arc: radius of curvature 3 widths; sine: 2.7 widths at its bends)\n\n");
  std::printf("| variant | case | triangles | noise %% | lines | init mean | init max | ref mean | ref max | ref/init | inward | worse |\n");
  std::printf("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  for (const auto& [key, row] : results.rows) {
    const Case& c = cases[key.case_index];
    if (c.group != "curved") continue;
    const RowSummary s = summarize(row);
    std::printf("| %s | %s | %zu | %.0f | %zu | %.3f | %.3f | %.3f | %.3f | %s | %+.3f | %zu |\n", variants[key.variant_index].name.c_str(),
                c.name.c_str(), row.triangles, c.noise_levels[key.noise_index], s.lines, s.initial_mean, s.initial_max,
                s.refined_mean, s.refined_max, ratio_text(s.refined_mean, s.initial_mean).c_str(), mean_inward(row), s.worse);
  }
}

// Per variant, the curved crests' worst rows: clean mean and max, noisy means, the largest bias.
void print_curved_summary(const BenchResults& results, const std::vector<Variant>& variants, const std::vector<Case>& cases) {
  struct Worst {
    double value = -1;
    std::string label;
    void take(double v, const std::string& l) {
      if (v > value) value = v, label = l;
    }
  };
  bool any = false;
  for (const auto& [key, row] : results.rows) any = any || cases[key.case_index].group == "curved";
  if (!any) return;
  std::printf("\n## Curved crests, summary per variant\n\n");
  std::printf("| variant | worst clean ref mean | worst clean ref max | worst 10%% ref mean | worst 20%% ref mean | largest clean |inward| | worse lines |\n");
  std::printf("|---|---|---|---|---|---|---:|\n");
  for (std::size_t vi = 0; vi < variants.size(); ++vi) {
    Worst clean_mean, clean_max, noisy10, noisy20, bias;
    std::size_t worse = 0, lines = 0;
    for (const auto& [key, row] : results.rows) {
      const Case& c = cases[key.case_index];
      if (key.variant_index != vi || c.group != "curved") continue;
      const double noise = c.noise_levels[key.noise_index];
      const RowSummary s = summarize(row);
      const std::string label = c.name + " @" + std::to_string(int(noise)) + "%";
      worse += s.worse, lines += s.lines;
      if (noise == 0) clean_mean.take(s.refined_mean, label), clean_max.take(s.refined_max, label);
      if (noise == 0) bias.take(std::abs(mean_inward(row)), label);
      if (noise == 10) noisy10.take(s.refined_mean, label);
      if (noise == 20) noisy20.take(s.refined_mean, label);
    }
    auto cell = [](const Worst& w) {
      char buffer[96];
      std::snprintf(buffer, sizeof buffer, "%.3f (%s)", w.value, w.label.c_str());
      return std::string(buffer);
    };
    std::printf("| %s | %s | %s | %s | %s | %s | %zu/%zu |\n", variants[vi].name.c_str(), cell(clean_mean).c_str(),
                cell(clean_max).c_str(), cell(noisy10).c_str(), cell(noisy20).c_str(), cell(bias).c_str(), worse, lines);
  }
}

// The lines refining made worst (largest excess first), then every line that failed.
void print_worst_lines(const BenchResults& results, const std::vector<Variant>& variants, const std::vector<Case>& cases,
                       int worst_count) {
  struct Worst {
    double excess;
    std::string text;
  };
  std::vector<Worst> worst;
  for (const auto& [key, row] : results.rows)
    for (const auto& l : row.lines) {
      if (l.failed || !l.worse()) continue;
      std::string keys;
      for (auto k : l.keys) keys += (keys.empty() ? "" : ",") + std::to_string(k);
      char buffer[512];
      std::snprintf(buffer, sizeof buffer, "| %s | %s | %.0f | %llu | %s | %.3f | %.3f | %.3f | %.3f |",
                    variants[key.variant_index].name.c_str(), cases[key.case_index].name.c_str(),
                    cases[key.case_index].noise_levels[key.noise_index], static_cast<unsigned long long>(l.seed),
                    keys.c_str(), l.initial.mean, l.refined.mean, l.initial.max, l.refined.max);
      worst.push_back({l.refined.mean - l.initial.mean, buffer});
    }
  std::sort(worst.begin(), worst.end(), [](const Worst& a, const Worst& b) { return a.excess > b.excess; });
  std::printf("\n## Lines where the refined line is worse (largest excess first, at most %d of %zu)\n\n", worst_count,
              worst.size());
  std::printf("| variant | case | noise %% | seed | keys | init mean | ref mean | init max | ref max |\n");
  std::printf("|---|---|---:|---:|---|---:|---:|---:|---:|\n");
  for (std::size_t i = 0; i < worst.size() && i < std::size_t(worst_count); ++i) std::printf("%s\n", worst[i].text.c_str());
  for (const auto& [key, row] : results.rows)
    for (const auto& l : row.lines)
      if (l.failed)
        std::printf("error: %s, %s, noise %.0f%%, seed %llu: %s\n", variants[key.variant_index].name.c_str(),
                    cases[key.case_index].name.c_str(), cases[key.case_index].noise_levels[key.noise_index],
                    static_cast<unsigned long long>(l.seed), l.error.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  const std::optional<BenchArgs> args = parse_args(argc, argv);
  if (!args) return 2;
  const std::vector<Variant> variants = selected_variants(args->only);
  if (variants.empty()) return 2;
  const std::vector<int> sizes = field_sizes(*args);
  std::vector<Case> cases;
  if (!build_cases(*args, sizes, cases)) return 1;

  const auto started = Clock::now();
  const BenchResults results = run_cases(cases, variants, *args);
  const double seconds = std::chrono::duration<double>(Clock::now() - started).count();

  print_header(args->seeds, sizes, results.chains_per_mesh);
  print_rows(results, variants, cases);
  print_summary(results, variants, cases);
  print_fitted_rows(results, variants, cases);
  print_curved_rows(results, variants, cases);
  print_curved_summary(results, variants, cases);
  if (args->worst_count > 0) print_worst_lines(results, variants, cases, args->worst_count);
  std::printf("\n%.1f s\n", seconds);
  return 0;
}
