#include "server/json_body.h"

// Eigen (through the API headers) must come before httplib.h: its <resolv.h> defines `_res`.
#include "api/json_budget.h"
#include "api/options_table.h"
#include "engine/errors.h"
#include "server/content_negotiation.h"
#include "server/metrics.h"

#include <httplib.h>

#include <algorithm>

namespace featureline::server {

namespace {

constexpr std::size_t kMaxJsonBytes = RequestLimits::max_json_bytes;
constexpr std::size_t kMinConcurrentLargestBodies = 16;

}  // namespace

std::size_t JsonBodies::budget_for(std::size_t cache_bytes) {
  return std::max(kMinConcurrentLargestBodies * kMaxJsonBytes, cache_bytes / 4);
}

void JsonBodies::read(const httplib::ContentReader& reader, JsonBody& body) {
  Appended last = Appended::ok;
  const bool complete = reader([&](const char* data, std::size_t size) {
    last = append_held(body.text, body.held, kMaxJsonBytes, data, size);
    return last == Appended::ok;
  });
  if (last == Appended::past_limit)
    throw HttpError(413, "payload_too_large", "the request body exceeds " + std::to_string(kMaxJsonBytes >> 20) + " MiB");
  if (last == Appended::account_full) throw memory_full();
  if (!complete) throw HttpError(400, "invalid_request", "the request body ended early");
}

nlohmann::json JsonBodies::parse(const httplib::Request& req, JsonBody& body) {
  require_json_body(req);
  const JsonShape shape = measure_json(body.text);
  check_json_shape(body.text.size(), shape);
  if (!body.held.hold(body.text.capacity() + shape.dom_bytes())) throw memory_full();
  nlohmann::json parsed = nlohmann::json::parse(body.text);
  if (!parsed.is_object()) throw InvalidInputError("the request body must be a JSON object");
  return parsed;
}

HttpError JsonBodies::memory_full() {
  metrics_.record_rejected("json_memory_full");
  return HttpError(503, "overloaded", "request bodies being parsed already hold " + used_of_capacity(memory_) + " they may; retry shortly",
                   {{"Retry-After", "1"}});
}

}  // namespace featureline::server
