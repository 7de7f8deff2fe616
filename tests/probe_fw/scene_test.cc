// Scene files and CSG ray casting against hand-computed intersections.

#include "mlp/sim/scene.h"

#include <cmath>

#include <gtest/gtest.h>

namespace mlp::sim {
namespace {

constexpr double kTolMm = 1e-9;

// A 100 x 100 x 30 block, top face at z = 0, with a through-bore of diameter 40 on the z axis and
// a cone frustum boss (radius 10 -> 5 over 10 mm) standing on it at x = 35.
const char* kBlockScene = R"({
  "format": "mlprobe-scene/1",
  "flange_from_probe": {"translation_mm": [0, 0, 0], "rotation_vector_rad": [0, 0, 0]},
  "workpiece": {"union": [
    {"difference": [
      {"box": {"min": [-50, -50, -30], "max": [50, 50, 0]}, "reflectance": 0.6},
      {"cylinder": {"base": [0, 0, -31], "axis": [0, 0, 1], "radius": 20, "length": 32}}
    ]},
    {"cone": {"base": [35, 0, 0], "axis": [0, 0, 1], "length": 10, "radius_base": 10,
              "radius_top": 5}, "reflectance": 0.3}
  ]},
  "captures": [{"id": "top", "mcs_from_flange":
      {"translation_mm": [0, 0, 120], "rotation_vector_rad": [3.141592653589793, 0, 0]}}]
})";

Ray RayTo(const Vec3& from, const Vec3& to) { return {from, (to - from).normalized()}; }

TEST(Scene, ParsesTheBlock) {
  const Scene s = ParseScene(kBlockScene);
  ASSERT_EQ(s.captures.size(), 1u);
  EXPECT_EQ(s.captures[0].id, "top");
  // The camera looks down: probe z is -Z of the machine.
  EXPECT_TRUE(
      (s.captures[0].mcs_from_flange.linear() * Vec3::UnitZ()).isApprox(-Vec3::UnitZ(), 1e-12));
}

TEST(Scene, TopFaceAndThroughBore) {
  const Scene s = ParseScene(kBlockScene);
  const auto top = s.FirstHit(RayTo({-30, 30, 100}, {-30, 30, 0}));
  ASSERT_TRUE(top);
  EXPECT_NEAR(top->t, 100.0, kTolMm);
  EXPECT_TRUE(top->normal.isApprox(Vec3::UnitZ(), 1e-12));
  EXPECT_DOUBLE_EQ(top->reflectance, 0.6);
  EXPECT_FALSE(s.FirstHit(RayTo({0, 0, 100}, {0, 0, -200})));  // straight through the bore
}

TEST(Scene, BoreWallNormalPointsIntoTheHole) {
  const Scene s = ParseScene(kBlockScene);
  // From the bore axis at z = -10 towards +x: the wall at x = 20.
  const auto wall = s.FirstHit({{0, 0, -10}, Vec3::UnitX()});
  ASSERT_TRUE(wall);
  EXPECT_NEAR(wall->t, 20.0, kTolMm);
  EXPECT_TRUE(wall->normal.isApprox(-Vec3::UnitX(), 1e-12));
  // Oblique from above: the ray enters the hole and meets the wall at x = -20.
  const Vec3 from(10, 0, 50), target(-20, 0, -10);
  const auto oblique = s.FirstHit(RayTo(from, target));
  ASSERT_TRUE(oblique);
  constexpr double kRayExactMm = 1e-9;  // a ray cast against the geometry
  EXPECT_NEAR(oblique->t, (target - from).norm(), kRayExactMm);
  EXPECT_TRUE(oblique->normal.isApprox(Vec3::UnitX(), 1e-12));
}

TEST(Scene, ConeFrustumMantleAndCap) {
  const Scene s = ParseScene(kBlockScene);
  // Horizontal ray at height 4 from +x: radius there is 10 - 0.5 * 4 = 8.
  const auto mantle = s.FirstHit({{60, 0, 4}, -Vec3::UnitX()});
  ASSERT_TRUE(mantle);
  EXPECT_NEAR(mantle->t, 60.0 - 35.0 - 8.0, kTolMm);
  EXPECT_TRUE(mantle->normal.isApprox(Vec3(1, 0, 0.5).normalized(), 1e-12));
  EXPECT_DOUBLE_EQ(mantle->reflectance, 0.3);
  const auto cap = s.FirstHit(RayTo({35, 0, 50}, {35, 0, 0}));
  ASSERT_TRUE(cap);
  EXPECT_NEAR(cap->t, 40.0, kTolMm);
  EXPECT_TRUE(cap->normal.isApprox(Vec3::UnitZ(), 1e-12));
}

TEST(Scene, SphereAndBlockedSegments) {
  Scene s;
  s.workpiece = MakeSphere({0, 0, 0}, 12.7, 0.8);
  const auto hit = s.FirstHit(RayTo({0, 0, 100}, {0, 0, 0}));
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->t, 100.0 - 12.7, kTolMm);
  EXPECT_TRUE(s.Blocked({0, 0, -20}, {0, 0, 20}));
  EXPECT_FALSE(s.Blocked({0, 0, 12.7}, {0, 0, 50}));  // starts on the surface, leaves it
  EXPECT_FALSE(s.Blocked({20, 0, -20}, {20, 0, 20}));
}

