#include "engine/trace.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>

#include <Eigen/Dense>

#include "engine/errors.h"
#include "engine/initial_line.h"
#include "engine/internal/geometry.h"
#include "engine/internal/stopwatch.h"

namespace featureline {

void check_trace_options(const TraceOptions& options) {
  using O = TraceOptions;
  auto check = [](const ValidRange& range, double value, const char* name) { check_in_range(range, value, std::string("trace.") + name); };
  check(O::max_edges_range, options.max_edges, "max_edges");
  check(O::stop_strength_range, options.stop_strength, "stop_strength");
  check(O::min_signal_to_noise_range, options.min_signal_to_noise, "min_signal_to_noise");
  check(O::step_range, options.step, "step");
  check(O::max_turn_range, options.max_turn, "max_turn");
  check(O::max_gap_edges_range, options.max_gap_edges, "max_gap_edges");
  check(O::snap_rings_range, options.snap_rings, "snap_rings");
}

namespace {

// A seed must be on a crest: the field a few steps across it is at least this share lower than
// along it. A sphere's or a cylinder's field does not fall at all (nothing to follow there).
constexpr double kMinCrestFall = 0.05;
constexpr double kJunctionMargin = kJunctionMarginDegrees * kPi / 180;

double sign_value(FeatureSign sign) { return sign == FeatureSign::ridge ? 1.0 : -1.0; }

// v's neighbours across crease edges of `sign`, in adjacency order.
std::vector<std::uint32_t> crease_neighbors(const PreparedMesh& mesh, std::uint32_t v, double sign) {
  std::vector<std::uint32_t> out;
  for (auto k = mesh.neighbor_offsets()[v]; k < mesh.neighbor_offsets()[v + 1]; ++k)
    if (mesh.curvature().crease[k] == sign) out.push_back(mesh.neighbors()[k]);
  return out;
}

// A crease is followed when at least this many of its edges of one sign are joined: noise on a
// smooth surface marks scattered single edges and short runs as creases (57 of them on a
// 5,000-triangle ridge at 20% noise), which are no feature.
constexpr std::size_t kMinCreaseRun = 3;

// Whether v's crease edges of `sign` belong to a connected run of at least kMinCreaseRun edges.
bool on_crease_run(const PreparedMesh& mesh, std::uint32_t v, double sign) {
  std::vector<std::uint32_t> reached{v};
  for (std::size_t i = 0; i < reached.size() && reached.size() <= kMinCreaseRun; ++i)
    for (auto w : crease_neighbors(mesh, reached[i], sign))
      if (std::find(reached.begin(), reached.end(), w) == reached.end()) reached.push_back(w);
  return reached.size() > kMinCreaseRun;
}

// d in v's tangent plane, unit length (d itself, normalised, where v has no normal).
Eigen::Vector3d tangent_at(const PreparedMesh& mesh, std::uint32_t v, const Eigen::Vector3d& d) {
  const Eigen::Vector3d& n = mesh.vertex_normals()[v];
  const Eigen::Vector3d t = d - d.dot(n) * n;
  return t.squaredNorm() > 1e-24 * d.squaredNorm() ? t.normalized() : d.normalized();
}

// Vertices within `rings` rings of edges of `from` (from first, then ring by ring), never
// through a vertex `passable` refuses (such vertices are left out). Bounded by the rings: a
// trace step looks a few edges ahead only.
template <class Passable>
std::vector<std::pair<std::uint32_t, int>> rings_around(const PreparedMesh& mesh, std::uint32_t from, int rings,
                                                        Passable&& passable) {
  std::vector<std::pair<std::uint32_t, int>> found{{from, 0}};
  std::size_t ring_begin = 0;
  for (int ring = 1; ring <= rings; ++ring) {
    const std::size_t ring_end = found.size();
    for (std::size_t i = ring_begin; i < ring_end; ++i) {
      const auto u = found[i].first;
      for (auto k = mesh.neighbor_offsets()[u]; k < mesh.neighbor_offsets()[u + 1]; ++k) {
        const auto w = mesh.neighbors()[k];
        if (!passable(w)) continue;
        if (std::any_of(found.begin(), found.end(), [w](const auto& f) { return f.first == w; })) continue;
        found.emplace_back(w, ring);
      }
    }
    ring_begin = ring_end;
  }
  return found;
}

// The path back from `to` to the first entry of a rings_around result, following any
// neighbour one ring nearer (the ring search's shortest path by edge count).
std::vector<std::uint32_t> ring_path(const PreparedMesh& mesh, const std::vector<std::pair<std::uint32_t, int>>& found,
                                     std::uint32_t to) {
  auto ring_of = [&](std::uint32_t v) {
    for (const auto& f : found)
      if (f.first == v) return f.second;
    return -1;
  };
  std::vector<std::uint32_t> path{to};
  for (int ring = ring_of(to); ring > 0; --ring) {
    const auto u = path.back();
    for (auto k = mesh.neighbor_offsets()[u]; k < mesh.neighbor_offsets()[u + 1]; ++k)
      if (ring_of(mesh.neighbors()[k]) == ring - 1) {
        path.push_back(mesh.neighbors()[k]);
        break;
      }
  }
  std::reverse(path.begin(), path.end());
  return path;
}

struct Seed {
  std::uint32_t vertex = 0;
  FeatureSign sign = FeatureSign::ridge;
  bool on_crease = false;
};

// The crease vertex nearest `v` within `rings` rings (fewest rings first, then Euclidean
// distance, then the lowest id), with the sign most of its crease edges have; std::nullopt when
// none. `only` restricts the sign (0: either).
std::optional<Seed> nearest_crease_seed(const PreparedMesh& mesh, std::uint32_t v, int rings, double only) {
  const auto found = rings_around(mesh, v, rings, [](std::uint32_t) { return true; });
  std::optional<Seed> best;
  int best_ring = 0;
  double best_distance = 0;
  for (const auto& [u, ring] : found) {
    if (best && ring > best_ring) break;
    const bool ridge_run = only >= 0 && on_crease_run(mesh, u, 1), valley_run = only <= 0 && on_crease_run(mesh, u, -1);
    if (!ridge_run && !valley_run) continue;
    const bool ridge = ridge_run && (!valley_run || crease_neighbors(mesh, u, 1).size() >= crease_neighbors(mesh, u, -1).size());
    const double distance = (mesh.positions()[u] - mesh.positions()[v]).norm();
    if (best && (distance > best_distance || (distance == best_distance && u > best->vertex))) continue;
    best = Seed{u, ridge ? FeatureSign::ridge : FeatureSign::valley, true};
    best_ring = ring;
    best_distance = distance;
  }
  return best;
}

// From v up the feature field of `sign` to a vertex no neighbour beats, at most `steps` edges.
std::uint32_t climb(const PreparedMesh& mesh, std::uint32_t v, double sign, int steps) {
  for (int i = 0; i < steps; ++i) {
    std::uint32_t best = v;
    for (auto k = mesh.neighbor_offsets()[v]; k < mesh.neighbor_offsets()[v + 1]; ++k)
      if (feature_value(mesh.curvature(), mesh.neighbors()[k], sign) > feature_value(mesh.curvature(), best, sign))
        best = mesh.neighbors()[k];
    if (best == v) break;
    v = best;
  }
  return v;
}

Seed find_seed(const PreparedMesh& mesh, std::uint32_t v, const TraceOptions& options) {
  const double only = options.sign == TraceSign::ridge ? 1.0 : options.sign == TraceSign::valley ? -1.0 : 0.0;
  if (auto crease = nearest_crease_seed(mesh, v, options.snap_rings, only)) return *crease;
  Seed seed;
  const double sign = only != 0 ? only : (mesh.curvature().k_max[v] >= -mesh.curvature().k_min[v] ? 1.0 : -1.0);
  seed.sign = sign > 0 ? FeatureSign::ridge : FeatureSign::valley;
  seed.vertex = climb(mesh, v, sign, options.snap_rings);
  return seed;
}

// One direction of the trace from the seed.
struct Walk {
  std::vector<std::uint32_t> path;  ///< from the seed
  Eigen::Vector3d direction = Eigen::Vector3d::Zero();
  bool on_crease = false;                 ///< following a crease chain
  std::uint32_t first_step = kNoIndex;    ///< a crease walk's first vertex, chosen at the seed
  bool done = false;
  TraceEnd end;
};

// What one step found: a path from the walk's last vertex (both ends included), or a reason to
// stop, or nothing (try the other kind of step).
struct Step {
  std::vector<std::uint32_t> path;
  std::optional<TraceStop> stop;
  bool joins = false;  ///< the path ends at the other walk's end: the line closes
};

class Tracer {
 public:
  Tracer(const PreparedMesh& mesh, const TraceOptions& options, const Seed& seed, int max_edges, const Cancellation* cancel)
      : mesh_(mesh), options_(options), sign_(sign_value(seed.sign)), smooth_seed_(!seed.on_crease), max_edges_(max_edges),
        cancel_(cancel) {
    seed_value_ = feature_value(mesh.curvature(), seed.vertex, sign_);
    floor_times_h_ = noise_floor_times_edge(mesh.curvature(), options.min_signal_to_noise);
    path_options_.feature_weight_floor = 0.05;
    blocked_.push_back(seed.vertex);
  }

