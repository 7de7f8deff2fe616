#pragma once
/// @file `mlp verify` (program mlp-verify, which `mlp verify` runs): the probe's acceptance test
/// in the manner of ISO 10360-8 on the virtual machine, through the calibrated chain
/// (mlp/verify/acceptance.h, docs/ACCURACY.md). Prints each test against its maximum permissible
/// error; exit 0 when every figure is within it, 3 when one is not.

#include <iosfwd>
#include <string>
#include <vector>

namespace mlp::host {

int RunVerifyCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace mlp::host
