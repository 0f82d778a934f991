// A feature line as JSON (api/feature_line_json.h): the answer's field names are the contract,
// and line options are strict (unknown or mistyped fields named in the error) and round-trip.
#include <gtest/gtest.h>

#include "api/feature_line_json.h"
#include "engine/errors.h"
#include "engine/feature_line.h"
#include "tests/support/synthetic_meshes.h"

namespace featureline {
namespace {

using namespace featureline::testing;

TEST(FeatureLineJson, FieldNamesAreTheContract) {
  const auto field = make_ridge_field(31, 0.2, 1, 0.3, 0.25, 0.2);
  const auto mesh = prepare_mesh(field.mesh);
  FeatureLineRequest request;
  request.keys = {nearest_vertex(field.mesh, -0.7, field.crest(-0.7)), nearest_vertex(field.mesh, 0.7, field.crest(0.7))};
  const auto json = feature_line_to_json(detect_feature_line(*mesh, request));
  EXPECT_EQ(json["keys"], nlohmann::json(request.keys));
  EXPECT_EQ(json["closed"], false);
  EXPECT_EQ(json["initial"]["method"], "feature-path");
  for (const char* k : {"vertices", "points", "length"}) EXPECT_TRUE(json["initial"].contains(k)) << k;
  for (const char* k : {"points", "faces", "barycentric", "length"}) EXPECT_TRUE(json["refined"].contains(k)) << k;
  EXPECT_EQ(json["refined"]["points"].size(), json["refined"]["faces"].size());
  EXPECT_EQ(json["refined"]["points"].size(), json["refined"]["barycentric"].size());
  for (const char* k : {"iterations", "strip_faces", "fallbacks", "timings_ms"}) EXPECT_TRUE(json["stats"].contains(k)) << k;
  for (const char* k : {"initial", "strip", "flatten", "snake", "total"})
    EXPECT_TRUE(json["stats"]["timings_ms"].contains(k)) << k;
}

TEST(FeatureLineJson, OptionsAreStrict) {
  FeatureLineOptions options;
  apply_options_json(nlohmann::json::parse(R"({"initial": {"method": "marching", "marching_delta": 3}, "snake": {"alpha": 0.5, "force": "paper"}})"),
                     options);
  EXPECT_EQ(options.initial.method, InitialMethod::marching);
  EXPECT_EQ(options.initial.marching_delta, 3);
  EXPECT_EQ(options.snake.alpha, 0.5);
  EXPECT_EQ(options.snake.force, SnakeForce::paper);
  auto error_of = [](const char* text) {
    FeatureLineOptions o;
    try {
      apply_options_json(nlohmann::json::parse(text), o);
    } catch (const InvalidInputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error_of(R"({"snake": {"alpah": 1}})"), "unknown option \"options.snake.alpah\"");
  EXPECT_EQ(error_of(R"({"initial": {"method": "dijkstra"}})"),
            "\"options.initial.method\" must be one of marching, feature-path, geodesic, not \"dijkstra\"");
  EXPECT_EQ(error_of(R"({"strip": {"rings": 2.5}})"), "\"options.strip.rings\" must be an integer from 0 to 8");
  EXPECT_EQ(error_of(R"({"strip": {"rings": 99}})"), "\"options.strip.rings\" must be an integer from 0 to 8");
  EXPECT_EQ(error_of(R"([1, 2])"), "\"options\" must be a JSON object");
  // Round trip: the defaults printed are accepted back unchanged.
  FeatureLineOptions defaults;
  FeatureLineOptions again;
  apply_options_json(options_to_json(defaults), again);
  EXPECT_EQ(options_to_json(again), options_to_json(defaults));
}

}  // namespace
}  // namespace featureline
