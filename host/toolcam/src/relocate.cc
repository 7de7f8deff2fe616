#include "mlp/toolcam/relocate.h"

#include "mlp/base/units.h"
#include "mlp/toolcam/measure.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>

#include <Eigen/Geometry>
#include <Eigen/QR>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace mlp::toolcam {
namespace {

using geometry::Vec2;
using geometry::Vec3;
using Motion = Eigen::Matrix<double, 6, 1>;  // rotation vector [rad], translation [mm]

Eigen::Matrix3d Rotation(const Vec3& rotation_rad) {
  const double angle = rotation_rad.norm();
  if (angle == 0.0) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, rotation_rad / angle).toRotationMatrix();
}

Eigen::Matrix3d TurnZ(double turn_rad) {
  return Eigen::AngleAxisd(turn_rad, Vec3::UnitZ()).toRotationMatrix();
}

// Where the camera's ray through tool-frame (y, h) (along +x of the turned chuck frame) first
// meets the electrode: its face (0 -x, 1 +x, 2 -y, 3 +y, 4 the end), the face's own
// coordinates (across, up) and the ray's depth x.
struct Hit {
  int face = 0;
  Vec2 on_face{0, 0};
  double depth_mm = 0;
};

// The slab method (Kay and Kajiya 1986) against |x| <= a, |y| <= b, z >= 0 in the electrode's
// frame.
std::optional<Hit> CastRay(
    const ToolDescription& e, const ClampPose& pose, double turn_rad, double y, double h) {
  const Eigen::Matrix3d back = Rotation(pose.rotation_rad).transpose() * TurnZ(-turn_rad);
  const Vec3 o =
      back * Vec3(0, y, h) - Rotation(pose.rotation_rad).transpose() * pose.translation_mm;
  const Vec3 d = back * Vec3::UnitX();
  const double half[2] = {e.section_mm[0] / 2, e.section_mm[1] / 2};
  double enter = -1e300, leave = 1e300;
  int face = -1;
  for (int axis = 0; axis < 2; ++axis) {
    if (std::abs(d[axis]) < 1e-15) {
      if (std::abs(o[axis]) > half[axis]) return std::nullopt;
      continue;
    }
    double t0 = (-half[axis] - o[axis]) / d[axis], t1 = (half[axis] - o[axis]) / d[axis];
    int f = 2 * axis;  // entering through the -side
    if (t0 > t1) std::swap(t0, t1), f = 2 * axis + 1;
    if (t0 > enter) enter = t0, face = f;
    leave = std::min(leave, t1);
  }
  if (std::abs(d.z()) > 1e-15) {  // the end: z >= 0
    const double t = -o.z() / d.z();
    if (d.z() > 0 && t > enter) enter = t, face = 4;
    if (d.z() < 0) leave = std::min(leave, t);
  } else if (o.z() < 0) {
    return std::nullopt;
  }
  if (!(enter < leave) || face < 0) return std::nullopt;
  const Vec3 p = o + enter * d;
  Hit hit;
  hit.face = face, hit.depth_mm = enter;
  hit.on_face = face < 2 ? Vec2(p.y(), p.z()) : face < 4 ? Vec2(p.x(), p.z()) : Vec2(p.x(), p.y());
  return hit;
}

// splitmix64 (Steele, Lea and Flood 2014): a node's value from its place, no table.
double NodeValue(unsigned seed, int face, long i, long j) {
  std::uint64_t z = (static_cast<std::uint64_t>(seed) << 40) ^
                    (static_cast<std::uint64_t>(face) << 56) ^
                    (static_cast<std::uint64_t>(i) * 0x9E3779B97F4A7C15ULL) ^
                    (static_cast<std::uint64_t>(j) * 0xC2B2AE3D27D4EB4FULL);
  z += 0x9E3779B97F4A7C15ULL;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  z ^= z >> 31;
  return static_cast<double>(z >> 11) * 0x1.0p-53;
}

// Value noise: the grid's node values blended with smoothstep weights, in [0, 1].
double Albedo(const TextureCamera& c, const Hit& hit) {
  const double s = hit.on_face.x() / c.texture_cell_mm, t = hit.on_face.y() / c.texture_cell_mm;
  const double fs = std::floor(s), ft = std::floor(t);
  const auto i = static_cast<long>(fs), j = static_cast<long>(ft);
  const auto smooth = [](double x) { return x * x * (3 - 2 * x); };
  const double ws = smooth(s - fs), wt = smooth(t - ft);
  const auto v = [&](long di, long dj) {
    return NodeValue(c.texture_seed, hit.face, i + di, j + dj);
  };
  return (1 - wt) * ((1 - ws) * v(0, 0) + ws * v(1, 0)) + wt * ((1 - ws) * v(0, 1) + ws * v(1, 1));
}

constexpr int kRounds = 3;

