#include "engine/io/triangle_strip.h"

namespace featureline::detail {

std::size_t append_run_triangles(const std::uint32_t* indices, std::size_t count, TriangleRun kind,
                                 std::vector<std::array<std::uint32_t, 3>>& triangles) {
  std::size_t degenerate = 0;
  for (std::size_t k = 0; k + 2 < count; ++k) {
    std::array<std::uint32_t, 3> t{};
    if (kind == TriangleRun::fan) {
      t = {indices[0], indices[k + 1], indices[k + 2]};
    } else if (k % 2 == 0) {
      t = {indices[k], indices[k + 1], indices[k + 2]};
    } else {
      t = {indices[k + 1], indices[k], indices[k + 2]};  // odd triangles of a strip turn the other way
    }
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
      ++degenerate;
      continue;
    }
    triangles.push_back(t);
  }
  return degenerate;
}

}  // namespace featureline::detail
