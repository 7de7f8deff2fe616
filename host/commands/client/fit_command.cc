#include "mlp/host/fit_command.h"

#include "mlp/base/check.h"
#include "mlp/base/units.h"
#include "mlp/geometry/chebyshev.h"
#include "mlp/geometry/error.h"
#include "mlp/geometry/fit.h"
#include "mlp/geometry/robust.h"
#include "mlp/host/cloud_io.h"

#include <cmath>
#include <iostream>
#include <sstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

namespace mlp::host {
namespace {

using geometry::Points3;
using geometry::Vec3;
using Json = nlohmann::ordered_json;

struct FitRequest {
  std::string shape;
  std::string method = "ls";
  std::string path;
  double unit_scale = 1.0;  // file units -> mm
  bool text = false;        // readable summary instead of JSON
  geometry::RobustOptions robust;
  std::string circle3 = "spatial";  // or "plane-then-circle": fit.h, Circle3Definition
};

FitRequest ParseArgs(const std::vector<std::string>& args) {
  const Args a(
      args, {{"--method", "--units", "--threshold", "--seed", "--circle3"}, {"--text"}, {}, true});
  FitRequest req;
  req.method = a.Text("--method", req.method);
  const std::string units = a.Text("--units", "mm");
  if (units == "mm")
    req.unit_scale = 1.0;
  else if (units == "m")
    req.unit_scale = 1000.0;
  else if (units == "um")
    req.unit_scale = 1e-3;
  else if (units == "in")
    req.unit_scale = 25.4;
  else
    throw UsageError("--units must be mm, m, um or in");
  req.text = a.Has("--text");
  req.robust.inlier_threshold_mm = a.Number("--threshold", req.robust.inlier_threshold_mm);
  req.robust.random_seed =
      static_cast<uint64_t>(a.Integer("--seed", static_cast<long long>(req.robust.random_seed)));
  const std::vector<std::string>& positional = a.Positionals();
  if (positional.size() != 2) throw UsageError("expected SHAPE and FILE");
  req.shape = positional[0];
  req.path = positional[1];
  req.circle3 = a.Text("--circle3", req.circle3);
  if (req.circle3 != "spatial" && req.circle3 != "plane-then-circle")
    throw UsageError("--circle3 must be spatial or plane-then-circle");
  if (a.Has("--circle3") && req.shape != "circle")
    throw UsageError("--circle3 is for a circle only");
  req.robust.least_squares.circle3 = req.circle3 == "spatial"
                                         ? geometry::Circle3Definition::kSpatial
                                         : geometry::Circle3Definition::kPlaneThenCircle;
  return req;
}

Json Vec(const Vec3& v) { return Json::array({v.x(), v.y(), v.z()}); }

void AddStats(const geometry::FitStats& s, Json* j) {
  (*j)["n"] = s.n;
  (*j)["rms"] = s.rms;
  (*j)["min"] = s.min_residual;
  (*j)["max"] = s.max_residual;
  (*j)["converged"] = s.converged;
}

void AddCovariance(const geometry::Covariance& c, Json* j) {
  Json sd = Json::object();
  for (size_t k = 0; k < c.parameters.size(); ++k) sd[c.parameters[k]] = c.StdDev(c.parameters[k]);
  (*j)["std_dev"] = sd;
}

Json ShapeJson(const geometry::Line3& s) {
  return {{"point", Vec(s.point)}, {"direction", Vec(s.direction)}};
}
Json ShapeJson(const geometry::Plane& s) {
  return {{"point", Vec(s.point)}, {"normal", Vec(s.normal)}};
}
Json ShapeJson(const geometry::Circle3& s) {
  return {{"center", Vec(s.center)}, {"normal", Vec(s.normal)}, {"radius", s.radius}};
}
Json ShapeJson(const geometry::Sphere& s) {
  return {{"center", Vec(s.center)}, {"radius", s.radius}};
}
Json ShapeJson(const geometry::Cylinder& s) {
  return {{"point", Vec(s.point)}, {"axis", Vec(s.axis)}, {"radius", s.radius}};
}
Json ShapeJson(const geometry::Cone& s) {
  return {{"apex", Vec(s.Apex())},
          {"axis", Vec(s.axis)},
          {"half_angle_deg", s.half_angle * base::kDegPerRad},
          {"point", Vec(s.point)},
          {"radius_at_point", s.RadiusAtPoint()}};
}
Json ShapeJson(const geometry::Ellipse3& s) {
  return {{"center", Vec(s.center)},
          {"normal", Vec(s.normal)},
          {"major_axis", Vec(s.major_axis)},
          {"semi_major", s.semi_major},
          {"semi_minor", s.semi_minor}};
}

template <class Shape>
Json LsJson(const geometry::FitResult<Shape>& fit) {
  Json j = ShapeJson(fit.shape);
  AddStats(fit.stats, &j);
  j["iterations"] = fit.stats.iterations;
  AddCovariance(fit.covariance, &j);
  return j;
}

template <class Shape>
Json RobustJson(const geometry::RobustFitResult<Shape>& r, Eigen::Index n_input) {
  Json j = LsJson(r.fit);
  j["inliers"] = r.inliers.size();
  j["outliers"] = n_input - static_cast<Eigen::Index>(r.inliers.size());
  j["threshold"] = r.threshold_mm;
  j["samples"] = r.samples;
  j["inliers_settled"] = r.inliers_settled;
  return j;
}

template <class Shape, class LsFn, class RobustFn>
Json LsOrRobust(const FitRequest& req, const Points3& p, LsFn ls, RobustFn robust) {
  if (req.method == "ls") return LsJson<Shape>(ls(p));
  if (req.method == "robust") return RobustJson<Shape>(robust(p, req.robust), p.cols());
  throw UsageError("method " + req.method + " is not available for " + req.shape +
                   " (use ls or robust" +
                   (req.shape == "line" || req.shape == "plane" || req.shape == "sphere" ||
                            req.shape == "cylinder"
                        ? ", minzone"
                        : "") +
                   ")");
}

// A zone between two concentric or coaxial surfaces: its mid-shape, width and radii.
template <class Shape, class Zone>
Json RadialZone(const Shape& shape, const char* width_name, const Zone& zone) {
  Json j = ShapeJson(shape);
  j[width_name] = zone.outer_radius - zone.inner_radius;
  j["inner_radius"] = zone.inner_radius;
  j["outer_radius"] = zone.outer_radius;
  AddStats(zone.stats, &j);
  return j;
}

Json MinZone(const std::string& shape, const Points3& p) {
  Json j;
  if (shape == "line") {
    const auto f = geometry::FitMinZoneLine(p);
    j = ShapeJson(f.line);
    j["straightness"] = f.straightness;
    j["profile_normal"] = Vec(f.plane_normal);
    AddStats(f.stats, &j);
  } else if (shape == "plane") {
    const auto f = geometry::FitMinZonePlane(p);
    j = ShapeJson(f.plane);
    j["flatness"] = f.flatness;
    AddStats(f.stats, &j);
  } else if (shape == "circle") {
    const auto f = geometry::FitMinZoneCircle(p);
    j = RadialZone(f.circle, "roundness", f);
  } else if (shape == "sphere") {
    const auto f = geometry::FitMinZoneSphere(p);
    j = RadialZone(f.sphere, "sphericity", f);
  } else {
    const auto f = geometry::FitMinZoneCylinder(p);
    j = RadialZone(f.cylinder, "cylindricity", f);
  }
  return j;
}

Json Fit(const FitRequest& req, const Points3& p) {
  namespace g = geometry;
  const g::FitOptions opts = req.robust.least_squares;
  const std::string& s = req.shape;
  const std::string& m = req.method;
  if (m == "minzone" &&
      (s == "line" || s == "plane" || s == "circle" || s == "sphere" || s == "cylinder"))
    return MinZone(s, p);
  if ((m == "mic" || m == "mcc") && s == "circle") {
    const auto f = m == "mic" ? g::FitMaxInscribedCircle(p) : g::FitMinCircumscribedCircle(p);
    Json j = ShapeJson(f.circle);
    AddStats(f.stats, &j);
    return j;
  }
  if (s == "line") return LsOrRobust<g::Line3>(req, p, g::FitLine3, g::FitLine3Robust);
  if (s == "plane") return LsOrRobust<g::Plane>(req, p, g::FitPlane, g::FitPlaneRobust);
  if (s == "circle") {
    if (m != "ls" && m != "robust")
      throw UsageError("circle methods: ls, robust, minzone, mic, mcc");
    Json j = LsOrRobust<g::Circle3>(
        req, p, [&](const Points3& q) { return g::FitCircle3(q, opts); }, g::FitCircle3Robust);
    j["definition"] = req.circle3;
    return j;
  }
  if (s == "sphere") {
    return LsOrRobust<g::Sphere>(
        req, p, [&](const Points3& q) { return g::FitSphere(q, opts); }, g::FitSphereRobust);
  }
  if (s == "cylinder") {
    return LsOrRobust<g::Cylinder>(
        req, p, [&](const Points3& q) { return g::FitCylinder(q, opts); }, g::FitCylinderRobust);
  }
  if (s == "cone") {
    return LsOrRobust<g::Cone>(
        req, p, [&](const Points3& q) { return g::FitCone(q, opts); }, g::FitConeRobust);
  }
  if (s == "ellipse") {
    return LsOrRobust<g::Ellipse3>(
        req, p, [&](const Points3& q) { return g::FitEllipse3(q, opts); }, g::FitEllipse3Robust);
  }
  throw UsageError("unknown shape '" + s +
                   "' (line, plane, circle, sphere, cylinder, cone, ellipse)");
}

std::string Number(const Json& v) {
  if (!v.is_number_float()) return v.dump();
  std::ostringstream os;
  os.precision(6);
  os << std::fixed << v.get<double>();
  return os.str();
}

// One "key: value" line per field, vectors as "x y z", numbers to 1 nm / 1e-6.
void PrintText(const Json& j, std::ostream& out) {
  for (const auto& [key, value] : j.items()) {
    out << "  " << key << ": ";
    if (value.is_array()) {
      for (size_t k = 0; k < value.size(); ++k) out << (k ? " " : "") << Number(value[k]);
    } else if (value.is_object()) {
      for (const auto& [k, v] : value.items()) out << k << "=" << Number(v) << " ";
    } else if (value.is_string()) {
      out << value.get<std::string>();
    } else {
      out << Number(value);
    }
    out << "\n";
  }
}

// Last line of defence of "no NaN out": every number in the reply must be finite.
bool AllFinite(const Json& j) {
  if (j.is_number_float()) return std::isfinite(j.get<double>());
  if (j.is_structured()) {
    for (const auto& v : j) {
      if (!AllFinite(v)) return false;
    }
  }
  return true;
}

}  // namespace

std::string FitUsage() {
  return "usage: mlp fit SHAPE [--method ls|robust|minzone|mic|mcc] [--units mm|m|um|in]\n"
         "                     [--threshold MM] [--seed N] [--circle3 DEF] [--text] FILE\n"
         "  SHAPE: line plane circle sphere cylinder cone ellipse\n"
         "  FILE:  .xyz/.txt (x y z per line), .pcd, .ply, or - for stdin\n"
         "  --circle3: spatial (ISO 10360-6, 3D distances; the default) or plane-then-circle\n"
         "             (NIST: least-squares plane, then the circle in it)\n"
         "  minzone: line (straightness), plane (flatness), circle (roundness),\n"
         "           sphere (sphericity), cylinder (cylindricity);\n"
         "  mic/mcc: circle (maximum inscribed / minimum circumscribed).\n"
         "  Prints one JSON object (or, with --text, a readable summary), lengths in mm.\n"
         "  Exit 0 ok, 2 bad input, 1 internal error.\n";
}

int RunFitCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  try {
    if (!args.empty() && (args[0] == "--help" || args[0] == "-h")) {
      out << FitUsage();
      return kExitOk;
    }
    const FitRequest req = ParseArgs(args);
    Cloud cloud = ReadCloud(req.path);
    cloud.points *= req.unit_scale;
    Json j = {{"shape", req.shape}, {"method", req.method}, {"units", "mm"}};
    j.update(Fit(req, cloud.points));
    j["points_read"] = cloud.points.cols() + static_cast<Eigen::Index>(cloud.dropped_non_finite);
    j["dropped_non_finite"] = cloud.dropped_non_finite;
    MLP_CHECK_MSG(AllFinite(j), "every fit returns finite values or throws");
    if (req.text) {
      out << "mlp fit " << req.shape << " (" << req.method << ") " << req.path << "\n";
      PrintText(j, out);
    } else {
      out << j.dump(2) << "\n";
    }
    return kExitOk;
  } catch (const UsageError& e) {
    err << "mlp fit: " << e.what() << "\n" << FitUsage();
    return kExitBadInput;
  } catch (const CloudIoError& e) {
    err << "mlp fit: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const geometry::GeometryError& e) {
    err << "mlp fit: " << geometry::ToString(e.code()) << ": " << e.what() << "\n";
    return kExitBadInput;
  } catch (const std::exception& e) {
    err << "mlp fit: internal error: " << e.what() << "\n";
    return kExitInternal;
  }
}

}  // namespace mlp::host
