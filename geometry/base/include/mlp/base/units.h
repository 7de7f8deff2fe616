#pragma once
/// @file Units at the edges. Inside, everything is millimetres and radians (DESIGN.md "Frames
/// and units"); degrees and arc seconds exist only where a person reads or types a number.

#include <cmath>
#include <numbers>

namespace mlp::base {

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kDegPerRad = 180.0 / kPi;
inline constexpr double kArcsecPerRad = kDegPerRad * 3600.0;
inline constexpr double kUmPerMm = 1000.0;

constexpr double DegFromRad(double rad) { return rad * kDegPerRad; }
constexpr double RadFromDeg(double deg) { return deg / kDegPerRad; }
constexpr double ArcsecFromRad(double rad) { return rad * kArcsecPerRad; }
constexpr double UmFromMm(double mm) { return mm * kUmPerMm; }
/// An angle brought into [-180, 180] degrees (a difference of two turns' angles).
inline double WrapDeg(double deg) { return deg - 360.0 * std::round(deg / 360.0); }

}  // namespace mlp::base
