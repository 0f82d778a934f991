// The option tables (api/options_table.h): every field round-trips JSON -> options -> JSON,
// limits give exact errors, enum names come from one table, request parsing names the field,
// renamed options are still read under their old names (and printed only under the new ones),
// and the limits of options the engine checks are the engine's own ranges (engine/valid_range.h).
#include <algorithm>

#include <gtest/gtest.h>

#include "api/feature_line_json.h"
#include "api/options_table.h"
#include "api/requests.h"
#include "engine/errors.h"
#include "engine/segmentation.h"
#include "tests/support/synthetic_meshes.h"

namespace featureline {
namespace {

using nlohmann::json;

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InvalidInputError& e) {
    return e.what();
  }
  return "no error";
}

// A valid value different from the default (the other end of the range, another name, !bool).
json other_value(const OptionSpec& spec) {
  switch (spec.kind) {
    case OptionKind::boolean: return !spec.default_value.get<bool>();
    case OptionKind::choice:
      for (const auto& c : spec.choices)
        if (c != spec.default_value.get<std::string>()) return c;
      break;
    case OptionKind::integer: return spec.default_value.get<double>() == spec.maximum ? spec.minimum : spec.maximum;
    case OptionKind::number: return spec.default_value.get<double>() == spec.maximum ? spec.minimum : spec.maximum;
  }
  ADD_FAILURE() << spec.name << " has a single choice";
  return nullptr;
}

template <typename Options>
void expect_every_field_round_trips(const OptionTable<Options>& table) {
  const json defaults = options_json(table, Options{});
  for (const auto& field : table) {
    SCOPED_TRACE(field.spec.name);
    const json pointer_value = other_value(field.spec);
    json request = json::object();
    request[option_pointer(field.spec.name)] = pointer_value;
    Options options;
    apply_options(table, request, "options", options);
    json written = options_json(table, options);
    EXPECT_EQ(written[option_pointer(field.spec.name)], pointer_value);
    // Only that field changed.
    written[option_pointer(field.spec.name)] = field.spec.default_value;
    EXPECT_EQ(written, defaults);
    // And what was written reads back to the same options.
    Options again;
    apply_options(table, options_json(table, options), "options", again);
    EXPECT_EQ(options_json(table, again), options_json(table, options));
  }
}

TEST(OptionTable, EveryFieldRoundTripsThroughJson) {
  expect_every_field_round_trips(feature_line_option_table());
  expect_every_field_round_trips(segmentation_option_table());
  expect_every_field_round_trips(curvature_option_table());
}

TEST(OptionTable, DefaultsAreTheStructsDefaults) {
  const json d = options_to_json(FeatureLineOptions{});
  EXPECT_EQ(d["snake"]["max_iterations"], 300);  // FeatureLineOptions::snake.max_iterations: names are member paths
  EXPECT_EQ(d["snake"]["spacing"], 0.5);
  EXPECT_EQ(d["initial"]["method"], "feature-path");
  EXPECT_EQ(d["initial"]["marching_delta"], 2);
  EXPECT_EQ(d["strip"]["flattening"], "automatic");
  EXPECT_EQ(d["strip"]["dense_line_edges"], 12);
  EXPECT_EQ(options_json(segmentation_option_table(), SegmentationOptions{})["mode"], "snap");
  // Every default is within its own limits, so an untouched request always passes.
  for (const auto& field : feature_line_option_table())
    EXPECT_NO_THROW(check_option_value(field.spec, field.spec.default_value, field.spec.name)) << field.spec.name;
  EXPECT_NO_THROW(check_options(feature_line_option_table(), FeatureLineOptions{}, "options"));
}

