#include "mlp/jobs/relocate.h"

#include <cmath>
#include <iomanip>
#include <sstream>

namespace mlp::jobs {

void CheckElectrode(const toolcam::ToolDescription& tool) {
  if (!tool.electrode) throw RequestError("request.tool: " + tool.id + " is not an electrode");
}

toolcam::Relocation AssessRelocate(const RelocateInputs& in) {
  CheckElectrode(in.electrode);
  try {
    return toolcam::Relocate({in.reference.pixels, in.reference.turn_deg, in.reference.camera},
                             {in.now.pixels, in.now.turn_deg, in.now.camera}, in.electrode);
  } catch (const toolcam::ToolInputError& x) {
    throw RequestError(std::string("request.images: ") + x.what());
  }
}

std::vector<OffsetChangeAsked> RelocateChangesAsked(const toolcam::Relocation& r,
                                                    const RelocateMachine& m) {
  const geometry::Vec3& t = r.change.translation_mm;
  std::vector<OffsetChangeAsked> asked;
  for (const OffsetChangeAsked& c :
       {OffsetChangeAsked{nc::ToolRegister::kLengthGeometry, -t.z()},
        OffsetChangeAsked{nc::ToolRegister::kOffsetX, -t.x()},
        OffsetChangeAsked{nc::ToolRegister::kOffsetY, -t.y()},
        OffsetChangeAsked{nc::ToolRegister::kOffsetC, -r.rotation_deg[2]}}) {
    const char word = nc::OffsetWord(c.reg);
    if (word != 0 && m.axes.find(word) == std::string::npos) continue;  // no such axis
    asked.push_back(c);
  }
  return asked;
}

nc::NcResult RelocateChanges(const RelocateInputs& in,
                             const toolcam::Relocation& r,
                             std::int64_t job,
                             std::vector<nc::ToolOffsetChange> resolved) {
  nc::NcResult out;
  out.header =
      "mlprobe job " + std::to_string(job) + ": electrode " + in.electrode.id + " re-located";
  out.tools = std::move(resolved);
  out.named = {{"status", 0.0}, {"tilt_deg", r.tilt_deg}};
  return out;
}

std::vector<std::string> RelocateRefusal(const RelocateInputs& in,
                                         const toolcam::Relocation& r,
                                         const nc::NcResult& out,
                                         const RelocateMachine& m) {
  std::vector<std::string> problems;
  std::ostringstream s;
  s << std::fixed << std::setprecision(4);
  if (!m.tool_table)
    problems.push_back(
        "a re-located electrode's X, Y and C offsets go to LinuxCNC's tool table only");
  if (r.tilt_deg > in.max_tilt_deg) {
    s << "the electrode is tilted " << r.tilt_deg << " deg, beyond " << in.max_tilt_deg
      << " deg, which no offset corrects: clamp it again";
    problems.push_back(s.str());
  }
  // Without a C axis its turn is not corrected either: the same limit.
  if (m.axes.find('C') == std::string::npos && std::abs(r.rotation_deg[2]) > in.max_tilt_deg) {
    std::ostringstream p;
    p << std::fixed << std::setprecision(4) << "the electrode is turned " << r.rotation_deg[2]
      << " deg and the machine has no C axis (controller.axes " << m.axes << "), beyond "
      << in.max_tilt_deg << " deg: clamp it again";
    problems.push_back(p.str());
  }
  for (const nc::ToolOffsetChange& c : out.tools) {
    const bool turn = c.reg == nc::ToolRegister::kOffsetC;
    const double limit = turn ? m.max_rotation_change_deg : m.max_offset_change_mm;
    if (!(std::abs(c.after_mm - c.before_mm) <= limit)) {
      std::ostringstream p;
      p << std::fixed << std::setprecision(4) << "the " << nc::ToString(c.reg)
        << " would change by " << c.after_mm - c.before_mm << (turn ? " deg" : " mm") << ", beyond "
        << limit << ": a wrong electrode or tool number?";
      problems.push_back(p.str());
    }
  }
  return problems;
}

}  // namespace mlp::jobs
