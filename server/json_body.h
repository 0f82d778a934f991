// JSON request bodies: read by the bytes received within RequestLimits::max_json_bytes, then
// parsed once their DOM's size is known (api/json_budget.h). Text and DOM are held against one
// account shared by every body being parsed, so concurrent bodies share one bound (503 beyond).
#pragma once

#include <cstddef>
#include <string>

#include <nlohmann/json.hpp>

#include "server/byte_account.h"
#include "server/http_errors.h"

namespace httplib {
class ContentReader;
struct Request;
}  // namespace httplib

namespace featureline::server {

class Metrics;

/// One request's body: its text, and what it holds of the account while the request lasts.
struct JsonBody {
  explicit JsonBody(ByteAccount& account) : held(account) {}
  std::string text;
  ByteHold held;

  /// Frees the text and gives its bytes back, for a handler that needs only the parsed values.
  void release() {
    text = std::string();
    held.hold(0);
  }
};

class JsonBodies {
 public:
  /// The account's size for a cache of `cache_bytes`: a quarter of it, and never below what 16
  /// bodies of the largest size need, however small the cache.
  static std::size_t budget_for(std::size_t cache_bytes);

  /// `metrics` counts refusals and must outlive this.
  JsonBodies(std::size_t budget_bytes, Metrics& metrics) : memory_(budget_bytes), metrics_(metrics) {}

  /// Reads the whole body into body.text. \throw HttpError 413 (too large), 503 (account spent),
  /// 400 (ended early)
  void read(const httplib::ContentReader& reader, JsonBody& body);

  /// The body as a JSON object, sent as application/json, its DOM's size checked against the
  /// text's and held as well. \throw HttpError 415, 413, 503; InvalidInputError when not an object
  nlohmann::json parse(const httplib::Request& req, JsonBody& body);

  ByteAccount& memory() { return memory_; }

 private:
  HttpError memory_full();

  ByteAccount memory_;
  Metrics& metrics_;
};

}  // namespace featureline::server
