// libFuzzer harness: one mesh reader (the format is fixed at build time by FEATURELINE_FUZZ_FORMAT)
// on arbitrary bytes, then preparation and a short feature line on what loaded, as an upload
// gets them. Expected refusals (featureline::Error) are fine; anything else is a finding: another
// exception, a sanitizer report, a hang (-timeout), or memory past -rss_limit_mb.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string_view>

#include "engine/errors.h"
#include "engine/feature_line.h"
#include "engine/mesh_io.h"
#include "engine/prepared_mesh.h"

namespace {

using namespace featureline;

// Limits as the server derives them, for inputs of at most 64 KiB (-max_len) and a 4 MiB budget
// for the prepared mesh: small enough to keep each run fast, and the expansion checks (glTF
// instancing, Draco's declared counts, repeated faces) are exercised at this scale as they are
// at the server's. An input that allocates far past this account is a finding (run_fuzzer.sh
// passes -malloc_limit_mb).
constexpr std::size_t kBudgetBytes = std::size_t(4) << 20;
ReadMeshOptions fuzz_limits() {
  ReadMeshOptions limits = read_limits_for(std::size_t(64) << 10, kBudgetBytes);
  limits.max_vertices = std::min<std::size_t>(limits.max_vertices, 5000);
  limits.max_triangles = std::min<std::size_t>(limits.max_triangles, 5000);
  return limits;
}

PrepareOptions fuzz_prepare_options() {
  PrepareOptions options;
  options.max_memory_bytes = kBudgetBytes;
  return options;
}

// Keys two edges apart from the first vertex that has a neighbour with another neighbour.
std::optional<FeatureLineRequest> short_line(const PreparedMesh& mesh) {
  for (std::uint32_t v = 0; v < mesh.n_vertices(); ++v) {
    for (std::uint32_t i = mesh.neighbor_offsets()[v]; i < mesh.neighbor_offsets()[v + 1]; ++i) {
      const std::uint32_t u = mesh.neighbors()[i];
      for (std::uint32_t j = mesh.neighbor_offsets()[u]; j < mesh.neighbor_offsets()[u + 1]; ++j) {
        if (mesh.neighbors()[j] == v) continue;
        FeatureLineRequest request;
        request.keys = {v, mesh.neighbors()[j]};
        return request;
      }
    }
  }
  return std::nullopt;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const MeshFormat format = *parse_mesh_format(FEATURELINE_FUZZ_FORMAT);
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  std::shared_ptr<const PreparedMesh> mesh;
  try {
    mesh = prepare_mesh(read_mesh(bytes, format, fuzz_limits()), fuzz_prepare_options());
  } catch (const Error&) {
    return 0;  // refused with a message: what an upload answers with 4xx
  }
  if (mesh->n_vertices() == 0 || mesh->neighbor_offsets().size() != mesh->n_vertices() + 1) __builtin_trap();
  if (const auto request = short_line(*mesh)) {
    try {
      const FeatureLineResult line = detect_feature_line(*mesh, *request);
      // An open line runs from its first key to its last.
      const auto& path = line.initial.vertices;
      if (path.size() < 2 || path.front() != request->keys[0] || path.back() != request->keys[1]) __builtin_trap();
      // Every number an answer carries is finite (JSON would print NaN as null).
      if (!std::isfinite(line.initial.length) || !std::isfinite(line.refined_length)) __builtin_trap();
      for (const auto& piece : line.piece_reports)
        if (!std::isfinite(piece.initial_strength) || !std::isfinite(piece.refined_strength)) __builtin_trap();
    } catch (const Error&) {
    }
  }
  return 0;
}
