#pragma once
/// @file The SHA-256 of a file (OpenSSL), how the history pins a cloud file to a job. Its own
/// library: `mlp` reads the history without loading libcrypto.

#include "mlp/history/history.h"

#include <string>

namespace mlp::history {

/// Lower-case hex. Throws HistoryError when the file cannot be read.
std::string Sha256OfFile(const std::string& path);
/// Lower-case hex of the bytes of `text`.
std::string Sha256OfText(const std::string& text);

}  // namespace mlp::history
