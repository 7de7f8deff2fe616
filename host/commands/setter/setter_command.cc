#include "mlp/host/setter_command.h"

#include "mlp/base/clock.h"
#include "mlp/host/cli.h"
#include "mlp/host/setter_station_args.h"
#include "mlp/setter/beam_processor.h"
#include "mlp/setter/beam_signal.h"
#include "mlp/setter/beam_signal_file.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <map>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

namespace mlp::host {
namespace {

constexpr int kExitNoResult = 3;
constexpr const char* kUsage =
    "usage: mlp setter simulate --out SIGNAL.txt [--rpm R] [--teeth-mm R1,R2,..]\n"
    "                           [--feed-mm-min F] [--gap-mm G] [--leaving] [--duration-s S]\n"
    "                           [--drops-per-s D] [--noise-v N] [--sample-rate-hz H] [--seed N]\n"
    "                           [--reflective] [--tool-width-mm W]\n"
    "  the receiver's signal while a pin (--rpm 0, one radius) or a turning tool (a radius per\n"
    "  tooth) moves into (or out of) the beam; its truth in SIGNAL.txt.truth.json\n"
    "       mlp setter calibrate --signal PIN.txt --feed-mm-min F [--leaving] [--reflective]\n"
    "                            --out CURVE.json [--pin-diameter-mm D] [--serial S] [--json]\n"
    "  the calibration curve from a pin's signal (a table over the fall, mlprobe-beam-curve/2)\n"
    "       mlp setter process --signal SIGNAL.txt (--curve CURVE.json | --no-curve) --rpm R\n"
    "                          --teeth N --feed-mm-min F [--leaving] [--reflective]\n"
    "                          [--threshold-share S] [--width-trigger-ms T] [--rise] [--json]\n"
    "                          [--amplifier-hz B]\n"
    "  the signal sample by sample as the setter's DSP: the trigger (the skip signal), the edge\n"
    "  it implies and its uncertainty, each tooth's lag, what was rejected; no diameter (the\n"
    "  dips' widths cannot give one to 5 um: the radius setting's edge along X does);\n"
    "  --rise: a pin entering, its rise p predicts the crossing (a curve that knows the rise)\n"
    "  B: the receiver amplifier's bandwidth, its lag undone on the dips; no trigger says why\n"
    "  (and, when the feed per turn was too high for the curve, the feed that works)\n"
    "exit codes: 0 done (process: triggered), 2 bad arguments or files, 3 no trigger or no\n"
    "calibration (the reason is printed), 1 bug\n";

namespace fs = std::filesystem;

// Every sub-command takes these switches.
const std::set<std::string> kSwitches = {"--json", "--leaving", "--reflective", "--no-curve",
                                         "--rise"};

setter::BeamSignal ReadSignal(const std::string& path) {
  return setter::ParseBeamSignal(ReadInputFile(path), path);
}

int Simulate(const std::vector<std::string>& args, std::ostream& out) {
  const Args f(args,
               {{"--out", "--rpm", "--teeth-mm", "--feed-mm-min", "--gap-mm", "--duration-s",
                 "--drops-per-s", "--noise-v", "--sample-rate-hz", "--seed", "--tool-width-mm"},
                kSwitches});
  setter::BeamModel beam;
  beam.reflective = f.Has("--reflective");
  beam.sample_rate_hz = f.Number("--sample-rate-hz", beam.sample_rate_hz);
  beam.noise_v = f.Number("--noise-v", beam.noise_v);
  beam.drops_per_s = f.Number("--drops-per-s", 0.0);
  setter::ToolInBeam tool;
  tool.rpm = f.Number("--rpm", 0.0);
  tool.tooth_radius_mm = ParseRadiiList("--teeth-mm", f.Text("--teeth-mm", "3.0"));
  tool.width_mm = f.Number("--tool-width-mm", 0.0);
  setter::Motion m;
  m.feed_mm_min = f.Number("--feed-mm-min", m.feed_mm_min);
  m.gap_mm = f.Number("--gap-mm", m.gap_mm);
  m.duration_s = f.Number("--duration-s", m.duration_s);
  m.entering = !f.Has("--leaving");
  const auto seed = static_cast<unsigned>(f.Number("--seed", 1));
  tool.start_turn_rad = 0.37 * seed;
  const setter::BeamSignal s = setter::GenerateSignal(beam, tool, m, seed);
  const std::string path = f.Text("--out");
  WriteOutputFile(path, setter::BeamSignalText(s));
  WriteOutputFile(path + ".truth.json", setter::BeamTruthJson(s));
  out << s.volts.size() << " samples at " << s.sample_rate_hz << " Hz in " << path << " ("
      << s.drop_times_s.size() << " drops; truth in " << path << ".truth.json)\n";
  return kExitOk;
}

int Calibrate(const std::vector<std::string>& args, std::ostream& out) {
  const Args f(
      args, {{"--signal", "--feed-mm-min", "--out", "--pin-diameter-mm", "--serial"}, kSwitches});
  const setter::BeamSignal s = ReadSignal(f.Text("--signal"));
  setter::CalibrationCurve c =
      setter::CalibrateFromPin(s.volts, s.sample_rate_hz, f.Number("--feed-mm-min", 0.0),
                               !f.Has("--leaving"), f.Has("--reflective"));
  c.pin_diameter_mm = f.Number("--pin-diameter-mm", 0.0);
  if (!(c.pin_diameter_mm >= 0)) throw UsageError("--pin-diameter-mm must be > 0");
  c.serial = f.Text("--serial", "");
  c.date_utc = base::UtcNow("%Y-%m-%dT%H:%M:%S", false) + "Z";
  WriteOutputFile(f.Text("--out"), setter::CurveJson(c));
  if (f.Has("--json")) {
    out << nlohmann::json::parse(setter::CurveJson(c)).dump() << "\n";
    return kExitOk;
  }
  out << std::fixed << std::setprecision(4) << "calibration curve: clear " << c.clear_v
      << " V, a table over " << c.lo_mm * 1e3 << " .. " << c.hi_mm * 1e3
      << " um of intrusion (from the clear level after the rise to 2 %), the beam's radius "
      << c.beam_radius_mm * 1e3 << " um (1/e^2, as a Gaussian's), the half-light point known to +-"
      << c.half_light_u_mm * 1e3 << " um\n  written to " << f.Text("--out") << "\n";
  return kExitOk;
}

setter::ProcessorConfig ProcessorConfigFrom(const Args& f, const setter::BeamSignal& s) {
  setter::ProcessorConfig c;
  c.sample_rate_hz = s.sample_rate_hz;
  c.rpm = f.Number("--rpm", 0.0);
  c.teeth = static_cast<int>(f.Number("--teeth", 1));
  c.feed_mm_min = f.Number("--feed-mm-min", 0.0);
  c.entering = !f.Has("--leaving");
  c.threshold_share = f.Number("--threshold-share", c.threshold_share);
  c.reflective = f.Has("--reflective");
  c.width_trigger_s = f.Number("--width-trigger-ms", 0.0) / 1000;
  c.rise_predicts = f.Has("--rise");
  c.amplifier_hz = f.Number("--amplifier-hz", 0.0);
  if (f.Has("--no-curve") == f.Has("--curve"))
    throw UsageError("give --curve CURVE.json, or --no-curve (a line through the minima)");
  if (f.Has("--curve"))
    c.curve = setter::ParseCurve(ReadInputFile(f.Text("--curve")), f.Text("--curve"));
  return c;
}

// The rejections: counts per reason, and the most recent ones by sample.
void RejectionsJson(const setter::BeamProcessor& p, nlohmann::ordered_json* j) {
  int shown = 0;
  const auto recent = p.RecentRejections(&shown);
  nlohmann::ordered_json rejected = nlohmann::ordered_json::array();
  for (int i = 0; i < shown; ++i)
    rejected.push_back({{"sample", recent[static_cast<size_t>(i)].sample},
                        {"reason", setter::ToString(recent[static_cast<size_t>(i)].reason)}});
  nlohmann::ordered_json counts = nlohmann::ordered_json::object();
  for (auto r :
       {setter::Rejected::kOffSchedule, setter::Rejected::kOutsideBand, setter::Rejected::kTooSteep,
        setter::Rejected::kNotHeld, setter::Rejected::kDimmed})
    counts[setter::ToString(r)] = p.RejectionCount(r);
  (*j)["rejections"] = counts;
  (*j)["recent_rejections"] = rejected;
}

// Issue 56: on an outside beam simulator the dips' widths gave diameters 142-511 um small
// (the beam's divergence over the dips' flanks, the amplifier, the spindle's real speed, the
// method itself); modelling them to 5 um needs the beam's divergence, which one pin's pass
// cannot give. A plausible wrong diameter is worse than none: the radius comes from the
// edge along X (mlp_setter_radius.ngc), as the length does along Z.
constexpr const char* kNoDiameter =
    "the dips' widths cannot give a diameter to 5 um (the beam's divergence is not known from "
    "one pin's pass); set the radius from the edge along X (mlp_setter_radius.ngc)";

nlohmann::ordered_json ProcessJson(const setter::BeamProcessor& p, int teeth) {
  nlohmann::ordered_json j = {{"samples", p.Samples()}, {"triggered", p.Triggered()}};
  const setter::Trigger& t = p.trigger();
  if (p.Triggered()) {
    j["trigger_sample"] = t.sample;
    j["trigger_time_s"] = t.time_s;
    j["threshold_time_s"] = t.threshold_time_s;
    j["edge_offset_mm"] = t.edge_offset_mm;
    j["tooth"] = t.tooth;
    j["extremes"] = t.extremes;
    j["cause"] = setter::ToString(t.cause);
    if (std::isfinite(t.edge_sigma_mm)) j["edge_sigma_mm"] = t.edge_sigma_mm;
  }
  if (std::isfinite(p.PredictedCrossingS())) j["predicted_crossing_s"] = p.PredictedCrossingS();
  j["deepest_share"] = p.DeepestShare();
  j["diameter_mm"] = nullptr;
  j["diameter_refused"] = kNoDiameter;
  nlohmann::ordered_json lags = nlohmann::ordered_json::array();
  for (int k = 0; k < teeth; ++k) {
    const double lag = p.ToothLagMm(k);
    lags.push_back(std::isfinite(lag) ? nlohmann::ordered_json(lag) : nullptr);
  }
  j["tooth_lag_mm"] = lags;
  RejectionsJson(p, &j);
  return j;
}

void PrintProcess(const setter::BeamProcessor& p,
                  int teeth,
                  const nlohmann::ordered_json& j,
                  std::ostream& out) {
  const setter::Trigger& t = p.trigger();
  if (p.Triggered() && t.cause == setter::TriggerCause::kLine)
    out << std::fixed << std::setprecision(6) << "trigger at sample " << t.sample << " ("
        << t.time_s << " s): tooth " << t.tooth << "'s line (" << t.extremes
        << " minima) crossed at " << t.threshold_time_s << " s; the edge is the latched "
        << "position less " << std::setprecision(4) << t.edge_offset_mm * 1e3 << " um"
        << std::setprecision(2);
  if (p.Triggered() && t.cause == setter::TriggerCause::kLine && std::isfinite(t.edge_sigma_mm))
    out << " (+-" << t.edge_sigma_mm * 1e3 << " um, 1 sigma, from its minima)";
  if (p.Triggered() && t.cause == setter::TriggerCause::kLine)
    out << "\n";
  else if (p.Triggered())
    out << std::fixed << std::setprecision(6) << "trigger at sample " << t.sample << " ("
        << t.time_s << " s): " << setter::ToString(t.cause) << " at " << t.threshold_time_s
        << " s; the edge is the latched position less " << std::setprecision(4)
        << t.edge_offset_mm * 1e3 << " um\n";
  out << "  no diameter: " << kNoDiameter << "\n";
  for (int k = 0; k < teeth; ++k)
    if (std::isfinite(p.ToothLagMm(k)) && k != p.LeadingTooth())
      out << std::setprecision(2) << "  tooth " << k << " reaches " << p.ToothLagMm(k) * 1e3
          << " um less\n";
  for (const auto& [reason, n] : j["rejections"].items())
    if (n.get<int>() > 0) out << "  rejected " << n.get<int>() << "x: " << reason << "\n";
}

// A file with the axis' positions (mlprobe-beam-signal/2) gives the edge itself: the axis
// where the threshold was crossed, interpolated between its samples.
void AxisEdge(const setter::BeamSignal& s,
              const setter::BeamProcessor& p,
              nlohmann::ordered_json* j) {
  if (!p.Triggered() || s.axis_mm.size() != s.volts.size() || s.axis_mm.size() < 2) return;
  const double at = std::clamp(p.trigger().threshold_time_s * s.sample_rate_hz, 0.0,
                               static_cast<double>(s.axis_mm.size() - 1));
  const auto i = std::min(static_cast<size_t>(at), s.axis_mm.size() - 2);
  const double f = at - static_cast<double>(i);
  (*j)["edge_axis_mm"] = s.axis_mm[i] + f * (s.axis_mm[i + 1] - s.axis_mm[i]);
}

int Process(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const Args f(args, {{"--signal", "--curve", "--rpm", "--teeth", "--feed-mm-min",
                       "--threshold-share", "--width-trigger-ms", "--amplifier-hz"},
                      kSwitches});
  const setter::BeamSignal s = ReadSignal(f.Text("--signal"));
  if (s.saturated > 0)  // the shares would be clipped: no edge from them
    throw setter::SetterError(std::to_string(s.saturated) +
                              " samples at the ADC's full scale: the receiver saturates (lower "
                              "its gain or the laser's power); no trigger is read from it");
  setter::ProcessorConfig c = ProcessorConfigFrom(f, s);
  if (!f.Has("--amplifier-hz")) c.amplifier_hz = s.amplifier_hz;  // the file's, if it has one
  const auto p = std::make_unique<setter::BeamProcessor>(c);
  for (float v : s.volts) p->Push(v);
  nlohmann::ordered_json j = ProcessJson(*p, c.teeth);
  AxisEdge(s, *p, &j);
  if (!p->Triggered()) j["no_trigger"] = p->WhyNoTrigger();
  const int code = p->Triggered() ? kExitOk : kExitNoResult;
  if (!p->Triggered())
    err << "mlp setter: no trigger in " << p->Samples() << " samples: " << p->WhyNoTrigger()
        << "\n";
  if (f.Has("--json"))
    out << j.dump() << "\n";
  else
    PrintProcess(*p, c.teeth, j, out);
  return code;
}

}  // namespace

int RunSetterCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  try {
    if (!args.empty() && (args[0] == "--help" || args[0] == "-h")) {
      out << kUsage;
      return kExitOk;
    }
    if (args.empty()) throw UsageError("expected: mlp setter simulate, calibrate or process");
    const std::vector<std::string> rest(args.begin() + 1, args.end());
    if (args[0] == "simulate") return Simulate(rest, out);
    if (args[0] == "calibrate") return Calibrate(rest, out);
    if (args[0] == "process") return Process(rest, out, err);
    throw UsageError("expected: mlp setter simulate, calibrate or process");
  } catch (const UsageError& e) {
    err << "mlp setter: " << e.what() << "\n" << kUsage;
    return kExitBadInput;
  } catch (const base::InputError& e) {  // a signal or curve file, a model out of range
    err << "mlp setter: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const setter::SetterError& e) {
    err << "mlp setter: " << e.what() << "\n";
    return kExitNoResult;
  }
}

}  // namespace mlp::host
