// glTF (JSON) and GLB through tinygltf 2.7.0, hardened for untrusted input.
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
//   not needed because the indices come from the decoded Draco faces) and the Draco bufferView
//   is decoded here with draco::Decoder.
// - Every accessor and bufferView is bounds-checked here; tinygltf does not do that.
#include <dlfcn.h>
#include <tiny_gltf.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <map>
#include <set>
#include <tuple>
#include <nlohmann/json.hpp>

#include "engine/errors.h"
#include "engine/mesh_io_detail.h"

namespace featureline::detail {

namespace {

constexpr std::string_view draco_extension = "KHR_draco_mesh_compression";

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

std::uint32_t le32(const unsigned char* p) {
  return std::uint32_t(p[0]) | (std::uint32_t(p[1]) << 8) | (std::uint32_t(p[2]) << 16) | (std::uint32_t(p[3]) << 24);
}

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
  const std::uint32_t version = le32(u + 4);
  if (version != 2) throw MeshFormatError("GLB file has container version " + std::to_string(version) + "; only version 2 is supported.");
  GlbParts parts;
  parts.length = le32(u + 8);
  if (parts.length > bytes.size()) {
    throw MeshFormatError("GLB header claims " + std::to_string(parts.length) + " bytes but the file has only " +
                          std::to_string(bytes.size()) + " bytes.");
  }
  if (parts.length < 20) throw MeshFormatError("GLB header claims a length of " + std::to_string(parts.length) + " bytes, less than its header.");
  const std::uint64_t json_length = le32(u + 12);
  if (le32(u + 16) != 0x4E4F534Au) throw MeshFormatError("GLB file's first chunk is not JSON.");
  if (json_length == 0 || 20 + json_length > parts.length) {
    throw MeshFormatError("GLB JSON chunk claims " + std::to_string(json_length) + " bytes but the file has only " +
                          std::to_string(parts.length) + " bytes.");
  }
  parts.json = bytes.substr(20, static_cast<std::size_t>(json_length));
  std::uint64_t pos = 20 + json_length;
  pos = (pos + 3) & ~std::uint64_t(3);
  if (pos + 8 <= parts.length) {
    const std::uint64_t bin_length = le32(u + pos);
    const std::uint32_t type = le32(u + pos + 4);
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

// ---- accessors ------------------------------------------------------------------------

struct ByteRange {
  const unsigned char* data = nullptr;
  std::size_t size = 0;
};

ByteRange buffer_view_bytes(const tinygltf::Model& model, int index, const std::string& context) {
  if (index < 0 || static_cast<std::size_t>(index) >= model.bufferViews.size()) {
    throw MeshFormatError(context + " refers to bufferView " + std::to_string(index) + ", which does not exist.");
  }
  const tinygltf::BufferView& view = model.bufferViews[static_cast<std::size_t>(index)];
  if (view.buffer < 0 || static_cast<std::size_t>(view.buffer) >= model.buffers.size()) {
    throw MeshFormatError(context + ": bufferView " + std::to_string(index) + " refers to buffer " +
                          std::to_string(view.buffer) + ", which does not exist.");
  }
  const auto& data = model.buffers[static_cast<std::size_t>(view.buffer)].data;
  if (view.byteOffset > data.size() || view.byteLength > data.size() - view.byteOffset) {
    throw MeshFormatError(context + ": bufferView " + std::to_string(index) + " (offset " + std::to_string(view.byteOffset) +
                          ", length " + std::to_string(view.byteLength) + ") extends past the end of buffer " +
                          std::to_string(view.buffer) + " (" + std::to_string(data.size()) + " bytes).");
  }
  return {data.data() + view.byteOffset, view.byteLength};
}

std::size_t component_size(int component_type) {
  switch (component_type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
    default: return 0;
  }
}

/// A bounds-checked view of an accessor's elements.
struct AccessorView {
  const unsigned char* data = nullptr;
  std::size_t stride = 0;
  std::size_t count = 0;
  int component_type = 0;
  int components = 0;
  bool normalized = false;

  double component(std::size_t element, int c) const {
    const unsigned char* p = data + element * stride + std::size_t(c) * component_size(component_type);
    switch (component_type) {
      case TINYGLTF_COMPONENT_TYPE_FLOAT: { float v; std::memcpy(&v, p, 4); return v; }
      case TINYGLTF_COMPONENT_TYPE_BYTE: {
        const double v = static_cast<std::int8_t>(p[0]);
        return normalized ? std::max(v / 127.0, -1.0) : v;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return normalized ? p[0] / 255.0 : double(p[0]);
      case TINYGLTF_COMPONENT_TYPE_SHORT: {
        std::int16_t s; std::memcpy(&s, p, 2);
        return normalized ? std::max(s / 32767.0, -1.0) : double(s);
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        std::uint16_t s; std::memcpy(&s, p, 2);
        return normalized ? s / 65535.0 : double(s);
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: { std::uint32_t v; std::memcpy(&v, p, 4); return double(v); }
      default: return 0.0;
    }
  }
};

AccessorView view_accessor(const tinygltf::Model& model, int index, int expected_type, const std::string& context) {
  if (index < 0 || static_cast<std::size_t>(index) >= model.accessors.size()) {
    throw MeshFormatError(context + " refers to accessor " + std::to_string(index) + ", which does not exist.");
  }
  const tinygltf::Accessor& accessor = model.accessors[static_cast<std::size_t>(index)];
  const std::string name = context + ": accessor " + std::to_string(index);
  if (accessor.sparse.isSparse) throw MeshFormatError(name + " is sparse, which is not supported for geometry.");
  if (accessor.type != expected_type) throw MeshFormatError(name + " has the wrong element type.");
  AccessorView view;
  view.component_type = accessor.componentType;
  view.components = tinygltf::GetNumComponentsInType(static_cast<std::uint32_t>(accessor.type));
  view.count = accessor.count;
  view.normalized = accessor.normalized;
  const std::size_t csize = component_size(accessor.componentType);
  if (csize == 0 || view.components <= 0) throw MeshFormatError(name + " has an invalid component type.");
  if (view.count == 0) throw MeshFormatError(name + " has no elements.");
  const std::size_t element_size = csize * std::size_t(view.components);
  // Without a bufferView the spec means "all zeros": useless as geometry, and its count would be
  // the only thing bounding the allocation, so it is refused.
  if (accessor.bufferView < 0) throw MeshFormatError(name + " has no bufferView (all-zero data is not usable geometry).");
  const ByteRange range = buffer_view_bytes(model, accessor.bufferView, name);
  const tinygltf::BufferView& buffer_view = model.bufferViews[static_cast<std::size_t>(accessor.bufferView)];
  view.stride = buffer_view.byteStride != 0 ? buffer_view.byteStride : element_size;
  if (view.stride < element_size) {
    throw MeshFormatError(name + " has a byte stride of " + std::to_string(view.stride) + ", smaller than its " +
                          std::to_string(element_size) + "-byte elements.");
  }
  // offset + stride * (count - 1) + element_size <= view length, without overflow.
  const std::size_t length = range.size;
  const std::size_t offset = accessor.byteOffset;
  bool fits = offset <= length && element_size <= length - offset;
  if (fits) {
    const std::size_t room = length - offset - element_size;
    fits = (view.count - 1) <= room / view.stride;
  }
  if (!fits) {
    throw MeshFormatError(name + " (" + std::to_string(view.count) + " elements of " + std::to_string(element_size) +
                          " bytes, stride " + std::to_string(view.stride) + ", offset " + std::to_string(offset) +
                          ") points past the end of its bufferView (" + std::to_string(length) + " bytes).");
  }
  view.data = range.data + offset;
  return view;
}

// ---- per-primitive geometry (untransformed) ---------------------------------------------

struct PrimitiveGeometry {
  std::vector<std::array<double, 3>> positions;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  bool skipped = false;
};

std::optional<int> value_as_int(const tinygltf::Value& v) {
  if (v.IsInt()) return v.GetNumberAsInt();
  if (v.IsReal()) {
    const double d = v.GetNumberAsDouble();
    if (std::floor(d) == d && d >= 0 && d <= double(std::numeric_limits<int>::max())) return static_cast<int>(d);
  }
  return std::nullopt;
}

struct Counters {
  std::size_t skipped_primitives = 0;
  std::size_t dropped_index_remainder = 0;
  std::size_t skipped_degenerate = 0;
};

PrimitiveGeometry load_primitive(const tinygltf::Model& model, const tinygltf::Primitive& primitive, MeshFormat format,
                                 const std::string& context, const ReadMeshOptions& options, Counters& counters) {
  PrimitiveGeometry g;
  const int mode = primitive.mode < 0 ? TINYGLTF_MODE_TRIANGLES : primitive.mode;
  if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP && mode != TINYGLTF_MODE_TRIANGLE_FAN) {
    if (mode < 0 || mode > 6) throw MeshFormatError(context + " has an invalid mode " + std::to_string(mode) + ".");
    g.skipped = true;
    ++counters.skipped_primitives;
    return g;
  }

  const auto draco = primitive.extensions.find(std::string(draco_extension));
  if (draco != primitive.extensions.end()) {
    const tinygltf::Value& ext = draco->second;
    if (!ext.IsObject() || !ext.Has("bufferView")) {
      throw MeshFormatError(context + " has a " + std::string(draco_extension) + " extension without a bufferView.");
    }
    const auto view_index = value_as_int(ext.Get("bufferView"));
    if (!view_index) throw MeshFormatError(context + " has a Draco bufferView that is not an index.");
    std::optional<std::uint32_t> position_id;
    if (ext.Has("attributes") && ext.Get("attributes").IsObject() && ext.Get("attributes").Has("POSITION")) {
      const auto id = value_as_int(ext.Get("attributes").Get("POSITION"));
      if (!id) throw MeshFormatError(context + " has a Draco POSITION attribute id that is not an integer.");
      position_id = static_cast<std::uint32_t>(*id);
    }
    const ByteRange bytes = buffer_view_bytes(model, *view_index, context);
    DracoGeometry decoded = decode_draco(bytes.data, bytes.size, position_id, format, context + " (Draco)", options);
    g.positions = std::move(decoded.positions);
    g.triangles = std::move(decoded.triangles);
    return g;
  }

  const auto position_attribute = primitive.attributes.find("POSITION");
  if (position_attribute == primitive.attributes.end()) throw MeshFormatError(context + " has no POSITION attribute.");
  const AccessorView positions = view_accessor(model, position_attribute->second, TINYGLTF_TYPE_VEC3, context + " POSITION");
  check_vertex_limit(format, positions.count, options);
  g.positions.resize(positions.count);
  for (std::size_t i = 0; i < positions.count; ++i) {
    for (int c = 0; c < 3; ++c) {
      const double v = positions.component(i, c);
      if (!std::isfinite(v)) {
        throw MeshFormatError(context + " vertex " + std::to_string(i) + " has a non-finite coordinate.");
      }
      g.positions[i][c] = v;
    }
  }

  std::vector<std::uint32_t> indices;
  if (primitive.indices >= 0) {
    const AccessorView index_view = view_accessor(model, primitive.indices, TINYGLTF_TYPE_SCALAR, context + " indices");
    if (index_view.component_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
        index_view.component_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
        index_view.component_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT) {
      throw MeshFormatError(context + " has indices that are not unsigned integers.");
    }
    check_triangle_limit(format, index_view.count / 3, options);
    indices.resize(index_view.count);
    for (std::size_t i = 0; i < index_view.count; ++i) {
      const double v = index_view.component(i, 0);
      if (v >= double(positions.count)) {
        throw MeshFormatError(context + " index " + std::to_string(i) + " refers to vertex " +
                              std::to_string(static_cast<std::uint64_t>(v)) + " but the primitive has only " +
                              std::to_string(positions.count) + " vertices.");
      }
      indices[i] = static_cast<std::uint32_t>(v);
    }
  } else {
    check_triangle_limit(format, positions.count / 3, options);
    indices.resize(positions.count);
    for (std::size_t i = 0; i < positions.count; ++i) indices[i] = static_cast<std::uint32_t>(i);
  }

  if (mode == TINYGLTF_MODE_TRIANGLES) {
    counters.dropped_index_remainder += indices.size() % 3;
    g.triangles.reserve(indices.size() / 3);
    for (std::size_t i = 0; i + 2 < indices.size(); i += 3) g.triangles.push_back({indices[i], indices[i + 1], indices[i + 2]});
  } else {
    for (std::size_t i = 0; i + 2 < indices.size(); ++i) {
      std::array<std::uint32_t, 3> t{};
      if (mode == TINYGLTF_MODE_TRIANGLE_FAN) {
        t = {indices[0], indices[i + 1], indices[i + 2]};
      } else if (i % 2 == 0) {
        t = {indices[i], indices[i + 1], indices[i + 2]};
      } else {
        t = {indices[i + 1], indices[i], indices[i + 2]};
      }
      if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
        ++counters.skipped_degenerate;  // strip/fan stitching, not a face
        continue;
      }
      g.triangles.push_back(t);
    }
  }
  return g;
}

// ---- expansion through instances and shared accessors -----------------------------------

/// What a primitive adds to the scene, from its accessors' counts alone (nothing is read or
/// allocated), so that a scene instancing one mesh many times, or listing many primitives over one
/// accessor, is refused before it is expanded. Counts that do not add up (missing or invalid
/// accessors) give 0 here; load_primitive reports them. Draco primitives are checked again once
/// decoded, since their accessors' counts are only declarations.
struct PrimitiveExtent {
  std::size_t vertex_records = 0;
  std::size_t triangles = 0;
};

// Declared counts come from the file and may be near SIZE_MAX: sums saturate instead of wrapping.
std::size_t saturating_add(std::size_t a, std::size_t b) { return b > SIZE_MAX - a ? SIZE_MAX : a + b; }

std::size_t accessor_count(const tinygltf::Model& model, int index) {
  if (index < 0 || static_cast<std::size_t>(index) >= model.accessors.size()) return 0;
  return model.accessors[static_cast<std::size_t>(index)].count;
}

PrimitiveExtent primitive_extent(const tinygltf::Model& model, const tinygltf::Primitive& primitive) {
  const int mode = primitive.mode < 0 ? TINYGLTF_MODE_TRIANGLES : primitive.mode;
  if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP && mode != TINYGLTF_MODE_TRIANGLE_FAN) return {};
  const auto position = primitive.attributes.find("POSITION");
  PrimitiveExtent extent;
  extent.vertex_records = position == primitive.attributes.end() ? 0 : accessor_count(model, position->second);
  const std::size_t corners = primitive.indices >= 0 ? accessor_count(model, primitive.indices) : extent.vertex_records;
  extent.triangles = mode == TINYGLTF_MODE_TRIANGLES ? corners / 3 : (corners >= 3 ? corners - 2 : 0);
  return extent;
}

/// Refuses a scene whose expansion passes the configured limits, saying that it is the expansion.
void check_expansion(MeshFormat format, std::size_t vertex_records, std::size_t triangles, std::size_t instances,
                     const ReadMeshOptions& options) {
  if (instances <= 1) {  // nothing is multiplied: the reader's plain limits and messages
    check_vertex_limit(format, vertex_records, options);
    check_triangle_limit(format, triangles, options);
    return;
  }
  const auto refuse = [&](std::size_t limit, const char* what, const char* flag) {
    throw LimitExceededError(std::string(display_name(format)) + " scene expands to more than " + std::to_string(limit) + " " +
                             what + " through its node instances and primitives (" + std::to_string(instances) +
                             " primitive instances so far); the configured limit is " + std::to_string(limit) + " (" + flag + ").");
  };
  const std::size_t vertex_limit = std::min<std::size_t>(options.max_vertices, std::numeric_limits<std::uint32_t>::max());
  if (vertex_records > vertex_limit) refuse(vertex_limit, "vertices", "--max-vertices");
  if (triangles > options.max_triangles) refuse(options.max_triangles, "triangles", "--max-triangles");
}

/// Primitives that read the same data decode to the same geometry: the cache key is the data, not
/// the primitive, so a file listing one accessor under many primitives holds one copy.
struct GeometryKey {
  int draco_view = -1;
  int draco_position = -1;
  int position_accessor = -1;
  int index_accessor = -1;
  int mode = TINYGLTF_MODE_TRIANGLES;
  bool operator<(const GeometryKey& o) const {
    return std::tie(draco_view, draco_position, position_accessor, index_accessor, mode) <
           std::tie(o.draco_view, o.draco_position, o.position_accessor, o.index_accessor, o.mode);
  }
};

GeometryKey geometry_key(const tinygltf::Primitive& primitive) {
  GeometryKey key;
  key.mode = primitive.mode < 0 ? TINYGLTF_MODE_TRIANGLES : primitive.mode;
  const auto draco = primitive.extensions.find(std::string(draco_extension));
  if (draco != primitive.extensions.end() && draco->second.IsObject()) {
    const tinygltf::Value& ext = draco->second;
    if (ext.Has("bufferView")) key.draco_view = value_as_int(ext.Get("bufferView")).value_or(-2);
    if (ext.Has("attributes") && ext.Get("attributes").IsObject() && ext.Get("attributes").Has("POSITION")) {
      key.draco_position = value_as_int(ext.Get("attributes").Get("POSITION")).value_or(-2);
    }
    return key;
  }
  const auto position = primitive.attributes.find("POSITION");
  key.position_accessor = position == primitive.attributes.end() ? -1 : position->second;
  key.index_accessor = primitive.indices;
  return key;
}

// ---- node transforms ------------------------------------------------------------------

Eigen::Matrix4d local_transform(const tinygltf::Node& node, int index, MeshFormat format) {
  const std::string name = std::string(display_name(format)) + " node " + std::to_string(index);
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  if (!node.matrix.empty()) {
    if (node.matrix.size() != 16) throw MeshFormatError(name + " has a matrix with " + std::to_string(node.matrix.size()) + " values instead of 16.");
    for (int c = 0; c < 4; ++c) {
      for (int r = 0; r < 4; ++r) m(r, c) = node.matrix[std::size_t(c * 4 + r)];  // column-major
    }
  } else {
    Eigen::Vector3d t = Eigen::Vector3d::Zero(), s = Eigen::Vector3d::Ones();
    Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
    if (!node.translation.empty()) {
      if (node.translation.size() != 3) throw MeshFormatError(name + " has a translation that is not 3 values.");
      t = Eigen::Vector3d(node.translation[0], node.translation[1], node.translation[2]);
    }
    if (!node.scale.empty()) {
      if (node.scale.size() != 3) throw MeshFormatError(name + " has a scale that is not 3 values.");
      s = Eigen::Vector3d(node.scale[0], node.scale[1], node.scale[2]);
    }
    if (!node.rotation.empty()) {
      if (node.rotation.size() != 4) throw MeshFormatError(name + " has a rotation that is not 4 values.");
      q = Eigen::Quaterniond(node.rotation[3], node.rotation[0], node.rotation[1], node.rotation[2]);  // stored x, y, z, w
      if (!(q.norm() > 0.0)) throw MeshFormatError(name + " has a zero rotation quaternion.");
      q.normalize();
    }
    m.block<3, 3>(0, 0) = q.toRotationMatrix() * s.asDiagonal();
    m.block<3, 1>(0, 3) = t;
  }
  if (!m.allFinite()) throw MeshFormatError(name + " has a non-finite transform.");
  return m;
}

}  // namespace

RawMesh read_gltf(std::string_view bytes, bool binary, const ReadMeshOptions& options) {
  check_tinygltf_copy();
  const MeshFormat format = binary ? MeshFormat::glb : MeshFormat::gltf;
  const std::string name = display_name(format);

  // Load through tinygltf with file access and image decoding switched off.
  tinygltf::Model model;
  {
    std::string rewritten;
    std::string_view input = bytes;
    if (binary) {
      const GlbParts parts = split_glb(bytes);
      check_json_depth(parts.json, format);
      if (auto json = strip_draco_indices(parts.json, format)) {
        rewritten = build_glb(*json, parts.bin);
        input = rewritten;
      } else {
        input = bytes.substr(0, parts.length);
      }
    } else {
      check_json_depth(bytes, format);
      if (auto json = strip_draco_indices(bytes, format)) {
        rewritten = std::move(*json);
        input = rewritten;
      }
    }
    if (input.size() > std::numeric_limits<unsigned int>::max()) throw LimitExceededError(name + " input is larger than 4 GiB.");

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
        throw MeshFormatError(name + " file refers to an external file for a buffer, which is never read (only embedded data and data: URIs are allowed).");
      }
      throw MeshFormatError(name + " file could not be parsed: " + (reason.empty() ? std::string("unknown error") : reason));
    }
  }

  for (const std::string& required : model.extensionsRequired) {
    if (required == "EXT_meshopt_compression" || required == "KHR_meshopt_compression" ||
        required == "EXT_mesh_gpu_instancing") {
      throw UnsupportedFormatError(name + " file requires the extension " + required + ", which is not supported.");
    }
  }

  RawMesh mesh;
  mesh.format = format;
  mesh.welded = true;
  PositionWelder welder(mesh.positions);
  Counters counters;
  std::map<GeometryKey, PrimitiveGeometry> cache;
  std::size_t vertex_records = 0;
  std::size_t instances = 0;
  std::set<std::pair<int, int>> skipped_seen;

  const auto emit_mesh = [&](int mesh_index, const Eigen::Matrix4d& world) {
    if (mesh_index < 0 || static_cast<std::size_t>(mesh_index) >= model.meshes.size()) {
      throw MeshFormatError(name + " node refers to mesh " + std::to_string(mesh_index) + ", which does not exist.");
    }
    const tinygltf::Mesh& gmesh = model.meshes[static_cast<std::size_t>(mesh_index)];
    const bool flip = world.block<3, 3>(0, 0).determinant() < 0.0;  // mirrored instance: winding flips
    for (std::size_t p = 0; p < gmesh.primitives.size(); ++p) {
      const tinygltf::Primitive& primitive = gmesh.primitives[p];
      const PrimitiveExtent declared = primitive_extent(model, primitive);
      check_expansion(format, saturating_add(vertex_records, declared.vertex_records),
                      saturating_add(mesh.triangles.size(), declared.triangles), instances + 1, options);
      const GeometryKey key = geometry_key(primitive);
      auto it = cache.find(key);
      const bool loaded_now = it == cache.end();
      if (loaded_now) {
        const std::string context = name + " mesh " + std::to_string(mesh_index) + " primitive " + std::to_string(p);
        it = cache.emplace(key, load_primitive(model, primitive, format, context, options, counters)).first;
      }
      const PrimitiveGeometry& g = it->second;
      if (g.skipped) {
        // Counted once per primitive of the file (load_primitive counted the first one).
        if (skipped_seen.insert({mesh_index, static_cast<int>(p)}).second && !loaded_now) ++counters.skipped_primitives;
        continue;
      }
      ++instances;
      vertex_records += g.positions.size();
      check_expansion(format, vertex_records, mesh.triangles.size() + g.triangles.size(), instances, options);
      std::vector<std::uint32_t> remap(g.positions.size());
      for (std::size_t v = 0; v < g.positions.size(); ++v) {
        const Eigen::Vector4d q = world * Eigen::Vector4d(g.positions[v][0], g.positions[v][1], g.positions[v][2], 1.0);
        if (!std::isfinite(q[0]) || !std::isfinite(q[1]) || !std::isfinite(q[2])) {
          throw MeshFormatError(name + " mesh " + std::to_string(mesh_index) + " primitive " + std::to_string(p) + " vertex " +
                                std::to_string(v) + " is non-finite after its node transform.");
        }
        remap[v] = welder.add({q[0], q[1], q[2]});
      }
      for (const auto& t : g.triangles) {
        if (flip) {
          mesh.triangles.push_back({remap[t[0]], remap[t[2]], remap[t[1]]});
        } else {
          mesh.triangles.push_back({remap[t[0]], remap[t[1]], remap[t[2]]});
        }
      }
    }
  };

  int scene = model.defaultScene;
  if (scene >= static_cast<int>(model.scenes.size())) {
    throw MeshFormatError(name + " file's default scene " + std::to_string(scene) + " does not exist.");
  }
  if (scene < 0 && !model.scenes.empty()) scene = 0;
  // Calls visit(mesh index, world transform) for every mesh instance of the scene (or every mesh
  // once when the file has no scene).
  const auto for_each_instance = [&](const auto& visit) {
    if (scene < 0) {
      for (std::size_t m = 0; m < model.meshes.size(); ++m) visit(static_cast<int>(m), Eigen::Matrix4d::Identity());
      return;
    }
    // Depth-first over the scene's node trees with an explicit stack; a node reached twice means
    // the hierarchy is not a tree (cycles, shared children), which glTF forbids.
    std::vector<char> visited(model.nodes.size(), 0);
    std::vector<std::pair<int, Eigen::Matrix4d>> stack;
    const auto& roots = model.scenes[static_cast<std::size_t>(scene)].nodes;
    for (auto r = roots.rbegin(); r != roots.rend(); ++r) stack.emplace_back(*r, Eigen::Matrix4d::Identity());
    while (!stack.empty()) {
      const auto [index, parent] = stack.back();
      stack.pop_back();
      if (index < 0 || static_cast<std::size_t>(index) >= model.nodes.size()) {
        throw MeshFormatError(name + " scene refers to node " + std::to_string(index) + ", which does not exist.");
      }
      if (visited[static_cast<std::size_t>(index)]) {
        throw MeshFormatError(name + " node " + std::to_string(index) + " is reached twice; the node hierarchy is not a tree.");
      }
      visited[static_cast<std::size_t>(index)] = 1;
      const tinygltf::Node& node = model.nodes[static_cast<std::size_t>(index)];
      const Eigen::Matrix4d world = parent * local_transform(node, index, format);
      if (node.mesh >= 0) visit(node.mesh, world);
      for (auto c = node.children.rbegin(); c != node.children.rend(); ++c) stack.emplace_back(*c, world);
    }
  };

  // First the declared size of the whole expansion, so that a small file instancing a mesh many
  // times is refused before any geometry is read or allocated.
  PrimitiveExtent declared;
  std::size_t declared_instances = 0;
  for_each_instance([&](int mesh_index, const Eigen::Matrix4d&) {
    if (mesh_index < 0 || static_cast<std::size_t>(mesh_index) >= model.meshes.size()) return;  // reported below
    for (const tinygltf::Primitive& primitive : model.meshes[static_cast<std::size_t>(mesh_index)].primitives) {
      const PrimitiveExtent extent = primitive_extent(model, primitive);
      declared.vertex_records = saturating_add(declared.vertex_records, extent.vertex_records);
      declared.triangles = saturating_add(declared.triangles, extent.triangles);
      ++declared_instances;
    }
    check_expansion(format, declared.vertex_records, declared.triangles, declared_instances, options);
  });
  for_each_instance(emit_mesh);

  if (counters.skipped_primitives > 0) {
    mesh.warnings.push_back(name + " file has " + std::to_string(counters.skipped_primitives) +
                            " point or line primitives, which were skipped.");
  }
  if (counters.dropped_index_remainder > 0) {
    mesh.warnings.push_back(name + " file has triangle index lists whose length is not a multiple of 3; " +
                            std::to_string(counters.dropped_index_remainder) + " trailing indices were ignored.");
  }
  if (counters.skipped_degenerate > 0) {
    mesh.warnings.push_back(name + " triangle strips or fans contain " + std::to_string(counters.skipped_degenerate) +
                            " degenerate stitching triangles, which were skipped.");
  }
  if (mesh.triangles.empty()) {
    throw MeshFormatError(name + " file contains no triangles" +
                          (scene >= 0 ? " in scene " + std::to_string(scene) : std::string()) + ".");
  }
  mesh.source_faces = mesh.triangles.size();
  return mesh;
}

}  // namespace featureline::detail
