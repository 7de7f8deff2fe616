// The probe model file: round trip, camera math, and typed errors naming the bad field.

#include "mlp/probe_fw/probe_model.h"

#include "mlp/probe_fw/cloud_file.h"
#include "mlp/probe_fw/stripe_file.h"
#include "mlp/probe_fw/triangulate.h"

#include <filesystem>
#include <fstream>
#include <random>

#include "test_data.h"
#include <gtest/gtest.h>

namespace mlp::probe_fw {
namespace {

const std::string kReference = mlp::test::SourceDir() + "/samples/probes/reference_probe.json";
constexpr double kPixelFootprintTolUm = 0.1;  // DESIGN.md's ~26 um per pixel at 120 mm
constexpr double kDesignExact = 1e-9;         // the design's own numbers computed again
constexpr double kAxisCrossTolCols = 0.05;    // the projector's axis at the working distance
constexpr double kApertureExact = 1e-15;      // sin u from the pupil, a closed form
constexpr double kStoredPx = 1e-4;            // stripe files keep 1e-4 px

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

TEST(ProbeModel, ReferenceProbeMatchesDesign) {
  const ProbeModel m = LoadProbeModel(kReference);
  EXPECT_EQ(m.camera.width_px, 2048);
  EXPECT_EQ(m.camera.height_px, 1536);
  // DESIGN.md: ~26 um per pixel at the 120 mm working distance, baseline ~60 mm.
  EXPECT_NEAR(120.0 / m.camera.fx_px * 1e3, 25.9, kPixelFootprintTolUm);
  EXPECT_NEAR(m.projector.camera_from_projector.translation().norm(), 60.0, kDesignExact);
  // The projector's axis meets the camera's at the working distance (triangulation ~26.6 deg).
  EXPECT_NEAR(m.projector.ColumnOf(Vec3(0, 0, 120)), m.projector.c_px, kAxisCrossTolCols);
}

TEST(ProbeModel, JsonRoundTripIsExact) {
  const ProbeModel a = LoadProbeModel(kReference);
  const ProbeModel b = ParseProbeModel(ToJson(a));
  EXPECT_EQ(ToJson(a), ToJson(b));
  EXPECT_EQ(b.camera.k2, a.camera.k2);
  EXPECT_TRUE(b.projector.camera_from_projector.isApprox(a.projector.camera_from_projector, 1e-15));
  EXPECT_FALSE(b.calibration_stats.present);  // the design file has none
  ProbeModel c = a;
  c.calibration_stats = {true, 16, 864, 12021, 0.042, 0.018};
  const ProbeModel d = ParseProbeModel(ToJson(c));
  EXPECT_TRUE(d.calibration_stats.present);
  EXPECT_EQ(d.calibration_stats.stripe_points, 12021);
  EXPECT_EQ(d.calibration_stats.corner_rms_px, 0.042);
  EXPECT_EQ(ToJson(c), ToJson(d));
  c.calibration_stats.corner_rms_px = -1.0;
  EXPECT_THROW(c.Validate(), ProbeModelError);
  // The lens (optional): written when given, read back exactly, absent from a design without it.
  EXPECT_EQ(ToJson(a).find("f_number"), std::string::npos);
  ProbeModel e = a;
  e.camera.f_number = 4.7;
  e.camera.focus_distance_mm = 118.5;
  const ProbeModel f = ParseProbeModel(ToJson(e));
  EXPECT_EQ(f.camera.f_number, 4.7);
  EXPECT_EQ(f.camera.focus_distance_mm, 118.5);
  // Entrance pupil 16.04 mm / 4.7 wide, seen from 120 mm: sin u = 1.706 / 120.01.
  const double pupil_radius = 0.5 * a.camera.fx_px * a.camera.pixel_pitch_mm / 4.7;
  EXPECT_NEAR(f.camera.ApertureSinAt(120.0), pupil_radius / std::hypot(pupil_radius, 120.0),
              kApertureExact);
  EXPECT_EQ(a.camera.ApertureSinAt(120.0), 0.0);
  e.camera.f_number = 0.2;
  EXPECT_THROW(e.Validate(), ProbeModelError);
  e.camera.f_number = 4.7, e.camera.focus_distance_mm = -1.0;
  EXPECT_THROW(e.Validate(), ProbeModelError);
}

TEST(ProbeModel, UndistortInvertsProjectAcrossTheSensor) {
  const ProbeModel m = LoadProbeModel(kReference);
  std::mt19937 gen(5);
  std::uniform_real_distribution<double> u(0.0, 2047.0), v(0.0, 1535.0);
  for (int i = 0; i < 1000; ++i) {
    const double row = v(gen);  // v drawn first: tests/seeded_draw.h
    const Vec2 pixel(u(gen), row);
    const Vec2 xy = m.camera.Undistort(pixel);
    const Vec2 back = m.camera.Project(Vec3(xy.x(), xy.y(), 1.0) * 117.0);
    ASSERT_NEAR((back - pixel).norm(), 0.0, 1e-9) << pixel.transpose();  // px
  }
}

TEST(ProbeModel, LightPlaneContainsItsColumn) {
  const ProbeModel m = LoadProbeModel(kReference);
  for (double column : {0.0, 100.5, 511.5, 1023.0}) {
    Vec3 n;
    double d = 0.0;
    m.projector.PlaneOf(column, &n, &d);
    // Two points of the plane at different depths project to the same column.
    const Vec3 a = n.cross(Vec3::UnitY()).normalized();
    const Vec3 p0 = n * d;
    for (double s : {100.0, 140.0}) {
      const Vec3 p = p0 + a * (s - p0.dot(a)) + Vec3::UnitY() * 5.0;
      EXPECT_NEAR(m.projector.ColumnOf(p), column, kDesignExact);
    }
  }
}

void ExpectError(const std::string& text, const std::string& field) {
  try {
    ParseProbeModel(text);
    ADD_FAILURE() << "accepted: " << field;
  } catch (const ProbeModelError& e) {
    EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
  }
}

// Issue 16: a real mirror and line generator (the mirror's cubic, the sheet's smile).
ProbeModel CurvedProbe() {
  ProbeModel m = LoadProbeModel(kReference);
  m.projector.mirror_cubic_cols = 1.5;
  m.projector.sheet_smile_cols = -0.8;
  m.projector.fan_half_angle_deg = 22.0;
  return m;
}

TEST(ProbeModel, CurvedSheetModelsAreVersionTwoAndRoundTrip) {
  const ProbeModel a = CurvedProbe();
  const std::string text = ToJson(a);
  EXPECT_NE(text.find("mlprobe-probe-model/2"), std::string::npos);
  const ProbeModel b = ParseProbeModel(text);
  EXPECT_EQ(ToJson(b), text);
  EXPECT_EQ(b.projector.mirror_cubic_cols, 1.5);
  EXPECT_EQ(b.projector.sheet_smile_cols, -0.8);
  EXPECT_EQ(b.projector.fan_half_angle_deg, 22.0);
  // Without the terms a model stays /1, readable by every firmware.
  EXPECT_NE(ToJson(LoadProbeModel(kReference)).find("mlprobe-probe-model/1"), std::string::npos);
  ProbeModel bad = a;
  bad.projector.mirror_cubic_cols = 400.0;  // the actual column would run backwards
  EXPECT_THROW(bad.Validate(), ProbeModelError);
}

// A point, the commanded column whose curved sheet lights it and its pixel: triangulation gives
// the point back, across the field and the mirror's range.
constexpr double kTriangulationExactMm = 1e-9;

TEST(ProbeModel, TriangulationMeetsTheCurvedSheet) {
  const ProbeModel m = CurvedProbe();
  int checked = 0;
  for (double x = -25.0; x <= 25.0; x += 5.0) {
    for (double y = -20.0; y <= 20.0; y += 5.0) {
      const Vec3 p(x, y, 118.0 + 0.1 * x);
      const double column = m.projector.CommandedColumnOf(p);
      const Vec2 pixel = m.camera.Project(p);
      EXPECT_NEAR(m.projector.CommandedColumn(m.projector.ActualColumn(column)), column,
                  kDesignExact);
      EXPECT_LT((Triangulate(m, pixel.x(), pixel.y(), column).value() - p).norm(),
                kTriangulationExactMm)
          << x << ", " << y;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 99);
}

// A pixel whose ray runs along the light plane has no depth: no point, and no exception that
// would end the whole sweep (ReconstructSweep skips it).
TEST(ProbeModel, AGrazingRayGivesNoPoint) {
  const ProbeModel m = CurvedProbe();
  const double column = 0.0;
  Vec3 normal;
  double offset = 0.0;
  m.projector.PlaneOf(m.projector.ActualColumn(column), &normal, &offset);
  Vec3 along = normal.cross(Vec3::UnitX()).normalized();  // in the plane's direction
  if (along.z() < 0) along = -along;
  const Vec2 pixel = m.camera.Project(100.0 * along);
  EXPECT_FALSE(Triangulate(m, pixel.x(), pixel.y(), column).has_value());
  // A ray 3 degrees off the plane meets it.
  const Vec2 off_plane = m.camera.Project(100.0 * (along + 0.05 * normal).normalized());
  EXPECT_TRUE(Triangulate(m, off_plane.x(), off_plane.y(), column).has_value());
}

TEST(ProbeModel, BadFilesNameTheField) {
  const std::string good = ReadFile(kReference);
  auto replace = [&](const std::string& from, const std::string& to) {
    std::string s = good;
    const auto at = s.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return s.replace(at, from.size(), to);
  };
  ExpectError("{", "not valid JSON");
  ExpectError("[]", "JSON object");
  ExpectError(replace("mlprobe-probe-model/1", "mlprobe-probe-model/3"), "format");
  ExpectError(replace("\"fx_px\": 4637.681", "\"fx_px\": -1"), "fx_px");
  ExpectError(replace("\"bit_depth\": 8", "\"bit_depth\": 7"), "bit_depth");
  ExpectError(replace("\"bit_depth\": 8", "\"bit_depth\": 8.5"), "bit_depth");
  ExpectError(replace("\"columns\": 1024", "\"columns\": \"many\""), "columns");
  ExpectError(replace("[60.0, 0.0, 0.0]", "[0.1, 0.0, 0.0]"), "baseline");
  ExpectError(replace("\"speckle_contrast\": 0.08", "\"speckle_contrast\": 1.5"), "speckle");
  ExpectError(replace("\"serial\": \"MLP-REF-0001\"", "\"serial\": \"\""), "serial");
}

TEST(ProbeModel, SaveWritesAtomicallyAndRefusesInvalid) {
  const auto dir = std::filesystem::temp_directory_path() / "mlp_probe_model_test";
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "probe.json").string();
  ProbeModel m = LoadProbeModel(kReference);
  SaveProbeModel(m, path);
  EXPECT_EQ(ToJson(LoadProbeModel(path)), ToJson(m));
  const std::string before = ReadFile(path);
  m.camera.fx_px = 0.0;
  EXPECT_THROW(SaveProbeModel(m, path), ProbeModelError);
  EXPECT_EQ(ReadFile(path), before);  // nothing changed
  EXPECT_FALSE(std::filesystem::exists(path + ".tmp"));
  std::filesystem::remove_all(dir);
}

TEST(StripeFile, RoundTripKeepsWhatCalibrationNeeds) {
  const std::string path = ::testing::TempDir() + "/stripes.json";
  StripeFile f{"MLP-T-1", "view01", {{1023.45678, 700, 612.875, 0.5}, {10.0, 0, 0.0, 1.0}}};
  SaveStripeFile(f, path);
  const StripeFile g = LoadStripeFile(path);
  EXPECT_EQ(g.probe_serial, "MLP-T-1");
  EXPECT_EQ(g.capture_id, "view01");
  ASSERT_EQ(g.points.size(), 2u);
  EXPECT_NEAR(g.points[0].x_px, 1023.45678, kStoredPx);
  EXPECT_EQ(g.points[0].y_px, 700);
  EXPECT_EQ(g.points[0].column, 612.875);
}

// A centre found down a column is sub-pixel in y: version 2 stores it so; version 1 files (rows
// only) still read.
TEST(StripeFile, ColumnScanCentresAndVersionOneFiles) {
  const std::string path = ::testing::TempDir() + "/stripes_v2.json";
  SaveStripeFile({"MLP-T-1", "view02", {{812.0, 640.12345, 300.5, 0.25}}}, path);
  const StripeFile g = LoadStripeFile(path);
  ASSERT_EQ(g.points.size(), 1u);
  EXPECT_EQ(g.points[0].x_px, 812.0);
  EXPECT_NEAR(g.points[0].y_px, 640.12345, kStoredPx);
  std::ofstream(path)
      << R"({"format": "mlprobe-stripes/1", "probe_serial": "P", "capture_id": "c", )"
      << R"("points": [[10.5, 700, 3, 0.5]]})";
  EXPECT_EQ(LoadStripeFile(path).points[0].y_px, 700.0);
}

TEST(StripeFile, BadFilesNameTheEntry) {
  const std::string path = ::testing::TempDir() + "/bad_stripes.json";
  const auto expect_error = [&](const std::string& text, const std::string& needle) {
    std::ofstream(path) << text;
    try {
      LoadStripeFile(path);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const StripeFileError& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  const std::string head =
      R"({"format": "mlprobe-stripes/1", "probe_serial": "P", "capture_id": "c", "points": )";
  expect_error(head + "[[1, 2, 3]]}", "points[0]");
  expect_error(head + "[[1, 2.5, 3, 0.5]]}", "integer");
  expect_error(head + "[[1, 2, -3, 0.5]]}", "negative");
  expect_error(head + "[[1, 2, 3, 1.5]]}", "quality");
  expect_error(head + "[[1e300, 2, 3, 0.5]]}", "finite");
  expect_error(head + "7}", "array");
  expect_error(R"({"format": "mlprobe-stripes/3"})", "format");
  EXPECT_THROW(LoadStripeFile(path + ".missing"), StripeFileError);
}

TEST(CloudFile, RoundTripWithThePose) {
  const std::string path = ::testing::TempDir() + "/cloud.ply";
  Eigen::Isometry3d h;
  h.matrix() << 1, 0, 0, 30.125, 0, -1, 0, 30, 0, 0, -1, 120.000000001, 0, 0, 0, 1;
  WriteCloudPly(path, {1.5, -2.25, 120.0, 0, 0, 99.5}, {0.5f, 1.0f},
                {"P-1", "cal-7", "c1", h, "probe", std::nullopt});
  const CloudFile f = ReadCloudPly(path);
  EXPECT_EQ(f.meta.probe_serial, "P-1");
  EXPECT_EQ(f.meta.calibration_id, "cal-7");
  EXPECT_EQ(f.meta.capture_id, "c1");
  ASSERT_TRUE(f.meta.mcs_from_flange);
  EXPECT_TRUE(f.meta.mcs_from_flange->matrix() == h.matrix());  // exact: 17 digits
  // A file whose pose is not a rigid transform (scaled here) is refused, naming why.
  Eigen::Isometry3d scaled = h;
  scaled.matrix()(0, 0) = 1.1;
  WriteCloudPly(path, {1.5, -2.25, 120.0}, {0.5f},
                {"P-1", "cal-7", "c1", scaled, "probe", std::nullopt});
  try {
    ReadCloudPly(path);
    ADD_FAILURE() << "a scaled pose was read";
  } catch (const CloudFileError& e) {
    EXPECT_NE(std::string(e.what()).find("not orthonormal"), std::string::npos) << e.what();
  }
  WriteCloudPly(path, {1.5, -2.25, 120.0, 0, 0, 99.5}, {0.5f, 1.0f},
                {"P-1", "cal-7", "c1", h, "probe", std::nullopt});
  EXPECT_EQ(f.xyz, (std::vector<double>{1.5, -2.25, 120.0, 0, 0, 99.5}));
  EXPECT_EQ(f.quality, (std::vector<float>{0.5f, 1.0f}));
  EXPECT_THROW(WriteCloudPly(path, {1, 2}, {1.0f}, {}), CloudFileError);  // sizes differ
  // A truncated file is refused, not read short.
  std::filesystem::resize_file(path, std::filesystem::file_size(path) - 3);
  EXPECT_THROW(ReadCloudPly(path), CloudFileError);
  std::ofstream(path) << "ply\nformat ascii 1.0\nend_header\n";
  EXPECT_THROW(ReadCloudPly(path), CloudFileError);
}

// The LED frame's edge rides in a comment, exactly; one that is not an edge is refused.
TEST(CloudFile, RoundTripWithTheEdge) {
  const std::string path = ::testing::TempDir() + "/edge.ply";
  base::EdgeSight edge;
  edge.normal_in_probe = Eigen::Vector3d(0.3, -0.9, 0.1).normalized();
  const Eigen::Vector3d along = edge.normal_in_probe.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d mid = edge.normal_in_probe.cross(along).normalized();
  edge.first_ray_in_probe = (mid.z() > 0 ? mid : Eigen::Vector3d(-mid)) - 0.01 * along;
  edge.first_ray_in_probe.normalize();
  edge.last_ray_in_probe = (mid.z() > 0 ? mid : Eigen::Vector3d(-mid)) + 0.01 * along;
  edge.last_ray_in_probe.normalize();
  edge.rms_px = 0.125;
  edge.points = 117;
  WriteCloudPly(path, {1.5, -2.25, 120.0}, {0.5f}, {"P-1", "cal-7", "c1", {}, "probe", edge});
  const CloudFile f = ReadCloudPly(path);
  ASSERT_TRUE(f.meta.edge);
  EXPECT_TRUE(f.meta.edge->normal_in_probe == edge.normal_in_probe);  // exact: 17 digits
  EXPECT_TRUE(f.meta.edge->first_ray_in_probe == edge.first_ray_in_probe);
  EXPECT_TRUE(f.meta.edge->last_ray_in_probe == edge.last_ray_in_probe);
  EXPECT_EQ(f.meta.edge->rms_px, 0.125);
  EXPECT_EQ(f.meta.edge->points, 117u);
  WriteCloudPly(path, {1.5, -2.25, 120.0}, {0.5f}, {"P-1", "cal-7", "c1", {}, "probe", {}});
  EXPECT_FALSE(ReadCloudPly(path).meta.edge);
  // A ray off the edge's plane is no edge: refused with the reason.
  base::EdgeSight bent = edge;
  bent.last_ray_in_probe = Eigen::Vector3d(0.3, 0.1, 1.0).normalized();
  std::ofstream out(path, std::ios::trunc);
  out << "ply\nformat binary_little_endian 1.0\ncomment edge";
  for (double v : base::EdgeSightNumbers(bent)) out << " " << v;
  out << " 117\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\n"
         "property float quality\nend_header\n";
  out.close();
  try {
    ReadCloudPly(path);
    ADD_FAILURE() << "a bent edge was read";
  } catch (const CloudFileError& e) {
    EXPECT_NE(std::string(e.what()).find("off the edge's plane"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace mlp::probe_fw