TEST(OptionTable, ErrorsNameTheFieldAndItsLimits) {
  auto error = [](const char* text) {
    return error_of([&] {
      FeatureLineOptions o;
      apply_options_json(json::parse(text), o);
    });
  };
  EXPECT_EQ(error(R"({"snake": {"max_iterations": 100000}})"), "\"options.snake.max_iterations\" must be an integer from 0 to 500");
  EXPECT_EQ(error(R"({"snake": {"max_iterations": 2.5}})"), "\"options.snake.max_iterations\" must be an integer from 0 to 500");
  EXPECT_EQ(error(R"({"snake": {"spacing": 0.05}})"), "\"options.snake.spacing\" must be a number from 0.25 to 10");
  EXPECT_EQ(error(R"({"snake": {"tau": "fast"}})"), "\"options.snake.tau\" must be a number from 0.0001 to 1000");
  EXPECT_EQ(error(R"({"strip": {"rings": 99}})"), "\"options.strip.rings\" must be an integer from 0 to 8");
  EXPECT_EQ(error(R"({"refine": 1})"), "\"options.refine\" must be true or false");
  EXPECT_EQ(error(R"({"initial": {"method": "dijkstra"}})"),
            "\"options.initial.method\" must be one of marching, feature-path, geodesic, not \"dijkstra\"");
  EXPECT_EQ(error(R"({"snake": {"alpah": 1}})"), "unknown option \"options.snake.alpah\"");
  EXPECT_EQ(error(R"({"snake": 3})"), "\"options.snake\" must be a JSON object");
  EXPECT_EQ(error(R"({"initial": {"marching_alpha": -1}})"), "\"options.initial.marching_alpha\" must be a number from 0 to 1000");
  EXPECT_EQ(error(R"({"initial": {"max_edges": 0}})"), "\"options.initial.max_edges\" must be an integer from 1 to 1000");
  EXPECT_EQ(error("[1]"), "\"options\" must be a JSON object");
  // A request that once grew the snake without bound (../shared/data/regressions/snake_runaway_ridge20.request.json)
  // is refused at once instead of growing the snake for 51 s.
  EXPECT_EQ(error(R"({"snake": {"kappa": 1000}})"), "\"options.snake.kappa\" must be a number from 0 to 1");
  // JSON Schema counts 2.0 as an integer, so do we; the value is stored as the integer.
  FeatureLineOptions o;
  apply_options_json(json::parse(R"({"strip": {"rings": 2.0}, "initial": {"method": "feature_path"}})"), o);
  EXPECT_EQ(o.strip.rings, 2);
  EXPECT_EQ(o.initial.method, InitialMethod::feature_path);  // an accepted alias, never printed
  // Options built in code meet the same limits.
  o.snake.max_iterations = 100000;
  EXPECT_EQ(error_of([&] { check_options(feature_line_option_table(), o, "options"); }),
            "\"options.snake.max_iterations\" must be an integer from 0 to 500");
}

// ---- renamed options: old paths read for one release, never printed ------------------------------

// Every row's name and old names as JSON paths, so a request can name the row by any of them.
template <typename Options>
std::size_t expect_old_names_read_like_new(const OptionTable<Options>& table) {
  std::size_t old_names = 0;
  for (const auto& field : table) {
    for (const auto& old : field.spec.old_names) {
      SCOPED_TRACE(old + " -> " + field.spec.name);
      ++old_names;
      json by_old = json::object(), by_new = json::object();
      by_old[option_pointer(old)] = other_value(field.spec);
      by_new[option_pointer(field.spec.name)] = other_value(field.spec);
      Options read_old, read_new;
      apply_options(table, by_old, "options", read_old);
      apply_options(table, by_new, "options", read_new);
      EXPECT_EQ(options_json(table, read_old), options_json(table, read_new));
      EXPECT_NE(options_json(table, read_old), options_json(table, Options{}));
      EXPECT_EQ(with_current_names(table, by_old, "options"), by_new);
      // Both names in one request: refused, naming both (the old one first) and the one to keep.
      // An old leaf that is now the new name's group ("initial") cannot meet it in one object.
      if (field.spec.name.rfind(old + ".", 0) == 0) continue;
      json both = by_new;
      both[option_pointer(old)] = other_value(field.spec);
      Options twice;
      EXPECT_EQ(error_of([&] { apply_options(table, both, "options", twice); }),
                "\"options." + old + "\" and \"options." + field.spec.name + "\" name the same option: give only \"options." +
                    field.spec.name + "\"");
    }
  }
  return old_names;
}

TEST(OptionTable, OldNamesReadLikeTheNewOnes) {
  EXPECT_EQ(expect_old_names_read_like_new(feature_line_option_table()), 15u);
  EXPECT_EQ(expect_old_names_read_like_new(segmentation_option_table()), 0u);
  EXPECT_EQ(expect_old_names_read_like_new(curvature_option_table()), 0u);
  EXPECT_EQ(expect_old_names_read_like_new(feature_seed_option_table()), 0u);
}

