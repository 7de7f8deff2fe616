#pragma once
/// @file A job request's text as the host and the macro's client read it, with the limits a
/// hostile peer cannot get past (docs/HOSTD.md, "Limits"): the size of a request line, how deep
/// its JSON nests (nlohmann's parser is iterative, but copying, comparing and printing a value
/// recurse: a 60,000-deep array overflowed the stack), numbers that fit a double, and strings
/// that are UTF-8. Every defect is one typed error with a sentence for the operator, never a
/// bare JSON exception that unwinds through a worker thread.

#include "mlp/base/input_error.h"

#include <cstddef>
#include <stdexcept>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace mlp::service {

/// One request line, at most (with its newline). A request is a small JSON object; a surface
/// patch's vector points go in a file (`vector_points_file`), not in the request.
constexpr std::size_t kMaxRequestBytes = 1u << 20;
/// Nesting depth of a request's JSON, at most: the deepest request the host knows nests 5.
constexpr int kMaxRequestDepth = 32;

class RequestParseError : public base::InputError {
 public:
  using base::InputError::InputError;
};

/// Parses a request's text: a JSON object, nesting at most kMaxRequestDepth deep, numbers within
/// a double's range, strings in UTF-8. Throws RequestParseError naming the defect.
nlohmann::json ParseRequest(std::string_view text);

/// JSON text for a reply or a log line. Bytes that are not UTF-8 (a peer's serial, a file's
/// name) become U+FFFD instead of throwing: a reply or a log line must always be writable.
std::string DumpSafe(const nlohmann::json& j, int indent = -1);

}  // namespace mlp::service
