// Feature seeds against known answers: a subdivided cube's 12 edges (chains split at its 8
// corners), the rounded slab's two outline loops (their exact polygon length), a Gaussian ridge's
// crest and its two valleys at the feet, a noisy plane with no seed at all, and fandisk's crease
// network (every chain a run of consecutive crease edges; together they cover every crease edge
// once). Plus the invariants: the same answer every run and under scaling, options checked, JSON
// finite and shaped as documented.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>

#include "api/feature_seeds_json.h"
#include "api/options_table.h"
#include "engine/errors.h"
#include "engine/feature_seeds.h"
#include "engine/mesh_io.h"
#include "tests/support/accuracy_meshes.h"
#include "tests/support/shared_data.h"
#include "tests/support/synthetic_meshes.h"

namespace featureline {
namespace {

using namespace featureline::testing;

// The crease flag of edge a -> b in the prepared mesh (0 when not an edge).
int crease_of(const PreparedMesh& mesh, std::uint32_t a, std::uint32_t b) {
  for (auto k = mesh.neighbor_offsets()[a]; k < mesh.neighbor_offsets()[a + 1]; ++k)
    if (mesh.neighbors()[k] == b) return mesh.curvature().crease[k];
  return 0;
}

int crease_degree(const PreparedMesh& mesh, std::uint32_t v, int sign) {
  int degree = 0;
  for (auto k = mesh.neighbor_offsets()[v]; k < mesh.neighbor_offsets()[v + 1]; ++k) degree += mesh.curvature().crease[k] == sign;
  return degree;
}

// Every chain is a run of consecutive crease edges of its sign, whose interior vertices have
// exactly two such edges and turn by at most the corner angle, and whose open ends are split
// vertices; closed chains close with a crease edge too.
void expect_chains_follow_creases(const PreparedMesh& mesh, const FeatureSeeds& seeds, const FeatureSeedOptions& options) {
  const auto& P = mesh.positions();
  for (std::size_t c = 0; c < seeds.crease_chains.size(); ++c) {
    const auto& chain = seeds.crease_chains[c];
    const int sign = int(chain.sign);
    const auto& V = chain.vertices;
    ASSERT_GE(V.size(), 2u);
    EXPECT_GE(chain.edges(), std::size_t(options.min_chain_edges));
    double length = 0;
    for (std::size_t i = 0; i < chain.edges(); ++i) {
      const auto a = V[i], b = V[(i + 1) % V.size()];
      EXPECT_EQ(crease_of(mesh, a, b), sign) << "chain " << c << " edge " << i << " (" << a << ", " << b << ")";
      length += (P[b] - P[a]).norm();
    }
    EXPECT_NEAR(chain.length, length, 1e-9 * length);
    auto turn_degrees = [&](std::uint32_t before, std::uint32_t at, std::uint32_t after) {
      const Eigen::Vector3d d0 = P[at] - P[before], d1 = P[after] - P[at];
      return std::atan2(d0.cross(d1).norm(), d0.dot(d1)) * 180 / 3.14159265358979323846;
    };
    for (std::size_t i = 1; i + 1 < V.size(); ++i) {
      // Through a junction only along its straightest pair, within the junction turn.
      const bool junction = crease_degree(mesh, V[i], sign) > 2;
      EXPECT_TRUE(crease_degree(mesh, V[i], sign) == 2 || (junction && options.junction_turn > 0))
          << "chain " << c << " vertex " << V[i];
      EXPECT_LE(turn_degrees(V[i - 1], V[i], V[i + 1]), (junction ? options.junction_turn : options.corner_angle) + 1e-9);
    }
    if (!chain.closed) {
      EXPECT_LT(V.front(), V.back()) << "open chains run from their lower-id end";
      for (auto [end, inner] : {std::pair{V.front(), V[1]}, std::pair{V.back(), V[V.size() - 2]}}) {
        const int degree = crease_degree(mesh, end, sign);
        if (degree == 2) {
          // A corner: its other crease edge turns sharply from this one.
          std::uint32_t other = 0;
          for (auto k = mesh.neighbor_offsets()[end]; k < mesh.neighbor_offsets()[end + 1]; ++k)
            if (mesh.curvature().crease[k] == sign && mesh.neighbors()[k] != inner) other = mesh.neighbors()[k];
          EXPECT_GT(turn_degrees(inner, end, other), options.corner_angle) << "chain " << c << " end " << end;
        }
      }
    }
  }
}

// ---------------------------------------------------------------------------------
// Crease chains
// ---------------------------------------------------------------------------------

TEST(FeatureSeeds, CubeHasTwelveEdgeChainsMeetingAtEightCorners) {
  const int n = 6;
  const auto mesh = prepare_mesh(make_subdivided_cube(n));
  ASSERT_EQ(mesh->curvature().crease_edges, std::size_t(12 * n));
  const FeatureSeeds seeds = find_feature_seeds(*mesh);
  ASSERT_EQ(seeds.crease_chains.size(), 12u);
  std::set<std::uint32_t> ends;
  for (const auto& chain : seeds.crease_chains) {
    EXPECT_FALSE(chain.closed);
    EXPECT_EQ(chain.sign, FeatureSign::ridge);
    EXPECT_EQ(chain.edges(), std::size_t(n));
    EXPECT_NEAR(chain.length, 1.0, 1e-12);
    EXPECT_NEAR(chain.dihedral_degrees, 90.0, 1e-9);
    ends.insert(chain.vertices.front());
    ends.insert(chain.vertices.back());
  }
  EXPECT_EQ(ends.size(), 8u);  // the corners, three chains each
  EXPECT_EQ(seeds.stats.junctions, 8u);
  EXPECT_EQ(seeds.stats.corners, 0u);
  EXPECT_EQ(seeds.stats.crease_chains, 12u);
  // Flat faces: no smooth ridge or valley anywhere.
  EXPECT_TRUE(seeds.ridge_vertices.empty());
  EXPECT_TRUE(seeds.valley_vertices.empty());
  expect_chains_follow_creases(*mesh, seeds, {});

  FeatureSeedOptions options;
  options.min_chain_edges = n + 1;  // every chain is too short
  const FeatureSeeds none = find_feature_seeds(*mesh, options);
  EXPECT_TRUE(none.crease_chains.empty());
  EXPECT_EQ(none.stats.short_chains, 12u);
  options = {};
  options.max_crease_chains = 5;
  const FeatureSeeds capped = find_feature_seeds(*mesh, options);
  EXPECT_EQ(capped.crease_chains.size(), 5u);
  EXPECT_EQ(capped.stats.crease_chains, 12u);
  for (std::size_t i = 0; i < 5; ++i) EXPECT_EQ(capped.crease_chains[i].vertices, seeds.crease_chains[i].vertices);
}

TEST(FeatureSeeds, SlabOutlinesAreTwoClosedChainsOfTheirPolygonLength) {
  for (auto tessellation : {SlabTessellation::skinny, SlabTessellation::fine}) {
    RoundedSlabOptions o;
    o.tessellation = tessellation;
    const CadPart part = make_rounded_slab(o);
    const auto mesh = prepare_mesh(part.mesh);
    const FeatureSeeds seeds = find_feature_seeds(*mesh);
    // The outline turns by 90/4 degrees at arc vertices, below the 60-degree corner angle.
    ASSERT_EQ(seeds.crease_chains.size(), 2u);
    const double perimeter = 4 * (o.half_x - o.corner_radius) + 4 * (o.half_y - o.corner_radius) +
                             4 * o.corner_segments * 2 * o.corner_radius * std::sin(3.14159265358979323846 / (4 * o.corner_segments));
    for (const auto& chain : seeds.crease_chains) {
      EXPECT_TRUE(chain.closed);
      EXPECT_EQ(chain.sign, FeatureSign::ridge);
      EXPECT_NEAR(chain.length, perimeter, 1e-12);
      EXPECT_NEAR(chain.dihedral_degrees, 90.0, 1e-9);
      EXPECT_EQ(chain.vertices.front(), *std::min_element(chain.vertices.begin(), chain.vertices.end()));
    }
    EXPECT_TRUE(same_cycle(seeds.crease_chains[0].vertices, part.bottom_outline) ||
                same_cycle(seeds.crease_chains[0].vertices, part.top_outline));
    EXPECT_TRUE(same_cycle(seeds.crease_chains[1].vertices, part.bottom_outline) ||
                same_cycle(seeds.crease_chains[1].vertices, part.top_outline));
    expect_chains_follow_creases(*mesh, seeds, {});

    // At 20 degrees the arcs' interior vertices (turning by 22.5 degrees; the tangent points by
    // 11.25) are corners: per loop 4 sides with an arc edge at each end and the 2 single edges
    // between an arc's 3 corners, 12 open chains per loop.
    FeatureSeedOptions corners;
    corners.corner_angle = 20;
    corners.min_chain_edges = 1;
    const FeatureSeeds split = find_feature_seeds(*mesh, corners);
    const std::size_t arc_corners = std::size_t(o.corner_segments) - 1;
    EXPECT_EQ(split.crease_chains.size(), 2 * (4 + 4 * (arc_corners - 1)));
    EXPECT_EQ(split.stats.corners, 2 * 4 * arc_corners);
    for (const auto& chain : split.crease_chains) EXPECT_FALSE(chain.closed);
    expect_chains_follow_creases(*mesh, split, corners);
  }
}

TEST(FeatureSeeds, FandiskChainsAreRunsOfConsecutiveCreaseEdgesCoveringEachOnce) {
  const auto mesh = prepare_mesh(read_mesh_file(require_shared_mesh("fandisk.off")));
  const FeatureSeeds seeds = find_feature_seeds(*mesh);
  ASSERT_FALSE(seeds.crease_chains.empty());
  expect_chains_follow_creases(*mesh, seeds, {});
  for (std::size_t i = 1; i < seeds.crease_chains.size(); ++i)
    EXPECT_GE(seeds.crease_chains[i - 1].length, seeds.crease_chains[i].length);
  bool ridge = false, valley = false;
  for (const auto& chain : seeds.crease_chains) {
    ridge |= chain.sign == FeatureSign::ridge;
    valley |= chain.sign == FeatureSign::valley;
    EXPECT_GT(chain.dihedral_degrees, mesh->curvature().crease_angle * 0.5);
  }
  EXPECT_TRUE(ridge && valley);  // fandisk has convex and concave creases

  // With nothing left out, the chains partition the crease edges: each edge in exactly one.
  FeatureSeedOptions all;
  all.min_chain_edges = 1;
  all.max_crease_chains = 1000;
  const FeatureSeeds every = find_feature_seeds(*mesh, all);
  ASSERT_EQ(every.crease_chains.size(), every.stats.crease_chains);
  std::set<std::pair<std::uint32_t, std::uint32_t>> edges;
  for (const auto& chain : every.crease_chains)
    for (std::size_t i = 0; i < chain.edges(); ++i) {
      const auto a = chain.vertices[i], b = chain.vertices[(i + 1) % chain.vertices.size()];
      EXPECT_TRUE(edges.insert({std::min(a, b), std::max(a, b)}).second) << "edge " << a << "-" << b << " twice";
    }
  EXPECT_EQ(edges.size(), mesh->curvature().crease_edges);
  expect_chains_follow_creases(*mesh, every, all);
  EXPECT_EQ(every.stats.short_chains, 0u);
  EXPECT_EQ(seeds.stats.crease_chains + seeds.stats.short_chains, every.stats.crease_chains);
}

// The mean over `truth`'s chains of the largest share of a chain's vertices that one chain of
// `found` (of the same sign) holds: 1 when every true chain is found whole.
double mean_best_cover(const std::vector<CreaseChainSeed>& truth, const std::vector<CreaseChainSeed>& found) {
  std::map<std::uint32_t, std::vector<std::size_t>> chains_at;
  for (std::size_t i = 0; i < found.size(); ++i)
    for (const auto v : found[i].vertices) chains_at[v].push_back(i);
  double sum = 0;
  for (const auto& t : truth) {
    std::map<std::size_t, std::size_t> held;
    std::size_t best = 0;
    for (const auto v : t.vertices)
      if (const auto it = chains_at.find(v); it != chains_at.end())
        for (const auto i : it->second)
          if (found[i].sign == t.sign) best = std::max(best, ++held[i]);
    sum += double(best) / double(t.vertices.size());
  }
  return truth.empty() ? 0.0 : sum / double(truth.size());
}

TEST(FeatureSeeds, ChainsGoOnThroughJunctionsAlongTheirStraightestPair) {
  // The wing nut's creases meet in T's: the straight crease through one is a single chain.
  const auto mesh = prepare_mesh(read_mesh_file(require_shared_mesh("wingnut.obj")));
  FeatureSeedOptions split, through;
  split.junction_turn = 0;
  split.max_crease_chains = through.max_crease_chains = 1000;
  const FeatureSeeds a = find_feature_seeds(*mesh, split), b = find_feature_seeds(*mesh, through);
  expect_chains_follow_creases(*mesh, a, split);
  expect_chains_follow_creases(*mesh, b, through);
  EXPECT_EQ(a.stats.junctions, b.stats.junctions);
  EXPECT_LT(b.crease_chains.size(), a.crease_chains.size());
  EXPECT_GT(b.crease_chains.front().edges(), a.crease_chains.front().edges());
  std::size_t passed = 0;
  for (const auto& chain : b.crease_chains)
    for (std::size_t i = 1; i + 1 < chain.vertices.size(); ++i) passed += crease_degree(*mesh, chain.vertices[i], int(chain.sign)) > 2;
  EXPECT_GT(passed, 0u);
}

TEST(FeatureSeeds, NoiseMarkingEdgesBesideACreaseDoesNotCutItsChain) {
  // At 10% noise some edges beside the fandisk's creases read as creases too, and a chain split
  // at every junction loses a true crease's run there (per clean chain of >= 10 edges, the share
  // one noisy chain holds: 0.94); going on through the straightest pair keeps it (0.997).
  const RawMesh raw = read_mesh_file(require_shared_mesh("fandisk.off"));
  FeatureSeedOptions split, through;
  split.junction_turn = 0;
  split.max_crease_chains = through.max_crease_chains = 1000;
  std::vector<CreaseChainSeed> truth;
  for (auto& chain : find_feature_seeds(*prepare_mesh(raw), split).crease_chains)
    if (chain.edges() >= 10) truth.push_back(std::move(chain));
  ASSERT_GE(truth.size(), 15u);
  const auto noisy = prepare_mesh(with_noise(raw, 0.1, 1000003ull * 1 + 7));
  const FeatureSeeds a = find_feature_seeds(*noisy, split), b = find_feature_seeds(*noisy, through);
  expect_chains_follow_creases(*noisy, b, through);
  EXPECT_LT(mean_best_cover(truth, a.crease_chains), 0.96);
  EXPECT_GT(mean_best_cover(truth, b.crease_chains), 0.98);
}

// ---------------------------------------------------------------------------------
// Ridge and valley vertices
// ---------------------------------------------------------------------------------

TEST(FeatureSeeds, GaussianRidgeSeedsLieOnTheCrestAndValleysAtItsFeet) {
  // z = 0.3 exp(-(d/0.25)^2): the crest d = 0 is the ridge; the profile's curvature is most
  // negative (a valley) at |d| = 0.25 sqrt(1.5) = 0.31 in the flat-profile approximation.
  const auto field = make_ridge_field(61, 0.2, 1, 0.3, 0.25, 0.3);
  const auto mesh = prepare_mesh(field.mesh);
  const FeatureSeeds seeds = find_feature_seeds(*mesh);
  EXPECT_TRUE(seeds.crease_chains.empty());
  ASSERT_GE(seeds.ridge_vertices.size(), 5u);
  const double spacing = 8 * field.spacing;  // the default suppression radius, about
  for (const auto& seed : seeds.ridge_vertices) {
    const auto& p = mesh->positions()[seed.vertex];
    EXPECT_LE(distance_to_crest(field, p.x(), p.y()), 1.0 * field.spacing) << "vertex " << seed.vertex;
    EXPECT_GT(seed.curvature, 0);
    EXPECT_GE(seed.strength, 1.0);
    ASSERT_TRUE(seed.direction.has_value());
    // Along the crest y = 0.3 sin(pi x / 2) + 0.1234: slope 0.15 pi cos(pi x / 2).
    const Eigen::Vector3d tangent = Eigen::Vector3d(1, 0.15 * 3.14159265358979323846 * std::cos(3.14159265358979323846 * p.x() / 2), 0).normalized();
    EXPECT_GT(std::abs(seed.direction->dot(tangent)), std::cos(15 * 3.14159265358979323846 / 180)) << "vertex " << seed.vertex;
  }
  for (std::size_t i = 0; i < seeds.ridge_vertices.size(); ++i)
    for (std::size_t j = 0; j < i; ++j) {
      EXPECT_LE(seeds.ridge_vertices[i].strength, seeds.ridge_vertices[j].strength);
      EXPECT_GE((mesh->positions()[seeds.ridge_vertices[i].vertex] - mesh->positions()[seeds.ridge_vertices[j].vertex]).norm(),
                0.7 * spacing);
    }
  ASSERT_GE(seeds.valley_vertices.size(), 4u);
  for (const auto& seed : seeds.valley_vertices) {
    const auto& p = mesh->positions()[seed.vertex];
    const double d = distance_to_crest(field, p.x(), p.y());
    EXPECT_GT(d, 0.2) << "vertex " << seed.vertex;
    EXPECT_LT(d, 0.45) << "vertex " << seed.vertex;
    EXPECT_LT(seed.curvature, 0);
  }
}

TEST(FeatureSeeds, NoisyPlaneHasNoSeedsButANoisyRidgeKeepsItsCrest) {
  for (double noise : {0.05, 0.1, 0.2}) {
    const auto plane = prepare_mesh(with_noise(make_plane_grid(61, 0.2, 1), noise, 5));
    const FeatureSeeds seeds = find_feature_seeds(*plane);
    EXPECT_TRUE(seeds.ridge_vertices.empty()) << "noise " << noise << ": " << seeds.ridge_vertices.size();
    EXPECT_TRUE(seeds.valley_vertices.empty()) << "noise " << noise << ": " << seeds.valley_vertices.size();
    EXPECT_GT(seeds.stats.noise_floor_strength, 1.0) << "noise " << noise;
  }
  // The same ridge under noise, on differently jittered grids: every ridge seed stays within a
  // grid spacing of the crest (the noise moves vertices by up to about a third of one).
  for (double noise : {0.1, 0.2, 0.3})
    for (std::uint64_t seed : {1, 2, 3}) {
      const auto field = make_ridge_field(61, 0.2, seed, 0.3, 0.25, 0.3);
      const auto noisy = prepare_mesh(with_noise(field.mesh, noise, seed + 10));
      const FeatureSeeds seeds = find_feature_seeds(*noisy);
      EXPECT_GE(seeds.ridge_vertices.size(), 3u) << "noise " << noise << ", grid " << seed;
      for (const auto& s : seeds.ridge_vertices) {
        const auto& p = noisy->positions()[s.vertex];
        EXPECT_LE(distance_to_crest(field, p.x(), p.y()), field.spacing)
            << "noise " << noise << ", grid " << seed << ", vertex " << s.vertex;
      }
    }
}

// ---------------------------------------------------------------------------------
// Invariants, options, JSON
// ---------------------------------------------------------------------------------

TEST(FeatureSeeds, SameAnswerEveryRunAndUnderScaling) {
  const auto field = make_ridge_field(41, 0.2, 3, 0.3, 0.25, 0.3);
  RoundedSlabOptions o;
  o.tessellation = SlabTessellation::fine;
  const std::vector<RawMesh> raws{field.mesh, make_rounded_slab(o).mesh};
  for (const RawMesh& raw : raws) {
    const auto mesh = prepare_mesh(raw);
    const FeatureSeeds a = find_feature_seeds(*mesh), b = find_feature_seeds(*mesh);
    auto ids = [](const std::vector<FeatureVertexSeed>& seeds) {
      std::vector<std::uint32_t> out;
      for (const auto& s : seeds) out.push_back(s.vertex);
      return out;
    };
    auto chains = [](const FeatureSeeds& s) {
      std::vector<std::vector<std::uint32_t>> out;
      for (const auto& c : s.crease_chains) out.push_back(c.vertices);
      return out;
    };
    EXPECT_EQ(chains(a), chains(b));
    EXPECT_EQ(ids(a.ridge_vertices), ids(b.ridge_vertices));
    EXPECT_EQ(ids(a.valley_vertices), ids(b.valley_vertices));
    const bool symmetric = &raw != &raws[0];
    for (double s : {1e-6, 1e6}) {
      const auto big = prepare_mesh(scaled(raw, s));
      const FeatureSeeds c = find_feature_seeds(*big);
      EXPECT_EQ(chains(c), chains(a)) << "scale " << s;
      if (!symmetric) {
        EXPECT_EQ(ids(c.ridge_vertices), ids(a.ridge_vertices)) << "scale " << s;
        EXPECT_EQ(ids(c.valley_vertices), ids(a.valley_vertices)) << "scale " << s;
      }
      // The slab's mirror-image vertices tie exactly in theory, so rounding picks among them:
      // the same strengths, not necessarily the same vertices.
      ASSERT_EQ(c.ridge_vertices.size(), a.ridge_vertices.size()) << "scale " << s;
      ASSERT_EQ(c.valley_vertices.size(), a.valley_vertices.size()) << "scale " << s;
      for (std::size_t i = 0; i < a.ridge_vertices.size(); ++i)
        EXPECT_NEAR(c.ridge_vertices[i].strength, a.ridge_vertices[i].strength, 1e-9 * a.ridge_vertices[i].strength);
      for (std::size_t i = 0; i < a.valley_vertices.size(); ++i)
        EXPECT_NEAR(c.valley_vertices[i].strength, a.valley_vertices[i].strength, 1e-9 * a.valley_vertices[i].strength);
      for (std::size_t i = 0; i < c.crease_chains.size() && i < a.crease_chains.size(); ++i)
        EXPECT_NEAR(c.crease_chains[i].length, s * a.crease_chains[i].length, 1e-9 * s * a.crease_chains[i].length);
    }
  }
}

TEST(FeatureSeeds, OptionsOutOfRangeAreRefused) {
  const auto mesh = prepare_mesh(make_subdivided_cube(2));
  auto refused = [&](auto change) {
    FeatureSeedOptions o;
    change(o);
    EXPECT_THROW(find_feature_seeds(*mesh, o), InvalidInputError);
  };
  refused([](FeatureSeedOptions& o) { o.max_crease_chains = -1; });
  refused([](FeatureSeedOptions& o) { o.min_chain_edges = 0; });
  refused([](FeatureSeedOptions& o) { o.corner_angle = 181; });
  refused([](FeatureSeedOptions& o) { o.junction_turn = -1; });
  refused([](FeatureSeedOptions& o) { o.spacing = NAN; });
  refused([](FeatureSeedOptions& o) { o.min_strength = -1; });
  refused([](FeatureSeedOptions& o) { o.min_signal_to_noise = HUGE_VAL; });
  FeatureSeedOptions none;
  none.max_crease_chains = 0;
  none.max_vertices_per_sign = 0;
  const FeatureSeeds empty = find_feature_seeds(*mesh, none);
  EXPECT_TRUE(empty.crease_chains.empty() && empty.ridge_vertices.empty() && empty.valley_vertices.empty());
}

TEST(FeatureSeeds, OptionTableRoundTripsAndStaysInsideTheEngine) {
  const auto& table = feature_seed_option_table();
  EXPECT_EQ(table.size(), 9u);
  const nlohmann::json defaults = options_json(table, FeatureSeedOptions{});
  EXPECT_EQ(defaults["max_crease_chains"], 64);
  EXPECT_EQ(defaults["corner_angle"], 60.0);
  EXPECT_EQ(defaults["junction_turn"], 45.0);
  EXPECT_NO_THROW(check_options(table, FeatureSeedOptions{}, "options"));
  for (const auto& field : table) {
    ASSERT_TRUE(field.spec.engine_range.has_value()) << field.spec.name;
    EXPECT_TRUE(field.spec.engine_range->contains(field.spec.minimum)) << field.spec.name;
    EXPECT_TRUE(field.spec.engine_range->contains(field.spec.maximum)) << field.spec.name;
    EXPECT_FALSE(field.spec.cli_flag.empty()) << field.spec.name;
    // Each row writes its own member: the maximum goes in and comes back out.
    FeatureSeedOptions o;
    field.write(o, check_option_value(field.spec, field.spec.maximum, field.spec.name));
    EXPECT_EQ(field.read(o).get<double>(), field.spec.maximum) << field.spec.name;
    EXPECT_NO_THROW(check_feature_seed_options(o)) << field.spec.name;
  }
  FeatureSeedOptions parsed;
  apply_options(table, {{"spacing", 4}, {"max_vertices_per_sign", 3}}, "options", parsed);
  EXPECT_EQ(parsed.spacing, 4);
  EXPECT_EQ(parsed.max_vertices_per_sign, 3);
  EXPECT_THROW(apply_options(table, {{"spacingg", 4}}, "options", parsed), InvalidInputError);
  EXPECT_THROW(apply_options(table, {{"max_crease_chains", 1001}}, "options", parsed), InvalidInputError);
}

void expect_finite_numbers(const nlohmann::json& j, const std::string& where) {
  if (j.is_number()) {
    EXPECT_TRUE(std::isfinite(j.get<double>())) << where;
  }
  if (j.is_array() || j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it) expect_finite_numbers(*it, where + "/" + (j.is_object() ? it.key() : "#"));
  }
}

TEST(FeatureSeeds, JsonHasTheDocumentedShapeAndFiniteNumbers) {
  for (const RawMesh& raw : {make_subdivided_cube(4), make_ridge_field(41, 0.2, 3, 0.3, 0.25, 0.3).mesh}) {
    const auto mesh = prepare_mesh(raw);
    const FeatureSeeds seeds = find_feature_seeds(*mesh);
    const nlohmann::json j = feature_seeds_to_json(*mesh, seeds);
    expect_finite_numbers(j, "");
    ASSERT_EQ(j["crease_chains"].size(), seeds.crease_chains.size());
    for (std::size_t i = 0; i < seeds.crease_chains.size(); ++i) {
      const auto& c = j["crease_chains"][i];
      EXPECT_EQ(c["vertices"].size(), c["points"].size());
      EXPECT_EQ(c["vertices"][0], seeds.crease_chains[i].vertices[0]);
      EXPECT_EQ(c["points"][0][2], mesh->positions()[seeds.crease_chains[i].vertices[0]].z());
      EXPECT_EQ(c["sign"], "ridge");
      EXPECT_EQ(c["edges"], seeds.crease_chains[i].edges());
      for (const char* key : {"closed", "length", "dihedral_deg"}) EXPECT_TRUE(c.contains(key)) << key;
    }
    ASSERT_EQ(j["ridge_vertices"].size(), seeds.ridge_vertices.size());
    ASSERT_EQ(j["valley_vertices"].size(), seeds.valley_vertices.size());
    for (std::size_t i = 0; i < seeds.ridge_vertices.size(); ++i) {
      const auto& r = j["ridge_vertices"][i];
      EXPECT_EQ(r["vertex"], seeds.ridge_vertices[i].vertex);
      EXPECT_EQ(r["point"].size(), 3u);
      EXPECT_TRUE(r["direction"].is_null() || r["direction"].size() == 3u);
      for (const char* key : {"curvature", "strength"}) EXPECT_TRUE(r[key].is_number()) << key;
    }
    for (const char* key : {"crease_chains", "short_chains", "junctions", "corners", "ridge_candidates",
                            "valley_candidates", "noise_floor_strength"})
      EXPECT_TRUE(j["stats"][key].is_number()) << key;
    EXPECT_TRUE(j["stats"]["timings_ms"]["features"].is_number());
  }
}

// The largest shared scan: the time is printed for the record (docs' figures), the answer checked.
TEST(FeatureSeeds, IgeaIsFastAndSpreadsItsSeeds) {
  const auto mesh = prepare_mesh(read_mesh_file(require_shared_mesh("igea.ply")));
  const auto start = std::chrono::steady_clock::now();
  const FeatureSeeds seeds = find_feature_seeds(*mesh);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  std::printf("igea: %zu vertices, find_feature_seeds %.1f ms; %zu chains, %zu ridge and %zu valley vertices "
              "(candidates %zu, %zu)\n",
              mesh->n_vertices(), ms, seeds.crease_chains.size(), seeds.ridge_vertices.size(), seeds.valley_vertices.size(),
              seeds.stats.ridge_candidates, seeds.stats.valley_candidates);
  EXPECT_EQ(seeds.ridge_vertices.size(), 32u);
  EXPECT_EQ(seeds.valley_vertices.size(), 32u);
  for (const auto* list : {&seeds.ridge_vertices, &seeds.valley_vertices})
    for (std::size_t i = 0; i < list->size(); ++i) {
      // Clear of the scan's crease marks and holes by the default two rings, so by one at least.
      const auto v = (*list)[i].vertex;
      EXPECT_FALSE(mesh->curvature().on_crease[v] || mesh->boundary_vertex()[v]);
      for (auto k = mesh->neighbor_offsets()[v]; k < mesh->neighbor_offsets()[v + 1]; ++k)
        EXPECT_FALSE(mesh->curvature().on_crease[mesh->neighbors()[k]] || mesh->boundary_vertex()[mesh->neighbors()[k]]) << v;
      for (std::size_t j = 0; j < i; ++j)
        EXPECT_GE((mesh->positions()[(*list)[i].vertex] - mesh->positions()[(*list)[j].vertex]).norm(),
                  8 * mesh->local_edge_length((*list)[j].vertex) * (1 - 1e-12));
    }
}

}  // namespace
}  // namespace featureline
