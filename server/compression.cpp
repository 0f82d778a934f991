#include "server/compression.h"

// Eigen (through the export formats) must come before httplib.h: its <resolv.h> defines `_res`.
#include "server/content_negotiation.h"

#include <httplib.h>
#include <zlib.h>

#include <algorithm>
#include <cctype>
#include <limits>
#include <stdexcept>

namespace featureline {

namespace {

bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(a[i])) != std::tolower(static_cast<unsigned char>(b[i]))) return false;
  return true;
}

}  // namespace

bool accepts_gzip(std::string_view accept_encoding) {
  double gzip_q = -1;  // not named
  double any_q = -1;   // "*"
  for (const auto& [coding, q] : server::weighted_elements(accept_encoding)) {
    if (iequals(coding, "gzip") || iequals(coding, "x-gzip")) gzip_q = std::max(gzip_q, q);
    else if (coding == "*") any_q = std::max(any_q, q);
  }
  // An explicit "gzip;q=0" refuses gzip even when "*" would allow it.
  return gzip_q >= 0 ? gzip_q > 0 : any_q > 0;
}

std::string gzip_compress(std::string_view data, int level) {
  if (data.size() > std::numeric_limits<uInt>::max()) throw std::runtime_error("gzip: body too large for one zlib call");
  z_stream stream{};
  // windowBits 15 + 16: a gzip header and trailer instead of zlib's.
  if (deflateInit2(&stream, level, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK)
    throw std::runtime_error("gzip: deflateInit2 failed");
  std::string out(deflateBound(&stream, static_cast<uLong>(data.size())) + 32, '\0');
  stream.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  stream.avail_in = static_cast<uInt>(data.size());
  stream.next_out = reinterpret_cast<Bytef*>(out.data());
  stream.avail_out = static_cast<uInt>(out.size());
  const int status = deflate(&stream, Z_FINISH);  // one call: the output buffer is deflateBound
  const auto written = stream.total_out;
  deflateEnd(&stream);
  if (status != Z_STREAM_END) throw std::runtime_error("gzip: deflate did not finish");
  out.resize(written);
  return out;
}

void set_content_gzip_if_accepted(const httplib::Request& req, httplib::Response& res, std::string body,
                                  const char* content_type) {
  res.set_header("Vary", "Accept-Encoding");
  if (accepts_gzip(req.get_header_value("Accept-Encoding")) && !body.empty()) {
    std::string packed = gzip_compress(body);
    if (packed.size() < body.size()) {
      res.set_header("Content-Encoding", "gzip");
      res.set_content(std::move(packed), content_type);
      return;
    }
  }
  res.set_content(std::move(body), content_type);
}

}  // namespace featureline
