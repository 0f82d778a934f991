// featureline: detect feature lines, segment and describe meshes from the command line.
// Requests are the HTTP API's JSON bodies (built from flags, or read with --request), so a
// script moves between the two without translation. Exit status: 0 done, 1 the input was
// refused (one line on stderr), 2 a usage error (one line and a pointer to --help).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cerrno>
#include <fstream>
#include <functional>
#include <iostream>
#include <iterator>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "api/export_formats.h"
#include "api/feature_line_json.h"
#include "api/feature_seeds_json.h"
#include "api/gltf_export.h"
#include "api/json_budget.h"
#include "api/options_table.h"
#include "api/requests.h"
#include "api/segmentation_json.h"
#include "engine/errors.h"
#include "engine/feature_line.h"
#include "engine/feature_seeds.h"
#include "engine/mesh_io.h"
#include "engine/segmentation.h"
#include "featureline_version.h"

namespace {

using featureline::InvalidInputError;
using nlohmann::json;

// ---- what the command line asks for ----------------------------------------------------------

struct Inputs {
  std::vector<std::string> meshes;  // "-" is standard input
  std::string format;               // of standard input (else from the extension or content)
  featureline::ReadMeshOptions limits;
  json curvature = json::object();  // curvature table flags
  bool keep_orientation = false;
};

struct LineFlags {
  std::string keys, points, request_path, out_path, options_text;
  std::vector<double> weights;
  bool closed = false, trace = false;
  json options = json::object();       // feature-line table flags (they win over --options)
  json segmentation = json::object();  // segmentation table flags
  std::vector<std::string> loops, open_lines;
};

std::string either(const std::vector<std::string>& names) {
  std::string text;
  for (std::size_t i = 0; i < names.size(); ++i) text += (i == 0 ? "" : i + 1 == names.size() ? " or " : ", ") + names[i];
  return text;
}

double parse_number(const std::string& text, const std::string& flag) {
  std::size_t used = 0;
  double v = 0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size()) throw CLI::ValidationError(flag + " expects a number, not \"" + text + "\"");
  return v;
}

// The flags of one option table, each writing its value (checked by the table's row, so the
// limits and names are the HTTP API's) into `out`, nested as the JSON options are.
template <typename Options>
void add_table_flags(CLI::App& command, const featureline::OptionTable<Options>& table, json& out, const std::string& group) {
  using featureline::OptionKind;
  for (const auto& field : table) {
    const featureline::OptionSpec& spec = field.spec;
    if (spec.cli_flag.empty()) continue;
    const json::json_pointer at("/" + featureline::dotted_to_pointer(spec.name));
    const auto set = [&out, at, spec](const json& value) {
      try {
        out[at] = featureline::check_option_value(spec, value, spec.cli_flag);
      } catch (const InvalidInputError& e) {
        throw CLI::ValidationError(e.what());
      }
    };
    if (spec.kind == OptionKind::boolean) {
      const bool value = !spec.default_value.template get<bool>();
      command.add_flag_callback(spec.cli_flag, [set, value] { set(value); },
                                spec.description + " (sets " + spec.name + " to " + (value ? "true" : "false") + ")")
          ->group(group);
      continue;
    }
    std::string detail = "default " + spec.default_value.dump();
    if (spec.kind == OptionKind::choice) detail = either(spec.choices) + "; " + detail;
    else detail = featureline::format_number(spec.minimum) + " to " + featureline::format_number(spec.maximum) + "; " + detail;
    command
        .add_option_function<std::string>(
            spec.cli_flag,
            [set, spec](const std::string& text) {
              if (spec.kind != OptionKind::choice) return set(parse_number(text, spec.cli_flag));
              for (const auto* names : {&spec.choices, &spec.aliases})
                for (const auto& name : *names)
                  if (name == text) return set(text);
              throw CLI::ValidationError(spec.cli_flag + " must be " + either(spec.choices));
            },
            spec.description + " (" + detail + ")")
        ->type_name(spec.kind == OptionKind::choice ? "NAME" : "X")
        ->group(group);
  }
}

