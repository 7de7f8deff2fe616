// libFuzzer target for the job socket's request parser (issue 24): any bytes give a parsed
// object within the limits or a RequestParseError, never another exception, a crash, a stack
// overflow or a leak; what parses prints (DumpSafe) and parses back to the same value.
// Built and run by scripts/fuzz-link.sh.

#include "mlp/service/request_json.h"

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const nlohmann::json request = mlp::service::ParseRequest(text);
    if (!request.is_object()) std::abort();
    const std::string printed = mlp::service::DumpSafe(request);
    if (mlp::service::ParseRequest(printed) != request) std::abort();
  } catch (const mlp::service::RequestParseError&) {
    // a typed refusal is the other allowed outcome
  }
  return 0;
}
