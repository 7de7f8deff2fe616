#include "mlp/calib/line_laser.h"

#include "mlp/calib/capture_io.h"
#include "mlp/geometry/columns.h"
#include "mlp/geometry/fit.h"
#include "mlp/geometry/robust.h"
#include "mlp/probe_fw/stripe.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "robust_scale.h"
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace mlp::calib {
namespace {

using geometry::Vec2;
using geometry::Vec3;

// Corner refinement window: as wide as the squares allow (0.4 of the closest corners' spacing:
// the window must not reach the next corner), at most 20 px half-width. Chosen on the real
// blaser images (defocused and sharpened in the camera): 5 px half-width gave 1.9 px reprojection
// RMS, 19 px 0.59 px, a window of the whole square 1.1 px (neighbouring corners in the window).
constexpr double kWindowOfSpacing = 0.4;
constexpr int kMaxHalfWindow = 20, kMinHalfWindow = 5;
// A view whose corners fit the camera this many times worse than the median view is refused.
constexpr double kViewRmsFactor = 3.0;
// Stripe scatter: points beyond this many RMS from the line are trimmed (the line bends where
// the laser leaves the board), then the line is refitted; three rounds.
constexpr double kTrimSigmas = 3.0;

cv::Mat ToGray8(const GrayImage& img) {
  cv::Mat m(img.height, img.width, CV_16U, const_cast<std::uint16_t*>(img.pixels.data()));
  cv::Mat out;
  m.convertTo(out, CV_8U, 255.0 / ((1 << img.bit_depth) - 1));
  return out;
}

GrayImage Weighted(const std::string& path,
                   const probe_fw::ChannelWeights& w,
                   const probe_fw::RawBayer& raw) {
  probe_fw::Frame f;
  probe_fw::ReadImage(path, &f, w, raw);  // a bad image: FrameIoError, an input error
  return {f.aoi.width, f.aoi.height, f.bit_depth, std::move(f.pixels)};
}

double ClosestSpacing(const std::vector<cv::Point2f>& p, const ChessboardSpec& b) {
  double d = 1e9;
  for (int r = 0; r < b.inner_rows; ++r) {
    for (int c = 0; c < b.inner_cols; ++c) {
      const int k = r * b.inner_cols + c;
      if (c + 1 < b.inner_cols) d = std::min(d, double(cv::norm(p[k] - p[k + 1])));
      if (r + 1 < b.inner_rows) d = std::min(d, double(cv::norm(p[k] - p[k + b.inner_cols])));
    }
  }
  return d;
}

// The board at full, half or quarter resolution, refined at full resolution.
bool FindBoard(const GrayImage& image, const ChessboardSpec& b, ImageFindings* out) {
  const cv::Mat gray = ToGray8(image);
  const cv::Size pattern(b.inner_cols, b.inner_rows);
  for (double scale : {1.0, 0.5, 0.25}) {
    cv::Mat scaled = gray;
    if (scale != 1.0) cv::resize(gray, scaled, cv::Size(), scale, scale, cv::INTER_AREA);
    std::vector<cv::Point2f> p;
    if (!cv::findChessboardCorners(scaled, pattern, p,
                                   cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE))
      continue;
    for (auto& q : p) {  // pixel centres: (x + 0.5) / scale - 0.5
      q.x = static_cast<float>((q.x + 0.5) / scale - 0.5);
      q.y = static_cast<float>((q.y + 0.5) / scale - 0.5);
    }
    const int half =
        std::clamp(static_cast<int>(std::lround(kWindowOfSpacing * ClosestSpacing(p, b))),
                   kMinHalfWindow, kMaxHalfWindow);
    cv::cornerSubPix(gray, p, cv::Size(half, half), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-4));
    for (const auto& q : p) out->corners.emplace_back(q.x, q.y);
    out->corner_scale = scale;
    return true;
  }
  return false;
}

void FindStripe(const GrayImage& image, const StripeSettings& s, ImageFindings* out) {
  probe_fw::Frame f;
  f.aoi = {0, 0, image.width, image.height};
  f.bit_depth = image.bit_depth;
  f.laser_column = 0.0;
  f.pixels = image.pixels;
  probe_fw::StripeOptions o;
  o.max_width_px = s.max_width_px;
  o.window_half_px = s.window_half_px;
  o.min_amplitude_dn = s.min_amplitude_dn;
  o.speckle_sigma_px = s.speckle_sigma_px;
  std::vector<probe_fw::StripePoint> points;
  probe_fw::StripeCounts counts;
  probe_fw::ExtractStripe(f, probe_fw::RowMask::Full(f.aoi), o, &points, &counts);
  for (const auto& p : points) {
    out->stripe_px.emplace_back(p.x_px, p.y_px);
    out->stripe_quality.push_back(static_cast<float>(p.quality));
  }
  out->stripe_saturated = static_cast<int>(counts.saturated);
  out->stripe_rejected = static_cast<int>(counts.weak + counts.double_peak + counts.too_wide +
                                          counts.too_narrow + counts.cut);
}

}  // namespace

