// STL, binary and ASCII. STL has no shared vertex ids, so corners are welded by exact position
// (first occurrence order); facets with coinciding corners are kept (prepare_mesh reports them),
// where OpenMesh's reader drops them.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "engine/errors.h"
#include "engine/io/byte_order.h"
#include "engine/io/reader_support.h"
#include "engine/io/readers.h"

namespace featureline::detail {

namespace {

RawMesh read_stl_binary(std::string_view bytes, const ReadMeshOptions& options) {
  RawMesh mesh;
  mesh.format = MeshFormat::stl;
  mesh.welded = true;
  const std::uint32_t count = load_little_endian<std::uint32_t>(bytes.data() + 80);
  const std::uint64_t needed = 84 + 50 * std::uint64_t(count);
  if (needed > bytes.size()) {
    throw MeshFormatError("Binary STL header claims " + std::to_string(count) + " triangles (" +
                          std::to_string(needed) + " bytes) but the file has only " + std::to_string(bytes.size()) +
                          " bytes.");
  }
  if (needed < bytes.size()) {
    mesh.warnings.push_back("Binary STL has " + std::to_string(bytes.size() - needed) + " bytes after its " +
                            std::to_string(count) + " triangles; they were ignored.");
  }
  check_triangle_limit(MeshFormat::stl, count, options);
  mesh.triangles.reserve(count);
  PositionWelder welder(mesh.positions);
  for (std::uint32_t t = 0; t < count; ++t) {
    const char* record = bytes.data() + 84 + 50 * std::size_t(t);
    std::array<std::uint32_t, 3> triangle{};
    for (int corner = 0; corner < 3; ++corner) {
      std::array<double, 3> p{};
      for (int c = 0; c < 3; ++c) {
        p[c] = load_little_endian<float>(record + 12 + 12 * corner + 4 * c);
        if (!std::isfinite(p[c])) {
          throw MeshFormatError("Binary STL triangle " + std::to_string(t + 1) + " has a non-finite coordinate at corner " +
                                std::to_string(corner + 1) + ".");
        }
      }
      triangle[corner] = welder.add(p);
    }
    mesh.triangles.push_back(triangle);
    if (welder.size() > options.max_vertices) check_vertex_limit(MeshFormat::stl, welder.size(), options);
  }
  mesh.source_faces = count;
  return mesh;
}

RawMesh read_stl_ascii(std::string_view bytes, const ReadMeshOptions& options) {
  RawMesh mesh;
  mesh.format = MeshFormat::stl;
  mesh.welded = true;
  PositionWelder welder(mesh.positions);
  TokenScanner tokens(bytes);
  bool in_facet = false;
  std::size_t facet_line = 0;
  std::vector<std::uint32_t> corners;
  const auto where = [&] { return "ASCII STL line " + std::to_string(tokens.line()); };
  while (const auto token = tokens.next()) {
    if (*token == "solid" || *token == "endsolid") {
      if (in_facet) throw MeshFormatError(where() + ": '" + std::string(*token) + "' inside a facet.");
      tokens.skip_line();  // the solid's name
    } else if (*token == "facet") {
      if (in_facet) throw MeshFormatError(where() + ": a facet starts before the previous one ended.");
      in_facet = true;
      facet_line = tokens.line();
      corners.clear();
      tokens.skip_line();  // "normal nx ny nz": not needed
    } else if (*token == "outer" || *token == "loop" || *token == "endloop") {
      if (!in_facet) throw MeshFormatError(where() + ": " + quote_token(*token) + " outside a facet.");
    } else if (*token == "vertex") {
      if (!in_facet) throw MeshFormatError(where() + ": a vertex outside a facet.");
      std::array<double, 3> p{};
      for (int c = 0; c < 3; ++c) {
        const auto value = tokens.next();
        const NumberStatus status = value ? parse_real(*value, p[c]) : NumberStatus::not_a_number;
        if (status == NumberStatus::non_finite) {
          throw MeshFormatError(where() + ": vertex of facet " + std::to_string(mesh.triangles.size() + 1) +
                                " has a non-finite coordinate " + quote_token(*value) + ".");
        }
        if (status != NumberStatus::ok) {
          throw MeshFormatError(where() + ": vertex of facet " + std::to_string(mesh.triangles.size() + 1) +
                                " needs 3 numeric coordinates.");
        }
      }
      corners.push_back(welder.add(p));
      if (welder.size() > options.max_vertices) check_vertex_limit(MeshFormat::stl, welder.size(), options);
    } else if (*token == "endfacet") {
      if (!in_facet) throw MeshFormatError(where() + ": 'endfacet' without a facet.");
      if (corners.size() != 3) {
        throw MeshFormatError("ASCII STL facet " + std::to_string(mesh.triangles.size() + 1) + " (line " +
                              std::to_string(facet_line) + ") has " + std::to_string(corners.size()) +
                              " vertices; STL facets are triangles.");
      }
      check_triangle_limit(MeshFormat::stl, mesh.triangles.size() + 1, options);
      mesh.triangles.push_back({corners[0], corners[1], corners[2]});
      in_facet = false;
    } else {
      throw MeshFormatError(where() + ": unexpected " + quote_token(*token) + ".");
    }
  }
  if (in_facet) throw MeshFormatError("ASCII STL ends inside a facet (started on line " + std::to_string(facet_line) + ").");
  mesh.source_faces = mesh.triangles.size();
  return mesh;
}

}  // namespace

RawMesh read_stl(std::string_view bytes, const ReadMeshOptions& options) {
  // Binary when the size matches the triangle count exactly (some binary files start with
  // "solid" too); ASCII when it starts with "solid"; otherwise binary with a checked header.
  if (bytes.size() >= 84 && 84 + 50 * std::uint64_t(load_little_endian<std::uint32_t>(bytes.data() + 80)) == bytes.size()) {
    return read_stl_binary(bytes, options);
  }
  // ASCII only when the start reads as text: binary files may also begin with "solid".
  const std::string_view head = bytes.substr(0, 1024);
  const std::string_view text = trim(head);
  const bool textual = std::none_of(head.begin(), head.end(), [](char c) {
    const auto u = static_cast<unsigned char>(c);
    return u < 0x20 && !is_space(c);
  });
  if (textual && starts_with(text, "solid") && (text.size() == 5 || is_space(text[5]))) return read_stl_ascii(bytes, options);
  if (bytes.size() < 84) {
    throw MeshFormatError("STL file has only " + std::to_string(bytes.size()) +
                          " bytes: too short for a binary STL header (84 bytes) and it does not start with 'solid'.");
  }
  return read_stl_binary(bytes, options);
}

}  // namespace featureline::detail
