#pragma once
// The tool camera's job on a site: the virtual tool camera's images of a D10 end mill, new and
// worn, and the job that measures it into T3 (the tool job's tests, and its kills beside a
// running LinuxCNC).

#include <string>

#include "hostd_site.h"

namespace mlp::test {

inline const std::string kTools = mlp::test::SourceDir() + "/samples/tools/";
/// T3 as a tool table holds it before the camera measured it.
inline const std::string kToolT3 = "T3 P3 Z+75.100000 D+10.050000 ;D10 Z4 roughing\n";

/// The virtual tool camera's images of `tool` into the site's data folder (the manifest holds
/// the virtual camera's own calibration).
inline void RenderInto(const Site& site, const std::string& tool, const std::string& folder) {
  const auto r = RunProcess(kMlp + " tool render --tool " + kTools + tool + " --out " +
                            (site.dir / "data" / folder).string() +
                            " --rpm 5000 --fps 50 --resolution-deg 7.2 --pulse-share 0.1 "
                            "--drops 0 --seed 3");
  ASSERT_EQ(r.exit_code, 0) << r.err;
}

/// The D10 end mill's description in the site's data folder and its images, new (tools/new)
/// and with a 20 um chip (tools/worn).
inline void EndMillImages(const Site& site) {
  fs::create_directories(site.dir / "data" / "tools");
  fs::copy_file(kTools + "endmill_d10_z4_new.json",
                site.dir / "data" / "tools" / "endmill_d10_z4_new.json");
  RenderInto(site, "endmill_d10_z4_new.json", "tools/new");
  RenderInto(site, "endmill_d10_z4_worn.json", "tools/worn");
}

/// The tool job of T3 on lcnc-1 from the `images` folder.
inline json ToolJob(const std::string& images) {
  return {{"op", "tool"},
          {"machine", "lcnc-1"},
          {"images", images},
          {"tool", "tools/endmill_d10_z4_new.json"},
          {"tool_number", 3}};
}

}  // namespace mlp::test
