#pragma once
/// @file CSV as spreadsheets and SPC tools read it (RFC 4180).

#include <string>
#include <string_view>

namespace mlp::base {

/// One field: as it is, or quoted with its quotes doubled when it holds a comma, a quote or a
/// line break (RFC 4180 section 2).
inline std::string CsvField(std::string_view text) {
  if (text.find_first_of(",\"\r\n") == std::string_view::npos) return std::string(text);
  std::string out = "\"";
  for (char c : text) out.append(c == '"' ? 2 : 1, c);
  return out.append(1, '"');
}

}  // namespace mlp::base