void ExpectSceneError(const std::string& text, const std::string& needle) {
  try {
    ParseScene(text);
    ADD_FAILURE() << "accepted: " << needle;
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

TEST(Scene, BadScenesAreTypedErrors) {
  const std::string head =
      R"({"format": "mlprobe-scene/1", "flange_from_probe": {"translation_mm": [0,0,0], "rotation_vector_rad": [0,0,0]}, "captures": [{"id": "a", "mcs_from_flange": {"translation_mm": [0,0,0], "rotation_vector_rad": [0,0,0]}}], "workpiece": )";
  ExpectSceneError(head + R"({"torus": {}}})", "expected one of");
  ExpectSceneError(head + R"({"sphere": {"center": [0,0,0]}}})", "radius");
  ExpectSceneError(head + R"({"sphere": {"center": [0,0,0], "radius": -1}}})", "positive");
  ExpectSceneError(head + R"({"sphere": {"center": [0,0], "radius": 1}}})", "3 numbers");
  ExpectSceneError(head + R"({"difference": [{"sphere": {"center": [0,0,0], "radius": 1}}]}})",
                   "at least one to subtract");
  ExpectSceneError(head + R"({"box": {"min": [0,0,0], "max": [1,1,1]}, "reflectance": 2}})",
                   "reflectance");
  ExpectSceneError(
      head + R"({"cylinder": {"base": [0,0,0], "axis": [0,0,0], "radius": 1, "length": 1}}})",
      "zero vector");
  const std::string board =
      R"({"chessboard": {"pose": {"translation_mm": [0,0,0], "rotation_vector_rad": [0,0,0]}, )";
  ExpectSceneError(head + board + R"("inner_cols": 1, "inner_rows": 6, "square_mm": 2}}})",
                   "2..100");
  ExpectSceneError(head + board + R"("inner_cols": 9, "inner_rows": 6, "square_mm": 0}}})",
                   "positive");
  ExpectSceneError(
      head + board +
          R"("inner_cols": 9, "inner_rows": 6, "square_mm": 2, "dark_reflectance": 0.9}, "reflectance": 0.5}})",
      "dark_reflectance");
  ExpectSceneError(R"({"format": "mlprobe-scene/9"})", "format");
  const std::string box = R"({"box": {"min": [0,0,0], "max": [1,1,1]}, "material": )";
  ExpectSceneError(head + box + R"("chrome"}})", "unknown finish");
  ExpectSceneError(head + box + R"({"specular_f0": 0.5, "roughness": 0.001}}})", "roughness");
  ExpectSceneError(head + box + R"({"specular_f0": 1.5, "roughness": 0.1}}})", "specular_f0");
  ExpectSceneError(head + box + R"({"specular_f0": 0.5}}})", "roughness");
  ExpectSceneError(head + box + R"(7}})", "finish name or an object");
}

// A finish on an operation reaches every face of it, the subtracted bore's wall too; a face
// without one is matt.
TEST(Scene, MaterialsReachEveryFaceOfTheirSolid) {
  const std::string text = R"({
    "format": "mlprobe-scene/1",
    "flange_from_probe": {"translation_mm": [0, 0, 0], "rotation_vector_rad": [0, 0, 0]},
    "workpiece": {"union": [
      {"difference": [
        {"box": {"min": [-50, -50, -30], "max": [50, 50, 0]}},
        {"cylinder": {"base": [0, 0, -31], "axis": [0, 0, 1], "radius": 20, "length": 32}}
      ], "material": "ground_steel"},
      {"sphere": {"center": [0, 80, 10], "radius": 5}, "reflectance": 0.4,
       "material": {"specular_f0": 0.9, "roughness": 0.3}},
      {"sphere": {"center": [0, -80, 10], "radius": 5}, "reflectance": 0.7}
    ]},
    "captures": [{"id": "top", "mcs_from_flange":
        {"translation_mm": [0, 0, 120], "rotation_vector_rad": [3.141592653589793, 0, 0]}}]
  })";
  const Scene s = ParseScene(text);
  EXPECT_TRUE(s.workpiece->Glossy());
  const auto top = s.FirstHit(RayTo({30, 30, 50}, {30, 30, 0}));
  const auto wall = s.FirstHit(RayTo({0, 0, -10}, {-30, 0, -10}));
  const auto glossy = s.FirstHit(RayTo({0, 80, 50}, {0, 80, 0}));
  const auto matt = s.FirstHit(RayTo({0, -80, 50}, {0, -80, 0}));
  ASSERT_TRUE(top && wall && glossy && matt);
  for (const auto& h : {*top, *wall}) {
    EXPECT_EQ(h.gloss.specular_f0, 0.55);
    EXPECT_EQ(h.gloss.roughness, 0.12);
    EXPECT_EQ(h.reflectance, 0.08);  // the finish's diffuse part
  }
  EXPECT_EQ(glossy->gloss.specular_f0, 0.9);
  EXPECT_EQ(glossy->reflectance, 0.4);  // no diffuse given: the solid's reflectance stays
  EXPECT_EQ(matt->gloss.specular_f0, 0.0);
  EXPECT_EQ(matt->reflectance, 0.7);
  EXPECT_FALSE(ParseScene(kBlockScene).workpiece->Glossy());
}

}  // namespace
}  // namespace mlp::sim
