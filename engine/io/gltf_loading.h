// Parsing glTF JSON and GLB containers with tinygltf, hardened for untrusted input
// (gltf_loading.cpp). Private to engine/io/.
#pragma once

#include <tiny_gltf.h>

#include <string_view>

#include "engine/mesh_io.h"

namespace featureline::detail {

inline constexpr std::string_view draco_extension = "KHR_draco_mesh_compression";

/// The glTF (`binary` false) or GLB document, loaded by tinygltf with file access and image
/// decoding switched off; geometry is not validated yet (accessors are checked when read).
/// \throw MeshFormatError, UnsupportedFormatError, LimitExceededError
tinygltf::Model load_gltf_model(std::string_view bytes, bool binary);

}  // namespace featureline::detail
