#include "api/options_table.h"

#include <cmath>
#include <stdexcept>

#include "engine/errors.h"

namespace featureline {

using nlohmann::json;

namespace {

std::string joined(const std::vector<std::string>& names) {
  std::string text;
  for (const auto& n : names) text += (text.empty() ? "" : ", ") + n;
  return text;
}

const char* kind_name(OptionKind kind) {
  switch (kind) {
    case OptionKind::number: return "number";
    case OptionKind::integer: return "integer";
    case OptionKind::boolean: return "boolean";
    case OptionKind::choice: break;
  }
  return "string";
}

// Client text quoted in an error: long values are cut, so an error never echoes megabytes.
std::string quoted_excerpt(const std::string& text) {
  return "\"" + (text.size() > 40 ? text.substr(0, 40) + "..." : text) + "\"";
}

}  // namespace

// "95%" for a dropped share of 0.05: what the automatic strip layout keeps.
std::string kept_percent(double dropped_share) { return format_number(100 * (1 - dropped_share)) + "%"; }

std::string option_path(const std::string& prefix, const std::string& name) {
  if (prefix.empty()) return name;
  return name.empty() ? prefix : prefix + "." + name;
}

std::string dotted_to_pointer(const std::string& dotted) {
  std::string pointer = dotted;
  for (char& c : pointer)
    if (c == '.') c = '/';
  return pointer;
}

json::json_pointer option_pointer(const std::string& name) { return json::json_pointer("/" + dotted_to_pointer(name)); }

void throw_not_an_object(const std::string& where) { throw InvalidInputError("\"" + where + "\" must be a JSON object"); }

void throw_unknown_option(const std::string& where) { throw InvalidInputError("unknown option \"" + where + "\""); }

void throw_option_given_twice(const std::string& first, const std::string& second, const std::string& current) {
  const bool current_first = first == current;
  throw InvalidInputError("\"" + (current_first ? second : first) + "\" and \"" + (current_first ? first : second) +
                          "\" name the same option: give only \"" + current + "\"");
}

json check_option_value(const OptionSpec& spec, const json& value, const std::string& where) {
  const std::string field = "\"" + where + "\"";
  const std::string range = " from " + format_number(spec.minimum) + " to " + format_number(spec.maximum);
  switch (spec.kind) {
    case OptionKind::boolean:
      if (!value.is_boolean()) throw InvalidInputError(field + " must be true or false");
      return value;
    case OptionKind::choice: {
      const std::string expected = field + " must be one of " + joined(spec.choices);
      if (!value.is_string()) throw InvalidInputError(expected);
      const std::string name = value.get<std::string>();
      for (const auto* names : {&spec.choices, &spec.aliases})
        for (const auto& choice : *names)
          if (choice == name) return value;
      throw InvalidInputError(expected + ", not " + quoted_excerpt(name));
    }
    case OptionKind::integer: {
      // JSON Schema counts 2.0 as an integer, so do we.
      const double x = value.is_number() ? value.get<double>() : NAN;
      if (!std::isfinite(x) || x != std::floor(x)) throw InvalidInputError(field + " must be an integer" + range);
      if (!(x >= spec.minimum && x <= spec.maximum)) throw InvalidInputError(field + " must be an integer" + range);
      return json(static_cast<long long>(x));
    }
    case OptionKind::number: break;
  }
  const double x = value.is_number() ? value.get<double>() : NAN;
  if (!(x >= spec.minimum && x <= spec.maximum)) throw InvalidInputError(field + " must be a number" + range);
  return json(x);
}

OptionRange within(const ValidRange& engine, double minimum, double maximum) {
  const bool own_min = !std::isnan(minimum), own_max = !std::isnan(maximum);
  if ((!own_min && (engine.min_open || !std::isfinite(engine.min))) || (!own_max && (engine.max_open || !std::isfinite(engine.max))))
    throw std::logic_error("an option row takes an open or unbounded end of the engine's range " + describe(engine));
  OptionRange range{own_min ? minimum : engine.min, own_max ? maximum : engine.max, engine};
  if (!engine.contains(range.minimum) || !engine.contains(range.maximum))
    throw std::logic_error("an option row's limits leave the engine's range " + describe(engine));
  return range;
}

json describe_options(const std::vector<OptionSpec>& specs) {
  json rows = json::array();
  for (const auto& spec : specs) {
    json row = {{"name", spec.name}, {"type", kind_name(spec.kind)}, {"default", spec.default_value}, {"description", spec.description}};
    if (spec.kind == OptionKind::number) {
      row["minimum"] = spec.minimum;
      row["maximum"] = spec.maximum;
    }
    if (spec.kind == OptionKind::integer) {
      row["minimum"] = static_cast<long long>(spec.minimum);
      row["maximum"] = static_cast<long long>(spec.maximum);
    }
    if (spec.kind == OptionKind::choice) row["enum"] = spec.choices;
    if (!spec.cli_flag.empty()) row["cli_flag"] = spec.cli_flag;
    if (!spec.old_names.empty()) row["old_names"] = spec.old_names;
    rows.push_back(row);
  }
  return rows;
}

// ---- the tables ----------------------------------------------------------------------------------
// Options the engine checks take their limits from the engine's ranges (within(): kEngineEnd is
// the engine's own end). Where the engine accepts more than a request may ask, the table's
// number is either a cost cap (named below) or a bound that only keeps values meaningful.

namespace {
// Caps on cost, tighter than the engine's ranges: at all of them together one line of a few
// hundred edges on a 270k-triangle mesh stays near a second (bench/bench_worst_case prints it).
// The strip's rings are capped by the engine itself (StripOptions::max_rings).
constexpr double kSnakeIterationsCap = 500;  // engine: any count >= 0
constexpr double kSnakeSpacingCap = 0.25;    // smallest spacing, edge lengths; engine: > 0.01
constexpr double kSnakeKappaCap = 1;         // engine: any weight >= 0
constexpr double kSnakeExponentCap = 4;      // engine: any p > 0
constexpr double kSnakeMaxStepCap = 1;       // edge lengths; engine: any step > 0
}  // namespace

const OptionTable<FeatureLineOptions>& feature_line_option_table() {
  using O = FeatureLineOptions;
  using I = InitialLineOptions;
  using S = SnakeOptions;
  static const OptionTable<O> table = {
      // Rows renamed to their member paths keep their old paths for one release (docs/options.md).
      formerly({"initial"}, option<O>("initial.method", {}, "How the initial line between keys is found: the paper's "
                "marching search, a path along the strongest edges, or the shortest path", "--initial", &O::initial, &I::method)),
      formerly({"weights.alpha"}, option<O>("initial.marching_alpha", {0, 1000}, "Marching weight of heading from the "
                "start key to the end key (Eq. 10)", "", &O::initial, &I::marching_alpha)),
      formerly({"weights.beta"}, option<O>("initial.marching_beta", {0, 1000}, "Marching weight of keeping the previous "
                "step's direction (Eq. 10)", "", &O::initial, &I::marching_beta)),
      formerly({"weights.gamma"}, option<O>("initial.marching_gamma", {0, 1000}, "Marching weight of getting closer to "
                "the end key (Eq. 10)", "", &O::initial, &I::marching_gamma)),
      formerly({"weights.delta"}, option<O>("initial.marching_delta", {0, 1000}, "Marching weight of the curvature term "
                "f_C (Eq. 10)", "", &O::initial, &I::marching_delta)),
      formerly({"curvature_term"}, option<O>("initial.marching_curvature_term", {}, "What the marching search's f_C "
                "compares: the current vertex, the end key, or curvature magnitude", "--curvature-term", &O::initial,
                &I::marching_curvature_term)),
      formerly({"fallback"}, option<O>("initial.fallback", {}, "Use feature-path for a segment the marching search "
                "cannot finish", "--no-fallback", &O::initial, &I::fallback)),
      formerly({"feature_weight_floor"}, option<O>("initial.feature_weight_floor", {1e-4, 1}, "feature-path edge cost "
                "on the strongest features, relative to featureless edges (1: geodesic)", "", &O::initial,
                &I::feature_weight_floor)),
      formerly({"sign_aware"}, option<O>("initial.sign_aware", {}, "Follow only ridges or only valleys when every key "
                "agrees in sign", "", &O::initial, &I::sign_aware)),
      formerly({"max_line_edges"}, option<O>("initial.max_edges", {1, 1000}, "Lines longer than this many edges are "
                "refused (split them): every stage's work grows with the length", "", &O::initial, &I::max_edges)),
      formerly({"rings"}, option<O>("strip.rings", within(StripOptions::rings_range), "Rings of faces around the "
                "initial line in the feature strip (0: 2 to 8, chosen from the line's length)", "--rings", &O::strip,
                &StripOptions::rings)),
      formerly({"dense_line_edges"}, option<O>("strip.dense_line_edges", {1, 1000}, "Automatic rings: lines of this "
                "many edges get 3 rings, twice as many 4, four times 6, eight times 8", "", &O::strip,
                &StripOptions::dense_line_edges)),
      formerly({"flattening"}, option<O>("strip.flattening", {}, ("How the strip is laid out in the plane: the "
                "paper's similar triangles, a conformal map, or the paper's where it keeps " +
                kept_percent(StripOptions::max_dropped_share) + " of the strip (" +
                kept_percent(StripOptions::max_dropped_share_noisy) + " on noisy meshes)").c_str(), "--flattening", &O::strip, &StripOptions::flattening)),
      formerly({"max_edge_distortion"}, option<O>("strip.max_edge_distortion", {0.01, 100}, "Flattened triangles whose "
                "edges stretch by more than this fraction are left out of the snake's domain", "", &O::strip,
                &StripOptions::max_edge_distortion)),
      option<O>("refine", {}, "Refine the initial line with the snake", "--no-refine", &O::refine),
      option<O>("pin_interior_keys", {}, "Interior keys stay where they are placed", "--free-keys", &O::pin_interior_keys),
      option<O>("min_piece_edges", within(O::min_piece_edges_range, kEngineEnd, 1000), "A strip that folds over is split in two until pieces are this short "
                "(line edges)", "", &O::min_piece_edges),
      option<O>("exact_crease_edges", {0, 1000}, "A piece running along at least this many crease edges only is kept "
                "exactly on clean meshes (0: refine creases too)", "", &O::exact_crease_edges),
      option<O>("exact_crease_noise", {0, 1}, "Mesh noise (local edge lengths) from which crease runs are re-fitted "
                "(crease_fit) instead of kept exactly", "", &O::exact_crease_noise),
      option<O>("crease_fit.bandwidth", {0, 20}, "Noisy crease runs: Gaussian width of the fit along the chain (local "
                "edge lengths; 0: refine them with the snake)", "", &O::crease_fit, &CreaseFitOptions::bandwidth),
      option<O>("crease_fit.confidence", {0, 10}, "Noisy crease runs: each vertex's fit window is the widest (1 to "
                "11 local edge lengths) whose estimate agrees with every narrower one within this many standard "
                "deviations of the noise (0: the fixed bandwidth)", "", &O::crease_fit, &CreaseFitOptions::confidence),
      option<O>("crease_fit.step", {0, 1}, "Noisy crease runs: how far each vertex moves toward the fitted crease "
                "(0: stays, 1: all the way)", "", &O::crease_fit, &CreaseFitOptions::step),
      option<O>("crease_fit.max_shift", {0, 10}, "Noisy crease runs: a vertex the fit would move further than this "
                "(local edge lengths) stays", "", &O::crease_fit, &CreaseFitOptions::max_shift),
      option<O>("crease_fit.curve_pull", {0, 1}, "Noisy crease runs: how far each point then moves toward the line's "
                "fitted space curve before it is put back on the surface (0: the crease fit's points)", "", &O::crease_fit,
                &CreaseFitOptions::curve_pull),
      option<O>("crease_fit.min_crease_share", {0, 1}, "A piece with at least this share of crease edges is fitted "
                "as a crease run (on a mesh that reads clean: when some are unmarked and its line runs on smoothly)", "", &O::crease_fit, &CreaseFitOptions::min_crease_share),
      option<O>("second_strip", {}, "A piece whose refined line reached its strip's outer rings is refined again on a strip "
                "around the vertices nearest that line (the stronger line kept)", "--one-strip", &O::second_strip),
      option<O>("crest.enabled", {}, "Place the snake's line on the crest of the feature field across it, located "
                "inside triangles (false: the snake's line as it settles, the paper's)", "--no-crest", &O::crest, &CrestOptions::enabled),
      option<O>("crest.radius", within(CrestOptions::radius_range), "Crest localisation: radius of the fits measuring the "
                "crest's half width (strip edge lengths), which the fit then takes, down to the jet radius", "", &O::crest, &CrestOptions::radius),
      option<O>("crest.max_radius", within(CrestOptions::radius_range), "Crest localisation: largest fit radius (strip edge "
                "lengths; also within the strip's rings)", "", &O::crest, &CrestOptions::max_radius),
      option<O>("crest.max_shift", within(CrestOptions::max_shift_range), "Crest localisation: largest move of a point "
                "across the line (strip edge lengths)", "", &O::crest, &CrestOptions::max_shift),
      option<O>("crest.max_key_shift", within(CrestOptions::max_key_shift_range), "Crest localisation: largest move "
                "of a key (a pinned end) across the line (strip edge lengths): the vertex nearest a crest can lie "
                "further from it than half an edge", "", &O::crest, &CrestOptions::max_key_shift),
      option<O>("crest.smoothing_passes", within(CrestOptions::smoothing_passes_range), "Crest localisation: (1, 2, 1)/4 "
                "passes over the moves along the line", "", &O::crest, &CrestOptions::smoothing_passes),
      option<O>("fitted.enabled", {}, "Also answer a smooth space curve fitted to the line's neighbourhood (crease sides "
                "intersected, a smoothing spline), allowed to leave the noisy surface", "--fitted", &O::fitted,
                &FittedCurveOptions::enabled),
      option<O>("fitted.radius", within(FittedCurveOptions::radius_range), "Fitted curve: radius of the neighbourhood "
                "fitted around each point of the line (local edge lengths; a noisy mesh's crease fits reach three "
                "times as far along the line)", "", &O::fitted, &FittedCurveOptions::radius),
      option<O>("fitted.control_spacing", within(FittedCurveOptions::control_spacing_range), "Fitted curve: distance "
                "between the spline's control points (the line's mean local edge lengths)", "--fitted-control-spacing",
                &O::fitted, &FittedCurveOptions::control_spacing),
      option<O>("fitted.smoothing", within(FittedCurveOptions::smoothing_range), "Fitted curve: weight of the spline's "
                "bending penalty, per control point's data (0: plain least squares)", "", &O::fitted,
                &FittedCurveOptions::smoothing),
      option<O>("fitted.min_dihedral", within(FittedCurveOptions::min_dihedral_range), "Fitted curve: sides closer "
                "to coplanar than this (degrees) are no crease: the surface fit is used", "", &O::fitted,
                &FittedCurveOptions::min_dihedral),
      option<O>("fitted.max_shift", within(FittedCurveOptions::max_shift_range), "Fitted curve: a fitted point "
                "further than this from the surface line (local edge lengths) is replaced by the line's", "", &O::fitted,
                &FittedCurveOptions::max_shift),
      option<O>("fitted.corner_angle", within(FittedCurveOptions::corner_angle_range), "Fitted curve: the spline is "
                "split where the line turns by more than this within an edge (degrees)", "", &O::fitted,
                &FittedCurveOptions::corner_angle),
      option<O>("fitted.run_averaging", within(FittedCurveOptions::run_averaging_range), "Fitted curve: on a noisy "
                "mesh's crease runs each point is averaged along the line over the widest window whose estimate "
                "agrees with every narrower one within this many standard deviations (0: the spline alone)", "",
                &O::fitted, &FittedCurveOptions::run_averaging),
      option<O>("crest.move_keys", {}, "Crest localisation: keys (and other pinned points) move across the line to the "
                "crest too, within max_key_shift; on a noisy mesh's crease runs they are re-fitted with the run, "
                "within crease_fit.max_shift (false: the line passes through the key vertices)", "--keys-on-vertices",
                &O::crest, &CrestOptions::move_keys),
      option<O>("crest.follow_bend", {}, "Crest localisation: fits measure across the line from its bend, so a bent "
                "crest is not read as an offset into the bend (false: from its tangent)", "", &O::crest, &CrestOptions::follow_bend),
      option<O>("crest.unblur", {}, "Crest localisation: each point moves out of the line's bend by three quarters of "
                "what the field's blur (jets, smoothing) moved the crest into it, where the field was smoothed (estimated "
                "noise 0.005-0.09) and the blur is narrow against the crest (false: the field's crest)", "", &O::crest,
                &CrestOptions::unblur),
      option<O>("trace.sign", {}, "A line traced from one key follows: a crease's sign near the key, else the larger "
                "curvature's (auto), or ridges or valleys only", "--trace-sign", &O::trace, &TraceOptions::sign),
      option<O>("trace.max_edges", within(TraceOptions::max_edges_range, kEngineEnd, 1000), "Traced lines: the longest, "
                "in edges (also within initial.max_edges)", "", &O::trace, &TraceOptions::max_edges),
      option<O>("trace.stop_strength", within(TraceOptions::stop_strength_range), "Traced lines: the trace ends where the "
                "feature falls below this share of its strength at the key", "", &O::trace, &TraceOptions::stop_strength),
      option<O>("trace.min_signal_to_noise", within(TraceOptions::min_signal_to_noise_range), "Traced lines: ... or below "
                "this many times the estimated noise (0: off)", "", &O::trace, &TraceOptions::min_signal_to_noise),
      option<O>("trace.step", within(TraceOptions::step_range), "Traced lines: step along smooth crests (local edge "
                "lengths)", "", &O::trace, &TraceOptions::step),
      option<O>("trace.max_turn", within(TraceOptions::max_turn_range), "Traced lines: the most a step or a crease at "
                "a junction may turn (degrees)", "", &O::trace, &TraceOptions::max_turn),
      option<O>("trace.follow_junctions", {}, "Traced lines: continue through a junction of creases along the branch "
                "that turns least (false: stop at junctions)", "--stop-at-junctions", &O::trace, &TraceOptions::follow_junctions),
      option<O>("trace.max_gap_edges", within(TraceOptions::max_gap_edges_range), "Traced lines: a crease chain broken "
                "by noise continues when it resumes within this many edges", "", &O::trace, &TraceOptions::max_gap_edges),
      option<O>("trace.snap_rings", within(TraceOptions::snap_rings_range), "Traced lines: the key moves to a crease "
                "within this many rings, else up the feature field this many edges", "", &O::trace, &TraceOptions::snap_rings),
      option<O>("keep_initial_below", {0, 1}, "A refined piece weaker on the feature than this share of its initial "
                "line keeps the initial line (0: always the snake's)", "", &O::keep_initial_below),
      option<O>("snake.alpha", within(S::alpha_range, kEngineEnd, 1000), "Elasticity: resistance to stretching (Eq. 12)", "--alpha", &O::snake, &S::alpha),
      option<O>("snake.beta", within(S::beta_range, kEngineEnd, 1000), "Rigidity: resistance to bending (Eq. 12)", "--beta", &O::snake, &S::beta),
      option<O>("snake.tau", within(S::tau_range, 1e-4, 1000), "Time step of the semi-implicit iteration (Eq. 15)", "--tau", &O::snake, &S::tau),
      option<O>("snake.kappa", within(S::kappa_range, kEngineEnd, kSnakeKappaCap), "Weight of the feature force", "--kappa", &O::snake, &S::kappa),
      option<O>("snake.exponent", within(S::exponent_range, 0.1, kSnakeExponentCap), "p in the feature potential |C|^p (the paper: 2)", "", &O::snake, &S::exponent),
      option<O>("snake.curvature_cap", within(S::curvature_cap_range, 0.01, 1000), "|C| is clamped at this many curvature-scale units", "", &O::snake,
                &S::curvature_cap),
      option<O>("snake.max_step", within(S::max_step_range, 1e-3, kSnakeMaxStepCap), "Largest move of a point in one iteration (edge lengths)", "", &O::snake,
                &S::max_step),
      formerly({"snake.iterations"}, option<O>("snake.max_iterations", within(S::max_iterations_range, kEngineEnd,
                kSnakeIterationsCap), "Iteration cap per piece", "--iterations", &O::snake, &S::max_iterations)),
      option<O>("snake.featureless_below", within(S::featureless_below_range, kEngineEnd, 4), "A strip whose 90th percentile of "
                "feature strength (in units of the mesh's 90th percentile of |C|) is below this has no feature: its snake "
                "only smooths the line (0: off)", "", &O::snake, &S::featureless_below),
      option<O>("snake.featureless_iterations", within(S::max_iterations_range, kEngineEnd, kSnakeIterationsCap),
                "Iteration cap on a featureless strip", "", &O::snake, &S::featureless_iterations),
      option<O>("snake.tolerance", {0, 10}, "Stop when the line's shape changes less than this per iteration (edge "
                "lengths)", "", &O::snake, &S::tolerance),
      option<O>("snake.spacing", within(S::spacing_range, kSnakeSpacingCap, 10), "Distance between snake points (edge lengths)", "--spacing", &O::snake,
                &S::spacing),
      option<O>("snake.resample_every", within(S::resample_every_range, kEngineEnd, 1000), "Iterations between resampling passes", "", &O::snake,
                &S::resample_every),
      option<O>("snake.force", {}, "Feature force: the paper's per-triangle gradient, or smooth vertex gradients",
                "--force", &O::snake, &S::force),
      option<O>("snake.normal_force_only", {}, "Paper step only: keep only the force's component normal to the line", "",
                &O::snake, &S::normal_force_only),
      option<O>("snake.sharp_crest_drop", {0, 0.99}, "Smooth force: the drop in |C|^p on both sides that makes a vertex "
                "a sharp crest (0: off)", "", &O::snake, &S::sharp_crest_drop),
      option<O>("snake.feature_sign", {-1, 1}, "Attract to ridges (positive), valleys (negative), or as the keys' "
                "sign says (0)", "", &O::snake, &S::feature_sign),
      option<O>("snake.normal_step", {}, "Move points along their normals with the force linearised (false: the "
                "paper's step)", "", &O::snake, &S::normal_step),
  };
  return table;
}

const OptionTable<SegmentationOptions>& segmentation_option_table() {
  using O = SegmentationOptions;
  static const OptionTable<O> table = {
      option<O>("mode", {}, "snap: cut along mesh edges nearest the lines; remesh: split faces so parts meet on the "
                "smooth line", "--mode", &O::mode),
      option<O>("min_segment_area_fraction", within(O::min_segment_area_fraction_range, kEngineEnd, 0.5), "Parts below this share of the area are reported (or merged)",
                "--min-segment-area", &O::min_segment_area_fraction),
      option<O>("merge_tiny_segments", {}, "Merge parts below min_segment_area_fraction into the neighbour sharing "
                "most of their cut", "--merge-tiny-segments", &O::merge_tiny_segments),
      option<O>("attach_distance", within(O::attach_distance_range, kEngineEnd, 20), "A loose line end this close (edge lengths) to the boundary or another "
                "line is joined to it (0: off)", "--attach-distance", &O::attach_distance),
      option<O>("remesh_snap", within(O::remesh_snap_range, kEngineEnd, 0.2), "remesh: crossings this close (fraction of an edge) to a vertex or edge "
                "move onto it", "--remesh-snap", &O::remesh_snap),
  };
  return table;
}

const OptionTable<CurvatureOptions>& curvature_option_table() {
  using O = CurvatureOptions;
  static const OptionTable<O> table = {
      option<O>("method", {}, "jet: principal curvatures of a fit over a radius that follows the noise; cotangent: "
                "the paper's one-ring mean curvature", "--curvature", &O::method),
      option<O>("radius", within(CurvatureLimits::radius_range), "Jet radius in local edge lengths (0: from the noise)",
                "--curvature-radius", &O::radius),
      option<O>("jet_degree", {}, "Jet polynomial: quadric, cubic (its odd terms take up a crest's bend), or auto: "
                "cubic, quadric at the border and beside creases", "--jet-degree", &O::jet_degree),
      option<O>("smoothing_passes", within(CurvatureLimits::smoothing_passes_range), "Laplacian passes over the "
                "curvature field (-1: none on an exact surface, else while they cut its roughness)", "--smooth-curvature", &O::smoothing_passes),
      option<O>("crease_angle", within(CurvatureLimits::crease_angle_range, -1), "Dihedral angle in degrees above which an "
                "edge is a crease (0: from the noise, -1: no creases)", "--crease-angle", &O::crease_angle),
      option<O>("smoothing_tolerance", within(CurvatureLimits::smoothing_tolerance_range, 0.01, 0.99), "Automatic smoothing goes on while a run of passes leaves at "
                "most this share of the field's roughness", "", &O::smoothing_tolerance),
  };
  return table;
}

namespace {
// Caps on the answer's size: every chain carries its points, so these bound the document.
constexpr double kMaxCreaseChainsCap = 1000;
constexpr double kMaxVerticesPerSignCap = 1000;
}  // namespace

const OptionTable<FeatureSeedOptions>& feature_seed_option_table() {
  using O = FeatureSeedOptions;
  static const OptionTable<O> table = {
      option<O>("max_crease_chains", within(O::max_crease_chains_range, kEngineEnd, kMaxCreaseChainsCap),
                "Crease chains returned, longest first (0: none)", "--max-chains", &O::max_crease_chains),
      option<O>("min_chain_edges", within(O::min_chain_edges_range, kEngineEnd, 1e6), "Crease chains of fewer edges "
                "are left out", "--min-chain-edges", &O::min_chain_edges),
      option<O>("corner_angle", within(O::corner_angle_range), "A crease chain is split where it turns by more than "
                "this many degrees (180: only where creases meet)", "--corner-angle", &O::corner_angle),
      option<O>("junction_turn", within(O::junction_turn_range), "Where creases meet, a chain goes on through the two "
                "that turn least when they turn by at most this many degrees and clearly less than any other (0: "
                "split at every junction)", "--junction-turn", &O::junction_turn),
      option<O>("max_vertices_per_sign", within(O::max_vertices_per_sign_range, kEngineEnd, kMaxVerticesPerSignCap),
                "Ridge vertices returned, and as many valley vertices, strongest first (0: none)", "--max-seeds",
                &O::max_vertices_per_sign),
      option<O>("spacing", within(O::spacing_range, kEngineEnd, 1000), "Ridge or valley vertices are at least this "
                "many local edge lengths apart", "--seed-spacing", &O::spacing),
      option<O>("crease_clearance", within(O::crease_clearance_range, kEngineEnd, 100), "Ridge or valley vertices "
                "are more than this many rings of edges from a crease or the boundary", "--crease-clearance",
                &O::crease_clearance),
      option<O>("min_strength", within(O::min_strength_range, kEngineEnd, 1000), "A ridge or valley vertex's "
                "curvature is at least this share of the mesh's 90th percentile", "--min-strength", &O::min_strength),
      option<O>("min_signal_to_noise", within(O::min_signal_to_noise_range, kEngineEnd, 1000), "A ridge or valley "
                "vertex bends the surface over the curvature fit by this many times the estimated noise (0: off)",
                "--min-signal-to-noise", &O::min_signal_to_noise),
  };
  return table;
}

}  // namespace featureline
