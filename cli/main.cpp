// featureline: detect feature lines and describe meshes from the command line.
// Errors: exit status 1 (usage: 2) and one line on stderr.
#include <algorithm>
#include <chrono>
#include <cstring>
#include <fstream>
#include <functional>
#include <iostream>
#include <string>
#include <vector>

#include "api/feature_line_json.h"
#include "api/gltf_export.h"
#include "api/options_table.h"
#include "api/requests.h"
#include "api/segmentation_json.h"
#include "engine/errors.h"
#include "engine/feature_line.h"
#include "engine/mesh_io.h"
#include "engine/segmentation.h"

namespace {

using featureline::InvalidInputError;
using nlohmann::json;

// The fixed part of the help; the option flags are listed from the option tables (usage()).
const char* const kUsage = R"(usage:
  featureline detect MESH --keys 10,20,30 [options]
  featureline segment MESH --loop 1,2,3,4 [--loop 5,6,7] [--line 8,9] [segment options] [options]
  featureline info MESH [curvature options]
  featureline options      every option with its type, default, limits and description (JSON)

detect:
  --keys LIST             comma-separated key vertex ids (0-based, file order)
  --closed                join the last key to the first (a loop)
  --weights A,B,G,D       marching weights alpha,beta,gamma,delta (paper: 1,1,1,2)
  --options JSON          any options as a JSON object (see `featureline options`); flags win
  --out FILE              write FILE.json or FILE.glb instead of printing JSON

segment (the detect options apply to every line):
  --loop LIST             keys of a closed line (repeatable)
  --line LIST             keys of an open line ending on the boundary or another line (repeatable)
  --out FILE              parts.glb (one primitive per part) or labels.json

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

std::size_t parse_count(const std::string& text, const char* flag) {
  const double v = parse_number(text, flag);
  if (!(v >= 1 && v <= 4e9) || v != double(std::size_t(v))) throw UsageError(std::string(flag) + " expects an integer from 1 to 4000000000");
  return std::size_t(v);
}

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// "a, b or c": the accepted names of a choice flag.
std::string either(const std::vector<std::string>& names) {
  std::string text;
  for (std::size_t i = 0; i < names.size(); ++i) text += (i == 0 ? "" : i + 1 == names.size() ? " or " : ", ") + names[i];
  return text;
}

std::string value_text(const json& value) {
  if (value.is_string()) return value.get<std::string>();
  if (value.is_number()) return featureline::format_number(value.get<double>());
  return value.dump();
}

// The help lines of one option table's flags.
template <typename Options>
std::string flag_help(const featureline::OptionTable<Options>& table) {
  using featureline::OptionKind;
  std::string text;
  for (const auto& field : table) {
    const auto& spec = field.spec;
    if (spec.cli_flag.empty()) continue;
    std::string flag = spec.cli_flag + (spec.kind == OptionKind::choice ? " M" : spec.kind == OptionKind::boolean ? "" : " N");
    flag.resize(std::max<std::size_t>(flag.size() + 1, 24), ' ');
    std::string detail = "default " + value_text(spec.default_value);
    if (spec.kind == OptionKind::choice) detail = either(spec.choices) + "; " + detail;
    if (spec.kind == OptionKind::number || spec.kind == OptionKind::integer)
      detail = featureline::format_number(spec.minimum) + " to " + featureline::format_number(spec.maximum) + "; " + detail;
    if (spec.kind == OptionKind::boolean)
      text += "  " + flag + spec.name + " = " + value_text(!spec.default_value.template get<bool>()) + ": " + spec.description + "\n";
    else
      text += "  " + flag + spec.description + " (" + detail + ")\n";
  }
  return text;
}

std::string usage() {
  return std::string(kUsage) + "\ndetect options:\n" + flag_help(featureline::feature_line_option_table()) +
         "\nsegment options:\n" + flag_help(featureline::segmentation_option_table()) +
         "\ncurvature options (every command):\n" + flag_help(featureline::curvature_option_table());
}

// Sets the option of `table` whose CLI flag is `flag` into `out` (nested like the JSON options);
// false when the table has no such flag. A boolean flag sets the opposite of the default.
template <typename Options>
bool table_flag(const featureline::OptionTable<Options>& table, const std::string& flag,
                const std::function<std::string()>& value, json& out) {
  for (const auto& field : table) {
    const auto& spec = field.spec;
    if (spec.cli_flag != flag) continue;
    json given;
    if (spec.kind == featureline::OptionKind::boolean) {
      given = !spec.default_value.template get<bool>();
    } else if (spec.kind == featureline::OptionKind::choice) {
      given = value();
      if (std::find(spec.choices.begin(), spec.choices.end(), given.get<std::string>()) == spec.choices.end())
        throw UsageError(flag + " must be " + either(spec.choices));
    } else {
      given = parse_number(value(), flag.c_str());
    }
    out[json::json_pointer("/" + featureline::dotted_to_pointer(spec.name))] = featureline::check_option_value(spec, given, flag);
    return true;
  }
  return false;
}

// What the command line asks for.
struct CommandLine {
  std::string command, mesh_path, keys_text, out_path;
  bool closed = false;
  json line_options = json::object();          // from --options
  json line_flags = json::object();            // from flags (they win over --options)
  json segmentation_flags = json::object();
  json curvature_flags = json::object();
  std::vector<std::pair<std::string, bool>> segment_lines;  // keys, closed
  featureline::ReadMeshOptions read_options;
};

json parse_options_flag(const std::string& text) {
  json given;
  try {
    given = json::parse(text);
  } catch (const json::parse_error& e) {
    throw UsageError(std::string("--options is not valid JSON: ") + e.what());
  }
  if (!given.is_object()) throw UsageError("--options must be a JSON object");
  return given;
}

CommandLine parse_command_line(int argc, char** argv) {
  CommandLine cl;
  if (argc >= 2 && std::string(argv[1]) == "options") {
    cl.command = "options";
    return cl;
  }
  if (argc < 3) throw UsageError("expected a command and a mesh");
  cl.command = argv[1];
  if (cl.command != "detect" && cl.command != "info" && cl.command != "segment")
    throw UsageError("unknown command \"" + cl.command + "\"");
  cl.mesh_path = argv[2];
  // The server's default limits (--max-upload-mb 256, --cache-mb 1024): a mesh the server would
  // refuse is refused here too, before a small glTF file can expand into gigabytes.
  cl.read_options = featureline::read_limits_for(std::size_t(256) << 20, std::size_t(1) << 30);
  cl.read_options.max_file_bytes = featureline::ReadMeshOptions{}.max_file_bytes;
  for (int i = 3; i < argc; ++i) {
    const std::string flag = argv[i];
    const std::function<std::string()> value = [&]() -> std::string {
      if (i + 1 >= argc) throw UsageError(flag + " needs a value");
      return argv[++i];
    };
    if (flag == "--keys") cl.keys_text = value();
    else if (flag == "--loop") cl.segment_lines.emplace_back(value(), true);
    else if (flag == "--line") cl.segment_lines.emplace_back(value(), false);
    else if (flag == "--closed") cl.closed = true;
    else if (flag == "--weights") {
      const auto w = parse_numbers(value(), 4, "--weights");
      cl.line_flags["weights"] = {{"alpha", w[0]}, {"beta", w[1]}, {"gamma", w[2]}, {"delta", w[3]}};
    } else if (flag == "--options") cl.line_options = parse_options_flag(value());
    else if (flag == "--out") cl.out_path = value();
    else if (flag == "--max-triangles") cl.read_options.max_triangles = parse_count(value(), "--max-triangles");
    else if (flag == "--max-vertices") cl.read_options.max_vertices = parse_count(value(), "--max-vertices");
    else if (flag == "-h" || flag == "--help") throw UsageError("");
    else if (!table_flag(featureline::feature_line_option_table(), flag, value, cl.line_flags) &&
             !table_flag(featureline::segmentation_option_table(), flag, value, cl.segmentation_flags) &&
             !table_flag(featureline::curvature_option_table(), flag, value, cl.curvature_flags))
      throw UsageError("unknown option \"" + flag + "\"");
  }
  return cl;
}

// Writes `text` to `path`, whose extension must be .json or .glb (`glb` / `json_text` make each).
void write_output(const std::string& path, const std::function<std::string()>& glb, const std::function<std::string()>& json_text) {
  std::string content;
  if (ends_with(path, ".glb")) content = glb();
  else if (ends_with(path, ".json")) content = json_text() + "\n";
  else throw UsageError("--out must end in .json or .glb");
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error("cannot write " + path);
  out << content;
  if (!out) throw std::runtime_error("failed writing " + path);
}

featureline::FeatureLineRequest line_request(const CommandLine& cl, const std::string& keys, bool closed) {
  featureline::FeatureLineRequest request;
  request.keys = featureline::parse_key_list(keys);
  request.closed = closed;
  json options = cl.line_options;
  options.merge_patch(cl.line_flags);  // flags win
  featureline::apply_options_json(options, request.options);
  return request;
}

int segment(const CommandLine& cl, const featureline::PreparedMesh& mesh) {
  if (cl.segment_lines.empty()) throw UsageError("segment needs at least one --loop or --line");
  featureline::SegmentationOptions options;
  featureline::apply_options(featureline::segmentation_option_table(), cl.segmentation_flags, "", options);
  std::vector<featureline::FeatureLineResult> lines;
  for (const auto& [keys, is_closed] : cl.segment_lines)
    lines.push_back(featureline::detect_feature_line(mesh, line_request(cl, keys, is_closed)));
  const auto parts = featureline::segment_mesh(mesh, lines, options);
  const auto parts_json = [&] { return featureline::segmentation_to_json(parts, options.mode).dump(2); };
  if (cl.out_path.empty()) std::cout << parts_json() << "\n";
  else write_output(cl.out_path, [&] { return featureline::segmentation_to_glb(mesh, parts); }, parts_json);
  return 0;
}

int detect(const CommandLine& cl, const featureline::PreparedMesh& mesh) {
  if (cl.keys_text.empty()) throw UsageError("detect needs --keys");
  const auto result = featureline::detect_feature_line(mesh, line_request(cl, cl.keys_text, cl.closed));
  const auto line_json = [&] { return featureline::feature_line_to_json(result).dump(2); };
  if (cl.out_path.empty()) std::cout << line_json() << "\n";
  else write_output(cl.out_path, [&] { return featureline::feature_line_to_glb(mesh, {result}, /*include_mesh=*/true); }, line_json);
  return 0;
}

int run(int argc, char** argv) {
  const CommandLine cl = parse_command_line(argc, argv);
  if (cl.command == "options") {
    std::cout << featureline::describe_api_options().dump(2) << "\n";
    return 0;
  }
  featureline::PrepareOptions prepare_options;
  featureline::apply_options(featureline::curvature_option_table(), cl.curvature_flags, "", prepare_options.curvature);
  const auto load_start = std::chrono::steady_clock::now();
  featureline::RawMesh raw = featureline::read_mesh_file(cl.mesh_path, cl.read_options);
  const double load_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - load_start).count();
  const auto mesh = featureline::prepare_mesh(std::move(raw), prepare_options);
  if (cl.command == "info") {
    std::cout << featureline::mesh_info_to_json(*mesh, load_ms).dump(2) << "\n";
    return 0;
  }
  return cl.command == "segment" ? segment(cl, *mesh) : detect(cl, *mesh);
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const UsageError& e) {
    if (std::strlen(e.what()) > 0) std::cerr << "featureline: " << e.what() << "\n";
    std::cerr << usage();
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "featureline: " << e.what() << "\n";
    return 1;
  }
}
