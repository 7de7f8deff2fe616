#pragma once
/// @file A tool camera's images as it leaves them: DIR/images.json (`mlprobe-tool-images/1`,
/// tool_images.h) and the images it lists, PGM, PNG or BMP (lossless; their size is read from their
/// header before they are decoded); and the camera for a
/// tool in them from a calibration file (`mlprobe-tool-camera/1`, pin_calibration.h). Shared by
/// `mlp tool` and the host service's tool job, which reads folders a client names: every
/// listed file must be a plain name in the manifest's folder, and the images are bounded.

#include "mlp/toolcam/measure.h"
#include "mlp/toolcam/tool_camera.h"
#include "mlp/toolcam/tool_images.h"
#include "mlp/toolcam/two_views.h"

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace mlp::toolcam {

struct ToolImageSeries : ToolImages {
  std::vector<std::vector<std::uint8_t>> pixels;  ///< one per file, row-major grey
};

/// At most this many pixels over a series (1 GiB): a manifest cannot make a reader allocate
/// without bound.
constexpr std::int64_t kMaxSeriesPixels = std::int64_t{1} << 30;

/// Reads DIR/images.json and its images. Throws ToolInputError naming the file: a manifest
/// over 1 MiB or out of range, a file name with a folder in it or starting with a dot, an image
/// that cannot be read, is not PGM, PNG or BMP or does not declare the manifest's size (checked
/// before decoding), more than kMaxSeriesPixels.
ToolImageSeries ReadToolImageSeries(const std::string& dir);

/// The camera for a tool `length_mm` long in `series`: the calibration's (`calibration_json`,
/// named `where` in errors, with the series' spindle shift through the frame loop) or, when
/// that is empty, the manifest's own (refused when it has none). A pitch over `pitch_warn_deg`
/// adds a warning.
ToolCameraModel ToolCameraFor(const ToolImageSeries& series,
                              const std::string& calibration_json,
                              const std::string& where,
                              double length_mm,
                              double pitch_warn_deg,
                              std::vector<std::string>* warnings);

/// A measurement as `mlp tool measure --json` and the host's tool job give it (docs/TOOLCAM.md):
/// the tool's diameter, length, runout, both flanks and the axis, the worst finding against the
/// wear limit, and per flute its edge, radius, runout, tip and views with their findings.
nlohmann::json ToolMeasurementJson(const ToolDescription& tool, const ToolMeasurement& m);

/// Two cameras' measurement (seed 000 example 7): each camera's as above ("a", "b") and what
/// the pair triangulates ("two_views": the pair's angle, the spindle axis in space, the tips,
/// each edge as a point) [mm, deg].
nlohmann::json ToolIn3dJson(const ToolDescription& tool, const ToolIn3d& t);

}  // namespace mlp::toolcam