void add_inputs(CLI::App& command, Inputs& in, bool many) {
  auto* meshes = command.add_option("mesh", in.meshes, many ? "Mesh files (- for standard input); several give a JSON array"
                                                            : "Mesh file (- for standard input)")
                     ->required()
                     ->type_name("MESH");
  if (!many) meshes->expected(1);
  command.add_option("--format", in.format, "Format of standard input: " + featureline::supported_formats())->type_name("NAME");
  command.add_option("--max-triangles", in.limits.max_triangles,
                     "Refuse meshes that expand to more triangles (glTF: over all instances and primitives); the server's default")
      ->check(CLI::Range(std::size_t(1), std::size_t(4000000000)))
      ->capture_default_str()
      ->group("Reading limits");
  command.add_option("--max-vertices", in.limits.max_vertices, "The same for vertex records")
      ->check(CLI::Range(std::size_t(1), std::size_t(4000000000)))
      ->capture_default_str()
      ->group("Reading limits");
  add_table_flags(command, featureline::curvature_option_table(), in.curvature, "Curvature (how the mesh is prepared)");
  command.add_flag("--keep-orientation", in.keep_orientation,
                   "Keep the faces of closed parts that point inward as they are (by default they are turned outward, so convex edges read as ridges)")
      ->group("Curvature (how the mesh is prepared)");
}

void add_line_flags(CLI::App& command, LineFlags& f) {
  auto* keys = command.add_option("--keys", f.keys, "Key vertex ids, comma-separated (0-based, file order)")->type_name("LIST");
  auto* points = command.add_option("--points", f.points, "Key points \"x,y,z;x,y,z;...\" (each becomes the nearest vertex)")
                     ->type_name("LIST");
  auto* request = command.add_option("--request", f.request_path,
                                     "A request body of POST /v1/meshes/{id}/feature-lines (one line or {\"lines\": [...]}), "
                                     "FILE or - for standard input")
                      ->type_name("FILE");
  keys->excludes(points)->excludes(request);
  points->excludes(request);
  auto* closed = command.add_flag("--closed", f.closed, "Join the last key to the first (a loop)")->excludes(request);
  command.add_flag("--trace", f.trace, "One key: the line is the whole feature through it, traced both ways (closed when it closes)")
      ->excludes(request)
      ->excludes(closed);
  command.add_option("--weights", f.weights, "Marching weights alpha,beta,gamma,delta (paper: 1,1,1,2)")
      ->expected(4)
      ->delimiter(',')
      ->type_name("A,B,G,D");
  command.add_option("--options", f.options_text, "Options as a JSON object (see `featureline options`); flags win")
      ->type_name("JSON");
  add_table_flags(command, featureline::feature_line_option_table(), f.options, "Feature-line options");
}

// ---- reading ----------------------------------------------------------------------------------

std::string read_stream(std::istream& in, std::size_t limit, const std::string& what) {
  std::string bytes;
  char buffer[1 << 16];
  while (in.read(buffer, sizeof buffer) || in.gcount() > 0) {
    bytes.append(buffer, std::size_t(in.gcount()));
    if (bytes.size() > limit)
      throw featureline::LimitExceededError(what + " has more than " + std::to_string(limit) + " bytes");
  }
  return bytes;
}

featureline::MeshFile read_input_mesh(const std::string& path, const Inputs& in) {
  featureline::MeshFile file;
  std::optional<featureline::MeshFormat> format;
  if (!in.format.empty() && !(format = featureline::parse_mesh_format(in.format)))
    throw CLI::ValidationError("--format must be one of " + featureline::supported_formats());
  if (path != "-") {
    file = featureline::read_mesh_file_bytes(path, in.limits);
  } else {
    file.bytes = read_stream(std::cin, in.limits.max_file_bytes, "standard input");
    // Nothing to sniff is no format question: say what is wrong, as for an empty file.
    if (file.bytes.empty()) throw featureline::MeshFormatError("standard input is empty.");
    if (!format) format = featureline::sniff_mesh_format(file.bytes);
    if (!format) throw CLI::ValidationError("cannot tell the format of standard input: pass --format");
  }
  if (format) file.format = *format;
  return file;
}

