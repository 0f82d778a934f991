// Tests for engine/mesh_io.h: every shared mesh with its known counts, id preservation, the
// glTF scene rules, hostile inputs (lying headers, NaN, bad indices, external URIs, truncation,
// random bytes), concurrency, and format sniffing.
#include "engine/mesh_io.h"

#include <dlfcn.h>
#include <draco/compression/encode.h>
#include <draco/mesh/triangle_soup_mesh_builder.h>
#include <draco/metadata/geometry_metadata.h>
#include <gtest/gtest.h>
#include <sys/inotify.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "engine/errors.h"
#include "engine/io/byte_order.h"
#include "engine/io/readers.h"
#include "engine/io/triangle_strip.h"

namespace featureline {
namespace {

namespace fs = std::filesystem;

// ---- helpers --------------------------------------------------------------------------

std::string mesh_dir() { return std::string(FEATURELINE_SHARED_DIR) + "/data/meshes"; }
std::string mesh_path(const std::string& name) { return mesh_dir() + "/" + name; }

std::string read_file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// Loads a shared data file; a missing file fails the test with its path (never skips).
void load_shared(const std::string& name, std::string& bytes) {
  const std::string path = mesh_path(name);
  ASSERT_TRUE(fs::is_regular_file(path)) << "missing test data file: " << path;
  bytes = read_file_bytes(path);
  ASSERT_FALSE(bytes.empty()) << "empty test data file: " << path;
}

#define LOAD_SHARED(var, name) \
  std::string var;             \
  ASSERT_NO_FATAL_FAILURE(load_shared(name, var))

/// Expects `statement` to throw `type` whose message contains `part`.
#define EXPECT_THROW_MSG(statement, type, part)                                                        \
  do {                                                                                                 \
    try {                                                                                              \
      statement;                                                                                       \
      ADD_FAILURE() << "expected " #type " from: " #statement;                                         \
    } catch (const type& e_) {                                                                         \
      EXPECT_NE(std::string(e_.what()).find(part), std::string::npos) << "message was: " << e_.what(); \
    } catch (const std::exception& e_) {                                                               \
      ADD_FAILURE() << "expected " #type ", got another exception: " << e_.what();                     \
    }                                                                                                  \
  } while (0)

/// Expects `statement` to throw `type` with exactly `message`.
#define EXPECT_THROW_EXACT(statement, type, message)                                \
  do {                                                                              \
    try {                                                                           \
      statement;                                                                    \
      ADD_FAILURE() << "expected " #type " from: " #statement;                      \
    } catch (const type& e_) {                                                      \
      EXPECT_EQ(std::string(e_.what()), std::string(message));                      \
    } catch (const std::exception& e_) {                                            \
      ADD_FAILURE() << "expected " #type ", got another exception: " << e_.what(); \
    }                                                                               \
  } while (0)

using Tri = std::array<std::uint32_t, 3>;
using Vec = std::array<double, 3>;

void put_u32(std::string& s, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) s += static_cast<char>((v >> (8 * i)) & 0xff);
}
void put_u16(std::string& s, std::uint16_t v) {
  s += static_cast<char>(v & 0xff);
  s += static_cast<char>(v >> 8);
}
void put_f32(std::string& s, float f) {
  std::uint32_t u;
  std::memcpy(&u, &f, 4);
  put_u32(s, u);
}
void put_f32_be(std::string& s, float f) {
  std::uint32_t u;
  std::memcpy(&u, &f, 4);
  for (int i = 3; i >= 0; --i) s += static_cast<char>((u >> (8 * i)) & 0xff);
}
void put_i32_be(std::string& s, std::int32_t v) {
  const auto u = static_cast<std::uint32_t>(v);
  for (int i = 3; i >= 0; --i) s += static_cast<char>((u >> (8 * i)) & 0xff);
}

std::string make_binary_stl(const std::vector<std::array<float, 9>>& triangles, const std::string& header_text = "") {
  std::string s = header_text;
  s.resize(80, ' ');
  put_u32(s, static_cast<std::uint32_t>(triangles.size()));
  for (const auto& t : triangles) {
    for (int i = 0; i < 3; ++i) put_f32(s, 0.f);  // normal
    for (float v : t) put_f32(s, v);
    put_u16(s, 0);
  }
  return s;
}

std::string base64(const std::string& in) {
  static const char* table = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  std::size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    const std::uint32_t n = (std::uint32_t(std::uint8_t(in[i])) << 16) | (std::uint32_t(std::uint8_t(in[i + 1])) << 8) |
                            std::uint8_t(in[i + 2]);
    out += table[(n >> 18) & 63];
    out += table[(n >> 12) & 63];
    out += table[(n >> 6) & 63];
    out += table[n & 63];
  }
  if (i + 1 == in.size()) {
    const std::uint32_t n = std::uint32_t(std::uint8_t(in[i])) << 16;
    out += table[(n >> 18) & 63];
    out += table[(n >> 12) & 63];
    out += "==";
  } else if (i + 2 == in.size()) {
    const std::uint32_t n = (std::uint32_t(std::uint8_t(in[i])) << 16) | (std::uint32_t(std::uint8_t(in[i + 1])) << 8);
    out += table[(n >> 18) & 63];
    out += table[(n >> 12) & 63];
    out += table[(n >> 6) & 63];
    out += '=';
  }
  return out;
}

/// Buffer with 4 positions (0,0,0) (1,0,0) (0,1,0) (1,1,0) then ushort indices.
std::string quad_buffer(const std::vector<std::uint16_t>& indices) {
  std::string bin;
  for (float v : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f, 1.f, 1.f, 0.f}) put_f32(bin, v);
  for (auto i : indices) put_u16(bin, i);
  while (bin.size() % 4) bin += '\0';
  return bin;
}

/// A glTF JSON document with one buffer (as data URI unless `uri` is given), position accessor 0
/// (4 vertices at offset 0) and index accessor 1 (`index_count` ushorts at offset 48).
std::string gltf_json(const std::string& bin, std::size_t index_count, const std::string& meshes_nodes_scenes,
                      const std::string& uri = "") {
  // uri "glb" leaves the buffer without a URI (the GLB BIN chunk).
  const std::string buffer_uri = uri.empty() ? "data:application/octet-stream;base64," + base64(bin) : uri;
  const std::string uri_member = uri == "glb" ? std::string() : R"("uri":")" + buffer_uri + R"(",)";
  return R"({"asset":{"version":"2.0"},"buffers":[{)" + uri_member + R"("byteLength":)" +
         std::to_string(bin.size()) + R"(}],"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":48},{"buffer":0,"byteOffset":48,"byteLength":)" +
         std::to_string(bin.size() - 48) + R"(}],"accessors":[{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3"},{"bufferView":1,"componentType":5123,"count":)" +
         std::to_string(index_count) + R"(,"type":"SCALAR"}],)" + meshes_nodes_scenes + "}";
}

std::string make_glb(std::string json, const std::string& bin) {
  while (json.size() % 4) json += ' ';
  std::string out = "glTF";
  put_u32(out, 2);
  put_u32(out, static_cast<std::uint32_t>(12 + 8 + json.size() + (bin.empty() ? 0 : 8 + bin.size())));
  put_u32(out, static_cast<std::uint32_t>(json.size()));
  put_u32(out, 0x4E4F534Au);
  out += json;
  if (!bin.empty()) {
    put_u32(out, static_cast<std::uint32_t>(bin.size()));
    put_u32(out, 0x004E4942u);
    out += bin;
  }
  return out;
}

const std::string one_triangle_mesh = R"("meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1}]}])";

/// A temporary directory removed at the end of the test.
struct TempDir {
  fs::path path;
  TempDir() {
    static std::atomic<int> counter{0};
    path = fs::temp_directory_path() / ("featureline_mesh_io_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  std::string write(const std::string& name, const std::string& bytes) const {
    const std::string p = (path / name).string();
    std::ofstream(p, std::ios::binary) << bytes;
    return p;
  }
};

/// Watches one file for being opened or read (inotify), to prove a reader never touches it.
class OpenWatch {
 public:
  explicit OpenWatch(const std::string& path) : path_(path) {
    fd_ = inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
    if (fd_ >= 0) wd_ = inotify_add_watch(fd_, path.c_str(), IN_OPEN | IN_ACCESS);
  }
  ~OpenWatch() {
    if (fd_ >= 0) ::close(fd_);
  }
  bool ok() const { return fd_ >= 0 && wd_ >= 0; }
  /// True when the file was opened or read since the last call.
  bool touched() {
    char buffer[4096];
    bool any = false;
    while (::read(fd_, buffer, sizeof buffer) > 0) any = true;
    return any;
  }
  /// Opens the file ourselves and checks that the watch notices (so a "not touched" result means something).
  bool notices_a_real_open() {
    touched();
    { std::ifstream in(path_); }
    return touched();
  }

