// An enum's names, both ways, from one table written beside the enum:
//
//   enum class Exposure { kFixed, kFree };
//   inline constexpr EnumName<Exposure> kExposureNames[] = {{Exposure::kFixed, "fixed"},
//                                                          {Exposure::kFree, "free"}};
//
// NameOf(kExposureNames, e) gives the name, ValueOf(kExposureNames, "free") the value (none for an
// unknown name), NamesOf the names in the table's order (for "known: ..." in an error).
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace shadefit {

template <typename E>
struct EnumName {
  E value;
  std::string_view name;
};

// The name of `value`; "?" for a value the table lacks (a table that misses a value is a bug its
// enum's test catches).
template <typename E, std::size_t N>
constexpr std::string_view NameOf(const EnumName<E> (&names)[N], E value) {
  for (const EnumName<E>& n : names) {
    if (n.value == value) return n.name;
  }
  return "?";
}

template <typename E, std::size_t N>
constexpr std::optional<E> ValueOf(const EnumName<E> (&names)[N], std::string_view name) {
  for (const EnumName<E>& n : names) {
    if (n.name == name) return n.value;
  }
  return std::nullopt;
}

template <typename E, std::size_t N>
std::vector<std::string> NamesOf(const EnumName<E> (&names)[N]) {
  std::vector<std::string> out;
  for (const EnumName<E>& n : names) out.emplace_back(n.name);
  return out;
}

}  // namespace shadefit
