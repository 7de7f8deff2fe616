#include "mlp/base/clock.h"

#include <chrono>
#include <cstdio>
#include <ctime>

namespace mlp::base {

std::string UtcNow(const char* strftime_format, bool millis) {
  const auto now = std::chrono::system_clock::now();
  const std::time_t seconds = std::chrono::system_clock::to_time_t(now);
  std::tm tm{};
  gmtime_r(&seconds, &tm);
  char buf[64];
  std::strftime(buf, sizeof buf, strftime_format, &tm);
  std::string out = buf;
  if (millis) {
    const auto ms =
        std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()) % 1000;
    char frac[8];
    std::snprintf(frac, sizeof frac, ".%03dZ", static_cast<int>(ms.count()));
    out += frac;
  }
  return out;
}

std::string UtcTimestamp() { return UtcNow("%Y-%m-%dT%H:%M:%S", true); }

}  // namespace mlp::base