std::shared_ptr<const featureline::PreparedMesh> prepare(const std::string& path, const Inputs& in, double& load_ms) {
  featureline::PrepareOptions options;
  featureline::apply_options(featureline::curvature_option_table(), in.curvature, "", options.curvature);
  options.orient_outward = !in.keep_orientation;
  const auto start = std::chrono::steady_clock::now();
  const featureline::MeshFile file = read_input_mesh(path, in);
  featureline::RawMesh raw = featureline::read_mesh(file.bytes, file.format, in.limits);
  load_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return featureline::prepare_mesh(std::move(raw), options);
}

json read_request_file(const std::string& path) {
  std::string text;
  if (path == "-") {
    text = read_stream(std::cin, featureline::RequestLimits::max_json_bytes, "the request");
  } else {
    std::ifstream file(path, std::ios::binary);
    if (!file) throw InvalidInputError("cannot open the request file '" + path + "'");
    text = read_stream(file, featureline::RequestLimits::max_json_bytes, "request file '" + path + "'");
  }
  try {
    return featureline::parse_json_within(text);
  } catch (const json::exception& e) {
    throw InvalidInputError("the request is not valid JSON: " + featureline::json_error_sentence(e));
  }
}

// ---- requests as the HTTP API's bodies ------------------------------------------------------

json split_list(const std::string& text, char separator, const std::function<json(const std::string&)>& item) {
  json list = json::array();
  std::size_t pos = 0;
  while (pos <= text.size()) {
    const std::size_t end = std::min(text.find(separator, pos), text.size());
    list.push_back(item(text.substr(pos, end - pos)));
    pos = end + 1;
  }
  return list;
}

json key_ids(const std::string& text) {
  json ids = json::array();
  for (const auto id : featureline::parse_key_list(text)) ids.push_back(id);
  return ids;
}

json key_points(const std::string& text) {
  return split_list(text, ';', [](const std::string& point) {
    const json xyz = split_list(point, ',', [](const std::string& x) { return json(parse_number(x, "--points")); });
    if (xyz.size() != 3) throw CLI::ValidationError("--points expects x,y,z triples separated by ';', not \"" + point + "\"");
    return json{{"point", xyz}};
  });
}

// Options under their current names, so the flags' (current names) merge over them: a flag
// replaces an option the JSON gave by an old name instead of giving it a second time.
json line_options_current(const json& options) {
  return featureline::with_current_names(featureline::feature_line_option_table(), options, "options");
}

// --options, then the flags over it.
json flag_options(const LineFlags& f) {
  json options = json::object();
  if (!f.options_text.empty()) {
    try {
      options = json::parse(f.options_text);
    } catch (const json::exception& e) {
      throw CLI::ValidationError("--options is not valid JSON: " + featureline::json_error_sentence(e));
    }
    if (!options.is_object()) throw CLI::ValidationError("--options must be a JSON object");
    options = line_options_current(options);
  }
  if (!f.weights.empty())
    options["initial"].update({{"marching_alpha", f.weights[0]}, {"marching_beta", f.weights[1]},
                               {"marching_gamma", f.weights[2]}, {"marching_delta", f.weights[3]}});
  options.merge_patch(f.options);
  return options;
}

// Each line of a body gets the command line's options over its own.
void merge_line_options(json& line, const json& options) {
  if (options.empty() || !line.is_object() || line.contains("refined")) return;
  json merged = line.value("options", json::object());
  if (merged.is_object()) merged = line_options_current(merged);
  merged.merge_patch(options);
  line["options"] = merged;
}

