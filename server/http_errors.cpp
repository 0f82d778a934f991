#include "server/http_errors.h"

#include <nlohmann/json.hpp>

#include <cstdio>
#include <new>

#include "api/json_budget.h"
#include "engine/errors.h"
#include "server/session_cache.h"
#include "server/upload_store.h"

namespace featureline::server {

std::string ErrorReply::body() const {
  // replace: a message with invalid UTF-8 (from any path that forgot quote_client_text) must
  // still serialise: a throw here would skip the close after a refusal, and the unread body
  // would then be parsed as the next request.
  return nlohmann::json{{"error", {{"code", code}, {"message", message}}}}.dump(-1, ' ', false,
                                                                               nlohmann::json::error_handler_t::replace);
}

std::string quote_client_text(std::string_view text) {
  constexpr std::size_t shown = 64;
  std::string out;
  for (std::size_t i = 0; i < text.size() && i < shown; ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c >= 0x20 && c < 0x7f && c != '\\') {
      out += char(c);
    } else {
      char escaped[8];
      std::snprintf(escaped, sizeof escaped, "\\x%02X", c);
      out += escaped;
    }
  }
  if (text.size() > shown) out += "...";
  return out;
}

ErrorReply error_reply(std::exception_ptr error) {
  ErrorReply r;
  try {
    std::rethrow_exception(error);
  } catch (const HttpError& e) {
    r = {e.status(), e.code(), e.what(), e.headers()};
  } catch (const StoreFullError& e) {
    r = {503, "storage_full", e.what(), {{"Retry-After", "60"}}};
  } catch (const StoreUnavailableError& e) {
    r = {503, "storage_unavailable", e.what(), {{"Retry-After", "5"}}};
  } catch (const CacheTooSmallError& e) {
    r = {503, "cache_too_small", e.what(), {{"Retry-After", "60"}}};
  } catch (const UnsupportedFormatError& e) {
    r = {415, "unsupported_format", e.what(), {}};
  } catch (const LimitExceededError& e) {
    r = {413, "payload_too_large", e.what(), {}};
  } catch (const MeshFormatError& e) {
    r = {400, "malformed_mesh", e.what(), {}};
  } catch (const InvalidInputError& e) {
    r = {400, "invalid_request", e.what(), {}};
  } catch (const GeometryError& e) {
    r = {422, "unprocessable_geometry", e.what(), {}};
  } catch (const CancelledError& e) {
    r = {503, "deadline_exceeded", e.what(), {{"Retry-After", "5"}}};
  } catch (const nlohmann::json::exception& e) {
    r = {400, "invalid_json", "the request body is not valid JSON: " + json_error_sentence(e), {}};
  } catch (const std::bad_alloc&) {
    r = {413, "payload_too_large", "the request needs more memory than the server can give it", {}};
  } catch (...) {
    r = {500, "internal", "internal error", {}};
  }
  return r;
}

ErrorReply error_reply_for_status(int status) {
  switch (status) {
    case 400: return {400, "invalid_request", "the request could not be parsed", {}};
    case 404: return {404, "not_found", "no such route", {}};
    case 405: return {405, "method_not_allowed", "method not allowed on this route", {}};
    case 413: return {413, "payload_too_large", "the request body is larger than the server accepts", {}};
    case 414: return {414, "invalid_request", "the request URI is too long", {}};
    default: return {status, status >= 500 ? "internal" : "invalid_request", "request failed", {}};
  }
}

}  // namespace featureline::server