 private:
  std::string path_;
  int fd_ = -1;
  int wd_ = -1;
};

// ---- every shared mesh ------------------------------------------------------------------

struct SharedMesh {
  const char* file;
  MeshFormat format;
  std::size_t vertices;
  std::size_t triangles;
  std::size_t source_faces;
  bool welded;
};

// Counts from data/meshes/SOURCES.md (vertices as stored for OBJ/OFF/PLY, welded for
// glTF/GLB/Draco; triangles after fan triangulation; source faces = polygons in the file).
const SharedMesh shared_meshes[] = {
    {"fandisk.off", MeshFormat::off, 6475, 12946, 12946, false},
    {"fandisk_aimatshape.off", MeshFormat::off, 7229, 14454, 14454, false},
    {"bunny_closed.off", MeshFormat::off, 34835, 69666, 69666, false},
    {"bun_zipper.ply", MeshFormat::ply, 35947, 69451, 69451, false},
    {"bunny_remeshed_6k.obj", MeshFormat::obj, 3301, 6598, 6598, false},
    {"bunny1k.obj", MeshFormat::obj, 1047, 2090, 2090, false},
    {"bunny_gltf.drc", MeshFormat::drc, 34834, 69451, 69451, true},
    {"armadillo_29k.obj", MeshFormat::obj, 14587, 29170, 29170, false},
    {"dragon_25k.off", MeshFormat::off, 12494, 24984, 24984, false},
    {"spot.obj", MeshFormat::obj, 2930, 5856, 5856, false},
    {"spot_control_mesh.obj", MeshFormat::obj, 188, 372, 180, false},
    {"cow.obj", MeshFormat::obj, 2903, 5804, 5804, false},
    {"rocker-arm.obj", MeshFormat::obj, 10044, 20088, 20088, false},
    {"igea.ply", MeshFormat::ply, 134345, 268686, 268686, false},
    {"wingnut.obj", MeshFormat::obj, 3047, 6090, 6090, false},
    {"cube.obj", MeshFormat::obj, 26, 48, 48, false},
    {"cube_no_bottom.obj", MeshFormat::obj, 25, 40, 40, false},
    {"chamfer-cube.off", MeshFormat::off, 24, 44, 26, false},
    {"torus.obj", MeshFormat::obj, 2304, 4608, 4608, false},
    {"hemisphere.off", MeshFormat::off, 1861, 3600, 3600, false},
    {"hole_capsule.off", MeshFormat::off, 89, 152, 76, false},
    {"Box.glb", MeshFormat::glb, 8, 12, 12, true},
    {"Box_Draco.glb", MeshFormat::glb, 8, 12, 12, true},
    {"SheenCloth.glb", MeshFormat::glb, 58081, 115200, 115200, true},
    {"suzanne_draco.glb", MeshFormat::glb, 505, 968, 968, true},
    {"LittlestTokyo.glb", MeshFormat::glb, 100942, 141802, 141802, true},
    {"teapot.obj", MeshFormat::obj, 3644, 6320, 6320, false},
    {"test_nm.obj", MeshFormat::obj, 114, 170, 170, false},
    {"non_manifold_wrap.obj", MeshFormat::obj, 10, 12, 12, false},
    {"deg_faces.obj", MeshFormat::obj, 6, 4, 4, false},
    {"degenerate_mesh.obj", MeshFormat::obj, 3, 1, 1, false},
    {"multiple_isolated_triangles.obj", MeshFormat::obj, 15, 5, 5, false},
    {"multiple_tetrahedrons.obj", MeshFormat::obj, 20, 20, 20, false},
    {"moebius.obj", MeshFormat::obj, 280, 448, 224, false},
    {"triple_vierbein.obj", MeshFormat::obj, 75, 108, 108, false},
    {"hourglass_ico.obj", MeshFormat::obj, 23, 40, 40, false},
    {"fan3.obj", MeshFormat::obj, 5, 3, 3, false},
    {"degenerated.obj", MeshFormat::obj, 7, 24, 24, false},
};

TEST(MeshIoShared, TableCoversEveryFileInTheFolder) {
  ASSERT_TRUE(fs::is_directory(mesh_dir())) << "missing test data folder: " << mesh_dir();
  std::set<std::string> listed;
  for (const auto& m : shared_meshes) listed.insert(m.file);
  std::set<std::string> present;
  for (const auto& entry : fs::directory_iterator(mesh_dir())) {
    const std::string name = entry.path().filename().string();
    if (name != "SOURCES.md") present.insert(name);
  }
  for (const auto& name : present) EXPECT_TRUE(listed.count(name)) << "shared mesh without known counts in this test: " << name;
  for (const auto& name : listed) EXPECT_TRUE(present.count(name)) << "missing test data file: " << mesh_path(name);
  EXPECT_EQ(listed.size(), 38u);
}

TEST(MeshIoShared, EveryFileLoadsWithItsKnownCounts) {
  for (const auto& expected : shared_meshes) {
    SCOPED_TRACE(expected.file);
    const std::string path = mesh_path(expected.file);
    ASSERT_TRUE(fs::is_regular_file(path)) << "missing test data file: " << path;
    RawMesh mesh;
    ASSERT_NO_THROW(mesh = read_mesh_file(path));
    EXPECT_EQ(mesh.format, expected.format);
    EXPECT_EQ(mesh.positions.size(), expected.vertices);
    EXPECT_EQ(mesh.triangles.size(), expected.triangles);
    EXPECT_EQ(mesh.source_faces, expected.source_faces);
    EXPECT_EQ(mesh.welded, expected.welded);
    for (const auto& t : mesh.triangles) {
      for (auto i : t) ASSERT_LT(i, mesh.positions.size());
    }
    for (const auto& p : mesh.positions) {
      ASSERT_TRUE(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]));
    }
  }
}

TEST(MeshIoShared, SniffingGivesTheRealFormat) {
  for (const auto& expected : shared_meshes) {
    SCOPED_TRACE(expected.file);
    LOAD_SHARED(bytes, expected.file);
    EXPECT_EQ(sniff_mesh_format(bytes), expected.format);
    EXPECT_EQ(mesh_format_from_path(expected.file), expected.format);
  }
}

// ---- format names and sniffing ----------------------------------------------------------

TEST(MeshIoFormat, NamesRoundTrip) {
  const std::map<MeshFormat, std::string> names = {{MeshFormat::obj, "obj"},   {MeshFormat::off, "off"},
                                                   {MeshFormat::ply, "ply"},   {MeshFormat::stl, "stl"},
                                                   {MeshFormat::gltf, "gltf"}, {MeshFormat::glb, "glb"},
                                                   {MeshFormat::drc, "drc"}};
  for (const auto& [format, name] : names) {
    EXPECT_EQ(to_string(format), name);
    EXPECT_EQ(parse_mesh_format(name), format);
  }
  EXPECT_EQ(parse_mesh_format("OFF"), MeshFormat::off);
  EXPECT_EQ(parse_mesh_format("Glb"), MeshFormat::glb);
  EXPECT_EQ(parse_mesh_format(""), std::nullopt);
  EXPECT_EQ(parse_mesh_format("objx"), std::nullopt);
  EXPECT_EQ(parse_mesh_format("fbx"), std::nullopt);
}

TEST(MeshIoFormat, FormatFromPath) {
  EXPECT_EQ(mesh_format_from_path("a/b/Model.OBJ"), MeshFormat::obj);
  EXPECT_EQ(mesh_format_from_path("scene.gltf"), MeshFormat::gltf);
  EXPECT_EQ(mesh_format_from_path("C:\\x\\y.Stl"), MeshFormat::stl);
  EXPECT_EQ(mesh_format_from_path("x.tar.gz"), std::nullopt);
  EXPECT_EQ(mesh_format_from_path("noext"), std::nullopt);
  EXPECT_EQ(mesh_format_from_path("dir.obj/file"), std::nullopt);
  EXPECT_EQ(mesh_format_from_path("trailingdot."), std::nullopt);
}

TEST(MeshIoFormat, SniffSynthetic) {
  EXPECT_EQ(sniff_mesh_format(make_binary_stl({{0, 0, 0, 1, 0, 0, 0, 1, 0}}, "solid but binary")), MeshFormat::stl);
  EXPECT_EQ(sniff_mesh_format("solid x\nfacet normal 0 0 1\n"), MeshFormat::stl);
  EXPECT_EQ(sniff_mesh_format("COFF\n3 1 0\n"), MeshFormat::off);
  EXPECT_EQ(sniff_mesh_format("NOFF\n3 1 0\n"), MeshFormat::off);
  EXPECT_EQ(sniff_mesh_format("ply\nformat ascii 1.0\n"), MeshFormat::ply);
  EXPECT_EQ(sniff_mesh_format("  {\"asset\":{\"version\":\"2.0\"}}"), MeshFormat::gltf);
  EXPECT_EQ(sniff_mesh_format("# made by hand\no thing\nv 0 0 0\nf 1 1 1\n"), MeshFormat::obj);
  EXPECT_EQ(sniff_mesh_format("DRACO\x02\x02"), MeshFormat::drc);
  EXPECT_EQ(sniff_mesh_format("hello world\n"), std::nullopt);
  EXPECT_EQ(sniff_mesh_format(""), std::nullopt);
  EXPECT_EQ(sniff_mesh_format("{\"json\": 1}"), std::nullopt);
  EXPECT_EQ(sniff_mesh_format("# only a comment\n"), std::nullopt);
}

// ---- OBJ ----------------------------------------------------------------------------------

TEST(MeshIoObj, VertexIdsFollowFileOrder) {
  LOAD_SHARED(bunny, "bunny1k.obj");
  const RawMesh mesh = read_mesh(bunny, MeshFormat::obj);
  ASSERT_EQ(mesh.positions.size(), 1047u);
  // "v 0.117507 -0.685214 0.711598" is line 1, "v -0.0573502 -0.926194 -0.206481" the 500th v line.
  EXPECT_EQ(mesh.positions[0], (Vec{0.117507, -0.685214, 0.711598}));
  EXPECT_EQ(mesh.positions[499], (Vec{-0.0573502, -0.926194, -0.206481}));
  EXPECT_EQ(mesh.positions[1046], (Vec{-0.659986, 0.836325, -0.721554}));
  EXPECT_EQ(mesh.triangles[0], (Tri{0, 1, 2}));  // f 1 2 3
  EXPECT_EQ(mesh.triangles[1], (Tri{3, 1, 0}));  // f 4 2 1

  // wingnut.obj starts with 46 comment lines; full double precision is kept.
  LOAD_SHARED(wingnut, "wingnut.obj");
  const RawMesh w = read_mesh(wingnut, MeshFormat::obj);
  EXPECT_EQ(w.positions[0], (Vec{0.5352182576084975, -0.03821388301744169, -1.537970379561425}));
  EXPECT_EQ(w.positions[3046], (Vec{-0.1120999375017594, -0.9545692975531432, 1.415700361231588}));
}

TEST(MeshIoObj, PolygonsAreFanTriangulatedInFileOrder) {
  LOAD_SHARED(bytes, "spot_control_mesh.obj");
  const RawMesh mesh = read_mesh(bytes, MeshFormat::obj);
  EXPECT_EQ(mesh.source_faces, 180u);
  EXPECT_EQ(mesh.triangles.size(), 372u);
  // f 6/1 14/2 10/3 16/4, then f 6/1 18/5 13/6 14/2
  EXPECT_EQ(mesh.triangles[0], (Tri{5, 13, 9}));
  EXPECT_EQ(mesh.triangles[1], (Tri{5, 9, 15}));
  EXPECT_EQ(mesh.triangles[2], (Tri{5, 17, 12}));
  EXPECT_EQ(mesh.triangles[3], (Tri{5, 12, 13}));
}

TEST(MeshIoObj, DegenerateAndDuplicateFacesAreKept) {
  LOAD_SHARED(deg, "deg_faces.obj");
  const RawMesh mesh = read_mesh(deg, MeshFormat::obj);
  const std::vector<Tri> expected = {{0, 1, 2}, {2, 1, 5}, {3, 5, 1}, {0, 0, 2}};
  EXPECT_EQ(mesh.triangles, expected);

  const RawMesh repeated = read_mesh("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 1 3\nf 1 2 3\nf 1 2 3\n", MeshFormat::obj);
  const std::vector<Tri> expected_repeated = {{0, 1, 0}, {0, 0, 2}, {0, 1, 2}, {0, 1, 2}};
  EXPECT_EQ(repeated.triangles, expected_repeated);
  EXPECT_EQ(repeated.source_faces, 3u);
}

