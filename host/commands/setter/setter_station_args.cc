#include "mlp/host/setter_station_args.h"

#include "mlp/base/args.h"
#include "mlp/host/cli.h"

#include <algorithm>

namespace mlp::host {

const char* SetterStationUsage() {
  return "usage: mlp-setter-hal --curve CURVE.json --beam-mm B [--name NAME] [--approach -1|1]\n"
         "                      [--teeth-mm R1,R2,..] [--feed-mm-min F] [--threshold-share S]\n"
         "                      [--sample-rate-hz H] [--noise-v N] [--drops-per-s D]\n"
         "                      [--seed N] [--cycle-us U]\n"
         "  a LinuxCNC HAL user-space component NAME (default mlp-setter; loadusr -Wn NAME\n"
         "  mlp-setter-hal --name NAME ...), pins NAME.position, .arm, .rpm, .sim-base-mm in,\n"
         "  .trigger, .edge-offset-mm, .deepest-share, .rejections, .samples out:\n"
         "  the virtual setter's beam at B on the approach's axis, the processor with CURVE;\n"
         "  the tool's teeth (one radius: a pin); F the probing feed the macro uses\n";
}

std::vector<double> ParseRadiiList(const std::string& option, const std::string& list) {
  std::vector<double> r;
  try {
    r = base::ParseNumberList(option, list);
  } catch (const UsageError&) {
    r.clear();
  }
  if (r.empty() || *std::min_element(r.begin(), r.end()) <= 0)
    throw UsageError(option + " takes radii > 0 separated by commas, not \"" + list + "\"");
  return r;
}

SetterStationArgs ParseSetterStationArgs(const std::vector<std::string>& args) {
  const base::Args a(args, {{"--name", "--curve", "--beam-mm", "--approach", "--teeth-mm",
                             "--feed-mm-min", "--threshold-share", "--sample-rate-hz", "--noise-v",
                             "--drops-per-s", "--seed", "--cycle-us"}});
  SetterStationArgs out;
  out.name = HalComponentName(a.Text("--name", out.name));
  setter::SetterStationConfig& c = out.config;
  const std::string curve_path = a.Text("--curve");
  c.processor.curve = setter::ParseCurve(ReadInputFile(curve_path), curve_path);
  c.beam_mm = a.Number("--beam-mm");
  c.approach_sign = a.Number("--approach", -1.0);
  c.tool.tooth_radius_mm = ParseRadiiList("--teeth-mm", a.Text("--teeth-mm", "3.0"));
  c.processor.teeth = c.tool.Teeth();
  c.processor.feed_mm_min = a.Number("--feed-mm-min", c.processor.feed_mm_min);
  c.processor.threshold_share = a.Number("--threshold-share", c.processor.threshold_share);
  c.beam.sample_rate_hz = a.Number("--sample-rate-hz", c.beam.sample_rate_hz);
  c.processor.sample_rate_hz = c.beam.sample_rate_hz;
  c.beam.clear_v = c.processor.curve.clear_v;
  c.beam.noise_v = a.Number("--noise-v", c.beam.noise_v);
  c.beam.drops_per_s = a.Number("--drops-per-s", c.beam.drops_per_s);
  out.seed = static_cast<unsigned>(a.Integer("--seed", out.seed));
  out.cycle_us = static_cast<int>(a.Integer("--cycle-us", out.cycle_us, 50));
  if (out.cycle_us > 100000) throw UsageError("--cycle-us: 50..100000");
  c.Validate();
  setter::ProcessorConfig check = c.processor;  // the processor's own checks, turning or not
  check.Validate();
  return out;
}

}  // namespace mlp::host
