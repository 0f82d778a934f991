#include "engine/valid_range.h"

#include <sstream>

namespace featureline {

std::string format_number(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

std::string describe(const ValidRange& range) {
  return (range.min_open ? "(" : "[") + format_number(range.min) + ", " + format_number(range.max) + (range.max_open ? ")" : "]");
}

}  // namespace featureline
