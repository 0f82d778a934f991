// libFuzzer harness: the JSON mapping of feature-line options (api/feature_line_json.h) on
// arbitrary bytes, as the server applies a request's "options". Unknown or mistyped fields must
// be an InvalidInputError; accepted options must survive options_to_json -> apply_options_json
// unchanged (one mapping, both directions).
#include <cstddef>
#include <cstdint>

#include "api/feature_line_json.h"
#include "engine/errors.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using nlohmann::json;
  const json request = json::parse(data, data + size, nullptr, /*allow_exceptions=*/false);
  if (request.is_discarded()) return 0;
  featureline::FeatureLineOptions options;
  try {
    featureline::apply_options_json(request, options);
  } catch (const featureline::InvalidInputError&) {
    return 0;
  }
  const json written = featureline::options_to_json(options);
  featureline::FeatureLineOptions read_back;
  try {
    featureline::apply_options_json(written, read_back);
  } catch (const featureline::InvalidInputError&) {
    __builtin_trap();  // the mapping refuses its own output
  }
  if (featureline::options_to_json(read_back) != written) __builtin_trap();
  return 0;
}
