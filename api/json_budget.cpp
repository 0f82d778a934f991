#include "api/json_budget.h"

#include <algorithm>
#include <memory>
#include <string>

#include "engine/errors.h"

namespace featureline {

using nlohmann::json;

namespace {

// Counts what json::parse would build; stops at the first syntax error, keeping it to rethrow.
struct ShapeCounter : json::json_sax_t {
  JsonShape shape;
  std::size_t level = 0;
  std::unique_ptr<json::parse_error> error;
  std::unique_ptr<json::exception> other_error;

  bool value() {
    ++shape.values;
    return true;
  }
  bool null() override { return value(); }
  bool boolean(bool) override { return value(); }
  bool number_integer(number_integer_t) override { return value(); }
  bool number_unsigned(number_unsigned_t) override { return value(); }
  bool number_float(number_float_t, const string_t&) override { return value(); }
  bool string(string_t& s) override {
    shape.string_bytes += s.size();
    return value();
  }
  bool binary(binary_t& b) override {
    shape.string_bytes += b.size();
    return value();
  }
  bool open() {
    ++shape.containers;
    shape.depth = std::max(shape.depth, ++level);
    return value();
  }
  bool start_object(std::size_t) override { return open(); }
  bool start_array(std::size_t) override { return open(); }
  bool end_object() override {
    --level;
    return true;
  }
  bool end_array() override {
    --level;
    return true;
  }
  bool key(string_t& k) override {
    shape.string_bytes += k.size();
    return true;
  }
  bool parse_error(std::size_t, const std::string&, const json::exception& ex) override {
    if (const auto* p = dynamic_cast<const json::parse_error*>(&ex)) error = std::make_unique<json::parse_error>(*p);
    else other_error = std::make_unique<json::exception>(ex);
    return false;
  }
};

}  // namespace

JsonShape measure_json(std::string_view text) {
  ShapeCounter counter;
  json::sax_parse(text.begin(), text.end(), &counter);
  if (counter.error) throw *counter.error;
  if (counter.other_error) throw *counter.other_error;
  return counter.shape;
}

std::size_t allowed_dom_bytes(std::size_t text_bytes, const JsonBudget& budget) {
  return std::max(budget.dom_bytes_floor, text_bytes * budget.dom_bytes_per_text_byte);
}

json parse_json_within(std::string_view text, const JsonBudget& budget) {
  check_json_shape(text.size(), measure_json(text), budget);
  return json::parse(text);
}

void check_json_shape(std::size_t text_bytes, const JsonShape& shape, const JsonBudget& budget) {
  if (shape.depth > budget.max_depth)
    throw LimitExceededError("the request body nests " + std::to_string(shape.depth) + " levels deep; at most " +
                             std::to_string(budget.max_depth) + " are accepted");
  const std::size_t allowed = allowed_dom_bytes(text_bytes, budget);
  if (shape.dom_bytes() > allowed)
    throw LimitExceededError("the request body holds " + std::to_string(shape.values) + " JSON values (" +
                             std::to_string(shape.containers) + " objects and arrays) in " + std::to_string(text_bytes) +
                             " bytes: parsed, it would take about " + std::to_string(shape.dom_bytes() >> 20) +
                             " MiB, more than the " + std::to_string(allowed >> 20) + " MiB a body of its size may take");
}

std::string json_error_sentence(const nlohmann::json::exception& error) {
  std::string what = error.what();
  if (const auto end = what.find("] "); !what.empty() && what[0] == '[' && end != std::string::npos) what.erase(0, end + 2);
  return what;
}

}  // namespace featureline
