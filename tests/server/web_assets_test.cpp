// The page's files as the server serves them: entity tags and If-None-Match (RFC 9110), and the
// real server in-process serving a --web-root folder and its built-in page with ETag,
// Cache-Control and 304.
#include <gtest/gtest.h>

#include "server/server.h"
#include "server/web_assets.h"

#include <httplib.h>

#include <filesystem>
#include <fstream>
#include <thread>

namespace featureline::server {
namespace {

TEST(EtagMatches, ComparesEachTagOfTheListWeakly) {
  EXPECT_TRUE(etag_matches(R"("abc")", R"("abc")"));
  EXPECT_TRUE(etag_matches(R"("x", "abc")", R"("abc")"));
  EXPECT_TRUE(etag_matches(R"("x" ,	"abc" )", R"("abc")"));
  EXPECT_TRUE(etag_matches(R"(W/"abc")", R"("abc")"));
  EXPECT_TRUE(etag_matches(R"("abc")", R"(W/"abc")"));
  EXPECT_TRUE(etag_matches("*", R"("abc")"));
  EXPECT_FALSE(etag_matches("", R"("abc")"));
  EXPECT_FALSE(etag_matches(R"("abcd")", R"("abc")"));
  EXPECT_FALSE(etag_matches(R"("x", "y")", R"("abc")"));
  EXPECT_FALSE(etag_matches(R"(abc)", R"("abc")"));  // unquoted is not the same tag
  EXPECT_FALSE(etag_matches(",", R"("abc")"));
}

TEST(ContentEtag, IsTheQuotedFnv1aOfTheBytes) {
  // FNV-1a 64 of "" is its offset basis; of "a", the published test vector.
  EXPECT_EQ(content_etag(""), R"("cbf29ce484222325")");
  EXPECT_EQ(content_etag("a"), R"("af63dc4c8601ec8c")");
  EXPECT_NE(content_etag("<html>1</html>"), content_etag("<html>2</html>"));
}

class RunningServer {
 public:
  explicit RunningServer(ServerOptions options) : server_(with_test_defaults(std::move(options))) {
    port_ = server_.bind();
    thread_ = std::thread([this] { server_.run(); });
  }
  ~RunningServer() {
    server_.stop();
    thread_.join();
  }
  httplib::Client client() const {
    httplib::Client c("127.0.0.1", port_);
    c.set_connection_timeout(5);
    c.set_read_timeout(30);
    return c;
  }

 private:
  static ServerOptions with_test_defaults(ServerOptions o) {
    o.host = "127.0.0.1";
    o.port = 0;
    o.engine_threads = 1;
    o.http_threads = 2;
    o.access_log = false;
    return o;
  }
  FeaturelineServer server_;
  int port_ = 0;
  std::thread thread_;
};

class WebRootFolder : public ::testing::Test {
 protected:
  void SetUp() override {
    folder_ = std::filesystem::temp_directory_path() /
              ("featureline-web-root-" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "-" +
               ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(folder_);
    write("index.html", "<!doctype html><p>one</p>\n");
  }
  void TearDown() override { std::filesystem::remove_all(folder_); }
  void write(const std::string& name, const std::string& text) { std::ofstream(folder_ / name, std::ios::binary) << text; }
  ServerOptions options() const {
    ServerOptions o;
    o.web_root = folder_.string();
    return o;
  }
  std::filesystem::path folder_;
};

TEST_F(WebRootFolder, AFileCarriesItsEtagAndMustBeRevalidated) {
  RunningServer server(options());
  auto client = server.client();
  const auto r = client.Get("/index.html");
  ASSERT_TRUE(r) << httplib::to_string(r.error());
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(r->body, "<!doctype html><p>one</p>\n");
  EXPECT_EQ(r->get_header_value("ETag"), content_etag("<!doctype html><p>one</p>\n"));
  EXPECT_EQ(r->get_header_value("Cache-Control"), "no-cache");
}

TEST_F(WebRootFolder, IfNoneMatchWithItsEtagIs304WithoutABody) {
  RunningServer server(options());
  auto client = server.client();
  const std::string etag = content_etag("<!doctype html><p>one</p>\n");
  for (const std::string& header : {etag, R"("other", )" + etag, "W/" + etag}) {
    const auto r = client.Get("/", {{"If-None-Match", header}});
    ASSERT_TRUE(r) << httplib::to_string(r.error());
    EXPECT_EQ(r->status, 304) << header;
    EXPECT_EQ(r->body, "") << header;
    EXPECT_EQ(r->get_header_value("ETag"), etag) << header;
  }
}

TEST_F(WebRootFolder, AChangedFileIsSentAgainUnderANewEtag) {
  RunningServer server(options());
  auto client = server.client();
  const std::string old_etag = content_etag("<!doctype html><p>one</p>\n");
  write("index.html", "<!doctype html><p>two</p>\n");
  const auto r = client.Get("/index.html", {{"If-None-Match", old_etag}});
  ASSERT_TRUE(r) << httplib::to_string(r.error());
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(r->body, "<!doctype html><p>two</p>\n");
  EXPECT_EQ(r->get_header_value("ETag"), content_etag("<!doctype html><p>two</p>\n"));
}

TEST(EmbeddedPage, IfNoneMatchListingItsEtagIs304) {
  RunningServer server({});
  auto client = server.client();
  const auto first = client.Get("/");
  ASSERT_TRUE(first) << httplib::to_string(first.error());
  ASSERT_EQ(first->status, 200);
  const std::string etag = first->get_header_value("ETag");
  EXPECT_EQ(etag, std::string(find_web_asset("/")->etag));
  EXPECT_EQ(first->get_header_value("Cache-Control"), "no-cache");
  const auto again = client.Get("/", {{"If-None-Match", R"("stale", W/)" + etag}});
  ASSERT_TRUE(again) << httplib::to_string(again.error());
  EXPECT_EQ(again->status, 304);
  EXPECT_EQ(again->body, "");
}

}  // namespace
}  // namespace featureline::server