// The paths of every leaf of a JSON object, joined by '.'.
void leaf_paths(const json& object, const std::string& prefix, std::vector<std::string>& out) {
  for (auto it = object.begin(); it != object.end(); ++it) {
    const std::string path = option_path(prefix, it.key());
    if (it.value().is_object()) leaf_paths(it.value(), path, out);
    else out.push_back(path);
  }
}

template <typename Options>
void expect_names_unambiguous_and_printed_new(const OptionTable<Options>& table) {
  std::vector<std::string> names, printed;
  for (const auto& field : table) {
    names.push_back(field.spec.name);
    names.insert(names.end(), field.spec.old_names.begin(), field.spec.old_names.end());
  }
  for (const auto& field : table) {
    const std::string& name = field.spec.name;
    EXPECT_EQ(std::count(names.begin(), names.end(), name), 1) << name << " names two rows";
    // A current name is a leaf: no name, current or old, lies below it.
    for (const auto& other : names) EXPECT_NE(other.rfind(name + ".", 0), 0u) << other << " lies below " << name;
    for (const auto& old : field.spec.old_names) EXPECT_EQ(std::count(names.begin(), names.end(), old), 1) << old;
  }
  // Effective options: exactly the current names, each once.
  leaf_paths(options_json(table, Options{}), "", printed);
  std::vector<std::string> current;
  for (const auto& field : table) current.push_back(field.spec.name);
  std::sort(printed.begin(), printed.end());
  std::sort(current.begin(), current.end());
  EXPECT_EQ(printed, current);
}

TEST(OptionTable, NamesAreUnambiguousAndOnlyCurrentOnesArePrinted) {
  expect_names_unambiguous_and_printed_new(feature_line_option_table());
  expect_names_unambiguous_and_printed_new(segmentation_option_table());
  expect_names_unambiguous_and_printed_new(curvature_option_table());
  expect_names_unambiguous_and_printed_new(feature_seed_option_table());
  const json printed = options_to_json(FeatureLineOptions{});
  for (const char* old : {"weights", "rings", "curvature_term", "max_line_edges", "flattening"}) EXPECT_FALSE(printed.contains(old)) << old;
  EXPECT_FALSE(printed["snake"].contains("iterations"));
}

TEST(OptionTable, InitialIsTheOldMethodAsAStringOrTheNewGroupAsAnObject) {
  auto read = [](const char* text) {
    FeatureLineOptions o;
    apply_options_json(json::parse(text), o);
    return o;
  };
  EXPECT_EQ(read(R"({"initial": "marching"})").initial.method, InitialMethod::marching);
  const FeatureLineOptions object = read(R"({"initial": {"method": "marching", "marching_delta": 3, "max_edges": 500}})");
  EXPECT_EQ(object.initial.method, InitialMethod::marching);
  EXPECT_EQ(object.initial.marching_delta, 3);
  EXPECT_EQ(object.initial.max_edges, 500);
  // The old string beside other old and new names of the initial line's options.
  const FeatureLineOptions mixed = read(R"({"initial": "geodesic", "weights": {"delta": 3}, "max_line_edges": 400,
                                            "strip": {"rings": 4}, "snake": {"iterations": 50}})");
  EXPECT_EQ(mixed.initial.method, InitialMethod::geodesic);
  EXPECT_EQ(mixed.initial.marching_delta, 3);
  EXPECT_EQ(mixed.initial.max_edges, 400);
  EXPECT_EQ(mixed.strip.rings, 4);
  EXPECT_EQ(mixed.snake.max_iterations, 50);
  auto error = [](const char* text) {
    return error_of([&] {
      FeatureLineOptions o;
      apply_options_json(json::parse(text), o);
    });
  };
  // Errors name the path the request used, old or new.
  EXPECT_EQ(error(R"({"initial": "dijkstra"})"), "\"options.initial\" must be one of marching, feature-path, geodesic, not \"dijkstra\"");
  EXPECT_EQ(error(R"({"initial": 3})"), "\"options.initial\" must be one of marching, feature-path, geodesic");
  EXPECT_EQ(error(R"({"initial": {"methd": "marching"}})"), "unknown option \"options.initial.methd\"");
  EXPECT_EQ(error(R"({"rings": 99})"), "\"options.rings\" must be an integer from 0 to 8");
  EXPECT_EQ(error(R"({"weights": {"alpha": -1}})"), "\"options.weights.alpha\" must be a number from 0 to 1000");
  EXPECT_EQ(error(R"({"weights": {"epsilon": 1}})"), "unknown option \"options.weights.epsilon\"");
  EXPECT_EQ(error(R"({"weights": 1})"), "\"options.weights\" must be a JSON object");
  EXPECT_EQ(error(R"({"snake": {"iterations": 100000}})"), "\"options.snake.iterations\" must be an integer from 0 to 500");
  EXPECT_EQ(error(R"({"initial": "marching", "curvature_term": "high-magnitude", "strip": {"flattening": 1}})"),
            "\"options.strip.flattening\" must be one of automatic, conformal, similar-triangles");
  // The old string and the new method cannot meet in one object (one key), but other pairs can.
  EXPECT_EQ(error(R"({"initial": {"method": "marching", "marching_alpha": 2}, "weights": {"alpha": 3}})"),
            "\"options.weights.alpha\" and \"options.initial.marching_alpha\" name the same option: give only "
            "\"options.initial.marching_alpha\"");
  EXPECT_EQ(error(R"({"snake": {"iterations": 10, "max_iterations": 20}})"),
            "\"options.snake.iterations\" and \"options.snake.max_iterations\" name the same option: give only "
            "\"options.snake.max_iterations\"");
  EXPECT_EQ(error(R"({"strip": {"rings": 3}, "rings": 3})"),
            "\"options.rings\" and \"options.strip.rings\" name the same option: give only \"options.strip.rings\"");
}

