// Named enums read from and written as text through one table per enum, so that to_string and
// parse_* cannot drift apart. The first entry of a value is its canonical name; later entries of
// the same value are accepted aliases ("impute_mean" for "impute-mean"). Lives in the model
// library (the base of the others) so that every library writes its enums the same way.
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <string_view>

namespace sigmaheart::model {

template <class E>
struct EnumName {
  E value;
  const char* name;
};

// The canonical name of `value`, or `fallback` for a value the table does not list.
template <class E, std::size_t N>
const char* enum_to_string(const std::array<EnumName<E>, N>& table, E value,
                           const char* fallback = "unknown") {
  for (const auto& e : table) {
    if (e.value == value) return e.name;
  }
  return fallback;
}

template <class E, std::size_t N>
std::optional<E> enum_from_string(const std::array<EnumName<E>, N>& table, std::string_view text) {
  for (const auto& e : table) {
    if (text == e.name) return e.value;
  }
  return std::nullopt;
}

}  // namespace sigmaheart::model

// Defines the pair every named enum declares, from its table given as the entries
// {Enum::kValue, "name"}, ... (the table is the constant k<parse>_names of the source file):
//   const char* to_string(Enum);  std::optional<Enum> parse(const std::string&);
#define SIGMAHEART_ENUM_TEXT(Enum, parse, ...)                                                    \
  constexpr auto k##parse##_names = std::to_array<::sigmaheart::model::EnumName<Enum>>({__VA_ARGS__}); \
  const char* to_string(Enum value) { return ::sigmaheart::model::enum_to_string(k##parse##_names, value); } \
  std::optional<Enum> parse(const std::string& text) {                                            \
    return ::sigmaheart::model::enum_from_string(k##parse##_names, text);                         \
  }
