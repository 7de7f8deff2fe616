// mlp-setter-hal: the laser tool setter as a LinuxCNC HAL user-space component (named by
// --name, default "mlp-setter"; docs/SETTER.md, "On the machine"). Each cycle it reads the approach
// axis' position, renders the virtual beam's samples for the time passed and runs the setter's
// processor on them; the trigger drives motion.probe-input, so a G38.2 move stops at the
// skip, and edge-offset-mm says how far the axis moved past the edge before it fired.
//
// Pins (NAME.*): in float position (net the approach's joint feedback), in bit arm (a
// measurement: on, a fresh processor at the spindle's speed; off, idle), in float rpm, in
// float sim-base-mm (the virtual tool's reach beyond its teeth: a length); out bit trigger,
// out float edge-offset-mm, out float deepest-share, out s32 rejections, out s32 samples.
// Why a user-space component: the processor is the setter's DSP, not motion's: its cycle
// (a few hundred microseconds, not real-time) only adds latency to the skip, which
// edge-offset-mm and the test's figures account for.

#include "mlp/host/setter_station_args.h"
#include "mlp/setter/setter_station.h"

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <hal.h>

namespace {

volatile std::sig_atomic_t g_stop = 0;
void OnSignal(int /*signal*/) { g_stop = 1; }

struct Pins {
  hal_float_t* position;
  hal_bit_t* arm;
  hal_float_t* rpm;
  hal_float_t* sim_base_mm;
  hal_bit_t* trigger;
  hal_float_t* edge_offset_mm;
  hal_float_t* deepest_share;
  hal_s32_t* rejections;
  hal_s32_t* samples;
};

bool MakePins(const std::string& name, int comp, Pins* p) {
  const auto pin = [&name](const char* suffix) { return name + "." + suffix; };
  return hal_pin_float_new(pin("position").c_str(), HAL_IN, &p->position, comp) == 0 &&
         hal_pin_bit_new(pin("arm").c_str(), HAL_IN, &p->arm, comp) == 0 &&
         hal_pin_float_new(pin("rpm").c_str(), HAL_IN, &p->rpm, comp) == 0 &&
         hal_pin_float_new(pin("sim-base-mm").c_str(), HAL_IN, &p->sim_base_mm, comp) == 0 &&
         hal_pin_bit_new(pin("trigger").c_str(), HAL_OUT, &p->trigger, comp) == 0 &&
         hal_pin_float_new(pin("edge-offset-mm").c_str(), HAL_OUT, &p->edge_offset_mm, comp) == 0 &&
         hal_pin_float_new(pin("deepest-share").c_str(), HAL_OUT, &p->deepest_share, comp) == 0 &&
         hal_pin_s32_new(pin("rejections").c_str(), HAL_OUT, &p->rejections, comp) == 0 &&
         hal_pin_s32_new(pin("samples").c_str(), HAL_OUT, &p->samples, comp) == 0;
}

// One cycle: arm / disarm on the pin's edge, the samples of the time passed, the outputs.
void Cycle(mlp::host::SetterStationArgs& station_args,
           std::optional<mlp::setter::SetterStation>& station,
           double dt_s,
           Pins* p) {
  if (*p->arm && (!station || !station->Armed())) {
    station_args.config.base_reach_mm = *p->sim_base_mm;
    station.emplace(station_args.config, station_args.seed++);
    station->Arm(*p->rpm);
  } else if (!*p->arm && station && station->Armed()) {
    station->Disarm();
  }
  if (!station || !station->Armed()) {
    *p->trigger = false;
    return;
  }
  station->Advance(dt_s, *p->position);
  *p->trigger = station->Triggered();
  *p->edge_offset_mm = station->Triggered() ? station->trigger().edge_offset_mm : 0.0;
  *p->deepest_share = station->DeepestShare();
  *p->rejections = station->processor()->RejectionCount();
  *p->samples = static_cast<std::int32_t>(std::min<long>(station->Samples(), INT32_MAX));
}

}  // namespace

int main(int argc, char** argv) {
  mlp::host::SetterStationArgs station_args;
  try {
    station_args =
        mlp::host::ParseSetterStationArgs(std::vector<std::string>(argv + 1, argv + argc));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mlp-setter-hal: %s\n%s", e.what(), mlp::host::SetterStationUsage());
    return 2;
  }
  const int comp = hal_init(station_args.name.c_str());
  if (comp < 0) {
    std::fprintf(stderr, "mlp-setter-hal: hal_init failed (%d): is LinuxCNC running?\n", comp);
    return 1;
  }
  auto* pins = static_cast<Pins*>(hal_malloc(sizeof(Pins)));
  if (pins == nullptr || !MakePins(station_args.name, comp, pins)) {
    std::fprintf(stderr, "mlp-setter-hal: cannot create the pins\n");
    hal_exit(comp);
    return 1;
  }
  std::signal(SIGTERM, OnSignal);
  std::signal(SIGINT, OnSignal);
  hal_ready(comp);
  std::optional<mlp::setter::SetterStation> station;
  auto last = std::chrono::steady_clock::now();
  int status = 0;
  while (g_stop == 0) {
    std::this_thread::sleep_for(std::chrono::microseconds(station_args.cycle_us));
    const auto now = std::chrono::steady_clock::now();
    const double dt_s = std::chrono::duration<double>(now - last).count();
    last = now;
    try {
      Cycle(station_args, station, dt_s, pins);
    } catch (const std::exception& e) {  // an rpm out of range at arming: no measurement
      std::fprintf(stderr, "mlp-setter-hal: %s\n", e.what());
      station.reset();
      *pins->trigger = false;
      status = 1;
    }
  }
  hal_exit(comp);
  return status;
}
