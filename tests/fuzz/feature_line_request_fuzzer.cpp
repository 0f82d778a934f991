// libFuzzer harness: whole feature-line requests (bounded engine work per line), as POST /v1/meshes/{id}/feature-lines
// receives them, parsed by api/requests.h and run by the engine on the bundled sample mesh
// (1,681 vertices). Refused requests must be engine errors (mapped to 4xx/5xx by the server);
// accepted ones must finish. As in the server (--deadline-s, 30 s there), each request's lines
// share a deadline (kDeadline) after which the engine stops at its next cancellation check:
// run_fuzzer.sh's -timeout=10 flags work that runs on past it. The option caps of
// api/options_table.cpp bound the work per line; the largest allowed options take about 0.13 s
// in a Release build and several seconds in this sanitised, instrumented one.
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>

#include "api/requests.h"
#include "engine/cancellation.h"
#include "engine/errors.h"
#include "engine/feature_line.h"
#include "engine/mesh_io.h"

namespace {
constexpr std::chrono::seconds kDeadline{3};

std::shared_ptr<const featureline::PreparedMesh> sample_mesh() {
  // ctest runs the harness from the repository root (tests/fuzz/CMakeLists.txt).
  static const auto mesh = featureline::prepare_mesh(featureline::read_mesh_file("samples/ridge_field.off"));
  return mesh;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const nlohmann::json body = nlohmann::json::parse(data, data + size, nullptr, /*allow_exceptions=*/false);
  if (body.is_discarded() || !body.is_object()) return 0;
  const auto mesh = sample_mesh();
  bool batch = false;
  std::vector<featureline::FeatureLineRequest> lines;
  try {
    lines = featureline::parse_feature_line_body(body, *mesh, batch);
  } catch (const featureline::InvalidInputError&) {
    return 0;  // 400 with its message
  } catch (const featureline::LimitExceededError&) {
    return 0;
  }
  const featureline::Cancellation cancel(featureline::Cancellation::Clock::now() + kDeadline);
  for (auto& line : lines) {
    line.cancel = &cancel;
    try {
      const auto result = featureline::detect_feature_line(*mesh, line);
      if (result.refined.empty() && !result.initial.vertices.empty()) __builtin_trap();  // a line must come back
    } catch (const featureline::InvalidInputError&) {
    } catch (const featureline::GeometryError&) {  // e.g. keys in different components: 422
    } catch (const featureline::LimitExceededError&) {
    } catch (const featureline::CancelledError&) {  // 503 at the deadline
    }
  }
  return 0;
}
