#include "mlp/calib/camera_calib.h"

#include "mlp/base/raster.h"
#include "mlp/calib/probe_calib.h"

#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace mlp::calib {
namespace {

constexpr int kMinViews = 4;
// Corner refinement: a 21 x 21 window (squares are > 100 px: a wide window averages the noise
// of more edge pixels), iterations to 1e-4 px.
constexpr int kSubPixHalfWindow = 10;

cv::Mat To8Bit(const GrayImage& img) {
  if (img.width <= 0 || img.height <= 0 ||
      img.pixels.size() != base::RasterSize(img.width, img.height))
    throw CameraCalibError("an image's size does not match its pixels");
  cv::Mat m(img.height, img.width, CV_16U, const_cast<std::uint16_t*>(img.pixels.data()));
  cv::Mat out;
  m.convertTo(out, CV_8U, 255.0 / ((1 << img.bit_depth) - 1));
  return out;
}

std::vector<cv::Point3f> BoardCorners(const ChessboardSpec& b) {
  std::vector<cv::Point3f> out;
  for (int j = 1; j <= b.inner_rows; ++j) {
    for (int i = 1; i <= b.inner_cols; ++i)
      out.emplace_back(static_cast<float>(i * b.square_mm), static_cast<float>(j * b.square_mm),
                       0.f);
  }
  return out;
}

}  // namespace

geometry::Vec2 Intrinsics::Project(const geometry::Vec3& p) const {
  const double x = p.x() / p.z(), y = p.y() / p.z(), r2 = x * x + y * y;
  const double radial = 1 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2;
  const double xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
  const double yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y;
  return {fx_px * xd + cx_px, fy_px * yd + cy_px};
}

std::vector<std::vector<geometry::Vec2>> DetectCorners(const std::vector<GrayImage>& images,
                                                       const ChessboardSpec& b) {
  if (b.inner_cols < 2 || b.inner_rows < 2 || !(b.square_mm > 0))
    throw CameraCalibError("chessboard: at least 2 x 2 inner corners and a square > 0 mm");
  std::vector<std::vector<geometry::Vec2>> out(images.size());
  for (size_t v = 0; v < images.size(); ++v) {
    const cv::Mat gray = To8Bit(images[v]);
    std::vector<cv::Point2f> corners;
    if (!cv::findChessboardCorners(gray, cv::Size(b.inner_cols, b.inner_rows), corners,
                                   cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE))
      continue;
    cv::cornerSubPix(gray, corners, cv::Size(kSubPixHalfWindow, kSubPixHalfWindow),
                     cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-4));
    for (const auto& c : corners) out[v].emplace_back(c.x, c.y);
  }
  return out;
}

CameraCalibration CalibrateCamera(const std::vector<GrayImage>& images, const ChessboardSpec& b) {
  for (const auto& image : images) {
    if (image.width != images.at(0).width || image.height != images.at(0).height)
      throw CameraCalibError("the images differ in size");
  }
  if (images.empty()) throw CameraCalibError("no images");
  return CalibrateCameraFromCorners(DetectCorners(images, b), b, images[0].width, images[0].height);
}

