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
  // Engine work stopped by the request's deadline (engine/cancellation.h): retry later.
  const auto cancelled = reply_for(CancelledError("the request was cancelled"));
  EXPECT_EQ(cancelled.status, 503);
  EXPECT_EQ(cancelled.code, "deadline_exceeded");
  ASSERT_EQ(cancelled.headers.size(), 1u);
  EXPECT_EQ(cancelled.headers[0].first, "Retry-After");
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

TEST(HttpErrors, ClientBytesAreEscapedInMessages) {
  EXPECT_EQ(quote_client_text("obj"), "obj");
  EXPECT_EQ(quote_client_text("\xff\"\n\\"), "\\xFF\"\\x0A\\x5C");
  EXPECT_EQ(quote_client_text(std::string(100, 'a')), std::string(64, 'a') + "...");
}

TEST(HttpErrors, InvalidUtf8NeverBreaksTheErrorBody) {
  // ?format=%FF once put the byte 0xFF into a message: serialising threw and the refusal's
  // connection close was skipped, so a body smuggled behind it was parsed as a request.
  const ErrorReply r{415, "unsupported_format", "unknown format \"\xff\"", {}};
  std::string body;
  ASSERT_NO_THROW(body = r.body());
  EXPECT_EQ(nlohmann::json::parse(body)["error"]["message"], "unknown format \"\xEF\xBF\xBD\"");
}

}  // namespace
}  // namespace featureline::server
