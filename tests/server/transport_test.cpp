// The transport's decisions about a request head (server/transport.h), before httplib sees it.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "server/transport.h"

namespace featureline::server {
namespace {

TransportLimits limits() {
  TransportLimits l;
  l.max_header_lines = 5;
  l.max_head_bytes = 1024;
  l.max_body_bytes = [](std::string_view method, std::string_view path) -> std::size_t {
    return method == "POST" && path == "/v1/meshes" ? 1000 : 100;
  };
  return l;
}

std::string head(const std::string& request_line, const std::string& fields) {
  return request_line + "\r\n" + fields + "\r\n";
}

TEST(RequestHead, APlainRequestPassesUnchanged) {
  const std::string h = head("POST /v1/meshes?format=obj HTTP/1.1", "Host: x\r\nContent-Length: 1000\r\n");
  const HeadCheck check = check_request_head(h, limits());
  EXPECT_FALSE(check.refusal);
  EXPECT_EQ(check.content_length, 1000u);
  EXPECT_EQ(check.forwarded_head, h);
}

TEST(RequestHead, BodyLimitsFollowTheRoute) {
  const HeadCheck upload = check_request_head(head("POST /v1/meshes HTTP/1.1", "Content-Length: 1001\r\n"), limits());
  ASSERT_TRUE(upload.refusal);
  EXPECT_EQ(upload.refusal->status, 413);
  EXPECT_EQ(upload.refusal->message, "the request body is 1001 bytes; uploads accept at most 1000 bytes");
  const HeadCheck json = check_request_head(head("POST /v1/meshes/ab/feature-lines HTTP/1.1", "Content-Length: 101\r\n"), limits());
  ASSERT_TRUE(json.refusal);
  EXPECT_EQ(json.refusal->code, "payload_too_large");
  EXPECT_EQ(json.refusal->message, "the request body is 101 bytes; this route accepts at most 100 bytes");
}

TEST(RequestHead, AmbiguousBodiesAreRefused) {
  const auto refusal = [](const std::string& fields) {
    const HeadCheck check = check_request_head(head("POST /v1/meshes HTTP/1.1", fields), limits());
    return check.refusal ? std::to_string(check.refusal->status) + " " + check.refusal->code : std::string("none");
  };
  EXPECT_EQ(refusal("Content-Length: 5\r\nContent-Length: 5\r\n"), "400 invalid_request");
  EXPECT_EQ(refusal("Content-Length: 5\r\ncontent-length: 7\r\n"), "400 invalid_request");
  EXPECT_EQ(refusal("Content-Length: -1\r\n"), "400 invalid_request");
  EXPECT_EQ(refusal("Content-Length: 0x10\r\n"), "400 invalid_request");
  EXPECT_EQ(refusal("Transfer-Encoding: chunked\r\n"), "411 length_required");
  EXPECT_EQ(refusal("Content-Length: 5\r\nTransfer-Encoding: chunked\r\n"), "411 length_required");
  EXPECT_EQ(refusal("Content-Encoding: gzip\r\nContent-Length: 5\r\n"), "415 unsupported_format");
  EXPECT_EQ(refusal("Content-Encoding: identity\r\nContent-Length: 5\r\n"), "none");
  EXPECT_EQ(refusal("X-A: 1\r\n folded\r\n"), "400 invalid_request");
}

TEST(RequestHead, HeaderCountAndSizeAreLimited) {
  const HeadCheck five = check_request_head(head("GET /healthz HTTP/1.1", "A: 1\r\nB: 2\r\nC: 3\r\nD: 4\r\nE: 5\r\n"), limits());
  EXPECT_FALSE(five.refusal);
  const HeadCheck six = check_request_head(head("GET /healthz HTTP/1.1", "A: 1\r\nB: 2\r\nC: 3\r\nD: 4\r\nE: 5\r\nF: 6\r\n"), limits());
  ASSERT_TRUE(six.refusal);
  EXPECT_EQ(six.refusal->status, 431);
  EXPECT_EQ(six.refusal->message, "the request has more than 5 header fields");
  const HeadCheck big = check_request_head(head("GET /healthz HTTP/1.1", "A: " + std::string(1100, 'a') + "\r\n"), limits());
  ASSERT_TRUE(big.refusal);
  EXPECT_EQ(big.refusal->code, "headers_too_large");
}

TEST(RequestHead, AHeadWithoutLineEndsIsOnlyARequestLine) {
  const HeadCheck check = check_request_head("GET /healthz HTTP/1.1", limits());
  EXPECT_FALSE(check.refusal);
  EXPECT_EQ(check.forwarded_head, "GET /healthz HTTP/1.1\r\n\r\n");
}

TEST(RequestHead, RangeIsDropped) {
  const HeadCheck check = check_request_head(head("GET /healthz HTTP/1.1", "Host: x\r\nRange: bytes=5-1\r\nAccept: */*\r\n"), limits());
  EXPECT_FALSE(check.refusal);
  EXPECT_EQ(check.forwarded_head, head("GET /healthz HTTP/1.1", "Host: x\r\nAccept: */*\r\n"));
}

TEST(RequestHead, ClientBytesInMessagesAreEscaped) {
  const HeadCheck check = check_request_head(head("POST /x HTTP/1.1", "Content-Encoding: \xff\xfe\r\n"), limits());
  ASSERT_TRUE(check.refusal);
  EXPECT_EQ(check.refusal->message, "compressed bodies (Content-Encoding: \\xFF\\xFE) are not accepted");
}

TEST(RefusalResponse, IsACompleteClosingJsonAnswer) {
  const std::string bytes = refusal_response({503, "overloaded", "busy", {{"Retry-After", "1"}}});
  const std::string body = R"({"error":{"code":"overloaded","message":"busy"}})";
  EXPECT_EQ(bytes, "HTTP/1.1 503 Service Unavailable\r\nContent-Type: application/json\r\nContent-Length: " +
                       std::to_string(body.size()) + "\r\nConnection: close\r\nRetry-After: 1\r\n\r\n" + body);
}

}  // namespace
}  // namespace featureline::server
