// glTF 2.0 output: the prepared mesh and feature lines as line-strip primitives with colours.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "engine/feature_line.h"
#include "engine/prepared_mesh.h"

namespace featureline {

/// A GLB holding, when `include_mesh`, the mesh (POSITION, NORMAL, indices, and the engine's
/// feature field, the dominant signed principal curvature, as the custom vertex attribute
/// _CURVATURE), and for every result its initial line (orange) and refined line (cyan) as
/// LINE_STRIP primitives (LINE_LOOP for closed lines) with COLOR_0 as normalised RGBA8 (linear
/// colour, as glTF requires), under a node "feature_line_<i>"; a result with a fitted curve
/// (FeatureLineResult::fitted) also gets it, magenta, under a node of its own "fitted_curve_<i>".
std::string feature_line_to_glb(const PreparedMesh& mesh, const std::vector<FeatureLineResult>& results, bool include_mesh);

/// The mesh alone in a compact GLB for downloads (KHR_mesh_quantization, required): positions as
/// unsigned 16-bit integers over the bounding box (the node's translation and scale map them
/// back; error at most half a step, 1/131070 of the box per axis), the dominant signed
/// curvature as a normalised 16-bit u in the 2 bytes that would pad the positions to 4-byte
/// alignment (value = offset + scale * u, `curvature_offset` and `curvature_scale` in the
/// primitive's extras; the attribute `_CURVATURE` is a VEC4 over the 8-byte vertex whose w is
/// u, as an attribute at offset 6 would be unaligned), no normals, and indices of the smallest
/// type that holds every vertex id. Vertex and triangle order are the prepared mesh's, so
/// vertex i is the session's vertex i. The prepared mesh's crease edges (curvature.crease, at
/// the angle preparation chose from the noise) follow as LINES primitives over the same
/// POSITION accessor, one per sign (extras `"crease": 1` convex, `-1` concave; none when it has
/// no edge), and the surface primitive's extras carry `crease_angle` and `crease_edges`. About
/// 38% of feature_line_to_glb's bytes before HTTP compression.
std::string prepared_mesh_to_compact_glb(const PreparedMesh& mesh);

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
