#include "server/web_assets.h"

#include <algorithm>
#include <array>
#include <utility>

namespace featureline::server {

const WebAsset* find_web_asset(std::string_view url_path) {
  std::string path(url_path);
  if (path.empty() || path.back() == '/') path += "index.html";
  const auto& assets = embedded_web_assets();
  const auto it = std::lower_bound(assets.begin(), assets.end(), path,
                                   [](const WebAsset& a, const std::string& p) { return a.path < p; });
  if (it != assets.end() && it->path == path) return &*it;
  // A folder without its trailing slash ("/samples") is its index too.
  if (path.find('.', path.rfind('/')) == std::string::npos) return find_web_asset(path + "/");
  return nullptr;
}

std::string web_content_type(std::string_view path) {
  static constexpr std::array<std::pair<std::string_view, std::string_view>, 14> types{{
      {".html", "text/html; charset=utf-8"},
      {".js", "text/javascript; charset=utf-8"},
      {".mjs", "text/javascript; charset=utf-8"},
      {".css", "text/css; charset=utf-8"},
      {".json", "application/json"},
      {".svg", "image/svg+xml"},
      {".png", "image/png"},
      {".ico", "image/x-icon"},
      {".wasm", "application/wasm"},
      {".glb", "model/gltf-binary"},
      {".gltf", "model/gltf+json"},
      {".obj", "model/obj"},
      {".stl", "model/stl"},
      {".txt", "text/plain; charset=utf-8"},
  }};
  for (const auto& [extension, type] : types)
    if (path.size() >= extension.size() && path.substr(path.size() - extension.size()) == extension) return std::string(type);
  return "application/octet-stream";
}

}  // namespace featureline::server
