// Accuracy against known answers (the refined line must never be worse than the initial
// one): the curvature stage's jet fit, noise estimate and creases, and whole lines on smooth
// ridges and valleys at 0-30% noise and on CAD-like creases with tight rounded corners and long
// skinny triangles. Distances are in grid spacings (fields) or outline edge lengths (slabs).
#include <gtest/gtest.h>

#include <cmath>

#include "engine/errors.h"
#include "engine/feature_line.h"
#include "engine/mesh_io.h"
#include "tests/support/accuracy_meshes.h"
#include "tests/support/line_metrics.h"
#include "tests/support/shared_data.h"
#include "tests/support/synthetic_meshes.h"

namespace featureline {
namespace {

using namespace featureline::testing;

TEST(JetCurvature, SphereAndCylinderPrincipalCurvatures) {
  const auto sphere = prepare_mesh(make_icosphere(2.0, 4));
  for (std::uint32_t v = 0; v < sphere->n_vertices(); ++v) {
    EXPECT_NEAR(sphere->curvature().k_max[v], 0.5, 0.01);
    EXPECT_NEAR(sphere->curvature().k_min[v], 0.5, 0.01);
  }
  const auto tube = prepare_mesh(make_cylinder(1.0, 4.0, 40, 64, false));
  for (std::uint32_t v = 64 * 10; v < 64 * 30; ++v) {  // away from the open ends
    EXPECT_NEAR(tube->curvature().k_max[v], 1.0, 0.02);
    EXPECT_NEAR(tube->curvature().k_min[v], 0.0, 0.02);
  }
}

TEST(JetCurvature, NoiseEstimateAndRadiusFollowTheNoise) {
  const auto field = make_ridge_field(61, 0.2, 1, 0.3, 0.25, 0.3);
  const auto clean = prepare_mesh(field.mesh);
  EXPECT_LT(clean->curvature().noise, 0.01);
  EXPECT_NEAR(clean->curvature().radius, 2.0, 0.2);
  // 10% RMS displacement in 3D is 5.8% along the normal; a 6-parameter fit over ~15 points
  // keeps about 80% of it in its residuals.
  const auto noisy = prepare_mesh(with_noise(field.mesh, 0.1, 3));
  EXPECT_NEAR(noisy->curvature().noise, 0.045, 0.01);
  EXPECT_GT(noisy->curvature().radius, 5.0);
  PrepareOptions fixed;
  fixed.curvature.radius = 3;
  EXPECT_EQ(prepare_mesh(with_noise(field.mesh, 0.1, 3), fixed)->curvature().radius, 3.0);
}

TEST(JetCurvature, SlabOutlinesAreConvexCreasesAndNothingElse) {
  for (auto tessellation : {SlabTessellation::skinny, SlabTessellation::fine}) {
    RoundedSlabOptions options;
    options.tessellation = tessellation;
    const auto part = make_rounded_slab(options);
    const auto mesh = prepare_mesh(part.mesh);
    EXPECT_EQ(mesh->curvature().crease_edges, part.top_outline.size() + part.bottom_outline.size());
    const auto& outline = part.top_outline;
    for (std::size_t i = 0; i < outline.size(); ++i) {
      const auto a = outline[i], b = outline[(i + 1) % outline.size()];
      for (auto k = mesh->neighbor_offsets()[a]; k < mesh->neighbor_offsets()[a + 1]; ++k)
        if (mesh->neighbors()[k] == b) {
          EXPECT_EQ(mesh->curvature().crease[k], 1) << "edge " << a << "-" << b;
        }
    }
  }
}

TEST(JetCurvature, OptionsOutOfRangeAreRefused) {
  PrepareOptions options;
  options.curvature.radius = 100;
  EXPECT_THROW(prepare_mesh(make_icosphere(1.0, 2), options), InvalidInputError);
  options.curvature.radius = 0;
  options.curvature.crease_angle = 200;
  EXPECT_THROW(prepare_mesh(make_icosphere(1.0, 2), options), InvalidInputError);
}

TEST(JetCurvature, AutomaticSmoothingFollowsTheNoiseAndTheMeshsFineness) {
  // A fine field (80k triangles) at 20% noise needs many passes; a coarse one (its features
  // span few edges) few: the blur must stay within 1% of the object's size.
  const auto fine = make_ridge_field(201, 0.2, 2, 0.3, 0.25, 0.3);
  const auto noisy = prepare_mesh(with_noise(fine.mesh, 0.2 * fine.spacing / mean_edge_length(fine.mesh), 2));
  EXPECT_GE(noisy->curvature().smoothing_passes, 16);
  // Clean, the same field is an exact surface (estimated noise below 0.005): no pass.
  const auto clean = prepare_mesh(fine.mesh);
  EXPECT_LT(clean->curvature().noise, 0.005);
  EXPECT_EQ(clean->curvature().smoothing_passes, 0);
  const auto coarse = make_ridge_field(51, 0.2, 2, 0.3, 0.25, 0.3);
  EXPECT_LE(prepare_mesh(with_noise(coarse.mesh, 0.2 * coarse.spacing / mean_edge_length(coarse.mesh), 2))->curvature().smoothing_passes, 4);
  // A CAD part without noise keeps its field as fitted.
  EXPECT_EQ(prepare_mesh(make_rounded_slab({}).mesh)->curvature().smoothing_passes, 0);
  // Explicit passes are applied as given; out of range is refused.
  PrepareOptions fixed;
  fixed.curvature.smoothing_passes = 3;
  EXPECT_EQ(prepare_mesh(coarse.mesh, fixed)->curvature().smoothing_passes, 3);
  fixed.curvature.smoothing_passes = 101;
  EXPECT_THROW(prepare_mesh(coarse.mesh, fixed), InvalidInputError);
}

struct LineDistances {
  double initial = 0, refined = 0, refined_max = 0;
};

LineDistances ridge_line(double amplitude, double noise, std::uint64_t seed, int n = 81, const FeatureLineOptions& options = {},
                         double bend = 0.3) {
  const auto field = make_ridge_field(n, 0.2, seed, amplitude, 0.25, bend);
  const auto mesh = prepare_mesh(with_noise(field.mesh, noise * field.spacing / mean_edge_length(field.mesh), seed));
  FeatureLineRequest request;
  request.options = options;
  request.keys = keys_on_crest(field, {-0.8, 0.0, 0.8});
  const auto result = detect_feature_line(*mesh, request);
  const auto refined = crest_distance(field, refined_positions(result));
  return {crest_distance(field, result.initial_points).mean / field.spacing, refined.mean / field.spacing,
          refined.max / field.spacing};
}

TEST(Accuracy, RidgesAndValleysAtEveryNoiseLevelAreNeverWorseThanTheInitialLine) {
  for (double amplitude : {0.3, -0.3})
    for (double noise : {0.0, 0.1, 0.2, 0.3}) {
      const auto d = ridge_line(amplitude, noise, 5);
      SCOPED_TRACE(std::string(amplitude > 0 ? "ridge" : "valley") + " noise " + std::to_string(noise));
      EXPECT_LT(d.refined, d.initial);
      if (noise == 0) {
        EXPECT_LT(d.refined, 0.08);
      }
      if (noise > 0 && noise <= 0.2) {
        EXPECT_LT(d.refined, 0.15);
        EXPECT_LT(d.refined, 0.5 * d.initial);
      }
      EXPECT_LT(d.refined_max, 1.0);
    }
}

TEST(Accuracy, NoisyRidgeOnAFineMeshIsWithinTheTarget) {
  // 80k triangles at 20% noise: the crest spans ~25 edges, so the field's noise must be
  // averaged over many edges and the strip laid out without compounding errors.
  const auto d = ridge_line(0.3, 0.2, 7, 201);
  EXPECT_LT(d.refined, 0.15);
  EXPECT_LT(d.refined, 0.5 * d.initial);
  EXPECT_LT(d.refined_max, 1.0);
}

TEST(CrestLocalization, CleanCrestsBetweenVerticesAreFoundWithinAFewHundredthsOfAnEdge) {
  // Straight and bent Gaussian crests (the straight one at y = 0.1234, between grid rows) on
  // jittered grids of 13k and 80k triangles. The snake alone settles where its force balances its
  // rigidity; the crest fit, inside triangles, must come closer, and never be worse. Distances
  // include the three keys, which the crest fit moves onto the crest too (crest.move_keys).
  FeatureLineOptions snake_only;
  snake_only.crest.enabled = false;
  for (const int n : {81, 201})
    for (const double bend : {0.0, 0.3}) {
      SCOPED_TRACE("n " + std::to_string(n) + " bend " + std::to_string(bend));
      const auto with_crest = ridge_line(0.3, 0, 3, n, {}, bend);
      const auto without = ridge_line(0.3, 0, 3, n, snake_only, bend);
      EXPECT_LT(with_crest.refined, 0.04);
      EXPECT_LE(with_crest.refined, without.refined + 1e-3);
    }
}

TEST(CrestLocalization, FlatFieldsAndTheOptionOffLeaveTheSnakesLine) {
  // A circle of a cylinder has no crest across it: the fit finds the field flat and moves nothing.
  const auto mesh = prepare_mesh(make_cylinder(1.0, 2.0, 12, 48, false));  // ring 6 of 0..12: z = 1
  FeatureLineRequest request;
  request.keys = {6 * 48u, 6 * 48u + 16, 6 * 48u + 32};
  request.closed = true;
  FeatureLineRequest off = request;
  off.options.crest.enabled = false;
  const auto with_crest = detect_feature_line(*mesh, request), without = detect_feature_line(*mesh, off);
  ASSERT_EQ(with_crest.refined.size(), without.refined.size());
  for (std::size_t i = 0; i < with_crest.refined.size(); ++i)
    EXPECT_LT((with_crest.refined[i].position - without.refined[i].position).norm(), 1e-9) << i;
  FeatureLineOptions bad;
  bad.crest.radius = 0.5;
  EXPECT_THROW(check_feature_line_options(bad), InvalidInputError);
}

// Largest distance of the refined line from the slab's top outline, in outline edge lengths.
double max_distance_to_outline(const CadPart& part, const FeatureLineResult& result, double unit) {
  const auto truth = positions_of(part.mesh, part.top_outline);
  double worst = 0;
  for (const auto& p : result.refined) worst = std::max(worst, distance_to_polyline(truth, true, p.position));
  return worst / unit;
}

TEST(Accuracy, CleanCreasesAreFollowedExactlyThroughTightCorners) {
  for (auto tessellation : {SlabTessellation::skinny, SlabTessellation::fine}) {
    RoundedSlabOptions options;
    options.tessellation = tessellation;
    const auto part = make_rounded_slab(options);
    const auto mesh = prepare_mesh(part.mesh);
    const auto& loop = part.top_outline;
    const double unit = (mesh->positions()[loop[1]] - mesh->positions()[loop[0]]).norm();
    // Open line over a quarter of the outline, through the rounded corner at (+a, +b).
    FeatureLineRequest open;
    const std::size_t q = loop.size() / 4;
    open.keys = {loop[q / 2], loop[q], loop[q + q / 2 + 2]};
    const auto line = detect_feature_line(*mesh, open);
    EXPECT_LT(max_distance_to_outline(part, line, unit), 0.02);
    for (const auto& piece : line.piece_reports) EXPECT_EQ(piece.kept, PieceKept::crease);
    // The whole outline as a closed line with four keys.
    FeatureLineRequest closed;
    closed.closed = true;
    for (std::size_t k = 0; k < 4; ++k) closed.keys.push_back(loop[k * loop.size() / 4 + 1]);
    const auto ring = detect_feature_line(*mesh, closed);
    EXPECT_LT(max_distance_to_outline(part, ring, unit), 0.02);
    EXPECT_EQ(ring.initial.vertices.size(), loop.size());
  }
}

TEST(JetCurvature, EveryEdgeOfRealCadCreaseChainsIsACrease) {
  // Chains of edges sharper than 30 degrees (>= 10 edges) on two real CAD meshes: their end
  // edges meet corners or skinny faces whose wings are as sharp as the crease, and must be
  // marked all the same, or lines along them are not kept exactly (unmarked, clean rocker-arm
  // creases were refined 0.035 edge lengths off their exact initial line).
  for (const char* file : {"rocker-arm.obj", "fandisk.off"}) {
    SCOPED_TRACE(file);
    const std::string path = require_shared_mesh(file);
    if (path.empty()) continue;
    const RawMesh raw = read_mesh_file(path);
    const auto mesh = prepare_mesh(raw);
    const auto chains = find_crease_chains(raw, 30, 10);
    ASSERT_FALSE(chains.empty());
    for (const auto& chain : chains)
      for (std::size_t i = 0; i < chain.edges(); ++i) {
        const auto a = chain.vertices[i], b = chain.vertices[(i + 1) % chain.vertices.size()];
        for (auto k = mesh->neighbor_offsets()[a]; k < mesh->neighbor_offsets()[a + 1]; ++k)
          if (mesh->neighbors()[k] == b) {
            EXPECT_NE(mesh->curvature().crease[k], 0) << "edge " << a << "-" << b;
          }
      }
  }
}

TEST(Accuracy, NoisyCreasesAreNeverWorseThanTheInitialLine) {
  RoundedSlabOptions options;
  options.tessellation = SlabTessellation::fine;
  const auto part = make_rounded_slab(options);
  const auto truth = positions_of(part.mesh, part.top_outline);
  const double unit = (truth[1] - truth[0]).norm();
  for (std::uint64_t seed : {1, 2}) {
    const auto mesh = prepare_mesh(with_noise(part.mesh, 0.1 * unit / part.mean_edge_length, seed));
    const auto& loop = part.top_outline;
    FeatureLineRequest request;
    const std::size_t q = loop.size() / 4;
    request.keys = {loop[q / 2], loop[q], loop[q + q / 2 + 2]};
    const auto result = detect_feature_line(*mesh, request);
    const double initial = mean_distance_to_polyline(result.initial_points, truth, true);
    const double refined = mean_distance_to_polyline(refined_positions(result), truth, true);
    EXPECT_LE(refined, initial * 1.05 + 0.005 * unit) << "seed " << seed;
  }
}

// A line along a crease chain as bench_accuracy draws it: keys at its ends and middle, or a third
// of the way round apart on a closed chain.
FeatureLineRequest chain_request(const CreaseChain& chain) {
  const auto& v = chain.vertices;
  const std::size_t n = v.size();
  FeatureLineRequest request;
  request.closed = chain.closed;
  request.keys = chain.closed ? std::vector<std::uint32_t>{v[0], v[n / 3], v[2 * n / 3]}
                              : std::vector<std::uint32_t>{v.front(), v[n / 2], v.back()};
  return request;
}

TEST(Accuracy, NoisyRealCadCreasesAreRefittedCloserToTheTrueCrease) {
  // Every crease chain of the fandisk (keys at its ends and middle) on the mesh with 10% noise:
  // the initial line runs on the noisy crease vertices; the crease fit (engine/crease_fit.h) must
  // bring the lines closer to the clean chain on average (bench_accuracy: 0.89 of the initial
  // distance; keeping the noisy vertices, as before, is 1.0) and make at most one line worse.
  const std::string path = require_shared_mesh("fandisk.off");
  if (path.empty()) return;
  const RawMesh raw = read_mesh_file(path);
  const auto chains = find_crease_chains(raw, 30, 10);
  ASSERT_GE(chains.size(), 10u);
  const auto mesh = prepare_mesh(with_noise(raw, 0.1, 7));
  double initial_sum = 0, refined_sum = 0;
  int worse = 0, fitted = 0;
  for (const auto& chain : chains) {
    const auto truth = positions_of(raw, chain.vertices);
    const auto result = detect_feature_line(*mesh, chain_request(chain));
    for (const auto& piece : result.piece_reports) fitted += piece.kept == PieceKept::crease_fit;
    const double initial = mean_distance_to_polyline(result.initial_points, truth, chain.closed);
    const double refined = mean_distance_to_polyline(refined_positions(result), truth, chain.closed);
    initial_sum += initial;
    refined_sum += refined;
    worse += refined > initial + 0.002 * mean_edge_length(raw);
  }
  EXPECT_GE(fitted, int(chains.size()));  // half the pieces (two per line) or more are crease runs
  EXPECT_LT(refined_sum, 0.95 * initial_sum);
  EXPECT_LE(worse, 1);
}

TEST(Accuracy, LightlyNoisyCreasesWithUnmarkedEdgesAreFittedNotSnaked) {
  // At 2-5% noise the mesh still reads clean (under exact_crease_noise) but the noise unmarks a
  // few edges of the wing nut's and fandisk's creases; the snake took such pieces off their
  // creases (bench_accuracy at 2%: 16 of 189 lines worse than their initial line, the wing nut's
  // 0.030 -> 0.045). Re-fitted as crease runs, the lines keep to their creases.
  int worse = 0, fitted = 0;
  double initial_sum = 0, refined_sum = 0;
  for (const char* name : {"wingnut.obj", "fandisk.off"}) {
    const std::string path = require_shared_mesh(name);
    if (path.empty()) return;
    const RawMesh raw = read_mesh_file(path);
    const auto chains = find_crease_chains(raw, 30, 10);
    for (const double noise : {0.02, 0.05}) {
      const auto mesh = prepare_mesh(with_noise(raw, noise, 7));
      ASSERT_LT(mesh->statistics().noise, FeatureLineOptions{}.exact_crease_noise) << name << " reads clean at " << noise;
      for (const auto& chain : chains) {
        const auto truth = positions_of(raw, chain.vertices);
        const auto result = detect_feature_line(*mesh, chain_request(chain));
        for (const auto& piece : result.piece_reports) fitted += piece.kept == PieceKept::crease_fit;
        const double unit = mean_edge_length(raw);
        const double initial = mean_distance_to_polyline(result.initial_points, truth, chain.closed) / unit;
        const double refined = mean_distance_to_polyline(refined_positions(result), truth, chain.closed) / unit;
        initial_sum += initial, refined_sum += refined;
        worse += refined > initial + 0.002;
      }
    }
  }
  // Measured: 62 lines, 1 worse, 5 pieces fitted, summed 1.695 against 1.742 initially (snaked:
  // 4 worse, none fitted, 1.784).
  EXPECT_GT(fitted, 0);
  EXPECT_LE(worse, 1);
  EXPECT_LT(refined_sum, initial_sum);
}

TEST(Accuracy, KeysOnANoisyCreaseRunAreFittedWithItUnlessKeptInPlace) {
  // The fandisk's chains at 10% noise again: a line whose pieces are all crease runs is fitted as
  // one run, its keys noisy vertices like the rest (crest.move_keys), so the line passes beside
  // them and lies nearer the clean chains than with every key kept on its vertex.
  const std::string path = require_shared_mesh("fandisk.off");
  if (path.empty()) return;
  const RawMesh raw = read_mesh_file(path);
  const auto chains = find_crease_chains(raw, 30, 10);
  const auto mesh = prepare_mesh(with_noise(raw, 0.1, 7));
  double moved_sum = 0, kept_sum = 0;
  std::size_t keys_moved = 0, keys = 0;
  for (const auto& chain : chains) {
    const auto truth = positions_of(raw, chain.vertices);
    FeatureLineRequest request = chain_request(chain);
    const auto moved = detect_feature_line(*mesh, request);
    request.options.crest.move_keys = false;
    const auto kept = detect_feature_line(*mesh, request);
    moved_sum += mean_distance_to_polyline(refined_positions(moved), truth, chain.closed);
    kept_sum += mean_distance_to_polyline(refined_positions(kept), truth, chain.closed);
    for (const double d : kept.key_moves) EXPECT_EQ(d, 0.0) << "chain from vertex " << chain.vertices.front();
    const bool all_crease_runs = std::all_of(moved.piece_reports.begin(), moved.piece_reports.end(),
                                             [](const PieceReport& p) { return p.kept == PieceKept::crease_fit; });
    if (!all_crease_runs || chain.closed) continue;
    for (const double d : moved.key_moves) keys_moved += d > 0, ++keys;
  }
  EXPECT_GT(keys, 10u);
  EXPECT_GT(double(keys_moved), 0.8 * double(keys));
  // Measured: 50 of 57 keys moved (the rest further than crease_fit.max_shift from the fit);
  // summed mean distances 0.0467 against 0.0475 model units.
  EXPECT_LT(moved_sum, kept_sum);
}

// Lines through the ends and middles of a CAD part's crease chains at 10% noise (bench_accuracy's
// seeds 1-3): the farthest point of any line and the lines' mean distance, in mean edge lengths.
struct NoisyChainLines {
  std::size_t chains = 0;
  double worst = 0, mean = 0;
};

NoisyChainLines noisy_chain_lines(const std::string& path, InitialMethod method = InitialMethod::feature_path) {
  NoisyChainLines out;
  const RawMesh raw = read_mesh_file(path);
  const auto chains = find_crease_chains(raw, 30, 10);
  out.chains = chains.size();
  const double unit = mean_edge_length(raw);
  double sum = 0;
  for (std::uint64_t seed : {1, 2, 3}) {
    const auto mesh = prepare_mesh(with_noise(raw, 0.1, 1000003ull * seed + 7));
    for (const auto& chain : chains) {
      const auto truth = positions_of(raw, chain.vertices);
      FeatureLineRequest request = chain_request(chain);
      request.options.initial.method = method;
      const auto result = detect_feature_line(*mesh, request);
      double refined = 0;
      for (const auto& p : result.refined) {
        const double d = distance_to_polyline(truth, chain.closed, p.position) / unit;
        refined += d, out.worst = std::max(out.worst, d);
      }
      sum += refined / double(result.refined.size());
    }
  }
  out.mean = sum / double(3 * chains.size());
  return out;
}

TEST(Accuracy, NoisyRockerArmLinesStayOnTheirCreases) {
  // Beside a convex crease the noise bends short runs of concave edges past the crease angle,
  // and jet fits stopped at them as at the crease's own broken-off bits drew one line an edge
  // length off its crease; where the crease's own runs read short, its unmarked edges were
  // chords and a path left it.
  const std::string path = require_shared_mesh("rocker-arm.obj");
  if (path.empty()) return;
  const NoisyChainLines lines = noisy_chain_lines(path);
  ASSERT_EQ(lines.chains, 3u);
  // Measured 0.533 and a mean of 0.088 (1.033 and 0.108 with the concave runs bounding fits;
  // 0.695 and 0.098 while runs were measured against their vertices' local edges, which the
  // long sides of skinny faces inflate, so that the crease's broken runs all read short).
  EXPECT_LT(lines.worst, 0.6);
  EXPECT_LT(lines.mean, 0.095);
}

TEST(Accuracy, NoisyWingNutLinesDoNotDetourOffTheirCreases) {
  // The wing nut's chains run along skinny faces a quarter of its mean edge wide: noise unmarks
  // some of a chain's edges, and with every unmarked edge between crease vertices read as a
  // chord across a face (no feature), one line's path went out along noise-marked long edges
  // and back, 1.8 mean edges off its crease.
  const std::string path = require_shared_mesh("wingnut.obj");
  if (path.empty()) return;
  const NoisyChainLines lines = noisy_chain_lines(path);
  ASSERT_EQ(lines.chains, 12u);
  // Measured 0.864 and a mean of 0.069 (1.792 and 0.089 with every such edge a chord).
  EXPECT_LT(lines.worst, 1.2);
  EXPECT_LT(lines.mean, 0.08);
}

TEST(Accuracy, NoisyWingNutLineTakesItsCreasesUnmarkedEdges) {
  // Noise (bench_accuracy's seed 5) bends two edges of this chain just under the crease angle or
  // leaves them with wings as sharp, and pushes the vertex between them into the part, where its
  // field reads a dent: with those edges weighed by their ends' field, the line took a parallel
  // crease 3 crease edges off. On a noisy mesh an unmarked edge's fold weighs as a feature from
  // kFoldFeatureShare of the crease angle.
  const std::string path = require_shared_mesh("wingnut.obj");
  if (path.empty()) return;
  const RawMesh raw = read_mesh_file(path);
  const auto chains = find_crease_chains(raw, 30, 10);
  const auto chain = std::find_if(chains.begin(), chains.end(), [](const CreaseChain& c) {
    return !c.closed && c.vertices.front() == 353 && c.vertices.back() == 644;
  });
  ASSERT_NE(chain, chains.end()) << "the wing nut's chain from vertex 353 to 644";
  const auto mesh = prepare_mesh(with_noise(raw, 0.1, 1000003ull * 5 + 7));
  const auto result = detect_feature_line(*mesh, chain_request(*chain));
  const auto truth = positions_of(raw, chain->vertices);
  const double unit = mean_edge_length(raw);
  double worst = 0;
  for (const auto& p : result.refined) worst = std::max(worst, distance_to_polyline(truth, false, p.position) / unit);
  // Measured 0.114 mean edge lengths (0.747 with those edges weighed by their ends' field).
  EXPECT_LT(worst, 0.3);
}

TEST(Accuracy, NoisyFandiskMarchingKeepsToItsCreases) {
  // The paper's marching search, between keys on creases, drops candidates across chords; on a
  // noisy mesh a crease's own unmarked edges are no chords (CurvatureField::chord), else the
  // march was turned off the crease where noise unmarked it.
  const std::string path = require_shared_mesh("fandisk.off");
  if (path.empty()) return;
  const NoisyChainLines lines = noisy_chain_lines(path, InitialMethod::marching);
  ASSERT_EQ(lines.chains, 19u);
  // Measured 0.898 and a mean of 0.069 (21.2 and 0.239 with every unmarked edge between crease
  // vertices a chord: one march strayed 21 mean edges off its crease).
  EXPECT_LT(lines.worst, 1.5);
  EXPECT_LT(lines.mean, 0.1);
}

}  // namespace
}  // namespace featureline
