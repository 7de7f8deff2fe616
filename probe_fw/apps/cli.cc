#include "cli.h"

#include "mlp/probe_fw/roi_spec.h"

namespace mlp::probe_fw::cli {

Aoi ParseAoi(const std::string& text) {
  try {
    return probe_fw::ParseAoi(text);
  } catch (const RoiError& e) {
    throw UsageError(e.what());
  }
}

}  // namespace mlp::probe_fw::cli
