// The search from both ends (cheapest_path_between) against the plain one-sided Dijkstra search:
// the same path, the same cost, on real scans and on a noisy synthetic ridge.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <random>

#include "engine/initial_line.h"
#include "engine/internal/edge_search.h"
#include "engine/mesh_io.h"
#include "tests/support/shared_data.h"
#include "tests/support/synthetic_meshes.h"

namespace featureline {
namespace {

using namespace featureline::testing;

double path_cost(const PreparedMesh& mesh, const std::vector<std::uint32_t>& path,
                 const std::function<double(std::uint32_t, std::uint32_t)>& edge_cost) {
  double cost = 0;
  for (std::size_t i = 1; i < path.size(); ++i)
    for (auto k = mesh.neighbor_offsets()[path[i - 1]]; k < mesh.neighbor_offsets()[path[i - 1] + 1]; ++k)
      if (mesh.neighbors()[k] == path[i]) cost += edge_cost(path[i - 1], k);
  return cost;
}

// A feature-weighted cost of the initial line's form: edges on strong curvature cost 5% of their
// length, featureless ones their whole length.
auto feature_cost(const PreparedMesh& mesh) {
  return [&mesh](std::uint32_t v, std::uint32_t k) {
    const double strength = 0.5 * (mesh.feature_strength(v, 0) + mesh.feature_strength(mesh.neighbors()[k], 0));
    return mesh.neighbor_edge_lengths()[k] * (0.05 + 0.95 * (1 - strength));
  };
}

// Pairs of vertices of one component, `rings` apart or anywhere (rings 0).
std::vector<std::pair<std::uint32_t, std::uint32_t>> random_pairs(const PreparedMesh& mesh, int count) {
  std::mt19937_64 rng(7);
  std::vector<std::pair<std::uint32_t, std::uint32_t>> pairs;
  for (int attempt = 0; attempt < 100 * count && int(pairs.size()) < count; ++attempt) {
    const auto a = std::uint32_t(rng() % mesh.n_vertices()), b = std::uint32_t(rng() % mesh.n_vertices());
    if (a != b && mesh.component()[a] >= 0 && mesh.component()[a] == mesh.component()[b]) pairs.emplace_back(a, b);
  }
  return pairs;
}

void expect_same_paths(const PreparedMesh& mesh, const std::string& name) {
  const auto cost = feature_cost(mesh);
  const auto length = [&mesh](std::uint32_t, std::uint32_t k) { return mesh.neighbor_edge_lengths()[k]; };
  const auto no_heuristic = [](std::uint32_t) { return 0.0; };
  for (const auto& [a, b] : random_pairs(mesh, 12)) {
    const auto goal = [b = b](std::uint32_t v) { return v == b; };
    const auto plain = cheapest_edge_path(mesh, a, goal, cost, no_heuristic, HUGE_VAL);
    const auto both = cheapest_path_between(mesh, a, b, cost, nullptr, CostBounds{0.05}, HUGE_VAL);
    ASSERT_FALSE(plain.empty()) << name;
    EXPECT_EQ(both, plain) << name << ": feature-weighted " << a << " -> " << b;
    EXPECT_NEAR(path_cost(mesh, both, cost), path_cost(mesh, plain, cost), 1e-12 * path_cost(mesh, plain, cost));

    const auto shortest = cheapest_edge_path(mesh, a, goal, length, no_heuristic, HUGE_VAL);
    EXPECT_EQ(shortest_path_between(mesh, a, b, HUGE_VAL), shortest) << name << ": by length " << a << " -> " << b;
  }
}

TEST(EdgeSearch, BothEndsFindThePlainSearchesPathOnScans) {
  for (const char* file : {"bunny_closed.off", "armadillo_29k.obj"}) {
    const std::string path = require_shared_mesh(file);
    if (path.empty()) continue;
    expect_same_paths(*prepare_mesh(read_mesh_file(path)), file);
  }
}

TEST(EdgeSearch, BothEndsFindThePlainSearchesPathOnANoisyRidge) {
  const auto field = make_ridge_field(61, 0.2, 7, 0.3, 0.25, 0.3);
  expect_same_paths(*prepare_mesh(field.mesh), "ridge field");
}

// The feature path itself (shortest_edge_path: its cost, creases and chords included, searched
// from both ends) against plain Dijkstra on the same cost, for each sign a line can have, on
// scans, a CAD part with creases and a noisy ridge.
TEST(EdgeSearch, TheFeaturePathIsThePlainSearchesOnEveryTestMesh) {
  std::vector<std::pair<std::string, std::shared_ptr<const PreparedMesh>>> meshes;
  for (const char* file : {"bunny_closed.off", "armadillo_29k.obj", "fandisk.off"}) {
    const std::string path = require_shared_mesh(file);
    if (!path.empty()) meshes.emplace_back(file, prepare_mesh(read_mesh_file(path)));
  }
  meshes.emplace_back("ridge field", prepare_mesh(make_ridge_field(61, 0.2, 7, 0.3, 0.25, 0.3).mesh));
  const InitialLineOptions options;
  for (const auto& [name, mesh] : meshes)
    for (double sign : {0.0, 1.0, -1.0})
      for (const auto& [a, b] : random_pairs(*mesh, 6)) {
        FeaturePathCost cost(*mesh, options, sign);
        const auto plain = cheapest_edge_path(
            *mesh, a, [b = b](std::uint32_t v) { return v == b; }, cost, [](std::uint32_t) { return 0.0; }, HUGE_VAL);
        const auto found = shortest_edge_path(*mesh, a, b, true, options, sign);
        ASSERT_TRUE(found.has_value()) << name;
        EXPECT_EQ(*found, plain) << name << ", sign " << sign << ": " << a << " -> " << b;
      }
}

TEST(EdgeSearch, BlockedVerticesAreAvoidedExceptAtTheEnds) {
  const auto field = make_ridge_field(41, 0.2, 7, 0.3, 0.25, 0.3);
  const auto mesh = prepare_mesh(field.mesh);
  const auto cost = feature_cost(*mesh);
  for (const auto& [a, b] : random_pairs(*mesh, 8)) {
    // Block every vertex of the plain path but its ends: the new path must go round it.
    const auto first = cheapest_path_between(*mesh, a, b, cost, nullptr, CostBounds{0.05}, HUGE_VAL);
    std::vector<std::uint32_t> blocked(first.begin() + 1, first.end() - 1);
    std::sort(blocked.begin(), blocked.end());
    const auto open = [&](std::uint32_t v) { return !std::binary_search(blocked.begin(), blocked.end(), v); };
    const auto around = cheapest_path_between(*mesh, a, b, cost, &blocked, CostBounds{0.05}, HUGE_VAL);
    const auto plain = cheapest_edge_path(
        *mesh, a, [b = b](std::uint32_t v) { return v == b; },
        [&](std::uint32_t v, std::uint32_t k) { return open(mesh->neighbors()[k]) || mesh->neighbors()[k] == b ? cost(v, k) : -1.0; },
        [](std::uint32_t) { return 0.0; }, HUGE_VAL);
    EXPECT_EQ(around, plain);
    if (first.size() > 2) {
      ASSERT_FALSE(around.empty());
      for (std::size_t i = 1; i + 1 < around.size(); ++i) EXPECT_TRUE(open(around[i]));
    }
  }
}

TEST(EdgeSearch, MaxCostBoundsTheSearch) {
  const auto field = make_ridge_field(41, 0.2, 7, 0.3, 0.25, 0.3);
  const auto mesh = prepare_mesh(field.mesh);
  const auto [a, b] = random_pairs(*mesh, 1).front();
  const auto path = shortest_path_between(*mesh, a, b, HUGE_VAL);
  const double length = path_length(*mesh, path);
  EXPECT_EQ(shortest_path_between(*mesh, a, b, length * (1 + 1e-9)), path);
  EXPECT_TRUE(shortest_path_between(*mesh, a, b, length * 0.99).empty());
  EXPECT_EQ(shortest_path_between(*mesh, a, a, 0), std::vector<std::uint32_t>{a});
}

TEST(EdgeSearch, AnEndWalledOffIsNoPath) {
  const auto field = make_ridge_field(41, 0.2, 7, 0.3, 0.25, 0.3);
  const auto mesh = prepare_mesh(field.mesh);
  const auto [a, b] = random_pairs(*mesh, 1).front();
  // Every neighbour of b blocked: no path, found at once, with and without a cost bound.
  std::vector<std::uint32_t> wall(mesh->neighbors().begin() + mesh->neighbor_offsets()[b],
                                  mesh->neighbors().begin() + mesh->neighbor_offsets()[b + 1]);
  std::sort(wall.begin(), wall.end());
  const auto length = [&](std::uint32_t, std::uint32_t k) { return mesh->neighbor_edge_lengths()[k]; };
  EXPECT_TRUE(cheapest_path_between(*mesh, a, b, length, &wall, CostBounds{1.0}, HUGE_VAL).empty());
  EXPECT_TRUE(cheapest_path_between(*mesh, b, a, length, &wall, CostBounds{1.0}, HUGE_VAL).empty());
  EXPECT_TRUE(cheapest_path_between(*mesh, a, b, length, &wall, CostBounds{1.0}, 1e9).empty());
}

}  // namespace
}  // namespace featureline
