// Internal to the engine: timing stages with one clock (the stage timings results report), and
// the order statistics of samples (medians, percentiles).
#pragma once

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <vector>

namespace featureline {

using StageClock = std::chrono::steady_clock;

/// Milliseconds since `start`.
inline double ms_since(StageClock::time_point start) {
  return std::chrono::duration<double, std::milli>(StageClock::now() - start).count();
}

/// Milliseconds since `start`, and restarts it, so consecutive stages are timed without gaps.
inline double lap_ms(StageClock::time_point& start) {
  const auto now = StageClock::now();
  const double ms = std::chrono::duration<double, std::milli>(now - start).count();
  start = now;
  return ms;
}

/// The value of rank k (0-based, ascending) among `values`, which it partially reorders; 0 when
/// there are none. \pre k < values.size() when values is not empty
inline double value_of_rank(std::vector<double>& values, std::size_t k) {
  if (values.empty()) return 0;
  std::nth_element(values.begin(), values.begin() + std::ptrdiff_t(k), values.end());
  return values[k];
}

/// The median (for an even count the upper of the middle two); 0 when there are none.
inline double median_of(std::vector<double> values) { return value_of_rank(values, values.size() / 2); }

}  // namespace featureline
