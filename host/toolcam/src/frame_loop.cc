#include "mlp/toolcam/frame_loop.h"

#include "mlp/base/units.h"

#include <cmath>

namespace mlp::toolcam {

using geometry::Pose3;
using geometry::Vec2;
using geometry::Vec3;

Pose3 FrameLoop::DetectorFromTool() const {
  // Round the loop from the detector: 24 -> 18 -> 20 (14C) -> 10 (14B) -> 12 -> 22.
  const Pose3 support_moved = Pose3(Eigen::Translation3d(encoder_z_mm * support_travel));
  const Pose3 carriage_moved = Pose3(Eigen::Translation3d(encoder_y_mm * carriage_travel));
  const Pose3 chuck_from_tool = Pose3(Eigen::Translation3d(0, 0, -tool_length_mm));
  return structure_from_detector.inverse() * support_moved * structure_from_support *
         carriage_moved * support_from_carriage * carriage_from_chuck * chuck_from_tool;
}

Pose3 FrameLoop::DetectorFromModel() const {
  return DetectorFromTool() *
         Pose3(Eigen::Translation3d(0, model_change_mm.x(), model_change_mm.y()));
}

ToolCameraModel CameraThroughLoop(const FrameLoop& loop, const ToolCameraModel& base) {
  const Pose3 d = loop.DetectorFromModel();
  ToolCameraModel c = base;
  const Vec3 tip = d.translation(), axis = d.linear().col(2);
  c.axis_u_px = tip.y() / base.mm_per_px;
  c.tip_v_px = -tip.z() / base.mm_per_px;
  // The spindle axis seen in the image: turned by the roll (tool_camera.h: leaning right going
  // down for roll > 0, i.e. its upward direction to the left).
  c.roll_deg = std::atan2(-axis.y(), axis.z()) * base::kDegPerRad;
  return c;
}

Vec2 AllowedChange(const FrameLoop& loop, const Vec2& image_shift_mm) {
  // The tool's y and z directions in the image plane: the change's image is a (dy, dz).
  const Eigen::Matrix3d r = loop.DetectorFromTool().linear();
  Eigen::Matrix2d a;
  a << r(1, 1), r(1, 2), r(2, 1), r(2, 2);
  if (std::abs(a.determinant()) < 0.1)
    throw ToolInputError(
        "frame loop: the tool's y-z plane is seen edge on: the change would not show");
  return a.inverse() * image_shift_mm;
}

double LoopGapMm(const FrameLoop& loop, const ToolCameraModel& base, const Vec2& seen_px) {
  const ToolCameraModel c = CameraThroughLoop(loop, base);
  return Vec2(seen_px.x() - c.axis_u_px, seen_px.y() - c.tip_v_px).norm() * base.mm_per_px;
}

}  // namespace mlp::toolcam
