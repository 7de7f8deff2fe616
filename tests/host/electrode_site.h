#pragma once
// A site whose lcnc-1 is an EDM sinker with a C axis and an electrode's textures (before, after
// turned 0.4 deg and shifted, tilted 0.05 deg beyond the limit) drawn by `mlp tool
// render-texture`: relocate jobs run on it without a probe (the plant tests' jobs).

#include <filesystem>
#include <fstream>

#include "hostd_site.h"

namespace mlp::test {

inline const std::string kElectrode = mlp::test::SourceDir() + "/samples/tools/electrode_10x6.json";
inline const std::string kElectrodeTable =
    "T30 P30 X0.01 Y0 Z60.0 C0 D11.662 ;EDM electrode 10x6\n";

/// `config` with lcnc-1 as the sinker, written to the site with the table and the textures.
inline void ElectrodeSite(const Site& site, json config) {
  config["machines"][1]["controller"]["write_tool_table"] = true;
  config["machines"][1]["controller"]["axes"] = "XYZC";
  std::ofstream(site.dir / "hostd.json") << config.dump(1);
  std::ofstream(site.dir / "tool.tbl") << kElectrodeTable;
  fs::create_directories(site.dir / "data" / "tools");
  fs::copy_file(kElectrode, site.dir / "data" / "tools" / "electrode.json");
  for (const auto& [folder, pose] :
       {std::pair{"before", "--seed 1"},
        {"after", "--seed 2 --rotation-deg 0.003,-0.004,0.4 --shift-mm 0.03,-0.02,0.015"},
        {"tilted", "--seed 3 --rotation-deg 0.05,0,0"}}) {
    const auto r = RunProcess(kMlp + " tool render-texture --tool " + kElectrode + " --out " +
                              (site.dir / "data" / "tools" / folder).string() + " " + pose);
    ASSERT_EQ(r.exit_code, 0) << r.err;
  }
}

/// The relocate job of T30 on lcnc-1 from the `images` folder's texture.
inline json RelocateJob(const std::string& images) {
  return {{"op", "relocate"},
          {"machine", "lcnc-1"},
          {"reference", "tools/before"},
          {"images", "tools/" + images},
          {"tool", "tools/electrode.json"},
          {"tool_number", 30}};
}

}  // namespace mlp::test
