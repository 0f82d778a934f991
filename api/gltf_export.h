// glTF 2.0 output: the prepared mesh and feature lines as line-strip primitives with colours.
#pragma once

#include <array>
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

/// The colour of segment label `label`, sRGB components in [0, 1]: golden-ratio hue steps with
/// alternating lightness, so neighbouring labels differ. The one palette: the segmentation
/// answer carries it per segment (the page draws with it) and the GLB's materials use it.
std::array<double, 3> segment_colour(int label);

/// A GLB of a labelled triangle mesh: one primitive per label, each with its own colour
/// (a material per segment, segment_colour in linear RGB), sharing positions and normals.
std::string labelled_mesh_to_glb(const std::vector<Eigen::Vector3d>& positions,
                                 const std::vector<std::array<std::uint32_t, 3>>& triangles, const std::vector<int>& labels,
                                 int label_count);

}  // namespace featureline