json feature_line_body(const LineFlags& f) {
  const json options = flag_options(f);
  if (!f.request_path.empty()) {
    json body = read_request_file(f.request_path);
    if (body.is_object() && body.contains("lines") && body["lines"].is_array())
      for (auto& line : body["lines"]) merge_line_options(line, options);
    else merge_line_options(body, options);
    return body;
  }
  if (f.keys.empty() && f.points.empty()) throw CLI::RequiredError("--keys, --points or --request");
  json line = {{"keys", f.keys.empty() ? key_points(f.points) : key_ids(f.keys)}};
  if (f.closed) line["closed"] = true;
  if (f.trace) line["trace"] = true;
  if (!options.empty()) line["options"] = options;
  return line;
}

json segmentation_body(const LineFlags& f) {
  const json options = flag_options(f);
  json body = f.request_path.empty() ? json::object() : read_request_file(f.request_path);
  if (!body.is_object()) throw InvalidInputError("the request must be a JSON object");
  if (f.request_path.empty()) {
    if (f.loops.empty() && f.open_lines.empty()) throw CLI::RequiredError("--loop, --line or --request");
    body["lines"] = json::array();
    for (const auto& keys : f.loops) body["lines"].push_back({{"keys", key_ids(keys)}, {"closed", true}});
    for (const auto& keys : f.open_lines) body["lines"].push_back({{"keys", key_ids(keys)}});
  }
  if (body.contains("lines") && body["lines"].is_array())
    for (auto& line : body["lines"]) merge_line_options(line, options);
  body.merge_patch(f.segmentation);
  return body;
}

// ---- output -------------------------------------------------------------------------------------

// A command's answer: its JSON, and what it holds for the other formats --out can ask for.
struct Answer {
  json body;
  std::optional<featureline::ExportContent> content;            // lines or a segmentation; none: JSON only
  std::function<std::string(featureline::ExportFormat)> file;  // the answer in a format the content allows
};

// Writes to --out (its ending picks the format: api/export_formats.h) or standard output (JSON).
void write_output(const std::string& path, const Answer& answer) {
  using featureline::ExportFormat;
  if (path.empty() || path == "-") {
    std::cout << answer.body.dump(2) << "\n";
    return;
  }
  const auto format = featureline::export_format_from_path(path);
  const std::string endings = answer.content ? featureline::export_format_extensions(*answer.content) : ".json";
  if (!format || (*format != ExportFormat::json && !(answer.content && featureline::can_export(*format, *answer.content))))
    throw CLI::ValidationError("--out must end in one of " + endings + " (or be - for standard output)");
  const std::string content = *format == ExportFormat::json ? answer.body.dump(2) + "\n" : answer.file(*format);
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error("cannot write " + path);
  out << content;
  if (!out) throw std::runtime_error("failed writing " + path);
}

Answer detect(const featureline::PreparedMesh& mesh, const LineFlags& f) {
  bool batch = false;
  const auto requests = featureline::parse_feature_line_body(feature_line_body(f), mesh, batch);
  std::vector<featureline::FeatureLineResult> results;
  for (const auto& request : requests) results.push_back(featureline::detect_feature_line(mesh, request));
  json answer;
  if (batch) {
    answer = {{"lines", json::array()}};
    for (const auto& r : results) answer["lines"].push_back(featureline::feature_line_to_json(r));
  } else {
    answer = featureline::feature_line_to_json(results[0]);
  }
  return {answer, featureline::ExportContent::lines, [&mesh, results](featureline::ExportFormat format) {
            if (format == featureline::ExportFormat::glb) return featureline::feature_line_to_glb(mesh, results, /*include_mesh=*/true);
            if (format == featureline::ExportFormat::gltf) return featureline::feature_line_to_gltf_json(mesh, results, true);
            return featureline::export_lines(results, format);
          }};
}

