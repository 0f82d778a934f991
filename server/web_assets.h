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

}  // namespace featureline::server
