#include <gtest/gtest.h>

#include <cmath>

#include "defects/defect_index.h"
#include "defects/dent.h"

using namespace dg;

namespace {
Dent makeDent(float r, float d, float thr = 0.1f, Vec2f c = {100, 100}) {
  DentParams p;
  p.center_uv = c;
  p.radius_mm = r;
  p.depth_mm = d;
  p.mask_threshold = thr;
  return Dent(p);
}
}  // namespace

TEST(Dent, ProfileValuesAndContinuity) {
  Dent dent = makeDent(20, 1);
  EXPECT_DOUBLE_EQ(dent.height(0), -1.0);
  EXPECT_DOUBLE_EQ(dent.height(20), 0.0);
  EXPECT_DOUBLE_EQ(dent.height(25), 0.0);
  EXPECT_DOUBLE_EQ(dent.slope(0), 0.0);
  EXPECT_NEAR(dent.slope(20 - 1e-9), 0.0, 1e-9);  // C1 at the rim
  // The derivative matches a central difference of the height.
  for (double r = 0.5; r < 20; r += 0.7) {
    double fd = (dent.height(r + 1e-5) - dent.height(r - 1e-5)) / 2e-5;
    EXPECT_NEAR(dent.slope(r), fd, 1e-6) << r;
  }
}

TEST(Dent, MaximumSlopeAtRadiusOverRootThree) {
  // Digest §8.5: max slope 8d/(3 sqrt 3 R) ~ 1.5396 d/R at r = R/sqrt 3.
  Dent dent = makeDent(20, 1);
  double best = 0, at = 0;
  for (double r = 0; r < 20; r += 1e-3)
    if (dent.slope(r) > best) best = dent.slope(r), at = r;
  EXPECT_NEAR(best, 8.0 / (3.0 * std::sqrt(3.0) * 20.0), 1e-7);
  EXPECT_NEAR(at, 20.0 / std::sqrt(3.0), 2e-3);
}

TEST(Dent, GradientPointsAwayFromCentreForADent) {
  // For a dent (F < 0) the height rises away from the centre, so dF/du > 0 to the right; the
  // perturbed normal n - grad F then tilts toward the centre (digest §3b, consequence 3).
  Dent dent = makeDent(20, 1);
  DefectShading s;
  DefectQuery q;
  q.uv = {110, 100};
  dent.shade(q, s);
  EXPECT_GT(s.height_grad.x, 0);
  EXPECT_NEAR(s.height_grad.y, 0, 1e-7);
  EXPECT_NEAR(s.height_grad.x, dent.slope(10), 1e-6);
  // Zero depth leaves the shading untouched; the centre and outside have no gradient.
  Dent flat = makeDent(20, 0);
  DefectShading z;
  flat.shade(q, z);
  EXPECT_EQ(z.height_grad.x, 0.0f);
  DefectShading c;
  q.uv = {100, 100};
  dent.shade(q, c);
  q.uv = {130, 100};
  dent.shade(q, c);
  EXPECT_EQ(c.height_grad.x, 0.0f);
  EXPECT_EQ(c.height_grad.y, 0.0f);
}

TEST(Dent, MaskRadiusFromThreshold) {
  Dent dent = makeDent(20, 2, 0.25f);
  // depth >= 0.25 d  <=>  (1 - s)^2 >= 0.25  <=>  s <= 0.5  <=>  r <= R / sqrt 2.
  EXPECT_NEAR(dent.maskRadius(), 20.0 / std::sqrt(2.0), 1e-9);
  EXPECT_TRUE(dent.inMask({100 + 14.1f, 100}));
  EXPECT_FALSE(dent.inMask({100 + 14.2f, 100}));
  EXPECT_GE(-dent.height(dent.maskRadius()), 0.25 * 2 - 1e-9);
}

