// Key picking shared by the benchmarks: realistic 3-key lines along features.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "engine/prepared_mesh.h"

namespace featureline {

/// Three keys along a feature: a random vertex in the top 10% of |H|, then the most curved
/// vertex of the same sign 12 and 24 rings away. Empty when none is found.
std::vector<std::uint32_t> pick_feature_keys(const PreparedMesh& mesh, std::mt19937_64& rng);

}  // namespace featureline
