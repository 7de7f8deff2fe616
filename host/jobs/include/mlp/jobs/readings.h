#pragma once
/// @file A job's numbers as its reply lists them: named values, each name ending in its unit
/// ("diameter_mm", "angle_deg", "points"), some grouped ("face_plus": a face's own numbers) or
/// listed ("holes"). The jobs say what they found in these; the service writes them as JSON
/// (docs/HOSTD.md lists every name), the reports print them. No JSON library in the jobs.

#include "mlp/geometry/types.h"

#include <cstdint>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

namespace mlp::jobs {

struct Reading;
using Readings = std::vector<Reading>;

struct Reading {
  using Value = std::variant<double,
                             std::int64_t,
                             std::string,  // a word: "+y"
                             geometry::Vec3,
                             std::vector<geometry::Vec3>,  // points: [[x, y, z], ...]
                             std::vector<std::string>,
                             Readings,                // a group: a face's numbers
                             std::vector<Readings>>;  // a list of groups: a bolt circle's holes
  std::string name;
  Value value;

  /// Integers stay integers (counts), floating point stays a number of its unit.
  template <class T>
  Reading(std::string n, T v) : name(std::move(n)), value(Of(std::move(v))) {}

 private:
  template <class T>
  static Value Of(T v) {
    if constexpr (std::is_same_v<T, bool>)
      static_assert(!std::is_same_v<T, bool>, "a flag is not a reading");
    else if constexpr (std::is_integral_v<T>)
      return static_cast<std::int64_t>(v);
    else if constexpr (std::is_floating_point_v<T>)
      return static_cast<double>(v);
    else if constexpr (std::is_convertible_v<T, std::string>)
      return std::string(std::move(v));
    else
      return Value(std::move(v));
  }
};

/// The reading named `name` at the top level, or nullptr.
const Reading* Find(const Readings& readings, const std::string& name);
Reading* Find(Readings* readings, const std::string& name);
/// Sets `name` to `value`: replaces a reading of that name, else appends it.
void Set(Readings* readings, Reading reading);

}  // namespace mlp::jobs
