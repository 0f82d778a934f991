// Content negotiation, in one place for every route: what a request's body is (an upload's mesh
// format from ?format=, Content-Type or its bytes; a JSON body's type) and what the answer is
// (?format= or Accept). Media types are compared without parameters and case-insensitively, and
// header lists are read with their quality values (RFC 9110 12.4.2, 12.5.1).
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "api/export_formats.h"
#include "engine/mesh_io.h"

namespace httplib {
struct Request;
}  // namespace httplib

namespace featureline::server {

/// Bytes of no declared format: an upload to sniff, the curvature as float32.
inline constexpr const char* kOctetStream = "application/octet-stream";

/// One element of a comma-separated header such as Accept or Accept-Encoding.
struct WeightedElement {
  std::string_view value;  ///< the element without its parameters, trimmed ("model/obj", "gzip")
  double quality = 1;      ///< its q parameter; 1 when absent, 0 when malformed (never a guess)
};

/// The elements of `header`, in order; empty elements are skipped.
std::vector<WeightedElement> weighted_elements(std::string_view header);

/// The media type without parameters, lower case, trimmed ("Model/OBJ; charset=x" -> "model/obj").
std::string media_type(std::string_view content_type);

/// Whether the request's Accept names `type` itself with a quality above 0. Wildcards do not
/// count: a route answers its default (JSON) to "*/*" and to no Accept at all.
bool accepts(const httplib::Request& req, std::string_view type);

/// The media type an upload of `format` is sent with: the registered one where there is one.
const char* mesh_media_type(MeshFormat format);

/// What an upload's head says about its body.
struct UploadType {
  std::optional<MeshFormat> format;  ///< from ?format= or Content-Type; none: sniffed from the bytes
  bool files = false;                ///< multipart/form-data: a .gltf and the files it names
};

/// From ?format= (a name of EnumNames<MeshFormat>), else the Content-Type (mesh_media_type of a
/// format, application/octet-stream or none to sniff, multipart/form-data for files).
/// \throw HttpError 415 unsupported_format for an unknown format or type, or a form body
UploadType upload_type(const httplib::Request& req);

/// The format of an upload's bytes when its head named none. \throw HttpError 415
MeshFormat sniff_upload_format(std::string_view bytes);

/// \throw HttpError 415 unless a JSON route's body is sent as application/json (or untyped).
void require_json_body(const httplib::Request& req);

/// The answer's format: ?format= (a name of api/export_formats.h) wins over Accept (the formats
/// with a media type of their own); JSON otherwise. \throw HttpError 400 for a format `content` lacks
ExportFormat answer_format(const httplib::Request& req, ExportContent content);

/// mesh.glb?compact=1: the quantised download the page reads (KHR_mesh_quantization); the float
/// GLB stays the default. A query, not Accept: both are model/gltf-binary. \throw HttpError 400
bool compact_glb_requested(const httplib::Request& req);

}  // namespace featureline::server
