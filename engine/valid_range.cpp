#include "engine/valid_range.h"

#include <sstream>

#include "engine/errors.h"

namespace featureline {

std::string format_number(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

std::string describe(const ValidRange& range) {
  return (range.min_open ? "(" : "[") + format_number(range.min) + ", " + format_number(range.max) + (range.max_open ? ")" : "]");
}

void check_in_range(const ValidRange& range, double value, const std::string& name) {
  if (!range.contains(value)) throw InvalidInputError(name + " must be in " + describe(range));
}

}  // namespace featureline
