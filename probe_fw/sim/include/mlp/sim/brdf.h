#pragma once
/// @file How much light a surface sends from a light towards a viewer: a Lambertian part plus a
/// microfacet lobe (Cook and Torrance, ACM TOG 1(1), 1982) with the GGX facet distribution and
/// Smith's masking (Walter, Marschner, Li, Torrance, EGSR 2007) and Schlick's Fresnel
/// approximation (Computer Graphics Forum 13(3), 1994). Hand-written: a few lines of closed
/// form; no Debian package offers a BRDF without a whole renderer around it.

#include "mlp/sim/scene.h"

namespace mlp::sim {

/// pi x BRDF x cos(incidence): the radiance towards `to_viewer` of a face with unit normal `n`
/// lit from `to_light`, relative to a white Lambertian face lit at normal incidence (so a matt
/// face of reflectance rho gives rho cos(incidence)). All directions unit, pointing away from the
/// surface. 0 when either direction is behind the face. A glint (specular direction, small
/// roughness) gives values far above 1: the camera saturates there, as on real metal.
/// Smith's masking of one direction at cos_theta from the normal, GGX alpha^2 (Walter et al.
/// 2007, eq. 34).
double SmithG1(double cos_theta, double alpha2);
/// Schlick's Fresnel reflectance at cos(angle to the half vector) `cos_h`, f0 at normal incidence.
double SchlickFresnel(double f0, double cos_h);

double Reflected(
    double diffuse, const Gloss& gloss, const Vec3& n, const Vec3& to_light, const Vec3& to_viewer);

}  // namespace mlp::sim
