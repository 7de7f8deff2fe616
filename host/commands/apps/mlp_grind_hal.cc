// mlp-grind-hal: the grinding cell (seed 001) as a LinuxCNC HAL user-space component (named by
// --name, default "mlp-grind"; docs/GRIND.md, "On the machine"). It reads the slide's x, y, z
// and the NC's theoretical wheel centre C every servo period; the wheel below the work's top
// takes its section out of the virtual work; at each top of stroke clear of the view the
// camera's frame is taken and, after a cut at C, measured against the frame from before the
// cut. The result and the compensation go out on pins; the running program
// (subs/mlp_grind_point.ngc) waits for `ready`, stops on `refused` and applies the compensation
// as a work offset.
//
// The slide comes through LinuxCNC's realtime `sampler` (man 9 sampler), whose five float pins
// (x, y, z in machine coordinates; C's x, y in the program's, from motion.analog-out) it samples
// in the servo thread into a FIFO this program reads (--sampler N: the sampler's channel). Why
// not pins read from here: a user-space program sees a pin when the scheduler lets it, and on a
// loaded machine the servo thread itself stalls and catches up in a burst; a turn of 1 mm took
// place between two readings of z (seen: z held at 4.965 for 0.48 s, then 5.000), the stroke's
// start was never seen and its frame not taken. Through the FIFO every period's value arrives,
// in order, whatever the load; the frame is rendered and measured meanwhile (a tenth of a
// second, far beyond a servo period) and the samples wait in the FIFO.
//
// Pins (NAME.*): in float sim-error-x-mm, sim-error-y-mm (the virtual machine's error;
// --sim-error-mm at start); out s32 tops, captures, measured, cuts, feed (0 good, 1 under-feed,
// 2 over-feed); out bit ready (the work as it is now, every sample read, was measured since the
// wheel last cut), refused (the last measurement: none possible, or its compensation over the
// limit); out float d-mm, error-mm, comp-x-mm, comp-y-mm, top-mm.

#include "mlp/host/grind_station_args.h"

#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include <hal.h>

namespace {

volatile std::sig_atomic_t g_stop = 0;
void OnSignal(int /*signal*/) { g_stop = 1; }

struct Pins {
  hal_float_t *sim_error_x_mm, *sim_error_y_mm;
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
  return in("sim-error-x-mm", &p->sim_error_x_mm) && in("sim-error-y-mm", &p->sim_error_y_mm) &&
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
      r.compensation_mm.x() * 1e3, r.compensation_mm.y() * 1e3,
      m.refused ? " REFUSED: " : (m.why.empty() ? "" : ": "), m.why.c_str());
}

// LinuxCNC's src/hal/components/streamer.h (2.9; not installed with linuxcnc-uspace-dev): the
// sampler's FIFO N is the HAL stream with this key + N.
constexpr int kSamplerShmemKey = 0x48534130;
constexpr const char* kSamplerColumns = "fffff";  // x, y, z, C x, C y

// Every sample the FIFO holds into the station, in order, at the servo period's time; its
// results onto the pins. Returns how many were read.
int FeedStation(hal_stream_t* fifo,
                double period_s,
                mlp::grind::GrindStation* station,
                int* measured,
                Pins* pins) {
  int read = 0;
  hal_stream_data row[5];
  unsigned sample_number = 0;
  while (g_stop == 0 && hal_stream_read(fifo, row, &sample_number) == 0) {
    ++read;
    station->SetMachineError({*pins->sim_error_x_mm, *pins->sim_error_y_mm});
    const int tops = station->Tops(), captures = station->Captures();
    const double z_mm = row[2].f;
    const auto m =
        station->Step(period_s * sample_number, {row[0].f, row[1].f}, z_mm, {row[3].f, row[4].f});
    if (station->Tops() > tops && station->Captures() == captures)
      std::fprintf(stderr,
                   "mlp-grind-hal: a top of stroke declared at z %.3f mm, where the wheel is in "
                   "view: no frame\n",
                   z_mm);
    if (m) Publish(*m, ++*measured, pins);
    *pins->tops = station->Tops();
    *pins->captures = station->Captures();
    *pins->cuts = station->Cuts();
    if (!station->Fresh()) *pins->ready = false;
  }
  return read;
}

// The loop until SIGTERM: the FIFO drained, then `ready` (the station has caught up with the
// slide, so a measurement from samples a stroke old never stands for a work cut since).
void Run(hal_stream_t* fifo,
         const mlp::host::GrindStationArgs& args,
         mlp::grind::GrindStation* station,
         Pins* pins) {
  int measured = 0, overruns = hal_stream_num_overruns(fifo);
  const double period_s = 1e-9 * static_cast<double>(args.servo_period_ns);
  while (g_stop == 0) {
    const int read = FeedStation(fifo, period_s, station, &measured, pins);
    *pins->ready = station->Fresh() && !hal_stream_readable(fifo);
    if (const int now = hal_stream_num_overruns(fifo); now != overruns) {
      std::fprintf(stderr,
                   "mlp-grind-hal: the sampler's FIFO overflowed %d times: samples of the slide "
                   "were lost (a deeper FIFO: loadrt sampler depth=...)\n",
                   now - overruns);
      overruns = now;
    }
    if (read == 0) std::this_thread::sleep_for(std::chrono::microseconds(args.cycle_us));
  }
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
  hal_stream_t fifo;
  if (const int e =
          hal_stream_attach(&fifo, comp, kSamplerShmemKey + args.sampler_channel, kSamplerColumns);
      e < 0) {
    std::fprintf(stderr,
                 "mlp-grind-hal: cannot read sampler channel %d (%s): loadrt sampler "
                 "cfg=%s before this, its pins on x, y, z, C x, C y (grind.hal)\n",
                 args.sampler_channel, std::strerror(-e), kSamplerColumns);
    hal_exit(comp);
    return 1;
  }
  hal_ready(comp);
  Run(&fifo, args, &station, pins);
  hal_stream_detach(&fifo);
  hal_exit(comp);
  return 0;
}
