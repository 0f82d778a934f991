// JSON mapping of the feature seeds (engine/feature_seeds.h): crease chains and ridge and valley
// vertices a user picks key vertices from. One place decides the field names, so the CLI and
// the server answer the same document.
#pragma once

#include <nlohmann/json.hpp>

#include "engine/feature_seeds.h"
#include "engine/prepared_mesh.h"

namespace featureline {

/// The seeds as JSON (field names are the contract; every number finite):
///   {"crease_chains": [{"sign": "ridge" | "valley", "closed", "edges", "length", "dihedral_deg",
///                       "vertices": [id, ...], "points": [[x, y, z], ...]}, ...],
///    "ridge_vertices":  [{"vertex", "point": [x, y, z], "curvature", "strength",
///                         "direction": [x, y, z] | null}, ...],
///    "valley_vertices": [... as ridge_vertices ...],
///    "stats": {"crease_chains", "short_chains", "junctions", "corners", "ridge_candidates",
///              "valley_candidates", "noise_floor_strength", "timings_ms": {"features"}}}
/// Points are the mesh's vertex positions; a closed chain does not repeat its first vertex.
nlohmann::json feature_seeds_to_json(const PreparedMesh& mesh, const FeatureSeeds& seeds);

}  // namespace featureline
