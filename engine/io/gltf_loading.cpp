// glTF (JSON) and GLB documents through tinygltf 2.7.0, hardened for untrusted input.
//
// - tinygltf is a compiled Debian library with file access built in: every load disables its
//   file-system callbacks (external buffer/image URIs then fail instead of being read from the
//   server's disk) and replaces the image decoder with a no-op. Data URIs still work.
// - libdraco.so exports its own copy of tinygltf's symbols, built from a different tinygltf
//   version with a different class layout (measured: TinyGLTF keeps its file-system callbacks at
//   offset 0x18 there and at 0x58 in libtinygltf.so 2.7.0). Whichever library comes first in the
//   link order wins; only libtinygltf matches the <tiny_gltf.h> we compile against, so the
//   engine links TinyGLTF before draco, and `check_tinygltf_copy` refuses to run otherwise.
// - libtinygltf 2.7.0 is built without Draco and rejects primitives whose "indices" accessor
//   has no bufferView, which is how KHR_draco_mesh_compression primitives are written. For such
//   files the JSON is rewritten first (the "indices" of Draco primitives are dropped; they are
//   not needed because the indices come from the decoded Draco faces); gltf_reader.cpp decodes
//   the Draco bufferView with draco::Decoder.
#include "engine/io/gltf_loading.h"

#include <dlfcn.h>

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "engine/errors.h"
#include "engine/io/byte_order.h"
#include "engine/io/reader_support.h"