TEST(Dent, StackedGradientsAreOrderIndependent) {
  Dent a = makeDent(20, 1, 0.1f, {100, 100}), b = makeDent(15, 0.5f, 0.1f, {120, 105});
  DefectQuery q;
  q.uv = {110, 102};
  DefectShading ab, ba;
  a.shade(q, ab);
  b.shade(q, ab);
  b.shade(q, ba);
  a.shade(q, ba);
  EXPECT_FLOAT_EQ(ab.height_grad.x, ba.height_grad.x);
  EXPECT_FLOAT_EQ(ab.height_grad.y, ba.height_grad.y);
}

TEST(DefectIndex, FindsExactlyTheOverlappingDefects) {
  DefectList list;
  for (int i = 0; i < 50; ++i) {
    DentParams p;
    p.center_uv = {float(20 * i + 10), float(7 * i + 10)};
    p.radius_mm = 5;
    list.push_back(std::make_unique<Dent>(p));
    list.back()->setInstanceId(uint16_t(i + 1));
  }
  Box2 uv;
  uv.lo = {0, 0};
  uv.hi = {1000, 400};
  DefectIndex idx(list, uv, 64);
  for (int i = 0; i < 50; ++i) {
    std::vector<int> found;
    idx.forEach({float(20 * i + 10), float(7 * i + 10)}, 0.0f, [&](const Defect& d) { found.push_back(d.instanceId()); });
    ASSERT_FALSE(found.empty());
    EXPECT_NE(std::find(found.begin(), found.end(), i + 1), found.end());
    // Cells are coarse, so neighbours may be reported too, but never a defect far away.
    for (int id : found) EXPECT_LE(std::abs(id - (i + 1)), 2) << i;
  }
  // A footprint spanning several cells reports each defect once, in ascending order.
  std::vector<int> found;
  idx.forEach({30, 15}, 40.0f, [&](const Defect& d) { found.push_back(d.instanceId()); });
  EXPECT_TRUE(std::is_sorted(found.begin(), found.end()));
  EXPECT_EQ(std::adjacent_find(found.begin(), found.end()), found.end());
  EXPECT_GE(found.size(), 3u);
  // Far from every defect: nothing.
  int n = 0;
  idx.forEach({990, 5}, 0.0f, [&](const Defect&) { ++n; });
  EXPECT_EQ(n, 0);
  EXPECT_TRUE(DefectIndex().empty());
}

TEST(Dent, CreaseIsTheProfileAcrossALine) {
  DentParams p;
  p.center_uv = {0, 0};
  p.end_uv = {100, 0};
  p.radius_mm = 10;
  p.depth_mm = 1;
  Dent c(p);
  EXPECT_TRUE(c.isCrease());
  // Along the line the depth is the full depth; across it the round profile.
  EXPECT_NEAR(c.height({50, 0}), -1.0, 1e-6);
  EXPECT_NEAR(c.height({50, 5}), c.height(5.0), 1e-6);
  EXPECT_NEAR(c.height({-5, 0}), c.height(5.0), 1e-6);  // round end cap
  EXPECT_EQ(c.height({50, 11}), 0.0f);
  // The gradient points straight across the line in the middle.
  DefectQuery q;
  q.uv = {50, 4};
  DefectShading s;
  c.shade(q, s);
  EXPECT_EQ(s.height_grad.x, 0.0f);
  EXPECT_NEAR(s.height_grad.y, c.slope(4), 1e-6);
  Box2 b = c.support();
  EXPECT_FLOAT_EQ(b.lo.x, -10);
  EXPECT_FLOAT_EQ(b.hi.x, 110);
  // Mask area: a capsule of radius r_m and length L.
  int n = 0;
  for (float y = -15; y < 15; y += 0.1f)
    for (float x = -15; x < 115; x += 0.1f) n += c.inMask({x + 0.05f, y + 0.05f});
  double rm = c.maskRadius();
  EXPECT_NEAR(n * 0.01, 100 * 2 * rm + kPi * rm * rm, 0.01 * (100 * 2 * rm + kPi * rm * rm));
  // A dent without an end point is round.
  DentParams r;
  r.center_uv = {3, 4};
  EXPECT_FALSE(Dent(r).isCrease());
}
