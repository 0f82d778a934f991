#include <gtest/gtest.h>
#include "engine/mesh_io.h"
TEST(MeshIo, Placeholder) { EXPECT_EQ(featureline::to_string(featureline::MeshFormat::obj), "obj"); }
