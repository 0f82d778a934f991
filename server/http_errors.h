// The one place where errors become HTTP statuses and the JSON error shape
// {"error": {"code": "...", "message": "..."}}. Handlers throw; they never format errors.
#pragma once

#include <exception>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>
#include <utility>

namespace featureline::server {

/// An error with its HTTP status and machine-readable code, thrown by request handling.
class HttpError : public std::runtime_error {
 public:
  HttpError(int status, std::string code, const std::string& message,
            std::vector<std::pair<std::string, std::string>> headers = {})
      : std::runtime_error(message), status_(status), code_(std::move(code)), headers_(std::move(headers)) {}
  int status() const { return status_; }
  const std::string& code() const { return code_; }
  const std::vector<std::pair<std::string, std::string>>& headers() const { return headers_; }

 private:
  int status_;
  std::string code_;
  std::vector<std::pair<std::string, std::string>> headers_;
};

struct ErrorReply {
  int status = 500;
  std::string code = "internal";
  std::string message = "internal error";
  std::vector<std::pair<std::string, std::string>> headers;
  std::string body() const;  ///< the JSON document
};

/// Client-supplied text for an error message: printable ASCII kept, every other byte as \xHH,
/// at most 64 characters. Error messages must be valid UTF-8 (JSON cannot carry anything else),
/// and a client's bytes must not be able to break the error path.
std::string quote_client_text(std::string_view text);

/// Maps any exception (HttpError, engine errors, JSON errors, bad_alloc, others) to a reply.
/// Unknown exceptions become 500 without their text, so internals never leak to clients.
ErrorReply error_reply(std::exception_ptr error);

/// The reply for an HTTP status the library produced on its own (routing miss, oversized body).
ErrorReply error_reply_for_status(int status);

}  // namespace featureline::server
