#pragma once
/// @file `mlp demo` (program mlp-demo, which `mlp demo` runs): the whole job on the virtual
/// machine. Starts mlp-hostd and a virtual probe (`mlp-sim serve`) on the demo plate
/// (samples/scenes/demo_plate.json), then as an NC program would: hand-eye calibration on the
/// reference sphere, plane-circle-circle alignment -> G54, the bore measured before its
/// finishing pass -> the finishing tool's radius offset; writes the tool table and the result
/// subroutine and prints what it found against the scene's truth.

#include <iosfwd>
#include <string>
#include <vector>

namespace mlp::host {

int RunDemoCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace mlp::host
