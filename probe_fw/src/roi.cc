#include "mlp/probe_fw/roi.h"

#include "mlp/geometry/error.h"
#include "mlp/geometry/robust.h"

#include <cmath>

#include <Eigen/Eigenvalues>
#include <opencv2/imgproc.hpp>

namespace mlp::probe_fw {
namespace {

// The LED frame as an 8-bit image (Canny's input), scaled from the camera's bit depth.
cv::Mat ToGrey8(const Frame& f) {
  cv::Mat image(f.aoi.height, f.aoi.width, CV_8UC1);
  const int shift = f.bit_depth - 8;
  for (int y = 0; y < f.aoi.height; ++y) {
    for (int x = 0; x < f.aoi.width; ++x)
      image.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(f.At(x, y) >> shift);
  }
  return image;
}

// Bilinear sample of a CV_32F image.
float Sample(const cv::Mat& m, double x, double y) {
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  if (x0 < 0 || y0 < 0 || x0 + 1 >= m.cols || y0 + 1 >= m.rows) return 0.0f;
  const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
  return (1 - fy) * ((1 - fx) * m.at<float>(y0, x0) + fx * m.at<float>(y0, x0 + 1)) +
         fy * ((1 - fx) * m.at<float>(y0 + 1, x0) + fx * m.at<float>(y0 + 1, x0 + 1));
}

}  // namespace

std::vector<EdgePoint> SubpixelEdges(const Frame& led, double low_fraction, double high_fraction) {
  const cv::Mat grey = ToGrey8(led);
  cv::Mat gx, gy, magnitude, edges;
  cv::Sobel(grey, gx, CV_32F, 1, 0, 3);
  cv::Sobel(grey, gy, CV_32F, 0, 1, 3);
  cv::magnitude(gx, gy, magnitude);
  // Sobel 3x3 of a full-scale step gives 4 x 255: thresholds as fractions of that.
  cv::Canny(grey, edges, low_fraction * 1020.0, high_fraction * 1020.0, 3, true);
  std::vector<EdgePoint> out;
  for (int y = 1; y + 1 < edges.rows; ++y) {
    for (int x = 1; x + 1 < edges.cols; ++x) {
      if (!edges.at<std::uint8_t>(y, x)) continue;
      const Vec2 g(gx.at<float>(y, x), gy.at<float>(y, x));
      const double norm = g.norm();
      if (!(norm > 0.0)) continue;
      const Vec2 u = g / norm;
      const double m0 = magnitude.at<float>(y, x);
      const double minus = Sample(magnitude, x - u.x(), y - u.y());
      const double plus = Sample(magnitude, x + u.x(), y + u.y());
      const double curvature = minus - 2.0 * m0 + plus;
      double offset = curvature < 0.0 ? 0.5 * (minus - plus) / curvature : 0.0;
      offset = std::clamp(offset, -0.5, 0.5);
      EdgePoint e;
      e.position_px = Vec2(x + led.aoi.x0, y + led.aoi.y0) + offset * u;
      e.gradient = g;
      out.push_back(e);
    }
  }
  return out;
}

std::optional<HoleRoi> FindHole(const Frame& led,
                                const Vec2& hint_px,
                                double min_radius_px,
                                double max_radius_px) {
  std::vector<Vec2> rim;
  for (const EdgePoint& e : SubpixelEdges(led)) {
    const Vec2 d = e.position_px - hint_px;
    const double r = d.norm();
    // Dark hole, bright face: the gradient points away from the hole's centre.
    if (r >= min_radius_px && r <= max_radius_px &&
        d.dot(e.gradient) > 0.7 * r * e.gradient.norm()) {
      rim.push_back(e.position_px);
    }
  }
  if (rim.size() < 12) return std::nullopt;
  geometry::Points3 pts(3, static_cast<Eigen::Index>(rim.size()));
  for (size_t i = 0; i < rim.size(); ++i) pts.col(static_cast<Eigen::Index>(i)) << rim[i], 0.0;
  try {
    geometry::RobustOptions options;
    options.inlier_threshold_mm = 0.5;  // pixels here: a sub-pixel edge is within half a pixel
    const auto fit = geometry::FitCircle3Robust(pts, options);
    HoleRoi hole;
    hole.center_px = fit.fit.shape.center.head<2>();
    hole.radius_px = fit.fit.shape.radius;
    // "The hole around the hint": a rim seen from outside (its far side, whose gradient also
    // points away from the hint) is another hole.
    if (!((hole.center_px - hint_px).norm() < hole.radius_px)) return std::nullopt;
    hole.edge_points = fit.fit.stats.n;
    hole.rms_px = fit.fit.stats.rms;
    return hole;
  } catch (const geometry::GeometryError&) {
    return std::nullopt;  // the edge points do not make a circle: no hole there
  }
}

std::optional<LineEdgeRoi> FindLineEdge(const Frame& led, const Vec2& hint_px, double radius_px) {
  std::vector<EdgePoint> near;
  for (const EdgePoint& e : SubpixelEdges(led)) {
    if ((e.position_px - hint_px).norm() <= radius_px) near.push_back(e);
  }
  if (near.size() < 12) return std::nullopt;
  geometry::Points3 pts(3, static_cast<Eigen::Index>(near.size()));
  for (size_t i = 0; i < near.size(); ++i)
    pts.col(static_cast<Eigen::Index>(i)) << near[i].position_px, 0.0;
  try {
    geometry::RobustOptions options;
    options.inlier_threshold_mm = 0.5;  // pixels here, as for holes
    const auto fit = geometry::FitLine3Robust(pts, options);
    LineEdgeRoi edge;
    edge.direction = fit.fit.shape.direction.head<2>().normalized();
    const Vec2 p0 = fit.fit.shape.point.head<2>();
    edge.point_px = p0 + edge.direction * edge.direction.dot(hint_px - p0);
    edge.edge_points = fit.fit.stats.n;
    edge.rms_px = fit.fit.stats.rms;
    // The gradient points dark -> bright: its mean over the line's points says the lit side.
    Vec2 gradient = Vec2::Zero();
    for (int i : fit.inliers) {
      edge.inliers_px.push_back(near[static_cast<size_t>(i)].position_px);
      gradient += near[static_cast<size_t>(i)].gradient;
    }
    const Vec2 normal(-edge.direction.y(), edge.direction.x());
    edge.bright_side = normal.dot(gradient) >= 0.0 ? normal : Vec2(-normal);
    return edge;
  } catch (const geometry::GeometryError&) {
    return std::nullopt;
  }
}

base::EdgeSight SightOfEdge(const CameraModel& camera, const LineEdgeRoi& edge) {
  const auto ray = [&](const Vec2& px) {
    return Vec3(camera.Undistort(px).homogeneous()).normalized();
  };
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  double first = 0.0, last = 0.0;
  Vec2 first_px = edge.point_px, last_px = edge.point_px;
  for (const Vec2& p : edge.inliers_px) {
    const Vec3 r = ray(p);
    scatter += r * r.transpose();
    const double along = edge.direction.dot(p - edge.point_px);
    if (along < first) first = along, first_px = p;
    if (along > last) last = along, last_px = p;
  }
  // Eigenvalues ascending: the first vector is the plane's normal.
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(scatter);
  base::EdgeSight s;
  s.normal_in_probe = eigen.eigenvectors().col(0).normalized();
  if (s.normal_in_probe.dot(ray(edge.point_px + 2.0 * edge.bright_side)) < 0.0)
    s.normal_in_probe = -s.normal_in_probe;
  const auto in_plane = [&](const Vec2& px) {
    const Vec3 r = ray(px);
    return Vec3(r - s.normal_in_probe * s.normal_in_probe.dot(r)).normalized();
  };
  s.first_ray_in_probe = in_plane(first_px);
  s.last_ray_in_probe = in_plane(last_px);
  s.rms_px = edge.rms_px;
  s.points = static_cast<std::uint32_t>(edge.inliers_px.size());
  return s;
}

RowMask BandMask(const Aoi& aoi, const Vec2& point, const Vec2& direction, double half_width) {
  RowMask m;
  m.aoi = aoi;
  m.rows.resize(static_cast<size_t>(aoi.height));
  const Vec2 normal(-direction.y(), direction.x());
  for (int y = 0; y < aoi.height; ++y) {
    int begin = -1;
    for (int x = 0; x <= aoi.width; ++x) {
      const bool in =
          x < aoi.width && std::abs(normal.dot(Vec2(aoi.x0 + x, aoi.y0 + y) - point)) <= half_width;
      if (in && begin < 0) begin = x;
      if (!in && begin >= 0) m.rows[static_cast<size_t>(y)].push_back({begin, x}), begin = -1;
    }
  }
  return m;
}

RowMask AnnulusMask(const Aoi& aoi, const Vec2& c, double r_in, double r_out) {
  RowMask m;
  m.aoi = aoi;
  m.rows.resize(static_cast<size_t>(aoi.height));
  for (int y = 0; y < aoi.height; ++y) {
    const double dy = aoi.y0 + y - c.y();
    if (std::abs(dy) > r_out) continue;
    const double outer = std::sqrt(r_out * r_out - dy * dy);
    const double inner = std::abs(dy) < r_in ? std::sqrt(r_in * r_in - dy * dy) : 0.0;
    auto add = [&](double from, double to) {  // sensor columns -> clipped AOI span
      const int b = std::max(0, static_cast<int>(std::ceil(from)) - aoi.x0);
      const int e = std::min(aoi.width, static_cast<int>(std::floor(to)) + 1 - aoi.x0);
      if (e > b) m.rows[static_cast<size_t>(y)].push_back({b, e});
    };
    if (inner > 0.0) {
      add(c.x() - outer, c.x() - inner);
      add(c.x() + inner, c.x() + outer);
    } else {
      add(c.x() - outer, c.x() + outer);
    }
  }
  return m;
}

RowMask FaceMask(const Frame& led, const Vec2& hint_px, int erode_px) {
  const cv::Mat grey = ToGrey8(led);
  cv::Mat bright;
  cv::threshold(grey, bright, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);
  if (erode_px > 0) {
    cv::erode(
        bright, bright,
        cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * erode_px + 1, 2 * erode_px + 1)));
  }
  cv::Mat labels;
  cv::connectedComponents(bright, labels, 8, CV_32S);
  RowMask m;
  m.aoi = led.aoi;
  m.rows.resize(static_cast<size_t>(led.aoi.height));
  const int hx = static_cast<int>(std::lround(hint_px.x())) - led.aoi.x0;
  const int hy = static_cast<int>(std::lround(hint_px.y())) - led.aoi.y0;
  if (hx < 0 || hy < 0 || hx >= led.aoi.width || hy >= led.aoi.height) return m;
  const int label = labels.at<int>(hy, hx);
  if (label == 0) return m;  // the hint is on the dark side
  for (int y = 0; y < labels.rows; ++y) {
    int begin = -1;
    for (int x = 0; x <= labels.cols; ++x) {
      const bool in = x < labels.cols && labels.at<int>(y, x) == label;
      if (in && begin < 0) begin = x;
      if (!in && begin >= 0) m.rows[static_cast<size_t>(y)].push_back({begin, x}), begin = -1;
    }
  }
  return m;
}

}  // namespace mlp::probe_fw