Answer segment(const featureline::PreparedMesh& mesh, const LineFlags& f) {
  auto request = featureline::parse_segmentation_request(segmentation_body(f), mesh);
  const auto options = request.options;
  std::vector<featureline::FeatureLineResult> detected;
  for (const auto& line : request.requests) detected.push_back(featureline::detect_feature_line(mesh, line));
  const auto lines = std::move(request).lines_with(std::move(detected));
  const auto parts = featureline::segment_mesh(mesh, lines, options);
  return {featureline::segmentation_to_json(parts, options.mode), featureline::ExportContent::segmentation,
          [&mesh, parts](featureline::ExportFormat format) {
            if (format == featureline::ExportFormat::glb) return featureline::segmentation_to_glb(mesh, parts);
            return featureline::export_segmentation(mesh, parts, format);
          }};
}

// Runs `command` on each mesh: one mesh prints its answer; several print a JSON array of
// {"mesh", "result" | "error"} and fail (exit 1) if any mesh did.
int for_each_mesh(const Inputs& in, const std::string& out_path,
                  const std::function<Answer(const featureline::PreparedMesh&, double load_ms)>& command) {
  if (in.meshes.size() == 1) {
    double load_ms = 0;
    const auto mesh = prepare(in.meshes[0], in, load_ms);
    const Answer answer = command(*mesh, load_ms);
    write_output(out_path, answer);
    return 0;
  }
  if (!out_path.empty() && out_path != "-") throw CLI::ValidationError("--out takes one mesh; several print a JSON array");
  if (std::count(in.meshes.begin(), in.meshes.end(), "-") > 0) throw CLI::ValidationError("- (standard input) takes one mesh");
  json all = json::array();
  int status = 0;
  for (const auto& path : in.meshes) {
    try {
      double load_ms = 0;
      const auto mesh = prepare(path, in, load_ms);
      all.push_back({{"mesh", path}, {"result", command(*mesh, load_ms).body}});
    } catch (const featureline::Error& e) {
      all.push_back({{"mesh", path}, {"error", e.what()}});
      status = 1;
    }
  }
  std::cout << all.dump(2) << "\n";
  return status;
}

// ---- the program --------------------------------------------------------------------------------

struct Program {
  CLI::App app{"featureline: smooth feature lines on triangle meshes (ridges, valleys, creases), from the command line",
               "featureline"};
  Inputs in;
  LineFlags line;
  std::function<int()> run;

  Program() {
    app.set_version_flag("--version", std::string("featureline ") + FEATURELINE_VERSION);
    app.require_subcommand(1);
    app.footer("Run 'featureline COMMAND --help' for a command's flags. Docs: docs/cli.md");
    // The server's default limits (--max-upload-mb 256, --cache-mb 1024): a mesh the server would
    // refuse is refused here too, before a small glTF file can expand into gigabytes.
    in.limits = featureline::read_limits_for(std::size_t(256) << 20, std::size_t(1) << 30);
    in.limits.max_file_bytes = featureline::ReadMeshOptions{}.max_file_bytes;
    add_detect();
    add_segment();
    add_info();
    add_features();
    auto* options = app.add_subcommand("options", "Every request option with its type, default, limits and description (JSON)");
    options->callback([this] {
      run = [] {
        std::cout << featureline::describe_api_options().dump(2) << "\n";
        return 0;
      };
    });
  }

  void add_detect() {
    auto* detect_command = app.add_subcommand("detect", "Detect a feature line through key vertices (or points)");
    add_inputs(*detect_command, in, true);
    add_line_flags(*detect_command, line);
    detect_command->add_option("--out", line.out_path, "Write the answer to FILE, in the format its ending names: .json, .glb or .gltf (lines and mesh), "
                                ".obj (l polylines), .ply (edges), .polylines.txt (CGAL), .csv (a row per point)")
        ->type_name("FILE");
    detect_command->callback([this] {
      run = [this] { return for_each_mesh(in, line.out_path, [this](const auto& mesh, double) { return detect(mesh, line); }); };
    });
  }

