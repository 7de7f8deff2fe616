#pragma once
/// @file Wall-clock time as the project writes it in records and logs: UTC, ISO 8601.

#include <string>

namespace mlp::base {

/// The time now in UTC, as `strftime_format` says, with ".mmmZ" (milliseconds) appended when
/// `millis`: records made within one second still sort in the order they were made.
std::string UtcNow(const char* strftime_format, bool millis);

/// The time now as "2026-11-26T08:30:12.345Z" (ISO 8601, UTC, milliseconds): log lines, records.
std::string UtcTimestamp();

}  // namespace mlp::base