CameraCalibration CalibrateCameraFromCorners(const std::vector<std::vector<geometry::Vec2>>& found,
                                             const ChessboardSpec& b,
                                             int width_px,
                                             int height_px) {
  CameraCalibration result;
  std::vector<std::vector<cv::Point3f>> object_points;
  std::vector<std::vector<cv::Point2f>> image_points;
  for (size_t v = 0; v < found.size(); ++v) {
    if (found[v].empty()) {
      result.warnings.push_back("image " + std::to_string(v) + ": no complete board found");
      continue;
    }
    if (found[v].size() != base::RasterSize(b.inner_cols, b.inner_rows))
      throw CameraCalibError("image " + std::to_string(v) + ": not the board's corner count");
    std::vector<cv::Point2f> corners;
    for (const auto& c : found[v])
      corners.emplace_back(static_cast<float>(c.x()), static_cast<float>(c.y()));
    image_points.push_back(corners);
    object_points.push_back(BoardCorners(b));
    result.views_used.push_back(static_cast<int>(v));
  }
  if (static_cast<int>(image_points.size()) < kMinViews)
    throw CameraCalibError("the board was found in " + std::to_string(image_points.size()) +
                           " images; at least " + std::to_string(kMinViews) + " are needed");
  const cv::Size size(width_px, height_px);
  cv::Mat k, dist;
  std::vector<cv::Mat> rvecs, tvecs;
  cv::Mat std_intr, std_extr, per_view;
  result.rms_reprojection_px = cv::calibrateCamera(
      object_points, image_points, size, k, dist, rvecs, tvecs, std_intr, std_extr, per_view, 0,
      cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 200, 1e-12));
  auto& in = result.intrinsics;
  in.fx_px = k.at<double>(0, 0), in.fy_px = k.at<double>(1, 1);
  in.cx_px = k.at<double>(0, 2), in.cy_px = k.at<double>(1, 2);
  in.k1 = dist.at<double>(0), in.k2 = dist.at<double>(1), in.p1 = dist.at<double>(2);
  in.p2 = dist.at<double>(3), in.k3 = dist.at<double>(4);
  auto& sd = result.std_dev;
  const auto s = [&](int i) { return std_intr.at<double>(i); };
  sd.fx_px = s(0), sd.fy_px = s(1), sd.cx_px = s(2), sd.cy_px = s(3);
  sd.k1 = s(4), sd.k2 = s(5), sd.p1 = s(6), sd.p2 = s(7), sd.k3 = s(8);
  for (size_t v = 0; v < rvecs.size(); ++v) {
    cv::Mat r;
    cv::Rodrigues(rvecs[v], r);
    geometry::Pose3 pose = geometry::Pose3::Identity();
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) pose.linear()(i, j) = r.at<double>(i, j);
      pose.translation()(i) = tvecs[v].at<double>(i);
    }
    result.camera_from_board.push_back(pose);
    result.view_rms_px.push_back(per_view.at<double>(static_cast<int>(v)));
  }
  return result;
}

CameraCalibration BoardPosesWithCamera(const std::vector<std::vector<geometry::Vec2>>& found,
                                       const ChessboardSpec& b,
                                       const Intrinsics& k) {
  CameraCalibration result;
  result.intrinsics = k;
  const cv::Matx33d camera(k.fx_px, 0, k.cx_px, 0, k.fy_px, k.cy_px, 0, 0, 1);
  const std::vector<double> dist = {k.k1, k.k2, k.p1, k.p2, k.k3};
  const std::vector<cv::Point3f> object = BoardCorners(b);
  double sum2 = 0.0;
  size_t count = 0;
  for (size_t v = 0; v < found.size(); ++v) {
    if (found[v].size() != object.size()) {
      result.warnings.push_back("image " + std::to_string(v) + ": no complete board found");
      continue;
    }
    std::vector<cv::Point2f> seen;
    for (const auto& c : found[v])
      seen.emplace_back(static_cast<float>(c.x()), static_cast<float>(c.y()));
    cv::Mat rvec, tvec;
    cv::solvePnP(object, seen, camera, dist, rvec, tvec, false, cv::SOLVEPNP_ITERATIVE);
    cv::Mat r;
    cv::Rodrigues(rvec, r);
    geometry::Pose3 pose = geometry::Pose3::Identity();
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) pose.linear()(i, j) = r.at<double>(i, j);
      pose.translation()(i) = tvec.at<double>(i);
    }
    double view2 = 0.0;
    for (size_t c = 0; c < object.size(); ++c) {
      const geometry::Vec3 p(object[c].x, object[c].y, object[c].z);
      view2 += (k.Project(pose * p) - found[v][c]).squaredNorm();
    }
    sum2 += view2, count += object.size();
    result.camera_from_board.push_back(pose);
    result.view_rms_px.push_back(std::sqrt(view2 / double(object.size())));
    result.views_used.push_back(static_cast<int>(v));
  }
  if (result.views_used.empty()) throw CameraCalibError("the board was found in no image");
  result.rms_reprojection_px = std::sqrt(sum2 / double(count));
  return result;
}

}  // namespace mlp::calib
