#pragma once
/// @file A camera with a fixed line laser (issue 18): one light plane instead of a MEMS mirror's
/// many. From images that show a flat chessboard and the laser line on it:
///   1. corners: OpenCV's detector on the board's view, at full, half and quarter resolution
///      (a defocused board is found at a coarser scale), refined at full resolution with a window
///      as wide as the squares allow (a blurred corner needs many edge pixels);
///   2. the camera: Zhang's method (CalibrateCamera's model, OpenCV);
///   3. laser stripes: the firmware's own extractor (probe_fw/stripe.h) on the laser's view;
///   4. the light plane: each stripe pixel's ray meets its image's board plane; one plane fitted
///      through all those points (MSAC + trimming, geometry/robust.h).
/// The result is a probe model whose projector has one column (ProjectorModel, columns = 1): the
/// firmware triangulates with it unchanged.

#include "mlp/calib/camera_calib.h"
#include "mlp/calib/robot_views.h"
#include "mlp/geometry/types.h"
#include "mlp/probe_fw/probe_model.h"

#include <functional>
#include <string>
#include <vector>

namespace mlp::calib {

/// What one image showed.
struct ImageFindings {
  std::string name;
  int width_px = 0, height_px = 0;
  std::vector<geometry::Vec2> corners;            ///< board order; empty: no board
  double corner_scale = 0.0;                      ///< resolution it was found at (1, 0.5, 0.25)
  std::vector<geometry::Vec2> stripe_px;          ///< stripe centres, distorted sensor pixels
  std::vector<float> stripe_quality;              ///< 0..1 per centre (the firmware's)
  int stripe_saturated = 0, stripe_rejected = 0;  ///< candidates the firmware refused
  /// Why the image adds nothing, or "" (a board, or a laser line, or both).
  std::string refused;
  bool HasBoard() const { return !corners.empty(); }
  bool HasLaser() const { return stripe_px.size() >= kMinStripePoints; }
  static constexpr size_t kMinStripePoints = 50;
};

/// Reads every image (colour, through the manifest's channel weights) and finds its board and
/// laser line. `progress` (may be empty) gets a line per image. Throws CaptureIoError when an
/// image cannot be read.
std::vector<ImageFindings> FindInImages(
    const RobotViews& views, const std::function<void(const std::string&)>& progress = {});

/// Stripe-centre scatter about a straight line [px]: the centres undistorted (a straight line
/// on a flat board is straight only without the lens' distortion), a line fitted with
/// trimming at 3 sigma (the laser leaving the board for the table bends it).
struct StripeScatter {
  double rms_px = 0.0;
  int points = 0, trimmed = 0;
};
StripeScatter ScatterAboutLine(const std::vector<geometry::Vec2>& stripe_px,
                               const Intrinsics& camera);

struct LineLaserCalibration {
  CameraCalibration camera;       ///< views_used index into the images with a board
  std::vector<int> board_images;  ///< index into the findings of each calibration view
  geometry::Plane plane;          ///< the light plane in the camera frame [mm]
  double plane_rms_mm = 0.0, plane_max_mm = 0.0;  ///< its inliers' distances
  int plane_points = 0, plane_inliers = 0;
  /// Per calibration view: stripe scatter about a straight line.
  std::vector<StripeScatter> scatter;
  double scatter_rms_px = 0.0;     ///< over all views' points
  std::vector<std::string> notes;  ///< views refused and why
};

/// Camera and light plane. A view whose corners fit the camera model worse than 3 x the median
/// view (blur, the laser over the corners) is refused and the camera re-fitted without it.
/// Throws CameraCalibError (fewer than 4 boards, no laser on any board).
LineLaserCalibration CalibrateLineLaser(const std::vector<ImageFindings>& images,
                                        const ChessboardSpec& board,
                                        int width_px,
                                        int height_px);

/// The same for a probe model calibrated already (a fixed line laser: one column), as the board
/// hand-eye needs it: the model's camera and light plane; each board image's pose by PnP with
/// that camera, views refused as above; the plane's residuals on these images' boards (inliers
/// within 2.5 robust sigma). Throws CameraCalibError (no board, too few laser points, a
/// projector with more than one column).
LineLaserCalibration LineLaserOfModel(const std::vector<ImageFindings>& images,
                                      const probe_fw::ProbeModel& model,
                                      const ChessboardSpec& board);

/// Calibrated intrinsics of the firmware's camera model, and back.
Intrinsics IntrinsicsOf(const probe_fw::CameraModel& camera);
/// The firmware's camera model of calibrated intrinsics (for its Newton undistortion).
probe_fw::CameraModel CameraModelOf(const Intrinsics& camera);

/// The light plane as the probe model's projector: one column (0), the projector frame's x axis
/// along the plane's normal, its origin the plane's point nearest the camera.
probe_fw::ProjectorModel OnePlaneProjector(const geometry::Plane& plane_in_camera);

/// The firmware's probe model: `design` (serial, sensor, laser and noise) with the calibrated
/// camera and the plane. Throws probe_fw::ProbeModelError.
probe_fw::ProbeModel LineLaserProbeModel(const probe_fw::ProbeModel& design,
                                         const Intrinsics& camera,
                                         const geometry::Plane& plane_in_camera,
                                         const std::string& calibration_id);

}  // namespace mlp::calib
