#pragma once
/// @file The one base of the "bad input" errors (docs/DEVELOPING.md, "Errors").

#include <stdexcept>

namespace mlp::base {

/// Bad input: a file, a request, a packet or an argument that is missing, malformed or out of
/// range. Every module's input error derives from it (FrameIoError, CaptureIoError, ...), so
/// that a program maps all of them to "bad input, nothing written" in one catch, and an error
/// from a lower module passes through its callers with its own words rather than being caught
/// and re-thrown as each caller's type.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace mlp::base
