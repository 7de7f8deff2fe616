// mlp-grind-hal: the grinding cell (seed 001) as a LinuxCNC HAL user-space component (named by
// --name, default "mlp-grind"; docs/GRIND.md, "On the machine"). Each cycle it reads the slide's
// x, y, z and the NC's theoretical wheel centre C; the wheel below the work's top takes its
// section out of the virtual work; at each top of stroke clear of the view the camera's frame
// is taken and, after a cut at C, measured against the frame from before the cut. The result
// and the compensation go out on pins; the running program (subs/mlp_grind_point.ngc) waits
// for `ready`, stops on `refused` and applies the compensation as a work offset.
//
// Pins (NAME.*): in float x-mm, y-mm, z-mm (the slide, machine coordinates), c-x-mm, c-y-mm
// (the NC's C: the program's coordinates, from motion.analog-out), sim-error-x-mm,
// sim-error-y-mm (the virtual machine's error; --sim-error-mm at start); out s32 tops, captures,
// measured, cuts, feed (0 good, 1 under-feed, 2 over-feed); out bit ready (a measurement
// since the wheel last cut), refused (the last measurement: none possible, or its
// compensation over the limit); out float d-mm, error-mm, comp-x-mm, comp-y-mm, top-mm.
// Why user space: rendering and measuring a frame takes a tenth of a second, far beyond a
// servo period; the frame is taken at the top, where nothing waits for it.

#include "mlp/host/grind_station_args.h"

#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include <hal.h>

namespace {

volatile std::sig_atomic_t g_stop = 0;
void OnSignal(int /*signal*/) { g_stop = 1; }

struct Pins {
  hal_float_t *x_mm, *y_mm, *z_mm, *c_x_mm, *c_y_mm, *sim_error_x_mm, *sim_error_y_mm;
  hal_s32_t *tops, *captures, *measured, *cuts, *feed;
  hal_bit_t *ready, *refused;
  hal_float_t *d_mm, *error_mm, *comp_x_mm, *comp_y_mm, *top_mm;
};

bool MakePins(const std::string& name, int comp, Pins* p) {
  const auto pin = [&name](const char* suffix) { return name + "." + suffix; };
  const auto in = [&](const char* s, hal_float_t** f) {
    return hal_pin_float_new(pin(s).c_str(), HAL_IN, f, comp) == 0;
  };
  const auto out = [&](const char* s, hal_float_t** f) {
    return hal_pin_float_new(pin(s).c_str(), HAL_OUT, f, comp) == 0;
  };
  const auto count = [&](const char* s, hal_s32_t** n) {
    return hal_pin_s32_new(pin(s).c_str(), HAL_OUT, n, comp) == 0;
  };
  const auto flag = [&](const char* s, hal_bit_t** b) {
    return hal_pin_bit_new(pin(s).c_str(), HAL_OUT, b, comp) == 0;
  };
  return in("x-mm", &p->x_mm) && in("y-mm", &p->y_mm) && in("z-mm", &p->z_mm) &&
         in("c-x-mm", &p->c_x_mm) && in("c-y-mm", &p->c_y_mm) &&
         in("sim-error-x-mm", &p->sim_error_x_mm) && in("sim-error-y-mm", &p->sim_error_y_mm) &&
         count("tops", &p->tops) && count("captures", &p->captures) &&
         count("measured", &p->measured) && count("cuts", &p->cuts) && count("feed", &p->feed) &&
         flag("ready", &p->ready) && flag("refused", &p->refused) && out("d-mm", &p->d_mm) &&
         out("error-mm", &p->error_mm) && out("comp-x-mm", &p->comp_x_mm) &&
         out("comp-y-mm", &p->comp_y_mm) && out("top-mm", &p->top_mm);
}

// A measurement onto the pins, and into LinuxCNC's log (what was measured where, and why not).
void Publish(const mlp::grind::StationMeasurement& m, int count, Pins* p) {
  const mlp::grind::PointResult& r = m.point;
  *p->refused = m.refused;
  *p->feed = static_cast<std::int32_t>(r.feed);
  *p->d_mm = r.d_mm;
  *p->error_mm = r.error_mm;
  *p->comp_x_mm = m.refused ? 0.0 : r.compensation_mm.x();
  *p->comp_y_mm = m.refused ? 0.0 : r.compensation_mm.y();
  *p->top_mm = m.top.top_mm;
  *p->measured = count;
  std::fprintf(
      stderr, "mlp-grind-hal: C (%.4f, %.4f) mm: %s, d %.2f um, compensation (%.2f, %.2f) um%s%s\n",
      m.c_mm.x(), m.c_mm.y(), mlp::grind::ToString(r.feed), r.d_mm * 1e3,
      r.compensation_mm.x() * 1e3, r.compensation_mm.y() * 1e3, m.refused ? " REFUSED: " : "",
      m.why.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  mlp::host::GrindStationArgs args;
  try {
    args = mlp::host::ParseGrindStationArgs(std::vector<std::string>(argv + 1, argv + argc));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mlp-grind-hal: %s\n%s", e.what(), mlp::host::GrindStationUsage());
    return 2;
  }
  mlp::grind::GrindStation station(args.config, args.seed);  // the stock's frame: before HAL
  const int comp = hal_init(args.name.c_str());
  if (comp < 0) {
    std::fprintf(stderr, "mlp-grind-hal: hal_init failed (%d): is LinuxCNC running?\n", comp);
    return 1;
  }
  auto* pins = static_cast<Pins*>(hal_malloc(sizeof(Pins)));
  if (pins == nullptr || !MakePins(args.name, comp, pins)) {
    std::fprintf(stderr, "mlp-grind-hal: cannot create the pins\n");
    hal_exit(comp);
    return 1;
  }
  std::signal(SIGTERM, OnSignal);
  std::signal(SIGINT, OnSignal);
  *pins->sim_error_x_mm = args.config.machine_error_mm.x();
  *pins->sim_error_y_mm = args.config.machine_error_mm.y();
  hal_ready(comp);
  const auto start = std::chrono::steady_clock::now();
  int measured = 0;
  while (g_stop == 0) {
    std::this_thread::sleep_for(std::chrono::microseconds(args.cycle_us));
    const double t_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    station.SetMachineError({*pins->sim_error_x_mm, *pins->sim_error_y_mm});
    const auto m =
        station.Step(t_s, {*pins->x_mm, *pins->y_mm}, *pins->z_mm, {*pins->c_x_mm, *pins->c_y_mm});
    if (m) Publish(*m, ++measured, pins);
    *pins->tops = station.Tops();
    *pins->captures = station.Captures();
    *pins->cuts = station.Cuts();
    *pins->ready = station.Fresh();
  }
  hal_exit(comp);
  return 0;
}
