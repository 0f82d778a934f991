// Internal to the engine: order statistics of samples (medians, percentiles) by partial sorting.
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

namespace featureline {

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
