// Prometheus metrics: requests and latency histograms per route and status, and gauges the
// server reports at scrape time (cache, pool).
#pragma once

#include <array>
#include <atomic>
#include <map>
#include <mutex>
#include <string>
#include <utility>

namespace featureline::server {

class Metrics {
 public:
  /// Latency bucket bounds in seconds (Prometheus histogram `le` labels).
  static constexpr std::array<double, 12> kBuckets = {0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025,
                                                      0.05,   0.1,   0.25,   0.5,   1.0,  5.0};

  void record_request(const std::string& route, const std::string& method, int status, double seconds);
  void record_rejected(const std::string& reason);

  /// Text exposition format 0.0.4; `gauges` are appended as `name value` lines with HELP/TYPE.
  std::string render(const std::map<std::string, std::pair<std::string, double>>& gauges) const;

 private:
  struct Histogram {
    std::array<std::uint64_t, kBuckets.size()> buckets{};
    std::uint64_t count = 0;
    double sum = 0;
  };
  mutable std::mutex mutex_;
  std::map<std::tuple<std::string, std::string, int>, std::uint64_t> requests_;  // route, method, status
  std::map<std::pair<std::string, std::string>, Histogram> latency_;            // route, method
  std::map<std::string, std::uint64_t> rejected_;
};

}  // namespace featureline::server
