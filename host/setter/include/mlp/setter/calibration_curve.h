#pragma once
/// @file The setter's calibration curve (seed 003): the receiver's voltage against how far an
/// edge reaches into the beam, from a pin driven in at a known feed. Intrusion x [mm] is counted
/// from where the pin blocked half the light (the beam's centre) along the approach; shares are
/// of the clear level. `mlprobe-beam-curve/2` keeps it as a table over the whole fall, from
/// where the light falls under the clear level after the rise (the wing) to 2 % of it, with the
/// pin, feed, sample rate, the beam's radius, date, serial and uncertainty; `/1` (a cubic over 90 %
/// to 10 %) is still read. A table and not a model: no low-order curve follows the rise's wing, the
/// Gaussian's fall and its foot together, and the fringes move the half-light point off the beam's
/// centre.

#include <string>
#include <vector>

namespace mlp::setter {

struct CalibrationCurve {
  double clear_v = 0.0;             ///< the receiver with the beam clear, during the calibration
  double lo_mm = 0.0, hi_mm = 0.0;  ///< the fitted span of x (shares from 90 % down to 10 %)
  double c[4] = {0, 0, 0, 0};       ///< share = c0 + c1 x + c2 x^2 + c3 x^3
  double rms = 0.0;                 ///< of the fit, share of clear
  int samples = 0;                  ///< fitted
  /// The rise p before blocking (rise.h): its height above clear (share; 0: none seen) and
  /// its peak's intrusion (mm, negative: before the beam's centre).
  double rise_share = 0.0, rise_mm = 0.0;
  /// /2: the shares at x = table_x0_mm + i table_step_mm, falling strictly (the pin's samples
  /// binned, then made monotonic); empty for a /1 cubic. Share, Slope and IntrusionAt use it.
  double table_x0_mm = 0.0, table_step_mm = 0.0;
  std::vector<double> table;
  /// What the curve was made from and how well it is known (/2; 0 or empty where unknown).
  double feed_mm_min = 0.0, sample_rate_hz = 0.0, pin_diameter_mm = 0.0;
  double beam_radius_mm = 0.0;   ///< 1/e^2, as a Gaussian's 10-90 % width / 1.2816
  double half_light_u_mm = 0.0;  ///< the half-light point's standard uncertainty
  std::string date_utc, serial;

  double Share(double x_mm) const;
  double Slope(double x_mm) const;  ///< dShare/dx [1/mm]
  /// The intrusion at which the curve passes `share` (inside [lo, hi]; clamped to them).
  double IntrusionAt(double share) const;
  double ShareLo() const { return Share(hi_mm); }  ///< the deepest share fitted (10 %)
  double ShareHi() const { return Share(lo_mm); }  ///< the shallowest (90 %)
};

/// The curve from a pin's signal: the clear level (the median of the first 20 ms entering,
/// the last leaving), the half-light crossing, x = feed x time from it, a cubic through the
/// samples between 90 % and 10 %. Throws SetterError when the pin never blocks half the beam,
/// or the curve is not monotonic over its span; SetterInputError without a sample rate, a feed
/// or 80 ms of signal. `reflective`: the receiver sees the pin's reflection; the level is the
/// full reflection (the pin all in: the last 20 ms entering) and the shares 1 - volts / level,
/// as BeamProcessor reads a reflective setter. A transmissive setter's rise p (a bump over
/// 6 times the averaged noise before the fall) is found and kept with the curve. The table
/// (/2) spans the fall from the last 100 % after the rise (or 99.5 % without one) to 2 %.
CalibrationCurve CalibrateFromPin(const std::vector<float>& volts,
                                  double sample_rate_hz,
                                  double feed_mm_min,
                                  bool entering,
                                  bool reflective = false);

std::string CurveJson(const CalibrationCurve& c);
/// Throws SetterInputError naming `where` (the file) and the field.
CalibrationCurve ParseCurve(const std::string& json_text, const std::string& where = "curve");

}  // namespace mlp::setter
