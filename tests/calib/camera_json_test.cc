// calib/camera_json: the camera calibration file is written and read in one place; what is read
// back is what was written, and a damaged file is refused naming the field.

#include "mlp/calib/camera_json.h"

#include <string>

#include <gtest/gtest.h>

namespace mlp::calib {
namespace {

BoardViews TwoViews() {
  BoardViews v;
  v.board = {9, 6, 2.5};
  v.probe_serial = "MLP-0007";
  for (int i = 0; i < 2; ++i) {
    BoardView view;
    view.dir = "views/" + std::to_string(i);
    view.capture_id = "c" + std::to_string(i);
    view.led.width = 1280;
    view.led.height = 1024;
    v.views.push_back(view);
  }
  return v;
}

CameraCalibration Calibration() {
  CameraCalibration c;
  c.intrinsics = {2400.125, 2399.75, 640.5, 511.25, -0.071, 0.12, 1e-4, -2e-4, 0.003};
  c.std_dev = {0.3, 0.31, 0.2, 0.21, 1e-3, 2e-3, 1e-5, 1e-5, 4e-3};
  c.rms_reprojection_px = 0.041;
  c.views_used = {1};  // the first view had no board
  c.view_rms_px = {0.039};
  return c;
}

TEST(CameraFile, WhatIsReadBackIsWhatWasWritten) {
  const nlohmann::ordered_json j = CameraFileJson(TwoViews(), Calibration());
  EXPECT_EQ(j.at("views").at(0).at("skipped"), "no complete board found");
  EXPECT_DOUBLE_EQ(j.at("views").at(1).at("rms_px").get<double>(), 0.039);
  const CameraFile f = ParseCameraFile(j.dump(2), "camera.json");
  EXPECT_EQ(f.probe_serial, "MLP-0007");
  EXPECT_EQ(f.width_px, 1280);
  EXPECT_EQ(f.height_px, 1024);
  // JSON keeps a double exactly (nlohmann writes the shortest text that reads back the same).
  EXPECT_EQ(f.intrinsics.fx_px, 2400.125);
  EXPECT_EQ(f.intrinsics.k3, 0.003);
  EXPECT_EQ(f.intrinsics.p2, -2e-4);
  EXPECT_EQ(f.std_dev.k3, 4e-3);
  EXPECT_EQ(f.rms_reprojection_px, 0.041);
}

TEST(CameraFile, ADamagedFileIsRefusedNamingTheField) {
  const std::string good = CameraFileJson(TwoViews(), Calibration()).dump();
  const auto refused = [](const std::string& text, const std::string& why) {
    try {
      ParseCameraFile(text, "camera.json");
      ADD_FAILURE() << "not refused: " << why;
    } catch (const CameraCalibError& e) {
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
    }
  };
  refused("{", "not valid JSON");
  refused(R"({"format": "mlprobe-camera/2"})", "format must be");
  nlohmann::json j = nlohmann::json::parse(good);
  j["intrinsics"].erase("k2");
  refused(j.dump(), "camera.json.intrinsics.k2 must be a number");
  j = nlohmann::json::parse(good);
  j["intrinsics"]["fx_px"] = -1.0;
  refused(j.dump(), "focal lengths must be positive");
  j = nlohmann::json::parse(good);
  j["image_size_px"] = {1280.5, 1024};
  refused(j.dump(), "image_size_px");
}

}  // namespace
}  // namespace mlp::calib