TEST(MeshIoObj, IndexForms) {
  const RawMesh mesh = read_mesh(
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvn 0 0 1\n"
      "f -4 -3 -2\nf 2/1/1 4/1/1 3/1/1\nf 1//1 2//1 4//1\n"
      "l 1 2\n",
      MeshFormat::obj);
  const std::vector<Tri> expected = {{0, 1, 2}, {1, 3, 2}, {0, 1, 3}};
  EXPECT_EQ(mesh.triangles, expected);
  ASSERT_EQ(mesh.warnings.size(), 1u);
  EXPECT_EQ(mesh.warnings[0], "OBJ file has 1 line elements ('l'), which were ignored.");
}

TEST(MeshIoObj, BadIndicesAndCoordinates) {
  EXPECT_THROW_EXACT(read_mesh("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", MeshFormat::obj), MeshFormatError,
                     "OBJ face 1 (line 4) refers to vertex 9 but the file has only 3 vertices.");
  EXPECT_THROW_EXACT(read_mesh("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", MeshFormat::obj), MeshFormatError,
                     "OBJ face 1 (line 4) uses vertex index 0, but OBJ indices start at 1.");
  EXPECT_THROW_EXACT(read_mesh("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n", MeshFormat::obj), MeshFormatError,
                     "OBJ face 1 (line 4) uses relative vertex index -4 but only 3 vertices precede it.");
  EXPECT_THROW_EXACT(read_mesh("v 0 0 0\nv 1 0 0\nf 1 2\n", MeshFormat::obj), MeshFormatError,
                     "OBJ face 1 (line 3) has 2 vertices; a face needs at least 3.");
  EXPECT_THROW_EXACT(read_mesh("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 x 3\n", MeshFormat::obj), MeshFormatError,
                     "OBJ face 1 (line 4) has a vertex reference 'x' that is not an index.");
}

TEST(MeshIoObj, NonFiniteCoordinatesAreRejectedNotDropped) {
  // OpenMesh would silently drop this vertex and shift every later index.
  EXPECT_THROW_EXACT(read_mesh("v 0 0 0\nv nan 0 0\nv 0 1 0\nv 1 1 1\nf 1 3 4\n", MeshFormat::obj), MeshFormatError,
                     "OBJ vertex 2 (line 2) has a non-finite coordinate 'nan'.");
  EXPECT_THROW_EXACT(read_mesh("v 0 0 0\nv 1 0 0\nv 0 -inf 0\nf 1 2 3\n", MeshFormat::obj), MeshFormatError,
                     "OBJ vertex 3 (line 3) has a non-finite coordinate '-inf'.");
  EXPECT_THROW_EXACT(read_mesh("v 0 0 0\nv 1e999 0 0\nv 0 1 0\nf 1 2 3\n", MeshFormat::obj), MeshFormatError,
                     "OBJ vertex 2 (line 2) has a non-finite coordinate '1e999'.");
  EXPECT_THROW_EXACT(read_mesh("v 0 0 0\nv 0x1p3 0 0\nv 0 1 0\nf 1 2 3\n", MeshFormat::obj), MeshFormatError,
                     "OBJ vertex 2 (line 2) has a coordinate '0x1p3' that is not a number.");
  EXPECT_THROW_EXACT(read_mesh("v 0 0\nf 1 1 1\n", MeshFormat::obj), MeshFormatError,
                     "OBJ vertex 1 (line 1) has fewer than 3 coordinates.");
}

TEST(MeshIoObj, MtllibIsNeverOpened) {
  TempDir dir;
  const std::string mtl = dir.write("evil.mtl", "newmtl m\nKd 1 0 0\n");
  OpenWatch watch(mtl);
  ASSERT_TRUE(watch.ok());
  const std::string obj = "mtllib " + mtl + "\nmtllib /etc/passwd\nusemtl m\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  const RawMesh mesh = read_mesh(obj, MeshFormat::obj);
  EXPECT_EQ(mesh.positions.size(), 3u);
  EXPECT_EQ(mesh.triangles.size(), 1u);
  EXPECT_FALSE(watch.touched()) << "the OBJ reader opened the mtllib file";
  EXPECT_TRUE(watch.notices_a_real_open());  // the watch itself works
  // The same through a file path.
  const std::string path = dir.write("with_mtl.obj", obj);
  EXPECT_EQ(read_mesh_file(path).triangles.size(), 1u);
  EXPECT_FALSE(watch.touched()) << "the OBJ reader opened the mtllib file";
}

TEST(MeshIoObj, EmptyInputs) {
  EXPECT_THROW_EXACT(read_mesh("", MeshFormat::obj), MeshFormatError, "OBJ input is empty.");
  EXPECT_THROW_EXACT(read_mesh("# nothing\n", MeshFormat::obj), MeshFormatError, "OBJ input contains no vertices.");
  EXPECT_THROW_EXACT(read_mesh("v 0 0 0\nv 1 0 0\n", MeshFormat::obj), MeshFormatError, "OBJ input contains no triangles.");
}

// ---- OFF ----------------------------------------------------------------------------------

TEST(MeshIoOff, IdsAndFanTriangulation) {
  LOAD_SHARED(bytes, "chamfer-cube.off");
  const RawMesh mesh = read_mesh(bytes, MeshFormat::off);
  // "-0.6 -0.6  1.0" is vertex 0, read in double precision (it came through OpenMesh as float).
  EXPECT_EQ(mesh.positions[0], (Vec{-0.6, -0.6, 1.0}));
  EXPECT_EQ(mesh.triangles[0], (Tri{0, 1, 2}));  // "4 0 1 2 3"
  EXPECT_EQ(mesh.triangles[1], (Tri{0, 2, 3}));
  EXPECT_EQ(mesh.triangles[2], (Tri{4, 5, 6}));  // "4 4 5 6 7"
  EXPECT_EQ(mesh.source_faces, 26u);
  EXPECT_EQ(mesh.triangles.size(), 44u);
}

TEST(MeshIoOff, CommentsCountsOnHeaderLineFaceColoursAndDegenerateFaces) {
  const RawMesh mesh = read_mesh(
      "OFF 4 3 0\n# a comment\n0 0 0\n1 0 0 # trailing comment\n0 1 0\n0 0 1\n"
      "3 0 1 2 255 0 0\n3 0 0 3\n3 0 1 2\n",
      MeshFormat::off);
  const std::vector<Tri> expected = {{0, 1, 2}, {0, 0, 3}, {0, 1, 2}};
  EXPECT_EQ(mesh.triangles, expected);
  EXPECT_EQ(mesh.positions[3], (Vec{0, 0, 1}));
}

TEST(MeshIoOff, LyingHeaderFailsFast) {
  const auto start = std::chrono::steady_clock::now();
  EXPECT_THROW_EXACT(read_mesh("OFF\n2000000000 1 0\n0 0 0\n", MeshFormat::off), MeshFormatError,
                     "OFF header claims 2000000000 vertices but the file has only 25 bytes.");
  EXPECT_THROW_EXACT(read_mesh("OFF\n3 2000000000 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", MeshFormat::off), MeshFormatError,
                     "OFF header claims 3 vertices and 2000000000 faces but the file has only 45 bytes.");
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(1));
}

TEST(MeshIoOff, GarbageNanAndBadIndices) {
  // OpenMesh turned a garbage token into millions of vertices and a nan into garbage indices.
  EXPECT_THROW_EXACT(read_mesh("OFF\n3 1 0\n0 0 0\n1 x 0\n0 1 0\n3 0 1 2\n", MeshFormat::off), MeshFormatError,
                     "OFF vertex 2 (line 4) has a coordinate 'x' that is not a number.");
  EXPECT_THROW_EXACT(read_mesh("OFF\n3 1 0\n0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n", MeshFormat::off), MeshFormatError,
                     "OFF vertex 2 (line 4) has a non-finite coordinate 'nan'.");
  EXPECT_THROW_EXACT(read_mesh("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", MeshFormat::off), MeshFormatError,
                     "OFF face 1 (line 6) refers to vertex index 3 but the file has only 3 vertices (indices start at 0).");
  EXPECT_THROW_EXACT(read_mesh("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n", MeshFormat::off), MeshFormatError,
                     "OFF face 1 (line 6) refers to vertex index -1 but the file has only 3 vertices (indices start at 0).");
  EXPECT_THROW_EXACT(read_mesh("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1\n", MeshFormat::off), MeshFormatError,
                     "OFF face 1 (line 6) has too few vertex indices.");
  EXPECT_THROW_EXACT(read_mesh("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n99999999 0 1 2\n", MeshFormat::off), MeshFormatError,
                     "OFF face 1 (line 6) claims 99999999 vertices, more than the rest of the file can hold.");
  EXPECT_THROW_EXACT(read_mesh("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n", MeshFormat::off), MeshFormatError,
                     "OFF face 1 (line 6) has 2 vertices; a face needs at least 3.");
  EXPECT_THROW_EXACT(read_mesh("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n", MeshFormat::off), MeshFormatError,
                     "OFF header claims 3 vertices and 1 faces but the file has only 28 bytes.");
  EXPECT_THROW_EXACT(read_mesh("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n# where are the faces?\n", MeshFormat::off),
                     MeshFormatError, "OFF file ends after 0 of its 1 faces.");
  EXPECT_THROW_EXACT(read_mesh("OFF BINARY\n", MeshFormat::off), MeshFormatError,
                     "Binary OFF is not supported; use ASCII OFF or PLY.");
  EXPECT_THROW_EXACT(read_mesh("OF\n3 1 0\n", MeshFormat::off), MeshFormatError,
                     "OFF file does not start with an OFF keyword (found 'OF').");
  EXPECT_THROW_EXACT(read_mesh("OFF\n0 0 0\n", MeshFormat::off), MeshFormatError, "OFF input contains no vertices.");
}

// ---- PLY ----------------------------------------------------------------------------------

TEST(MeshIoPly, AsciiIdsKept) {
  LOAD_SHARED(bytes, "bun_zipper.ply");
  const RawMesh mesh = read_mesh(bytes, MeshFormat::ply);
  // "-0.0378297 0.12794 0.00447467 ..." in double precision (it came through OpenMesh as float).
  EXPECT_EQ(mesh.positions[0], (Vec{-0.0378297, 0.12794, 0.00447467}));
  EXPECT_EQ(mesh.triangles[0], (Tri{21216, 21215, 20399}));
  EXPECT_EQ(mesh.triangles[1], (Tri{9186, 9280, 14838}));
}

TEST(MeshIoPly, TriangleStripsDecodeWithAlternatingWinding) {
  LOAD_SHARED(bytes, "igea.ply");
  const RawMesh mesh = read_mesh(bytes, MeshFormat::ply);
  ASSERT_EQ(mesh.triangles.size(), 268686u);
  // The strip starts 0 1 2 3 4 5.
  EXPECT_EQ(mesh.triangles[0], (Tri{0, 1, 2}));
  EXPECT_EQ(mesh.triangles[1], (Tri{2, 1, 3}));
  EXPECT_EQ(mesh.triangles[2], (Tri{2, 3, 4}));
  EXPECT_EQ(mesh.triangles[3], (Tri{4, 3, 5}));
  EXPECT_EQ(mesh.positions[0], (Vec{double(0.008178f), double(-0.049651f), double(0.014658f)}));
  EXPECT_EQ(mesh.positions[134344], (Vec{double(0.001461f), double(0.049127f), double(0.018492f)}));
  EXPECT_TRUE(mesh.warnings.empty());
}

