// How far an upload may expand (engine/mesh_io.h read_limits_for), with the amplifying and
// malformed inputs the fuzzers found kept in tests/fuzz/corpus/ (made by tests/fuzz/make_corpus.mjs).
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "engine/errors.h"
#include "engine/mesh_io.h"

namespace featureline {
namespace {

std::string corpus_file(const std::string& name) {
  const std::string path = "tests/fuzz/corpus/" + name;
  std::ifstream in(path, std::ios::binary);
  if (!in) ADD_FAILURE() << "missing regression input " << path << " (run from the repository root)";
  std::stringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

TEST(ReadLimits, FollowTheUploadLimitAndTheMemoryBudget) {
  // 256 MiB / 12 bytes = 22,369,621; 1 GiB / 136 bytes per prepared triangle = 7,895,160 and
  // / 112 bytes per prepared vertex = 9,586,980: the smaller wins.
  const ReadMeshOptions server_default = read_limits_for(std::size_t(256) << 20, std::size_t(1) << 30);
  EXPECT_EQ(server_default.max_triangles, 7895160u);
  EXPECT_EQ(server_default.max_vertices, 9586980u);
  EXPECT_EQ(server_default.memory_budget_bytes, std::size_t(1) << 30);
  EXPECT_EQ(server_default.max_file_bytes, std::size_t(256) << 20);
  const ReadMeshOptions small_uploads = read_limits_for(std::size_t(1) << 20, std::size_t(1) << 30);
  EXPECT_EQ(small_uploads.max_triangles, 87381u);
  // Never above the reader's own absolute caps.
  const ReadMeshOptions huge = read_limits_for(std::size_t(1) << 40, std::size_t(1) << 40);
  EXPECT_EQ(huge.max_triangles, ReadMeshOptions{}.max_triangles);
  EXPECT_EQ(huge.max_vertices, ReadMeshOptions{}.max_vertices);
}

TEST(ReadLimits, AGlbInstancingOneMeshIsRefusedBeforeExpanding) {
  // 22 KB: a 1,058-triangle grid as 100 primitives over one accessor, instanced by 300 nodes.
  const std::string glb = corpus_file("glb/regression_amplified_instances.glb");
  ASSERT_LT(glb.size(), 32000u);
  ReadMeshOptions limits = read_limits_for(std::size_t(1) << 20, std::size_t(1) << 30);
  try {
    read_mesh(glb, MeshFormat::glb, limits);
    ADD_FAILURE() << "the amplified GLB was read";
  } catch (const LimitExceededError& e) {
    EXPECT_STREQ(e.what(),
                 "GLB scene expands to more than 87381 triangles through its node instances and primitives "
                 "(100 primitive instances so far); the configured limit is 87381 (--max-triangles).");
  }
  limits.max_triangles = 40'000'000;
  limits.max_vertices = 1'000'000;
  EXPECT_THROW(read_mesh(glb, MeshFormat::glb, limits), LimitExceededError);  // 17 M vertex records
}

TEST(ReadLimits, InstancesWithinTheLimitsAreRead) {
  const RawMesh mesh = read_mesh(corpus_file("glb/regression_small_instances.glb"), MeshFormat::glb,
                                 read_limits_for(std::size_t(1) << 20, std::size_t(1) << 30));
  EXPECT_EQ(mesh.triangles.size(), 72u);  // 4 translated instances of 18 triangles
  EXPECT_EQ(mesh.positions.size(), 64u);
}

TEST(ObjReader, RelativeIndexInt64MinIsAnErrorNotOverflow) {
  try {
    read_mesh(corpus_file("obj/regression_relative_int64_min.obj"), MeshFormat::obj);
    ADD_FAILURE() << "read";
  } catch (const MeshFormatError& e) {
    EXPECT_STREQ(e.what(), "OBJ face 1 (line 4) uses relative vertex index -9223372036854775808 but only 3 vertices precede it.");
  }
  EXPECT_THROW(read_mesh(corpus_file("obj/regression_relative_int64_max.obj"), MeshFormat::obj), MeshFormatError);
}

}  // namespace
}  // namespace featureline
