// featureline: detect feature lines and describe meshes from the command line.
// Errors: exit status 1 (usage: 2) and one line on stderr.
#include <chrono>
#include <cstring>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "api/feature_line_json.h"
#include "api/gltf_export.h"
#include "api/segmentation_json.h"
#include "engine/errors.h"
#include "engine/feature_line.h"
#include "engine/mesh_io.h"
#include "engine/segmentation.h"

namespace {

using featureline::InvalidInputError;
using nlohmann::json;

const char* const kUsage = R"(usage:
  featureline detect MESH --keys 10,20,30 [options]
  featureline segment MESH --loop 1,2,3,4 [--loop 5,6,7] [--line 8,9] [--mode snap|remesh] [options]
  featureline info MESH [--curvature M] [--curvature-radius R] [--crease-angle A] [--smooth-curvature N]

segment options:
  --loop LIST             keys of a closed line (repeatable)
  --line LIST             keys of an open line ending on the boundary or another line (repeatable)
  --mode M                snap (default: cut along mesh edges) | remesh (cut along the smooth line)
  --out FILE              parts.glb (one primitive per part) or labels.json
  (the detect options below apply to every line)

detect options:
  --keys LIST             comma-separated key vertex ids (0-based, file order)
  --closed                join the last key to the first (a loop)
  --initial METHOD        marching | feature-path (default) | geodesic
  --weights A,B,G,D       marching weights alpha,beta,gamma,delta (paper: 1,1,1,2)
  --curvature-term T      marching f_C: similar-to-end (default) | similar-to-current | high-magnitude
  --no-fallback           fail instead of falling back when marching fails
  --rings K               strip rings (0 = automatic: 2 to 8 by the line's length)
  --flattening F          automatic (default) | conformal | similar-triangles (the paper's Fig. 5)
  --alpha A --beta B      snake elasticity and rigidity
  --tau T --kappa K       snake time step and feature-force weight
  --iterations N          snake iteration cap
  --spacing S             snake point spacing, in mean edge lengths
  --force F               smooth (default) | paper
  --free-keys             interior keys may move with the snake
  --no-refine             stop after the initial line
  --curvature M           jet (default: fitted over a radius that follows the noise) | cotangent (the paper)
  --curvature-radius R    jet radius in local edge lengths (0 = automatic, up to 12)
  --crease-angle A        dihedral angle in degrees above which an edge is a crease (0 = automatic, -1 = none)
  --smooth-curvature N    Laplacian passes over the curvature field (-1: automatic, the default)
  --options JSON          any options as a JSON object (see api/openapi.yaml); flags win
  --out FILE              write FILE.json or FILE.glb instead of printing JSON

reading limits (every command):
  --max-triangles N       refuse meshes that expand to more triangles (glTF: over all node
                          instances and primitives); default 8388608, the server's default
  --max-vertices N        the same for vertex records; default 8388608
)";

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

std::vector<double> parse_numbers(const std::string& text, std::size_t count, const char* flag) {
  std::vector<double> values;
  std::size_t pos = 0;
  while (pos <= text.size()) {
    const std::size_t comma = std::min(text.find(',', pos), text.size());
    try {
      std::size_t used = 0;
      const std::string item = text.substr(pos, comma - pos);
      values.push_back(std::stod(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw UsageError(std::string(flag) + " expects " + std::to_string(count) + " comma-separated numbers");
    }
    pos = comma + 1;
  }
  if (values.size() != count)
    throw UsageError(std::string(flag) + " expects " + std::to_string(count) + " comma-separated numbers");
  return values;
}

double parse_number(const std::string& text, const char* flag) { return parse_numbers(text, 1, flag)[0]; }

int parse_int(const std::string& text, const char* flag) {
  const double v = parse_number(text, flag);
  if (v != double(int(v))) throw UsageError(std::string(flag) + " expects an integer");
  return int(v);
}

std::size_t parse_count(const std::string& text, const char* flag) {
  const double v = parse_number(text, flag);
  if (!(v >= 1 && v <= 4e9) || v != double(std::size_t(v))) throw UsageError(std::string(flag) + " expects an integer from 1 to 4000000000");
  return std::size_t(v);
}

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

int run(int argc, char** argv) {
  if (argc < 3) throw UsageError("expected a command and a mesh");
  const std::string command = argv[1];
  if (command != "detect" && command != "info" && command != "segment")
    throw UsageError("unknown command \"" + command + "\"");
  const std::string mesh_path = argv[2];

  json options = json::object();
  json snake = json::object();
  std::string keys_text, out_path;
  bool closed = false;
  featureline::PrepareOptions prepare_options;
  std::vector<std::pair<std::string, bool>> segment_lines;  // keys, closed
  std::string mode_text = "snap";
  // The server's default limits (--max-upload-mb 256, --cache-mb 1024): a mesh the server would
  // refuse is refused here too, before a small glTF file can expand into gigabytes.
  featureline::ReadMeshOptions read_options = featureline::read_limits_for(std::size_t(256) << 20, std::size_t(1) << 30);
  read_options.max_file_bytes = featureline::ReadMeshOptions{}.max_file_bytes;
  for (int i = 3; i < argc; ++i) {
    const std::string flag = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw UsageError(flag + " needs a value");
      return argv[++i];
    };
    if (flag == "--keys") keys_text = value();
    else if (flag == "--loop") segment_lines.emplace_back(value(), true);
    else if (flag == "--line") segment_lines.emplace_back(value(), false);
    else if (flag == "--mode") mode_text = value();
    else if (flag == "--closed") closed = true;
    else if (flag == "--initial") options["initial"] = value();
    else if (flag == "--weights") {
      const auto w = parse_numbers(value(), 4, "--weights");
      options["weights"] = {{"alpha", w[0]}, {"beta", w[1]}, {"gamma", w[2]}, {"delta", w[3]}};
    } else if (flag == "--curvature-term") options["curvature_term"] = value();
    else if (flag == "--no-fallback") options["fallback"] = false;
    else if (flag == "--rings") options["rings"] = parse_int(value(), "--rings");
    else if (flag == "--flattening") options["flattening"] = value();
    else if (flag == "--alpha") snake["alpha"] = parse_number(value(), "--alpha");
    else if (flag == "--beta") snake["beta"] = parse_number(value(), "--beta");
    else if (flag == "--tau") snake["tau"] = parse_number(value(), "--tau");
    else if (flag == "--kappa") snake["kappa"] = parse_number(value(), "--kappa");
    else if (flag == "--iterations") snake["iterations"] = parse_int(value(), "--iterations");
    else if (flag == "--spacing") snake["spacing"] = parse_number(value(), "--spacing");
    else if (flag == "--force") snake["force"] = value();
    else if (flag == "--free-keys") options["pin_interior_keys"] = false;
    else if (flag == "--no-refine") options["refine"] = false;
    else if (flag == "--smooth-curvature") prepare_options.curvature.smoothing_passes = parse_int(value(), "--smooth-curvature");
    else if (flag == "--curvature") {
      const auto method = featureline::parse_curvature_method(value());
      if (!method) throw UsageError("--curvature must be jet or cotangent");
      prepare_options.curvature.method = *method;
    } else if (flag == "--curvature-radius") prepare_options.curvature.radius = parse_number(value(), "--curvature-radius");
    else if (flag == "--crease-angle") prepare_options.curvature.crease_angle = parse_number(value(), "--crease-angle");
    else if (flag == "--options") {
      json given;
      try {
        given = json::parse(value());
      } catch (const json::parse_error& e) {
        throw UsageError(std::string("--options is not valid JSON: ") + e.what());
      }
      if (!given.is_object()) throw UsageError("--options must be a JSON object");
      for (auto it = given.begin(); it != given.end(); ++it)
        if (!options.contains(it.key())) options[it.key()] = it.value();
    } else if (flag == "--out") out_path = value();
    else if (flag == "--max-triangles") read_options.max_triangles = parse_count(value(), "--max-triangles");
    else if (flag == "--max-vertices") read_options.max_vertices = parse_count(value(), "--max-vertices");
    else if (flag == "-h" || flag == "--help") throw UsageError("");
    else throw UsageError("unknown option \"" + flag + "\"");
  }
  if (!snake.empty()) {
    if (!options.contains("snake")) options["snake"] = json::object();
    if (!options["snake"].is_object()) throw UsageError("--options: \"snake\" must be a JSON object");
    options["snake"].update(snake);  // flags win over --options
  }

  const auto load_start = std::chrono::steady_clock::now();
  featureline::RawMesh raw = featureline::read_mesh_file(mesh_path, read_options);
  const double load_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - load_start).count();
  const auto mesh = featureline::prepare_mesh(std::move(raw), prepare_options);

  if (command == "info") {
    std::cout << featureline::mesh_info_to_json(*mesh, load_ms).dump(2) << "\n";
    return 0;
  }
  if (command == "segment") {
    if (segment_lines.empty()) throw UsageError("segment needs at least one --loop or --line");
    const auto mode = featureline::parse_segmentation_mode(mode_text);
    if (!mode) throw UsageError("--mode must be snap or remesh");
    std::vector<featureline::FeatureLineResult> lines;
    for (const auto& [keys, is_closed] : segment_lines) {
      featureline::FeatureLineRequest request;
      request.keys = featureline::parse_key_list(keys);
      request.closed = is_closed;
      featureline::apply_options_json(options, request.options);
      lines.push_back(featureline::detect_feature_line(*mesh, request));
    }
    featureline::SegmentationOptions segmentation_options;
    segmentation_options.mode = *mode;
    const auto parts = featureline::segment_mesh(*mesh, lines, segmentation_options);
    if (out_path.empty()) {
      std::cout << featureline::segmentation_to_json(parts, *mode).dump(2) << "\n";
      return 0;
    }
    std::ofstream out(out_path, std::ios::binary);
    if (!out) throw std::runtime_error("cannot write " + out_path);
    if (ends_with(out_path, ".glb")) out << featureline::segmentation_to_glb(*mesh, parts);
    else if (ends_with(out_path, ".json")) out << featureline::segmentation_to_json(parts, *mode).dump(2) << "\n";
    else throw UsageError("--out must end in .json or .glb");
    if (!out) throw std::runtime_error("failed writing " + out_path);
    return 0;
  }
  if (keys_text.empty()) throw UsageError("detect needs --keys");
  featureline::FeatureLineRequest request;
  request.keys = featureline::parse_key_list(keys_text);
  request.closed = closed;
  featureline::apply_options_json(options, request.options);
  const auto result = featureline::detect_feature_line(*mesh, request);

  if (out_path.empty()) {
    std::cout << featureline::feature_line_to_json(result).dump(2) << "\n";
    return 0;
  }
  std::ofstream out(out_path, std::ios::binary);
  if (!out) throw std::runtime_error("cannot write " + out_path);
  if (ends_with(out_path, ".glb")) {
    out << featureline::feature_line_to_glb(*mesh, {result}, /*include_mesh=*/true);
  } else if (ends_with(out_path, ".json")) {
    out << featureline::feature_line_to_json(result).dump(2) << "\n";
  } else {
    throw UsageError("--out must end in .json or .glb");
  }
  if (!out) throw std::runtime_error("failed writing " + out_path);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const UsageError& e) {
    if (std::strlen(e.what()) > 0) std::cerr << "featureline: " << e.what() << "\n";
    std::cerr << kUsage;
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "featureline: " << e.what() << "\n";
    return 1;
  }
}
