// The browser page compiled into featureline-server (server/embed_web.cmake), so the binary
// alone serves it at /; --web-root DIR serves a folder instead.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace featureline::server {

struct WebAsset {
  std::string_view path;   ///< URL path, "/index.html"
  std::string_view bytes;  ///< the file's content
  std::string_view etag;   ///< quoted content hash, for If-None-Match
};

/// Every file of the built page, sorted by path.
const std::vector<WebAsset>& embedded_web_assets();

/// The asset a GET of `url_path` answers ("/" and folders mean their index.html); null when none.
const WebAsset* find_web_asset(std::string_view url_path);

/// Content-Type by file extension (text types in UTF-8); application/octet-stream when unknown.
std::string web_content_type(std::string_view path);

/// A quoted entity tag for a file's bytes (64-bit FNV-1a, hex), for files served from a
/// folder (--web-root): it changes whenever the bytes do.
std::string content_etag(std::string_view bytes);

/// Whether an If-None-Match header names `etag` (RFC 9110 13.1.2): "*", or one of a
/// comma-separated list of tags compared weakly (a W/ prefix on either side is ignored).
bool etag_matches(std::string_view if_none_match, std::string_view etag);

/// How browsers may keep the page's files: always revalidate (the next build of the page must
/// show at once), which costs a 304 per unchanged file.
inline constexpr const char* kWebCacheControl = "no-cache";

}  // namespace featureline::server
