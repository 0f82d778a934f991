// The landmarks' lower bounds (engine/path_landmarks.h): never above a true cost, consistent
// edge by edge (what the searches from both ends need to return the cheapest path), and absent
// only where a component has no landmark.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <random>

#include "engine/initial_line.h"
#include "engine/internal/edge_search.h"
#include "engine/mesh_io.h"
#include "engine/path_landmarks.h"
#include "engine/prepared_mesh.h"
#include "tests/support/shared_data.h"
#include "tests/support/synthetic_meshes.h"

namespace featureline {
namespace {

using namespace featureline::testing;

std::vector<std::pair<std::string, std::shared_ptr<const PreparedMesh>>> test_meshes() {
  std::vector<std::pair<std::string, std::shared_ptr<const PreparedMesh>>> meshes;
  for (const char* file : {"bunny_closed.off", "fandisk.off"}) {
    const std::string path = require_shared_mesh(file);
    if (!path.empty()) meshes.emplace_back(file, prepare_mesh(read_mesh_file(path)));
  }
  meshes.emplace_back("noisy ridge", prepare_mesh(make_ridge_field(61, 0.2, 7, 0.3, 0.25, 0.3).mesh));
  return meshes;
}

double path_cost(const PreparedMesh& mesh, const std::vector<std::uint32_t>& path, FeaturePathCost& cost) {
  double sum = 0;
  for (std::size_t i = 1; i < path.size(); ++i) sum += cost(path[i - 1], mesh.edge_slot(path[i - 1], path[i]));
  return sum;
}

// Along every edge, each landmark's distance changes by at most the edge's cost at the
// landmarks' floor, for either sign: the bound is consistent (and so never above a true cost).
TEST(PathLandmarks, EveryEdgeChangesADistanceByAtMostItsCost) {
  InitialLineOptions options;
  options.feature_weight_floor = PathLandmarks::kFloor;
  for (const auto& [name, mesh] : test_meshes()) {
    const auto& landmarks = mesh->landmarks();
    ASSERT_FALSE(landmarks.empty()) << name;
    FeaturePathCost cost(*mesh, options, 0);
    std::size_t checked = 0;
    for (std::uint32_t v = 0; v < mesh->n_vertices(); ++v)
      for (auto k = mesh->neighbor_offsets()[v]; k < mesh->neighbor_offsets()[v + 1]; ++k) {
        const auto w = mesh->neighbors()[k];
        ASSERT_LE(landmarks.lower_bound(landmarks.at(v), landmarks.at(w)), cost(v, k)) << name << ": edge " << v << "-" << w;
        ++checked;
      }
    EXPECT_EQ(checked, mesh->neighbors().size());
  }
}

// Against the cheapest paths themselves: below every true cost (either sign, the default floor
// or a higher one), and close to it (a bound far below would leave the searches flooding discs).
TEST(PathLandmarks, BoundsAreBelowTheCheapestCostsAndNearThem) {
  for (const auto& [name, mesh] : test_meshes()) {
    const auto& landmarks = mesh->landmarks();
    std::mt19937_64 rng(11);
    double bound_sum = 0, cost_sum = 0;
    for (int pair = 0; pair < 12; ++pair) {
      const auto a = std::uint32_t(rng() % mesh->n_vertices()), b = std::uint32_t(rng() % mesh->n_vertices());
      for (double sign : {0.0, 1.0, -1.0})
        for (double floor : {PathLandmarks::kFloor, 0.2}) {
          InitialLineOptions options;
          options.feature_weight_floor = floor;
          FeaturePathCost cost(*mesh, options, sign);
          const auto path = cheapest_edge_path(
              *mesh, a, [b = b](std::uint32_t v) { return v == b; }, cost, [](std::uint32_t) { return 0.0; }, HUGE_VAL);
          ASSERT_FALSE(path.empty()) << name;
          const double bound = landmarks.lower_bound(landmarks.at(a), landmarks.at(b)), true_cost = path_cost(*mesh, path, cost);
          EXPECT_LE(bound, true_cost) << name << ": " << a << " -> " << b << ", sign " << sign << ", floor " << floor;
          if (sign == 0 && floor == PathLandmarks::kFloor) bound_sum += bound, cost_sum += true_cost;
        }
    }
    EXPECT_GT(bound_sum, 0.5 * cost_sum) << name << " ratio " << bound_sum / cost_sum;
  }
}

// A floor below the landmarks' (the options allow 1e-4) still gets the cheapest path: the bound
// is scaled by the share such a floor can take off.
TEST(PathLandmarks, AFloorBelowTheLandmarksStillFindsTheCheapestPath) {
  for (const auto& [name, mesh] : test_meshes()) {
    InitialLineOptions options;
    options.feature_weight_floor = 0.005;
    std::mt19937_64 rng(5);
    for (int pair = 0; pair < 6; ++pair) {
      const auto a = std::uint32_t(rng() % mesh->n_vertices()), b = std::uint32_t(rng() % mesh->n_vertices());
      FeaturePathCost cost(*mesh, options, 0);
      const auto plain = cheapest_edge_path(
          *mesh, a, [b = b](std::uint32_t v) { return v == b; }, cost, [](std::uint32_t) { return 0.0; }, HUGE_VAL);
      const auto found = shortest_edge_path(*mesh, a, b, true, options, 0);
      ASSERT_TRUE(found.has_value()) << name;
      EXPECT_EQ(*found, plain) << name << ": " << a << " -> " << b;
    }
  }
}

// The landmarks lie on the largest component; a smaller one has none (no bound there, searches
// in it keep the straight-line bound and still find their cheapest paths).
TEST(PathLandmarks, OnlyTheLargestComponentHasLandmarks) {
  RawMesh two = make_icosphere(1.0, 3);
  const RawMesh small = translated(make_icosphere(0.5, 2), 5, 0, 0);
  const auto offset = std::uint32_t(two.positions.size());
  for (const auto& p : small.positions) two.positions.push_back(p);
  for (const auto& t : small.triangles) two.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  two.source_faces = two.triangles.size();
  const auto mesh = prepare_mesh(two);
  const auto& landmarks = mesh->landmarks();
  for (std::uint32_t v = 0; v < mesh->n_vertices(); ++v)
    for (auto d : landmarks.at(v))
      EXPECT_EQ(d == PathLandmarks::kUnreachable, v >= offset) << "vertex " << v;
  const auto plain = shortest_path_to(*mesh, offset, [&](std::uint32_t v) { return v == offset + 20; }, HUGE_VAL);
  EXPECT_EQ(shortest_path_between(*mesh, offset, offset + 20, HUGE_VAL), plain);
  EXPECT_EQ(landmarks.memory_bytes(), mesh->n_vertices() * sizeof(PathLandmarks::Distances));
}

}  // namespace
}  // namespace featureline
