// Small pieces shared by the synthetic mesh generators (synthetic_meshes.cpp,
// accuracy_meshes.cpp): argument checks that throw std::invalid_argument, and their types.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace featureline::testing::detail {

constexpr double kPi = 3.14159265358979323846;

using Vec3 = std::array<double, 3>;
using Triangle = std::array<std::uint32_t, 3>;

inline void require(bool condition, const char* function, const std::string& message) {
  if (!condition) throw std::invalid_argument(std::string(function) + ": " + message);
}

inline bool positive_finite(double value) { return std::isfinite(value) && value > 0; }

}  // namespace featureline::testing::detail
