// Names of the engine's enums, one table per enum: to_string, parsing and the list of accepted
// names (error messages, the API description, CLI help) all read the same table, so a new value
// cannot be printable but unparsable, or accepted but missing from the documentation.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>

namespace featureline {

/// Specialise next to an enum: `static constexpr std::array<std::pair<Enum, const char*>, N>
/// entries`. The first entry of a value is its name; later entries of the same value are
/// accepted aliases (parsed, never printed).
template <typename Enum>
struct EnumNames;

template <typename Enum, typename = void>
struct has_enum_names : std::false_type {};
template <typename Enum>
struct has_enum_names<Enum, std::void_t<decltype(EnumNames<Enum>::entries)>> : std::true_type {};

template <typename Enum, typename = std::enable_if_t<has_enum_names<Enum>::value>>
std::string to_string(Enum value) {
  for (const auto& [entry, name] : EnumNames<Enum>::entries)
    if (entry == value) return name;
  return "unknown";
}

template <typename Enum>
std::optional<Enum> parse_enum(std::string_view name) {
  for (const auto& [entry, entry_name] : EnumNames<Enum>::entries)
    if (name == entry_name) return entry;
  return std::nullopt;
}

/// Whether entries[index] is the printed name of its value (not an alias).
template <typename Enum>
bool is_primary_enum_name(std::size_t index) {
  const auto& entries = EnumNames<Enum>::entries;
  for (std::size_t i = 0; i < index; ++i)
    if (entries[i].first == entries[index].first) return false;
  return true;
}

}  // namespace featureline