  void add_segment() {
    auto* segment_command = app.add_subcommand("segment", "Cut a mesh into parts along closed lines (and open lines between them)");
    add_inputs(*segment_command, in, false);
    auto* loops = segment_command->add_option("--loop", line.loops, "Keys of a closed line (repeatable)")->type_name("LIST");
    auto* open_lines =
        segment_command->add_option("--line", line.open_lines, "Keys of an open line ending on the boundary or another line (repeatable)")
            ->type_name("LIST");
    segment_command->add_option("--request", line.request_path,
                                "A request body of POST /v1/meshes/{id}/segmentation, FILE or - for standard input")
        ->type_name("FILE")
        ->excludes(loops)
        ->excludes(open_lines);
    segment_command->add_option("--weights", line.weights, "Marching weights of every line")->expected(4)->delimiter(',')->type_name("A,B,G,D");
    segment_command->add_option("--options", line.options_text, "Options of every line, as a JSON object")->type_name("JSON");
    add_table_flags(*segment_command, featureline::feature_line_option_table(), line.options, "Feature-line options (every line)");
    add_table_flags(*segment_command, featureline::segmentation_option_table(), line.segmentation, "Segmentation options");
    segment_command->add_option("--out", line.out_path, "Write the answer to FILE, in the format its ending names: .json (labels), .glb (one primitive per "
                                 "part), .ply (colour and label per face), .obj (a group per part)")->type_name("FILE");
    segment_command->callback([this] {
      run = [this] { return for_each_mesh(in, line.out_path, [this](const auto& mesh, double) { return segment(mesh, line); }); };
    });
  }

  json feature_seed_flags = json::object();
  void add_features() {
    auto* features = app.add_subcommand("features", "What to pick keys from: crease chains and the strongest ridge and valley vertices (JSON)");
    add_inputs(*features, in, true);
    add_table_flags(*features, featureline::feature_seed_option_table(), feature_seed_flags, "Feature options");
    features->callback([this] {
      run = [this] {
        featureline::FeatureSeedOptions options;
        featureline::apply_options(featureline::feature_seed_option_table(), feature_seed_flags, "", options);
        return for_each_mesh(in, "", [options](const auto& mesh, double) {
          return Answer{featureline::feature_seeds_to_json(mesh, featureline::find_feature_seeds(mesh, options)), {}, nullptr};
        });
      };
    });
  }

  void add_info() {
    auto* info = app.add_subcommand("info", "Describe meshes: counts, components, curvature, creases, timings");
    add_inputs(*info, in, true);
    info->callback([this] {
      run = [this] {
        return for_each_mesh(in, "", [](const auto& mesh, double load_ms) {
          return Answer{featureline::mesh_info_to_json(mesh, load_ms), {}, nullptr};
        });
      };
    });
  }
};

}  // namespace

int main(int argc, char** argv) {
  Program program;
  try {
    program.app.parse(argc, argv);
    const int status = program.run();
    // Standard output is buffered: a full disk shows only when it is flushed. A reader that
    // stopped reading (| head) is no error, as for a tool that SIGPIPE ends quietly.
    errno = 0;
    if (!std::cout.flush() && errno != EPIPE) throw std::runtime_error("failed writing standard output");
    return status;
  } catch (const CLI::Success& e) {
    return program.app.exit(e);  // --help, --version: standard output, exit 0
  } catch (const CLI::ParseError& e) {
    const auto given = program.app.get_subcommands();
    const std::string help = given.empty() ? "featureline --help" : "featureline " + given[0]->get_name() + " --help";
    std::string message = e.what();
    // A first word that is no command reads as a missing one to the parser: name it.
    if (given.empty() && argc > 1 && argv[1][0] != '-') {
      message = "no command \"" + std::string(argv[1]) + "\"; the commands are";
      for (const auto* command : program.app.get_subcommands([](CLI::App*) { return true; }))
        message += " " + command->get_name();
    }
    std::cerr << "featureline: " << message << "\nRun '" << help << "' for usage.\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "featureline: " << e.what() << "\n";
    return 1;
  }
}