  double seed_value() const { return seed_value_; }
  bool joined() const { return joined_; }
  std::size_t steps() const { return steps_; }
  std::vector<TraceJunction>& junctions() { return junctions_; }
  /// Whether the seed's feature is strong enough to follow at all (see trace_feature).
  double floor_at(std::uint32_t v) const { return floor_times_h_ / mesh_.local_edge_length(v); }

  /// Advances `walk` by one step; marks it done when it ends (or when it closes the line).
  void advance(Walk& walk, Walk& other) {
    throw_if_cancelled(cancel_);
    const std::uint32_t c = walk.path.back();
    if (edges_ >= std::size_t(max_edges_)) return finish(walk, TraceStop::max_edges);
    if (walk.path.size() > 1 && mesh_.boundary_vertex()[c]) return finish(walk, TraceStop::boundary);
    Step step = crease_step(walk, other);
    if (step.path.empty() && !step.stop) step = smooth_step(walk, other);
    if (step.stop) return finish(walk, *step.stop);
    if (step.path.size() < 2) return finish(walk, TraceStop::feature_end);
    if (edges_ + step.path.size() - 1 > std::size_t(max_edges_)) return finish(walk, TraceStop::max_edges);
    append(walk, step.path);
    if (step.joins) {
      joined_ = true;
      walk.done = other.done = true;
    }
  }