std::vector<ImageFindings> FindInImages(const RobotViews& views,
                                        const std::function<void(const std::string&)>& progress) {
  std::vector<ImageFindings> out;
  for (const RobotImage& image : views.images) {
    ImageFindings f;
    f.name = image.name;
    const GrayImage board = Weighted(image.path, views.board_channels, views.raw);
    const GrayImage laser = Weighted(image.path, views.laser_channels, views.raw);
    if (!out.empty() &&
        (board.width != out.front().width_px || board.height != out.front().height_px))
      throw CaptureIoError(image.path + ": its size differs from the first image's");
    f.width_px = board.width, f.height_px = board.height;
    const bool has_board = FindBoard(board, views.board, &f);
    FindStripe(laser, views.stripe, &f);
    if (!has_board && !f.HasLaser()) f.refused = "neither the board nor the laser line was found";
    if (progress) {
      std::ostringstream line;
      line << image.name << ": " << (has_board ? "board" : "no board") << ", " << f.stripe_px.size()
           << " stripe points";
      progress(line.str());
    }
    out.push_back(std::move(f));
  }
  return out;
}

StripeScatter ScatterAboutLine(const std::vector<Vec2>& stripe_px, const Intrinsics& camera) {
  StripeScatter s;
  const probe_fw::CameraModel cam = CameraModelOf(camera);
  std::vector<Vec2> all;
  all.reserve(stripe_px.size());
  for (const auto& p : stripe_px) all.push_back(cam.Undistort(p) * camera.fx_px);
  if (all.size() < 3) return s;
  std::vector<Vec2> kept = all;
  double rms = 0.0;
  for (int round = 0; round < 4; ++round) {
    const auto fit = geometry::FitLine2(geometry::AsColumns(kept));
    const Vec2 n(-fit.shape.direction.y(), fit.shape.direction.x());
    double sum = 0.0;
    for (const auto& p : kept) sum += std::pow(n.dot(p - fit.shape.point), 2);
    rms = std::sqrt(sum / double(kept.size()));
    if (round == 3) break;
    std::vector<Vec2> next;
    for (const auto& p : all)
      if (std::abs(n.dot(p - fit.shape.point)) <= kTrimSigmas * rms) next.push_back(p);
    if (next.size() < 3) break;
    kept = std::move(next);
  }
  s.rms_px = rms;
  s.points = static_cast<int>(kept.size());
  s.trimmed = static_cast<int>(all.size() - kept.size());
  return s;
}

