#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "defects/weathering.h"

using namespace dg;

namespace {

RustParams rust(float age, uint64_t seed = 7) {
  RustParams p;
  p.origin_uv = {100, 100};
  p.radius_mm = 30;
  p.age_years = age;
  p.seed = seed;
  return p;
}

PatinaParams patina(float age, float cavity_weight = 0, uint64_t seed = 5) {
  PatinaParams p;
  p.center_uv = {100, 100};
  p.radius_mm = 80;
  p.age_years = age;
  p.cavity_weight = cavity_weight;
  p.seed = seed;
  return p;
}

// The set of grid points (1 mm spacing) inside a defect's label.
template <class D>
std::vector<char> covered(const D& d) {
  std::vector<char> in;
  for (int y = 0; y < 200; ++y)
    for (int x = 0; x < 200; ++x) in.push_back(d.inMask(Vec2f(float(x) + 0.5f, float(y) + 0.5f)));
  return in;
}

size_t count(const std::vector<char>& v) {
  size_t n = 0;
  for (char c : v) n += c;
  return n;
}

}  // namespace

TEST(Rust, CoverageGrowsWithAgeAndTheRegionsAreNested) {
  std::vector<float> ages = {0, 0.25f, 0.5f, 1, 2, 4, 8, 16, 40};
  std::vector<char> prev;
  size_t prev_n = 0;
  for (float a : ages) {
    Rust r(rust(a));
    std::vector<char> in = covered(r);
    size_t n = count(in);
    if (a == 0) {
      EXPECT_EQ(n, 0u);
    }
    if (!prev.empty()) {
      EXPECT_GE(n, prev_n) << "age " << a;
      for (size_t i = 0; i < in.size(); ++i) ASSERT_TRUE(!prev[i] || in[i]) << "point left the rust at age " << a;
    }
    prev = in;
    prev_n = n;
  }
  // Fully grown (g -> 1) the spot's area is near pi R^2 (the noise moves the front both ways).
  EXPECT_GT(prev_n, 0.6 * kPi * 30 * 30);
  EXPECT_LT(prev_n, 1.6 * kPi * 30 * 30);
}

TEST(Rust, EverythingLabelledLiesInTheSupportAndIsShadedAsRust) {
  Rust r(rust(3));
  Box2 mb = r.maskBox(), sb = r.support();
  int inside = 0;
  for (int y = 0; y < 200; ++y)
    for (int x = 0; x < 200; ++x) {
      Vec2f p(float(x) + 0.5f, float(y) + 0.5f);
      DefectQuery q;
      q.uv = p;
      DefectShading s;
      r.shade(q, s);
      if (r.inMask(p)) {
        ++inside;
        ASSERT_TRUE(mb.contains(p));
        ASSERT_FLOAT_EQ(s.cover, 1.0f);
        // The colour lies between the fresh/accent and the old colour (per channel bounds).
        EXPECT_LE(s.appearance.albedo.x, 0.45f + 1e-4f);
        EXPECT_GE(s.appearance.albedo.x, 0.06f - 1e-4f);
      } else {
        ASSERT_EQ(s.cover, 0.0f);
      }
      if (!sb.contains(p)) {
        ASSERT_EQ(s.height_grad.x, 0.0f);
        ASSERT_EQ(s.height_grad.y, 0.0f);
      }
      ASSERT_TRUE(std::isfinite(s.height_grad.x) && std::isfinite(s.height_grad.y));
    }
  EXPECT_GT(inside, 100);
}

TEST(Rust, OlderRustIsDarker) {
  // Near the origin (oldest) the albedo is darker than near the front (freshest).
  Rust r(rust(5));
  float g = r.front();
  double lum_old = 0, lum_fresh = 0;
  int n_old = 0, n_fresh = 0;
  for (int y = 0; y < 200; ++y)
    for (int x = 0; x < 200; ++x) {
      Vec2f p(float(x) + 0.5f, float(y) + 0.5f);
      if (!r.inMask(p)) continue;
      DefectQuery q;
      q.uv = p;
      DefectShading s;
      r.shade(q, s);
      float ph = r.phi(p);
      float l = luminance(s.appearance.albedo);
      if (ph < 0.3f * g) lum_old += l, ++n_old;
      if (ph > 0.8f * g) lum_fresh += l, ++n_fresh;
    }
  ASSERT_GT(n_old, 20);
  ASSERT_GT(n_fresh, 20);
  EXPECT_LT(lum_old / n_old, 0.7 * lum_fresh / n_fresh);
}

TEST(Rust, SeedDeterminesTheShape) {
  EXPECT_EQ(covered(Rust(rust(3, 1))), covered(Rust(rust(3, 1))));
  EXPECT_NE(covered(Rust(rust(3, 1))), covered(Rust(rust(3, 2))));
}

TEST(Rust, BlistersLiftThePaintOnlyJustOutsideTheFront) {
  Rust r(rust(3));
  int bumped_outside = 0;
  for (int y = 0; y < 200; ++y)
    for (int x = 0; x < 200; ++x) {
      Vec2f p(float(x) + 0.5f, float(y) + 0.5f);
      if (r.inMask(p)) continue;
      DefectQuery q;
      q.uv = p;
      DefectShading s;
      r.shade(q, s);
      bool bumped = s.height_grad.x != 0 || s.height_grad.y != 0;
      bumped_outside += bumped;
      if (bumped) {
        EXPECT_LT(r.phi(p), r.front() + 3.0f / 30.0f + 1e-5f);
      }
    }
  EXPECT_GT(bumped_outside, 10);
}

