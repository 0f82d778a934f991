// Request bodies parsed within a memory bound. A JSON DOM costs far more than its text where the
// text is many tiny containers ("[{},{},...]": about 100 bytes of DOM per 3 bytes of text), so a
// body is first measured by a SAX pass that allocates nothing, and parsed only when its DOM
// would stay within a small multiple of its size.
#pragma once

#include <cstddef>
#include <string_view>

#include <nlohmann/json.hpp>

#include <string>

namespace featureline {

/// What a DOM of a JSON text would hold.
struct JsonShape {
  std::size_t values = 0;        ///< every value, containers included
  std::size_t containers = 0;    ///< objects and arrays
  std::size_t string_bytes = 0;  ///< characters of strings and keys
  std::size_t depth = 0;         ///< deepest nesting

  /// Bytes the DOM would allocate, from nlohmann::json's layout (16-byte values, one heap node
  /// per object member, a vector per array, strings beyond the small-string buffer), rounded up.
  std::size_t dom_bytes() const { return values * 48 + containers * 64 + string_bytes; }
};

/// Limits of one body.
struct JsonBudget {
  std::size_t dom_bytes_per_text_byte = 16;  ///< the DOM may take this many bytes per byte of text...
  std::size_t dom_bytes_floor = 8 << 20;     ///< ... or this much, whichever is more (every request of
                                             ///  64 lines of 128 point keys fits)
  std::size_t max_depth = 64;                ///< nesting deeper than any request needs
};

/// The shape of `text` without building it. \throw nlohmann::json::parse_error exactly as
/// nlohmann::json::parse would for invalid text
JsonShape measure_json(std::string_view text);

/// The most DOM bytes `budget` allows for a text of `text_bytes`.
std::size_t allowed_dom_bytes(std::size_t text_bytes, const JsonBudget& budget);

/// Parses `text` after checking its shape against `budget`. \throw LimitExceededError naming what
/// is too large (nesting, or the DOM's size against the body's), nlohmann::json::parse_error
nlohmann::json parse_json_within(std::string_view text, const JsonBudget& budget = {});

/// Checks a measured text (`text_bytes` long) against `budget`. \throw LimitExceededError as above
void check_json_shape(std::size_t text_bytes, const JsonShape& shape, const JsonBudget& budget = {});

/// What a JSON parse error says, without nlohmann's "[json.exception.parse_error.101] " prefix
/// (a parse error, or a number too large for a double: out_of_range.406).
std::string json_error_sentence(const nlohmann::json::exception& error);

}  // namespace featureline
