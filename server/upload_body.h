// Upload bodies: the head checked before a byte of the body is read, then the body read chunk by
// chunk into a buffer held against one budget shared by every upload being received (503 when
// it is spent), as one mesh file or as a .gltf with the files it names (multipart/form-data).
#pragma once

#include <cstddef>
#include <memory>

#include "server/byte_account.h"
#include "server/content_negotiation.h"
#include "server/http_errors.h"
#include "server/upload_store.h"

namespace httplib {
class ContentReader;
}  // namespace httplib

namespace featureline::server {

class Metrics;

/// What an upload's head says, checked before its body is read.
struct UploadHead {
  std::size_t length = 0;  ///< Content-Length, within the upload limit
  UploadType type;         ///< the format it names, or files, or neither (sniffed)
};

class UploadBodies {
 public:
  /// `max_upload_bytes`: the largest body; `buffer_bytes`: all bodies being received at once.
  /// `metrics` counts the refusals and must outlive this.
  UploadBodies(std::size_t max_upload_bytes, std::size_t buffer_bytes, Metrics& metrics);

  /// Refuses an upload from its head alone. Transfer-Encoding, Content-Encoding, a repeated or
  /// oversized Content-Length never get here: the transport refuses them.
  /// \throw HttpError 411, 400, 413, 415
  UploadHead check_head(const httplib::Request& req);

  /// Reads the body whole while `held` (on buffer()) holds its bytes, which the caller keeps
  /// until the upload is prepared. `body_read` is set when the body was consumed; when it is
  /// not, the transport closes the connection so its bytes are never read as a next request.
  /// \throw HttpError 400 (ended early, malformed parts), 415 (format unknown), 503 (budget spent)
  std::shared_ptr<StoredUpload> read(const UploadHead& head, const httplib::ContentReader& reader, ByteHold& held,
                                     bool& body_read);

  ByteAccount& buffer() { return buffer_; }

 private:
  std::string read_gltf_files(const httplib::ContentReader& reader, std::size_t length, ByteHold& held, bool& body_read);
  std::string read_mesh_file(const httplib::ContentReader& reader, std::size_t length, ByteHold& held, bool& body_read);
  HttpError buffer_full();

  const std::size_t max_upload_bytes_;
  ByteAccount buffer_;
  Metrics& metrics_;
};

}  // namespace featureline::server