TEST(MeshIoPly, ExtraPropertiesListsAndElementsDoNotShiftIds) {
  // Elements and list properties before, between and after the ones read are skipped by type.
  const std::string ply =
      "ply\nformat ascii 1.0\ncomment hi\n"
      "element vertex 4\nproperty float confidence\nproperty list uchar float weights\nproperty float x\n"
      "property float y\nproperty float z\n"
      "element edge 1\nproperty list uchar int vertex_indices\n"
      "element face 2\nproperty uchar flags\nproperty list uchar int vertex_index\nproperty list uchar float texcoord\n"
      "end_header\n"
      "0.5 2 9 9 0 0 0\n0.5 0 1 0 0\n0.5 1 7 0 1 0\n0.5 0 1 1 1\n"
      "3 0 1 2\n"
      "1 4 0 1 3 2 8 0 0 1 1 2 2 3 3\n0 3 1 2 3 6 1 1 2 2 3 3\n";
  const RawMesh mesh = read_mesh(ply, MeshFormat::ply);
  const std::vector<Vec> positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 1}};
  const std::vector<Tri> triangles = {{0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  EXPECT_EQ(mesh.positions, positions);
  EXPECT_EQ(mesh.triangles, triangles);
  EXPECT_EQ(mesh.source_faces, 2u);
}

TEST(MeshIoPly, BinaryBigEndian) {
  std::string ply =
      "ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  for (float v : {0.f, 0.f, 0.f, 1.5f, 0.f, 0.f, 0.f, 2.5f, -1.f}) put_f32_be(ply, v);
  ply += '\x03';
  for (int i : {2, 1, 0}) put_i32_be(ply, i);
  const RawMesh mesh = read_mesh(ply, MeshFormat::ply);
  const std::vector<Vec> positions = {{0, 0, 0}, {1.5, 0, 0}, {0, 2.5, -1}};
  EXPECT_EQ(mesh.positions, positions);
  EXPECT_EQ(mesh.triangles, (std::vector<Tri>{{2, 1, 0}}));
}

TEST(MeshIoPly, IntegerCoordinatesAndUnusualListTypes) {
  // Integer coordinates and any integer list types (OpenMesh 9 read int16 coordinates as 0 and
  // rejected list counts other than uchar/int).
  std::string ply =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty short x\nproperty short y\nproperty short z\n"
      "element face 1\nproperty list ushort ushort vertex_indices\nend_header\n";
  for (int v : {0, 0, 0, 7, 0, 0, 0, -3, 2}) put_u16(ply, static_cast<std::uint16_t>(static_cast<std::int16_t>(v)));
  put_u16(ply, 3);
  for (int i : {0, 2, 1}) put_u16(ply, static_cast<std::uint16_t>(i));
  const RawMesh mesh = read_mesh(ply, MeshFormat::ply);
  EXPECT_EQ(mesh.positions, (std::vector<Vec>{{0, 0, 0}, {7, 0, 0}, {0, -3, 2}}));
  EXPECT_EQ(mesh.triangles, (std::vector<Tri>{{0, 2, 1}}));

  const RawMesh ascii = read_mesh(
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty int x\nproperty int y\nproperty int z\n"
      "element face 1\nproperty list char int vertex_indices\nend_header\n0 0 0\n5 0 0\n0 5 0\n3 1 2 0\n",
      MeshFormat::ply);
  EXPECT_EQ(ascii.positions[1], (Vec{5, 0, 0}));
  EXPECT_EQ(ascii.triangles, (std::vector<Tri>{{1, 2, 0}}));
}

TEST(MeshIoPly, BinaryLittleEndianDoublesAndDegenerateFace) {
  std::string ply =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\n"
      "element face 2\nproperty list uchar uint vertex_indices\nend_header\n";
  for (double v : {0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 4.0, 0.0}) {
    std::uint64_t u;
    std::memcpy(&u, &v, 8);
    for (int i = 0; i < 8; ++i) ply += static_cast<char>((u >> (8 * i)) & 0xff);
  }
  for (const auto& face : {std::array<std::uint32_t, 3>{0, 1, 2}, std::array<std::uint32_t, 3>{1, 1, 2}}) {
    ply += '\x03';
    for (auto i : face) put_u32(ply, i);
  }
  const RawMesh mesh = read_mesh(ply, MeshFormat::ply);
  EXPECT_EQ(mesh.positions[1], (Vec{0.25, 0, 0}));
  EXPECT_EQ(mesh.triangles, (std::vector<Tri>{{0, 1, 2}, {1, 1, 2}}));

  // Truncated by one byte.
  EXPECT_THROW_EXACT(read_mesh(ply.substr(0, ply.size() - 1), MeshFormat::ply), MeshFormatError,
                     "PLY file ends in the middle of face 2.");
}

TEST(MeshIoPly, LyingAndTruncated) {
  const auto start = std::chrono::steady_clock::now();
  const std::string lying =
      "ply\nformat binary_little_endian 1.0\nelement vertex 2000000000\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0123456789";
  EXPECT_THROW_EXACT(read_mesh(lying, MeshFormat::ply), MeshFormatError,
                     "PLY header claims 2000000000 vertex elements but the file has only " + std::to_string(lying.size()) +
                         " bytes.");
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(1));

  LOAD_SHARED(igea, "igea.ply");
  EXPECT_THROW_EXACT(read_mesh(std::string_view(igea).substr(0, 1000000), MeshFormat::ply), MeshFormatError,
                     "PLY header claims 134345 vertex elements but the file has only 1000000 bytes.");
  EXPECT_THROW_EXACT(read_mesh(std::string_view(igea).substr(0, igea.size() - 100), MeshFormat::ply), MeshFormatError,
                     "PLY triangle strip 1 claims a list of 373830 values, more than the rest of the file holds.");

  LOAD_SHARED(bunny, "bun_zipper.ply");
  EXPECT_THROW_EXACT(read_mesh(std::string_view(bunny).substr(0, bunny.size() - 30), MeshFormat::ply), MeshFormatError,
                   "PLY file ends in the middle of face 69450 (line 105409).");
}

TEST(MeshIoPly, BadValues) {
  const std::string head =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  EXPECT_THROW_EXACT(read_mesh(head + "0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n", MeshFormat::ply), MeshFormatError,
                     "PLY vertex 2 (line 11) has a non-finite value 'nan'.");
  EXPECT_THROW_EXACT(read_mesh(head + "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", MeshFormat::ply), MeshFormatError,
                     "PLY face 1 (line 13) refers to vertex index 3 but the file has only 3 vertices (indices start at 0).");
  EXPECT_THROW_EXACT(read_mesh(head + "0 0 0\n1 0 0\n0 1 0\n3 0 1 x\n", MeshFormat::ply), MeshFormatError,
                     "PLY face 1 (line 13) has a value 'x' that is not an integer.");
  EXPECT_THROW_EXACT(read_mesh("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                               "property float z\nend_header\n0 0 0\n",
                               MeshFormat::ply),
                     MeshFormatError, "PLY file has no face or tristrips element (a point cloud is not a mesh).");
  EXPECT_THROW_EXACT(read_mesh("ply\nformat ascii 1.0\nelement vertex 1\n", MeshFormat::ply), MeshFormatError,
                     "PLY header has no 'end_header' line.");
  EXPECT_THROW_EXACT(read_mesh("plx\n", MeshFormat::ply), MeshFormatError, "PLY file does not start with 'ply'.");
}

// ---- STL ----------------------------------------------------------------------------------

TEST(MeshIoStl, BinaryIsWeldedByExactPosition) {
  // Two triangles sharing an edge, in a file whose header starts with "solid".
  const std::string stl = make_binary_stl({{0, 0, 0, 1, 0, 0, 0, 1, 0}, {1, 0, 0, 1, 1, 0, 0, 1, 0}}, "solid fake");
  const RawMesh mesh = read_mesh(stl, MeshFormat::stl);
  EXPECT_TRUE(mesh.welded);
  const std::vector<Vec> positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  EXPECT_EQ(mesh.positions, positions);
  EXPECT_EQ(mesh.triangles, (std::vector<Tri>{{0, 1, 2}, {1, 3, 2}}));
  EXPECT_EQ(mesh.source_faces, 2u);
  EXPECT_TRUE(mesh.warnings.empty());

  // -0 and +0 are one position.
  const RawMesh zero = read_mesh(make_binary_stl({{0, 0, 0, 1, 0, 0, 0, 1, 0}, {-0.f, 0, 0, 0, 1, 0, 0, 0, 1}}), MeshFormat::stl);
  EXPECT_EQ(zero.positions.size(), 4u);
}

TEST(MeshIoStl, BinaryHeaderChecks) {
  const std::string stl = make_binary_stl({{0, 0, 0, 1, 0, 0, 0, 1, 0}, {1, 0, 0, 1, 1, 0, 0, 1, 0}});
  EXPECT_THROW_EXACT(read_mesh(stl.substr(0, stl.size() - 10), MeshFormat::stl), MeshFormatError,
                     "Binary STL header claims 2 triangles (184 bytes) but the file has only 174 bytes.");
  // Trailing bytes, and a header starting with "solid": still binary.
  const RawMesh padded = read_mesh(make_binary_stl({{0, 0, 0, 1, 0, 0, 0, 1, 0}, {1, 0, 0, 1, 1, 0, 0, 1, 0}}, "solid x") + "xyz",
                                   MeshFormat::stl);
  EXPECT_EQ(padded.triangles.size(), 2u);
  ASSERT_EQ(padded.warnings.size(), 1u);
  EXPECT_EQ(padded.warnings[0], "Binary STL has 3 bytes after its 2 triangles; they were ignored.");

  // 84 bytes claiming 0xFFFFFFF0 triangles: OpenMesh loops for a long time on this.
  std::string lying(80, 'x');
  put_u32(lying, 0xFFFFFFF0u);
  const auto start = std::chrono::steady_clock::now();
  EXPECT_THROW_EXACT(read_mesh(lying, MeshFormat::stl), MeshFormatError,
                     "Binary STL header claims 4294967280 triangles (214748364084 bytes) but the file has only 84 bytes.");
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(1));

  EXPECT_THROW_EXACT(read_mesh(make_binary_stl({}), MeshFormat::stl), MeshFormatError, "STL input contains no vertices.");
  EXPECT_THROW_EXACT(read_mesh(make_binary_stl({{0, 0, 0, 1, 0, std::nanf(""), 0, 1, 0}}), MeshFormat::stl), MeshFormatError,
                     "Binary STL triangle 1 has a non-finite coordinate at corner 2.");
  EXPECT_THROW_MSG(read_mesh("not an stl", MeshFormat::stl), MeshFormatError, "STL file has only 10 bytes");
}