TEST(EnumNames, OneTableGivesNamesParsingAndChoices) {
  EXPECT_EQ(to_string(StripFlattening::similar_triangles), "similar-triangles");
  EXPECT_EQ(parse_enum<StripFlattening>("conformal"), StripFlattening::conformal);
  EXPECT_EQ(parse_enum<StripFlattening>("Conformal"), std::nullopt);
  EXPECT_EQ(to_string(InitialMethod::feature_path), "feature-path");
  EXPECT_EQ(parse_enum<InitialMethod>("feature_path"), InitialMethod::feature_path);
  EXPECT_EQ(enum_choices<InitialMethod>(), (std::vector<std::string>{"marching", "feature-path", "geodesic"}));
  EXPECT_EQ(enum_choices<SegmentationMode>(), (std::vector<std::string>{"snap", "remesh"}));
  EXPECT_EQ(to_string(CurvatureMethod::cotangent), "cotangent");
  EXPECT_EQ(to_string(MarchingCurvatureTerm::high_magnitude), "high-magnitude");
  EXPECT_EQ(to_string(SnakeForce::paper), "paper");
  for (const auto& name : enum_choices<MarchingCurvatureTerm>()) EXPECT_EQ(to_string(*parse_enum<MarchingCurvatureTerm>(name)), name);
}

TEST(OptionTable, DescriptionUsesJsonSchemaWords) {
  const json described = describe_api_options();
  json iterations, mode;
  for (const auto& row : described["feature_line"])
    if (row["name"] == "snake.max_iterations") iterations = row;
  for (const auto& row : described["segmentation"])
    if (row["name"] == "mode") mode = row;
  EXPECT_EQ(iterations["type"], "integer");
  EXPECT_EQ(iterations["minimum"], 0);
  EXPECT_EQ(iterations["maximum"], 500);
  EXPECT_EQ(iterations["default"], 300);
  EXPECT_EQ(iterations["cli_flag"], "--iterations");
  EXPECT_EQ(iterations["old_names"], json({"snake.iterations"}));
  EXPECT_FALSE(mode.contains("old_names"));
  EXPECT_FALSE(iterations["description"].get<std::string>().empty());
  EXPECT_EQ(mode["type"], "string");
  EXPECT_EQ(mode["enum"], json({"snap", "remesh"}));
  EXPECT_EQ(described["feature_line"].size(), feature_line_option_table().size());
  EXPECT_EQ(described["limits"]["max_lines"], RequestLimits::max_lines);
  EXPECT_EQ(described["limits"]["max_keys_per_line"], RequestLimits::max_keys_per_line);
}

