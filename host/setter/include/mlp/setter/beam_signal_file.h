#pragma once
/// @file The beam signal on disk, read and written here only (docs/SETTER.md):
/// `mlprobe-beam-signal/1` is a header line `# mlprobe-beam-signal/1 sample_rate_hz=H`, then
/// one voltage a line (`#` lines are comments); a generated signal's truth goes beside it as
/// `mlprobe-beam-truth/1` JSON.
/// `mlprobe-beam-signal/2` is what a real setter's logger writes: a header line
/// `# mlprobe-beam-signal/2 sample_rate_hz=H adc_bits=B full_scale_v=V [amplifier_hz=A]`,
/// a line `# columns: ...` naming the columns (from t_s, code, volts, axis_mm, latch, index;
/// code or volts required), then one sample a line. Timestamps must step by 1/H (within 2 %):
/// a lost sample is refused, never closed up; codes must fit the ADC's bits.

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