TEST(MeshIoStl, AsciiKeepsDegenerateFacets) {
  const std::string stl =
      "solid thing\n"
      "facet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 1 0 0\n  vertex 0 1 0\n endloop\nendfacet\n"
      "facet normal 0 0 1\n outer loop\n  vertex 1 0 0\n  vertex 1 0 0\n  vertex 0 1 0\n endloop\nendfacet\n"
      "endsolid thing\n";
  const RawMesh mesh = read_mesh(stl, MeshFormat::stl);
  EXPECT_EQ(mesh.positions.size(), 3u);
  EXPECT_EQ(mesh.triangles, (std::vector<Tri>{{0, 1, 2}, {1, 1, 2}}));

  EXPECT_THROW_EXACT(read_mesh("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
                               "vertex 1 1 1\nendloop\nendfacet\nendsolid\n",
                               MeshFormat::stl),
                     MeshFormatError, "ASCII STL facet 1 (line 2) has 4 vertices; STL facets are triangles.");
  EXPECT_THROW_EXACT(read_mesh("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 nan 0\n", MeshFormat::stl), MeshFormatError,
                     "ASCII STL line 4: vertex of facet 1 has a non-finite coordinate 'nan'.");
  EXPECT_THROW_EXACT(read_mesh("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n", MeshFormat::stl), MeshFormatError,
                     "ASCII STL ends inside a facet (started on line 2).");
  EXPECT_THROW_EXACT(read_mesh("solid x\nhello\n", MeshFormat::stl), MeshFormatError, "ASCII STL line 2: unexpected 'hello'.");
}

// ---- double precision in every reader that stores text or doubles ------------------------

// 1.000000000001 is 1 + 4504 ulps of a double and 1.0f as a float: it survives only a reader
// that keeps doubles.
constexpr double kFine = 1.000000000001;
constexpr double kTiny = -2.5e-300;  // below float's range: a float reader flushes it to 0

TEST(MeshIoPrecision, TextFormatsKeepEveryDoubleDigit) {
  ASSERT_NE(double(float(kFine)), kFine);
  const Vec fine{kFine, 0.1, kTiny};
  const std::string v1 = "1.000000000001 0.1 -2.5e-300";
  const std::map<MeshFormat, std::string> files = {
      {MeshFormat::obj, "v " + v1 + "\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"},
      {MeshFormat::off, "OFF\n3 1 0\n" + v1 + "\n1 0 0\n0 1 0\n3 0 1 2\n"},
      {MeshFormat::ply,
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\n"
       "element face 1\nproperty list uchar int vertex_indices\nend_header\n" + v1 + "\n1 0 0\n0 1 0\n3 0 1 2\n"},
      {MeshFormat::stl, "solid s\nfacet normal 0 0 1\nouter loop\nvertex " + v1 +
                            "\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid s\n"},
  };
  for (const auto& [format, text] : files) {
    SCOPED_TRACE(to_string(format));
    const RawMesh mesh = read_mesh(text, format);
    ASSERT_EQ(mesh.positions.size(), 3u);
    EXPECT_EQ(mesh.positions[0], fine);
    EXPECT_EQ(mesh.triangles, (std::vector<Tri>{{0, 1, 2}}));
  }
}

TEST(MeshIoPrecision, CoordinatesBeyondFloatRangeAreKeptWithinTheEngineRange) {
  // Beyond float's range and precision (3.4e38 is float's largest; 1e-40 is below its smallest
  // normal), within the engine's: read as written.
  const RawMesh off = read_mesh("OFF\n3 1 0\n1e15 0 0\n0 1 0\n0 0 -1e-40\n3 0 1 2\n", MeshFormat::off);
  EXPECT_EQ(off.positions[0][0], 1e15);
  EXPECT_EQ(off.positions[2][2], -1e-40);
  // Above 1e15 the engine's squares and cubes lose the mesh (1e300 had given NaN lengths): refused.
  EXPECT_THROW_MSG(read_mesh("OFF\n3 1 0\n1e300 0 0\n0 1 0\n0 0 -4e39\n3 0 1 2\n", MeshFormat::off), MeshFormatError,
                   "OFF vertex 1 has a coordinate of magnitude 1e+300, above the 1e15 this engine computes with; scale the mesh.");
  EXPECT_THROW_MSG(read_mesh("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                             "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n0 1 0\n0 0 -2e16\n3 0 1 2\n",
                             MeshFormat::ply),
                   MeshFormatError, "PLY vertex 3 has a coordinate of magnitude 2e+16");
  // A mesh smaller than 1e-30 across underflows when squared twice: refused; one point (no extent) is not.
  EXPECT_THROW_MSG(read_mesh("OFF\n3 1 0\n0 0 0\n1e-31 0 0\n0 1e-31 0\n3 0 1 2\n", MeshFormat::off), MeshFormatError,
                   "OFF input spans 1.41421e-31 units, less than the 1e-30");
  EXPECT_NO_THROW(read_mesh("OFF\n3 1 0\n0 0 0\n0 0 0\n0 0 0\n3 0 1 2\n", MeshFormat::off));
}

/// A binary PLY triangle whose double coordinates include kFine, in the given byte order.
std::string binary_ply_with_doubles(bool big_endian) {
  std::string ply = std::string("ply\nformat ") + (big_endian ? "binary_big_endian" : "binary_little_endian") +
                    " 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\n"
                    "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  const auto put = [&](std::uint64_t bits, int bytes) {
    for (int i = 0; i < bytes; ++i) {
      const int shift = 8 * (big_endian ? bytes - 1 - i : i);
      ply += static_cast<char>((bits >> shift) & 0xff);
    }
  };
  for (double v : {kFine, 0.1, kTiny, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0}) {
    std::uint64_t bits;
    std::memcpy(&bits, &v, 8);
    put(bits, 8);
  }
  put(3, 1);
  for (std::uint64_t i : {0, 1, 2}) put(i, 4);
  return ply;
}

TEST(MeshIoPrecision, BinaryPlyDoublesAreExactInBothByteOrders) {
  for (bool big_endian : {false, true}) {
    SCOPED_TRACE(big_endian ? "big endian" : "little endian");
    const RawMesh mesh = read_mesh(binary_ply_with_doubles(big_endian), MeshFormat::ply);
    ASSERT_EQ(mesh.positions.size(), 3u);
    EXPECT_EQ(mesh.positions[0], (Vec{kFine, 0.1, kTiny}));
    EXPECT_EQ(mesh.positions[2], (Vec{0, 1, 0}));
    EXPECT_EQ(mesh.triangles, (std::vector<Tri>{{0, 1, 2}}));
  }
}

// ---- shared decoding helpers --------------------------------------------------------------

TEST(MeshIoHelpers, ByteOrderLoads) {
  const unsigned char bytes[8] = {0x01, 0x02, 0x03, 0x04, 0xBF, 0xC0, 0x00, 0x00};
  using detail::ByteOrder;
  EXPECT_EQ(detail::load<std::uint32_t>(bytes, ByteOrder::little_endian), 0x04030201u);
  EXPECT_EQ(detail::load<std::uint32_t>(bytes, ByteOrder::big_endian), 0x01020304u);
  EXPECT_EQ(detail::load<std::uint16_t>(bytes, ByteOrder::big_endian), 0x0102u);
  EXPECT_EQ(detail::load<std::int8_t>(bytes + 4, ByteOrder::big_endian), std::int8_t(-65));
  EXPECT_EQ(detail::load<std::int16_t>(bytes + 4, ByteOrder::big_endian), std::int16_t(-16448));  // 0xBFC0
  EXPECT_EQ(detail::load<float>(bytes + 4, ByteOrder::big_endian), -1.5f);                         // BF C0 00 00
  const unsigned char one_le[8] = {0, 0, 0, 0, 0, 0, 0xF0, 0x3F};
  const unsigned char one_be[8] = {0x3F, 0xF0, 0, 0, 0, 0, 0, 0};
  EXPECT_EQ(detail::load_little_endian<double>(one_le), 1.0);
  EXPECT_EQ(detail::load<double>(one_be, ByteOrder::big_endian), 1.0);
}

TEST(MeshIoHelpers, TriangleStripAndFanKnownAnswers) {
  using detail::TriangleRun;
  std::vector<Tri> out;
  const std::vector<std::uint32_t> strip = {0, 1, 2, 3, 4, 5};
  EXPECT_EQ(detail::append_run_triangles(strip.data(), strip.size(), TriangleRun::strip, out), 0u);
  EXPECT_EQ(out, (std::vector<Tri>{{0, 1, 2}, {2, 1, 3}, {2, 3, 4}, {4, 3, 5}}));

  out.clear();
  const std::vector<std::uint32_t> fan = {7, 1, 2, 3};
  EXPECT_EQ(detail::append_run_triangles(fan.data(), fan.size(), TriangleRun::fan, out), 0u);
  EXPECT_EQ(out, (std::vector<Tri>{{7, 1, 2}, {7, 2, 3}}));

  // Two strips stitched by repeating 3 and 4: the triangles with a repeated corner are skipped
  // and counted, and the parity of the later ones still follows their position in the run.
  out = {{9, 9, 9}};  // appended to, never cleared
  const std::vector<std::uint32_t> stitched = {0, 1, 2, 3, 3, 4, 4, 5, 6};
  EXPECT_EQ(detail::append_run_triangles(stitched.data(), stitched.size(), TriangleRun::strip, out), 4u);
  EXPECT_EQ(out, (std::vector<Tri>{{9, 9, 9}, {0, 1, 2}, {2, 1, 3}, {4, 5, 6}}));

  out.clear();
  EXPECT_EQ(detail::append_run_triangles(strip.data(), 2, TriangleRun::strip, out), 0u);
  EXPECT_TRUE(out.empty());
}