void CheckSeries(const TextureSeries& ref, const TextureSeries& after, const ToolDescription& e) {
  if (!e.electrode) throw ToolInputError("relocate: the description is not an electrode");
  if (ref.frames.size() != ref.turn_deg.size() || after.frames.size() != after.turn_deg.size())
    throw ToolInputError("relocate: a series has not one turn per image");
  if (ref.turn_deg.size() != after.turn_deg.size())
    throw ToolInputError("relocate: the series have different numbers of images");
  for (size_t k = 0; k < ref.turn_deg.size(); ++k)
    if (std::abs(base::WrapDeg(ref.turn_deg[k] - after.turn_deg[k])) > 1e-6)
      throw ToolInputError("relocate: image " + std::to_string(k) +
                           " was taken at another turn in each series");
  const auto size = [](const ToolCameraModel& c) {
    return static_cast<size_t>(c.width_px) * static_cast<size_t>(c.height_px);
  };
  for (const auto* s : {&ref, &after})
    for (const auto& f : s->frames)
      if (f.size() != size(s->camera))
        throw ToolInputError("relocate: an image's size is not its camera's");
}

// One patch: the surface point at its centre in the turned chuck frame at the reference, the
// turn, and how far the texture there moved across and up [mm].
struct PatchShift {
  Vec3 at{0, 0, 0};
  double turn_rad = 0;
  Vec2 moved{0, 0};
};

// Where the motion `p` (rotation vector, translation) puts a patch's point, across and up,
// less where it was.
Vec2 Predicted(const Motion& p, const PatchShift& s) {
  const Eigen::Matrix3d turn = TurnZ(s.turn_rad);
  const Vec3 moved =
      turn * (Rotation(p.head<3>()) * (turn.transpose() * s.at) + p.tail<3>()) - s.at;
  return {moved.y(), moved.z()};
}

cv::Mat Window(const std::vector<std::uint8_t>& px,
               const ToolCameraModel& c,
               const Vec2& centre,
               int n) {
  // The window straight from the 8-bit image into float (getRectSubPix's 8U -> 32F), not the
  // whole image converted for every patch.
  const cv::Mat whole(c.height_px, c.width_px, CV_8UC1, const_cast<std::uint8_t*>(px.data()));
  cv::Mat out;
  cv::getRectSubPix(whole, cv::Size(n, n),
                    cv::Point2f(static_cast<float>(centre.x()), static_cast<float>(centre.y())),
                    out, CV_32F);
  out.convertTo(out, CV_64F);
  return out;
}

// Every patch of every turn that shows texture in both images. The after-image's window is
// taken where `prior` moves the patch (sub-pixel), so phase correlation measures only what is
// left: its sub-pixel peak is least biased near zero shift (an iterative refinement in the
// manner of Lucas and Kanade 1981).
std::vector<PatchShift> Shifts(const TextureSeries& ref,
                               const TextureSeries& after,
                               const ToolDescription& e,
                               const RelocateOptions& o,
                               const Motion& prior) {
  const int n = o.patch_px;
  const ToolCameraModel& c = ref.camera;
  if (n < 16 || n > std::min(c.width_px, c.height_px))
    throw ToolInputError("relocate: a patch must be 16 px or more and fit the image");
  cv::Mat window;
  cv::createHanningWindow(window, cv::Size(n, n), CV_64F);
  const int nu = c.width_px / n, nv = c.height_px / n;
  const double u_first = (c.width_px - nu * n) / 2.0, v_first = (c.height_px - nv * n) / 2.0;
  std::vector<PatchShift> out;
  for (size_t k = 0; k < ref.frames.size(); ++k) {
    const double turn = ref.turn_deg[k] / base::kDegPerRad;
    for (int iv = 0; iv < nv; ++iv)
      for (int iu = 0; iu < nu; ++iu) {
        const Vec2 centre(u_first + iu * n + (n - 1) / 2.0, v_first + iv * n + (n - 1) / 2.0);
        const Vec2 yh = ToolFromImage(centre, c);
        const auto hit = CastRay(e, {}, turn, yh.x(), yh.y());
        if (!hit) continue;
        PatchShift s;
        s.at = Vec3(hit->depth_mm, yh.x(), yh.y()), s.turn_rad = turn;
        const Vec2 expect_mm = Predicted(prior, s);
        const Vec2 moved_px = after.camera.PixelFromTool(yh + expect_mm);
        double response = 0;
        const cv::Point2d d = cv::phaseCorrelate(Window(ref.frames[k], c, centre, n),
                                                 Window(after.frames[k], after.camera, moved_px, n),
                                                 window, &response);
        if (!(response >= o.min_response)) continue;
        s.moved = ToolFromImage(moved_px + Vec2(d.x, d.y), after.camera) - yh;
        out.push_back(s);
      }
  }
  return out;
}