 private:
  static void finish(Walk& walk, TraceStop reason) {
    walk.done = true;
    walk.end = {walk.path.back(), reason};
  }

  bool is_blocked(std::uint32_t v) const { return std::binary_search(blocked_.begin(), blocked_.end(), v); }

  // The line may close once it has three edges: a loop needs three vertices.
  bool may_join(std::size_t step_edges) const { return edges_ + step_edges >= 3; }

  void append(Walk& walk, const std::vector<std::uint32_t>& path) {
    for (std::size_t i = 1; i < path.size(); ++i) {
      walk.path.push_back(path[i]);
      blocked_.insert(std::upper_bound(blocked_.begin(), blocked_.end(), path[i]), path[i]);
    }
    edges_ += path.size() - 1;
    ++steps_;
    // The chord over the last two edges: one edge's direction zig-zags on irregular meshes.
    const std::size_t back = walk.path.size() >= 3 ? walk.path.size() - 3 : 0;
    const auto& P = mesh_.positions();
    const Eigen::Vector3d chord = P[walk.path.back()] - P[path.size() > 2 ? path.front() : walk.path[back]];
    if (chord.squaredNorm() > 0) walk.direction = tangent_at(mesh_, walk.path.back(), chord);
  }

  double turn(const Walk& walk, std::uint32_t from, std::uint32_t to) const {
    return angle_between(walk.direction, mesh_.positions()[to] - mesh_.positions()[from]);
  }