TEST(MeshIoPly, StripsRestartWithTheirWindingAndUnsignedMarkers) {
  // -1 restarts a strip (the winding starts afresh), as does the maximum of an unsigned index type.
  const std::string head =
      "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\n"
      "element tristrips 1\nproperty list int ";
  const std::string vertices = "end_header\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n2 1 0\n";
  const std::vector<Tri> expected = {{0, 1, 2}, {2, 1, 3}, {1, 2, 3}, {3, 2, 4}};
  const RawMesh signed_strip = read_mesh(head + "int vertex_indices\n" + vertices + "9 0 1 2 3 -1 1 2 3 4\n", MeshFormat::ply);
  EXPECT_EQ(signed_strip.triangles, expected);
  EXPECT_EQ(signed_strip.source_faces, 4u);
  const RawMesh unsigned_strip =
      read_mesh(head + "uchar vertex_indices\n" + vertices + "9 0 1 2 3 255 1 2 3 4\n", MeshFormat::ply);
  EXPECT_EQ(unsigned_strip.triangles, expected);

  const RawMesh stitched = read_mesh(head + "int vertex_indices\n" + vertices + "6 0 1 2 2 3 4\n", MeshFormat::ply);
  EXPECT_EQ(stitched.triangles, (std::vector<Tri>{{0, 1, 2}, {3, 2, 4}}));
  EXPECT_EQ(stitched.warnings,
            (std::vector<std::string>{"PLY triangle strips contain 2 degenerate stitching triangles, which were skipped."}));
  EXPECT_THROW_EXACT(read_mesh(head + "int vertex_indices\n" + vertices + "4 0 1 2 -2\n", MeshFormat::ply), MeshFormatError,
                     "PLY triangle strip 1 (line 15) refers to vertex index -2 but the file has only 5 vertices (indices start at 0).");
}

// ---- glTF / GLB ---------------------------------------------------------------------------

TEST(MeshIoGltf, BoxAndDracoBoxAgree) {
  LOAD_SHARED(box, "Box.glb");
  LOAD_SHARED(draco_box, "Box_Draco.glb");
  const RawMesh a = read_mesh(box, MeshFormat::glb);
  const RawMesh b = read_mesh(draco_box, MeshFormat::glb);
  const auto sorted = [](std::vector<Vec> v) {
    std::sort(v.begin(), v.end());
    return v;
  };
  ASSERT_EQ(a.positions.size(), 8u);
  EXPECT_EQ(sorted(a.positions), sorted(b.positions));
  for (const auto& p : a.positions) {
    for (double c : p) EXPECT_EQ(std::fabs(c), 0.5);
  }
}

TEST(MeshIoGltf, InstancesTransformsAndDataUri) {
  const std::string bin = quad_buffer({0, 1, 2});
  // Two instances of mesh 0: translated, and scaled by a column-major matrix.
  const std::string json = gltf_json(
      bin, 3,
      one_triangle_mesh +
          R"(,"nodes":[{"mesh":0,"translation":[10,0,0]},{"mesh":0,"matrix":[2,0,0,0,0,2,0,0,0,0,2,0,0,0,0,1]}],"scenes":[{"nodes":[0,1]}])");
  const RawMesh mesh = read_mesh(json, MeshFormat::gltf);
  ASSERT_EQ(mesh.positions.size(), 8u);  // 4 records per instance, none shared
  EXPECT_EQ(mesh.positions[0], (Vec{10, 0, 0}));
  EXPECT_EQ(mesh.positions[1], (Vec{11, 0, 0}));
  EXPECT_EQ(mesh.positions[2], (Vec{10, 1, 0}));
  EXPECT_EQ(mesh.positions[4], (Vec{0, 0, 0}));
  EXPECT_EQ(mesh.positions[5], (Vec{2, 0, 0}));
  EXPECT_EQ(mesh.positions[6], (Vec{0, 2, 0}));
  EXPECT_EQ(mesh.triangles, (std::vector<Tri>{{0, 1, 2}, {4, 5, 6}}));
  EXPECT_TRUE(mesh.welded);

  // The same as GLB with the buffer in the BIN chunk.
  const std::string glb_json = gltf_json(
      bin, 3,
      one_triangle_mesh +
          R"(,"nodes":[{"mesh":0,"translation":[10,0,0]},{"mesh":0,"matrix":[2,0,0,0,0,2,0,0,0,0,2,0,0,0,0,1]}],"scenes":[{"nodes":[0,1]}])",
      "glb");
  const RawMesh from_glb = read_mesh(make_glb(glb_json, bin), MeshFormat::glb);
  EXPECT_EQ(from_glb.positions, mesh.positions);
  EXPECT_EQ(from_glb.triangles, mesh.triangles);
}

TEST(MeshIoGltf, HierarchyRotationMirrorAndNoScene) {
  const std::string bin = quad_buffer({0, 1, 2});
  // Parent translation then child rotation of 90 degrees about z: (1,0,0) -> (0,1,0) -> +(0,0,5).
  const double s = std::sqrt(0.5);
  const RawMesh h = read_mesh(
      gltf_json(bin, 3,
                one_triangle_mesh + R"(,"nodes":[{"translation":[0,0,5],"children":[1]},{"mesh":0,"rotation":[0,0,)" +
                    std::to_string(s) + "," + std::to_string(s) + R"(]}],"scenes":[{"nodes":[0]}],"scene":0)"),
      MeshFormat::gltf);
  ASSERT_EQ(h.positions.size(), 4u);
  EXPECT_NEAR(h.positions[1][0], 0.0, 1e-6);
  EXPECT_NEAR(h.positions[1][1], 1.0, 1e-6);
  EXPECT_EQ(h.positions[1][2], 5.0);

  // A mirrored instance keeps the outward winding by flipping its triangles.
  const RawMesh m = read_mesh(
      gltf_json(bin, 3, one_triangle_mesh + R"(,"nodes":[{"mesh":0,"scale":[-1,1,1]}],"scenes":[{"nodes":[0]}])"),
      MeshFormat::gltf);
  EXPECT_EQ(m.positions[1], (Vec{-1, 0, 0}));
  EXPECT_EQ(m.triangles, (std::vector<Tri>{{0, 2, 1}}));

  // No scene at all: every mesh once, untransformed (nodes are ignored).
  const RawMesh n = read_mesh(gltf_json(bin, 3, one_triangle_mesh + R"(,"nodes":[{"mesh":0,"translation":[5,5,5]}])"),
                              MeshFormat::gltf);
  EXPECT_EQ(n.positions[1], (Vec{1, 0, 0}));
  EXPECT_EQ(n.triangles.size(), 1u);

  // A cycle in the node graph is an error, not an endless loop.
  EXPECT_THROW_EXACT(read_mesh(gltf_json(bin, 3,
                                         one_triangle_mesh + R"(,"nodes":[{"mesh":0,"children":[1]},{"children":[0]}],"scenes":[{"nodes":[0]}])"),
                               MeshFormat::gltf),
                     MeshFormatError, "glTF node 0 is reached twice; the node hierarchy is not a tree.");
}

TEST(MeshIoGltf, PrimitiveModes) {
  const std::string bin = quad_buffer({0, 1, 2, 3});
  const auto with_mode = [&](int mode) {
    return gltf_json(bin, 4, R"("meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1,"mode":)" + std::to_string(mode) + "}]}]");
  };
  EXPECT_EQ(read_mesh(with_mode(5), MeshFormat::gltf).triangles, (std::vector<Tri>{{0, 1, 2}, {2, 1, 3}}));
  EXPECT_EQ(read_mesh(with_mode(6), MeshFormat::gltf).triangles, (std::vector<Tri>{{0, 1, 2}, {0, 2, 3}}));
  const RawMesh four = read_mesh(with_mode(4), MeshFormat::gltf);
  EXPECT_EQ(four.triangles, (std::vector<Tri>{{0, 1, 2}}));
  ASSERT_EQ(four.warnings.size(), 1u);
  EXPECT_EQ(four.warnings[0],
            "glTF file has triangle index lists whose length is not a multiple of 3; 1 trailing indices were ignored.");

  // Lines are skipped with a warning next to a triangle primitive.
  const std::string mixed = gltf_json(
      bin, 4,
      R"("meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1,"mode":1},{"attributes":{"POSITION":0},"indices":1,"mode":6}]}])");
  const RawMesh m = read_mesh(mixed, MeshFormat::gltf);
  EXPECT_EQ(m.triangles.size(), 2u);
  ASSERT_EQ(m.warnings.size(), 1u);
  EXPECT_EQ(m.warnings[0], "glTF file has 1 point or line primitives, which were skipped.");
  EXPECT_THROW_EXACT(read_mesh(with_mode(1), MeshFormat::gltf), MeshFormatError, "glTF file contains no triangles.");
}

TEST(MeshIoGltf, ExternalBufferUrisAreNeverRead) {
  TempDir dir;
  const std::string bin = quad_buffer({0, 1, 2});
  const std::string secret = dir.write("secret.bin", bin);
  OpenWatch watch(secret);
  ASSERT_TRUE(watch.ok());
  const std::string expected =
      "glTF file refers to an external file for a buffer, which is never read (only embedded data and data: URIs are allowed; "
      "upload the .gltf together with the files it names).";
  for (const std::string& uri : {secret, "file://" + secret, std::string("/etc/passwd"), std::string("file:///etc/passwd"),
                                std::string("../../../../etc/passwd"), std::string("secret.bin")}) {
    SCOPED_TRACE(uri);
    const std::string json = gltf_json(bin, 3, one_triangle_mesh, uri);
    EXPECT_THROW_EXACT(read_mesh(json, MeshFormat::gltf), MeshFormatError, expected);
    // Also from a file next to the buffer, where a relative URI would resolve.
    EXPECT_THROW_EXACT(read_mesh_file(dir.write("scene.gltf", json)), MeshFormatError, expected);
  }
  EXPECT_FALSE(watch.touched()) << "the glTF reader opened an external buffer file";
  EXPECT_TRUE(watch.notices_a_real_open());
}

// A .gltf uploaded with its .bin files: packed into one GLB whose geometry is the document's.
TEST(MeshIoGltf, AGltfAndItsBinFilesPackIntoOneGlb) {
  const std::string bin = quad_buffer({0, 1, 2});
  const std::string embedded = gltf_json(bin, 3, one_triangle_mesh);
  const RawMesh expected = read_mesh(embedded, MeshFormat::gltf);
  const std::string external = gltf_json(bin, 3, one_triangle_mesh, "scene%20data.bin");
  const std::string packed = pack_gltf_files(external, {{"texture.png", "not needed"}, {"scene data.bin", bin}});
  ASSERT_EQ(packed.substr(0, 4), "glTF");
  const RawMesh mesh = read_mesh(packed, MeshFormat::glb);
  EXPECT_EQ(mesh.positions, expected.positions);
  EXPECT_EQ(mesh.triangles, expected.triangles);

  // A data: buffer before the file's: the file's becomes buffer 0 (the GLB's binary chunk), the
  // data: one buffer 1, and the views follow.
  std::string mixed = external;
  mixed.replace(mixed.find(R"("buffers":[{)"), 12,
                R"("buffers":[{"uri":"data:application/octet-stream;base64,)" + base64("unused") + R"(","byteLength":6},{)");
  for (std::size_t at; (at = mixed.find(R"("buffer":0)")) != std::string::npos;) mixed.replace(at, 10, R"("buffer":1)");
  const RawMesh from_mixed = read_mesh(pack_gltf_files(mixed, {{"scene data.bin", bin}}), MeshFormat::glb);
  EXPECT_EQ(from_mixed.positions, expected.positions);
  EXPECT_EQ(from_mixed.triangles, expected.triangles);

  EXPECT_THROW_EXACT(pack_gltf_files(external, {{"other.bin", bin}}), MeshFormatError,
                     "glTF file's buffer 0 is in \"scene data.bin\", which was not uploaded with it (send the .gltf and its "
                     ".bin files together).");
  EXPECT_EQ(pack_gltf_files(embedded, {{"scene data.bin", bin}}), embedded) << "nothing to pack: the document as it is";
  EXPECT_THROW(pack_gltf_files("{\"buffers\": [", {}), MeshFormatError);
}