namespace {

// The images with a board: their corners and their indices into the findings.
struct BoardImages {
  std::vector<std::vector<Vec2>> corners;
  std::vector<int> index;
};

BoardImages WithBoard(const std::vector<ImageFindings>& images) {
  BoardImages b;
  for (size_t i = 0; i < images.size(); ++i) {
    if (!images[i].HasBoard()) continue;
    b.corners.push_back(images[i].corners);
    b.index.push_back(static_cast<int>(i));
  }
  return b;
}

// The views whose corners the camera follows (at most 3 x the median view's RMS); the others
// get a note each.
std::vector<size_t> KeptViews(const CameraCalibration& camera,
                              const BoardImages& boards,
                              const std::vector<ImageFindings>& images,
                              std::vector<std::string>* notes) {
  const double median = Median(camera.view_rms_px);
  std::vector<size_t> kept;
  for (size_t v = 0; v < boards.corners.size(); ++v) {
    if (camera.view_rms_px[v] <= kViewRmsFactor * median) {
      kept.push_back(v);
      continue;
    }
    std::ostringstream note;
    note.precision(2);
    note << std::fixed << images[static_cast<size_t>(boards.index[v])].name << ": corners refused, "
         << camera.view_rms_px[v] << " px RMS against the camera model, > " << kViewRmsFactor
         << " x the median view (" << median << " px): blurred, or the laser over the corners";
    notes->push_back(note.str());
  }
  return kept;
}

// Each board view's stripe pixels met with its board plane [mm, camera frame]; the stripes'
// scatter about a straight line on the way.
std::vector<Vec3> LaserOnBoards(const std::vector<ImageFindings>& images, LineLaserCalibration* r) {
  const probe_fw::CameraModel cam = CameraModelOf(r->camera.intrinsics);
  std::vector<Vec3> points;
  double sum2 = 0.0;
  int scatter_points = 0;
  for (size_t v = 0; v < r->board_images.size(); ++v) {
    const ImageFindings& f = images[static_cast<size_t>(r->board_images[v])];
    const geometry::Pose3& t = r->camera.camera_from_board[v];
    const Vec3 n = t.linear().col(2);
    const double d = n.dot(t.translation());
    for (const auto& px : f.stripe_px) {
      const Vec2 u = cam.Undistort(px);
      const Vec3 ray(u.x(), u.y(), 1.0);
      points.push_back(ray * (d / n.dot(ray)));
    }
    r->scatter.push_back(ScatterAboutLine(f.stripe_px, r->camera.intrinsics));
    sum2 += std::pow(r->scatter.back().rms_px, 2) * r->scatter.back().points;
    scatter_points += r->scatter.back().points;
  }
  r->scatter_rms_px = scatter_points > 0 ? std::sqrt(sum2 / scatter_points) : 0.0;
  if (points.size() < 3 * ImageFindings::kMinStripePoints)
    throw CameraCalibError("too few laser points on the boards (" + std::to_string(points.size()) +
                           "): is the laser in the board images, and the channel weights right?");
  return points;
}

// The plane's statistics over the points given as its inliers.
void PlaneStats(const std::vector<Vec3>& points,
                const std::vector<int>& inliers,
                LineLaserCalibration* r) {
  double s2 = 0.0, mx = 0.0;
  for (int i : inliers) {
    const double e = r->plane.normal.dot(points[static_cast<size_t>(i)] - r->plane.point);
    s2 += e * e, mx = std::max(mx, std::abs(e));
  }
  r->plane_points = static_cast<int>(points.size());
  r->plane_inliers = static_cast<int>(inliers.size());
  r->plane_rms_mm = std::sqrt(s2 / static_cast<double>(std::max<size_t>(1, inliers.size())));
  r->plane_max_mm = mx;
}

// Keeps the calibration's views `kept` (indices into `boards`).
void KeepViews(const std::vector<size_t>& kept, CameraCalibration* c) {
  CameraCalibration out = *c;
  out.camera_from_board.clear(), out.view_rms_px.clear(), out.views_used.clear();
  for (size_t v : kept) {
    out.camera_from_board.push_back(c->camera_from_board[v]);
    out.view_rms_px.push_back(c->view_rms_px[v]);
    out.views_used.push_back(static_cast<int>(v));
  }
  *c = std::move(out);
}

}  // namespace

LineLaserCalibration CalibrateLineLaser(const std::vector<ImageFindings>& images,
                                        const ChessboardSpec& board,
                                        int width_px,
                                        int height_px) {
  LineLaserCalibration r;
  const BoardImages boards = WithBoard(images);
  r.camera = CalibrateCameraFromCorners(boards.corners, board, width_px, height_px);
  // Refuse views whose corners the model cannot follow, once, and fit again without them.
  const std::vector<size_t> kept = KeptViews(r.camera, boards, images, &r.notes);
  std::vector<std::vector<Vec2>> kept_corners;
  for (size_t v : kept) {
    kept_corners.push_back(boards.corners[v]);
    r.board_images.push_back(boards.index[v]);
  }
  if (kept.size() != boards.corners.size())
    r.camera = CalibrateCameraFromCorners(kept_corners, board, width_px, height_px);
  const std::vector<Vec3> points = LaserOnBoards(images, &r);
  const auto plane = geometry::FitPlaneRobust(geometry::AsColumns(points));
  r.plane = plane.fit.shape;
  PlaneStats(points, plane.inliers, &r);
  return r;
}

