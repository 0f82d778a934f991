// Paths to the test meshes kept beside the repository (../shared/data/meshes, see its
// SOURCES.md). Tests that need one call require_shared_mesh, which fails the test
// loudly when the file is missing: tests never skip for lack of data.
#pragma once

#include <string>

namespace featureline::testing {

/// FEATURELINE_SHARED_DIR "/data/meshes/" + file_name (the compile definition comes
/// from tests/CMakeLists.txt); the file may or may not exist.
/// \param file_name  a file name inside data/meshes, e.g. "fandisk.off"
std::string shared_mesh_path(const std::string& file_name);

/// shared_mesh_path(file_name) when that file exists. Otherwise records a GoogleTest
/// failure naming the missing path and throws std::runtime_error, so the calling test
/// stops there (GoogleTest reports the exception as a second failure).
/// \param file_name  a file name inside data/meshes, e.g. "fandisk.off"
/// \throw std::runtime_error when the file does not exist
std::string require_shared_mesh(const std::string& file_name);

}  // namespace featureline::testing
