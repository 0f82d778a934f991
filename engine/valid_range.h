// The values an engine option accepts, declared beside the option (SnakeOptions::tau_range,
// StripOptions::rings_range, ...): the engine's checks test them, and api/options_table.cpp
// builds its limits from them, so the engine and the API never hold two sets of numbers for the
// same option (tests/api/options_table_test.cpp checks each row against its range).
#pragma once

#include <limits>
#include <string>

namespace featureline {

struct ValidRange {
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool min_open = false;  ///< min itself is refused
  bool max_open = false;  ///< max itself is refused
  /// NaN is never inside.
  constexpr bool contains(double x) const {
    return (min_open ? x > min : x >= min) && (max_open ? x < max : x <= max);
  }
};

/// A limit as errors and help print it: 0.0001, 500, 1e+06.
std::string format_number(double x);

/// "[0, 1)", "(0.01, inf]": the range in interval notation.
std::string describe(const ValidRange& range);

/// \throw InvalidInputError "<name> must be in <range>" when `value` is outside `range`.
void check_in_range(const ValidRange& range, double value, const std::string& name);

/// [lo, hi]
constexpr ValidRange closed_range(double lo, double hi) { return {lo, hi, false, false}; }
/// [lo, hi)
constexpr ValidRange half_open_range(double lo, double hi) { return {lo, hi, false, true}; }
/// (lo, hi)
constexpr ValidRange open_range(double lo, double hi) { return {lo, hi, true, true}; }
/// [lo, infinity]
constexpr ValidRange at_least(double lo) { return {lo, std::numeric_limits<double>::infinity(), false, false}; }
/// (lo, infinity]
constexpr ValidRange above(double lo) { return {lo, std::numeric_limits<double>::infinity(), true, false}; }
/// [lo, infinity): finite numbers from lo
constexpr ValidRange finite_from(double lo) { return half_open_range(lo, std::numeric_limits<double>::infinity()); }
/// [-infinity, hi]
constexpr ValidRange at_most(double hi) { return {-std::numeric_limits<double>::infinity(), hi, false, false}; }

}  // namespace featureline
