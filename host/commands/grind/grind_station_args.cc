#include "mlp/host/grind_station_args.h"

#include "mlp/base/args.h"
#include "mlp/host/cli.h"

namespace mlp::host {

const char* GrindStationUsage() {
  return "usage: mlp-grind-hal [--name NAME] [--job JOB.json] [--work-top-mm Z0] [--clear-mm ZC]\n"
         "                     [--min-stroke-mm S] [--hysteresis-mm H] [--max-comp-mm M]\n"
         "                     [--sim-error-mm X,Y] [--sim-wear-mm W] [--seed N]\n"
         "                     [--sampler CH] [--servo-period-ns P] [--cycle-us U]\n"
         "  a LinuxCNC HAL user-space component NAME (default mlp-grind; loadusr -Wn NAME\n"
         "  mlp-grind-hal --name NAME ...). The slide comes through the realtime sampler's\n"
         "  FIFO CH (default 0; loadrt sampler cfg=fffff, its pins on x, y, z in machine\n"
         "  coordinates and the NC's theoretical C x, y; addf it to the thread of period P ns,\n"
         "  default 1000000); the FIFO is read again U us after it was found empty (default\n"
         "  1000). Pins NAME.sim-error-x-mm, .sim-error-y-mm in; .tops, .captures, .measured,\n"
         "  .cuts,\n"
         "  .ready, .refused, .feed (0 good, 1 under-feed, 2 over-feed), .d-mm, .error-mm,\n"
         "  .comp-x-mm, .comp-y-mm, .top-mm out. The camera, the nominal profile, the wheel and\n"
         "  the limit e come from JOB (an mlprobe-grind/1 job; its points are not used; default\n"
         "  the demo's). A frame is taken at each top of stroke above ZC (default 2 mm); the\n"
         "  wheel cuts below Z0 (default 0); a compensation longer than M (default 0.1 mm) is\n"
         "  refused. The virtual machine's error (X,Y mm): the wheel's real centre less the\n"
         "  commanded one; its pins change it while running\n";
}

GrindStationArgs ParseGrindStationArgs(const std::vector<std::string>& args) {
  const base::Args a(args, {{"--name", "--job", "--work-top-mm", "--clear-mm", "--min-stroke-mm",
                             "--hysteresis-mm", "--max-comp-mm", "--sim-error-mm", "--sim-wear-mm",
                             "--seed", "--sampler", "--servo-period-ns", "--cycle-us"}});
  GrindStationArgs out;
  out.name = HalComponentName(a.Text("--name", out.name));
  grind::GrindStationConfig& c = out.config;
  if (a.Has("--job")) {
    c.job = grind::ParseJob(ReadInputFile(a.Text("--job")), a.Text("--job"));
  } else {
    c.job.profile = grind::DemoProfile();
  }
  c.work_top_mm = a.Number("--work-top-mm", c.work_top_mm);
  c.trigger.clear_mm = a.Number("--clear-mm", 2.0);
  c.trigger.min_stroke_mm = a.Number("--min-stroke-mm", c.trigger.min_stroke_mm);
  c.trigger.hysteresis_mm = a.Number("--hysteresis-mm", c.trigger.hysteresis_mm);
  c.max_compensation_mm = a.Number("--max-comp-mm", c.max_compensation_mm);
  if (a.Has("--sim-error-mm")) {
    const std::vector<double> xy =
        base::ParseNumberList("--sim-error-mm", a.Text("--sim-error-mm"));
    if (xy.size() != 2) throw UsageError("--sim-error-mm takes X,Y");
    c.machine_error_mm = {xy[0], xy[1]};
  }
  c.wear_mm = a.Number("--sim-wear-mm", c.wear_mm);
  out.seed = static_cast<unsigned>(a.Integer("--seed", out.seed));
  out.sampler_channel = static_cast<int>(a.Integer("--sampler", out.sampler_channel, 0));
  if (out.sampler_channel > 7) throw UsageError("--sampler: 0..7 (the sampler's channels)");
  out.servo_period_ns =
      static_cast<long>(a.Integer("--servo-period-ns", out.servo_period_ns, 1000));
  if (out.servo_period_ns > 100'000'000) throw UsageError("--servo-period-ns: 1000..100000000");
  out.cycle_us = static_cast<int>(a.Integer("--cycle-us", out.cycle_us, 50));
  if (out.cycle_us > 100000) throw UsageError("--cycle-us: 50..100000");
  c.Validate();
  return out;
}

}  // namespace mlp::host
