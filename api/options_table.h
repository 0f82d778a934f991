// One table per options struct: each row names a JSON field (the path of the struct member behind
// it, so JSON, code and docs use one name), the member, its
// type, default, limits (or accepted names) and what it does. The same rows drive JSON parsing
// (with exact errors), JSON output of the effective options, range checks of options built in
// code, the CLI's flags and help, and the description served at GET /v1/options that the page
// builds its inputs from; tests check api/openapi.yaml against them. Limits are where cost is
// capped: a row's maximum is what one request may ask for (bench/bench_worst_case measures a
// line at the caps).
#pragma once

#include <cmath>
#include <functional>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine/curvature.h"
#include "engine/enum_names.h"
#include "engine/feature_line.h"
#include "engine/feature_seeds.h"
#include "engine/segmentation.h"

namespace featureline {

template <>
struct EnumNames<SegmentationMode> {
  static constexpr std::array<std::pair<SegmentationMode, const char*>, 2> entries{{{SegmentationMode::snap, "snap"},
                                                                                   {SegmentationMode::remesh, "remesh"}}};
};

enum class OptionKind { number, integer, boolean, choice };

/// What one option accepts, as the API describes it.
struct OptionSpec {
  /// JSON path below the options object, parts joined by '.': the member's path in the options
  /// struct ("snake.max_iterations" is SnakeOptions::max_iterations in FeatureLineOptions::snake).
  std::string name;
  OptionKind kind = OptionKind::number;
  double minimum = 0, maximum = 0;   ///< number and integer
  /// What the engine itself accepts, for options it checks (engine/valid_range.h): the row's
  /// limits lie inside it, equal to its closed finite ends.
  std::optional<ValidRange> engine_range;
  std::vector<std::string> choices;  ///< choice: the accepted names
  std::vector<std::string> aliases;  ///< choice: older names still accepted, never printed
  /// Paths the option had before `name`, still accepted in requests until the next release (a
  /// request giving one of them and `name` is refused); never printed in effective options.
  std::vector<std::string> old_names;
  nlohmann::json default_value;      ///< the struct's default, as JSON
  std::string description;           ///< one line
  /// The CLI flag setting it, "" for none. A boolean flag sets the opposite of the default.
  std::string cli_flag;
};

template <typename Options>
struct OptionField {
  OptionSpec spec;
  std::function<nlohmann::json(const Options&)> read;
  std::function<void(Options&, const nlohmann::json&)> write;  ///< the value already passed check_option_value
};

template <typename Options>
using OptionTable = std::vector<OptionField<Options>>;

/// FeatureLineOptions with its nested initial-line, strip and snake options (a request's "options").
const OptionTable<FeatureLineOptions>& feature_line_option_table();
/// SegmentationOptions (the fields of a segmentation request beside "lines").
const OptionTable<SegmentationOptions>& segmentation_option_table();
/// CurvatureOptions: how a mesh is prepared (CLI flags; uploads use the defaults).
const OptionTable<CurvatureOptions>& curvature_option_table();
/// FeatureSeedOptions: which crease chains and ridge and valley vertices are offered as seeds.
const OptionTable<FeatureSeedOptions>& feature_seed_option_table();

/// Limits of a request's shape rather than of one option, served beside the tables.
struct RequestLimits {
  static constexpr std::size_t max_lines = 64;          ///< lines per feature-line or segmentation request
  static constexpr std::size_t max_keys_per_line = 128;
  static constexpr std::size_t max_json_bytes = 4 << 20;
};

/// `value` checked against `spec` (type, range, accepted names), normalised (2.0 -> 2 for
/// integers). \throw InvalidInputError "\"<where>\" must be an integer from 1 to 2000" and the like.
nlohmann::json check_option_value(const OptionSpec& spec, const nlohmann::json& value, const std::string& where);

/// "prefix.name", or "name" when the prefix is empty.
std::string option_path(const std::string& prefix, const std::string& name);
/// "snake.max_iterations" -> "snake/max_iterations" (a JSON pointer without its leading '/').
std::string dotted_to_pointer(const std::string& dotted);
/// Where the option named `name` sits in a JSON object: "snake.tau" -> /snake/tau.
nlohmann::json::json_pointer option_pointer(const std::string& name);
[[noreturn]] void throw_not_an_object(const std::string& where);
[[noreturn]] void throw_unknown_option(const std::string& where);
/// A request named one option by two paths (an old name and the current one): `current` is the
/// one to keep.
[[noreturn]] void throw_option_given_twice(const std::string& first, const std::string& second, const std::string& current);

/// The table as the API describes it: [{"name", "type", "default", "minimum", "maximum" | "enum",
/// "description", "cli_flag", "old_names"}] (JSON Schema's words, so it compares directly with
/// api/openapi.yaml); "cli_flag" and "old_names" only where a row has them.
nlohmann::json describe_options(const std::vector<OptionSpec>& specs);

template <typename Options>
std::vector<OptionSpec> option_specs(const OptionTable<Options>& table) {
  std::vector<OptionSpec> specs;
  for (const auto& field : table) specs.push_back(field.spec);
  return specs;
}

/// Applies a JSON object onto `options`. Nested objects follow the dotted names, current or old;
/// unknown fields, wrong types, values out of range and an option given by two names are an
/// InvalidInputError naming the field by the path the object used, below `prefix` (e.g.
/// "options.snake.max_iterations", or "options.snake.iterations" for a request using the old name).
template <typename Options>
void apply_options(const OptionTable<Options>& table, const nlohmann::json& object, const std::string& prefix, Options& options);

/// The options of `object` (checked as apply_options checks them) under their current names only,
/// so it can be merged with other options objects (the CLI's flags over a request's options).
template <typename Options>
nlohmann::json with_current_names(const OptionTable<Options>& table, const nlohmann::json& object, const std::string& prefix);

/// Every option's current value, as the nested JSON object apply_options reads (current names).
template <typename Options>
nlohmann::json options_json(const OptionTable<Options>& table, const Options& options) {
  nlohmann::json out = nlohmann::json::object();
  for (const auto& field : table) out[option_pointer(field.spec.name)] = field.read(options);
  return out;
}

/// Checks options built in code (the CLI, benchmarks) against the same limits as JSON input.
template <typename Options>
void check_options(const OptionTable<Options>& table, const Options& options, const std::string& prefix) {
  for (const auto& field : table) check_option_value(field.spec, field.read(options), option_path(prefix, field.spec.name));
}

// ---- building rows -------------------------------------------------------------------------------

template <typename Object, typename Member>
Member& member_at(Object& object, Member Object::*member) {
  return object.*member;
}
template <typename Object, typename Member, typename... Rest>
auto& member_at(Object& object, Member Object::*member, Rest... rest) {
  return member_at(object.*member, rest...);
}

template <typename Value>
nlohmann::json option_to_json(const Value& value) {
  if constexpr (std::is_enum_v<Value>) return to_string(value);
  else return value;
}
template <typename Value>
void option_from_json(Value& out, const nlohmann::json& value) {
  if constexpr (std::is_enum_v<Value>) out = *parse_enum<Value>(value.get<std::string>());
  else out = value.get<Value>();
}

template <typename Value>
OptionKind option_kind() {
  if constexpr (std::is_same_v<Value, bool>) return OptionKind::boolean;
  else if constexpr (std::is_enum_v<Value>) return OptionKind::choice;
  else if constexpr (std::is_integral_v<Value>) return OptionKind::integer;
  else return OptionKind::number;
}

/// The names of an enum's values (`primary`), or its accepted aliases (!primary).
template <typename Enum>
std::vector<std::string> enum_choices(bool primary = true) {
  std::vector<std::string> names;
  const auto& entries = EnumNames<Enum>::entries;
  for (std::size_t i = 0; i < entries.size(); ++i)
    if (is_primary_enum_name<Enum>(i) == primary) names.push_back(entries[i].second);
  return names;
}

struct OptionRange {
  OptionRange() = default;
  OptionRange(double min, double max, std::optional<ValidRange> engine_range = std::nullopt)
      : minimum(min), maximum(max), engine(engine_range) {}
  double minimum = 0, maximum = 0;  ///< unused for booleans and choices
  std::optional<ValidRange> engine;  ///< the engine's own range, when it checks the option
};

/// In within(): this end of the row is the engine's own (a closed, finite end of its range).
constexpr double kEngineEnd = NAN;

/// A row's limits for an option the engine checks: each end is the engine's (kEngineEnd) or the
/// table's own number inside the engine's range (where the engine's end is open or unbounded,
/// or where the table caps cost). \throw std::logic_error when kEngineEnd meets an open or
/// unbounded end, or a number lies outside the engine's range.
OptionRange within(const ValidRange& engine, double minimum = kEngineEnd, double maximum = kEngineEnd);

/// A row for the member reached from Options through `path` (one member pointer per level).
template <typename Options, typename... Path>
OptionField<Options> option(const char* name, OptionRange range, const char* description, const char* cli_flag, Path... path) {
  using Value = std::decay_t<decltype(member_at(std::declval<Options&>(), path...))>;
  OptionField<Options> field;
  field.spec.name = name;
  field.spec.kind = option_kind<Value>();
  field.spec.minimum = range.minimum;
  field.spec.maximum = range.maximum;
  field.spec.engine_range = range.engine;
  if constexpr (std::is_enum_v<Value>) {
    field.spec.choices = enum_choices<Value>();
    field.spec.aliases = enum_choices<Value>(false);
  }
  field.spec.description = description;
  field.spec.cli_flag = cli_flag;
  field.read = [path...](const Options& o) { return option_to_json(member_at(const_cast<Options&>(o), path...)); };
  field.write = [path...](Options& o, const nlohmann::json& value) { option_from_json(member_at(o, path...), value); };
  field.spec.default_value = field.read(Options{});
  return field;
}

/// `field` still accepted under the paths it had before it was renamed (OptionSpec::old_names).
template <typename Options>
OptionField<Options> formerly(std::vector<std::string> old_names, OptionField<Options> field) {
  field.spec.old_names = std::move(old_names);
  return field;
}

// ---- parsing -------------------------------------------------------------------------------------
/// The row a request's path names, by its current or an old name; null when none. `is_group`
/// tells whether names (current or old) exist below "path.": an old leaf name can be a group now
/// ("initial" was the method and now holds it with the other initial-line options).
template <typename Options>
const OptionField<Options>* find_option(const OptionTable<Options>& table, const std::string& path, bool& is_group) {
  is_group = false;
  const OptionField<Options>* found = nullptr;
  const auto check = [&](const OptionField<Options>& field, const std::string& name) {
    if (name == path) found = &field;
    else if (name.compare(0, path.size() + 1, path + ".") == 0) is_group = true;
  };
  for (const auto& field : table) {
    check(field, field.spec.name);
    for (const auto& old : field.spec.old_names) check(field, old);
  }
  return found;
}

/// Walks `object` (see for_each_option) below `group`; `given` holds the path each row was given by.
template <typename Options, typename Visit>
void for_each_option_below(const OptionTable<Options>& table, const nlohmann::json& object, const std::string& group,
                           const std::string& prefix, std::vector<std::pair<const OptionField<Options>*, std::string>>& given,
                           const Visit& visit) {
  if (!object.is_object()) throw_not_an_object(option_path(prefix, group));
  for (auto it = object.begin(); it != object.end(); ++it) {
    const std::string name = group.empty() ? it.key() : group + "." + it.key();
    bool is_group = false;
    const OptionField<Options>* field = find_option(table, name, is_group);
    // Where a name is both an old leaf and a group, the value's shape says which is meant.
    if (is_group && (field == nullptr || it.value().is_object())) {
      for_each_option_below(table, it.value(), name, prefix, given, visit);
      continue;
    }
    if (field == nullptr) throw_unknown_option(option_path(prefix, name));
    const std::string path = option_path(prefix, name);
    for (const auto& [row, first] : given)
      if (row == field) throw_option_given_twice(first, path, option_path(prefix, field->spec.name));
    given.emplace_back(field, path);
    visit(*field, check_option_value(field->spec, it.value(), path));
  }
}

/// Calls visit(field, value) for each option `object` gives, by current or old name, its value
/// checked and named in errors by the path the object used below `prefix`.
template <typename Options, typename Visit>
void for_each_option(const OptionTable<Options>& table, const nlohmann::json& object, const std::string& prefix, const Visit& visit) {
  std::vector<std::pair<const OptionField<Options>*, std::string>> given;
  for_each_option_below(table, object, "", prefix, given, visit);
}

template <typename Options>
void apply_options(const OptionTable<Options>& table, const nlohmann::json& object, const std::string& prefix, Options& options) {
  for_each_option(table, object, prefix, [&options](const OptionField<Options>& field, const nlohmann::json& value) {
    field.write(options, value);
  });
}

template <typename Options>
nlohmann::json with_current_names(const OptionTable<Options>& table, const nlohmann::json& object, const std::string& prefix) {
  nlohmann::json out = nlohmann::json::object();
  for_each_option(table, object, prefix, [&out](const OptionField<Options>& field, const nlohmann::json& value) {
    out[option_pointer(field.spec.name)] = value;
  });
  return out;
}

}  // namespace featureline
