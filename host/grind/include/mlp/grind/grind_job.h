#pragma once
/// @file A grinding inspection job (`mlprobe-grind/1`, docs/GRIND.md): the camera, the nominal
/// profile (lines and arcs), the wheel's nose radius, the error limit e, and per cutting point
/// the frames before and after its stroke with the NC's C and Mi. Also the demo profile and a
/// seeded sweep of injected machine errors with their truth (what the tests and
/// `mlp grind render` use).

#include "mlp/grind/grind_frame.h"
#include "mlp/grind/grind_measure.h"

#include <string>
#include <vector>

namespace mlp::grind {

struct JobPoint {
  std::string before, after;  ///< image files, relative to the job file's folder
  geometry::Vec2 c_mm = geometry::Vec2::Zero(), mi_mm = geometry::Vec2::Zero();
};

struct GrindJob {
  GrindCamera camera;
  std::vector<geometry::ProfileSegment> profile;
  double wheel_radius_mm = 1.0, limit_mm = 0.01, stock_mm = 0.15;
  WheelBevel bevel;  ///< the wheel's flanks (`bevel` in the file); off: a round nose
  std::vector<JobPoint> points;
};

/// Throws GrindInputError naming `where` (the file) and the field, or the profile's fault.
GrindJob ParseJob(const std::string& json_text, const std::string& where = "grind job");
std::string JobJson(const GrindJob& job);

/// The demo's nominal: a flat, a convex arc R0.8 down to 45 deg, a flank, a concave arc R1.5
/// back to flat, a flat (5 mm across, y 0.76..2.0 mm), material below.
std::vector<geometry::ProfileSegment> DemoProfile();

/// One injected machine error at a cutting point, and what it must be found as.
struct ErrorCase {
  double s_mm = 0.0;                                   ///< the cutting point along the nominal
  geometry::Vec2 offset_mm = geometry::Vec2::Zero();   ///< the wheel centre's error
  double wear_mm = 0.0;                                ///< the nose's lost radius
  Feed feed = Feed::kGood;                             ///< truth
  double d_mm = 0.0;                                   ///< truth: |Mr - Mi|
  geometry::Vec2 error_dir = geometry::Vec2::UnitY();  ///< truth (under-feed)
  double error_mm = 0.0;
  geometry::Vec2 c_mm = geometry::Vec2::Zero(), mi_mm = geometry::Vec2::Zero();
};

/// `n` cases, seeded: good, under-feed (an offset outwards), over-feed (inwards) and worn nose
/// in turn, at points spread along the profile, sizes 1.5..5 e, none within 20 % of e.
std::vector<ErrorCase> SweepCases(const geometry::Profile2& nominal,
                                  double wheel_radius_mm,
                                  double limit_mm,
                                  int n,
                                  unsigned seed,
                                  const WheelBevel& bevel = {});

/// The case's frames (before and after its stroke), rendered.
void RenderCase(const geometry::Profile2& nominal,
                const GrindJob& job,
                const ErrorCase& c,
                unsigned seed,
                std::vector<std::uint8_t>* before,
                std::vector<std::uint8_t>* after);

/// Writes an 8-bit binary PGM atomically; throws GrindError.
void WritePgm(const std::string& path, int width, int height, const std::vector<std::uint8_t>& px);

}  // namespace mlp::grind
