// Triangle strips and fans (PLY "tristrips" elements, glTF TRIANGLE_STRIP and TRIANGLE_FAN
// primitives) decoded into triangles, one decoder for every reader.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace featureline::detail {

enum class TriangleRun {
  strip,  ///< triangle k is (i_k, i_k+1, i_k+2), every second one reversed to keep the winding
  fan,    ///< triangle k is (i_0, i_k+1, i_k+2)
};

/// Appends the triangles of one run of `count` indices (no restart markers; a caller splits at
/// them) to `triangles`, in run order. Triangles with a repeated corner are how strips are
/// stitched together, not faces: they are skipped, and their number is returned.
std::size_t append_run_triangles(const std::uint32_t* indices, std::size_t count, TriangleRun kind,
                                 std::vector<std::array<std::uint32_t, 3>>& triangles);

}  // namespace featureline::detail
