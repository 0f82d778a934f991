#include "engine/line_averaging.h"

#include <cmath>
#include <optional>

#include <Eigen/Dense>

#include "engine/errors.h"

namespace featureline {
namespace {

// The ladder of bandwidths, in units: each 1.5 times the last, from one unit (the narrowest
// window any point gets) to eleven.
constexpr double kBandwidths[] = {1.0, 1.5, 2.25, 3.4, 5.0, 7.5, 11.0};
// Neighbours further than this many bandwidths carry no weight worth summing.
constexpr double kReach = 3;

// A local quadratic regression at one point: its estimate and the sum of its squared
// equivalent-kernel weights (the estimate's variance over one point's).
struct LocalFit {
  Eigen::Vector3d estimate = Eigen::Vector3d::Zero();
  double variance = 0;
  bool ok = false;
};

class LocalQuadratic {
 public:
  explicit LocalQuadratic(const AveragedLineInput& line) : line_(line) {}

  // The fit at point i with Gaussian weights of standard deviation h along the line, its window
  // ending at corners (a corner's own point is the window's last).
  LocalFit at(std::size_t i, double h) {
    normal_.setZero();
    rhs_.setZero();
    offsets_.clear();
    add(i, 0, h);
    const std::size_t n = line_.points.size();
    std::size_t used = 1;
    for (const int step : {-1, 1}) {
      std::size_t at = i;
      double offset = 0;
      while (used < n) {
        const auto next = neighbour(at, step);
        if (!next) break;
        offset += step * arc_between(step < 0 ? *next : at, step < 0 ? at : *next);
        at = *next;
        if (std::abs(offset) > kReach * h) break;
        add(at, offset, h);
        ++used;
        if (line_.corner[at]) break;
      }
    }
    return solve();
  }

 private:
  std::optional<std::size_t> neighbour(std::size_t at, int step) const {
    const std::size_t n = line_.points.size();
    if (line_.period > 0) return step < 0 ? (at + n - 1) % n : (at + 1) % n;
    if (step < 0) return at == 0 ? std::nullopt : std::optional<std::size_t>(at - 1);
    return at + 1 >= n ? std::nullopt : std::optional<std::size_t>(at + 1);
  }
  // Arc length from point a to the next point b (across the seam of a closed line).
  double arc_between(std::size_t a, std::size_t b) const {
    const double d = line_.u[b] - line_.u[a];
    return d < 0 && line_.period > 0 ? d + line_.period : d;
  }
  void add(std::size_t j, double offset, double h) {
    const double x = offset / h, w = std::exp(-0.5 * x * x);
    const Eigen::Vector3d basis(1, x, x * x);
    normal_ += w * basis * basis.transpose();
    rhs_ += w * basis * line_.points[j].transpose();
    offsets_.push_back(x);
  }
  LocalFit solve() const {
    LocalFit fit;
    // Too few points on one side (a line's end, a corner) leave the quadratic undetermined.
    if (!(normal_(2, 2) > 1e-6 * normal_(0, 0))) return fit;
    const Eigen::LDLT<Eigen::Matrix3d> solver(normal_);
    if (solver.info() != Eigen::Success) return fit;
    const Eigen::Vector3d row = solver.solve(Eigen::Vector3d::UnitX());  // the estimate is row . rhs
    if (!row.allFinite()) return fit;
    for (const double x : offsets_) {
      const double weight = std::exp(-0.5 * x * x) * row.dot(Eigen::Vector3d(1, x, x * x));
      fit.variance += weight * weight;
    }
    fit.estimate = (row.transpose() * rhs_).transpose();
    fit.ok = fit.estimate.allFinite();
    return fit;
  }

  const AveragedLineInput& line_;
  Eigen::Matrix3d normal_;
  Eigen::Matrix3d rhs_;  // rows: basis functions; columns: x, y, z
  std::vector<double> offsets_;
};

void check_line_averaging_options(const LineAveragingOptions& o) {
  check_in_range(LineAveragingOptions::confidence_range, o.confidence, "line averaging confidence");
  check_in_range(LineAveragingOptions::points_per_error_range, o.points_per_error, "line averaging points per error");
}

}  // namespace

AveragedLine average_along_line(const AveragedLineInput& line, const LineAveragingOptions& options) {
  check_line_averaging_options(options);
  const std::size_t n = line.points.size();
  if (line.u.size() != n || line.movable.size() != n || line.corner.size() != n)
    throw InvalidInputError("line averaging: u, movable and corner need one entry per point");
  AveragedLine out{line.points, std::vector<double>(n, 0.0)};
  if (!(line.sigma > 0) || !(line.unit > 0)) return out;
  LocalQuadratic fits(line);
  for (std::size_t i = 0; i < n; ++i) {
    if (!line.movable[i] || line.corner[i]) continue;
    // The intersection of the intervals so far, per axis.
    Eigen::Array3d low = Eigen::Array3d::Constant(-HUGE_VAL), high = Eigen::Array3d::Constant(HUGE_VAL);
    for (const double bandwidth : kBandwidths) {
      const LocalFit fit = fits.at(i, bandwidth * line.unit);
      if (!fit.ok) break;
      const double half = options.confidence * line.sigma * std::sqrt(fit.variance * options.points_per_error);
      low = low.max(fit.estimate.array() - half);
      high = high.min(fit.estimate.array() + half);
      if ((low > high).any()) break;
      out.points[i] = fit.estimate;
      out.bandwidth[i] = bandwidth;
    }
  }
  return out;
}

}  // namespace featureline
