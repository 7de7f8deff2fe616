#pragma once
/// @file The beam signal on disk, read and written here only (docs/SETTER.md):
/// `mlprobe-beam-signal/1` is a header line `# mlprobe-beam-signal/1 sample_rate_hz=H`, then
/// one voltage a line (`#` lines are comments); a generated signal's truth goes beside it as
/// `mlprobe-beam-truth/1` JSON.

#include "mlp/setter/beam_signal.h"

#include <string>

namespace mlp::setter {

/// The signal as `mlprobe-beam-signal/1` text (7 significant digits, float's precision).
std::string BeamSignalText(const BeamSignal& s);

/// Reads `mlprobe-beam-signal/1` text; throws SetterInputError naming `where` and the line. Only
/// the sample rate and the voltages are filled.
BeamSignal ParseBeamSignal(const std::string& text, const std::string& where);

/// The truth of a generated signal (`mlprobe-beam-truth/1`): where the axis was, and the drops.
std::string BeamTruthJson(const BeamSignal& s);

}  // namespace mlp::setter
