#include "tests/support/shared_data.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <stdexcept>
#include <system_error>

#ifndef FEATURELINE_SHARED_DIR
#error "FEATURELINE_SHARED_DIR must be defined (tests/CMakeLists.txt sets it)"
#endif

namespace featureline::testing {

std::string shared_mesh_path(const std::string& file_name) {
  return std::string(FEATURELINE_SHARED_DIR) + "/data/meshes/" + file_name;
}

std::string require_shared_mesh(const std::string& file_name) {
  std::string path = shared_mesh_path(file_name);
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) {
    // ADD_FAILURE rather than FAIL: FAIL returns void, which a helper returning a
    // value cannot do; the exception then ends the calling test.
    ADD_FAILURE() << "missing test mesh " << path
                  << " (expected beside the repository in ../shared/data/meshes; see SOURCES.md)";
    throw std::runtime_error("missing test mesh " + path);
  }
  return path;
}

}  // namespace featureline::testing