TEST(MeshIoGltf, HostileAccessorsAndViews) {
  const std::string bin = quad_buffer({0, 1, 2});
  std::string json = gltf_json(bin, 3, one_triangle_mesh);
  // Accessor 0 claims 1000 positions in a 48-byte bufferView.
  std::string glb_json = gltf_json(bin, 3, one_triangle_mesh, "glb");
  glb_json.replace(glb_json.find("\"count\":4"), 9, "\"count\":1000");
  EXPECT_THROW_EXACT(read_mesh(make_glb(glb_json, bin), MeshFormat::glb), MeshFormatError,
                     "GLB mesh 0 primitive 0 POSITION: accessor 0 (1000 elements of 12 bytes, stride 12, offset 0) points "
                     "past the end of its bufferView (48 bytes).");

  std::string no_view = json;
  const std::string view_member = "\"bufferView\":0,\"componentType\":5126";
  no_view.replace(no_view.find(view_member), view_member.size(), "\"componentType\":5126");
  EXPECT_THROW_EXACT(read_mesh(no_view, MeshFormat::gltf), MeshFormatError,
                     "glTF mesh 0 primitive 0 POSITION: accessor 0 has no bufferView (all-zero data is not usable geometry).");

  std::string view_past_end = json;
  view_past_end.replace(view_past_end.find("\"byteLength\":48"), 15, "\"byteLength\":4800");
  EXPECT_THROW_MSG(read_mesh(view_past_end, MeshFormat::gltf), MeshFormatError, "extends past the end of buffer 0");

  EXPECT_THROW_EXACT(read_mesh(gltf_json(quad_buffer({0, 1, 7}), 3, one_triangle_mesh), MeshFormat::gltf), MeshFormatError,
                     "glTF mesh 0 primitive 0 index 2 refers to vertex 7 but the primitive has only 4 vertices.");

  std::string nan_bin = bin;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(&nan_bin[16], &nan, 4);  // vertex 1, y
  EXPECT_THROW_EXACT(read_mesh(gltf_json(nan_bin, 3, one_triangle_mesh), MeshFormat::gltf), MeshFormatError,
                     "glTF mesh 0 primitive 0 vertex 1 has a non-finite coordinate.");

  EXPECT_THROW_EXACT(read_mesh(gltf_json(bin, 3, R"("meshes":[{"primitives":[{"attributes":{"POSITION":9}}]}])"), MeshFormat::gltf),
                     MeshFormatError, "glTF mesh 0 primitive 0 POSITION refers to accessor 9, which does not exist.");
  EXPECT_THROW_MSG(read_mesh("{\"asset\":{\"version\":\"2.0\"},\"meshes\":[{]}", MeshFormat::gltf), MeshFormatError,
                   "glTF file could not be parsed: ");
  EXPECT_THROW_EXACT(read_mesh(std::string(1000, '[') + std::string(1000, ']'), MeshFormat::gltf), MeshFormatError,
                     "glTF JSON nests deeper than 256 levels.");
  EXPECT_THROW_MSG(read_mesh("{\"asset\":{\"version\":\"2.0\"}}", MeshFormat::gltf), MeshFormatError, "glTF file contains no triangles");

  // GLB container lies.
  std::string glb = make_glb(gltf_json(bin, 3, one_triangle_mesh), "");
  std::string long_claim = glb;
  long_claim[8] = '\xff';
  long_claim[9] = '\xff';
  EXPECT_THROW_MSG(read_mesh(long_claim, MeshFormat::glb), MeshFormatError, "GLB header claims");
  EXPECT_THROW_EXACT(read_mesh("glTF", MeshFormat::glb), MeshFormatError, "GLB file has only 4 bytes, less than a GLB header.");
}

TEST(MeshIoGltf, TinygltfSymbolsResolveToLibtinygltf) {
  // libdraco.so exports an incompatible copy of tinygltf; the link order must put TinyGLTF first.
  void* symbol = dlsym(RTLD_DEFAULT, "_ZN8tinygltf8TinyGLTF20LoadBinaryFromMemoryEPNS_5ModelEPNSt7__cxx1112basic_stringIcSt11"
                                     "char_traitsIcESaIcEEES9_PKhjRKS8_j");
  ASSERT_NE(symbol, nullptr);
  Dl_info info{};
  ASSERT_NE(dladdr(symbol, &info), 0);
  ASSERT_NE(info.dli_fname, nullptr);
  EXPECT_NE(std::string(info.dli_fname).find("libtinygltf"), std::string::npos) << "tinygltf resolves to " << info.dli_fname;
}

// ---- Draco --------------------------------------------------------------------------------

TEST(MeshIoDraco, BunnyAndBadStreams) {
  LOAD_SHARED(bytes, "bunny_gltf.drc");
  const RawMesh mesh = read_mesh(bytes, MeshFormat::drc);
  EXPECT_EQ(mesh.triangles.size(), 69451u);
  EXPECT_EQ(mesh.positions.size(), 34834u);
  EXPECT_THROW_MSG(read_mesh(std::string_view(bytes).substr(0, bytes.size() / 2), MeshFormat::drc), MeshFormatError,
                   "Draco file could not be decoded by Draco");
  EXPECT_THROW_MSG(read_mesh("DRACO garbage garbage", MeshFormat::drc), MeshFormatError, "Draco file is not a valid Draco bitstream");
  EXPECT_THROW_MSG(read_mesh("hello", MeshFormat::drc), MeshFormatError, "Draco file is not a valid Draco bitstream");
}

// A .drc of an n x n grid (2 n^2 triangles) by draco::Encoder with the given method.
std::string encode_draco_grid(int n, draco::MeshEncoderMethod method, bool with_metadata) {
  draco::TriangleSoupMeshBuilder builder;
  builder.Start(2 * n * n);
  const int position = builder.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32);
  int face = 0;
  auto corner = [](int i, int j) { return draco::Vector3f(float(i), float(j), float((i * j) % 3)); };
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      builder.SetAttributeValuesForFace(position, draco::FaceIndex(face++), corner(i, j).data(), corner(i + 1, j).data(),
                                        corner(i + 1, j + 1).data());
      builder.SetAttributeValuesForFace(position, draco::FaceIndex(face++), corner(i, j).data(), corner(i + 1, j + 1).data(),
                                        corner(i, j + 1).data());
    }
  std::unique_ptr<draco::Mesh> mesh = builder.Finalize();
  if (with_metadata) {
    auto metadata = std::make_unique<draco::GeometryMetadata>();
    metadata->AddEntryString("name", "grid");
    auto child = std::make_unique<draco::Metadata>();
    child->AddEntryInt("level", 2);
    metadata->AddSubMetadata("detail", std::move(child));
    mesh->AddMetadata(std::move(metadata));
  }
  draco::Encoder encoder;
  encoder.SetEncodingMethod(method);
  draco::EncoderBuffer out;
  if (!encoder.EncodeMeshToBuffer(*mesh, &out).ok()) return {};
  return std::string(out.data(), out.size());
}

TEST(MeshIoDraco, DeclaredCountsMatchWhatIsDecoded) {
  for (const auto method : {draco::MESH_SEQUENTIAL_ENCODING, draco::MESH_EDGEBREAKER_ENCODING})
    for (const bool metadata : {false, true}) {
      SCOPED_TRACE(std::to_string(int(method)) + (metadata ? " with metadata" : ""));
      const std::string drc = encode_draco_grid(20, method, metadata);
      ASSERT_FALSE(drc.empty());
      const auto declared = detail::read_draco_declared_counts(reinterpret_cast<const unsigned char*>(drc.data()), drc.size(), "t");
      const RawMesh mesh = read_mesh(drc, MeshFormat::drc);
      EXPECT_EQ(declared.faces, 800u);
      EXPECT_EQ(mesh.triangles.size(), 800u);
      EXPECT_EQ(declared.vertices, 441u);
      EXPECT_EQ(mesh.positions.size(), 441u);
    }
}

// A Draco header declaring `faces` and `points` (sequential encoding), then junk.
std::string forged_draco(std::uint32_t faces, std::uint32_t points) {
  std::string bytes = "DRACO";
  bytes += {2, 2, 1, 0, 0, 0};
  for (std::uint32_t v : {faces, points}) {
    do {
      bytes += char((v & 0x7F) | (v > 0x7F ? 0x80 : 0));
      v >>= 7;
    } while (v != 0);
  }
  bytes += std::string(64, '\x01');
  return bytes;
}

TEST(MeshIoDraco, HugeDeclaredCountsAreRefusedBeforeDecoding) {
  const ReadMeshOptions server = read_limits_for(std::size_t(256) << 20, std::size_t(1) << 30);
  EXPECT_THROW_MSG(read_mesh(forged_draco(33'554'432, 100), MeshFormat::drc, server), LimitExceededError,
                   "Draco mesh has more than 7895160 triangles, the configured limit.");
  // Within the triangle limit, but 7 M faces and 3.5 M points could never be kept in 1 GiB.
  EXPECT_THROW_MSG(read_mesh(forged_draco(7'000'000, 3'500'000), MeshFormat::drc, server), LimitExceededError,
                   "Draco file declares 7000000 faces and 3500000 vertices, which need more than 1281 MiB prepared");
  // A header cut short, and an older bitstream version.
  EXPECT_THROW_MSG(read_mesh(forged_draco(5, 5).substr(0, 12), MeshFormat::drc), MeshFormatError, "Draco file ends inside its header.");
  std::string old = forged_draco(5, 5);
  old[6] = 1;
  EXPECT_THROW_MSG(read_mesh(old, MeshFormat::drc), MeshFormatError, "only version 2.2");
}

// ---- limits, files, empty input -----------------------------------------------------------

