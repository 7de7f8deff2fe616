#pragma once
/// @file The probe's acceptance test in the manner of ISO 10360-8 (optical distance sensors), run
/// on the virtual machine through the product's own chain (issue 16, part 4; docs/ACCURACY.md).
///
/// The virtual probe renders with the probe as built (`mlprobe-as-built/1`); the firmware
/// triangulates and the host computes with the calibrated model only, which `mlp calibrate
/// projector` made from that probe's chessboard views. The hand-eye M is calibrated first by the
/// sphere method on a matt reference sphere, as at the machine. Then, for each surface finish:
///  - probing test: a test sphere seen in single views from many orientations and depths, each
///    reading the square window whose corners lie on the cap 65 deg from the view. The sphere's
///    points are those within 1 mm of its nominal place (anything seen past its rim is not the
///    sphere); per view (ISO 10360-8 names, the suffix ::j left out):
///    P_Form.Sph.All   range of the radial residuals of all points about their least-squares
///                     sphere (free radius);
///    P_Form.Sph.D95%  the same after the 5 % of points farthest from that sphere are set aside
///                     (the probing dispersion value);
///    P_Form.Sph.1x25  range of 25 points spread evenly over the measured cap (farthest-point
///                     sampling) about their own least-squares sphere;
///    P_Size.Sph.All / .1x25   fitted diameter minus the sphere's calibrated diameter;
///  - length test, E_Uni: a row of spheres (a ball step gauge) in several orientations of the
///    working volume; each sphere seen in one view from its own direction, its centre mapped to
///    the machine by H M; E = measured minus true centre distance, for each length from the first
///    sphere.
/// Every figure is of the virtual world (its truth known, its machine perfect, no thermal
/// drift): it says what the chain does with the physics the renderer has, not what a real probe
/// achieves.

#include "mlp/geometry/types.h"

#include <cstdint>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace mlp::verify {

/// Unusable options or input files (the message names which); nothing was measured.
class VerifyError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A surface finish under test and the exposure it is measured with.
struct Finish {
  std::string material = "matt_coated";  ///< a named finish (sim::MakeNamedFinish)
  double exposure = 1.0;                 ///< x the model's photometry; dark metal needs more
};

struct AcceptanceOptions {
  std::string as_built_path;    ///< the probe the virtual probe renders with
  std::string calibrated_path;  ///< the model the firmware and the host use
  /// The lens and the laser's coherence of the as-built probe, set here when its file gives none
  /// (or to test another): the speckle grain follows from the f-number (docs/PROBE.md).
  std::optional<double> f_number, speckle_contrast;
  std::vector<Finish> finishes = {{"matt_coated", 1.0}, {"ground_steel", 8.0}};
  double sphere_diameter_mm = 25.4;  ///< test spheres and the reference sphere (calibrated)
  int hand_eye_views = 8;
  int probing_views = 10;       ///< views of the test sphere per finish
  int length_orientations = 7;  ///< of the ball step gauge: X, Y, steep, 4 space diagonals
  int gauge_spheres = 4;        ///< lengths: 1..n-1 times the pitch from the first sphere
  double gauge_pitch_mm = 50.0;
  std::uint64_t seed = 1;
  /// Called before each view is rendered ("hand-eye 3/8", ...): rendering takes seconds.
  std::function<void(const std::string&)> progress;
  void Check() const;  ///< throws VerifyError
};

/// One view of the probing test [um]; form figures are ranges, size figures signed.
struct ProbingView {
  std::string id;
  int points = 0;            ///< on the sphere (the figures' points)
  int set_aside = 0;         ///< the view's other points: beyond 1 mm of the sphere's nominal place
  double standoff_mm = 0.0;  ///< probe origin to the sphere's nearest point
  double tilt_deg = 0.0;     ///< view direction from the vertical
  double form_all_um = 0.0, form_d95_um = 0.0, form_1x25_um = 0.0;
  double size_all_um = 0.0, size_1x25_um = 0.0;
  double rms_um = 0.0;  ///< RMS radial residual of all points: the point scatter
};

/// One length of the length test.
struct LengthError {
  std::string orientation;
  double length_mm = 0.0;  ///< true centre distance
  double error_um = 0.0;   ///< measured minus true, with the calibrated M
  double error_true_m_um =
      0.0;  ///< the same with the true M (the hand-eye's share is the difference)
};

struct FinishResult {
  Finish finish;
  std::vector<ProbingView> views;
  std::vector<LengthError> lengths;
  int gauge_points_set_aside = 0;  ///< gauge views' points beyond 1 mm of their sphere's place
  /// Largest magnitudes over the views / lengths [um].
  double p_form_all_um = 0.0, p_form_d95_um = 0.0, p_form_1x25_um = 0.0;
  double p_size_all_um = 0.0, p_size_1x25_um = 0.0;
  double e_uni_um = 0.0, e_uni_true_m_um = 0.0;
  double dispersion_rms_um = 0.0;  ///< RMS of the views' point scatter
};

struct AcceptanceResult {
  // The hand-eye, through the chain, against the true M in the calibrated probe frame.
  double hand_eye_translation_um = 0.0, hand_eye_rotation_arcsec = 0.0;
  double hand_eye_point_rms_um = 0.0;
  /// How rigidly the calibrated probe frame lies in the true one over the sphere's window (RMS
  /// after the best rigid fit, sim::TrueFromModelFrame): the calibration's own error there.
  double calibration_frame_rms_um = 0.0;
  double speckle_contrast = 0.0, f_number = 0.0, grain_px = 0.0;  ///< as rendered
  /// The fundamental depth scatter of laser triangulation under that speckle, on the optical
  /// axis at 120 mm (Dorsch, Haeusler, Herrmann, Appl. Opt. 33(7):1306, 1994): C lambda /
  /// (2 pi sin u_obs sin theta). 0 without a lens.
  double dorsch_limit_um = 0.0;
  std::vector<FinishResult> finishes;
};

/// Runs the whole test. Throws VerifyError (bad options or files) or the chain's own errors
/// (a calibration that does not converge is a finding, not a result).
AcceptanceResult RunAcceptance(const AcceptanceOptions& options);

}  // namespace mlp::verify
