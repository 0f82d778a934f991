// JSON written without a DOM (api/json_writer.h): exact text for structure, numbers and
// strings, and a feature line's answer that reads back to the engine's numbers bit for bit.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>

#include "api/feature_line_json.h"
#include "api/json_writer.h"
#include "engine/feature_line.h"
#include "tests/support/synthetic_meshes.h"

namespace featureline {
namespace {

using namespace featureline::testing;

std::string number_text(double x) {
  JsonWriter w;
  w.value(x);
  return w.take();
}

TEST(JsonWriter, NestsWithCommasOnlyBetweenValues) {
  JsonWriter w;
  w.begin_object().member("a", 1).key("b").begin_array();
  w.begin_object().end_object().begin_array().end_array().value(true).value(std::uint64_t(7));
  w.end_array().member("c", std::vector<int>{1, 2}).key("d").begin_object().member("e", false).end_object().end_object();
  EXPECT_EQ(w.text(), R"({"a":1,"b":[{},[],true,7],"c":[1,2],"d":{"e":false}})");
}

TEST(JsonWriter, NumbersAreShortestAndReadAsDoubles) {
  EXPECT_EQ(number_text(0.1), "0.1");
  EXPECT_EQ(number_text(1), "1.0");
  EXPECT_EQ(number_text(-0.0), "-0.0");
  EXPECT_EQ(number_text(250), "250.0");
  EXPECT_EQ(number_text(1e300), "1e+300");
  EXPECT_EQ(number_text(-2.5e-7), "-2.5e-07");
  EXPECT_EQ(number_text(std::numeric_limits<double>::quiet_NaN()), "null");
  EXPECT_EQ(number_text(std::numeric_limits<double>::infinity()), "null");
  EXPECT_EQ(number_text(-std::numeric_limits<double>::infinity()), "null");
  JsonWriter integers;
  integers.begin_array().value(std::numeric_limits<std::uint64_t>::max()).value(std::int64_t(-3)).end_array();
  EXPECT_EQ(integers.text(), "[18446744073709551615,-3]");
  // Every double reads back to itself, and as a double (never an integer).
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> exponent(-300, 300);
  for (int i = 0; i < 2000; ++i) {
    const double x = std::ldexp(std::uniform_real_distribution<double>(-1, 1)(rng), int(exponent(rng)));
    const auto read = nlohmann::json::parse(number_text(x));
    ASSERT_TRUE(read.is_number_float()) << number_text(x);
    ASSERT_EQ(read.get<double>(), x) << number_text(x);
  }
  EXPECT_EQ(nlohmann::json::parse(number_text(5e-324)).get<double>(), 5e-324);
}

TEST(JsonWriter, StringsAreEscapedAsTheDomEscapesThem) {
  for (const std::string& s : {std::string("plain"), std::string("quote \" and \\ backslash"), std::string("new\nline\ttab"),
                              std::string("control \x01\x1f"), std::string("unicode \xc3\xa9\xe2\x82\xac"), std::string()}) {
    JsonWriter w;
    w.begin_object().member(s, s).end_object();
    const nlohmann::json dom = {{s, s}};
    EXPECT_EQ(w.text(), dom.dump());
  }
  JsonWriter w;
  EXPECT_THROW(w.value(std::string("\xff\xfe")), nlohmann::json::type_error);
}

TEST(JsonWriter, FeatureLineTextReadsBackToTheEngineNumbers) {
  const auto field = make_ridge_field(31, 0.2, 1, 0.3, 0.25, 0.2);
  const auto mesh = prepare_mesh(field.mesh);
  FeatureLineRequest request;
  request.keys = {nearest_vertex(field.mesh, -0.7, field.crest(-0.7)), nearest_vertex(field.mesh, 0.7, field.crest(0.7))};
  request.options.fitted.enabled = true;
  const FeatureLineResult line = detect_feature_line(*mesh, request);
  const auto json = nlohmann::json::parse(feature_line_json_text(line));
  ASSERT_EQ(json["refined"]["points"].size(), line.refined.size());
  ASSERT_GT(line.refined.size(), 10u);
  for (std::size_t i = 0; i < line.refined.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      ASSERT_EQ(json["refined"]["points"][i][k].get<double>(), line.refined[i].position[k]);
      ASSERT_EQ(json["refined"]["barycentric"][i][k].get<double>(), line.refined[i].barycentric[k]);
    }
    ASSERT_EQ(json["refined"]["faces"][i].get<std::uint32_t>(), line.refined[i].face);
  }
  ASSERT_TRUE(line.fitted);
  ASSERT_EQ(json["fitted"]["points"].size(), line.fitted->points.size());
  EXPECT_EQ(json["fitted"]["points"][0][0].get<double>(), line.fitted->points[0].x());
  EXPECT_EQ(json["stats"]["pieces_detail"].size(), line.piece_reports.size());
  EXPECT_EQ(json["stats"]["iterations"].get<int>(), line.iterations);
  EXPECT_EQ(json, feature_line_to_json(line));
}

}  // namespace
}  // namespace featureline
