#include "server/web_assets.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdio>
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

std::string content_etag(std::string_view bytes) {
  std::uint64_t hash = 0xcbf29ce484222325ULL;
  for (const unsigned char c : bytes) hash = (hash ^ c) * 0x100000001b3ULL;
  char text[20];
  std::snprintf(text, sizeof text, "\"%016llx\"", static_cast<unsigned long long>(hash));
  return text;
}

namespace {

std::string_view trimmed(std::string_view s) {
  const auto first = s.find_first_not_of(" \t");
  if (first == std::string_view::npos) return {};
  return s.substr(first, s.find_last_not_of(" \t") - first + 1);
}

std::string_view without_weak_prefix(std::string_view tag) {
  return tag.substr(0, 2) == "W/" ? tag.substr(2) : tag;
}

}  // namespace

bool etag_matches(std::string_view if_none_match, std::string_view etag) {
  const std::string_view wanted = without_weak_prefix(etag);
  while (!if_none_match.empty()) {
    const auto comma = if_none_match.find(',');
    const std::string_view tag = trimmed(if_none_match.substr(0, comma));
    if (tag == "*" || (!wanted.empty() && without_weak_prefix(tag) == wanted)) return true;
    if (comma == std::string_view::npos) break;
    if_none_match.remove_prefix(comma + 1);
  }
  return false;
}

}  // namespace featureline::server
