#pragma once
/// @file Offset changes as NC code a control runs: LinuxCNC (a subroutine of G10 lines and global
/// named parameters, called by the probing macro after its M-code), and Fanuc / Haas / Syntec
/// style controls (G10 lines or macro-variable assignments, per-machine variable map).

#include "mlp/nc/offsets.h"

#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace mlp::nc {

class NcOutputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class Dialect { kLinuxCnc, kFanuc, kHaas, kSyntec };

/// How one machine takes offsets. Presets (FanucMap, HaasMap, SyntecMap) hold the controls'
/// documented defaults; machines differ (options, parameters): check against the machine's
/// manual and override in the machine's config.
struct NcMap {
  Dialect dialect = Dialect::kFanuc;
  bool use_variables = false;  ///< false: G10 lines; true: #var = value assignments
  /// First variable of each tool register (offset 1); offset n is base + n - 1.
  int length_geometry_var = 0, length_wear_var = 0, radius_geometry_var = 0, radius_wear_var = 0;
  int max_offset = 200;             ///< highest offset number the variables cover
  bool radius_as_diameter = false;  ///< the D register holds a diameter (Haas setting 40, Syntec)
  int work_var = 5221, work_stride = 20;                    ///< G54 X; G55 X = G54 X + stride
  int extended_work_var = 7001, extended_work_stride = 20;  ///< first extended offset's X
  int max_extended_work = 48;
  int rotation_var = 0;  ///< variable for a work rotation [deg] the macro applies (0: none)
};

NcMap FanucMap();   ///< 0i/30i tool memory C: #11001 #10001 #13001 #12001, radius; G54.1 P1..48
NcMap HaasMap();    ///< NGC: #2001 #2201 #2401 #2601, diameter; G154 P1..99
NcMap SyntecMap();  ///< G10 L10-L13 (L12/L13 take diameters); variables: configure per machine

/// "G54", "G59", "G54.1 P3" (Fanuc, Syntec), "G154 P3" (Haas); LinuxCNC: G54..G59, G59.1..G59.3.
std::string WorkOffsetName(Dialect dialect, int index);

struct NcResult {
  std::vector<ToolOffsetChange> tools;
  std::vector<WorkOffsetChange> work;
  /// Global named parameters for the macro's own decisions (LinuxCNC `#<_mlp_name>`); on the
  /// other dialects, numbered variables given in `numbered`.
  std::map<std::string, double> named;
  std::map<int, double> numbered;
  std::string header;  ///< one comment line: job id, feature, time
};

/// LinuxCNC: `o<name> sub` ... `o<name> endsub` + `M2`, to be called with `o<name> call` after
/// the M-code (and `M66 E0 L0`). Tool changes as `G10 L1 P<tool> Z<length> R<radius>` (LinuxCNC
/// has no wear registers: throws for them), work offsets as `G10 L2 P<n> X Y Z [R]`.
std::string LinuxCncSubroutine(const std::string& name, const NcResult& result);

/// Fanuc / Haas / Syntec: G10 L10..L13 / L2 / L20 lines in G90, or variable assignments. Throws
/// NcOutputError for an offset number or work offset the map does not cover.
std::string FanucStyleSnippet(const NcMap& map, const NcResult& result);

}  // namespace mlp::nc