TEST(Requests, SegmentationOptionsAreAllReachable) {
  const SegmentationOptions o = parse_segmentation_options(json::parse(
      R"({"lines": [], "mode": "remesh", "merge_tiny_segments": true, "min_segment_area_fraction": 0.01,
          "attach_distance": 0, "remesh_snap": 0.05})"));
  EXPECT_EQ(o.mode, SegmentationMode::remesh);
  EXPECT_TRUE(o.merge_tiny_segments);
  EXPECT_EQ(o.min_segment_area_fraction, 0.01);
  EXPECT_EQ(o.attach_distance, 0);
  EXPECT_EQ(o.remesh_snap, 0.05);
  EXPECT_EQ(error_of([] { parse_segmentation_options(json::parse(R"({"lines": [], "mode": "cut"})")); }),
            "\"mode\" must be one of snap, remesh, not \"cut\"");
  EXPECT_EQ(error_of([] { parse_segmentation_options(json::parse(R"({"lines": [], "moed": "snap"})")); }),
            "unknown option \"moed\"");
  EXPECT_EQ(error_of([] { parse_segmentation_options(json::parse(R"({"remesh_snap": 0.3})")); }),
            "\"remesh_snap\" must be a number from 0 to 0.2");
  // The fields naming the lines are the caller's: another engineer's "computed_lines" passes.
  EXPECT_NO_THROW(parse_segmentation_options(json::parse(R"({"computed_lines": []})"), {"computed_lines"}));
}

TEST(Requests, LineRequestsNameTheFieldInErrors) {
  const auto field = testing::make_ridge_field(11, 0.0, 2, 0.3, 0.25, 0.0);
  const auto mesh = prepare_mesh(field.mesh);
  bool batch = true;
  const auto one = parse_feature_line_body(json::parse(R"({"keys": [3, {"point": [0, 0, 0]}], "closed": true})"), *mesh, batch);
  EXPECT_FALSE(batch);
  ASSERT_EQ(one.size(), 1u);
  EXPECT_TRUE(one[0].closed);
  EXPECT_EQ(one[0].keys[0], 3u);
  // The point key is the nearest vertex.
  double nearest = HUGE_VAL;
  for (std::uint32_t v = 0; v < mesh->n_vertices(); ++v) nearest = std::min(nearest, mesh->positions()[v].norm());
  EXPECT_DOUBLE_EQ(mesh->positions()[one[0].keys[1]].norm(), nearest);
  const auto two = parse_feature_line_body(json::parse(R"({"lines": [{"keys": [1, 2]}, {"keys": [3, 4]}]})"), *mesh, batch);
  EXPECT_TRUE(batch);
  EXPECT_EQ(two.size(), 2u);
  auto error = [&](const std::string& text) {
    return error_of([&] { parse_feature_line_body(json::parse(text), *mesh, batch); });
  };
  EXPECT_EQ(error(R"({"keys": [1, 2], "colour": "red"})"), "unknown field \"request.colour\"");
  EXPECT_EQ(error(R"({"lines": [{"keys": [1, 2], "options": {"strip": {"rings": 9}}}]})"),
            "\"options.strip.rings\" must be an integer from 0 to 8");
  EXPECT_EQ(error(R"({"lines": [{"keys": [1, 2], "options": {"rings": 9}}]})"), "\"options.rings\" must be an integer from 0 to 8");
  EXPECT_EQ(error(R"({"keys": [1, 100000]})"), "request.keys[1] is vertex 100000, but the mesh has only " +
                                                    std::to_string(mesh->n_vertices()) + " vertices");
  EXPECT_EQ(error(R"({"lines": []})"), "\"lines\" must be an array of 1 to 64 line requests");
  // A point key far off the mesh was not picked on it (far enough, every vertex reads as nearest).
  const auto& stats = mesh->statistics();
  const double size = std::hypot(stats.bbox_max[0] - stats.bbox_min[0], stats.bbox_max[1] - stats.bbox_min[1],
                                 stats.bbox_max[2] - stats.bbox_min[2]);
  for (const char* far : {R"({"keys": [3, {"point": [1e200, 1e200, 1e200]}]})", R"({"keys": [3, {"point": [0, 0, 50]}]})"})
    EXPECT_EQ(error(far), "request.keys[1].point lies further from the mesh than the mesh's size (" + format_number(size) +
                              ", its bounding box's diagonal): a point key is replaced by the vertex nearest to it")
        << far;
  json many = {{"keys", json::array()}};
  for (std::size_t i = 0; i <= RequestLimits::max_keys_per_line; ++i) many["keys"].push_back(i % 2);
  EXPECT_EQ(error(many.dump()), "request.keys has more than " + std::to_string(RequestLimits::max_keys_per_line) + " keys");
}

