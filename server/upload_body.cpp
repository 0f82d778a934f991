#include "server/upload_body.h"

// Eigen (through the engine headers) must come before httplib.h: its <resolv.h> defines `_res`.
#include <httplib.h>

#include <algorithm>
#include <cctype>
#include <ctime>
#include <string>
#include <utility>
#include <vector>

#include "engine/mesh_io.h"
#include "server/metrics.h"

namespace featureline::server {

namespace {

// Upload buffers start at this and double as bytes arrive.
constexpr std::size_t kUploadChunkBytes = std::size_t(1) << 20;
// A .gltf and its .bin files rarely number more than a few; every part costs a string.
constexpr std::size_t kMaxUploadFiles = 64;
// More digits than any upload limit has (and than std::stoull could overflow on).
constexpr std::size_t kMaxLengthDigits = 15;

bool is_gltf_name(const std::string& name) { return mesh_format_from_path(name) == MeshFormat::gltf; }

}  // namespace

UploadBodies::UploadBodies(std::size_t max_upload_bytes, std::size_t buffer_bytes, Metrics& metrics)
    : max_upload_bytes_(max_upload_bytes), buffer_(buffer_bytes), metrics_(metrics) {}

UploadHead UploadBodies::check_head(const httplib::Request& req) {
  auto refuse = [&](int status, const std::string& code, const std::string& message) {
    metrics_.record_rejected(code);
    throw HttpError(status, code, message);
  };
  UploadHead head;
  if (!req.has_header("Content-Length")) refuse(411, "length_required", "the upload needs a Content-Length header");
  const std::string length_text = req.get_header_value("Content-Length");
  if (length_text.empty() || length_text.size() > kMaxLengthDigits || length_text.find_first_not_of("0123456789") != std::string::npos)
    refuse(400, "invalid_request", "Content-Length is not a number");
  head.length = std::stoull(length_text);
  if (head.length == 0) refuse(400, "malformed_mesh", "the upload is empty");
  if (head.length > max_upload_bytes_)
    refuse(413, "payload_too_large", "the upload is " + std::to_string(head.length) + " bytes; this server accepts at most " +
                                         std::to_string(max_upload_bytes_ >> 20) + " MiB");
  try {
    head.type = upload_type(req);
  } catch (const HttpError& e) {
    metrics_.record_rejected(e.code());
    throw;
  }
  return head;
}

std::shared_ptr<StoredUpload> UploadBodies::read(const UploadHead& head, const httplib::ContentReader& reader, ByteHold& held,
                                                 bool& body_read) {
  if (!held.hold(std::min(head.length, kUploadChunkBytes))) throw buffer_full();
  // The bytes are kept as uploaded: the store holds them so the mesh can be prepared again.
  auto upload = std::make_shared<StoredUpload>();
  if (head.type.files) {
    upload->bytes = read_gltf_files(reader, head.length, held, body_read);
    upload->format = upload->bytes.rfind("glTF", 0) == 0 ? MeshFormat::glb : MeshFormat::gltf;  // packed, or had no files to pack
  } else {
    upload->bytes = read_mesh_file(reader, head.length, held, body_read);
    upload->format = head.type.format ? *head.type.format : sniff_upload_format(upload->bytes);
  }
  upload->uploaded_at_unix_s = std::int64_t(std::time(nullptr));
  return upload;
}

std::string UploadBodies::read_mesh_file(const httplib::ContentReader& reader, std::size_t length, ByteHold& held, bool& body_read) {
  std::string body;
  body.reserve(std::min(length, kUploadChunkBytes));
  Appended last = Appended::ok;
  const bool complete = reader([&](const char* data, std::size_t size) {
    last = append_held(body, held, length, data, size);
    return last == Appended::ok;
  });
  if (last == Appended::account_full) throw buffer_full();
  body_read = complete && body.size() == length;
  if (!body_read)
    throw HttpError(400, "malformed_mesh", "the upload ended after " + std::to_string(body.size()) + " of " + std::to_string(length) + " bytes");
  return body;
}

// A .gltf posted with the files it names (a browser's FormData, curl -F): the parts are read
// within the upload's hold, then packed into one GLB (engine pack_gltf_files), which is what is
// stored and prepared, so the session can be rebuilt from one blob like any upload.
std::string UploadBodies::read_gltf_files(const httplib::ContentReader& reader, std::size_t length, ByteHold& held, bool& body_read) {
  std::vector<std::pair<std::string, std::string>> parts;
  std::size_t received = 0;
  bool buffer_spent = false, too_many = false;
  const bool complete = reader(
      [&](const httplib::MultipartFormData& part) {
        if (parts.size() >= kMaxUploadFiles) return !(too_many = true);
        parts.emplace_back(part.filename.empty() ? part.name : part.filename, std::string());
        return true;
      },
      [&](const char* data, std::size_t size) {
        received += size;
        if (received > length || !held.hold(received)) return !(buffer_spent = true);
        parts.back().second.append(data, size);
        return true;
      });
  if (buffer_spent) throw buffer_full();
  if (too_many) throw HttpError(400, "malformed_mesh", "an upload of files has at most " + std::to_string(kMaxUploadFiles) + " parts");
  body_read = complete;
  if (!complete) throw HttpError(400, "malformed_mesh", "the multipart upload is malformed or ended early");
  const auto documents = std::count_if(parts.begin(), parts.end(), [](const auto& p) { return is_gltf_name(p.first); });
  if (documents != 1)
    throw HttpError(415, "unsupported_format", "an upload of files takes one .gltf file and the files it names (" +
                                                   std::to_string(documents) + " .gltf files were sent)");
  const auto document = std::find_if(parts.begin(), parts.end(), [](const auto& p) { return is_gltf_name(p.first); });
  const std::string gltf = std::move(document->second);
  parts.erase(document);
  return pack_gltf_files(gltf, parts);
}

// Bodies being received sit outside the cache budget: their total is bounded by the bytes each
// has received (not what it declares), so a few slow large uploads cannot hold the memory.
HttpError UploadBodies::buffer_full() {
  metrics_.record_rejected("upload_buffer_full");
  return HttpError(503, "overloaded", "uploads being received already hold " + used_of_capacity(buffer_) + " the server buffers; retry shortly",
                   {{"Retry-After", "5"}});
}

}  // namespace featureline::server
