#pragma once
/// @file Typed, checked reads of JSON fields shared by the probe model and scene files: each
/// throws `Error` (the caller's error type) naming the field, never a bare JSON exception.

#include "mlp/base/json_text.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <numeric>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

namespace mlp::base::json_fields {

using nlohmann::json;

template <class Error>
[[noreturn]] void Fail(const std::string& what) {
  throw Error(what);
}

template <class Error>
double Number(const json& j, const char* key, const std::string& where) {
  if (!j.contains(key) || !j.at(key).is_number())
    Fail<Error>(where + "." + key + " must be a number");
  const double v = j.at(key).get<double>();
  if (!std::isfinite(v)) Fail<Error>(where + "." + key + " must be finite");
  return v;
}

template <class Error>
double NumberOr(const json& j, const char* key, double fallback, const std::string& where) {
  return j.contains(key) ? Number<Error>(j, key, where) : fallback;
}

template <class Error>
bool FlagOr(const json& j, const char* key, bool fallback, const std::string& where) {
  if (!j.contains(key)) return fallback;
  if (!j.at(key).is_boolean()) Fail<Error>(where + "." + key + " must be true or false");
  return j.at(key).get<bool>();
}

/// A whole number that fits an int: 4294967308 is refused, never read as 12 (a 64-bit value
/// cut to 32 bits once named tool 12 instead of refusing).
template <class Error>
int Integer(const json& j, const char* key, const std::string& where) {
  if (!j.contains(key) || !j.at(key).is_number_integer()) {
    Fail<Error>(where + "." + key + " must be an integer");
  }
  const json& v = j.at(key);
  constexpr auto kMax = std::numeric_limits<int>::max();
  constexpr auto kMin = std::numeric_limits<int>::min();
  const bool fits = v.is_number_unsigned()
                        ? v.get<std::uint64_t>() <= std::uint64_t{kMax}
                        : v.get<std::int64_t>() >= kMin && v.get<std::int64_t>() <= kMax;
  if (!fits) Fail<Error>(where + "." + key + " is out of range");
  return static_cast<int>(v.get<std::int64_t>());
}

template <class Error>
std::string Text(const json& j, const char* key, const std::string& where) {
  if (!j.contains(key) || !j.at(key).is_string())
    Fail<Error>(where + "." + key + " must be a string");
  return j.at(key).get<std::string>();
}

template <class Error>
const json& Object(const json& j, const char* key, const std::string& where) {
  if (!j.contains(key) || !j.at(key).is_object())
    Fail<Error>(where + "." + key + " must be an object");
  return j.at(key);
}

template <class Error>
Eigen::Vector3d Vector3(const json& j, const char* key, const std::string& where) {
  const std::string name = where + "." + key;
  if (!j.contains(key) || !j.at(key).is_array() || j.at(key).size() != 3) {
    Fail<Error>(name + " must be an array of 3 numbers");
  }
  Eigen::Vector3d v;
  for (int k = 0; k < 3; ++k) {
    if (!j.at(key)[k].is_number()) Fail<Error>(name + " must be an array of 3 numbers");
    v(k) = j.at(key)[k].get<double>();
  }
  if (!v.allFinite()) Fail<Error>(name + " must be finite");
  return v;
}

/// A pose: translation [mm] and rotation vector [rad] (axis times angle, as OpenCV's Rodrigues):
/// no gimbal lock, and what calibration estimates.
template <class Error>
Eigen::Isometry3d Pose(const json& j, const std::string& where) {
  const Eigen::Vector3d t = Vector3<Error>(j, "translation_mm", where);
  const Eigen::Vector3d r = Vector3<Error>(j, "rotation_vector_rad", where);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  const double angle = r.norm();
  if (angle > 0.0) pose.linear() = Eigen::AngleAxisd(angle, r / angle).toRotationMatrix();
  pose.translation() = t;
  return pose;
}

/// [x, y, z]: how every vector is written in the project's JSON files.
inline nlohmann::ordered_json Vec3ToJson(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

/// The pose as Pose() reads it.
inline nlohmann::ordered_json PoseToJson(const Eigen::Isometry3d& pose) {
  const Eigen::AngleAxisd aa(pose.linear());
  return {{"translation_mm", Vec3ToJson(pose.translation())},
          {"rotation_vector_rad", Vec3ToJson(aa.axis() * aa.angle())}};
}

/// Levenshtein distance (insert, delete, substitute: 1 each), for "did you mean" hints. Written
/// here because no library the project uses offers it and field names are a few letters long.
inline std::size_t EditDistance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  std::iota(row.begin(), row.end(), std::size_t{0});
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t k = 1; k <= b.size(); ++k) {
      const std::size_t above = row[k];
      row[k] = std::min({row[k] + 1, row[k - 1] + 1, diagonal + (a[i - 1] != b[k - 1])});
      diagonal = above;
    }
  }
  return row[b.size()];
}

/// Refuses any field of object `j` not in `known`: a misspelled key ("job_timout_s") would
/// otherwise be ignored and its default used without a word. Names the nearest known field.
template <class Error>
void OnlyKnownFields(const json& j,
                     std::initializer_list<std::string_view> known,
                     const std::string& where) {
  for (const auto& item : j.items()) {
    const std::string& key = item.key();
    if (std::find(known.begin(), known.end(), key) != known.end()) continue;
    std::string_view nearest;
    std::size_t best = std::numeric_limits<std::size_t>::max();
    for (std::string_view k : known) {
      const std::size_t d = EditDistance(key, k);
      if (d < best) best = d, nearest = k;
    }
    std::string message = where;
    message.append(".").append(key).append(" is not a known field");
    if (best <= std::max<std::size_t>(3, key.size() / 3))
      message.append(" (did you mean \"").append(nearest).append("\"?)");
    Fail<Error>(message);
  }
}

/// Parses text into a JSON object whose "format" is one of `formats` (the newest first: the
/// error names it); throws Error otherwise.
template <class Error>
json ParseDocument(const std::string& text,
                   std::initializer_list<std::string> formats,
                   const std::string& what) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::exception& e) {  // parse_error, or out_of_range for 1e400
    Fail<Error>(what + ": not valid JSON (" + e.what() + ")");
  }
  if (!j.is_object()) Fail<Error>(what + ": the document must be a JSON object");
  const bool known =
      j.contains("format") && j.at("format").is_string() &&
      std::find(formats.begin(), formats.end(), j.at("format").get<std::string>()) != formats.end();
  if (!known) {
    Fail<Error>(what + ": format must be \"" + *formats.begin() +
                "\" (a newer file needs a newer program)");
  }
  return j;
}

/// Parses text into a JSON object whose "format" is `format`; throws Error otherwise.
template <class Error>
json ParseDocument(const std::string& text, const std::string& format, const std::string& what) {
  return ParseDocument<Error>(text, std::initializer_list<std::string>{format}, what);
}

}  // namespace mlp::base::json_fields
