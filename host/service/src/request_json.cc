#include "mlp/service/request_json.h"

#include "mlp/base/json_text.h"

namespace mlp::service {
namespace {

using json = nlohmann::json;

// Thrown from the parser's callback to stop at the first level too deep; caught below.
struct TooDeep {};

}  // namespace

json ParseRequest(std::string_view text) {
  if (text.size() > kMaxRequestBytes)
    throw RequestParseError("the request is " + std::to_string(text.size()) +
                            " bytes long; at most " + std::to_string(kMaxRequestBytes) +
                            " are taken");
  // The callback sees every value with its depth before the value is built: a deep array is
  // refused at its 33rd bracket, not after a million.
  const json::parser_callback_t depth_guard = [](int depth, json::parse_event_t, json&) {
    if (depth > kMaxRequestDepth) throw TooDeep{};
    return true;
  };
  json j;
  try {
    j = json::parse(text.begin(), text.end(), depth_guard);
  } catch (const TooDeep&) {
    throw RequestParseError("the request nests deeper than " + std::to_string(kMaxRequestDepth) +
                            " levels");
  } catch (const json::out_of_range& e) {
    // nlohmann reports a number beyond a double's range (1e400) here, not as a parse error.
    throw RequestParseError(std::string("the request holds a number out of range: ") + e.what());
  } catch (const json::exception& e) {
    throw RequestParseError(std::string("the request is not JSON: ") + e.what());
  }
  if (!j.is_object()) throw RequestParseError("the request must be a JSON object with an \"op\"");
  return j;
}

std::string DumpSafe(const json& j, int indent) { return base::json_fields::DumpText(j, indent); }

}  // namespace mlp::service