namespace featureline::detail {

namespace {

// ---- which tinygltf copy runs ---------------------------------------------------------

/// Empty when the tinygltf symbols resolve to libtinygltf; otherwise why glTF cannot be read.
const std::string& tinygltf_copy_problem() {
  static const std::string problem = [] {
    void* symbol = dlsym(RTLD_DEFAULT, "_ZN8tinygltf8TinyGLTF14SetFsCallbacksENS_11FsCallbacksE");
    Dl_info info{};
    if (symbol == nullptr || dladdr(symbol, &info) == 0 || info.dli_fname == nullptr) return std::string();
    const std::string library = info.dli_fname;
    if (library.find("tinygltf") != std::string::npos) return std::string();
    return "glTF support is misconfigured in this build: tinygltf's functions resolve to " + library +
           ", whose copy of tinygltf does not match <tiny_gltf.h>; link TinyGLTF before draco.";
  }();
  return problem;
}

void check_tinygltf_copy() {
  if (!tinygltf_copy_problem().empty()) throw UnsupportedFormatError(tinygltf_copy_problem());
}

// ---- GLB container --------------------------------------------------------------------

void put_le32(std::string& out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out += static_cast<char>((v >> (8 * i)) & 0xff);
}

struct GlbParts {
  std::string_view json;
  std::optional<std::string_view> bin;
  std::uint32_t length = 0;
};

GlbParts split_glb(std::string_view bytes) {
  const auto* u = reinterpret_cast<const unsigned char*>(bytes.data());
  if (bytes.size() < 20) throw MeshFormatError("GLB file has only " + std::to_string(bytes.size()) + " bytes, less than a GLB header.");
  if (bytes.substr(0, 4) != "glTF") throw MeshFormatError("GLB file does not start with the 'glTF' magic.");
  const std::uint32_t version = load_little_endian<std::uint32_t>(u + 4);
  if (version != 2) throw MeshFormatError("GLB file has container version " + std::to_string(version) + "; only version 2 is supported.");
  GlbParts parts;
  parts.length = load_little_endian<std::uint32_t>(u + 8);
  if (parts.length > bytes.size()) {
    throw MeshFormatError("GLB header claims " + std::to_string(parts.length) + " bytes but the file has only " +
                          std::to_string(bytes.size()) + " bytes.");
  }
  if (parts.length < 20) throw MeshFormatError("GLB header claims a length of " + std::to_string(parts.length) + " bytes, less than its header.");
  const std::uint64_t json_length = load_little_endian<std::uint32_t>(u + 12);
  if (load_little_endian<std::uint32_t>(u + 16) != 0x4E4F534Au) throw MeshFormatError("GLB file's first chunk is not JSON.");
  if (json_length == 0 || 20 + json_length > parts.length) {
    throw MeshFormatError("GLB JSON chunk claims " + std::to_string(json_length) + " bytes but the file has only " +
                          std::to_string(parts.length) + " bytes.");
  }
  parts.json = bytes.substr(20, static_cast<std::size_t>(json_length));
  std::uint64_t pos = 20 + json_length;
  pos = (pos + 3) & ~std::uint64_t(3);
  if (pos + 8 <= parts.length) {
    const std::uint64_t bin_length = load_little_endian<std::uint32_t>(u + pos);
    const std::uint32_t type = load_little_endian<std::uint32_t>(u + pos + 4);
    if (type == 0x004E4942u) {
      if (pos + 8 + bin_length > parts.length) {
        throw MeshFormatError("GLB BIN chunk claims " + std::to_string(bin_length) + " bytes but only " +
                              std::to_string(parts.length - pos - 8) + " remain in the file.");
      }
      parts.bin = bytes.substr(static_cast<std::size_t>(pos + 8), static_cast<std::size_t>(bin_length));
    }
  }
  return parts;
}

std::string build_glb(const std::string& json, std::optional<std::string_view> bin) {
  std::string padded_json = json;
  while (padded_json.size() % 4 != 0) padded_json += ' ';
  std::string padded_bin;
  if (bin) {
    padded_bin.assign(bin->data(), bin->size());
    while (padded_bin.size() % 4 != 0) padded_bin += '\0';
    if (padded_bin.size() < 4) padded_bin.append(4 - padded_bin.size(), '\0');
  }
  const std::uint64_t total = 12 + 8 + padded_json.size() + (bin ? 8 + padded_bin.size() : 0);
  if (total > std::numeric_limits<std::uint32_t>::max()) throw MeshFormatError("GLB file is larger than 4 GiB.");
  std::string out;
  out.reserve(static_cast<std::size_t>(total));
  out += "glTF";
  put_le32(out, 2);
  put_le32(out, static_cast<std::uint32_t>(total));
  put_le32(out, static_cast<std::uint32_t>(padded_json.size()));
  put_le32(out, 0x4E4F534Au);
  out += padded_json;
  if (bin) {
    put_le32(out, static_cast<std::uint32_t>(padded_bin.size()));
    put_le32(out, 0x004E4942u);
    out += padded_bin;
  }
  return out;
}

/// Rejects JSON nested deeper than `limit` (a cheap guard against recursion-depth attacks on the JSON parsers).
void check_json_depth(std::string_view json, MeshFormat format, int limit = 256) {
  int depth = 0;
  bool in_string = false;
  for (std::size_t i = 0; i < json.size(); ++i) {
    const char c = json[i];
    if (in_string) {
      if (c == '\\') {
        ++i;
      } else if (c == '"') {
        in_string = false;
      }
    } else if (c == '"') {
      in_string = true;
    } else if (c == '{' || c == '[') {
      if (++depth > limit) {
        throw MeshFormatError(std::string(display_name(format)) + " JSON nests deeper than " + std::to_string(limit) + " levels.");
      }
    } else if (c == '}' || c == ']') {
      --depth;
    }
  }
}

/// Drops "indices" from KHR_draco_mesh_compression primitives so that libtinygltf 2.7.0 (built
/// without Draco) accepts the file. Returns std::nullopt when nothing needed to change.
std::optional<std::string> strip_draco_indices(std::string_view json, MeshFormat format) {
  if (json.find(draco_extension) == std::string_view::npos) return std::nullopt;
  nlohmann::json doc = nlohmann::json::parse(json.begin(), json.end(), nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded() || !doc.is_object()) throw MeshFormatError(std::string(display_name(format)) + " JSON is not valid.");
  bool changed = false;
  const auto meshes = doc.find("meshes");
  if (meshes != doc.end() && meshes->is_array()) {
    for (auto& mesh : *meshes) {
      if (!mesh.is_object()) continue;
      const auto primitives = mesh.find("primitives");
      if (primitives == mesh.end() || !primitives->is_array()) continue;
      for (auto& primitive : *primitives) {
        if (!primitive.is_object()) continue;
        const auto extensions = primitive.find("extensions");
        if (extensions == primitive.end() || !extensions->is_object() || !extensions->contains(std::string(draco_extension))) continue;
        if (primitive.erase("indices") > 0) changed = true;
      }
    }
  }
  if (!changed) return std::nullopt;
  return doc.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

bool ignore_image(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int, void*) {
  return true;  // images are never needed
}

/// The bytes tinygltf is given: the GLB container or JSON, with Draco primitives' "indices" dropped.
std::string_view prepare_gltf_input(std::string_view bytes, bool binary, std::string& rewritten) {
  const MeshFormat format = binary ? MeshFormat::glb : MeshFormat::gltf;
  if (binary) {
    const GlbParts parts = split_glb(bytes);
    check_json_depth(parts.json, format);
    if (auto json = strip_draco_indices(parts.json, format)) {
      rewritten = build_glb(*json, parts.bin);
      return rewritten;
    }
    return bytes.substr(0, parts.length);
  }
  check_json_depth(bytes, format);
  if (auto json = strip_draco_indices(bytes, format)) {
    rewritten = std::move(*json);
    return rewritten;
  }
  return bytes;
}

}  // namespace

namespace {

// A buffer URI naming a file beside the document (not data:, not a URL or an absolute path), as
// the file name it refers to: percent-escapes decoded, no directory part allowed.
std::optional<std::string> relative_file(const std::string& uri) {
  if (uri.rfind("data:", 0) == 0 || uri.find("://") != std::string::npos || uri.empty() || uri[0] == '/') return std::nullopt;
  std::string name;
  for (std::size_t i = 0; i < uri.size(); ++i) {
    if (uri[i] == '%' && i + 2 < uri.size() && std::isxdigit(static_cast<unsigned char>(uri[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(uri[i + 2]))) {
      name += static_cast<char>(std::stoi(uri.substr(i + 1, 2), nullptr, 16));
      i += 2;
    } else {
      name += uri[i];
    }
  }
  if (name.rfind("./", 0) == 0) name = name.substr(2);
  return name;
}

}  // namespace

tinygltf::Model load_gltf_model(std::string_view bytes, bool binary) {
  check_tinygltf_copy();
  const std::string name = display_name(binary ? MeshFormat::glb : MeshFormat::gltf);
  std::string rewritten;
  const std::string_view input = prepare_gltf_input(bytes, binary, rewritten);
  if (input.size() > std::numeric_limits<unsigned int>::max()) throw LimitExceededError(name + " input is larger than 4 GiB.");

  tinygltf::Model model;
  tinygltf::TinyGLTF loader;
  tinygltf::FsCallbacks no_files{};
  no_files.FileExists = nullptr;
  no_files.ExpandFilePath = nullptr;
  no_files.ReadWholeFile = nullptr;
  no_files.WriteWholeFile = nullptr;
  no_files.user_data = nullptr;
  loader.SetFsCallbacks(no_files);
  loader.SetImageLoader(&ignore_image, nullptr);
  std::string err, warn;
  const bool ok =
      binary ? loader.LoadBinaryFromMemory(&model, &err, &warn, reinterpret_cast<const unsigned char*>(input.data()),
                                           static_cast<unsigned int>(input.size()), "")
             : loader.LoadASCIIFromString(&model, &err, &warn, input.data(), static_cast<unsigned int>(input.size()), "");
  if (!ok) {
    std::string reason = err;
    std::replace(reason.begin(), reason.end(), '\n', ' ');
    while (!reason.empty() && reason.back() == ' ') reason.pop_back();
    if (reason.size() > 300) reason = reason.substr(0, 300) + "...";
    if (reason.find("FS callback") != std::string::npos || reason.find("File read error") != std::string::npos ||
        reason.find("Failed to load external") != std::string::npos) {
      throw MeshFormatError(name + " file refers to an external file for a buffer, which is never read (only embedded data and data: URIs "
                            "are allowed; upload the .gltf together with the files it names).");
    }
    throw MeshFormatError(name + " file could not be parsed: " + (reason.empty() ? std::string("unknown error") : reason));
  }
  return model;
}

}  // namespace featureline::detail

namespace featureline {

std::string pack_gltf_files(std::string_view gltf, const std::vector<std::pair<std::string, std::string>>& files) {
  detail::check_json_depth(gltf, MeshFormat::gltf);
  nlohmann::json doc = nlohmann::json::parse(gltf.begin(), gltf.end(), nullptr, false);
  if (!doc.is_object()) throw MeshFormatError("glTF file is not a JSON object.");
  auto find_file = [&](const std::string& name) -> const std::string* {
    for (const auto& [file_name, bytes] : files)
      if (file_name == name) return &bytes;
    return nullptr;
  };
  nlohmann::json& buffers = doc["buffers"];
  if (!buffers.is_array()) return std::string(gltf);
  // The files' buffers are laid end to end in the GLB's one binary chunk (buffer 0); the other
  // buffers (data: URIs) follow it, renumbered.
  std::string bin;
  std::vector<std::int64_t> new_index(buffers.size(), -1), offset(buffers.size(), 0);
  nlohmann::json kept = nlohmann::json::array();
  std::size_t from_files = 0;
  for (std::size_t i = 0; i < buffers.size(); ++i) {
    const nlohmann::json& buffer = buffers[i];
    const std::optional<std::string> name = buffer.is_object() && buffer.contains("uri") && buffer["uri"].is_string()
                                                ? detail::relative_file(buffer["uri"])
                                                : std::nullopt;
    if (!name) {
      new_index[i] = -2;  // numbered once the binary chunk's place is known
      kept.push_back(buffer);
      continue;
    }
    const std::string* bytes = find_file(*name);
    if (bytes == nullptr)
      throw MeshFormatError("glTF file's buffer " + std::to_string(i) + " is in \"" + name->substr(0, 200) +
                            "\", which was not uploaded with it (send the .gltf and its .bin files together).");
    while (bin.size() % 4 != 0) bin += '\0';
    offset[i] = std::int64_t(bin.size());
    bin += *bytes;
    new_index[i] = 0;
    ++from_files;
  }
  if (from_files == 0) return std::string(gltf);
  std::int64_t next = 1;
  for (auto& index : new_index)
    if (index == -2) index = next++;
  nlohmann::json packed = nlohmann::json::array({{{"byteLength", bin.size()}}});
  for (auto& buffer : kept) packed.push_back(std::move(buffer));
  buffers = std::move(packed);
  if (doc.contains("bufferViews") && doc["bufferViews"].is_array())
    for (auto& view : doc["bufferViews"]) {
      if (!view.is_object() || !view.contains("buffer") || !view["buffer"].is_number_unsigned()) continue;
      const std::size_t b = view["buffer"].get<std::size_t>();
      if (b >= new_index.size()) continue;  // tinygltf refuses it when the packed file is read
      view["buffer"] = new_index[b];
      if (new_index[b] == 0) view["byteOffset"] = view.value("byteOffset", std::int64_t(0)) + offset[b];
    }
  return detail::build_glb(doc.dump(), bin);
}

}  // namespace featureline
