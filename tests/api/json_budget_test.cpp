#include "api/json_budget.h"

#include <gtest/gtest.h>

#include <string>

#include "engine/errors.h"

namespace featureline {
namespace {

TEST(JsonBudget, MeasuresValuesContainersStringsAndDepth) {
  const JsonShape shape = measure_json(R"({"keys": [1, 2, {"point": [0.5, 1, 2]}], "closed": true, "name": "abc"})");
  // root, keys array, 1, 2, point object, point array, 3 numbers, true, "abc"
  EXPECT_EQ(shape.values, 11u);
  EXPECT_EQ(shape.containers, 4u);
  EXPECT_EQ(shape.string_bytes, std::string("keyspointclosednameabc").size());
  EXPECT_EQ(shape.depth, 4u);
}

TEST(JsonBudget, InvalidTextThrowsWhatParseThrows) {
  const std::string text = R"({"keys": [1, 2,)";
  std::string expected;
  try {
    [[maybe_unused]] const auto parsed = nlohmann::json::parse(text);  // a (void) cast does not silence warn_unused_result
  } catch (const nlohmann::json::parse_error& e) {
    expected = e.what();
  }
  ASSERT_FALSE(expected.empty());
  try {
    (void)measure_json(text);
    FAIL() << "no exception";
  } catch (const nlohmann::json::parse_error& e) {
    EXPECT_EQ(std::string(e.what()), expected);
  }
}

TEST(JsonBudget, TinyContainersAreRefusedBeforeParsing) {
  std::string text = "{\"lines\": [";
  for (int i = 0; i < 400000; ++i) text += i ? ",{}" : "{}";
  text += "]}";
  try {
    (void)parse_json_within(text);
    FAIL() << "accepted";
  } catch (const LimitExceededError& e) {
    EXPECT_NE(std::string(e.what()).find("400002 JSON values (400002 objects and arrays)"), std::string::npos) << e.what();
  }
}

TEST(JsonBudget, DeepNestingIsRefused) {
  const std::string text = "{\"a\": " + std::string(65, '[') + std::string(65, ']') + "}";
  EXPECT_THROW((void)parse_json_within(text), LimitExceededError);
  const std::string ok = "{\"a\": " + std::string(63, '[') + std::string(63, ']') + "}";
  EXPECT_EQ(parse_json_within(ok).size(), 1u);
}

// The largest legitimate request: 64 lines of 128 point keys written as compactly as possible.
TEST(JsonBudget, TheLargestRequestOfCompactPointKeysIsAccepted) {
  std::string text = "{\"lines\": [";
  for (int line = 0; line < 64; ++line) {
    text += line ? ",{\"keys\": [" : "{\"keys\": [";
    for (int k = 0; k < 128; ++k) text += std::string(k ? "," : "") + "{\"point\":[1,2,3]}";
    text += "]}";
  }
  text += "]}";
  EXPECT_EQ(parse_json_within(text)["lines"].size(), 64u);
}

TEST(JsonBudget, AllowedBytesAreAMultipleOfTheTextWithAFloor) {
  const JsonBudget budget;
  EXPECT_EQ(allowed_dom_bytes(10, budget), budget.dom_bytes_floor);
  EXPECT_EQ(allowed_dom_bytes(4 << 20, budget), std::size_t(4 << 20) * budget.dom_bytes_per_text_byte);
}

}  // namespace
}  // namespace featureline