  // Along crease edges of the line's sign. A smooth walk takes a crease only where it runs on
  // ahead; a crease walk whose chain breaks off bridges the gap or hands over to smooth steps.
  Step crease_step(Walk& walk, const Walk& other) {
    const std::uint32_t c = walk.path.back();
    const std::uint32_t previous = walk.path.size() > 1 ? walk.path[walk.path.size() - 2] : kNoIndex;
    const std::vector<std::uint32_t> all = crease_neighbors(mesh_, c, sign_);
    std::vector<std::uint32_t> ahead;
    for (auto w : all)
      if (w != previous && (walk.first_step == kNoIndex || w == walk.first_step)) ahead.push_back(w);
    walk.first_step = kNoIndex;
    const double max_turn = options_.max_turn * kPi / 180;
    if (!walk.on_crease)
      ahead.erase(std::remove_if(ahead.begin(), ahead.end(),
                                 [&](std::uint32_t w) { return turn(walk, c, w) > max_turn || !on_crease_run(mesh_, w, sign_); }),
                  ahead.end());
    if (ahead.empty()) {
      if (!walk.on_crease) return {};
      Step bridge = bridge_gap(walk, other);
      if (bridge.path.empty()) walk.on_crease = false;
      return bridge;
    }
    std::uint32_t next = ahead.front();
    if (all.size() >= 3 && previous != kNoIndex) {
      const std::optional<std::uint32_t> branch = junction_branch(walk, c, ahead);
      if (!branch && smooth_seed_) {
        // A smooth feature's trace that took creases noise made along it: where they meet, the
        // feature goes on, not a choice of creases (a 245,000-triangle ridge at 20% noise stopped
        // at such a junction at x = 0.74, its crest running from x = -1 to 1).
        walk.on_crease = false;
        return {};
      }
      junctions_.push_back({c, all.size(), branch.has_value()});
      if (!branch) return Step{{}, TraceStop::junction, false};
      next = *branch;
    }
    walk.on_crease = true;
    return to_vertex(c, next, other);
  }

  // The branch a junction continues along: the one turning least, when it turns at most
  // max_turn and clearly less than the next.
  std::optional<std::uint32_t> junction_branch(const Walk& walk, std::uint32_t c, std::vector<std::uint32_t> ahead) const {
    std::sort(ahead.begin(), ahead.end(), [&](std::uint32_t a, std::uint32_t b) { return turn(walk, c, a) < turn(walk, c, b); });
    const double best = turn(walk, c, ahead[0]);
    // A rival branch within the margin that is itself a neighbour of the best one closes a
    // triangle with it (noise marking a face's second edge): one crease, not a junction.
    const bool clear = std::all_of(ahead.begin() + 1, ahead.end(), [&](std::uint32_t w) {
      return turn(walk, c, w) >= best + kJunctionMargin || mesh_.are_neighbors(ahead[0], w);
    });
    if (!options_.follow_junctions || best > options_.max_turn * kPi / 180 || !clear) return std::nullopt;
    return ahead[0];
  }

  // One edge c -> w: closes the line at the other walk's end, stops where it meets itself.
  Step to_vertex(std::uint32_t c, std::uint32_t w, const Walk& other) const {
    if (w == other.path.back() && may_join(1)) return Step{{c, w}, std::nullopt, true};
    if (is_blocked(w)) return Step{{}, TraceStop::line_met, false};
    return Step{{c, w}, std::nullopt, false};
  }

