#include "tests/support/curved_crests.h"

#include <algorithm>
#include <cmath>
#include <memory>

#include "tests/support/generator_detail.h"

namespace featureline::testing {
namespace {

using detail::kPi;
using detail::positive_finite;
using detail::require;

// The sine crest y = a sin(k x) + b.
struct SineCrest {
  double a = 0.15, k = kPi, b = kRidgeCrestOffset;
  double y(double x) const { return a * std::sin(k * x) + b; }
  double slope(double x) const { return a * k * std::cos(k * x); }
  double second(double x) const { return -a * k * k * std::sin(k * x); }

  // The parameter of the curve point nearest (x, y). The vertical offset bounds the distance, so
  // that point lies within it of x; samples finer than the curve's bends (radius of curvature
  // >= 0.68) bracket the nearest one, and golden-section search narrows the bracket to rounding.
  double nearest(double x, double y) const {
    auto squared = [&](double t) {
      const double dx = t - x, dy = this->y(t) - y;
      return dx * dx + dy * dy;
    };
    const double bound = std::abs(y - this->y(x));
    if (bound == 0) return x;
    const int samples = std::max(8, int(std::ceil(2 * bound / 0.02)));
    const double step = 2 * bound / samples, low = x - bound;
    int best = 0;
    double best_value = squared(low);
    for (int s = 1; s <= samples; ++s)
      if (const double value = squared(low + step * s); value < best_value) best_value = value, best = s;
    const double inv_phi = (std::sqrt(5.0) - 1) / 2;
    double lo = low + step * std::max(best - 1, 0), hi = low + step * std::min(best + 1, samples);
    double c = hi - inv_phi * (hi - lo), d = lo + inv_phi * (hi - lo);
    double fc = squared(c), fd = squared(d);
    for (int iteration = 0; iteration < 200 && hi - lo > 1e-14; ++iteration) {
      if (fc < fd) {
        hi = d, d = c, fd = fc;
        c = hi - inv_phi * (hi - lo), fc = squared(c);
      } else {
        lo = c, c = d, fc = fd;
        d = lo + inv_phi * (hi - lo), fd = squared(d);
      }
    }
    const double t = 0.5 * (lo + hi);
    return squared(t) <= best_value ? t : low + step * best;
  }
  double distance(double x, double y) const {
    const double t = nearest(x, y);
    return std::hypot(t - x, this->y(t) - y);
  }
  double inward_offset(double x, double y) const {
    const double t = nearest(x, y);
    const double s = slope(t), norm = std::hypot(s, 1.0);
    const double up = ((x - t) * -s + (y - this->y(t))) / norm;  // along the normal (-y', 1)
    const double bend = second(t);
    return bend > 0 ? up : bend < 0 ? -up : 0.0;
  }
};

}  // namespace

const char* to_string(CrestCurve curve) { return curve == CrestCurve::arc ? "arc" : "sine"; }

CurvedCrestField make_curved_crest_field(const CurvedCrestOptions& o) {
  require(std::isfinite(o.amplitude) && o.amplitude != 0, "make_curved_crest_field", "amplitude must be finite and non-zero");
  require(positive_finite(o.width) && o.width <= 0.3, "make_curved_crest_field", "width must be in (0, 0.3]");
  CurvedCrestField out;
  out.curve = o.curve;
  const double amplitude = o.amplitude, width = o.width;
  if (o.curve == CrestCurve::arc) {
    // The radius of curvature is 3 widths: as tight as the profile allows while its distance
    // field stays smooth where the profile is not yet flat; the top of the arc stays at y = 0.25.
    const double radius = 3 * width;
    const Eigen::Vector2d centre(0, 0.25 - radius);
    out.distance = [centre, radius](double x, double y) { return std::abs((Eigen::Vector2d(x, y) - centre).norm() - radius); };
    out.inward_offset = [centre, radius](double x, double y) { return radius - (Eigen::Vector2d(x, y) - centre).norm(); };
    out.crest_point = [centre, radius](double t) {
      const double angle = (35 + 110 * t) * kPi / 180;
      return Eigen::Vector2d(centre + radius * Eigen::Vector2d(std::cos(angle), std::sin(angle)));
    };
  } else {
    require(width <= 0.68 / 2.5, "make_curved_crest_field", "the sine's bends need width <= 0.27");
    const auto sine = std::make_shared<SineCrest>();
    out.distance = [sine](double x, double y) { return sine->distance(x, y); };
    out.inward_offset = [sine](double x, double y) { return sine->inward_offset(x, y); };
    out.crest_point = [sine](double t) {
      const double x = -0.8 + 1.6 * t;
      return Eigen::Vector2d(x, sine->y(x));
    };
  }
  auto distance = out.distance;
  out.field = make_height_field(
      [distance, amplitude, width](double x, double y) {
        const double d = distance(x, y) / width;
        return amplitude * std::exp(-d * d);
      },
      o.n, o.jitter, o.seed);
  return out;
}

namespace {

// The larger principal curvature magnitude of the graph z = height(x, y) at (x, y), from the first
// and second fundamental forms with central differences.
double largest_curvature(const std::function<double(double, double)>& z, double x, double y) {
  const double h = 1e-4;
  const double zx = (z(x + h, y) - z(x - h, y)) / (2 * h), zy = (z(x, y + h) - z(x, y - h)) / (2 * h);
  const double zxx = (z(x + h, y) - 2 * z(x, y) + z(x - h, y)) / (h * h);
  const double zyy = (z(x, y + h) - 2 * z(x, y) + z(x, y - h)) / (h * h);
  const double zxy = (z(x + h, y + h) - z(x + h, y - h) - z(x - h, y + h) + z(x - h, y - h)) / (4 * h * h);
  const double g = std::sqrt(1 + zx * zx + zy * zy);
  const double e = 1 + zx * zx, f = zx * zy, gg = 1 + zy * zy, l = zxx / g, m = zxy / g, n = zyy / g;
  const double det = e * gg - f * f;
  const double a = (gg * l - f * m) / det, b = (gg * m - f * n) / det, c = (e * m - f * l) / det, d = (e * n - f * m) / det;
  const double half_trace = (a + d) / 2, root = std::sqrt(std::max(half_trace * half_trace - (a * d - b * c), 0.0));
  return std::max(std::abs(half_trace + root), std::abs(half_trace - root));
}

}  // namespace

std::vector<Eigen::Vector3d> ridge_field_feature_crest(const HeightField& field, double x0, double x1, double step) {
  require(static_cast<bool>(field.crest) && static_cast<bool>(field.height), "ridge_field_feature_crest",
          "the field has no crest curve");
  require(x1 > x0 && positive_finite(step), "ridge_field_feature_crest", "empty range or bad step");
  std::vector<Eigen::Vector3d> out;
  const int samples = int(std::ceil((x1 - x0) / step));
  for (int i = 0; i <= samples; ++i) {
    const double x = std::min(x1, x0 + step * i), e = 1e-6;
    const Eigen::Vector2d p(x, field.crest(x));
    const Eigen::Vector2d t = Eigen::Vector2d(2 * e, field.crest(x + e) - field.crest(x - e)).normalized();
    const Eigen::Vector2d normal(-t.y(), t.x());
    auto value = [&](double s) {
      const Eigen::Vector2d q = p + s * normal;
      return largest_curvature(field.height, q.x(), q.y());
    };
    const double inv_phi = (std::sqrt(5.0) - 1) / 2;
    double lo = -0.005, hi = 0.005, c = hi - inv_phi * (hi - lo), d = lo + inv_phi * (hi - lo);
    double fc = value(c), fd = value(d);
    for (int iteration = 0; iteration < 80 && hi - lo > 1e-12; ++iteration) {
      if (fc > fd) {
        hi = d, d = c, fd = fc;
        c = hi - inv_phi * (hi - lo), fc = value(c);
      } else {
        lo = c, c = d, fc = fd;
        d = lo + inv_phi * (hi - lo), fd = value(d);
      }
    }
    const Eigen::Vector2d q = p + 0.5 * (lo + hi) * normal;
    out.emplace_back(q.x(), q.y(), 0.0);
  }
  return out;
}

std::vector<std::uint32_t> keys_on_curved_crest(const CurvedCrestField& field, const std::vector<double>& ts) {
  std::vector<std::uint32_t> keys;
  for (double t : ts) {
    const Eigen::Vector2d p = field.crest_point(t);
    keys.push_back(nearest_vertex(field.field.mesh, p.x(), p.y()));
  }
  return keys;
}

CurvedCrestField make_sine_crest_field(int n, std::uint64_t seed, double amplitude) {
  CurvedCrestOptions options;
  options.curve = CrestCurve::sine;
  options.n = n;
  options.seed = seed;
  options.amplitude = amplitude;
  return make_curved_crest_field(options);
}

}  // namespace featureline::testing
