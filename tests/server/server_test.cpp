// The real server in-process (the bash integration test runs the binary): started on a free
// loopback port in a thread, called with httplib's client, stopped. Covers a line, a bad option
// (exact error and status), GET /v1/options, segmentation options and a deadline.
#include <gtest/gtest.h>

#include <cstdio>

// Eigen (through the engine headers) must come before httplib.h (its <resolv.h> defines `_res`).
#include "api/feature_line_json.h"
#include "api/requests.h"
#include "engine/feature_line.h"
#include "engine/mesh_io.h"
#include "server/server.h"

#include <httplib.h>

#include <nlohmann/json.hpp>
#include <thread>

namespace featureline::server {
namespace {

using nlohmann::json;

constexpr const char* kSample = "samples/ridge_field.off";  // tests run from the project root

class RunningServer {
 public:
  explicit RunningServer(ServerOptions options) : server_(with_test_defaults(std::move(options))) {
    port_ = server_.bind();
    mesh_id_ = server_.preload(kSample);
    thread_ = std::thread([this] { server_.run(); });
  }
  ~RunningServer() {
    server_.stop();
    thread_.join();
  }
  httplib::Client client() const {
    httplib::Client c("127.0.0.1", port_);
    c.set_connection_timeout(5);
    c.set_read_timeout(30);  // bounded: a hung server fails the test instead of stalling it
    return c;
  }
  const std::string& mesh_id() const { return mesh_id_; }

