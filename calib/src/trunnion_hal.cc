#include "mlp/calib/trunnion_hal.h"

#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>

namespace mlp::calib {
namespace {

const std::string kPrefix = "xyzac-trt-kins.";

// One `setp xyzac-trt-kins.NAME VALUE` line's pin name, or "" for any other line.
std::string PinOf(const std::string& line, std::string* value) {
  std::istringstream words(line.substr(0, line.find('#')));
  std::string verb, pin, extra;
  if (!(words >> verb) || verb != "setp" || !(words >> pin) || pin.rfind(kPrefix, 0) != 0)
    return "";
  if (!(words >> *value) || (words >> extra))
    throw TrunnionError("pins: '" + line + "' is not setp PIN VALUE");
  return pin.substr(kPrefix.size());
}

double Number(const std::string& pin, const std::string& text) {
  size_t used = 0;
  double v = 0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || !std::isfinite(v))
    throw TrunnionError("pins: " + kPrefix + pin + " is not a number: '" + text + "'");
  return v;
}

}  // namespace

TrtPins ParseTrtPinsHal(const std::string& text) {
  std::map<std::string, double> values;
  std::istringstream lines(text);
  std::string line, value;
  while (std::getline(lines, line)) {
    const std::string name = PinOf(line, &value);
    if (name.empty()) continue;
    if (!values.emplace(name, Number(name, value)).second)
      throw TrunnionError(
          std::string("pins: ").append(kPrefix).append(name).append(" is set twice"));
  }
  const auto get = [&](const std::string& name, bool required) {
    const auto it = values.find(name);
    if (it != values.end()) return it->second;
    if (required) throw TrunnionError("pins: no setp " + kPrefix + name);
    return 0.0;
  };
  TrtPins p;
  p.x_rot_point = get("x-rot-point", true), p.y_rot_point = get("y-rot-point", true);
  p.z_rot_point = get("z-rot-point", true), p.y_offset = get("y-offset", true);
  p.z_offset = get("z-offset", true), p.tool_offset = get("tool-offset", false);
  return p;
}

std::string RewriteTrtPinsHal(const std::string& text, const TrtPins& pins) {
  ParseTrtPinsHal(text);  // every pin there once, each a number
  const std::map<std::string, double> to = {{"x-rot-point", pins.x_rot_point},
                                            {"y-rot-point", pins.y_rot_point},
                                            {"y-offset", pins.y_offset},
                                            {"z-offset", pins.z_offset}};
  std::string out, line, value;
  std::istringstream lines(text);
  while (std::getline(lines, line)) {
    const auto it = to.find(PinOf(line, &value));
    if (it != to.end()) {
      if (!std::isfinite(it->second)) throw TrunnionError("pins: " + it->first + " not finite");
      char number[64];
      std::snprintf(number, sizeof number, "%.7f", it->second);
      line = "setp " + kPrefix + it->first + " " + number;
    }
    out += line;
    if (!lines.eof()) out += "\n";
  }
  return out;
}

}  // namespace mlp::calib
