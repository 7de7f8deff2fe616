#pragma once
/// @file Camera and MEMS projector calibrated together (seed 004 step 3: the projector as an
/// inverse camera). Views of a planar chessboard give, per view, the board's corners in the
/// camera image (LED frame) and laser stripe points on the board (laser frames at known
/// projector columns). One least-squares problem (Ceres) holds the camera intrinsics and
/// distortion, the projector's focal length, centre column and pose relative to the camera, and
/// every board pose:
///   corner residual  = projected board corner - detected corner            [px]
///   stripe residual  = column of the point where the pixel's ray meets the board - column lit
/// so the projector's planes are fitted to where the laser really fell, and errors of the
/// camera that the board poses absorb are not paid twice.

#include "mlp/calib/camera_calib.h"
#include "mlp/probe_fw/probe_model.h"

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

namespace mlp::calib {

struct ProjectorParams {
  double f_px = 0.0, c_px = 0.0;
  geometry::Pose3 camera_from_projector = geometry::Pose3::Identity();
  /// The mirror's cubic and the sheet's smile [columns] (probe_model.h, ProjectorModel),
  /// estimated when the mirror's range `columns` is given (from the design; fixed, with the
  /// fan's half angle), held otherwise.
  double mirror_cubic_cols = 0.0, sheet_smile_cols = 0.0;
  int columns = 0;
  double fan_half_angle_deg = 25.0;
  /// Continuous column lighting a point given in the camera frame.
  double ColumnOf(const geometry::Vec3& point_in_camera) const;
};

/// A stripe centre found in view `view`: sensor pixel and the projector column lit.
struct StripeObservation {
  int view = 0;
  double x_px = 0.0, y_px = 0.0;
  double column = 0.0;
};

struct ProbeCalibInput {
  ChessboardSpec board;
  /// Per view: the board's inner corners in board order (empty: the board was not found).
  std::vector<std::vector<geometry::Vec2>> corners;
  std::vector<StripeObservation> stripes;
  Intrinsics camera_start;                               ///< e.g. from CalibrateCamera
  ProjectorParams projector_start;                       ///< e.g. the design values
  std::vector<geometry::Pose3> camera_from_board_start;  ///< per view
  /// The mirror's cubic and the smile are kept only when the views determine them to this
  /// (1-sigma, columns at the range's ends and at the field's edge): views whose stripes stay in
  /// the middle of the mirror's range extrapolate a cubic to its ends.
  double max_term_std_cols = 0.05;
};

struct ProbeCalibResult {
  Intrinsics camera;
  ProjectorParams projector;
  std::vector<geometry::Pose3> camera_from_board;
  double corner_rms_px = 0.0, stripe_rms_columns = 0.0;
  int views_used = 0, corners_used = 0, stripes_used = 0, iterations = 0;
  /// 1-sigma of the mirror's cubic at the range's ends and of the smile at the camera's field
  /// edge [columns] (0 when not estimated). Above ProbeCalibInput's limit a term is held at its
  /// start value (the design's), and `notes` says so.
  double mirror_cubic_std_cols = 0.0, smile_std_cols = 0.0;
  std::vector<std::string> notes;
};

/// Throws CameraCalibError when the data cannot determine the model (fewer than 4 views with a
/// board, no stripes, no convergence).
ProbeCalibResult AdjustCameraAndProjector(const ProbeCalibInput& input);

/// The probe model the firmware reads: `design` (sensor size, bit depth, projector columns,
/// laser and noise) with the calibrated camera and projector, `calibration_id` and the fit's
/// statistics. Throws
/// probe_fw::ProbeModelError when the result is out of the format's ranges.
probe_fw::ProbeModel CalibratedProbeModel(const probe_fw::ProbeModel& design,
                                          const ProbeCalibResult& result,
                                          const std::string& calibration_id);

/// Whether a stripe point at sensor pixel (x_px, y_px) can be used: the LED frame is light and
/// uniform over +-8 px along its row. A checker edge inside the stripe's centroid window shifts
/// the centre towards the light square (reflectance changes by 10x there).
bool OnUniformLight(const GrayImage& led, double x_px, int y_px);

/// Whether a pixel lies inside the quadrilateral of a view's outer inner corners (board order;
/// none found: false). The board's plane is known there; beyond, a stripe may fall on the
/// board's margin or its sides, which a sweep over the whole board lights.
bool InsideTheCorners(const std::vector<geometry::Vec2>& corners,
                      const ChessboardSpec& board,
                      double x_px,
                      double y_px);

struct ProbeCalibReport {
  CameraCalibration camera_start;  ///< OpenCV's camera-only calibration, the start
  ProbeCalibResult result;         ///< the joint adjustment
  std::size_t stripes_found = 0, stripes_on_light = 0;
  int stripe_stride = 1;  ///< every n-th usable stripe point entered the adjustment
};

/// The whole camera/projector calibration: camera start from OpenCV (Zhang), projector start
/// from the design, stripe points on uniform light (thinned to at most 15,000: ~1,000 per view
/// determine the projector's 8 parameters far beyond their noise), one joint adjustment.
/// `stripes[k].view` indexes `leds`. `progress` (may be empty) gets a line per stage.
/// Throws CameraCalibError.
ProbeCalibReport CalibrateProbe(const std::vector<GrayImage>& leds,
                                const std::vector<StripeObservation>& stripes,
                                const ChessboardSpec& board,
                                const probe_fw::ProbeModel& design,
                                const std::function<void(const std::string&)>& progress = {});

/// Inner corners per image in board order (what CalibrateCamera uses).
std::vector<std::vector<geometry::Vec2>> DetectCorners(const std::vector<GrayImage>& images,
                                                       const ChessboardSpec& board);

}  // namespace mlp::calib