TEST(Patina, NormalizedAgeIsMonotoneFromZeroToOne) {
  EXPECT_EQ(Patina::normalizedAge(0, 1), 0.0f);
  EXPECT_NEAR(Patina::normalizedAge(25, 1), 1.0f, 1e-6);
  EXPECT_EQ(Patina::normalizedAge(100, 1), 1.0f);
  float prev = -1;
  for (float t = 0; t < 30; t += 0.1f) {
    float a = Patina::normalizedAge(t, 1);
    EXPECT_GE(a, prev);
    prev = a;
  }
  // A harsher environment ages faster.
  EXPECT_GT(Patina::normalizedAge(2, 3), Patina::normalizedAge(2, 1));
  // Fast start, slow later (log model): the first year does more than the tenth.
  EXPECT_GT(Patina::normalizedAge(1, 1) - Patina::normalizedAge(0, 1),
            Patina::normalizedAge(10, 1) - Patina::normalizedAge(9, 1));
}

TEST(Patina, CoverageGrowsWithAgeAndTheRegionsAreNested) {
  std::vector<char> prev;
  size_t prev_n = 0;
  for (float a : {0.0f, 0.1f, 0.5f, 1.0f, 3.0f, 10.0f, 25.0f}) {
    Patina pt(patina(a));
    std::vector<char> in = covered(pt);
    size_t n = count(in);
    if (a == 0) {
      EXPECT_EQ(n, 0u);
    }
    if (!prev.empty()) {
      EXPECT_GE(n, prev_n);
      for (size_t i = 0; i < in.size(); ++i) ASSERT_TRUE(!prev[i] || in[i]);
    }
    prev = in;
    prev_n = n;
  }
  // At 25 years the whole disc is covered.
  EXPECT_NEAR(double(prev_n), kPi * 80 * 80, 0.02 * kPi * 80 * 80);
}

TEST(Patina, CavitiesAttractPatina) {
  Patina open(patina(1.5f, 0.6f)), dummy(patina(1.5f, 0.6f));
  int n_open = 0, n_cavity = 0;
  for (int y = 40; y < 160; ++y)
    for (int x = 40; x < 160; ++x) {
      DefectQuery q;
      q.uv = {float(x), float(y)};
      q.cavity = 0;
      n_open += open.inMask(q);
      q.cavity = 1;
      n_cavity += dummy.inMask(q);
    }
  EXPECT_GT(n_cavity, n_open + 1000);
  EXPECT_TRUE(open.needsCavity());
  EXPECT_FALSE(Patina(patina(1.5f, 0.0f)).needsCavity());
}

TEST(Patina, ColourFollowsTheAgeBands) {
  // Young patina is brown (red > green); old patina is green-blue (green > red).
  auto meanColor = [](float age) {
    Patina p(patina(age));
    Rgb sum(0.0f);
    int n = 0;
    for (int y = 30; y < 170; y += 2)
      for (int x = 30; x < 170; x += 2) {
        DefectQuery q;
        q.uv = {float(x), float(y)};
        DefectShading s;
        p.shade(q, s);
        if (s.cover > 0) sum += s.appearance.albedo, ++n;
      }
    return n ? sum / float(n) : sum;
  };
  Rgb young = meanColor(0.3f), old = meanColor(30.0f);
  EXPECT_GT(young.x, young.y);
  EXPECT_GT(old.y, old.x);
}

// Rust from a scratch: the front is a band around the bared stretch of the path. Without noise
// (roughness 0) the label is exactly the points within g R of the stretch.
TEST(Rust, FromAScratchGrowsAsABandAroundTheBaredStretch) {
  RustParams p = rust(3);
  p.roughness = 0;
  p.origin = "scratch";
  p.origin_path = {{40, 100}, {100, 100}, {160, 130}};
  Rust r(p);
  float reach = r.front() * p.radius_mm;
  ScratchPath line = ScratchPath::polyline(p.origin_path);
  int in = 0;
  for (int y = 0; y < 200; ++y)
    for (int x = 0; x < 200; ++x) {
      Vec2f q(float(x) + 0.5f, float(y) + 0.5f);
      float d = line.closest(q).distance;
      if (std::fabs(d - reach) < 1e-3f) continue;
      ASSERT_EQ(r.inMask(q), d < reach) << x << "," << y;
      if (d < reach) {
        ++in;
        ASSERT_TRUE(r.maskBox().contains(q));
      }
    }
  // Area of the band: 2 g R * length + pi (g R)^2 (the two end caps), less a little at the bend.
  double area = 2 * reach * line.length() + kPi * reach * reach;
  EXPECT_NEAR(in, area, 0.03 * area);
  // Oldest on the stretch, fresh at the front.
  DefectQuery q0, q1;
  q0.uv = {70, 100};
  q1.uv = {70, 100 + 0.9f * reach};
  DefectShading s0, s1;
  r.shade(q0, s0);
  r.shade(q1, s1);
  EXPECT_LT(s0.appearance.albedo.x, s1.appearance.albedo.x);
  // With the default roughness, growth with age stays monotone and nested.
  std::vector<char> prev;
  for (float a : {0.5f, 1.0f, 2.0f, 4.0f, 8.0f}) {
    RustParams pa = p;
    pa.roughness = 0.35f;
    pa.age_years = a;
    std::vector<char> cur = covered(Rust(pa));
    for (size_t i = 0; i < cur.size() && !prev.empty(); ++i) ASSERT_TRUE(!prev[i] || cur[i]) << "age " << a;
    prev = cur;
  }
  EXPECT_EQ(r.attributes()["origin"], "scratch");
}
