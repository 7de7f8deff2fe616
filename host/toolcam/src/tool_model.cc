#include "mlp/toolcam/tool_model.h"

#include "mlp/base/files.h"
#include "mlp/base/json_fields.h"
#include "mlp/base/units.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <sstream>

namespace mlp::toolcam {
namespace {

namespace jf = base::json_fields;
using json = nlohmann::json;

[[noreturn]] void Fail(const std::string& what) { throw ToolInputError("tool: " + what); }

double Bell(double x) {  // 0 at 0 and 1, 1 in the middle, smooth at both ends
  return x <= 0 || x >= 1 ? 0.0 : 0.5 - 0.5 * std::cos(2 * M_PI * x);
}

CuttingEdge ParseEdge(const json& e, const std::string& w) {
  CuttingEdge edge;
  edge.radial_offset_mm = jf::NumberOr<ToolInputError>(e, "radial_offset_mm", 0.0, w);
  edge.axial_offset_mm = jf::NumberOr<ToolInputError>(e, "axial_offset_mm", 0.0, w);
  if (e.contains("defects")) {
    if (!e.at("defects").is_array()) Fail(w + ".defects must be an array");
    for (size_t i = 0; i < e.at("defects").size(); ++i) {
      const json& d = e.at("defects")[i];
      const std::string dw = w + ".defects[" + std::to_string(i) + "]";
      edge.defects.push_back({jf::Number<ToolInputError>(d, "h_mm", dw),
                              jf::Number<ToolInputError>(d, "length_mm", dw),
                              jf::Number<ToolInputError>(d, "depth_mm", dw)});
    }
  }
  if (e.contains("profile")) {
    if (!e.at("profile").is_array()) Fail(w + ".profile must be an array of [h_mm, dr_mm]");
    for (const json& p : e.at("profile")) {
      if (!p.is_array() || p.size() != 2 || !p[0].is_number() || !p[1].is_number())
        Fail(w + ".profile must be an array of [h_mm, dr_mm]");
      edge.profile.emplace_back(p[0].get<double>(), p[1].get<double>());
      if (edge.profile.size() > 1 && !(edge.profile.back().first > edge.profile.end()[-2].first))
        Fail(w + ".profile's heights must rise");
    }
  }
  return edge;
}

// An electrode's corners from its section (ToolDescription::electrode). A diameter, corner count
// or angles the file gives as well (ToJson writes them) must be the section's.
void ElectrodeFromSection(const json& j, ToolDescription* t) {
  const json* s = j.contains("section_mm") ? &j.at("section_mm") : nullptr;
  if (s == nullptr || !s->is_array() || s->size() != 2 || !(*s)[0].is_number() ||
      !(*s)[1].is_number())
    Fail("an electrode needs section_mm: [width, thickness]");
  t->section_mm[0] = (*s)[0].get<double>(), t->section_mm[1] = (*s)[1].get<double>();
  if (!(t->section_mm[0] > 0 && t->section_mm[1] > 0)) Fail("section_mm's sizes must be > 0");
  t->diameter_mm = std::hypot(t->section_mm[0], t->section_mm[1]);
  const double a_deg = std::atan2(t->section_mm[1], t->section_mm[0]) * base::kDegPerRad;
  if (!(a_deg > 3 && a_deg < 87))  // the corners 6 deg apart at least (flute_angles_deg)
    Fail("section_mm: an electrode's thickness must be 0.053 to 19 times its width");
  t->flute_angles_deg = {0.0, 180.0 - 2 * a_deg, 180.0, 360.0 - 2 * a_deg};
  // The web: the inscribed circle (what the section covers at every turn).
  t->core_ratio = std::min(t->section_mm[0], t->section_mm[1]) / t->diameter_mm;
  if (j.contains("diameter_mm") &&
      std::abs(jf::Number<ToolInputError>(j, "diameter_mm", "tool") - t->diameter_mm) > 1e-9)
    Fail("an electrode's diameter_mm must be its section's diagonal");
  if (j.contains("flutes") && jf::Integer<ToolInputError>(j, "flutes", "tool") != 4)
    Fail("an electrode has 4 corners (flutes)");
}

// The largest y = r sin(t0 + sigma psi) over psi in [0, len], r = r0 - b psi (b >= 0): a piece
// of a tooth's back. At the piece's ends or inside where dy/dpsi = 0, which lies within
// atan(b / r) of where a circle's top would (t = pi/2): Newton from there. In closed form no
// library gives it; four steps reach 1e-12 rad for reliefs under 45 deg.
double PieceMaxY(double t0, double sigma, double len, double r0, double b) {
  const auto y = [&](double psi) { return (r0 - b * psi) * std::sin(t0 + sigma * psi); };
  double best = std::max(y(0.0), y(len));
  double top = std::remainder(sigma * (M_PI / 2 - t0), 2 * M_PI);  // in [-pi, pi]
  for (double psi : {top, top + 2 * M_PI}) {
    if (psi < -1.0 || psi > len + 1.0) continue;
    for (int i = 0; i < 4; ++i) {
      const double t = t0 + sigma * psi, r = r0 - b * psi;
      const double g = sigma * r * std::cos(t) - b * std::sin(t);
      const double dg = -2 * sigma * b * std::cos(t) - r * std::sin(t);
      if (dg >= 0) break;  // not near a maximum
      psi -= g / dg;
    }
    if (psi > 0 && psi < len) best = std::max(best, y(psi));
  }
  return best;
}

// Whether sin reaches above `level` anywhere between angles a and a + sigma len.
bool SinMayExceed(double a, double sigma, double len, double level) {
  if (level >= 1) return false;
  const double to_top = std::remainder(sigma * (M_PI / 2 - a), 2 * M_PI);
  const double top = to_top < 0 ? to_top + 2 * M_PI : to_top;
  return top <= len || std::sin(a) > level || std::sin(a + sigma * len) > level;
}

// "right" (the default) or "left": true for left.
bool Hand(const json& j, const char* field) {
  if (!j.contains(field)) return false;
  const std::string hand = jf::Text<ToolInputError>(j, field, "tool");
  if (hand != "right" && hand != "left") Fail(std::string(field) + " must be right or left");
  return hand == "left";
}

// A tooth's back: each field in range, none without a land.
void ValidateBack(const ToolDescription& t) {
  if (!(t.land_width_mm >= 0 && t.land_width_mm < t.Radius()) ||
      !(t.land_relief_deg >= 0 && t.land_relief_deg < 30) ||
      !(t.clearance_relief_deg >= 0 && t.clearance_relief_deg < 45) ||
      !(t.body_clearance_mm >= 0 && t.body_clearance_mm < 0.2 * t.Radius()) ||
      !(t.heel_deg >= 0 && t.heel_deg <= 180 &&
        (t.heel_deg > 0 ? t.heel_deg : 180.0 / t.flutes) / base::kDegPerRad * t.Radius() >=
            t.land_width_mm))
    Fail(
        "a tooth's back needs land_width_mm in [0, radius), land_relief_deg in [0, 30), "
        "clearance_relief_deg in [0, 45), body_clearance_mm in [0, 20 % of the radius), heel_deg "
        "in [0, 180] and past the land");
  if (t.land_width_mm == 0 &&
      (t.land_relief_deg != 0 || t.body_clearance_mm != 0 || t.heel_deg != 0))
    Fail("a tooth's back (relief, body clearance, heel) needs its land_width_mm");
}

// A point's angle and tip, a thread's pitch; a tap's land not modelled.
void ValidatePointAndThread(const ToolDescription& t) {
  if (!(t.point_angle_deg == 0 || (t.point_angle_deg >= 10 && t.point_angle_deg < 180)))
    Fail("point_angle_deg must be 0 (a flat end) or in [10, 180)");
  if (t.point_angle_deg > 0 && t.corner_radius_mm > 0)
    Fail("a pointed tool has no corner_radius_mm");
  if (!(t.tip_diameter_mm >= 0 && t.tip_diameter_mm < t.diameter_mm) ||
      (t.tip_diameter_mm > 0 && t.point_angle_deg == 0))
    Fail("tip_diameter_mm must be in [0, diameter_mm), with a point_angle_deg");
  if (!(t.thread_pitch_mm >= 0 && t.thread_pitch_mm <= 0.5 * t.diameter_mm))
    Fail("thread_pitch_mm must be in [0, diameter / 2]");
  // A tap's land carries its thread round the back, each point's crests P / 2 pi a radian on:
  // its silhouette fills the roots the edge alone shows (the outside renderer's M8 tap with
  // 2 mm lands read 38 um small with build-up and wear on every flank). Not modelled: refused
  // rather than measured against the edge's thread alone.
  if (t.thread_pitch_mm > 0 && t.land_width_mm > 0)
    Fail(
        "a tap's land (its thread round the tooth's back) is not modelled: thread_pitch_mm "
        "with land_width_mm cannot be measured yet");
}

}  // namespace

double ToolDescription::HelixTurnPerMm() const {
  const double per_mm = std::tan(helix_deg / base::kDegPerRad) / Radius();
  return left_hand_helix ? per_mm : -per_mm;
}

void ToolDescription::BackSpan(
    int k, double edge_rad, double r_edge, double* lo, double* hi) const {
  const double r_k = Radius() + edges[static_cast<size_t>(k)].radial_offset_mm;
  const double sigma = left_hand_cut ? 1.0 : -1.0;  // the back trails the edge's motion
  const double heel = (heel_deg > 0 ? heel_deg : 0.5 * 360.0 / flutes) / base::kDegPerRad;
  const double top = std::max(r_k, r_edge);
  const bool up = SinMayExceed(edge_rad, sigma, heel, *hi / top);
  const bool down = SinMayExceed(edge_rad + M_PI, sigma, heel, -*lo / top);
  if (!up && !down) return;
  // The back's radius below r_k: the land (from 0, b = R tan a1), then the body (flat, c) or
  // the clearance relief; never above the edge's own radius at this height (the end's shape).
  const double land = std::min(land_width_mm / Radius(), heel);
  const double a1 = std::tan(land_relief_deg / base::kDegPerRad) * Radius();
  struct Piece {
    double from, to, drop, b;
  };
  std::array<Piece, 2> pieces{{{0, land, 0, a1}, {land, heel, land * a1, 0}}};
  if (body_clearance_mm > 0)
    pieces[1].drop = body_clearance_mm;
  else
    pieces[1].b = std::tan(clearance_relief_deg / base::kDegPerRad) * Radius();
  const double cap_drop = r_k - r_edge;  // drops under this are capped at r_edge
  for (const Piece& p : pieces) {
    if (!(p.to > p.from)) continue;
    // split where r_k - drop meets r_edge: before it the end's shape holds the back at r_edge
    double split = p.from;
    if (cap_drop > p.drop)
      split = p.b > 0 ? std::min(p.to, p.from + (cap_drop - p.drop) / p.b) : p.to;
    const auto add = [&](double from, double to, double r0, double b) {
      if (!(to > from) || r0 <= 0) return;
      const double a = edge_rad + sigma * from;
      if (up) *hi = std::max(*hi, PieceMaxY(a, sigma, to - from, r0, b));
      if (down) *lo = std::min(*lo, -PieceMaxY(a + M_PI, sigma, to - from, r0, b));
    };
    add(p.from, split, r_edge, 0.0);
    add(split, p.to, r_k - p.drop - p.b * (split - p.from), p.b);
  }
}

double ToolDescription::TipH(int k) const { return -edges[static_cast<size_t>(k)].axial_offset_mm; }

double ToolDescription::EdgeRadius(int k, double h) const {
  const CuttingEdge& e = edges[static_cast<size_t>(k)];
  const double above_tip = h - TipH(k);
  if (above_tip < 0) return 0.0;
  const double r_edge = Radius() + e.radial_offset_mm;
  double r = r_edge;
  if (above_tip < corner_radius_mm) {  // the corner: an arc of its radius
    const double d = corner_radius_mm - above_tip;
    r = r_edge - corner_radius_mm + std::sqrt(corner_radius_mm * corner_radius_mm - d * d);
  }
  if (thread_pitch_mm > 0)
    r -= ThreadDepth(above_tip + thread_pitch_mm * FluteAngle(k) / (2 * M_PI));
  if (point_angle_deg > 0)  // the point's cone, moved with the edge: its radius grows with the
    r = std::min(r, tip_diameter_mm / 2 + e.radial_offset_mm +  // height above the apex
                        above_tip * std::tan(point_angle_deg / 2 / base::kDegPerRad));
  for (const EdgeDefect& d : e.defects) r -= d.depth_mm * Bell((h - d.h_mm) / d.length_mm);
  if (e.profile.size() >= 2 && h >= e.profile.front().first && h <= e.profile.back().first) {
    const auto hi = std::lower_bound(e.profile.begin(), e.profile.end(), std::make_pair(h, -1e300));
    if (hi == e.profile.begin()) {
      r += hi->second;
    } else {
      const auto lo = hi - 1;
      const double t = hi->first > lo->first ? (h - lo->first) / (hi->first - lo->first) : 0.0;
      r += lo->second + t * (hi->second - lo->second);
    }
  }
  return std::max(r, 0.0);
}

double ToolDescription::FluteAngle(int k) const {
  return EqualPitch() ? 2 * M_PI * k / flutes
                      : flute_angles_deg[static_cast<size_t>(k)] / base::kDegPerRad;
}

double ToolDescription::EndHeight() const {
  if (point_angle_deg == 0) return corner_radius_mm;
  return (Radius() - tip_diameter_mm / 2) / std::tan(point_angle_deg / 2 / base::kDegPerRad);
}

double ToolDescription::EdgeAngle(int k, double h, double turn_rad) const {
  return turn_rad + FluteAngle(k) + h * HelixTurnPerMm();
}

double ToolDescription::ThreadDepth(double h) const {
  // ISO 68-1's basic profile in pitches from a crest's middle: the crest flat to 1/16, the
  // 60-degree flank to 3/8, the root flat to the half pitch; 5H/8 = 0.5413 P deep.
  const double t = h / thread_pitch_mm, a = std::abs(t - std::round(t));
  constexpr double kCrest = 1.0 / 16, kRoot = 3.0 / 8, kDepth = 0.54127;
  return thread_pitch_mm * kDepth * std::clamp((a - kCrest) / (kRoot - kCrest), 0.0, 1.0);
}

bool ToolDescription::ShadowSpan(double h, double turn, double* lo, double* hi) const {
  const ShadowSpans s = Shadow(h, turn, 0.0);
  *lo = s.count ? s.lo[0] : 0.0, *hi = s.count ? s.hi[s.count - 1] : 0.0;
  return s.count > 0;
}

ShadowSpans ToolDescription::Shadow(double h, double turn, double tan_pitch) const {
  if (pin) return PinShadow(h, turn, tan_pitch);
  if (stylus) {  // round: the turn and the pitch do not change its outline
    ShadowSpans out;
    if (const double w = StylusHalfWidth(h); w > 0) out.count = 1, out.lo[0] = -w, out.hi[0] = w;
    return out;
  }
  ShadowSpans out;
  double lo = 0, hi = 0, widest = 0;
  bool any = false;
  // sin of each edge's angle (EdgeAngle) by turning one sine/cosine pair a flute at a time:
  // two sincos a call instead of one sin and one tan an edge (the renderer's hot loop); an
  // unequal pitch takes each edge's own.
  const double base = EdgeAngle(0, h, turn), step = 2 * M_PI / flutes;
  double s = std::sin(base), c = std::cos(base);
  const double ss = std::sin(step), cs = std::cos(step), depth_rise = Radius() * tan_pitch;
  for (int k = 0; k < flutes; ++k) {
    if (!EqualPitch() && k > 0)
      s = std::sin(base + FluteAngle(k)), c = std::cos(base + FluteAngle(k));
    const double r = EdgeRadius(k, h + c * depth_rise);  // the outer point is at depth R cos
    if (r > 0) {
      widest = std::max(widest, r);
      const double y = r * s;
      lo = std::min(lo, y), hi = std::max(hi, y);
      if (HasBack()) BackSpan(k, EdgeAngle(k, h, turn), r, &lo, &hi);
      any = true;
    }
    const double s_next = s * cs + c * ss;
    c = c * cs - s * ss, s = s_next;
  }
  if (!any) return out;
  // The web, within what the edges reach at this height (a point or a ball nose's end).
  const double core = std::min(core_ratio * Radius(), widest);
  out.count = 1, out.lo[0] = std::min(lo, -core), out.hi[0] = std::max(hi, core);
  return out;
}

// The ball (its bottom at the edge's tip) and the stem from its middle up.
double ToolDescription::StylusHalfWidth(double h) const {
  const double r = Radius() + edges[0].radial_offset_mm, a = h - TipH(0);
  if (a < 0) return 0.0;
  const double ball = a < 2 * r ? std::sqrt(std::max(0.0, r * r - (a - r) * (a - r))) : 0.0;
  return std::max(ball, a >= r ? stem_diameter_mm / 2 : 0.0);
}

// Half the pin's shadow at image height h: the widest |y| of its round section over the
// depths x the ray crosses, x^2 + y^2 <= r(h + x tan_pitch)^2. Only the end (and its edge
// round) needs the depths: sampled at 33, closer than the end's own blur matters for (the
// pin's end is a landmark; the calibration's heights come from the blades).
double ToolDescription::PinHalfWidth(double h, double tan_pitch) const {
  const double r_max = Radius() + edges[0].radial_offset_mm;
  if (tan_pitch == 0 || h - r_max * std::abs(tan_pitch) > TipH(0) + corner_radius_mm)
    return EdgeRadius(0, h);
  double widest2 = 0;
  for (int i = 0; i <= 32; ++i) {
    const double x = r_max * (i / 16.0 - 1), r = EdgeRadius(0, h + x * tan_pitch);
    widest2 = std::max(widest2, r * r - x * x);
  }
  return std::sqrt(widest2);
}

ShadowSpans ToolDescription::PinShadow(double h, double turn, double tan_pitch) const {
  std::array<std::pair<double, double>, 3> spans{};
  int n = 0;
  if (const double w = PinHalfWidth(h, tan_pitch); w > 0) spans[n++] = {-w, w};
  for (const PinBlade& b : blades) {
    // A rod at depth xc reaching down to h_end: the ray at h meets it where
    // h + (xc + x') tan_pitch >= h_end, x' its own depth; its widest chord where it does.
    const double xc = b.offset_mm * std::cos(turn), yc = b.offset_mm * std::sin(turn);
    const double rho = b.width_mm / 2, h_end = TipH(0) - b.extends_mm;
    double half = h >= h_end ? rho : 0.0;
    if (tan_pitch != 0) {
      const double q = ((h_end - h) / tan_pitch - xc) * (tan_pitch > 0 ? 1 : -1);
      half = q <= 0 ? rho : q < rho ? std::sqrt(rho * rho - q * q) : 0.0;
    }
    if (half > 0) spans[n++] = {yc - half, yc + half};
  }
  for (int i = 1; i < n; ++i)  // by hand: GCC 12 warns falsely on std::sort of 3
    for (int j = i; j > 0 && spans[j] < spans[j - 1]; --j) std::swap(spans[j], spans[j - 1]);
  ShadowSpans out;
  for (int i = 0; i < n; ++i) {  // disjoint: overlapping spans merged
    if (out.count > 0 && spans[i].first <= out.hi[out.count - 1]) {
      out.hi[out.count - 1] = std::max(out.hi[out.count - 1], spans[i].second);
      continue;
    }
    out.lo[out.count] = spans[i].first, out.hi[out.count] = spans[i].second, ++out.count;
  }
  return out;
}

void ToolDescription::Validate() const {
  if (!(diameter_mm > 0 && diameter_mm < 500)) Fail("diameter_mm must be in (0, 500)");
  if (!(length_mm > 0)) Fail("length_mm must be > 0");
  if (flutes < 1 || flutes > 32) Fail("flutes must be 1..32");
  if (!(corner_radius_mm >= 0 && corner_radius_mm <= Radius()))
    Fail("corner_radius_mm must be in [0, diameter / 2]");
  if (!(helix_deg >= 0 && helix_deg < 60)) Fail("helix_deg must be in [0, 60)");
  if (!(flute_length_mm > 0 && flute_length_mm <= length_mm))
    Fail("flute_length_mm must be in (0, length_mm]");
  if (!(core_ratio > 0 && core_ratio < 1)) Fail("core_ratio must be in (0, 1)");
  ValidatePointAndThread(*this);
  if (!(wear_limit_mm >= 0 && wear_limit_mm <= 0.1 * Radius()))
    Fail("wear_limit_mm must be in [0, 10 % of the radius]");
  if (!(reference_height_mm == 0 ||
        (reference_height_mm > EndHeight() && reference_height_mm < flute_length_mm)))
    Fail(
        "reference_height_mm must be 0 (the default, 1.5 mm) or above the end's shape and "
        "below flute_length_mm");
  ValidateBack(*this);
  if (!flute_angles_deg.empty()) {
    if (static_cast<int>(flute_angles_deg.size()) != flutes || flute_angles_deg[0] != 0)
      Fail("flute_angles_deg must list one angle per flute, the first 0");
    for (size_t k = 1; k < flute_angles_deg.size(); ++k)
      if (!(flute_angles_deg[k] > flute_angles_deg[k - 1] + 5 && flute_angles_deg[k] < 355))
        Fail("flute_angles_deg must rise by over 5 deg a flute and stay under 355");
  }
  if (static_cast<int>(edges.size()) != flutes) Fail("edges must list one edge per flute");
  if (!blades.empty() && (!pin || blades.size() != 2)) Fail("blades: a pin has none or two");
  if (electrode && !(flutes == 4 && helix_deg == 0 && point_angle_deg == 0 &&
                     thread_pitch_mm == 0 && section_mm[0] > 0 && section_mm[1] > 0))
    Fail("an electrode has a section_mm of two sizes > 0, four corners, no helix, point or thread");
  if (stylus && !(flutes == 1 && stem_diameter_mm > 0 && stem_diameter_mm < diameter_mm))
    Fail("a stylus has flutes 1 and a stem_diameter_mm in (0, diameter_mm)");
  for (const PinBlade& b : blades)
    if (!(b.width_mm > 0) || !(b.extends_mm > 0 && b.extends_mm <= 50) ||
        !(std::abs(b.offset_mm) + b.width_mm / 2 <= Radius()))
      Fail("a blade needs width_mm > 0, extends_mm in (0, 50], and to lie within the pin");
  if (blades.size() == 2 &&
      !(std::abs(blades[0].offset_mm - blades[1].offset_mm) > blades[0].width_mm))
    Fail("the blades must lie apart by more than their width");
  for (const CuttingEdge& e : edges) {
    if (std::abs(e.radial_offset_mm) > 0.1 * Radius() || std::abs(e.axial_offset_mm) > 1.0)
      Fail("an edge's offsets must be within 10 % of the radius and 1 mm");
    for (const EdgeDefect& d : e.defects)
      if (!(d.length_mm > 0) || !(std::abs(d.depth_mm) < 0.5 * Radius()) || !(d.h_mm >= -1))
        Fail("a defect needs a length > 0, a depth under half the radius, h_mm >= -1");
  }
}

ToolDescription ParseTool(const std::string& text) {
  const json j = jf::ParseDocument<ToolInputError>(text, "mlprobe-tool/1", "tool");
  ToolDescription t;
  t.id = jf::Text<ToolInputError>(j, "id", "tool");
  const std::string kind =
      j.contains("kind") ? jf::Text<ToolInputError>(j, "kind", "tool") : std::string("cutter");
  if (kind != "pin" && kind != "cutter" && kind != "stylus" && kind != "electrode")
    Fail("kind must be cutter, pin, stylus or electrode");
  t.pin = kind == "pin", t.stylus = kind == "stylus", t.electrode = kind == "electrode";
  const bool electrode = t.electrode;  // sized by its section (ElectrodeFromSection)
  t.diameter_mm = electrode ? 0.0 : jf::Number<ToolInputError>(j, "diameter_mm", "tool");
  t.length_mm = jf::Number<ToolInputError>(j, "length_mm", "tool");
  t.flutes = electrode ? 4 : jf::Integer<ToolInputError>(j, "flutes", "tool");
  t.corner_radius_mm = jf::NumberOr<ToolInputError>(j, "corner_radius_mm", 0.0, "tool");
  t.helix_deg = jf::NumberOr<ToolInputError>(j, "helix_deg", electrode ? 0.0 : 30.0, "tool");
  t.flute_length_mm = jf::Number<ToolInputError>(j, "flute_length_mm", "tool");
  t.core_ratio = jf::NumberOr<ToolInputError>(j, "core_ratio", t.core_ratio, "tool");
  t.point_angle_deg = jf::NumberOr<ToolInputError>(j, "point_angle_deg", 0.0, "tool");
  t.tip_diameter_mm = jf::NumberOr<ToolInputError>(j, "tip_diameter_mm", 0.0, "tool");
  t.thread_pitch_mm = jf::NumberOr<ToolInputError>(j, "thread_pitch_mm", 0.0, "tool");
  t.wear_limit_mm = jf::NumberOr<ToolInputError>(j, "wear_limit_mm", 0.0, "tool");
  t.reference_height_mm = jf::NumberOr<ToolInputError>(j, "reference_height_mm", 0.0, "tool");
  t.left_hand_helix = Hand(j, "helix_hand");
  t.left_hand_cut = Hand(j, "cut");
  t.land_width_mm = jf::NumberOr<ToolInputError>(j, "land_width_mm", 0.0, "tool");
  t.land_relief_deg = jf::NumberOr<ToolInputError>(j, "land_relief_deg", 0.0, "tool");
  t.clearance_relief_deg =
      jf::NumberOr<ToolInputError>(j, "clearance_relief_deg", t.clearance_relief_deg, "tool");
  t.body_clearance_mm = jf::NumberOr<ToolInputError>(j, "body_clearance_mm", 0.0, "tool");
  t.heel_deg = jf::NumberOr<ToolInputError>(j, "heel_deg", 0.0, "tool");
  if (j.contains("flute_angles_deg") && !electrode) {
    if (!j.at("flute_angles_deg").is_array()) Fail("flute_angles_deg must be an array");
    for (const json& a : j.at("flute_angles_deg")) {
      if (!a.is_number()) Fail("flute_angles_deg must hold numbers");
      t.flute_angles_deg.push_back(a.get<double>());
    }
  }
  if (t.stylus) t.stem_diameter_mm = jf::Number<ToolInputError>(j, "stem_diameter_mm", "tool");
  if (t.electrode) ElectrodeFromSection(j, &t);
  if (j.contains("blades")) {
    if (!j.at("blades").is_array()) Fail("blades must be an array");
    for (size_t k = 0; k < j.at("blades").size(); ++k) {
      const json& b = j.at("blades")[k];
      const std::string w = "tool.blades[" + std::to_string(k) + "]";
      t.blades.push_back({jf::Number<ToolInputError>(b, "offset_mm", w),
                          jf::Number<ToolInputError>(b, "width_mm", w),
                          jf::Number<ToolInputError>(b, "extends_mm", w)});
    }
  }
  if (j.contains("edges")) {
    if (!j.at("edges").is_array()) Fail("edges must be an array");
    for (size_t k = 0; k < j.at("edges").size(); ++k)
      t.edges.push_back(ParseEdge(j.at("edges")[k], "tool.edges[" + std::to_string(k) + "]"));
  } else if (t.flutes > 0 && t.flutes <= 32) {
    t.edges.resize(static_cast<size_t>(t.flutes));  // a new, true-running tool
  }
  t.Validate();
  return t;
}

std::string ToJson(const ToolDescription& t) {
  nlohmann::ordered_json edges = nlohmann::ordered_json::array();
  for (const CuttingEdge& e : t.edges) {
    nlohmann::ordered_json defects = nlohmann::ordered_json::array();
    nlohmann::ordered_json profile = nlohmann::ordered_json::array();
    for (const EdgeDefect& d : e.defects)
      defects.push_back({{"h_mm", d.h_mm}, {"length_mm", d.length_mm}, {"depth_mm", d.depth_mm}});
    for (const auto& [h, dr] : e.profile) profile.push_back({h, dr});
    nlohmann::ordered_json edge = {{"radial_offset_mm", e.radial_offset_mm},
                                   {"axial_offset_mm", e.axial_offset_mm}};
    if (!e.defects.empty()) edge["defects"] = defects;
    if (!e.profile.empty()) edge["profile"] = profile;
    edges.push_back(edge);
  }
  const nlohmann::ordered_json j = {{"format", "mlprobe-tool/1"},
                                    {"id", t.id},
                                    {"diameter_mm", t.diameter_mm},
                                    {"length_mm", t.length_mm},
                                    {"flutes", t.flutes},
                                    {"corner_radius_mm", t.corner_radius_mm},
                                    {"helix_deg", t.helix_deg},
                                    {"flute_length_mm", t.flute_length_mm},
                                    {"core_ratio", t.core_ratio},
                                    {"kind", t.pin         ? "pin"
                                             : t.stylus    ? "stylus"
                                             : t.electrode ? "electrode"
                                                           : "cutter"},
                                    {"edges", edges}};
  nlohmann::ordered_json with = j;
  if (t.point_angle_deg > 0) with["point_angle_deg"] = t.point_angle_deg;
  if (t.stylus) with["stem_diameter_mm"] = t.stem_diameter_mm;
  if (t.tip_diameter_mm > 0) with["tip_diameter_mm"] = t.tip_diameter_mm;
  if (t.thread_pitch_mm > 0) with["thread_pitch_mm"] = t.thread_pitch_mm;
  if (t.wear_limit_mm > 0) with["wear_limit_mm"] = t.wear_limit_mm;
  if (t.reference_height_mm > 0) with["reference_height_mm"] = t.reference_height_mm;
  if (t.left_hand_helix) with["helix_hand"] = "left";
  if (t.left_hand_cut) with["cut"] = "left";
  if (t.HasBack()) {
    with["land_width_mm"] = t.land_width_mm, with["land_relief_deg"] = t.land_relief_deg;
    if (t.body_clearance_mm > 0)
      with["body_clearance_mm"] = t.body_clearance_mm;
    else
      with["clearance_relief_deg"] = t.clearance_relief_deg;
    if (t.heel_deg > 0) with["heel_deg"] = t.heel_deg;
  }
  if (!t.flute_angles_deg.empty() && !t.electrode) with["flute_angles_deg"] = t.flute_angles_deg;
  if (t.electrode) with["section_mm"] = {t.section_mm[0], t.section_mm[1]};
  if (!t.blades.empty()) {
    nlohmann::ordered_json blades = nlohmann::ordered_json::array();
    for (const PinBlade& b : t.blades)
      blades.push_back(
          {{"offset_mm", b.offset_mm}, {"width_mm", b.width_mm}, {"extends_mm", b.extends_mm}});
    with["blades"] = blades;
  }
  return with.dump(1) + "\n";
}

ToolDescription LoadTool(const std::string& path) {
  return ParseTool(base::ReadFileAs<ToolInputError>(path, "tool: "));
}

}  // namespace mlp::toolcam
