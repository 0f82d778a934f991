#pragma once
// HTTP gzip for the large binary answers cpp-httplib does not compress itself. Debian's
// cpp-httplib 0.11.4 is built with zlib and brotli and compresses text, JSON and JavaScript
// answers on its own, but only those content types (its can_compress_content_type): a
// model/gltf-binary mesh goes out raw. This compresses such a body once, when the client
// accepts gzip, and says so in Content-Encoding and Vary.
#include <string>
#include <string_view>

namespace httplib {
struct Request;
struct Response;
}  // namespace httplib

namespace featureline {

/// Whether an Accept-Encoding header value admits gzip (RFC 9110 12.5.3): "gzip" or "x-gzip"
/// or "*" with a q-value above 0, case-insensitive; "gzip;q=0" refuses it.
bool accepts_gzip(std::string_view accept_encoding);

/// The gzip stream (RFC 1952) of `data` at zlib `level` (1 fastest .. 9 smallest). Level 1 is
/// the default: on meshes (float32 attributes, 32-bit indices) higher levels take 2-3x longer
/// for the same size within 1% (measured on bunny_closed's mesh.glb: 70.3% at level 1, 70.5%
/// at 6). \throw std::runtime_error when zlib fails (out of memory).
std::string gzip_compress(std::string_view data, int level = 1);

/// Sets `body` as the response with `content_type`, gzip-compressed when the request accepts
/// gzip and compression saves bytes; always adds "Vary: Accept-Encoding" so caches keep the
/// two forms apart.
void set_content_gzip_if_accepted(const httplib::Request& req, httplib::Response& res, std::string body,
                                  const char* content_type);

}  // namespace featureline
