// Key picking shared by the benchmarks: 3-key lines along features, or anywhere.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "engine/prepared_mesh.h"

namespace featureline {

/// Three keys along a feature: a random vertex in the top 10% of |H|, then the most curved
/// vertex of the same sign 12 and 24 rings away. Empty when none is found.
std::vector<std::uint32_t> pick_feature_keys(const PreparedMesh& mesh, std::mt19937_64& rng);

/// Three keys anywhere on the mesh, each `spacing` rings from the last (as a user dragging a key
/// or a script giving any keys would): empty when none is found.
std::vector<std::uint32_t> pick_random_keys(const PreparedMesh& mesh, std::mt19937_64& rng, int spacing = 30);

}  // namespace featureline