LineLaserCalibration LineLaserOfModel(const std::vector<ImageFindings>& images,
                                      const probe_fw::ProbeModel& model,
                                      const ChessboardSpec& board) {
  if (model.projector.columns != 1)
    throw CameraCalibError("probe " + model.serial +
                           ": not a fixed line laser (the projector has " +
                           std::to_string(model.projector.columns) + " columns, not 1)");
  LineLaserCalibration r;
  const BoardImages boards = WithBoard(images);
  r.camera = BoardPosesWithCamera(boards.corners, board, IntrinsicsOf(model.camera));
  const std::vector<size_t> kept = KeptViews(r.camera, boards, images, &r.notes);
  KeepViews(kept, &r.camera);
  for (size_t v : kept) r.board_images.push_back(boards.index[v]);
  const std::vector<Vec3> points = LaserOnBoards(images, &r);
  Vec3 n;
  double d = 0.0;
  model.projector.PlaneOf(0.0, &n, &d);
  r.plane = {n * d, n};
  // Inliers as a robust fit would take them: within 2.5 robust sigma (geometry/robust.h).
  std::vector<double> e;
  e.reserve(points.size());
  for (const Vec3& p : points) e.push_back(n.dot(p) - d);
  const double limit = 2.5 * RobustSigma(e);
  std::vector<int> inliers;
  for (size_t i = 0; i < points.size(); ++i)
    if (std::abs(e[i]) <= limit) inliers.push_back(static_cast<int>(i));
  PlaneStats(points, inliers, &r);
  return r;
}

Intrinsics IntrinsicsOf(const probe_fw::CameraModel& c) {
  return {c.fx_px, c.fy_px, c.cx_px, c.cy_px, c.k1, c.k2, c.p1, c.p2, c.k3};
}

probe_fw::CameraModel CameraModelOf(const Intrinsics& in) {
  probe_fw::CameraModel c;
  c.fx_px = in.fx_px, c.fy_px = in.fy_px, c.cx_px = in.cx_px, c.cy_px = in.cy_px;
  c.k1 = in.k1, c.k2 = in.k2, c.p1 = in.p1, c.p2 = in.p2, c.k3 = in.k3;
  return c;
}

probe_fw::ProjectorModel OnePlaneProjector(const geometry::Plane& plane) {
  probe_fw::ProjectorModel p;
  p.f_px = 1.0, p.c_px = 0.0, p.columns = 1;
  Vec3 n = plane.normal.normalized();
  double d = n.dot(plane.point);
  if (d < 0) n = -n, d = -d;
  // x along the normal; y, z any right-handed completion (the plane is x = 0 for column 0).
  const Vec3 helper = std::abs(n.z()) < 0.9 ? Vec3::UnitZ() : Vec3::UnitX();
  const Vec3 y = n.cross(helper).normalized();
  geometry::Pose3 pose = geometry::Pose3::Identity();
  pose.linear().col(0) = n;
  pose.linear().col(1) = y;
  pose.linear().col(2) = n.cross(y);
  pose.translation() = n * d;
  p.camera_from_projector = pose;
  return p;
}

probe_fw::ProbeModel LineLaserProbeModel(const probe_fw::ProbeModel& design,
                                         const Intrinsics& camera,
                                         const geometry::Plane& plane,
                                         const std::string& calibration_id) {
  probe_fw::ProbeModel m = design;
  m.calibration_id = calibration_id;
  const probe_fw::CameraModel k = CameraModelOf(camera);
  auto& c = m.camera;
  c.fx_px = k.fx_px, c.fy_px = k.fy_px, c.cx_px = k.cx_px, c.cy_px = k.cy_px;
  c.k1 = k.k1, c.k2 = k.k2, c.p1 = k.p1, c.p2 = k.p2, c.k3 = k.k3;
  m.projector = OnePlaneProjector(plane);
  m.Validate();
  return m;
}

}  // namespace mlp::calib
