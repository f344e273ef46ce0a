#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/rng.h"
#include "render/lights.h"

namespace dg {
namespace {

AreaLight ring() {
  AreaLight al;
  al.shape = AreaLight::Shape::Disk;
  al.center = Vec3f(1, 2, 60);
  al.radius = 30;
  al.inner_radius = 20;
  return al;
}

AreaLight bar() {
  AreaLight al;
  al.shape = AreaLight::Shape::Rect;
  al.center = Vec3f(0, 200, 40);
  al.normal = normalize(Vec3f(0, -1, -0.2f));
  al.axis_u = Vec3f(1, 0, 0);
  al.axis_v = normalize(cross(al.normal, al.axis_u));
  al.half_u = 150;
  al.half_v = 10;
  return al;
}

// domainPoint undoes samplePoint: the guide's density for a BSDF direction that meets the light
// is looked up at the domain point the light samples would have drawn.
TEST(LightGuide, DomainPointInvertsSamplePoint) {
  Rng rng(3);
  for (const AreaLight& al : {ring(), bar()}) {
    for (int i = 0; i < 1000; ++i) {
      const Vec2f u(rng.uniform(), rng.uniform());
      const Vec2f v = al.domainPoint(al.samplePoint(u));
      EXPECT_NEAR(v.x, u.x, 2e-4f);
      // The annulus's angle is periodic: 0 and 1 are the same place.
      const float dy = std::fabs(v.y - u.y);
      EXPECT_LT(std::min(dy, 1 - dy), 2e-4f);
    }
  }
  EXPECT_EQ(ring().majorAxis(), 1);  // the angle
  EXPECT_EQ(bar().majorAxis(), 0);   // its length
}

// The warp's density: relDensity at the warped point is the factor warp returns, every domain
// point keeps at least floor^2 of the uniform density, and weighting guided points by 1 / rel
// integrates a function as uniform points do (the guided light samples stay unbiased).
TEST(LightGuide, WarpIsADensityThatIntegratesLikeUniform) {
  float wa[LightGuide::kMajor], wb[LightGuide::kMinor];
  for (int j = 0; j < LightGuide::kMajor; ++j) wa[j] = std::exp(-0.5f * float((j - 5) * (j - 5)));
  for (int i = 0; i < LightGuide::kMinor; ++i) wb[i] = float(i + 1);
  for (int major : {0, 1}) {
    LightGuide g;
    g.major = major;
    g.build(wa, wb, 0.25f);
    ASSERT_TRUE(g.on);
    auto f = [](Vec2f u) { return std::exp(-20 * (u.x - 0.3) * (u.x - 0.3)) * (1 + std::sin(6.2831853 * u.y)); };
    Rng rng(7);
    double guided = 0, uniform = 0, least = 1e9;
    const int n = 400000;
    for (int k = 0; k < n; ++k) {
      const Vec2f u(rng.uniform(), rng.uniform());
      float rel = 0;
      const Vec2f v = g.warp(u, rel);
      ASSERT_GE(v.x, 0.0f);
      ASSERT_LT(v.x, 1.0f);
      ASSERT_GE(v.y, 0.0f);
      ASSERT_LT(v.y, 1.0f);
      ASSERT_NEAR(g.relDensity(v), rel, 1e-4f * rel);
      least = std::min(least, double(rel));
      guided += f(v) / rel;
      uniform += f(u);
    }
    EXPECT_NEAR(guided / uniform, 1.0, 0.01) << "major " << major;
    EXPECT_GE(least, 0.25 * 0.25 * 0.999);
  }
}

// Weights that give nothing to hold on to leave the guide off, and its samples uniform.
TEST(LightGuide, NoWeightLeavesTheSamplesUniform) {
  float wa[LightGuide::kMajor] = {}, wb[LightGuide::kMinor];
  for (float& w : wb) w = 1;
  LightGuide g;
  g.build(wa, wb, 0.25f);
  EXPECT_FALSE(g.on);
  wa[3] = std::nanf("");
  g.build(wa, wb, 0.25f);
  EXPECT_FALSE(g.on);
  float rel = 0;
  const Vec2f v = g.warp(Vec2f(0.3f, 0.7f), rel);
  EXPECT_EQ(rel, 1.0f);
  EXPECT_EQ(v.x, 0.3f);
  EXPECT_EQ(v.y, 0.7f);
  EXPECT_EQ(g.relDensity(v), 1.0f);
}

}  // namespace
}  // namespace dg