  // A crease vertex of the sign within max_gap_edges edges ahead whose chain goes on; the ring
  // path to it. Noise unmarks single edges of a true crease; the chain resumes beyond.
  Step bridge_gap(const Walk& walk, const Walk& other) const {
    const std::uint32_t c = walk.path.back();
    const std::uint32_t other_end = other.path.back();
    auto passable = [&](std::uint32_t v) { return !is_blocked(v) || (v == other_end && may_join(2)); };
    const auto found = rings_around(mesh_, c, options_.max_gap_edges, passable);
    const double max_turn = options_.max_turn * kPi / 180;
    for (std::size_t i = 1; i < found.size(); ++i) {
      const auto x = found[i].first;
      if (found[i].second < 2 || turn(walk, c, x) > max_turn) continue;
      if (x == other_end) return Step{ring_path(mesh_, found, x), std::nullopt, true};
      const auto onward = crease_neighbors(mesh_, x, sign_);
      if (std::any_of(onward.begin(), onward.end(), [&](std::uint32_t y) { return !is_blocked(y) && y != c; }))
        return Step{ring_path(mesh_, found, x), std::nullopt, false};
    }
    return {};
  }

  // A step of options.step local edge lengths on a smooth feature: among the vertices about
  // that far ahead (within max_turn of the line's direction), the strongest; joined by the
  // feature-weighted path. Where the mesh ends within that, a step straight on to its boundary.
  // Ends the walk where the feature fades.
  Step smooth_step(const Walk& walk, const Walk& other) const {
    const std::uint32_t c = walk.path.back();
    const double h = mesh_.local_edge_length(c), reach = options_.step * h;
    const Eigen::Vector3d d = tangent_at(mesh_, c, walk.direction);
    const auto& P = mesh_.positions();
    const std::uint32_t other_end = other.path.back();
    const Eigen::Vector3d to_end = P[other_end] - P[c];
    if (may_join(2) && edges_ >= std::size_t(4 * options_.step) && to_end.norm() <= reach + h && to_end.dot(d) > 0) {
      auto path = shortest_edge_path(mesh_, c, other_end, true, path_options_, sign_, &blocked_, cancel_, 4 * (reach + h));
      if (path) return Step{std::move(*path), std::nullopt, true};
    }
    const auto found = rings_around(mesh_, c, int(std::ceil(options_.step)) + 3,
                                    [&](std::uint32_t v) { return !is_blocked(v) && (P[v] - P[c]).norm() <= reach + 2 * h; });
    // Within a step of the boundary the line goes straight on to it: there the field's fit sees
    // one side only and drifts, while the line's direction comes from the steps before.
    const Step to_boundary = weighted_step(c, boundary_ahead(found, c, d, reach));
    if (!to_boundary.path.empty()) return to_boundary;
    return weighted_step(c, crest_ahead(found, c, d, reach - 0.75 * h, reach + 0.75 * h));
  }

  // Where the mesh ends within a step: the boundary vertex of `found` nearest the line's
  // straight continuation (within max_turn of d, at most `far` ahead); kNoIndex when none.
  std::uint32_t boundary_ahead(const std::vector<std::pair<std::uint32_t, int>>& found, std::uint32_t c,
                               const Eigen::Vector3d& d, double far) const {
    const auto& P = mesh_.positions();
    const Eigen::Vector3d side = mesh_.vertex_normals()[c].cross(d);
    const double slope = std::tan(options_.max_turn * kPi / 180);
    std::uint32_t best = kNoIndex;
    double best_lateral = HUGE_VAL;
    for (const auto& [x, ring] : found) {
      if (!mesh_.boundary_vertex()[x]) continue;
      const Eigen::Vector3d r = P[x] - P[c];
      const double along = r.dot(d), lateral = std::abs(r.dot(side));
      if (along <= 0 || along > far || lateral > slope * along) continue;
      if (lateral < best_lateral) best = x, best_lateral = lateral;
    }
    return best;
  }

