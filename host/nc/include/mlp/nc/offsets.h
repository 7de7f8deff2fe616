#pragma once
/// @file Offset changes as a controller receives them: tool offset registers (length / radius,
/// geometry / wear) and work offsets (G54..G59 and the extended ones), each with the value
/// before and after, in mm and degrees. What the adapters write and the history stores.

#include <optional>
#include <string>

namespace mlp::nc {

/// The last three are a tool's offsets across the spindle and its turn (LinuxCNC's tool table X,
/// Y, C, applied by G43; an EDM electrode put back after re-clamping): LinuxCNC only.
enum class ToolRegister {
  kLengthGeometry,
  kLengthWear,
  kRadiusGeometry,
  kRadiusWear,
  kOffsetX,
  kOffsetY,
  kOffsetC
};

/// "length geometry", "radius wear", "offset X", ...
std::string ToString(ToolRegister r);
/// The register ToString names; empty for any other text.
std::optional<ToolRegister> ToolRegisterFrom(const std::string& text);
/// The tool table's word of an offset register ('X', 'Y', 'C'); 0 for the others.
char OffsetWord(ToolRegister r);

struct ToolOffsetChange {
  int tool = 0;  ///< offset number (H/D number; LinuxCNC: the tool number)
  ToolRegister reg = ToolRegister::kLengthGeometry;
  /// The register's value; radius registers hold radii, kOffsetC degrees.
  double before_mm = 0.0, after_mm = 0.0;
  /// The value before is not known here (it lives in the control): the change after - before
  /// is written as an increment (G91 G10, or #var = #var + change).
  bool incremental = false;
};

/// Work offset index: 1..6 = G54..G59; 7 and up = the extended offsets, number index - 6
/// (G54.1 P1 on Fanuc and LinuxCNC's G59.3 is not one of them: LinuxCNC has 9 offsets, G54..G59.3).
struct WorkOffsetChange {
  int index = 1;
  double before_mm[3] = {0, 0, 0}, after_mm[3] = {0, 0, 0};  ///< X Y Z
  /// Rotation about Z [deg], where the controller keeps one with the offset (LinuxCNC: R).
  std::optional<double> rotation_before_deg, rotation_after_deg;
  /// Which of X Y Z are written (a bore's centre moves X and Y, a face Z).
  bool axes[3] = {true, true, true};
  /// The values before live in the control: the shift after - before is added there
  /// (LinuxCNC: G10 L2 with the offset's own parameters, #5221...; Fanuc-style: G91 G10, or
  /// #var = #var + shift).
  bool incremental = false;
};

}  // namespace mlp::nc
