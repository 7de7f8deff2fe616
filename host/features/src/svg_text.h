#pragma once
// Text put into an SVG (a feature's or a tool's name from a request): XML's five characters
// escaped. Shared by the deviation report and the run chart (not installed).

#include <string>

namespace mlp::features {

inline std::string SvgText(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '<')
      out += "&lt;";
    else if (c == '>')
      out += "&gt;";
    else if (c == '&')
      out += "&amp;";
    else if (c == '"')
      out += "&quot;";
    else if (c == '\'')
      out += "&apos;";
    else
      out += c;
  }
  return out;
}

}  // namespace mlp::features
