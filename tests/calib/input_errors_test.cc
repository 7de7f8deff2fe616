// The error convention (docs/DEVELOPING.md, "Errors"): every module's bad-input error is a
// base::InputError, and an error from a lower module reaches the caller as itself, with its own
// words, rather than re-thrown as the caller's type.

#include "mlp/base/input_error.h"
#include "mlp/calib/board_views.h"
#include "mlp/calib/capture_io.h"
#include "mlp/calib/record.h"
#include "mlp/probe_fw/cloud_file.h"
#include "mlp/probe_fw/frame_io.h"
#include "mlp/probe_fw/probe_model.h"
#include "mlp/probe_fw/stripe_file.h"

#include <filesystem>
#include <fstream>
#include <type_traits>

#include <gtest/gtest.h>

namespace mlp::calib {
namespace {

namespace fs = std::filesystem;

static_assert(std::is_base_of_v<base::InputError, CaptureIoError>);
static_assert(std::is_base_of_v<base::InputError, RecordError>);
static_assert(std::is_base_of_v<base::InputError, CameraCalibError>);
static_assert(std::is_base_of_v<base::InputError, probe_fw::FrameIoError>);
static_assert(std::is_base_of_v<base::InputError, probe_fw::StripeFileError>);
static_assert(std::is_base_of_v<base::InputError, probe_fw::CloudFileError>);
static_assert(std::is_base_of_v<base::InputError, probe_fw::ProbeModelError>);

// A board-view manifest whose view folder holds no capture: the frame reader's own error, naming
// the folder, reaches the caller (it used to be re-thrown as a CaptureIoError).
TEST(InputErrors, AFrameErrorReachesTheCallerAsItself) {
  const fs::path dir = fs::temp_directory_path() / "mlp_calib_input_errors";
  fs::remove_all(dir);
  fs::create_directories(dir / "view01");
  const fs::path manifest = dir / "views.json";
  std::ofstream(manifest) << R"({"format": "mlprobe-board-views/1",
    "board": {"inner_cols": 9, "inner_rows": 6, "square_mm": 2.5}, "views": ["view01"]})";
  try {
    LoadBoardViews(manifest.string(), false);
    FAIL() << "an empty view folder was accepted";
  } catch (const base::InputError& e) {
    EXPECT_NE(dynamic_cast<const probe_fw::FrameIoError*>(&e), nullptr) << e.what();
    EXPECT_NE(std::string(e.what()).find("view01"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace mlp::calib
