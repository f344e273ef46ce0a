// The car paint's flake lobe with a tilted flake normal (sparkles from the paint variation).
#include <gtest/gtest.h>

#include <cmath>

#include "core/rng.h"
#include "render/bsdf.h"

using namespace dg;

namespace {
Material tiltedFlakePaint(Vec3f n) {
  Material m;
  m.kind = MaterialKind::CarPaint;
  m.base_color = {0.6f, 0.3f, 0.2f};
  m.flake_amount = 1.0f;
  m.flake_roughness = 0.15f;
  m.flake_normal = normalize(n);
  m.coat_ior = 1.0f;  // no coat reflection: look at the flake lobe alone
  return m;
}
Vec3f randomDir(Rng& r) {
  float z = r.uniform(), phi = 2 * kPiF * r.uniform(), s = std::sqrt(std::max(0.0f, 1 - z * z));
  return {s * std::cos(phi), s * std::sin(phi), z};
}
}  // namespace

TEST(FlakeLobe, TiltedFlakeIsReciprocalAndFinite) {
  Material m = tiltedFlakePaint({0.3f, -0.2f, 1.0f});
  Rng r(3, Stream::Test);
  for (int i = 0; i < 5000; ++i) {
    Vec3f a = randomDir(r), b = randomDir(r);
    Rgb f1 = evalBsdf(m, a, b), f2 = evalBsdf(m, b, a);
    ASSERT_TRUE(isFinite(f1));
    EXPECT_NEAR(f1.x, f2.x, 1e-5f * std::max(1.0f, f1.x));
  }
}

TEST(FlakeLobe, TiltedFlakeMovesTheHighlight) {
  // Seen head-on, a flake tilted by ~17 degrees about y reflects the light from ~34 degrees away
  // more strongly than from the mirror direction of the untilted surface.
  Material flat = tiltedFlakePaint({0, 0, 1}), tilted = tiltedFlakePaint({0.3f, 0, 1});
  Vec3f wo(0, 0, 1);
  float t = 2 * std::atan(0.3f);
  Vec3f wi_tilted(std::sin(t), 0, std::cos(t));
  EXPECT_GT(evalBsdf(tilted, wo, wi_tilted).x, 5 * evalBsdf(tilted, wo, Vec3f(0, 0, 1)).x);
  EXPECT_GT(evalBsdf(flat, wo, Vec3f(0, 0, 1)).x, 5 * evalBsdf(flat, wo, wi_tilted).x);
}

TEST(FlakeLobe, SamplingMatchesPdfAndConservesEnergy) {
  Material m = tiltedFlakePaint({-0.2f, 0.25f, 1.0f});
  Rng r(9, Stream::Test);
  for (float cz : {0.9f, 0.5f, 0.2f}) {
    Vec3f wo(std::sqrt(1 - cz * cz), 0, cz);
    double sum = 0;
    const int n = 40000;
    for (int i = 0; i < n; ++i) {
      BsdfSample s;
      if (!sampleBsdf(m, wo, r.uniform(), {r.uniform(), r.uniform()}, s)) continue;
      EXPECT_NEAR(s.pdf, pdfBsdf(m, wo, s.wi), 1e-3f * s.pdf);
      sum += luminance(s.f) * s.wi.z / s.pdf;
    }
    EXPECT_LE(sum / n, 1.0 + 0.02) << cz;
    EXPECT_GT(sum / n, 0.01) << cz;  // some light is reflected at every angle
  }
}