  // The crest point among the vertices of `found` whose distance ahead of c along d is in
  // [near, far] and which lie within max_turn of d:
  // the vertex nearest the peak of a parabola fitted to the field across the line (its noise
  // averages out over the section), or the strongest vertex where the section has no peak.
  // kNoIndex when there is none.
  std::uint32_t crest_ahead(const std::vector<std::pair<std::uint32_t, int>>& found, std::uint32_t c,
                            const Eigen::Vector3d& d, double near, double far) const {
    const auto& P = mesh_.positions();
    const Eigen::Vector3d& n = mesh_.vertex_normals()[c];
    const Eigen::Vector3d side = n.cross(d);
    const double slope = std::tan(options_.max_turn * kPi / 180);
    struct Candidate {
      std::uint32_t vertex;
      double lateral, value;
    };
    std::vector<Candidate> section;
    for (const auto& [x, ring] : found) {
      const Eigen::Vector3d r = P[x] - P[c];
      const double along = r.dot(d);
      if (along < near || along > far) continue;
      const double lateral = r.dot(side);
      if (std::abs(lateral) > slope * along) continue;
      section.push_back({x, lateral, feature_value(mesh_.curvature(), x, sign_)});
    }
    if (section.empty()) return kNoIndex;
    const auto strongest = std::max_element(section.begin(), section.end(), [](const Candidate& a, const Candidate& b) {
      return a.value != b.value ? a.value < b.value : std::abs(a.lateral) > std::abs(b.lateral);
    });
    const std::optional<double> peak = section.size() >= 4 ? parabola_peak(section) : std::nullopt;
    if (!peak) return strongest->vertex;
    return std::min_element(section.begin(), section.end(), [&](const Candidate& a, const Candidate& b) {
             return std::abs(a.lateral - *peak) < std::abs(b.lateral - *peak);
           })->vertex;
  }

  // The lateral offset of the peak of f(t) = a + b t + c t^2 fitted (least squares) to the
  // section's values; std::nullopt when the fit has no maximum inside the section.
  template <class Section>
  static std::optional<double> parabola_peak(const Section& section) {
    Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
    Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
    double lo = HUGE_VAL, hi = -HUGE_VAL;
    for (const auto& s : section) {
      const Eigen::Vector3d row(1, s.lateral, s.lateral * s.lateral);
      normal += row * row.transpose();
      rhs += row * s.value;
      lo = std::min(lo, s.lateral);
      hi = std::max(hi, s.lateral);
    }
    const Eigen::Vector3d k = normal.ldlt().solve(rhs);
    if (!k.allFinite() || !(k[2] < 0)) return std::nullopt;
    const double t = -k[1] / (2 * k[2]);
    if (!(t >= lo && t <= hi)) return std::nullopt;
    return t;
  }

  // The feature-weighted path from c to `target`; a stop where the feature along it (the mean
  // feature value of its vertices after c) has faded below the stop strength or the noise floor.
  Step weighted_step(std::uint32_t c, std::uint32_t target) const {
    if (target == kNoIndex) return {};
    const double reach = (options_.step + 1) * mesh_.local_edge_length(c);
    auto path = shortest_edge_path(mesh_, c, target, true, path_options_, sign_, &blocked_, cancel_, 4 * reach);
    if (!path) return {};
    double sum = 0;
    for (std::size_t i = 1; i < path->size(); ++i) sum += feature_value(mesh_.curvature(), (*path)[i], sign_);
    const double mean = sum / double(path->size() - 1);
    if (mean < options_.stop_strength * seed_value_ || mean < floor_at(c)) return Step{{}, TraceStop::feature_end, false};
    return Step{std::move(*path), std::nullopt, false};
  }