// Gauss-Newton on the exact rotation over the patches `use` says; returns the motion.
Motion FitMotion(const std::vector<PatchShift>& shifts, const std::vector<bool>& use) {
  Motion p = Motion::Zero();
  for (int iteration = 0; iteration < 8; ++iteration) {
    Eigen::MatrixXd jac(2 * shifts.size(), 6);
    Eigen::VectorXd res(2 * shifts.size());
    jac.setZero(), res.setZero();
    for (size_t i = 0; i < shifts.size(); ++i) {
      if (!use[i]) continue;
      res.segment<2>(static_cast<Eigen::Index>(2 * i)) = shifts[i].moved - Predicted(p, shifts[i]);
      for (int j = 0; j < 6; ++j) {
        Motion q = p;
        const double step = 1e-7;
        q(j) += step;
        jac.block<2, 1>(static_cast<Eigen::Index>(2 * i), j) =
            (Predicted(q, shifts[i]) - Predicted(p, shifts[i])) / step;
      }
    }
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(jac);
    if (qr.rank() < 6)
      throw ToolError("relocate: the patches do not fix all six degrees of freedom");
    const Eigen::VectorXd step = qr.solve(res);
    p += step;
    if (step.norm() < 1e-12) break;
  }
  return p;
}

double Residual(const Motion& p, const PatchShift& s) { return (s.moved - Predicted(p, s)).norm(); }

// Two turns whose views are at least 60 deg apart (mod 180): the motion along one view shows
// across the other.
void CheckTurnsSpread(const std::vector<PatchShift>& shifts) {
  for (const auto& a : shifts)
    for (const auto& b : shifts)
      if (std::abs(std::sin(a.turn_rad - b.turn_rad)) >= std::sin(60.0 / base::kDegPerRad)) return;
  throw ToolError(
      "relocate: no two turns 60 deg or more apart show texture: the motion along the view is "
      "not seen");
}

}  // namespace

std::vector<std::uint8_t> RenderTextureFrame(const ToolDescription& e,
                                             const ClampPose& pose,
                                             double turn_rad,
                                             const TextureCamera& c,
                                             std::mt19937& rng) {
  if (!e.electrode) throw ToolInputError("texture camera: the description is not an electrode");
  c.geometry.Validate();
  std::normal_distribution<double> noise(0.0, c.noise_sigma);
  const ToolCameraModel& g = c.geometry;
  std::vector<std::uint8_t> px(static_cast<size_t>(g.width_px) * static_cast<size_t>(g.height_px));
  for (int v = 0; v < g.height_px; ++v)
    for (int u = 0; u < g.width_px; ++u) {
      double sum = 0;
      for (int s = 0; s < 4; ++s) {  // 2 x 2 rays, a quarter pixel from the centre
        const int su = s % 2, sv = s / 2;
        const Vec2 yh = g.ToolFromPixel({u - 0.25 + 0.5 * su, v - 0.25 + 0.5 * sv});
        const auto hit = CastRay(e, pose, turn_rad, yh.x(), yh.y());
        sum += hit ? c.dark + (c.bright - c.dark) * (0.2 + 0.8 * Albedo(c, *hit)) : c.dark;
      }
      const double grey = sum / 4 + noise(rng);
      px[static_cast<size_t>(v) * static_cast<size_t>(g.width_px) + static_cast<size_t>(u)] =
          static_cast<std::uint8_t>(std::clamp(std::lround(grey), 0L, 255L));
    }
  return px;
}

Relocation Relocate(const TextureSeries& reference,
                    const TextureSeries& after,
                    const ToolDescription& electrode,
                    const RelocateOptions& options) {
  CheckSeries(reference, after, electrode);
  Motion p = Motion::Zero();
  std::vector<PatchShift> shifts;
  std::vector<bool> use;
  // Each round measures the patches where the last one's motion puts them.
  for (int round = 0; round < kRounds; ++round) {
    shifts = Shifts(reference, after, electrode, options, p);
    if (shifts.size() < 6) throw ToolError("relocate: too few patches show the texture");
    CheckTurnsSpread(shifts);
    use.assign(shifts.size(), true);
    p = FitMotion(shifts, use);
  }
  // Patches far off the fit (a scratch, a spot of dielectric): out, and fitted again.
  std::vector<double> r;
  r.reserve(shifts.size());
  for (const auto& s : shifts) r.push_back(Residual(p, s));
  std::vector<double> sorted = r;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2),
                   sorted.end());
  const double limit = options.outlier_factor * std::max(sorted[sorted.size() / 2], 1e-6);
  Relocation out;
  for (size_t i = 0; i < shifts.size(); ++i)
    if (r[i] > limit) use[i] = false, ++out.left_out;
  if (out.left_out > 0) p = FitMotion(shifts, use);
  double square = 0;
  for (size_t i = 0; i < shifts.size(); ++i)
    if (use[i]) square += std::pow(Residual(p, shifts[i]), 2), ++out.patches;
  out.rms_um = std::sqrt(square / std::max(out.patches, 1)) * 1e3;
  out.change.rotation_rad = p.head<3>(), out.change.translation_mm = p.tail<3>();
  for (int k = 0; k < 3; ++k) out.rotation_deg[k] = p(k) * base::kDegPerRad;
  out.tilt_deg = std::hypot(p(0), p(1)) * base::kDegPerRad;
  return out;
}

}  // namespace mlp::toolcam
