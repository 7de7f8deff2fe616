#include "mlp/probe_fw/stripe_file.h"

#include "mlp/base/files.h"
#include "mlp/base/json_fields.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace mlp::probe_fw {
namespace {

namespace jf = base::json_fields;
constexpr const char* kFormat = "mlprobe-stripes/2";
// Version 1 had row scans only (y_px a whole sensor row); its files read unchanged.
constexpr const char* kFormatRowsOnly = "mlprobe-stripes/1";
// Sensor coordinates and projector columns are far below this; anything above is garbage.
constexpr double kMaxCoordinate = 1e6;

[[noreturn]] void Fail(const std::string& what) { throw StripeFileError(what); }

// 1e-4 px / column is far below the centre's noise (~0.03 px) and keeps the file small.
double Rounded(double v) { return std::round(v * 1e4) / 1e4; }

// `rows_only`: a version 1 file, whose y_px is a whole sensor row.
StripeObservationRecord ParsePoint(const jf::json& p,
                                   size_t i,
                                   const std::string& path,
                                   bool rows_only) {
  const std::string where = path + ": points[" + std::to_string(i) + "]";
  if (!p.is_array() || p.size() != 4) Fail(where + " must be [x_px, y_px, column, quality]");
  for (const auto& v : p) {
    if (!v.is_number() || !std::isfinite(v.get<double>()) ||
        std::abs(v.get<double>()) > kMaxCoordinate)
      Fail(where + " must hold finite numbers");
  }
  if (rows_only && !p[1].is_number_integer())
    Fail(where + ": y_px is a sensor row (an integer) in " + kFormatRowsOnly);
  StripeObservationRecord r{p[0].get<double>(), p[1].get<double>(), p[2].get<double>(),
                            p[3].get<double>()};
  if (r.x_px < 0 || r.y_px < 0 || r.column < 0) Fail(where + ": coordinates must not be negative");
  if (r.quality < 0 || r.quality > 1) Fail(where + ": quality must be in [0, 1]");
  return r;
}

}  // namespace

void SaveStripeFile(const StripeFile& file, const std::string& path) {
  nlohmann::ordered_json j;
  j["format"] = kFormat;
  j["probe_serial"] = file.probe_serial;
  j["capture_id"] = file.capture_id;
  j["points"] = nlohmann::ordered_json::array();
  for (const auto& p : file.points)
    j["points"].push_back(
        {Rounded(p.x_px), Rounded(p.y_px), Rounded(p.column), Rounded(p.quality)});
  try {
    base::WriteFileAtomically(path, j.dump() + "\n");
  } catch (const base::FileError& e) {
    Fail(e.what());
  }
}

StripeFile LoadStripeFile(const std::string& path) {
  const jf::json j = jf::ParseDocument<StripeFileError>(base::ReadFileAs<StripeFileError>(path),
                                                        {kFormat, kFormatRowsOnly}, path);
  StripeFile f;
  f.probe_serial = jf::Text<StripeFileError>(j, "probe_serial", path);
  f.capture_id = jf::Text<StripeFileError>(j, "capture_id", path);
  if (!j.contains("points") || !j.at("points").is_array()) Fail(path + ": points must be an array");
  const auto& points = j.at("points");
  f.points.reserve(points.size());
  const bool rows_only = j.at("format") == kFormatRowsOnly;
  for (size_t i = 0; i < points.size(); ++i)
    f.points.push_back(ParsePoint(points[i], i, path, rows_only));
  return f;
}

}  // namespace mlp::probe_fw
