// The one mapping from errors to HTTP statuses and JSON.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "engine/errors.h"
#include "server/http_errors.h"

namespace featureline::server {
namespace {

template <typename E>
ErrorReply reply_for(E error) {
  try {
    throw error;
  } catch (...) {
    return error_reply(std::current_exception());
  }
}

TEST(HttpErrors, EngineErrorsMapToTheirStatuses) {
  EXPECT_EQ(reply_for(InvalidInputError("x")).status, 400);
  EXPECT_EQ(reply_for(MeshFormatError("x")).status, 400);
  EXPECT_EQ(reply_for(MeshFormatError("x")).code, "malformed_mesh");
  EXPECT_EQ(reply_for(UnsupportedFormatError("x")).status, 415);
  EXPECT_EQ(reply_for(LimitExceededError("x")).status, 413);
  EXPECT_EQ(reply_for(GeometryError("keys on different components")).status, 422);
  EXPECT_EQ(reply_for(GeometryError("keys on different components")).code, "unprocessable_geometry");
  EXPECT_EQ(reply_for(HttpError(503, "overloaded", "busy", {{"Retry-After", "1"}})).headers.size(), 1u);
}

TEST(HttpErrors, UnknownExceptionsDoNotLeakTheirText) {
  const auto r = reply_for(std::runtime_error("secret path /etc/shadow"));
  EXPECT_EQ(r.status, 500);
  EXPECT_EQ(r.body().find("secret"), std::string::npos);
}

TEST(HttpErrors, BodyIsTheJsonErrorShape) {
  const auto r = reply_for(GeometryError("keys 0 and 1 lie on different components"));
  const auto j = nlohmann::json::parse(r.body());
  EXPECT_EQ(j, (nlohmann::json{{"error", {{"code", "unprocessable_geometry"}, {"message", "keys 0 and 1 lie on different components"}}}}));
  bool threw = false;
  try {
    const auto parsed = nlohmann::json::parse("{bad");
    ADD_FAILURE() << "parsed " << parsed.dump();
  } catch (...) {
    threw = true;
    EXPECT_EQ(error_reply(std::current_exception()).code, "invalid_json");
  }
  EXPECT_TRUE(threw);
}

}  // namespace
}  // namespace featureline::server
