// server/content_negotiation.h: media types, the Accept check with quality values, which
// Content-Type names which mesh format, and the answer's format.
#include "server/content_negotiation.h"

#include <gtest/gtest.h>
#include <httplib.h>

#include "server/http_errors.h"

namespace featureline::server {
namespace {

httplib::Request with_header(const char* name, const char* value) {
  httplib::Request req;
  req.set_header(name, value);
  return req;
}

int status_of(const std::function<void()>& call) {
  try {
    call();
  } catch (const HttpError& e) {
    return e.status();
  }
  return 0;
}

TEST(MediaType, LowerCaseWithoutParametersOrSpace) {
  EXPECT_EQ(media_type(" Model/OBJ ; charset=x"), "model/obj");
  EXPECT_EQ(media_type("application/json"), "application/json");
  EXPECT_EQ(media_type(""), "");
}

TEST(WeightedElements, ValuesAndQualitiesInOrder) {
  const auto elements = weighted_elements("gzip;q=0.5, , br ;level=1; Q=0 ,*;q=nonsense");
  ASSERT_EQ(elements.size(), 3u);
  EXPECT_EQ(elements[0].value, "gzip");
  EXPECT_DOUBLE_EQ(elements[0].quality, 0.5);
  EXPECT_EQ(elements[1].value, "br");
  EXPECT_DOUBLE_EQ(elements[1].quality, 0);
  EXPECT_EQ(elements[2].value, "*");
  EXPECT_DOUBLE_EQ(elements[2].quality, 0);  // malformed: refused, not guessed
}

TEST(Accepts, NamedTypeWithPositiveQualityOnly) {
  EXPECT_TRUE(accepts(with_header("Accept", "text/html, Model/GLTF-Binary;q=0.8"), "model/gltf-binary"));
  EXPECT_FALSE(accepts(with_header("Accept", "model/gltf-binary;q=0"), "model/gltf-binary"));
  EXPECT_FALSE(accepts(with_header("Accept", "*/*"), "application/octet-stream"));
  EXPECT_FALSE(accepts(with_header("Accept", "application/octet-streams"), "application/octet-stream"));
  EXPECT_FALSE(accepts(httplib::Request{}, "application/octet-stream"));
}

TEST(UploadType, EveryMeshFormatByItsMediaType) {
  for (const auto& [format, name] : EnumNames<MeshFormat>::entries) {
    const std::string type = std::string(mesh_media_type(format)) + "; charset=binary";
    const UploadType upload = upload_type(with_header("Content-Type", type.c_str()));
    ASSERT_TRUE(upload.format) << name;
    EXPECT_EQ(*upload.format, format) << name;
    EXPECT_FALSE(upload.files);
  }
}

TEST(UploadType, FormatQueryWinsOverContentType) {
  httplib::Request req = with_header("Content-Type", "model/obj");
  req.params.emplace("format", "PLY");
  EXPECT_EQ(upload_type(req).format, MeshFormat::ply);
  req.params.clear();
  req.params.emplace("format", "dxf");
  EXPECT_EQ(status_of([&] { upload_type(req); }), 415);
}

TEST(UploadType, SniffedFilesOrRefused) {
  EXPECT_FALSE(upload_type(httplib::Request{}).format);
  EXPECT_FALSE(upload_type(with_header("Content-Type", "application/octet-stream")).format);
  EXPECT_TRUE(upload_type(with_header("Content-Type", "multipart/form-data; boundary=x")).files);
  EXPECT_EQ(status_of([] { upload_type(with_header("Content-Type", "application/x-www-form-urlencoded")); }), 415);
  EXPECT_EQ(status_of([] { upload_type(with_header("Content-Type", "text/html")); }), 415);
}

TEST(SniffUploadFormat, KnownBytesOrRefused) {
  EXPECT_EQ(sniff_upload_format("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"), MeshFormat::off);
  EXPECT_EQ(status_of([] { sniff_upload_format("hello"); }), 415);
}

TEST(RequireJsonBody, JsonOrUntyped) {
  EXPECT_EQ(status_of([] { require_json_body(with_header("Content-Type", "Application/JSON; charset=utf-8")); }), 0);
  EXPECT_EQ(status_of([] { require_json_body(httplib::Request{}); }), 0);
  EXPECT_EQ(status_of([] { require_json_body(with_header("Content-Type", "text/plain")); }), 415);
}

TEST(AnswerFormat, QueryThenAcceptThenJson) {
  httplib::Request req = with_header("Accept", "model/gltf+json");
  EXPECT_EQ(answer_format(req, ExportContent::lines), ExportFormat::gltf);
  EXPECT_EQ(answer_format(req, ExportContent::segmentation), ExportFormat::json);  // no glTF JSON for segmentations
  req.params.emplace("format", "csv");
  EXPECT_EQ(answer_format(req, ExportContent::lines), ExportFormat::csv);
  EXPECT_EQ(status_of([&] { answer_format(req, ExportContent::segmentation); }), 400);
  EXPECT_EQ(answer_format(with_header("Accept", "text/plain, */*"), ExportContent::lines), ExportFormat::json);
  EXPECT_EQ(answer_format(with_header("Accept", "model/gltf-binary;q=0"), ExportContent::lines), ExportFormat::json);
}

TEST(CompactGlbRequested, OnlyTheFourSpellings) {
  httplib::Request req;
  EXPECT_FALSE(compact_glb_requested(req));
  req.params.emplace("compact", "TRUE");
  EXPECT_TRUE(compact_glb_requested(req));
  req.params.clear();
  req.params.emplace("compact", "yes");
  EXPECT_EQ(status_of([&] { compact_glb_requested(req); }), 400);
}

}  // namespace
}  // namespace featureline::server
