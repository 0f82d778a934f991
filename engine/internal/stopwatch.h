// Internal to the engine: timing stages with one clock (the stage timings results report).
#pragma once

#include <chrono>

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

}  // namespace featureline
