// The 2D profile of lines and arcs: lengths, points and outward normals along it, closest
// points with signed distances (outside +), and profiles refused with the reason.

#include "mlp/geometry/profile2d.h"

#include "mlp/geometry/error.h"

#include <cmath>

#include <gtest/gtest.h>

namespace mlp::geometry {
namespace {

constexpr double kTol = 1e-12;

// A line along +x, a convex quarter arc down (cw about (2, 0)), a line down: material below
// and to the right.
Profile2 LArc() {
  ProfileSegment a{{0, 1}, {2, 1}, false, {0, 0}, true};
  ProfileSegment b{{2, 1}, {3, 0}, true, {2, 0}, false};
  ProfileSegment c{{3, 0}, {3, -2}, false, {0, 0}, true};
  return Profile2({a, b, c});
}

TEST(Profile2, PointsAndNormalsAlongIt) {
  const Profile2 p = LArc();
  EXPECT_NEAR(p.Length(), 2 + M_PI / 2 + 2, kTol);
  const ProfileFoot f = p.At(1.0);
  EXPECT_NEAR((f.point - Vec2(1, 1)).norm(), 0, kTol);
  EXPECT_NEAR((f.normal - Vec2(0, 1)).norm(), 0, kTol);  // up: away from the material
  const ProfileFoot m = p.At(2 + M_PI / 4);              // the arc's middle
  EXPECT_NEAR((m.point - Vec2(2 + std::sqrt(0.5), std::sqrt(0.5))).norm(), 0, kTol);
  EXPECT_NEAR((m.normal - Vec2(std::sqrt(0.5), std::sqrt(0.5))).norm(), 0, kTol);
  EXPECT_NEAR((p.At(p.Length() - 1).normal - Vec2(1, 0)).norm(), 0, kTol);
}

TEST(Profile2, ClosestPointsAndSignedDistances) {
  const Profile2 p = LArc();
  const ProfileFoot above = p.Closest({1.5, 1.3});
  EXPECT_NEAR(above.signed_distance, 0.3, kTol);
  EXPECT_NEAR(above.s, 1.5, kTol);
  const ProfileFoot inside = p.Closest({2.3, 0.3});  // in the material, near the arc
  EXPECT_NEAR(inside.signed_distance, std::hypot(0.3, 0.3) - 1, kTol);
  EXPECT_EQ(inside.segment, 1);
  const ProfileFoot right = p.Closest({3.2, -1});
  EXPECT_NEAR(right.signed_distance, 0.2, kTol);
  EXPECT_NEAR(right.s, 2 + M_PI / 2 + 1, kTol);
}

TEST(Profile2, RefusesProfilesThatDoNotJoin) {
  ProfileSegment a{{0, 1}, {2, 1}, false, {0, 0}, true};
  ProfileSegment gap{{2.1, 1}, {3, 1}, false, {0, 0}, true};
  EXPECT_THROW(Profile2({a, gap}), GeometryError);
  ProfileSegment bad_arc{{2, 1}, {3.5, 0}, true, {2, 0}, false};
  EXPECT_THROW(Profile2({a, bad_arc}), GeometryError);
  EXPECT_THROW(Profile2({}), GeometryError);
}

}  // namespace
}  // namespace mlp::geometry
