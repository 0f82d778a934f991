#include "server/metrics.h"

#include <sstream>
#include <tuple>

namespace featureline::server {

void Metrics::record_request(const std::string& route, const std::string& method, int status, double seconds) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++requests_[{route, method, status}];
  Histogram& h = latency_[{route, method}];
  for (std::size_t i = 0; i < kBuckets.size(); ++i)
    if (seconds <= kBuckets[i]) ++h.buckets[i];
  ++h.count;
  h.sum += seconds;
}

void Metrics::record_rejected(const std::string& reason) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++rejected_[reason];
}

std::string Metrics::render(const std::map<std::string, std::pair<std::string, double>>& gauges) const {
  std::ostringstream out;
  out.precision(10);
  std::lock_guard<std::mutex> lock(mutex_);
  out << "# HELP featureline_http_requests_total HTTP requests by route, method and status.\n"
      << "# TYPE featureline_http_requests_total counter\n";
  for (const auto& [key, n] : requests_)
    out << "featureline_http_requests_total{route=\"" << std::get<0>(key) << "\",method=\"" << std::get<1>(key)
        << "\",status=\"" << std::get<2>(key) << "\"} " << n << "\n";
  out << "# HELP featureline_http_request_duration_seconds Time from routing to response, by route and method.\n"
      << "# TYPE featureline_http_request_duration_seconds histogram\n";
  for (const auto& [key, h] : latency_) {
    const std::string labels = "route=\"" + key.first + "\",method=\"" + key.second + "\"";
    for (std::size_t i = 0; i < kBuckets.size(); ++i)
      out << "featureline_http_request_duration_seconds_bucket{" << labels << ",le=\"" << kBuckets[i] << "\"} "
          << h.buckets[i] << "\n";
    out << "featureline_http_request_duration_seconds_bucket{" << labels << ",le=\"+Inf\"} " << h.count << "\n";
    out << "featureline_http_request_duration_seconds_sum{" << labels << "} " << h.sum << "\n";
    out << "featureline_http_request_duration_seconds_count{" << labels << "} " << h.count << "\n";
  }
  out << "# HELP featureline_rejected_requests_total Requests refused before any work, by reason.\n"
      << "# TYPE featureline_rejected_requests_total counter\n";
  for (const auto& [reason, n] : rejected_)
    out << "featureline_rejected_requests_total{reason=\"" << reason << "\"} " << n << "\n";
  for (const auto& [name, help_and_value] : gauges) {
    const bool counter = name.size() > 6 && name.compare(name.size() - 6, 6, "_total") == 0;
    out << "# HELP " << name << " " << help_and_value.first << "\n"
        << "# TYPE " << name << (counter ? " counter" : " gauge") << "\n"
        << name << " " << help_and_value.second << "\n";
  }
  return out.str();
}

}  // namespace featureline::server
