#pragma once
// The setter's test cases shared by beam_test.cc and trigger_modes_test.cc: the approach, the
// curve from a pin, a processor's configuration, and a signal processed against its truth.

#include "mlp/setter/beam_processor.h"
#include "mlp/setter/beam_signal.h"

namespace mlp::setter::test {

inline Motion Approach(double gap_mm, double duration_s, bool entering = true) {
  Motion m;
  m.feed_mm_min = 6.0, m.gap_mm = gap_mm, m.duration_s = duration_s, m.entering = entering;
  return m;
}

// The curve from a D6 pin driven in from 5 beam radii out, no drops (a calibration is taken
// with the coolant off).
inline CalibrationCurve PinCurve() {
  ToolInBeam pin;
  pin.tooth_radius_mm = {3.0};
  const BeamSignal s = GenerateSignal(BeamModel(), pin, Approach(0.15, 2.5), 1);
  return CalibrateFromPin(s.volts, s.sample_rate_hz, 6.0, true);
}

inline ProcessorConfig Config(const CalibrationCurve& curve, double rpm, int teeth, bool entering) {
  ProcessorConfig c;
  c.rpm = rpm, c.teeth = teeth, c.feed_mm_min = 6.0, c.entering = entering, c.curve = curve;
  return c;
}

struct Outcome {
  bool triggered = false;
  double edge_error_mm = 0, radius_mm = 0, lag_mm = 0;
  int rejections = 0;
};

inline Outcome Process(const BeamSignal& s, const ProcessorConfig& c) {
  BeamProcessor p(c);
  for (float v : s.volts) p.Push(v);
  Outcome r;
  r.triggered = p.Triggered();
  r.rejections = p.RejectionCount();
  if (!r.triggered) return r;
  const Trigger& t = p.trigger();
  // What the control latches at the skip, less the offset: the edge; against the truth.
  r.edge_error_mm = s.AxisAt(static_cast<double>(t.sample)) - t.edge_offset_mm - s.axis_at_edge_mm;
  r.radius_mm = p.ToothRadiusMm();
  for (int k = 0; k < c.teeth; ++k)
    if (k != p.LeadingTooth()) r.lag_mm = p.ToothLagMm(k);
  return r;
}

}  // namespace mlp::setter::test
