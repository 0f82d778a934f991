// glTF 2.0 output: the prepared mesh and feature lines as line-strip primitives with colours.
#pragma once

#include <string>
#include <vector>

#include "engine/feature_line.h"
#include "engine/prepared_mesh.h"

namespace featureline {

/// A GLB holding, when `include_mesh`, the mesh (POSITION, NORMAL, indices, and the signed mean
/// curvature as the custom vertex attribute _CURVATURE), and for every result its initial line
/// (orange) and refined line (cyan) as LINE_STRIP primitives (LINE_LOOP for closed lines) with
/// COLOR_0 as normalised RGBA8 (linear colour, as glTF requires).
std::string feature_line_to_glb(const PreparedMesh& mesh, const std::vector<FeatureLineResult>& results, bool include_mesh);

/// The same document as glTF JSON with an embedded base64 buffer.
std::string feature_line_to_gltf_json(const PreparedMesh& mesh, const std::vector<FeatureLineResult>& results,
                                      bool include_mesh);

}  // namespace featureline
