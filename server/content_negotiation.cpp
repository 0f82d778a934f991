#include "server/content_negotiation.h"

#include <httplib.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>

#include "server/http_errors.h"

namespace featureline::server {

namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

std::string lower(std::string_view s) {
  std::string out(s);
  std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return out;
}

// Splits off the text before `separator` (all of it when there is none).
std::string_view take_until(std::string_view& rest, char separator) {
  const auto at = rest.find(separator);
  const std::string_view head = rest.substr(0, at);
  rest = at == std::string_view::npos ? std::string_view{} : rest.substr(at + 1);
  return head;
}

// The q-value among one element's parameters ("level=1; q=0.5"); 1 when absent, 0 when
// malformed (a client that writes nonsense gets the default rather than a guess).
double quality(std::string_view params) {
  while (!params.empty()) {
    const std::string_view param = trim(take_until(params, ';'));
    if (param.size() < 2 || std::tolower(static_cast<unsigned char>(param[0])) != 'q' || param[1] != '=') continue;
    const std::string value(trim(param.substr(2)));
    char* end = nullptr;
    const double q = std::strtod(value.c_str(), &end);
    if (value.empty() || end != value.c_str() + value.size() || !(q >= 0 && q <= 1)) return 0;
    return q;
  }
  return 1;
}

std::optional<MeshFormat> mesh_format_of_media_type(std::string_view type) {
  for (const auto& [format, name] : EnumNames<MeshFormat>::entries)
    if (type == mesh_media_type(format)) return format;
  return std::nullopt;
}

HttpError unsupported_format(const std::string& message) { return HttpError(415, "unsupported_format", message); }

}  // namespace

std::vector<WeightedElement> weighted_elements(std::string_view header) {
  std::vector<WeightedElement> elements;
  while (!header.empty()) {
    std::string_view element = take_until(header, ',');
    const std::string_view value = trim(take_until(element, ';'));
    if (!value.empty()) elements.push_back({value, quality(element)});
  }
  return elements;
}

std::string media_type(std::string_view content_type) { return lower(trim(content_type.substr(0, content_type.find(';')))); }

bool accepts(const httplib::Request& req, std::string_view type) {
  const std::string accept = req.get_header_value("Accept");
  for (const auto& element : weighted_elements(accept))
    if (element.quality > 0 && lower(element.value) == type) return true;
  return false;
}

const char* mesh_media_type(MeshFormat format) {
  switch (format) {
    // Registered types, the same the answers are sent with.
    case MeshFormat::obj: return export_format_info(ExportFormat::obj).mime_type;
    case MeshFormat::glb: return export_format_info(ExportFormat::glb).mime_type;
    case MeshFormat::gltf: return export_format_info(ExportFormat::gltf).mime_type;
    case MeshFormat::stl: return "model/stl";
    // No registered type: the ones other tools send.
    case MeshFormat::off: return "model/x-off";
    case MeshFormat::ply: return "application/x-ply";
    case MeshFormat::drc: return "application/x-draco";
  }
  return kOctetStream;
}

UploadType upload_type(const httplib::Request& req) {
  UploadType upload;
  if (req.has_param("format")) {
    const std::string name = req.get_param_value("format");
    upload.format = parse_mesh_format(name);
    if (!upload.format)
      throw unsupported_format("unknown format \"" + quote_client_text(name) + "\"; use one of " + supported_formats());
    return upload;
  }
  const std::string type = media_type(req.get_header_value("Content-Type"));
  upload.format = mesh_format_of_media_type(type);
  if (upload.format || type.empty() || type == kOctetStream) return upload;
  if (type == "multipart/form-data") {
    upload.files = true;
    return upload;
  }
  if (type == "application/x-www-form-urlencoded")
    throw unsupported_format(
        "the body was sent as a form (curl -d does that); send it as application/octet-stream or a model/* type, "
        "e.g. curl --data-binary @mesh.obj -H 'Content-Type: application/octet-stream'");
  throw unsupported_format("unsupported Content-Type \"" + quote_client_text(type) + "\"");
}

MeshFormat sniff_upload_format(std::string_view bytes) {
  const auto format = sniff_mesh_format(bytes);
  if (!format) throw unsupported_format("could not tell the mesh format from its bytes; pass ?format= with one of " + supported_formats());
  return *format;
}

void require_json_body(const httplib::Request& req) {
  const std::string type = media_type(req.get_header_value("Content-Type"));
  if (!type.empty() && type != export_format_info(ExportFormat::json).mime_type)
    throw unsupported_format("send the request as application/json (curl: -H 'Content-Type: application/json'), not \"" +
                             quote_client_text(type) + "\"");
}

ExportFormat answer_format(const httplib::Request& req, ExportContent content) {
  if (req.has_param("format")) {
    const auto format = parse_export_format(req.get_param_value("format"));
    if (!format || !can_export(*format, content)) throw HttpError(400, "invalid_request", "format must be " + export_format_names(content));
    return *format;
  }
  // text/plain is shared by several formats and names none of them.
  for (const auto& row : export_format_table()) {
    const bool own_type = std::string_view(row.mime_type) != "text/plain" && row.format != ExportFormat::json;
    if (own_type && can_export(row.format, content) && accepts(req, row.mime_type)) return row.format;
  }
  return ExportFormat::json;
}

bool compact_glb_requested(const httplib::Request& req) {
  if (!req.has_param("compact")) return false;
  const std::string value = lower(req.get_param_value("compact"));
  if (value == "1" || value == "true") return true;
  if (value == "0" || value == "false") return false;
  throw HttpError(400, "invalid_request", "compact must be 1, true, 0 or false");
}

}  // namespace featureline::server