// ---- the tables' limits and the engine's ranges: one set of numbers -----------------------------

template <typename Options>
std::size_t expect_limits_inside_engine_ranges(const OptionTable<Options>& table) {
  std::size_t checked = 0;
  for (const auto& field : table) {
    const OptionSpec& spec = field.spec;
    if (!spec.engine_range) continue;
    SCOPED_TRACE(spec.name + " in " + describe(*spec.engine_range));
    ++checked;
    const ValidRange& engine = *spec.engine_range;
    EXPECT_TRUE(engine.contains(spec.minimum)) << spec.minimum;
    EXPECT_TRUE(engine.contains(spec.maximum)) << spec.maximum;
    // A closed, finite end of the engine's range is the row's end, not a second number.
    if (!engine.min_open && std::isfinite(engine.min)) {
      EXPECT_EQ(spec.minimum, engine.min);
    }
    if (!engine.max_open && std::isfinite(engine.max)) {
      EXPECT_EQ(spec.maximum, engine.max);
    }
  }
  return checked;
}

const OptionSpec& spec_named(const std::vector<OptionSpec>& specs, const std::string& name) {
  for (const auto& spec : specs)
    if (spec.name == name) return spec;
  throw std::out_of_range(name);
}

TEST(OptionTable, LimitsAreTheEnginesRanges) {
  // 33 feature-line rows (rings, min_piece_edges, twelve snake options, five crest options, seven
  // trace options, seven fitted-curve options), 3 segmentation, 4 curvature.
  EXPECT_EQ(expect_limits_inside_engine_ranges(feature_line_option_table()), 33u);
  EXPECT_EQ(expect_limits_inside_engine_ranges(segmentation_option_table()), 3u);
  EXPECT_EQ(expect_limits_inside_engine_ranges(curvature_option_table()), 4u);
  const auto line = option_specs(feature_line_option_table());
  EXPECT_EQ(spec_named(line, "strip.rings").maximum, StripOptions::max_rings);
  EXPECT_EQ(spec_named(line, "min_piece_edges").minimum, FeatureLineOptions::min_piece_edges_range.min);
  EXPECT_EQ(spec_named(line, "snake.max_iterations").minimum, SnakeOptions::max_iterations_range.min);
  EXPECT_EQ(spec_named(option_specs(curvature_option_table()), "radius").maximum, CurvatureLimits::max_radius);
  // A row cannot take an open or unbounded engine end, nor leave the engine's range.
  EXPECT_THROW(within(above(0)), std::logic_error);
  EXPECT_THROW(within(at_least(0)), std::logic_error);
  EXPECT_THROW(within(closed_range(0, 8), kEngineEnd, 9), std::logic_error);
  EXPECT_THROW(within(above(0.01), 0.01, 10), std::logic_error);
  EXPECT_EQ(within(above(0.01), 0.25, 10).minimum, 0.25);
  EXPECT_EQ(describe(half_open_range(0, 0.25)), "[0, 0.25)");
}

// One options struct per numeric row at its table minimum and one at its maximum, the other
// fields at their defaults; `label` names the row and the value.
template <typename Options>
std::vector<std::pair<std::string, Options>> options_at_table_limits(const OptionTable<Options>& table) {
  std::vector<std::pair<std::string, Options>> out;
  for (const auto& field : table) {
    const OptionSpec& spec = field.spec;
    if (spec.kind != OptionKind::number && spec.kind != OptionKind::integer) continue;
    for (double value : {spec.minimum, spec.maximum}) {
      Options options;
      field.write(options, check_option_value(spec, json(value), spec.name));
      out.emplace_back(spec.name + " = " + format_number(value), options);
    }
  }
  return out;
}