TEST(MeshIoLimits, VertexTriangleAndByteLimits) {
  LOAD_SHARED(cube, "cube.obj");
  ReadMeshOptions options;
  options.max_vertices = 25;
  EXPECT_THROW_EXACT(read_mesh(cube, MeshFormat::obj, options), LimitExceededError,
                     "OBJ mesh has more than 25 vertices, the configured limit.");
  options = {};
  options.max_triangles = 47;
  EXPECT_THROW_EXACT(read_mesh(cube, MeshFormat::obj, options), LimitExceededError,
                     "OBJ mesh has more than 47 triangles, the configured limit.");
  options = {};
  options.max_triangles = 48;
  EXPECT_EQ(read_mesh(cube, MeshFormat::obj, options).triangles.size(), 48u);

  LOAD_SHARED(off, "chamfer-cube.off");
  options = {};
  options.max_vertices = 10;
  EXPECT_THROW_EXACT(read_mesh(off, MeshFormat::off, options), LimitExceededError,
                     "OFF mesh has more than 10 vertices, the configured limit.");
  LOAD_SHARED(ply, "igea.ply");
  options = {};
  options.max_triangles = 1000;
  EXPECT_THROW_EXACT(read_mesh(ply, MeshFormat::ply, options), LimitExceededError,
                     "PLY mesh has more than 1000 triangles, the configured limit.");
  LOAD_SHARED(box, "Box.glb");
  options = {};
  options.max_triangles = 11;
  EXPECT_THROW_EXACT(read_mesh(box, MeshFormat::glb, options), LimitExceededError,
                     "GLB mesh has more than 11 triangles, the configured limit.");
  LOAD_SHARED(drc, "bunny_gltf.drc");
  options = {};
  options.max_vertices = 1000;
  EXPECT_THROW_EXACT(read_mesh(drc, MeshFormat::drc, options), LimitExceededError,
                     "Draco mesh has more than 1000 vertices, the configured limit.");
  options = {};
  options.max_triangles = 1;
  EXPECT_THROW_EXACT(read_mesh(make_binary_stl({{0, 0, 0, 1, 0, 0, 0, 1, 0}, {1, 0, 0, 1, 1, 0, 0, 1, 0}}), MeshFormat::stl, options),
                     LimitExceededError, "STL mesh has more than 1 triangles, the configured limit.");

  options = {};
  options.max_file_bytes = 100;
  const std::string path = mesh_path("cube.obj");
  EXPECT_THROW_EXACT(read_mesh_file(path, options), LimitExceededError,
                     "Mesh file '" + path + "' has " + std::to_string(cube.size()) + " bytes, more than the limit of 100 bytes.");
}

TEST(MeshIoFiles, PathsExtensionsAndSniffing) {
  TempDir dir;
  const std::string missing = (dir.path / "nope.obj").string();
  EXPECT_THROW_EXACT(read_mesh_file(missing), MeshFormatError, "Cannot open mesh file '" + missing + "': it does not exist.");
  EXPECT_THROW_EXACT(read_mesh_file(dir.path.string()), MeshFormatError,
                     "Cannot open mesh file '" + dir.path.string() + "': it is not a regular file.");
  LOAD_SHARED(cube, "cube.obj");
  EXPECT_EQ(read_mesh_file(dir.write("cube.mesh", cube)).triangles.size(), 48u);  // sniffed
  EXPECT_EQ(read_mesh_file(dir.write("CUBE.OBJ", cube)).format, MeshFormat::obj);
  const std::string unknown = dir.write("data.bin", "hello world\n");
  EXPECT_THROW_EXACT(read_mesh_file(unknown), UnsupportedFormatError,
                     "Cannot tell the format of mesh file '" + unknown +
                         "' from its extension or content (supported: obj, off, ply, stl, gltf, glb, drc).");
}

TEST(MeshIoEmpty, EveryFormatRejectsEmptyInput) {
  for (MeshFormat f : {MeshFormat::obj, MeshFormat::off, MeshFormat::ply, MeshFormat::stl, MeshFormat::gltf, MeshFormat::glb,
                       MeshFormat::drc}) {
    SCOPED_TRACE(to_string(f));
    std::string expected = "OBJ input is empty.";
    switch (f) {
      case MeshFormat::obj: expected = "OBJ input is empty."; break;
      case MeshFormat::off: expected = "OFF input is empty."; break;
      case MeshFormat::ply: expected = "PLY input is empty."; break;
      case MeshFormat::stl: expected = "STL input is empty."; break;
      case MeshFormat::gltf: expected = "glTF input is empty."; break;
      case MeshFormat::glb: expected = "GLB input is empty."; break;
      case MeshFormat::drc: expected = "Draco input is empty."; break;
    }
    EXPECT_THROW_EXACT(read_mesh("", f), MeshFormatError, expected);
  }
}

// ---- concurrency --------------------------------------------------------------------------

TEST(MeshIoConcurrency, ParallelReadsGiveIdenticalResults) {
  const std::vector<std::pair<std::string, MeshFormat>> files = {
      {"armadillo_29k.obj", MeshFormat::obj}, {"dragon_25k.off", MeshFormat::off}, {"bun_zipper.ply", MeshFormat::ply},
      {"fandisk.off", MeshFormat::off},       {"igea.ply", MeshFormat::ply}};
  std::vector<std::string> bytes(files.size());
  std::vector<RawMesh> reference(files.size());
  for (std::size_t i = 0; i < files.size(); ++i) {
    ASSERT_NO_FATAL_FAILURE(load_shared(files[i].first, bytes[i]));
    reference[i] = read_mesh(bytes[i], files[i].second);
  }
  constexpr int threads = 8;
  std::atomic<int> mismatches{0}, failures{0};
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) {
    pool.emplace_back([&, t] {
      for (int round = 0; round < 2; ++round) {
        for (std::size_t k = 0; k < files.size(); ++k) {
          const std::size_t i = (k + std::size_t(t)) % files.size();
          try {
            const RawMesh m = read_mesh(bytes[i], files[i].second);
            if (m.positions != reference[i].positions || m.triangles != reference[i].triangles) ++mismatches;
          } catch (...) {
            ++failures;
          }
        }
      }
    });
  }
  for (auto& th : pool) th.join();
  EXPECT_EQ(mismatches.load(), 0);
  EXPECT_EQ(failures.load(), 0);
}

// ---- fuzz ---------------------------------------------------------------------------------

/// Reads `bytes`; returns false (and records a failure) for anything but success or an engine error.
bool survives(std::string_view bytes, MeshFormat format, std::size_t seed, std::size_t& loaded, std::size_t& rejected) {
  ReadMeshOptions options;
  options.max_vertices = 1'000'000;
  options.max_triangles = 2'000'000;
  try {
    (void)read_mesh(bytes, format, options);
    ++loaded;
  } catch (const Error&) {
    ++rejected;
  } catch (const std::exception& e) {
    ADD_FAILURE() << to_string(format) << " seed " << seed << ": non-engine exception: " << e.what();
    return false;
  }
  return true;
}

TEST(MeshIoFuzz, RandomBytesAndMutationsNeverCrash) {
  std::string draco_box, box, obj, off, ply_bin;
  ASSERT_NO_FATAL_FAILURE(load_shared("Box_Draco.glb", draco_box));
  ASSERT_NO_FATAL_FAILURE(load_shared("Box.glb", box));
  ASSERT_NO_FATAL_FAILURE(load_shared("cube.obj", obj));
  ASSERT_NO_FATAL_FAILURE(load_shared("chamfer-cube.off", off));
  // The Draco payload of Box_Draco.glb (bufferView 0: the first 152 bytes of its BIN chunk) is a .drc stream.
  std::uint32_t json_length = 0;
  std::memcpy(&json_length, draco_box.data() + 12, 4);
  const std::string drc = draco_box.substr(20 + json_length + 8, 152);
  ASSERT_EQ(drc.substr(0, 5), "DRACO");
  ASSERT_EQ(read_mesh(drc, MeshFormat::drc).triangles.size(), 12u);

  ply_bin =
      "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 2\nproperty list uchar int vertex_indices\nend_header\n";
  for (float v : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f, 1.f, 1.f, 0.f}) put_f32(ply_bin, v);
  for (int f = 0; f < 2; ++f) {
    ply_bin += '\x03';
    for (int i : {f, f + 1, f + 2}) put_u32(ply_bin, static_cast<std::uint32_t>(i));
  }
  const std::string ply_ascii =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  const std::string stl_ascii =
      "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n";
  const std::string bin = quad_buffer({0, 1, 2});
  const std::string gltf = gltf_json(bin, 3, one_triangle_mesh + R"(,"nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}])");

  const std::vector<std::pair<MeshFormat, std::string>> seeds = {
      {MeshFormat::obj, obj},
      {MeshFormat::off, off},
      {MeshFormat::ply, ply_bin},
      {MeshFormat::ply, ply_ascii},
      {MeshFormat::stl, make_binary_stl({{0, 0, 0, 1, 0, 0, 0, 1, 0}, {1, 0, 0, 1, 1, 0, 0, 1, 0}})},
      {MeshFormat::stl, stl_ascii},
      {MeshFormat::gltf, gltf},
      {MeshFormat::glb, box},
      {MeshFormat::glb, draco_box},
      {MeshFormat::drc, drc},
  };
  // Every seed must itself be valid, so mutations start from something meaningful.
  for (const auto& [format, sample] : seeds) ASSERT_NO_THROW(read_mesh(sample, format)) << to_string(format);

  const char* env_rounds = std::getenv("FEATURELINE_FUZZ_ROUNDS");  // more rounds for a manual soak
  const std::size_t rounds = env_rounds ? std::strtoul(env_rounds, nullptr, 10) : 120;
  std::mt19937_64 rng(20240611);
  std::size_t runs = 0, loaded = 0, rejected = 0;
  for (const auto& [format, sample] : seeds) {
    for (std::size_t seed = 0; seed < rounds; ++seed, ++runs) {
      std::string input;
      const auto pick = rng() % 4;
      if (pick == 0) {
        // Pure random bytes, sometimes behind the format's magic.
        input.resize(rng() % 512);
        for (auto& c : input) c = static_cast<char>(rng());
        if (rng() % 2) input = sample.substr(0, std::min<std::size_t>(sample.size(), 1 + rng() % 16)) + input;
      } else if (pick == 1) {
        input = sample.substr(0, rng() % (sample.size() + 1));  // truncation
      } else {
        input = sample;
        const int flips = 1 + int(rng() % 8);
        for (int f = 0; f < flips && !input.empty(); ++f) {
          const std::size_t at = rng() % input.size();
          switch (rng() % 3) {
            case 0: input[at] = static_cast<char>(rng()); break;
            case 1: input[at] = "0123456789-.e \n/#"[rng() % 17]; break;
            default: input.insert(at, 1 + rng() % 4, static_cast<char>(rng())); break;
          }
        }
      }
      if (!survives(input, format, seed, loaded, rejected)) return;
    }
  }
  EXPECT_EQ(runs, rounds * seeds.size());
  // Both outcomes occur: the mutations are neither all harmless nor all fatal (a flipped byte of
  // a binary coordinate often lands above the 1e15 coordinate bound, so fewer load than fail).
  EXPECT_GT(loaded, runs / 40);
  EXPECT_GT(rejected, runs / 4);
}

}  // namespace
}  // namespace featureline