  const PreparedMesh& mesh_;
  const TraceOptions& options_;
  double sign_;
  bool smooth_seed_;  ///< the trace started on a smooth feature, not on a crease
  int max_edges_;
  const Cancellation* cancel_;
  double seed_value_ = 0;
  double floor_times_h_ = 0;
  InitialLineOptions path_options_;
  std::vector<std::uint32_t> blocked_;  ///< every vertex on the line so far, sorted
  std::size_t edges_ = 0, steps_ = 0;
  bool joined_ = false;
  std::vector<TraceJunction> junctions_;
};

// The two walks' first moves from a crease seed: along its two crease edges (at a junction, the
// pair that lines up best); a chain's end has one walk along the chain, the other looks past it.
void start_on_crease(const PreparedMesh& mesh, const Seed& seed, Walk& forward, Walk& backward,
                     std::vector<TraceJunction>& junctions, const TraceOptions& options) {
  const auto& P = mesh.positions();
  const auto branches = crease_neighbors(mesh, seed.vertex, sign_value(seed.sign));
  std::uint32_t a = branches.front(), b = kNoIndex;
  double straightest = -1;
  for (std::size_t i = 0; i < branches.size(); ++i)
    for (std::size_t j = i + 1; j < branches.size(); ++j) {
      const double angle = angle_between(P[branches[i]] - P[seed.vertex], P[branches[j]] - P[seed.vertex]);
      if (angle > straightest) straightest = angle, a = branches[i], b = branches[j];
    }
  if (branches.size() >= 3)
    junctions.push_back({seed.vertex, branches.size(), options.follow_junctions && straightest >= kPi - options.max_turn * kPi / 180});
  forward.on_crease = true;
  forward.first_step = a;
  forward.direction = tangent_at(mesh, seed.vertex, P[a] - P[seed.vertex]);
  backward.direction = -forward.direction;
  if (b != kNoIndex) {
    backward.on_crease = true;
    backward.first_step = b;
    backward.direction = tangent_at(mesh, seed.vertex, P[b] - P[seed.vertex]);
  }
}

// The crest's axis through a smooth seed, at the first of three scales (1, 2 and 4 steps) where
// the feature field falls across it: the mean field over ring sectors of the seed (16 sectors
// of 22.5 degrees, opposite sectors together) is largest along the crest and smallest across.
// A two-ring fit sees too little of a wide or noisy crest; a ring a few steps out sees its
// shape. std::nullopt where the field falls by less than kMinCrestFall every way (a sphere, a
// cylinder: nothing to follow).
std::optional<Eigen::Vector3d> crest_axis(const PreparedMesh& mesh, std::uint32_t seed, double sign, double step) {
  const auto& P = mesh.positions();
  const Eigen::Vector3d& n = mesh.vertex_normals()[seed];
  const Eigen::Vector3d u = n.unitOrthogonal(), w = n.cross(u);
  const double h = mesh.local_edge_length(seed);
  constexpr int kSectors = 16;
  for (double scale : {1.0, 2.0, 4.0}) {
    const double radius = step * scale * h;
    const auto found = rings_around(mesh, seed, int(std::ceil(1.5 * radius / h)) + 2,
                                    [&](std::uint32_t v) { return (P[v] - P[seed]).norm() <= radius + h; });
    std::array<double, kSectors / 2> sum{}, count{};
    for (const auto& [v, ring] : found) {
      const Eigen::Vector3d r = P[v] - P[seed];
      const double distance = r.norm();
      if (distance < radius - h) continue;
      const double angle = std::atan2(r.dot(w), r.dot(u));  // (-pi, pi]
      const int sector = int(std::floor((angle + kPi) / (2 * kPi) * kSectors)) % kSectors;
      sum[sector % (kSectors / 2)] += feature_value(mesh.curvature(), v, sign);
      count[sector % (kSectors / 2)] += 1;
    }
    int along = -1;
    std::array<double, kSectors / 2> mean{};
    for (int k = 0; k < kSectors / 2; ++k) {
      mean[k] = count[k] > 0 ? sum[k] / count[k] : -1;
      if (count[k] > 0 && (along < 0 || mean[k] > mean[along])) along = k;
    }
    const int across = (along + kSectors / 4) % (kSectors / 2);
    if (along < 0 || count[across] == 0 || !(mean[along] > 0)) continue;
    if (1 - mean[across] / mean[along] < kMinCrestFall) continue;
    const double angle = (along + 0.5) * 2 * kPi / kSectors - kPi;
    return Eigen::Vector3d(std::cos(angle) * u + std::sin(angle) * w);
  }
  return std::nullopt;
}

// On an exact surface the noise floor is nearly zero (a CAD part's noise estimate is 1e-5 edge
// lengths), and the jets' own error on a flat face reads as curvature: 2-5e-5 of the curvature
// scale beside fandisk's creases. Under this share of the scale a seed has no feature to follow.
constexpr double kMinSeedStrength = 1e-3;

// A smooth seed's two walks go both ways along its crest; a seed without a crest (the field
// below the noise floor, or not falling across) has no feature to follow.
void start_on_crest(const PreparedMesh& mesh, const Seed& seed, const Tracer& tracer, const TraceOptions& options,
                    Walk& forward, Walk& backward) {
  const auto at = "vertex " + std::to_string(seed.vertex);
  const double strength = tracer.seed_value() / mesh.curvature_scale();
  if (!(tracer.seed_value() > 0) || tracer.seed_value() < tracer.floor_at(seed.vertex) || strength < kMinSeedStrength)
    throw GeometryError("no ridge, valley or crease to trace at " + at + ": its feature strength " + format_number(strength) +
                        " is within the noise");
  const std::optional<Eigen::Vector3d> axis = crest_axis(mesh, seed.vertex, sign_value(seed.sign), options.step);
  if (!axis)
    throw GeometryError("no ridge, valley or crease to trace at " + at +
                        ": the feature field does not fall across any direction there (no crest)");
  forward.direction = tangent_at(mesh, seed.vertex, *axis);
  backward.direction = -forward.direction;
}

std::vector<std::uint32_t> joined_vertices(const Walk& forward, const Walk& backward, bool closed) {
  std::vector<std::uint32_t> line(backward.path.rbegin(), backward.path.rend());
  line.insert(line.end(), forward.path.begin() + 1, forward.path.end());
  if (closed) line.pop_back();  // the walks met: the last vertex is the first again
  return line;
}

}  // namespace

TraceResult trace_feature(const PreparedMesh& mesh, std::uint32_t vertex, const TraceOptions& options,
                          const Cancellation* cancel) {
  auto clock = StageClock::now();
  check_trace_options(options);
  if (vertex >= mesh.n_vertices())
    throw InvalidInputError("the trace starts at vertex " + std::to_string(vertex) + ", but the mesh has only " +
                            std::to_string(mesh.n_vertices()) + " vertices");
  if (mesh.component()[vertex] < 0) throw GeometryError("vertex " + std::to_string(vertex) + " belongs to no triangle");
  TraceResult result;
  result.clicked = vertex;
  const Seed seed = find_seed(mesh, vertex, options);
  result.seed = seed.vertex;
  result.sign = seed.sign;
  result.on_crease = seed.on_crease;
  Tracer tracer(mesh, options, seed, options.max_edges, cancel);
  result.seed_strength = tracer.seed_value() / mesh.curvature_scale();
  Walk forward, backward;
  forward.path = backward.path = {seed.vertex};
  if (seed.on_crease)
    start_on_crease(mesh, seed, forward, backward, tracer.junctions(), options);
  else
    start_on_crest(mesh, seed, tracer, options, forward, backward);
  // Alternating, so a length limit shares the edges between both ways.
  while (!forward.done || !backward.done) {
    if (!forward.done) tracer.advance(forward, backward);
    if (!backward.done) tracer.advance(backward, forward);
  }
  result.closed = tracer.joined();
  result.vertices = joined_vertices(forward, backward, result.closed);
  if (result.vertices.size() < 2)
    throw GeometryError("the feature at vertex " + std::to_string(seed.vertex) + " ends where it starts: nothing to trace");
  if (result.closed)
    result.ends = {TraceEnd{result.vertices.front(), TraceStop::closed}, TraceEnd{result.vertices.front(), TraceStop::closed}};
  else
    result.ends = {backward.end, forward.end};
  result.junctions = std::move(tracer.junctions());
  result.steps = tracer.steps();
  result.length = path_length(mesh, result.vertices, result.closed);
  result.elapsed_ms = lap_ms(clock);
  return result;
}

}  // namespace featureline
