// server/compression.h: gzip negotiation (Accept-Encoding) and the gzip stream itself, checked
// by inflating it again with zlib.
#include "server/compression.h"

#include <gtest/gtest.h>
#include <httplib.h>
#include <zlib.h>

#include <random>
#include <string>

namespace featureline {
namespace {

// Inflates a gzip stream (windowBits 15 + 16 accepts only gzip, not raw zlib).
std::string gunzip(const std::string& packed) {
  z_stream stream{};
  if (inflateInit2(&stream, 15 + 16) != Z_OK) throw std::runtime_error("inflateInit2");
  std::string out;
  char buffer[1 << 15];
  stream.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(packed.data()));
  stream.avail_in = static_cast<uInt>(packed.size());
  int status = Z_OK;
  while (status == Z_OK) {
    stream.next_out = reinterpret_cast<Bytef*>(buffer);
    stream.avail_out = sizeof buffer;
    status = inflate(&stream, Z_NO_FLUSH);
    out.append(buffer, sizeof buffer - stream.avail_out);
  }
  inflateEnd(&stream);
  if (status != Z_STREAM_END) throw std::runtime_error("not a complete gzip stream");
  return out;
}

// A body like a mesh download: float32 coordinates and 32-bit indices.
std::string mesh_like_bytes(std::size_t triangles) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> coordinate(-1.0f, 1.0f);
  std::string bytes;
  for (std::size_t i = 0; i < triangles * 3 / 2; ++i) {
    const float f = coordinate(rng);
    bytes.append(reinterpret_cast<const char*>(&f), 4);
  }
  for (std::uint32_t i = 0; i < triangles * 3; ++i) {
    const std::uint32_t v = (i / 3) / 2 + i % 3;
    bytes.append(reinterpret_cast<const char*>(&v), 4);
  }
  return bytes;
}

TEST(AcceptsGzip, NamedWithoutOrWithPositiveQuality) {
  EXPECT_TRUE(accepts_gzip("gzip"));
  EXPECT_TRUE(accepts_gzip("gzip, deflate, br, zstd"));  // Chromium's header
  EXPECT_TRUE(accepts_gzip("br;q=1.0, GZIP;q=0.5"));
  EXPECT_TRUE(accepts_gzip("x-gzip"));
  EXPECT_TRUE(accepts_gzip(" deflate ,  gzip ; q=0.001 "));
}

TEST(AcceptsGzip, AbsentRefusedOrMalformed) {
  EXPECT_FALSE(accepts_gzip(""));
  EXPECT_FALSE(accepts_gzip("identity"));
  EXPECT_FALSE(accepts_gzip("br, deflate"));
  EXPECT_FALSE(accepts_gzip("gzip;q=0"));
  EXPECT_FALSE(accepts_gzip("gzip;q=0.000"));
  EXPECT_FALSE(accepts_gzip("gzip;q=banana"));
  EXPECT_FALSE(accepts_gzip("gzip;q=2"));
  EXPECT_FALSE(accepts_gzip("gzipped"));
}

TEST(AcceptsGzip, WildcardUnlessGzipIsRefusedByName) {
  EXPECT_TRUE(accepts_gzip("*"));
  EXPECT_FALSE(accepts_gzip("*;q=0"));
  EXPECT_FALSE(accepts_gzip("*, gzip;q=0"));
}

TEST(GzipCompress, RoundTripsAndShrinksMeshLikeData) {
  const std::string body = mesh_like_bytes(20000);
  const std::string packed = gzip_compress(body);
  ASSERT_GE(packed.size(), 18u);
  EXPECT_EQ(static_cast<unsigned char>(packed[0]), 0x1f);  // gzip magic (RFC 1952)
  EXPECT_EQ(static_cast<unsigned char>(packed[1]), 0x8b);
  EXPECT_EQ(gunzip(packed), body);
  EXPECT_LT(packed.size(), body.size() * 0.8);  // the indices compress; the floats hardly
}

TEST(GzipCompress, EmptyAndEveryLevel) {
  EXPECT_EQ(gunzip(gzip_compress("")), "");
  const std::string text(100000, 'a');
  for (int level = 1; level <= 9; ++level) {
    const std::string packed = gzip_compress(text, level);
    EXPECT_EQ(gunzip(packed), text) << "level " << level;
    EXPECT_LT(packed.size(), 1000u) << "level " << level;
  }
}

TEST(SetContentGzipIfAccepted, CompressesWhenAcceptedAndSaysSo) {
  httplib::Request req;
  req.headers.emplace("Accept-Encoding", "gzip, deflate, br");
  httplib::Response res;
  const std::string body = mesh_like_bytes(5000);
  set_content_gzip_if_accepted(req, res, body, "model/gltf-binary");
  EXPECT_EQ(res.get_header_value("Content-Encoding"), "gzip");
  EXPECT_EQ(res.get_header_value("Vary"), "Accept-Encoding");
  EXPECT_EQ(res.get_header_value("Content-Type"), "model/gltf-binary");
  EXPECT_LT(res.body.size(), body.size());
  EXPECT_EQ(gunzip(res.body), body);
}

TEST(SetContentGzipIfAccepted, RawWhenNotAcceptedButStillVaries) {
  httplib::Request req;
  req.headers.emplace("Accept-Encoding", "br, gzip;q=0");
  httplib::Response res;
  const std::string body = mesh_like_bytes(1000);
  set_content_gzip_if_accepted(req, res, body, "model/gltf-binary");
  EXPECT_FALSE(res.has_header("Content-Encoding"));
  EXPECT_EQ(res.get_header_value("Vary"), "Accept-Encoding");
  EXPECT_EQ(res.body, body);
}

TEST(SetContentGzipIfAccepted, RawWhenCompressionWouldGrowTheBody) {
  httplib::Request req;
  req.headers.emplace("Accept-Encoding", "gzip");
  httplib::Response res;
  std::mt19937 rng(3);
  std::string noise(4096, '\0');
  for (auto& c : noise) c = static_cast<char>(rng());
  set_content_gzip_if_accepted(req, res, noise, "model/gltf-binary");
  EXPECT_FALSE(res.has_header("Content-Encoding"));
  EXPECT_EQ(res.body, noise);
}

}  // namespace
}  // namespace featureline
