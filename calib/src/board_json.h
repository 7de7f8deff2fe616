#pragma once
// What the views manifests (mlprobe-board-views/1, mlprobe-robot-views/1) share: reading the
// file and its "board" object.

#include "mlp/base/files.h"
#include "mlp/base/json_fields.h"
#include "mlp/calib/camera_calib.h"
#include "mlp/calib/capture_io.h"

#include <fstream>
#include <sstream>
#include <string>

namespace mlp::calib {

inline std::string ReadTextFile(const std::string& path) {
  return base::ReadFileAs<CaptureIoError>(path);
}

inline ChessboardSpec ParseBoard(const base::json_fields::json& j, const std::string& where) {
  namespace jf = base::json_fields;
  const jf::json& b = jf::Object<CaptureIoError>(j, "board", where);
  ChessboardSpec s;
  s.inner_cols = jf::Integer<CaptureIoError>(b, "inner_cols", where + ".board");
  s.inner_rows = jf::Integer<CaptureIoError>(b, "inner_rows", where + ".board");
  s.square_mm = jf::Number<CaptureIoError>(b, "square_mm", where + ".board");
  if (s.inner_cols < 2 || s.inner_rows < 2 || s.inner_cols > 100 || s.inner_rows > 100 ||
      !(s.square_mm > 0))
    throw CaptureIoError(where + ".board: 2..100 inner corners each way and square_mm > 0");
  return s;
}

}  // namespace mlp::calib