// One options struct per closed, finite end of an engine range, just outside it.
template <typename Options>
std::vector<std::pair<std::string, Options>> options_outside_engine_ranges(const OptionTable<Options>& table) {
  std::vector<std::pair<std::string, Options>> out;
  for (const auto& field : table) {
    const OptionSpec& spec = field.spec;
    if (!spec.engine_range) continue;
    const ValidRange& r = *spec.engine_range;
    const double step = spec.kind == OptionKind::integer ? 1 : 1e-9;
    std::vector<double> outside;
    if (!r.min_open && std::isfinite(r.min)) outside.push_back(r.min - step);
    if (!r.max_open && std::isfinite(r.max)) outside.push_back(r.max + step);
    if (r.min_open) outside.push_back(r.min);
    if (r.max_open) outside.push_back(r.max);  // infinity too, where only finite numbers pass
    for (double value : outside) {
      Options options;
      field.write(options, spec.kind == OptionKind::integer ? json(static_cast<long long>(value)) : json(value));
      out.emplace_back(spec.name + " = " + format_number(value), options);
    }
  }
  return out;
}

TEST(OptionTable, EngineAcceptsWhatTheTableAcceptsAndRefusesWhatItsRangeRefuses) {
  for (const auto& [what, options] : options_at_table_limits(feature_line_option_table()))
    EXPECT_NO_THROW(check_feature_line_options(options)) << what;
  for (const auto& [what, options] : options_at_table_limits(segmentation_option_table()))
    EXPECT_NO_THROW(check_segmentation_options(options)) << what;
  for (const auto& [what, options] : options_at_table_limits(curvature_option_table()))
    EXPECT_NO_THROW(check_curvature_options(options)) << what;
  // The engine's checks use those same ranges: one step outside is refused.
  const auto line = options_outside_engine_ranges(feature_line_option_table());
  for (const auto& [what, options] : line) EXPECT_THROW(check_feature_line_options(options), InvalidInputError) << what;
  const auto segmentation = options_outside_engine_ranges(segmentation_option_table());
  for (const auto& [what, options] : segmentation) EXPECT_THROW(check_segmentation_options(options), InvalidInputError) << what;
  const auto curvature = options_outside_engine_ranges(curvature_option_table());
  for (const auto& [what, options] : curvature) EXPECT_THROW(check_curvature_options(options), InvalidInputError) << what;
  // Two ends of rings, one of each other line option but the crest's five, the trace's seven and
  // the fitted curve's seven, which have two (max_edges: below 2, and infinity); both ends of the
  // three segmentation ranges; radius, passes and tolerance at both ends, crease_angle above its maximum.
  EXPECT_EQ(line.size(), 53u);
  EXPECT_EQ(segmentation.size(), 6u);
  EXPECT_EQ(curvature.size(), 7u);
}

// The whole engine, not only its checks: a line on a small ridge field runs with every numeric
// row at each of its table limits (the fitted curve on, so its rows are exercised too), and the
// mesh prepares with every curvature row at its limits.
TEST(OptionTable, LinesAndPreparationRunAtEveryTableLimit) {
  const auto field = testing::make_ridge_field(21, 0.2, 3, 0.3, 0.2, 0.3);
  const auto mesh = prepare_mesh(field.mesh);
  const auto keys = testing::keys_on_crest(field, {-0.8, 0.0, 0.8});
  for (const auto& [what, options] : options_at_table_limits(feature_line_option_table())) {
    // At its minimum of one edge initial.max_edges refuses any longer line: that is its job.
    if (what == "initial.max_edges = 1") continue;
    FeatureLineRequest request;
    request.keys = keys;
    request.options = options;
    request.options.fitted.enabled = true;
    EXPECT_NO_THROW({
      const auto line = detect_feature_line(*mesh, request);
      EXPECT_GE(line.refined.size(), 2u) << what;
      ASSERT_TRUE(line.fitted) << what;
      EXPECT_GE(line.fitted->points.size(), 2u) << what;
    }) << what;
  }
  for (const auto& [what, options] : options_at_table_limits(curvature_option_table())) {
    PrepareOptions prepare;
    prepare.curvature = options;
    EXPECT_NO_THROW(prepare_mesh(field.mesh, prepare)) << what;
  }
}

}  // namespace
}  // namespace featureline