 private:
  static ServerOptions with_test_defaults(ServerOptions o) {
    o.host = "127.0.0.1";
    o.port = 0;
    o.engine_threads = 2;
    o.http_threads = 4;
    o.access_log = false;
    return o;
  }
  FeaturelineServer server_;
  int port_ = 0;
  std::string mesh_id_;
  std::thread thread_;
};

json error_of(const httplib::Result& r) { return json::parse(r->body)["error"]; }

TEST(InProcessServer, AnswersALineAsTheEngineComputesIt) {
  RunningServer server({});
  auto client = server.client();
  const auto r = client.Post(("/v1/meshes/" + server.mesh_id() + "/feature-lines").c_str(),
                             R"({"keys": [701, 963, 1184]})", "application/json");
  ASSERT_TRUE(r) << httplib::to_string(r.error());
  ASSERT_EQ(r->status, 200) << r->body;
  const json answer = json::parse(r->body);
  // The known answer: the engine's own result on the same mesh.
  FeatureLineRequest request;
  request.keys = {701, 963, 1184};
  const auto expected = detect_feature_line(*prepare_mesh(read_mesh_file(kSample)), request);
  EXPECT_EQ(answer["keys"], json({701, 963, 1184}));
  EXPECT_EQ(answer["initial"]["vertices"], json(expected.initial.vertices));
  EXPECT_EQ(answer["refined"]["points"].size(), expected.refined.size());
  // Where the time went: the wait for an engine thread and the engine's own time, as the
  // answer's timings report it.
  double queue = -1, engine = -1;
  ASSERT_EQ(std::sscanf(r->get_header_value("Server-Timing").c_str(), "queue;dur=%lf, engine;dur=%lf", &queue, &engine), 2)
      << r->get_header_value("Server-Timing");
  EXPECT_GE(queue, 0);
  EXPECT_NEAR(engine, answer["stats"]["timings_ms"]["total"].get<double>(), 1e-3);
}

TEST(InProcessServer, ABadOptionIs400WithTheExactMessage) {
  RunningServer server({});
  auto client = server.client();
  const std::string lines = "/v1/meshes/" + server.mesh_id() + "/feature-lines";
  auto r = client.Post(lines.c_str(), R"({"keys": [701, 963], "options": {"snake": {"max_iterations": 100000}}})",
                       "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 400);
  EXPECT_EQ(error_of(r)["code"], "invalid_request");
  EXPECT_EQ(error_of(r)["message"], "\"options.snake.max_iterations\" must be an integer from 0 to 500");
  // An old name (accepted for one release) is named as the request wrote it; with its new name, 400.
  r = client.Post(lines.c_str(), R"({"keys": [701, 963], "options": {"snake": {"iterations": 100000}}})", "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(error_of(r)["message"], "\"options.snake.iterations\" must be an integer from 0 to 500");
  r = client.Post(lines.c_str(), R"({"keys": [701, 963], "options": {"rings": 3, "strip": {"rings": 3}}})", "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 400);
  EXPECT_EQ(error_of(r)["message"],
            "\"options.rings\" and \"options.strip.rings\" name the same option: give only \"options.strip.rings\"");
  r = client.Post(lines.c_str(), R"({"keys": [701, 963], "options": {"snake": {"iteratoins": 5}}})", "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 400);
  EXPECT_EQ(error_of(r)["message"], "unknown option \"options.snake.iteratoins\"");
  // Segmentation options come from their own table: every one is reachable, and checked.
  const std::string segmentation = "/v1/meshes/" + server.mesh_id() + "/segmentation";
  r = client.Post(segmentation.c_str(), R"({"lines": [{"keys": [820, 860]}], "mode": "remesh", "remesh_snap": 0.3})",
                  "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 400);
  EXPECT_EQ(error_of(r)["message"], "\"remesh_snap\" must be a number from 0 to 0.2");
  r = client.Post(segmentation.c_str(), R"({"lines": [{"keys": [820, 860]}], "attach_distance": 0, "merge_tiny_segments": true})",
                  "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(json::parse(r->body)["segments"].size(), 2u);  // a border-to-border line: two parts
}

TEST(InProcessServer, AnUnservedMethodIs405NamingTheServedOnesInAllow) {
  RunningServer server({});
  auto client = server.client();
  const std::string mesh = "/v1/meshes/" + server.mesh_id();
  auto expect_405 = [](const httplib::Result& r, const std::string& allow) {
    ASSERT_TRUE(r) << httplib::to_string(r.error());
    EXPECT_EQ(r->status, 405) << r->body;
    EXPECT_EQ(r->get_header_value("Allow"), allow);
    EXPECT_EQ(error_of(r)["code"], "method_not_allowed");
  };
  expect_405(client.Put(mesh.c_str(), "{}", "application/json"), "GET, HEAD, DELETE, OPTIONS");
  expect_405(client.Get((mesh + "/feature-lines").c_str()), "POST, OPTIONS");
  expect_405(client.Delete("/v1/meshes"), "POST, OPTIONS");
  expect_405(client.Post("/healthz", "x", "text/plain"), "GET, HEAD, OPTIONS");
  expect_405(client.Patch((mesh + "/segmentation").c_str(), "{}", "application/json"), "POST, OPTIONS");
  // A path that is no route stays 404, and the served methods answer as before.
  auto r = client.Get("/v1/nothing-here");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 404);
  r = client.Get(mesh.c_str());
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
}

TEST(InProcessServer, AnswersAdvertiseNoByteRangesSinceTheyAreAlwaysWhole) {
  RunningServer server({});
  auto client = server.client();
  const std::string glb = "/v1/meshes/" + server.mesh_id() + "/mesh.glb";
  auto head = client.Head(glb.c_str());
  ASSERT_TRUE(head) << httplib::to_string(head.error());
  EXPECT_EQ(head->status, 200);
  EXPECT_FALSE(head->has_header("Accept-Ranges"));
  auto ranged = client.Get(glb.c_str(), {{"Range", "bytes=0-9"}});
  ASSERT_TRUE(ranged);
  EXPECT_EQ(ranged->status, 200);
  EXPECT_GT(ranged->body.size(), 10u);
  EXPECT_FALSE(ranged->has_header("Accept-Ranges"));
}

TEST(InProcessServer, AnUnknownFormatIs415NamingEveryFormatTheReadersTake) {
  RunningServer server({});
  auto client = server.client();
  const auto r = client.Post("/v1/meshes?format=3ds", "solid x", "application/octet-stream");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 415);
  EXPECT_EQ(error_of(r)["code"], "unsupported_format");
  EXPECT_EQ(error_of(r)["message"], "unknown format \"3ds\"; use one of obj, off, ply, stl, gltf, glb, drc");
}

TEST(InProcessServer, ServesTheOptionTables) {
  RunningServer server({});
  auto client = server.client();
  const auto r = client.Get("/v1/options");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200);
  EXPECT_EQ(r->get_header_value("Content-Type"), "application/json");
  EXPECT_EQ(json::parse(r->body), describe_api_options());
}

TEST(InProcessServer, PreparationPastTheDeadlineIs503AndStops) {
  // A deadline of 0 s has passed when the job starts: preparation stops at its first check
  // (engine/cancellation.h) and the upload is refused, whichever comes first.
  ServerOptions options;
  options.deadline_s = 0;
  RunningServer server(options);
  auto client = server.client();
  std::ifstream file(kSample, std::ios::binary);
  const std::string body((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  const auto r = client.Post("/v1/meshes?format=off", body, "application/octet-stream");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 503);
  EXPECT_EQ(error_of(r)["code"], "deadline_exceeded");
  EXPECT_EQ(r->get_header_value("Retry-After"), "5");
}

}  // namespace
}  // namespace featureline::server
