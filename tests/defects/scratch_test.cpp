// Tests of the scratch geometry: the derivation values of shared/reference/bosch-grooves.md §7.A,
// profile invariants, path queries against brute force, flattening bounds, fading, masks and the
// placement helpers.
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "defects/scratch.h"

using namespace dg;

namespace {
constexpr double kDeg = kPi / 180.0;

ToolSpec cone(double apex_deg, double tip_r = 0, double theta_deg = 0, double phi_deg = 0) {
  ToolSpec t;
  t.shape = ToolSpec::Shape::Cone;
  t.apex_angle_rad = apex_deg * kDeg;
  t.tip_radius_mm = tip_r;
  t.theta_rad = theta_deg * kDeg;
  t.phi_rad = phi_deg * kDeg;
  return t;
}

// Distance from p to a polyline (double, brute force).
double polyDist(const std::vector<Vec2d>& P, Vec2d p) {
  double best = 1e300;
  for (size_t i = 0; i + 1 < P.size(); ++i) {
    Vec2d a = P[i], d = P[i + 1] - P[i];
    double l2 = d.x * d.x + d.y * d.y;
    double t = l2 > 0 ? std::clamp(((p.x - a.x) * d.x + (p.y - a.y) * d.y) / l2, 0.0, 1.0) : 0.0;
    double ex = a.x + d.x * t - p.x, ey = a.y + d.y * t - p.y;
    best = std::min(best, std::sqrt(ex * ex + ey * ey));
  }
  return best;
}

Vec2d cubicAt(const Vec2d c[4], double t) {
  double u = 1 - t;
  return c[0] * (u * u * u) + c[1] * (3 * u * u * t) + c[2] * (3 * u * t * t) + c[3] * (t * t * t);
}

Box2 box(float x0, float y0, float x1, float y1) {
  Box2 b;
  b.lo = {x0, y0};
  b.hi = {x1, y1};
  return b;
}

// Area of {inMask} over a box by midpoint sampling.
double maskArea(const Scratch& s, Box2 b, double step) {
  long n = 0;
  for (double y = b.lo.y + 0.5 * step; y < b.hi.y; y += step)
    for (double x = b.lo.x + 0.5 * step; x < b.hi.x; x += step) n += s.inMask(Vec2f{float(x), float(y)});
  return n * step * step;
}
}  // namespace

// ---- §7.A derivation values ------------------------------------------------------------------

TEST(ScratchProcess, DepthFormulaValues) {
  // §7.A.1: 0.182 sqrt(0.0155) - 0.014.
  EXPECT_NEAR(scratchDepthMm(1, 100), 0.0086588172683, 1e-9);
  // Spot checks of the digest's §1.4.3 table (µm, two decimals).
  EXPECT_NEAR(scratchDepthMm(4, 30) * 1e3, 53.81, 0.006);
  EXPECT_NEAR(scratchDepthMm(0.5, 60) * 1e3, 7.41, 0.006);
  EXPECT_NEAR(scratchDepthMm(2, 200) * 1e3, 8.66, 0.006);
  EXPECT_NEAR(scratchDepthMm(0.05, 30) * 1e3, 1.41, 0.006);
  // Monotone in the force, inverse in the hardness.
  EXPECT_LT(scratchDepthMm(1, 100), scratchDepthMm(1.5, 100));
  EXPECT_GT(scratchDepthMm(1, 100), scratchDepthMm(1, 150));
}

TEST(ScratchProcess, DepthClampedAtZero) {
  // §7.A.2: negative below F/H = 4.17e-4 in the fit; clamped to 0.
  EXPECT_EQ(scratchDepthMm(0.04, 100), 0.0);   // F/H = 4.0e-4
  EXPECT_EQ(scratchDepthMm(0.05, 200), 0.0);   // table entry -0.20 µm
  EXPECT_EQ(scratchDepthMm(0.0, 100), 0.0);
  EXPECT_GT(scratchDepthMm(0.0425, 100), 0.0);  // F/H = 4.25e-4
  EXPECT_LT(scratchDepthMm(0.0425, 100), 1e-5);
  // A zero depth gives a zero-width profile.
  ProcessCrossSection cs = deriveCrossSectionForDepth(cone(120), 0.0);
  EXPECT_EQ(cs.profile.width(), 0.0);
  EXPECT_EQ(cs.profile.depth(), 0.0);
}

TEST(ScratchProcess, PeakSlopes) {
  // §7.A.3.
  EXPECT_NEAR(peakTanBetaRaw(std::tan(30 * kDeg)), 0.90647, 5e-6);
  EXPECT_NEAR(peakBeta(30 * kDeg) / kDeg, 42.19, 0.005);
  EXPECT_NEAR(peakBeta(45 * kDeg) / kDeg, 63.20, 0.005);
  // Below alpha = 12.43 deg the fit is <= 0: clamped to the positive minimum.
  EXPECT_LE(peakTanBetaRaw(std::tan(12.4 * kDeg)), 0.0);
  EXPECT_GT(peakTanBetaRaw(std::tan(12.5 * kDeg)), 0.0);
  EXPECT_DOUBLE_EQ(peakBeta(10 * kDeg), kMinPeakBetaRad);
  EXPECT_DOUBLE_EQ(peakBeta(1 * kDeg), kMinPeakBetaRad);
  EXPECT_GT(peakBeta(20 * kDeg), kMinPeakBetaRad);
}

TEST(ScratchProcess, WorkedExampleCone120And90) {
  // §7.A.5: 120 deg cone (alpha = 30 deg): h/p = 0.7816, w_i/p = 1.3538, w_e/p = 0.8622.
  const double p = scratchDepthMm(1, 100);
  ProcessCrossSection cs = deriveCrossSection({cone(120), 1.0, 100.0, 1.0});
  EXPECT_NEAR(cs.depth, p, 1e-15);
  for (int s = 0; s < 2; ++s) {
    EXPECT_NEAR(cs.alpha[s] / kDeg, 30.0, 1e-6);
    EXPECT_NEAR(cs.h[s] / p, 0.7816027, 1e-6);
    EXPECT_NEAR(cs.w_inner[s] / p, 1.3537755, 1e-6);
    EXPECT_NEAR(cs.w_outer[s] / p, 0.8622491, 1e-6);
    EXPECT_NEAR(cs.w_inner[s], cs.h[s] / std::tan(cs.alpha[s]), 1e-15);
    EXPECT_NEAR(cs.w_outer[s], cs.h[s] / std::tan(cs.beta[s]), 1e-15);
  }
  EXPECT_NEAR(cs.groove_area, std::sqrt(3.0) * p * p, 1e-12 * p * p);
  // Groove ~3.46 p wide, ~7.9 p with the peaks (digest §6.4).
  EXPECT_NEAR((cs.b_right - cs.b_left) / p, 2 * std::sqrt(3.0), 1e-6);
  EXPECT_NEAR(cs.profile.width() / p, 2 * (std::sqrt(3.0) + 1.3537755 + 0.8622491), 1e-5);
  // 90 deg cone: beta = 63.2 deg, h = 0.815 p, w_e = 0.412 p.
  ProcessCrossSection c90 = deriveCrossSectionForDepth(cone(90), 0.01);
  EXPECT_NEAR(c90.beta[0] / kDeg, 63.204, 1e-3);
  EXPECT_NEAR(c90.h[0] / 0.01, 0.81513, 1e-5);
  EXPECT_NEAR(c90.w_outer[1] / 0.01, 0.41168, 1e-5);
}

TEST(ScratchProcess, VolumeConservation) {
  // §7.A.4: the two peaks hold the groove's area, for symmetric and asymmetric tools.
  std::vector<ToolSpec> tools = {cone(120), cone(90), cone(120, 0.2), cone(60, 0, 20, 90),
                                 cone(40, 0.01, 45, -90), cone(60, 0, 25, 40)};
  ToolSpec vick;
  vick.shape = ToolSpec::Shape::Pyramid;
  vick.apex_angle_rad = 136 * kDeg;
  tools.push_back(vick);
  vick.roll_rad = 45 * kDeg;
  vick.theta_rad = 10 * kDeg;
  vick.phi_rad = 70 * kDeg;
  tools.push_back(vick);
  for (const ToolSpec& t : tools) {
    ProcessCrossSection cs = deriveCrossSection({t, 1.5, 60.0, 1.0});
    const Profile& pr = cs.profile;
    double A = pr.grooveArea();
    EXPECT_NEAR(A, cs.groove_area, 1e-12 * A);
    EXPECT_NEAR(pr.peakArea(), A, 1e-9 * A) << "apex " << t.apex_angle_rad / kDeg;
    EXPECT_NEAR(pr.depth(), scratchDepthMm(1.5, 60), 1e-12);
  }
  // A pile-up fraction scales the peaks.
  ProcessCrossSection half = deriveCrossSection({cone(120), 1.5, 60.0, 0.5});
  EXPECT_NEAR(half.profile.peakArea(), 0.5 * half.profile.grooveArea(), 1e-9 * half.groove_area);
  ProcessCrossSection none = deriveCrossSection({cone(120), 1.5, 60.0, 0.0});
  EXPECT_EQ(none.profile.peakHeight(), 0.0);
  EXPECT_EQ(none.profile.pts.size(), 3u);
}

TEST(ScratchProcess, ProfileInvariantsAndSigns) {
  ProcessCrossSection cs = deriveCrossSection({cone(120, 0.2), 2.0, 60.0, 1.0});
  const Profile& pr = cs.profile;
  ASSERT_GE(pr.pts.size(), 7u);
  EXPECT_EQ(pr.pts.front().y, 0.0);  // closed at the surface level
  EXPECT_EQ(pr.pts.back().y, 0.0);
  EXPECT_EQ(pr.layer.size(), pr.facets());
  for (size_t k = 0; k + 1 < pr.pts.size(); ++k) EXPECT_LE(pr.pts[k].x, pr.pts[k + 1].x);
  // Depth positive, groove below, peaks above; the lowest point is at -p.
  EXPECT_GT(pr.depth(), 0.0);
  EXPECT_NEAR(pr.depth(), scratchDepthMm(2, 60), 1e-12);
  EXPECT_GT(pr.peakHeight(), 0.0);
  for (const Vec2d& q : pr.pts) {
    if (q.x > cs.b_left + 1e-12 && q.x < cs.b_right - 1e-12) {
      EXPECT_LT(q.y, 0.0);
    }
    if (q.x < cs.b_left - 1e-12 || q.x > cs.b_right + 1e-12) {
      EXPECT_GE(q.y, 0.0);
    }
  }
  // heightAt is continuous (polyline) and 0 outside.
  EXPECT_EQ(pr.heightAt(pr.bMin() - 1e-3), 0.0);
  EXPECT_EQ(pr.heightAt(pr.bMax() + 1e-3), 0.0);
  double prev = pr.heightAt(pr.bMin());
  double maxjump = 0, db = pr.width() / 20000;
  for (double b = pr.bMin() + db; b <= pr.bMax(); b += db) {
    double h = pr.heightAt(b);
    maxjump = std::max(maxjump, std::fabs(h - prev));
    prev = h;
  }
  EXPECT_LT(maxjump, 3.0 * db);  // slopes are below ~tan(72 deg) here
  EXPECT_NEAR(pr.heightAt(0.0), -pr.depth(), 1e-12);
  // The groove lies in the 0.2 mm spherical tip at this depth (the cone starts 26.8 µm down):
  // the wall angle is the sphere's, sin(alpha) = rho / r with rho the half-width at w = 0, up to
  // the sampling of the sphere (chords within 1% of the depth).
  double p = pr.depth(), rho = std::sqrt(2 * 0.2 * p - p * p);
  EXPECT_NEAR(cs.b_right, rho, 0.01 * rho);
  EXPECT_NEAR(cs.alpha[0], std::asin(rho / 0.2), 1.0 * kDeg);
  EXPECT_NEAR(cs.alpha[1], cs.alpha[0], 1e-9);
}

TEST(ScratchProcess, ToolOrientation) {
  const double p = 0.01;
  // (0, phi) equals the un-rotated tool.
  ProcessCrossSection a = deriveCrossSectionForDepth(cone(60), p);
  ProcessCrossSection b = deriveCrossSectionForDepth(cone(60, 0, 0, 37), p);
  ASSERT_EQ(a.profile.pts.size(), b.profile.pts.size());
  for (size_t k = 0; k < a.profile.pts.size(); ++k) {
    EXPECT_NEAR(a.profile.pts[k].x, b.profile.pts[k].x, 1e-12);
    EXPECT_NEAR(a.profile.pts[k].y, b.profile.pts[k].y, 1e-12);
  }
  // Tilted across (phi = 90): the flanks in the tilt plane are at 30 +- 20 deg from vertical.
  ProcessCrossSection c = deriveCrossSectionForDepth(cone(60, 0, 20, 90), p);
  EXPECT_NEAR(c.alpha[0] / kDeg, 80.0, 1e-6);  // -B side steeper: the axis leans towards +B
  EXPECT_NEAR(c.alpha[1] / kDeg, 40.0, 1e-6);
  EXPECT_GT(std::fabs(c.h[0] - c.h[1]), 0.1 * c.h[0]);
  // phi = -90 mirrors it.
  ProcessCrossSection m = deriveCrossSectionForDepth(cone(60, 0, 20, -90), p);
  EXPECT_NEAR(m.alpha[0], c.alpha[1], 1e-9);
  EXPECT_NEAR(m.b_left, -c.b_right, 1e-9);
  // Tilted along the scratch (phi = 0): still symmetric.
  ProcessCrossSection d = deriveCrossSectionForDepth(cone(60, 0, 25, 0), p);
  EXPECT_NEAR(d.alpha[0], d.alpha[1], 1e-6);
  EXPECT_NEAR(d.b_left, -d.b_right, 1e-6 * p);
  EXPECT_NEAR(d.h[0], d.h[1], 1e-6 * p);
  // Vickers pyramid with a face across the path: alpha = 90 - 68 deg.
  ToolSpec v;
  v.shape = ToolSpec::Shape::Pyramid;
  v.apex_angle_rad = 136 * kDeg;
  ProcessCrossSection e = deriveCrossSectionForDepth(v, p);
  EXPECT_NEAR(e.alpha[0] / kDeg, 22.0, 1e-9);
  // theta_t > apex/2 across the scratch: the far flank overhangs and the sweep leaves a vertical
  // wall; the profile stays monotone in b and the peaks still hold the groove's area.
  ProcessCrossSection o = deriveCrossSectionForDepth(cone(40, 0, 45, -90), p);
  EXPECT_NEAR(o.alpha[1] / kDeg, 90.0, 1e-9);
  EXPECT_NEAR(o.alpha[0] / kDeg, 90.0 - 45.0 - 20.0, 1e-6);
  EXPECT_NEAR(o.w_inner[1], o.h[1] / std::tan(kMaxPeakAlphaRad), 1e-15);
  for (size_t k = 0; k + 1 < o.profile.pts.size(); ++k) EXPECT_LE(o.profile.pts[k].x, o.profile.pts[k + 1].x);
  EXPECT_NEAR(o.profile.peakArea(), o.profile.grooveArea(), 1e-9 * o.groove_area);
  // A tilt that puts the flank under the tip is rejected.
  EXPECT_THROW(deriveCrossSectionForDepth(cone(120, 0, 35, 90), p), std::invalid_argument);
  EXPECT_THROW(deriveCrossSectionForDepth(cone(5), p), std::invalid_argument);
  // The limit: 90 - 1 - apex/2 for a cone, less for a pyramid, whose edges are steeper than its
  // faces (apex 136, four faces: edge half-angle atan(tan 68 / cos 45) = 74.05 deg).
  EXPECT_NEAR(maxToolTilt(cone(120)) / kDeg, 29.0, 1e-9);
  ToolSpec vick;
  vick.shape = ToolSpec::Shape::Pyramid;
  vick.apex_angle_rad = 136 * kDeg;
  EXPECT_NEAR(maxToolTilt(vick) / kDeg, 89.0 - std::atan(std::tan(68 * kDeg) / std::cos(kPi / 4)) / kDeg, 1e-9);
  EXPECT_NEAR(maxToolTilt(vick) / kDeg, 14.95, 0.01);
  EXPECT_NO_THROW(deriveCrossSectionForDepth(cone(120, 0, 28.9), p));
  EXPECT_THROW(deriveCrossSectionForDepth(cone(120, 0, 29.1), p), std::invalid_argument);
}

TEST(ScratchProfile, ExplicitPolylineAndLayers) {
  EXPECT_THROW(Profile::fromPolyline({{0, 0}, {1, -0.1}}), std::invalid_argument);  // open end
  EXPECT_THROW(Profile::fromPolyline({{0, 0}, {-1, -0.1}, {1, 0}}), std::invalid_argument);
  Profile v = Profile::fromPolyline({{-0.1, 0}, {0, -0.05}, {0, -0.05}, {0.1, 0}});
  EXPECT_EQ(v.pts.size(), 3u);  // repeated point dropped
  EXPECT_NEAR(v.grooveArea(), 0.1 * 0.05, 1e-15);
  EXPECT_EQ(v.peakArea(), 0.0);
  // Paint: clear 0.02, base 0.015, primer 0.01, steel substrate.
  LayerStack paint{{{"clear", 0.02}, {"base", 0.015}, {"primer", 0.01}, {"steel", 0}}};
  EXPECT_EQ(paint.layerAtDepth(0.0), 0);
  EXPECT_EQ(paint.layerAtDepth(0.025), 1);
  EXPECT_EQ(paint.layerAtDepth(0.05), 3);
  Profile lv = v.withLayers(paint);
  // Split at the interfaces 0.02, 0.035 and 0.045 on each flank (the bottom is at 0.05).
  EXPECT_EQ(lv.facets(), 8u);
  EXPECT_NEAR(lv.grooveArea(), v.grooveArea(), 1e-15);
  int deepest = 0;
  for (size_t k = 0; k < lv.facets(); ++k) {
    double d0 = -lv.pts[k].y, d1 = -lv.pts[k + 1].y;
    // Each facet lies in the layer it shows.
    EXPECT_EQ(paint.layerAtDepth(std::min(d0, d1) + 1e-12), lv.layer[k]);
    deepest = std::max(deepest, lv.layer[k]);
  }
  EXPECT_EQ(deepest, 3);  // through the coat: bare steel at the bottom
  // A shallow scratch stays in the clear coat; the peaks show the top layer.
  ProcessCrossSection cs = deriveCrossSectionForDepth(cone(120), 0.01);
  Profile shallow = cs.profile.withLayers(paint);
  for (int l : shallow.layer) EXPECT_EQ(l, 0);
  Profile deep = cs.profile.scaled(4.0).withLayers(paint);  // 0.04 deep: reaches the primer
  int dl = 0;
  for (int l : deep.layer) dl = std::max(dl, l);
  EXPECT_EQ(dl, 2);
  EXPECT_NEAR(deep.depth(), 0.04, 1e-15);
}

// ---- paths ------------------------------------------------------------------------------------

// A profile cut at b: the kept side's heights are the profile's, the other side is the base, and
// a vertical facet of the cut facet's layer closes it.
TEST(ScratchProfile, KeepSideCutsAtAVerticalFacet) {
  Profile p;
  p.pts = {{-0.07, 0}, {-0.06, 0.004}, {-0.05, 0}, {0, -0.02}, {0.05, 0}, {0.06, 0.004}, {0.07, 0}};
  p.layer = {0, 0, 1, 2, 0, 0};
  for (double bc : {-0.065, -0.03, 0.0, 0.02, 0.05, 0.055})
    for (bool below : {true, false}) {
      Profile q = p;
      q.keepSide(bc, below);
      ASSERT_GE(q.pts.size(), 2u);
      ASSERT_EQ(q.layer.size(), q.pts.size() - 1);
      for (size_t k = 0; k + 1 < q.pts.size(); ++k) EXPECT_LE(q.pts[k].x, q.pts[k + 1].x);
      EXPECT_EQ(q.pts.front().y, 0.0);
      EXPECT_EQ(q.pts.back().y, 0.0);
      for (int i = 0; i <= 200; ++i) {
        const double b = -0.08 + 0.16 * (i + 0.37) / 201;
        const bool kept = below ? b < bc : b > bc;
        EXPECT_NEAR(q.heightAt(b), kept ? p.heightAt(b) : 0.0, 1e-12) << bc << " " << below << " " << b;
      }
      // The vertical facet at bc (none where the profile is on the base there).
      const size_t v = below ? q.pts.size() - 2 : 0;
      EXPECT_EQ(q.pts[v + (below ? 1 : 0)].x, bc);
      if (p.heightAt(bc) != 0) {
        EXPECT_EQ(q.pts[v + (below ? 0 : 1)].x, bc);
      }
    }
  Profile q = p;
  q.keepSide(0.02, true);
  EXPECT_EQ(q.layer.back(), 2);  // the wall down from (0, -0.02) to (0.05, 0) is layer 2
  q = p;
  q.keepSide(-0.09, true);  // nothing below
  EXPECT_TRUE(q.pts.empty());
  q = p;
  q.keepSide(0.09, true);  // all of it
  ASSERT_EQ(q.pts.size(), p.pts.size());
  for (size_t k = 0; k < p.pts.size(); ++k) EXPECT_EQ(q.pts[k].x, p.pts[k].x);
}

TEST(ScratchPath, BezierFlatteningErrorBound) {
  Vec2d c[4] = {{0, 0}, {10, 25}, {30, -20}, {40, 5}};
  for (double tol : {1e-1, 1e-2, 1e-3}) {
    ScratchPath p = ScratchPath::bezier({c[0], c[1], c[2], c[3]}, tol);
    double worst = 0;
    for (int i = 0; i <= 20000; ++i) worst = std::max(worst, polyDist(p.points(), cubicAt(c, i / 20000.0)));
    EXPECT_LE(worst, tol);
    EXPECT_GT(worst, 0.05 * tol);  // not absurdly over-refined
    // Vertices lie on the curve: the polyline's length is at most the curve's.
    double len = 0;
    Vec2d prev = c[0];
    for (int i = 1; i <= 100000; ++i) {
      Vec2d q = cubicAt(c, i / 100000.0);
      len += std::hypot(q.x - prev.x, q.y - prev.y);
      prev = q;
    }
    EXPECT_LE(p.length(), len + 1e-9);
    EXPECT_GT(p.length(), len * (1 - 1e-3));
  }
  EXPECT_THROW(ScratchPath::bezier({{0, 0}, {1, 1}, {2, 2}}), std::invalid_argument);
}

// Corners: a polyline's vertices that turn by 10 degrees or more, with their sides; the flattened
// curves of the scene's patterns (a cubic curve, an arc, wash swirls, a key scratch) have none.
TEST(ScratchPath, CornersAreTheVerticesThatTurn) {
  // Turns: 90 degrees left at (1, 0), 5.7 right at (1, 1), 113.3 right at (1.1, 2), 29.1 left at
  // (2, 1.5).
  ScratchPath z = ScratchPath::polyline({{0, 0}, {1, 0}, {1, 1}, {1.1, 2}, {2, 1.5}, {3, 1.5}});
  const auto& cs = z.corners();
  ASSERT_EQ(cs.size(), 3u);
  EXPECT_EQ(cs[0].vertex, 1u);
  EXPECT_NEAR(cs[0].turn, M_PI / 2, 1e-12);
  EXPECT_NEAR(cs[0].s, 1.0, 1e-12);
  EXPECT_NEAR(cs[0].t_in.x, 1, 1e-12);
  EXPECT_NEAR(cs[0].t_out.y, 1, 1e-12);
  EXPECT_EQ(cs[1].vertex, 3u);
  EXPECT_NEAR(cs[1].turn, -(std::atan2(1, 0.1) + std::atan2(0.5, 0.9)), 1e-12);
  EXPECT_EQ(cs[2].vertex, 4u);
  EXPECT_NEAR(cs[2].turn, std::atan2(0.5, 0.9), 1e-12);
  // Below 10 degrees: none.
  EXPECT_TRUE(ScratchPath::polyline({{0, 0}, {1, 0}, {2, 0.17}}).corners().empty());  // 9.6 degrees
  EXPECT_EQ(ScratchPath::polyline({{0, 0}, {1, 0}, {2, 0.18}}).corners().size(), 1u);  // 10.2
  // The nearest within reach.
  EXPECT_EQ(z.nearestCorner({1.1, 0.1}, 0.5), &cs[0]);
  EXPECT_EQ(z.nearestCorner({1.9, 1.6}, 0.5), &cs[2]);
  EXPECT_EQ(z.nearestCorner({1.1, 0.6}, 0.5), nullptr);
  // Around an arc position: the corners at the ends of its segment, whichever is nearer p. On the
  // first leg (s < 1) only the corner at its end; on the third (from (1.1, 2) to (2, 1.5)) the
  // corners at both ends, but not the first corner, however near p is to it.
  EXPECT_EQ(z.cornerAround(0.5, {1, 0.2}, 0.5), &cs[0]);
  EXPECT_EQ(z.cornerAround(0.5, {0, 0}, 0.5), nullptr);
  const double s3 = cs[1].s + 0.3;
  EXPECT_EQ(z.cornerAround(s3, {1.2, 1.9}, 2.0), &cs[1]);
  EXPECT_EQ(z.cornerAround(s3, {1.9, 1.6}, 2.0), &cs[2]);
  EXPECT_EQ(z.cornerAround(s3, {0.9, 0.9}, 5.0), &cs[1]);  // cs[0] is nearer, but not next to s3
  EXPECT_EQ(z.cornerAround(cs[2].s, {2, 1.5}, 0.1), &cs[2]);
  EXPECT_EQ(z.nearestCorner({5, 5}, 0.5), nullptr);
  // Flattened curves.
  EXPECT_TRUE(ScratchPath::bezier({{0, 0}, {10, 25}, {30, -20}, {40, 5}}, 1e-3).corners().empty());
  EXPECT_TRUE(ScratchPath::arc({0, 0}, 5, 0, 3, 1e-3).corners().empty());
  Rng r(7, Stream::Defect);
  EXPECT_TRUE(randomKeyScratch(r, box(0, 0, 400, 250)).corners().empty());
  SwirlOptions o;
  o.count = 10;
  for (const ScratchPath& a : randomWashSwirls(r, box(0, 0, 300, 200), o).arcs) EXPECT_TRUE(a.corners().empty());
}

TEST(ScratchPath, ArcLengthParameterisation) {
  ScratchPath p = ScratchPath::polyline({{0, 0}, {3, 4}, {3, 10}});
  EXPECT_DOUBLE_EQ(p.length(), 11.0);
  Vec2d q = p.pointAt(2.5);
  EXPECT_NEAR(q.x, 1.5, 1e-12);
  EXPECT_NEAR(q.y, 2.0, 1e-12);
  q = p.pointAt(8.0);
  EXPECT_NEAR(q.x, 3.0, 1e-12);
  EXPECT_NEAR(q.y, 7.0, 1e-12);
  Vec2d t = p.tangentAt(6.0);
  EXPECT_NEAR(t.y, 1.0, 1e-12);
  Box2 b = p.bounds();
  EXPECT_EQ(b.lo.x, 0.0f);
  EXPECT_EQ(b.hi.y, 10.0f);
  ScratchPath a = ScratchPath::arc({0, 0}, 10, 0, kPi, 1e-3);
  EXPECT_NEAR(a.length(), 10 * kPi, 10 * kPi * 1e-4);
  for (const Vec2d& v : a.points()) EXPECT_NEAR(std::hypot(v.x, v.y), 10.0, 1e-12);
}

TEST(ScratchPath, ClosestPointAgainstBruteForce) {
  ScratchPath p = ScratchPath::bezier({{5, 5}, {20, 40}, {40, -20}, {60, 20}, {70, 40}, {40, 50}, {30, 30}}, 1e-3);
  ASSERT_GT(p.points().size(), 20u);  // the segment grid is in use
  // Dense samples of the path by arc length (double).
  const int N = 200000;
  std::vector<Vec2d> samp(N + 1);
  for (int i = 0; i <= N; ++i) samp[size_t(i)] = p.pointAt(p.length() * i / N);
  const double spacing = p.length() / N;
  Rng rng(7, Stream::Test);
  for (int k = 0; k < 300; ++k) {
    Vec2d q{-5 + 85 * rng.uniformD(), -15 + 75 * rng.uniformD()};
    double best = 1e300, best_s = 0;
    for (int i = 0; i <= N; ++i) {
      double d = std::hypot(samp[size_t(i)].x - q.x, samp[size_t(i)].y - q.y);
      if (d < best) {
        best = d;
        best_s = p.length() * i / N;
      }
    }
    PathPoint c = p.closest(Vec2f{float(q.x), float(q.y)});
    ASSERT_TRUE(c.found);
    EXPECT_LE(c.distance, best + 1e-4);
    EXPECT_GE(c.distance, best - spacing - 1e-4);
    // The reported point is the path at s, and its distance is the reported one.
    Vec2d at = p.pointAt(c.s);
    EXPECT_NEAR(at.x, c.point.x, 2e-4);
    EXPECT_NEAR(at.y, c.point.y, 2e-4);
    if (best > 0.5) {
      // Away from the medial axis ties, the arc position agrees too.
      bool unique = true;
      for (int i = 0; i <= N && unique; i += 50)
        if (std::fabs(p.length() * i / N - best_s) > 2.0 &&
            std::hypot(samp[size_t(i)].x - q.x, samp[size_t(i)].y - q.y) < best + 0.05)
          unique = false;
      if (unique) {
        EXPECT_NEAR(c.s, best_s, 1e-2);
      }
    }
    // Side: B = (-T.y, T.x) is the left normal.
    if (c.beyond == 0 && c.distance > 1e-3) {
      double cr = c.tangent.x * (q.y - c.point.y) - c.tangent.y * (q.x - c.point.x);
      EXPECT_EQ(c.side(), cr > 0 ? 1 : -1);
      EXPECT_NEAR(std::fabs(c.offset), c.distance, 1e-5);
    }
    // The grid-accelerated bounded query agrees with the exhaustive one.
    PathPoint g = p.closest(Vec2f{float(q.x), float(q.y)}, 3.0f);
    EXPECT_EQ(g.found, c.distance <= 3.0f);
    if (g.found) {
      EXPECT_EQ(g.distance, c.distance);
      EXPECT_EQ(g.s, c.s);
    }
  }
}

// A path that goes exactly back over itself: its two passes are as near every point beside them,
// and the closest point is on the earlier (the lower segment), not on whichever pass's distance
// rounds lower. The explicit geometry takes its cross-sections from it: with a tilted tool's
// asymmetric profile the rounding made its surface a random mix of the two passes'.
TEST(ScratchPath, ATieBetweenPassesOnOneLineGoesToTheEarlier) {
  for (double scale : {1.0, 300.0}) {  // (coordinates of a small part, and of a door's)
    const Vec2d a = Vec2d(0.31, 0.77) * scale, b = a + Vec2d(2.9, 1.7);
    const ScratchPath p = ScratchPath::polyline({a, b, a});
    const ScratchPath longer = ScratchPath::polyline({a - Vec2d(0.1, 0.3), a, b, a});  // (many segments before)
    Rng rng(11, Stream::Test);
    int later = 0, later_longer = 0;
    const int n = 2000;
    for (int k = 0; k < n; ++k) {
      const double u = 0.05 + 0.9 * rng.uniformD(), v = 0.2 * (rng.uniformD() - 0.5);
      const Vec2d t = (b - a) * (1 / std::hypot(b.x - a.x, b.y - a.y)), q = a + (b - a) * u + Vec2d(-t.y, t.x) * v;
      const Vec2f qf(float(q.x), float(q.y));
      const PathPoint c = p.closest(qf), g = p.closest(qf, 1.0f);
      ASSERT_TRUE(c.found && g.found);
      later += c.s > p.length() / 2 || g.s > p.length() / 2;
      later_longer += longer.closest(qf, 1.0f).s > longer.length() / 2 + 0.16;
    }
    EXPECT_EQ(later, 0) << "of " << n << " points beside the path, scale " << scale;
    EXPECT_EQ(later_longer, 0) << "of " << n << " points beside the path, scale " << scale;
  }
}

// A path typed back along its own line with rounded coordinates (the retraces fuzzer's four
// decimals) is 1e-6 to 1e-4 rad off that line: its vertex is put on it, so that its passes tie as
// an exact retrace does; farther off, or on along the line, the path is left as given.
TEST(ScratchPath, APathBackNearlyAlongItsLineIsPutOnIt) {
  auto round4 = [](Vec2d q) { return Vec2d(std::round(q.x * 1e4) / 1e4, std::round(q.y * 1e4) / 1e4); };
  auto offLine = [](Vec2d a, Vec2d b, Vec2d e) {
    const Vec2d d = b - a;
    return std::fabs(d.x * (e.y - a.y) - d.y * (e.x - a.x)) / std::hypot(d.x, d.y);
  };
  Rng rng(38, Stream::Test);
  int snapped = 0, later = 0;
  const int layouts = 40;
  for (int k = 0; k < layouts; ++k) {
    const double ang = 2 * M_PI * rng.uniformD(), c = std::cos(ang), s = std::sin(ang);
    const Vec2d o(10 + rng.uniformD(), 10 + rng.uniformD());  // (a 20 mm plate's chart)
    auto at = [&](double x) { return round4(o + Vec2d(c * x, s * x)); };
    // (Half of them back a short way: a leg of 0.03 to 0.33 mm, whose float direction is a few
    // 1e-6 rad off the line however exactly its double points lie on it.)
    const double turn = 0.2 + 1.3 * rng.uniformD();
    const double back = k % 2 ? turn - 0.03 - 0.3 * rng.uniformD() : -4 * rng.uniformD();
    const Vec2d a = at(-5), b = at(turn), e = at(back);
    const ScratchPath p = ScratchPath::polyline({a, b, e});
    const Vec2d e2 = p.points()[2];
    ASSERT_EQ(p.points()[0].x, a.x);  // (the first leg stays as given)
    ASSERT_EQ(p.points()[1].y, b.y);
    EXPECT_LE(std::hypot(e2.x - e.x, e2.y - e.y), ScratchPath::kRetraceSnap);
    EXPECT_LE(offLine(a, b, e2), 1e-14) << "layout " << k;
    snapped += e2.x != e.x || e2.y != e.y;
    // Every point beside the way back now takes the earlier pass, as on an exact retrace.
    const Vec2d t = (b - a) * (1 / std::hypot(b.x - a.x, b.y - a.y));
    const double s_turn = p.arcLengths()[1];
    for (int j = 0; j < 50; ++j) {
      const double u = back + (turn - back) * (0.05 + 0.9 * rng.uniformD()), v = 0.2 * (rng.uniformD() - 0.5);
      const Vec2d q = o + Vec2d(c * u, s * u) + Vec2d(-t.y, t.x) * v;
      later += p.closest(Vec2f(float(q.x), float(q.y)), 1.0f).s > s_turn;
    }
  }
  EXPECT_GE(snapped, layouts / 2);  // (most rounded layouts are off their line)
  EXPECT_EQ(later, 0) << "of " << layouts * 50 << " points beside the ways back";
  // Farther off than kRetraceSnap: a path that comes back beside its line, as given.
  const ScratchPath apart = ScratchPath::polyline({{10, 10}, {13, 11}, {11.5, 10.5 + 3e-4}});
  EXPECT_EQ(apart.points()[2].y, 10.5 + 3e-4);
  // On along its line (a straight path in rounded pieces), not back: as given.
  const ScratchPath on = ScratchPath::polyline({{10, 10}, {13, 11.0001}, {16, 12.0001}});
  EXPECT_EQ(on.points()[2].y, 12.0001);
  // Back and forth twice: the second turn is put on the line too.
  const ScratchPath twice = ScratchPath::polyline({round4({10, 10}), round4({13.33333, 11.11111}),
                                                  round4({11.11111, 10.37037}), round4({12.9, 10.966667}),
                                                  round4({10, 10})});
  for (size_t i = 2; i < 5; ++i)
    EXPECT_LE(offLine(twice.points()[0], twice.points()[1], twice.points()[i]), 1e-14) << "vertex " << i;
  // A jog of 10 nm across the line and 1e-16 back along it is not a way back: left as given (put
  // on the line, it would leave a segment of no length).
  const ScratchPath jog = ScratchPath::polyline({{0, 0}, {1, 0}, {0.9999999999999999, 1e-5}, {0.5, 0}});
  EXPECT_EQ(jog.points()[2].y, 1e-5);
  for (size_t i = 1; i < jog.points().size(); ++i)
    EXPECT_GT(jog.arcLengths()[i], jog.arcLengths()[i - 1]) << "segment " << i;
}

// A path that passes a point more than once has one branch per pass: a hairpin, a loop that
// crosses itself, and a long curve against dense samples of it.
TEST(ScratchPath, BranchesAreThePassesNearAPoint) {
  std::vector<PathPoint> b;
  // A hairpin: out along y = 1, round at x = 5, back along y = -1.
  const ScratchPath hairpin = ScratchPath::polyline({{-5, 1}, {5, 1}, {5, -1}, {-5, -1}});
  hairpin.closestBranches({0, 0}, 1.5f, b);
  ASSERT_EQ(b.size(), 2u);
  EXPECT_NEAR(b[0].s, 5, 1e-5);  // a tie: the lower segment first, as closest has it
  EXPECT_NEAR(b[1].s, 17, 1e-5);
  EXPECT_NEAR(b[1].tangent.x, -1, 1e-6);
  EXPECT_NEAR(b[1].offset, -1, 1e-6);  // (0, 0) is right of the way back
  EXPECT_EQ(b[0].s, hairpin.closest({0, 0}, 1.5f).s);
  hairpin.closestBranches({0, 0}, 6.0f, b);  // the turn within reach too: one pass
  EXPECT_EQ(b.size(), 1u);
  hairpin.closestBranches({0, 0}, 0.5f, b);
  EXPECT_TRUE(b.empty());
  // A loop that crosses itself at the origin: the nearer pass first.
  const ScratchPath loop = ScratchPath::polyline({{-4, -3}, {4, 3}, {4, -3}, {-4, 3}});
  loop.closestBranches({0.1f, -0.01f}, 0.5f, b);
  ASSERT_EQ(b.size(), 2u);
  EXPECT_NEAR(b[0].tangent.x, -0.8, 1e-6);  // the way back, y = -0.75 x: 0.052 away
  EXPECT_NEAR(b[0].distance, 0.052, 1e-6);
  EXPECT_NEAR(b[1].tangent.x, 0.8, 1e-6);  // the way out, y = 0.75 x: 0.068
  EXPECT_NEAR(b[1].distance, 0.068, 1e-6);
  EXPECT_NEAR(b[1].s, 5.0 + 0.8 * 0.1 + 0.6 * -0.01, 1e-5);
  // A curve (the segment grid in use): the first branch is closest's, every branch is the
  // nearest point of a run of the path within reach, and there are as many as dense samples show.
  const ScratchPath p =
      ScratchPath::bezier({{5, 5}, {20, 40}, {40, -20}, {60, 20}, {70, 40}, {40, 50}, {30, 30}}, 1e-3);
  const int N = 100000;
  std::vector<double> d(N + 1);
  Rng rng(11, Stream::Test);
  int several = 0;
  for (int k = 0; k < 300; ++k) {
    // Within reach of a random point of the path.
    const float r = 3.0f + 17.0f * float(rng.uniformD());
    const double ang = 2 * M_PI * rng.uniformD(), off = double(r) * rng.uniformD();
    const Vec2d q = p.pointAt(p.length() * rng.uniformD()) + Vec2d(std::cos(ang), std::sin(ang)) * off;
    for (int i = 0; i <= N; ++i) {
      const Vec2d a = p.pointAt(p.length() * i / N);
      d[size_t(i)] = std::hypot(a.x - q.x, a.y - q.y);
    }
    auto runs = [&](double reach) {
      int n = 0;
      for (int i = 0; i <= N; ++i) n += d[size_t(i)] <= reach && (i == 0 || d[size_t(i - 1)] > reach);
      return n;
    };
    p.closestBranches(Vec2f(float(q.x), float(q.y)), r, b);
    const PathPoint c = p.closest(Vec2f(float(q.x), float(q.y)), r);
    ASSERT_EQ(b.empty(), !c.found);
    if (b.empty()) continue;
    EXPECT_EQ(b[0].s, c.s);
    EXPECT_EQ(b[0].distance, c.distance);
    EXPECT_EQ(b[0].offset, c.offset);
    const int lo = runs(r - 1e-2), hi = runs(r + 1e-2);
    EXPECT_GE(int(b.size()), std::min(lo, hi)) << k;
    EXPECT_LE(int(b.size()), std::max(lo, hi)) << k;
    several += b.size() > 1;
    for (size_t j = 1; j < b.size(); ++j) {
      EXPECT_GE(b[j].distance, b[0].distance);
      EXPECT_LE(b[j].distance, r);
      // Its own run's nearest: no sample within 0.5 of it along the path is nearer.
      const int i0 = int(std::lround(b[j].s / p.length() * N));
      for (int i = std::max(0, i0 - 500); i <= std::min(N, i0 + 500); ++i)
        EXPECT_GE(d[size_t(i)], b[j].distance - 1e-3);
      if (j > 1) {
        EXPECT_GT(b[j].s, b[j - 1].s);
      }
    }
  }
  EXPECT_GE(several, 10);  // the curve folds back: 15 of these points see it more than once
}

// With a long reach a hairpin's turn is within it, and the two legs are one run of segments. The
// `rise` argument still tells them apart: a new branch where the path has gone away by more than
// that from the nearest point so far and come back by as much (a corner's inner side, where it
// goes away and back by less, stays one).
TEST(ScratchPath, ABranchAlsoEndsWhereThePathGoesAwayAndComesBack) {
  std::vector<PathPoint> b;
  const ScratchPath hairpin = ScratchPath::polyline({{-5, 1}, {5, 1}, {5, -1}, {-5, -1}});
  hairpin.closestBranches({0, 0}, 6.0f, b, 1.0f);  // out to the turn, 5.1 away, and back
  ASSERT_EQ(b.size(), 2u);
  EXPECT_NEAR(b[0].s, 5, 1e-5);
  EXPECT_NEAR(b[1].s, 17, 1e-5);
  EXPECT_EQ(b[0].s, hairpin.closest({0, 0}, 6.0f).s);
  hairpin.closestBranches({0, 0}, 6.0f, b, 4.5f);  // it rises by 4.1 only
  EXPECT_EQ(b.size(), 1u);
  hairpin.closestBranches({0, 0}, 6.0f, b);  // the default: runs alone
  EXPECT_EQ(b.size(), 1u);
  // A right angle: (-1, 1) is 1 from both legs and 1.41 from the vertex between them.
  const ScratchPath corner = ScratchPath::polyline({{-5, 0}, {0, 0}, {0, 5}});
  corner.closestBranches({-1, 1}, 3.0f, b, 0.3f);
  ASSERT_EQ(b.size(), 2u);
  EXPECT_NEAR(b[0].s, 4, 1e-5);
  EXPECT_NEAR(b[1].s, 6, 1e-5);
  corner.closestBranches({-1, 1}, 3.0f, b, 0.5f);
  EXPECT_EQ(b.size(), 1u);
  corner.closestBranches({-0.2f, 0.1f}, 3.0f, b, 0.3f);  // near the vertex: one
  EXPECT_EQ(b.size(), 1u);
  // A winding curve: each branch the nearest point of the path around it, and at least as many
  // as without `rise`.
  const ScratchPath p =
      ScratchPath::bezier({{5, 5}, {20, 40}, {40, -20}, {60, 20}, {70, 40}, {40, 50}, {30, 30}}, 1e-3);
  Rng rng(12, Stream::Test);
  std::vector<PathPoint> plain;
  int more = 0;
  for (int k = 0; k < 300; ++k) {
    const float r = 10.0f + 30.0f * float(rng.uniformD());
    const Vec2d q = p.pointAt(p.length() * rng.uniformD()) + Vec2d(rng.uniformD() - 0.5, rng.uniformD() - 0.5) * 20.0;
    const Vec2f qf(float(q.x), float(q.y));
    p.closestBranches(qf, r, b, 2.0f);
    p.closestBranches(qf, r, plain);
    ASSERT_GE(b.size(), plain.size()) << k;
    if (b.empty()) continue;
    EXPECT_EQ(b[0].s, plain[0].s);
    more += b.size() > plain.size();
    for (const PathPoint& x : b) {
      EXPECT_LE(x.distance, r);
      for (double ds : {-0.3, -0.05, 0.05, 0.3}) {
        const Vec2d a = p.pointAt(double(x.s) + ds);
        EXPECT_GE(std::hypot(a.x - q.x, a.y - q.y), double(x.distance) - 1e-3) << k;
      }
    }
  }
  EXPECT_GE(more, 10);
}

// Bends (ScratchPath::bendsAround) of an arc 0.3 mm in radius (flattened into 20 chords, each
// turn below a corner's): they keep the path within tol + growth * (distance from p) of their
// polyline, their window starts and ends beyond the reach, and they turn by the polyline's angle in
// all. With growth, fewer bends far from p. A straight line has none, and a polyline's corner is its
// one bend.
TEST(ScratchPath, BendsFollowACurveWithinTheTolerance) {
  const double r = 0.3;
  const ScratchPath arc = ScratchPath::arc({0, 0}, r, 0, M_PI);
  ASSERT_TRUE(arc.corners().empty());
  const Vec2d p(0, 0.35);
  const double s = double(arc.closest(Vec2f(0.0f, 0.35f)).s);
  std::vector<ScratchPath::Corner> bends;
  std::pair<double, double> span;
  for (const double growth : {0.0, 0.05}) {
    const double tol = 1e-3;
    ASSERT_TRUE(arc.bendsAround(s, p, 0.2, tol, growth, 0.0, 16, M_PI, bends, span)) << growth;
    ASSERT_GE(bends.size(), 2u);
    EXPECT_LE(bends.size(), 16u);
    // The window: around s, beyond the reach at both ends.
    EXPECT_LT(span.first, s);
    EXPECT_GT(span.second, s);
    EXPECT_GT(std::hypot(arc.pointAt(span.first).x - p.x, arc.pointAt(span.first).y - p.y), 0.2);
    EXPECT_GT(std::hypot(arc.pointAt(span.second).x - p.x, arc.pointAt(span.second).y - p.y), 0.2);
    std::vector<Vec2d> poly{arc.pointAt(span.first)};
    double turn = 0;
    for (size_t k = 0; k < bends.size(); ++k) {
      poly.push_back(bends[k].p);
      turn += bends[k].turn;
      if (k > 0) {
        EXPECT_GT(bends[k].s, bends[k - 1].s);
      }
      EXPECT_LT(std::hypot(bends[k].p.x - arc.pointAt(bends[k].s).x, bends[k].p.y - arc.pointAt(bends[k].s).y), 1e-12);
    }
    poly.push_back(arc.pointAt(span.second));
    // Every point of the flattened arc in the window within the allowance of the bends' polyline.
    for (int k = 0; k <= 400; ++k) {
      const Vec2d q = arc.pointAt(span.first + (span.second - span.first) * k / 400);
      double best = 1e30;
      for (size_t j = 0; j + 1 < poly.size(); ++j) {
        const Vec2d a = poly[j], d = poly[j + 1] - a;
        const double t = std::clamp(((q.x - a.x) * d.x + (q.y - a.y) * d.y) / (d.x * d.x + d.y * d.y), 0.0, 1.0);
        best = std::min(best, std::hypot(q.x - a.x - d.x * t, q.y - a.y - d.y * t));
      }
      EXPECT_LE(best, tol + growth * std::hypot(q.x - p.x, q.y - p.y) + 1e-12) << growth << ", " << k;
    }
    // The turns add up to the turn from the window's first leg to its last: to the left.
    const Vec2d t0 = bends.front().t_in, t1 = bends.back().t_out;
    EXPECT_NEAR(turn, std::atan2(t0.x * t1.y - t0.y * t1.x, t0.x * t1.x + t0.y * t1.y), 1e-9);
    EXPECT_GT(turn, 0);
    std::printf("[          ] growth %.2f: %zu bends\n", growth, bends.size());
    EXPECT_EQ(bends.size(), growth > 0 ? 3u : 7u);
  }
  // At most 3 bends: the tolerance doubles until they fit.
  ASSERT_TRUE(arc.bendsAround(s, p, 0.2, 1e-3, 0.0, 0.0, 3, M_PI, bends, span));
  EXPECT_LE(bends.size(), 3u);
  // A straight line (its middle vertex on the line) has none, and a polyline's corner is its bend.
  const ScratchPath line = ScratchPath::polyline({{-1, 0}, {-0.5, 0.0}, {1, 0}});
  EXPECT_FALSE(line.bendsAround(0.9, {-0.1, 0.05}, 0.5, 1e-6, 0.0, 0.0, 12, M_PI, bends, span));
  EXPECT_TRUE(bends.empty());
  const ScratchPath corner = ScratchPath::polyline({{-1, 0}, {0, 0}, {0, 1}});
  ASSERT_TRUE(corner.bendsAround(0.9, {-0.1, 0.05}, 0.5, 1e-3, 0.03, 0.0, 12, M_PI, bends, span));
  ASSERT_EQ(bends.size(), 1u);
  EXPECT_EQ(bends[0].vertex, corner.corners()[0].vertex);
  EXPECT_EQ(bends[0].turn, corner.corners()[0].turn);
  EXPECT_EQ(span.first, 0.0);
  EXPECT_EQ(span.second, corner.length());
}

// A cubic followed by its own reverse flattens into the same points both ways, so the explicit
// geometry has its two passes on one line and keeps the earlier (ScratchPath::closest). The bends
// around its tip must be the same points on the way out and on the way back, the tip among them:
// Douglas-Peucker alone split the window (from a point back to that point) at the first of each
// vertex and its mirror image, so the legs of the two passes crossed at small angles (the retraces
// fuzzer's r2_4, a tilted tool's mirrored cross-section in wedges along the groove). Footprints
// beside the path on the way out, at the integrator's tolerances (kBendTol, kBendGrowth, kBendDev)
// for footprints 0.003 to 0.03 mm across.
TEST(ScratchPath, BendsOfAPathBackOverItselfAreTheSameBothWays) {
  const ScratchPath path = ScratchPath::bezier({{-0.0541, -5.1308}, {-1.3195, 0.4285}, {2.5053, -2.0842},
                                                {-0.1620, 0.6576}, {2.5053, -2.0842}, {-1.3195, 0.4285},
                                                {-0.0541, -5.1308}});
  const double tip = 0.5 * path.length();
  // The flattened path is its own mirror image about the tip.
  const size_t n = path.points().size();
  ASSERT_EQ(n % 2, 1u);
  for (size_t i = 0; i < n; ++i) {
    ASSERT_EQ(path.points()[i].x, path.points()[n - 1 - i].x) << i;
    ASSERT_EQ(path.points()[i].y, path.points()[n - 1 - i].y) << i;
  }
  std::vector<ScratchPath::Corner> bends;
  std::pair<double, double> span;
  int checked = 0;
  for (const double fp : {0.003, 0.01, 0.03}) {
    for (const double reach : {0.2, 0.4, 0.8}) {
      for (const double back : {0.02, 0.05, 0.1, 0.2, 0.35, 0.6}) {
        for (const double side : {-0.04, 0.0, 0.03}) {
          const double s = tip - back;
          const Vec2d t = path.tangentAt(s), p = path.pointAt(s) + Vec2d(-t.y, t.x) * side;
          // (A window that ends short of the tip holds one pass.)
          if (!path.bendsAround(s, p, reach, 0.05 * fp, 0.03, 0.0, 16, M_PI / 180, bends, span) ||
              !(span.second > tip))
            continue;
          ++checked;
          std::ostringstream where;
          where << "footprint " << fp << ", reach " << reach << ", " << back << " before the tip, " << side << " aside";
          // The tip is a bend, and every bend on the way out has its mirror image on the way back,
          // its legs on the same lines.
          size_t at_tip = 0, out = 0, in = 0;
          for (const ScratchPath::Corner& c : bends) {
            if (c.vertex == n / 2) {
              ++at_tip;
              continue;
            }
            (c.vertex < n / 2 ? out : in) += 1;
            bool mirrored = false;
            for (const ScratchPath::Corner& d : bends)
              mirrored = mirrored || (d.vertex == n - 1 - c.vertex && d.p.x == c.p.x && d.p.y == c.p.y &&
                                      std::fabs(d.t_in.x + c.t_out.x) + std::fabs(d.t_in.y + c.t_out.y) < 1e-12);
            EXPECT_TRUE(mirrored) << where.str() << ": vertex " << c.vertex << " of " << n;
          }
          EXPECT_EQ(at_tip, 1u) << where.str();
          EXPECT_EQ(out, in) << where.str();
        }
      }
    }
  }
  // (Without keepRetracesAlike, 21 of the 129 windows differ.)
  std::printf("[          ] %d windows over the tip\n", checked);
  EXPECT_GE(checked, 100);
}

// The leg over p's own segment takes the path's direction there where the simplified chord turns
// from it by more than max_dev (a wall's glint moves along a curve with its direction; the
// accuracy test's `loop` under the bar): that segment's two ends are bends too. And past
// max_bends the growth doubles, not the tolerance, so the path near p stays within tol.
TEST(ScratchPath, BendsKeepTheDirectionAtTheFootprint) {
  const ScratchPath arc = ScratchPath::arc({0, 0}, 0.3, 0, M_PI, 1e-5);
  const Vec2d p(0.1, 0.33);
  const double s = double(arc.closest(Vec2f(0.1f, 0.33f)).s);
  std::vector<ScratchPath::Corner> bends;
  std::pair<double, double> span;
  // The direction of the bends' leg that holds s against the path's own segment there.
  auto deviation = [&] {
    Vec2d t = bends.front().t_in;
    for (const ScratchPath::Corner& c : bends)
      if (c.s <= s) t = c.t_out;
    const Vec2d u = arc.tangentAt(s);
    return std::fabs(std::atan2(t.x * u.y - t.y * u.x, t.x * u.x + t.y * u.y));
  };
  const double tol = 4e-3, dev = M_PI / 180;
  ASSERT_TRUE(arc.bendsAround(s, p, 0.2, tol, 0.0, 0.0, 16, M_PI, bends, span));
  const double loose = deviation();
  const size_t n_loose = bends.size();
  ASSERT_TRUE(arc.bendsAround(s, p, 0.2, tol, 0.0, 0.0, 16, dev, bends, span));
  std::printf("[          ] leg at p off the path by %.2f deg with %zu bends, %.2g deg with %zu\n",
              loose * 180 / M_PI, n_loose, deviation() * 180 / M_PI, bends.size());
  EXPECT_GT(loose, dev);
  EXPECT_LT(deviation(), 1e-9);
  EXPECT_GE(bends.size(), n_loose + 1);
  EXPECT_LE(bends.size(), n_loose + 2);
  // Past max_bends the growth doubles, not the tolerance: at p itself, a vertex of the path near
  // its end (an uneven window), the bends' polyline stays within tol (doubling the tolerance
  // instead left it 0.0027 away, 27 times tol).
  std::vector<Vec2d> ring;
  for (int k = 0; k <= 200; ++k) ring.push_back({0.3 * std::cos(M_PI * k / 200), 0.3 * std::sin(M_PI * k / 200)});
  const ScratchPath poly_arc = ScratchPath::polyline(ring);
  const Vec2d on = ring[175];
  const double s_on = poly_arc.length() * 175 / 200;
  ASSERT_TRUE(poly_arc.bendsAround(s_on, on, 0.2, 1e-4, 0.005, 0.0, 4, M_PI, bends, span));
  EXPECT_LE(bends.size(), 4u);
  std::vector<Vec2d> poly{poly_arc.pointAt(span.first)};
  for (const ScratchPath::Corner& c : bends) poly.push_back(c.p);
  poly.push_back(poly_arc.pointAt(span.second));
  double best = 1e30;
  for (size_t j = 0; j + 1 < poly.size(); ++j) {
    const Vec2d a = poly[j], d = poly[j + 1] - a;
    const double t = std::clamp(((on.x - a.x) * d.x + (on.y - a.y) * d.y) / (d.x * d.x + d.y * d.y), 0.0, 1.0);
    best = std::min(best, std::hypot(on.x - a.x - d.x * t, on.y - a.y - d.y * t));
  }
  std::printf("[          ] %zu bends, %.2g from p\n", bends.size(), best);
  EXPECT_LE(best, 1e-4);
}

// With `near`, every segment within near of p (beyond the closest one's distance) is held by a
// leg of its own direction, not only the closest point's: inside a tight curl a footprint sees
// the walls of the legs beside its own, and a chord over several of them turned the border
// between two legs' walls (the passes fuzzer's p75_0; docs/grooves.md, "Bends"). A curl of radius
// 0.11 mm in sixteen segments of 14 um (7.3 degrees each), seen from 0.06 mm inside it, with the
// integrator's tolerances at a footprint radius of 11 um.
TEST(ScratchPath, BendsKeepTheDirectionOfTheSegmentsNearTheFootprint) {
  const double r = 0.11, step = 2 * std::asin(0.007 / r);
  std::vector<Vec2d> curl;
  for (int k = 0; k <= 16; ++k) curl.push_back({r * std::cos(step * (k - 8)), r * std::sin(step * (k - 8))});
  const ScratchPath path = ScratchPath::polyline(curl);
  // p 0.06 mm in from the curl, a third of the way along the segment after vertex 8.
  const Vec2d c8 = curl[8], c9 = curl[9];
  const Vec2d on = c8 + (c9 - c8) * (1.0 / 3);
  const Vec2d p = on * ((r - 0.06) / std::hypot(on.x, on.y));
  const PathPoint pp = path.closest(Vec2f(float(p.x), float(p.y)));
  const double s = double(pp.s), fp = 0.011, dev = M_PI / 180, near = 2 * fp;
  ASSERT_EQ(pp.seg, 8);
  std::vector<ScratchPath::Corner> bends;
  std::pair<double, double> span;
  // The largest turn between a segment within near of p (beyond the closest one's distance) and
  // the bends' leg that holds it.
  const double d_seg = double(pp.distance);
  auto worst = [&] {
    double w = 0;
    for (size_t j = 0; j + 1 < curl.size(); ++j) {
      const Vec2d a = curl[j], d = curl[j + 1] - a;
      const double t = std::clamp(((p.x - a.x) * d.x + (p.y - a.y) * d.y) / (d.x * d.x + d.y * d.y), 0.0, 1.0);
      if (!(std::hypot(p.x - a.x - d.x * t, p.y - a.y - d.y * t) <= d_seg + near)) continue;
      if (!(path.arcLengths()[j] >= span.first && path.arcLengths()[j + 1] <= span.second)) continue;
      // The leg: from the last bend at or before vertex j to the first at or after j + 1.
      Vec2d from = path.pointAt(span.first), to = path.pointAt(span.second);
      for (const ScratchPath::Corner& c : bends) {
        if (c.vertex <= j) from = c.p;
        if (c.vertex >= j + 1) {
          to = c.p;
          break;
        }
      }
      const Vec2d l = to - from;
      w = std::max(w, std::fabs(std::atan2(l.x * d.y - l.y * d.x, l.x * d.x + l.y * d.y)));
    }
    return w;
  };
  ASSERT_TRUE(path.bendsAround(s, p, 0.2, 0.05 * fp, 0.03, 0.0, 16, dev, bends, span));
  const double before = worst();
  const size_t n_before = bends.size();
  ASSERT_TRUE(path.bendsAround(s, p, 0.2, 0.05 * fp, 0.03, 0.0, 16, dev, bends, span, near));
  std::printf("[          ] segments near p off their legs by %.2f deg with %zu bends, %.2g deg with %zu\n",
              before * 180 / M_PI, n_before, worst() * 180 / M_PI, bends.size());
  EXPECT_GT(before, dev);
  EXPECT_LT(worst(), 1e-9);
  EXPECT_GT(bends.size(), n_before);
  EXPECT_LE(bends.size(), 16u);
  // Where holding them all would take more than max_bends (and max_near), only the closest
  // point's segment is held, as without `near`.
  std::vector<ScratchPath::Corner> few, plain;
  ASSERT_TRUE(path.bendsAround(s, p, 0.2, 0.05 * fp, 0.03, 0.0, n_before, dev, plain, span));
  ASSERT_TRUE(path.bendsAround(s, p, 0.2, 0.05 * fp, 0.03, 0.0, n_before, dev, few, span, near));
  ASSERT_EQ(few.size(), plain.size());
  for (size_t k = 0; k < few.size(); ++k) EXPECT_EQ(few[k].vertex, plain[k].vertex);
  ASSERT_TRUE(path.bendsAround(s, p, 0.2, 0.05 * fp, 0.03, 0.0, n_before, dev, few, span, near, n_before));
  ASSERT_EQ(few.size(), plain.size());
  // max_near above that holds them all, with the simplification's own bends (max_bends) as they
  // were: the same bends as with max_bends 16.
  ASSERT_TRUE(path.bendsAround(s, p, 0.2, 0.05 * fp, 0.03, 0.0, n_before, dev, bends, span, near, 16));
  EXPECT_LT(worst(), 1e-9);
  ASSERT_TRUE(path.bendsAround(s, p, 0.2, 0.05 * fp, 0.03, 0.0, 16, dev, few, span, near));
  ASSERT_EQ(few.size(), bends.size());
  for (size_t k = 0; k < few.size(); ++k) EXPECT_EQ(few[k].vertex, bends[k].vertex);
}

TEST(ScratchPath, SideAndEnds) {
  ScratchPath p = ScratchPath::polyline({{0, 0}, {10, 0}, {10, 10}});  // right, then up (left turn)
  PathPoint a = p.closest({5, 1});
  EXPECT_EQ(a.side(), 1);
  EXPECT_NEAR(a.offset, 1.0f, 1e-6);
  EXPECT_NEAR(a.s, 5.0f, 1e-6);
  PathPoint b = p.closest({5, -2});
  EXPECT_NEAR(b.offset, -2.0f, 1e-6);
  // Outer wedge of the corner: right of the path.
  PathPoint c = p.closest({12, -2});
  EXPECT_NEAR(c.s, 10.0f, 1e-6);
  EXPECT_EQ(c.side(), -1);
  EXPECT_NEAR(c.distance, std::sqrt(8.0f), 1e-5);
  // Before the start, past the end.
  PathPoint d = p.closest({-3, 0.5f});
  EXPECT_NEAR(d.beyond, 3.0f, 1e-6);
  EXPECT_NEAR(d.offset, 0.5f, 1e-6);
  PathPoint e = p.closest({9, 12});
  EXPECT_NEAR(e.beyond, 2.0f, 1e-6);
  EXPECT_NEAR(e.offset, 1.0f, 1e-6);  // left of an upward path is -u
  EXPECT_EQ(p.closest({5, 1}).beyond, 0.0f);
  // Bounded queries: nothing within the radius, and far-away points.
  ScratchPath arc = ScratchPath::arc({0, 0}, 50, 0, 2, 1e-3);
  EXPECT_FALSE(arc.closest({0, 0}, 10).found);
  EXPECT_FALSE(arc.closest({1e30f, -1e30f}, 10).found);
  EXPECT_TRUE(arc.closest({0, 0}, 50.01f).found);
  EXPECT_NEAR(arc.closest({0, 0}, 50.01f).distance, 50.0f, 1e-3);
}

// ---- variation along the path -----------------------------------------------------------------

TEST(ScratchAlong, FadeMonotoneAndZeroAtEnds) {
  EXPECT_EQ(scratchFade(0, 10, 2), 0.0);
  EXPECT_EQ(scratchFade(10, 10, 2), 0.0);
  EXPECT_EQ(scratchFade(5, 10, 2), 1.0);
  EXPECT_NEAR(scratchFade(1, 10, 2), 0.5, 1e-15);
  ScratchPath path = ScratchPath::polyline({{0, 0}, {30, 0}});
  ScratchPerturbation pert;
  pert.fade_length_mm = 4;
  Scratch proc = Scratch::fromProcess(path, {cone(120), 1.0, 100.0, 1.0}, pert);
  Scratch expl = Scratch::fromProfile(path, Profile::fromPolyline({{-0.1, 0}, {0, -0.02}, {0.1, 0}}), pert);
  for (const Scratch* s : {&proc, &expl}) {
    EXPECT_EQ(s->scaleAt(0), 0.0f);
    EXPECT_EQ(s->scaleAt(30), 0.0f);
    EXPECT_NEAR(s->scaleAt(15), 1.0f, 1e-6);
    EXPECT_NEAR(s->maxScale(), 1.0f, 1e-6);
    float prev = 0;
    for (float x = 0; x <= 15; x += 0.01f) {
      float k = s->scaleAt(x);
      EXPECT_GE(k, prev - 1e-7f);
      EXPECT_NEAR(s->scaleAt(30 - x), k, 1e-5);  // symmetric
      prev = k;
    }
  }
  // The process scratch vanishes before its end: F/H below 4.17e-4 where g(u) < 0.0417.
  EXPECT_EQ(proc.scaleAt(0.3f), 0.0f);
  EXPECT_GT(expl.scaleAt(0.3f), 0.0f);
  // Depth and width follow the scale.
  Profile mid = proc.profileAt(15), q = proc.profileAt(2);
  EXPECT_NEAR(mid.depth(), scratchDepthMm(1, 100), 1e-7);
  EXPECT_NEAR(q.depth() / mid.depth(), proc.scaleAt(2), 1e-6);
  EXPECT_NEAR(q.depth(), scratchDepthMm(1.0 * 0.5, 100), 1e-7);  // g(0.5) = 0.5
  EXPECT_NEAR(q.width() / mid.width(), q.depth() / mid.depth(), 1e-6);
}

TEST(ScratchAlong, KeyedForceAndNoise) {
  ScratchPath path = ScratchPath::polyline({{0, 0}, {40, 0}});
  ScratchPerturbation pert;
  pert.force_keys = {{0.0, 0.5}, {0.5, 2.0}, {1.0, 1.0}};
  Scratch s = Scratch::fromProcess(path, {cone(120), 1.0, 100.0, 1.0}, pert);
  EXPECT_NEAR(s.profileAt(20).depth(), scratchDepthMm(2.0, 100), 1e-7);
  EXPECT_NEAR(s.profileAt(0).depth(), scratchDepthMm(0.5, 100), 1e-7);
  EXPECT_NEAR(s.profileAt(10).depth(), scratchDepthMm(1.25, 100), 1e-6);
  double prev = 0;
  for (double x = 0; x <= 20; x += 0.5) {  // monotone between keys
    double d = s.profileAt(x).depth();
    EXPECT_GE(d, prev);
    prev = d;
  }
  for (double x = 20.5; x <= 40; x += 0.5) {
    double d = s.profileAt(x).depth();
    EXPECT_LE(d, prev);
    prev = d;
  }
  // Noise: bounded by the amplitude, smooth, seeded.
  ScratchPerturbation np;
  np.noise_amplitude = 0.3;
  np.noise_wavelength_mm = 3;
  np.noise_seed = 11;
  Profile pr = Profile::fromPolyline({{-0.1, 0}, {0, -0.02}, {0.1, 0}});
  Scratch n1 = Scratch::fromProfile(path, pr, np), n2 = Scratch::fromProfile(path, pr, np);
  np.noise_seed = 12;
  Scratch n3 = Scratch::fromProfile(path, pr, np);
  double diff = 0, lo = 2, hi = 0;
  for (float x = 0; x <= 40; x += 0.05f) {
    float k = n1.scaleAt(x);
    EXPECT_EQ(k, n2.scaleAt(x));
    lo = std::min(lo, double(k));
    hi = std::max(hi, double(k));
    diff = std::max(diff, double(std::fabs(k - n3.scaleAt(x))));
  }
  EXPECT_GE(lo, 0.7 - 1e-6);
  EXPECT_LE(hi, 1.3 + 1e-6);
  EXPECT_GT(hi - lo, 0.1);
  EXPECT_GT(diff, 0.01);
}

// ---- the defect -------------------------------------------------------------------------------

TEST(ScratchDefect, MaskAreaOfStraightScratch) {
  const double L = 30, W = 0.4;
  Profile pr = Profile::fromPolyline({{-0.2, 0}, {-0.1, 0.01}, {0, -0.03}, {0.1, 0.01}, {0.2, 0}});
  ScratchPath path = ScratchPath::polyline({{10, 10}, {10 + L, 10}});
  Scratch blunt = Scratch::fromProfile(path, pr);
  EXPECT_EQ(blunt.cls(), DefectClass::Scratch);
  Box2 sup = blunt.support();
  EXPECT_NEAR(sup.lo.x, 9.8f, 1e-5);
  EXPECT_NEAR(sup.hi.y, 10.2f, 1e-5);
  const double step = 0.005;
  Box2 area = box(9, 9.5f, 41, 10.5f);
  // Blunt ends: L x W, up to the sampling of the boundary.
  EXPECT_NEAR(maskArea(blunt, area, step), L * W, 2 * (L + W) * step);
  // Faded ends: W * integral of the smoothstep = W (L - fade).
  ScratchPerturbation pert;
  pert.fade_length_mm = 3;
  Scratch faded = Scratch::fromProfile(path, pr, pert);
  EXPECT_NEAR(maskArea(faded, area, step), W * (L - 3), 2 * (L + W) * step);
  // Mask points are inside the support; the height is the profile's.
  EXPECT_TRUE(blunt.inMask({25, 10.19f}));
  EXPECT_FALSE(blunt.inMask({25, 10.21f}));
  EXPECT_FALSE(blunt.inMask({9.9f, 10}));
  EXPECT_NEAR(blunt.height({25, 10}), -0.03f, 1e-6);
  EXPECT_NEAR(blunt.height({25, 10.1f}), 0.01f, 1e-5);   // left peak (b = +0.1)
  EXPECT_NEAR(blunt.height({25, 9.95f}), -0.01f, 1e-5);  // b = -0.05: halfway up (-0.1, 0.01)
  EXPECT_EQ(blunt.height({25, 10.3f}), 0.0f);
  nlohmann::json j = faded.attributes();
  EXPECT_EQ(j["model"], "profile");
  EXPECT_NEAR(j["length_mm"].get<double>(), L, 1e-12);
  EXPECT_NEAR(j["width_mm"].get<double>(), W, 1e-6);
  EXPECT_NEAR(j["depth_mm"].get<double>(), 0.03, 1e-6);
}

// Through the bump interface a scratch adds its facet's slope only when asked: in normal-map mode,
// or for a path vertex past the camera hit (DefectQuery::point_grooves; the groove renderer
// integrates camera footprints itself).
TEST(ScratchDefect, SlopeThroughTheBumpInterfaceOnlyWhenAsked) {
  Profile pr = Profile::fromPolyline({{-0.2, 0}, {-0.1, 0.01}, {0, -0.03}, {0.1, 0.01}, {0.2, 0}});
  Scratch sc = Scratch::fromProfile(ScratchPath::polyline({{10, 10}, {40, 10}}), pr);
  auto grad = [&](Vec2f uv, bool point) {
    DefectQuery q;
    q.uv = uv;
    q.point_grooves = point;
    DefectShading ds;
    sc.shade(q, ds);
    return ds.height_grad + ds.grooveGrad();  // as the integrator's applyDefects sums them
  };
  // b = v - 10 (the path's left is +v); at b = -0.05 the facet from (-0.1, 0.01) to (0, -0.03)
  // falls 0.4 mm per mm.
  EXPECT_EQ(grad({25, 9.95f}, false).y, 0.0f);
  EXPECT_NEAR(grad({25, 9.95f}, true).x, 0.0f, 1e-6f);
  EXPECT_NEAR(grad({25, 9.95f}, true).y, -0.4f, 1e-4f);
  EXPECT_NEAR(grad({25, 10.05f}, true).y, 0.4f, 1e-4f);  // the other wall rises
  EXPECT_EQ(grad({25, 10.3f}, true).y, 0.0f);            // beside the scratch
  sc.setBumpShading(true);
  EXPECT_NEAR(grad({25, 9.95f}, false).y, -0.4f, 1e-4f);
}

// Where the force fades, the slope through the bump interface is the gradient of the height field
// along the path too, not only across it: against central differences of height() on a faded,
// oblique scratch (both components, on facets' interiors, on either side of the path).
TEST(ScratchDefect, BumpSlopeIsTheHeightGradientAlsoAlongAFade) {
  Profile pr = Profile::fromPolyline({{-0.2, 0}, {-0.1, 0.01}, {0, -0.03}, {0.1, 0.01}, {0.2, 0}});
  ScratchPerturbation pert;
  pert.fade_length_mm = 4;
  Scratch sc = Scratch::fromProfile(ScratchPath::polyline({{10, 10}, {34, 20}}), pr, pert);
  sc.setBumpShading(true);
  const Vec2f T = Vec2f(24, 10) / 26.0f, B(-T.y, T.x);
  int tilted = 0;
  for (double along : {0.7, 1.5, 2.5, 3.3, 12.0, 21.0, 23.2, 24.5}) {
    for (double b : {-0.15, -0.06, -0.03, 0.04, 0.08, 0.16}) {
      const Vec2f uv = Vec2f(10, 10) + T * float(along) + B * float(b * sc.scaleAt(float(along)));
      DefectQuery q;
      q.uv = uv;
      DefectShading ds;
      sc.shade(q, ds);
      const float e = 1e-3f;  // float UVs near 30 mm: a smaller step is rounding
      auto diff = [&](Vec2f d) { return (double(sc.height(uv + d * e)) - sc.height(uv - d * e)) / (2.0 * e); };
      const double g_along = diff(T), g_across = diff(B);
      SCOPED_TRACE(testing::Message() << "along " << along << " b " << b);
      EXPECT_NEAR(dot(ds.height_grad, T), g_along, 2e-3 + 0.01 * std::fabs(g_along));
      EXPECT_NEAR(dot(ds.height_grad, B), g_across, 2e-3 + 0.01 * std::fabs(g_across));
      tilted += std::fabs(g_along) > 2e-3;
    }
  }
  EXPECT_GE(tilted, 12);  // the fades' points do tilt along the path; the middle's do not
}

TEST(ScratchDefect, MaskAreaOfArcAndProcessAttributes) {
  ScratchPath arc = arcScratch({50, 50}, 20, 0.3, 0.05);  // radius 20, sweep 1 rad
  LayerStack paint{{{"clear", 0.02}, {"base", 0.015}, {"primer", 0.01}, {"steel", 0}}};
  Scratch s = Scratch::fromProcess(arc, {cone(120), 4.0, 60.0, 1.0}, {}, paint);
  double W = s.referenceProfile().width();
  Box2 sup = s.support();
  double A = maskArea(s, sup, 0.004);
  // Symmetric profile about a circular path: the band's area is exactly L x W.
  EXPECT_NEAR(A, 20 * W, 2 * 20 * 0.004 + 0.05 * 20 * W);
  nlohmann::json j = s.attributes();
  EXPECT_EQ(j["model"], "process");
  EXPECT_EQ(j["tool"]["shape"], "cone");
  EXPECT_NEAR(j["depth_mm"].get<double>(), scratchDepthMm(4, 60), 1e-6);
  EXPECT_EQ(j["deepest_layer"], "base");  // 34.9 µm: through the 20 µm clear coat, into the base
  EXPECT_NEAR(j["alpha_deg"][0].get<double>(), 30.0, 1e-5);
}

// ---- placement --------------------------------------------------------------------------------

TEST(ScratchPlacement, KeyScratchDeterministicAndInside) {
  Box2 region = box(0, 0, 400, 250);
  for (uint64_t seed : {1ull, 2ull, 3ull}) {
    Rng r1(seed, Stream::Defect), r2(seed, Stream::Defect);
    ScratchPath a = randomKeyScratch(r1, region), b = randomKeyScratch(r2, region);
    ASSERT_EQ(a.points().size(), b.points().size());
    for (size_t i = 0; i < a.points().size(); ++i) {
      EXPECT_EQ(a.points()[i].x, b.points()[i].x);
      EXPECT_EQ(a.points()[i].y, b.points()[i].y);
    }
    Box2 bb = a.bounds();
    EXPECT_GE(bb.lo.x, region.lo.x);
    EXPECT_LE(bb.hi.x, region.hi.x);
    EXPECT_GE(bb.lo.y, region.lo.y);
    EXPECT_LE(bb.hi.y, region.hi.y);
    double chord = std::hypot(a.points().back().x - a.points().front().x,
                              a.points().back().y - a.points().front().y);
    EXPECT_GT(a.length(), 0.2 * std::hypot(400.0, 250.0));  // long
    EXPECT_LT(a.length(), 1.1 * chord);                        // gently curved
  }
  Rng r1(1, Stream::Defect), r3(2, Stream::Defect);
  EXPECT_NE(randomKeyScratch(r1, region).points()[0].x, randomKeyScratch(r3, region).points()[0].x);
}

TEST(ScratchPlacement, WashSwirlsConcentricAndParallel) {
  Box2 region = box(0, 0, 300, 200);
  SwirlOptions o;
  o.count = 10;
  Rng r1(42, Stream::Defect), r2(42, Stream::Defect);
  SwirlSet a = randomWashSwirls(r1, region, o), b = randomWashSwirls(r2, region, o);
  ASSERT_EQ(a.arcs.size(), b.arcs.size());
  ASSERT_GE(a.arcs.size(), 5u);
  EXPECT_EQ(a.centre.x, b.centre.x);
  for (size_t i = 0; i < a.arcs.size(); ++i) {
    ASSERT_EQ(a.arcs[i].points().size(), b.arcs[i].points().size());
    EXPECT_EQ(a.arcs[i].points().back().y, b.arcs[i].points().back().y);
    // Every vertex on the circle about the common centre; inside the region.
    for (const Vec2d& v : a.arcs[i].points()) {
      EXPECT_NEAR(std::hypot(v.x - a.centre.x, v.y - a.centre.y), a.radii[i], 1e-9);
      EXPECT_TRUE(v.x >= 0 && v.x <= 300 && v.y >= 0 && v.y <= 200);
    }
    EXPECT_GE(a.arcs[i].length(), o.min_length_mm);
    // Parallel: radii increase, neighbours one spacing apart (within the jitter).
    if (i > 0) {
      double gap = a.radii[i] - a.radii[i - 1];
      EXPECT_GT(gap, 0.0);
      EXPECT_LT(gap, 2.0 * o.spacing_mm.hi * (1 + 2 * o.spacing_jitter));
    }
  }
  // A fixed centre is honoured; the distance to the centre is constant along an arc: the closest
  // point query of each arc from the centre returns its radius.
  o.fixed_centre = true;
  o.centre = {-20, -30};
  Rng r3(5, Stream::Defect);
  SwirlSet c = randomWashSwirls(r3, region, o);
  EXPECT_EQ(c.centre.x, -20.0);
  for (size_t i = 0; i < c.arcs.size(); ++i)
    EXPECT_NEAR(c.arcs[i].closest({-20, -30}).distance, c.radii[i], 1e-3 * c.radii[i]);
}

TEST(ScratchPlacement, GenericScratch) {
  Box2 region = box(10, 10, 110, 60);
  GenericScratchOptions o;
  o.length_mm = {10, 30};
  o.curvature = {0.01, 0.05};
  Rng r1(9, Stream::Defect), r2(9, Stream::Defect);
  for (int k = 0; k < 50; ++k) {
    ScratchPath a = randomScratch(r1, region, o), b = randomScratch(r2, region, o);
    ASSERT_EQ(a.points().size(), b.points().size());
    EXPECT_EQ(a.points()[1].x, b.points()[1].x);
    EXPECT_GE(a.length(), 10 * (1 - 1e-4));
    EXPECT_LE(a.length(), 30.0 + 1e-9);
    Box2 bb = a.bounds();
    EXPECT_TRUE(bb.lo.x >= 10 && bb.hi.x <= 110 && bb.lo.y >= 10 && bb.hi.y <= 60);
  }
  // arcScratch: mid-point, direction and curvature as asked.
  ScratchPath s = arcScratch({0, 0}, 10, 0.5, 0.1, 1e-6);
  Vec2d m = s.pointAt(s.length() / 2);
  EXPECT_NEAR(m.x, 0, 1e-5);
  EXPECT_NEAR(m.y, 0, 1e-5);
  Vec2d t = s.tangentAt(s.length() / 2);
  EXPECT_NEAR(std::atan2(t.y, t.x), 0.5, 1e-3);
  Vec2d c{-std::sin(0.5) * 10, std::cos(0.5) * 10};  // centre on the left at radius 10
  for (const Vec2d& v : s.points()) EXPECT_NEAR(std::hypot(v.x - c.x, v.y - c.y), 10, 1e-9);
  ScratchPath line = arcScratch({1, 2}, 4, 0, 0);
  EXPECT_EQ(line.points().size(), 2u);
  EXPECT_DOUBLE_EQ(line.length(), 4.0);
}

TEST(ScratchPath, SubPathKeepsArcLengthAndPoints) {
  ScratchPath arc = ScratchPath::arc({0, 0}, 50, 0, 1.5);
  ScratchPath sub = arc.sub(10, 40);
  EXPECT_NEAR(sub.length(), 30.0, 1e-9);
  for (double s : {0.0, 7.5, 15.0, 30.0}) {
    Vec2d a = sub.pointAt(s), b = arc.pointAt(10 + s);
    EXPECT_NEAR(a.x, b.x, 1e-9);
    EXPECT_NEAR(a.y, b.y, 1e-9);
  }
  EXPECT_NEAR(arc.sub(-5, 1e9).length(), arc.length(), 1e-9);  // clamped
  EXPECT_THROW(arc.sub(20, 20), std::invalid_argument);
}

// Where a scratch bares the substrate: depth(s) = g(s) * d0 against the coating's total
// thickness, with g the smoothstep fade; the run ends solve 3u^2 - 2u^3 = coat / d0.
TEST(ScratchDefect, ExposedRunsFollowTheFadeLaw) {
  ScratchPath path = ScratchPath::polyline({{0, 0}, {100, 0}});
  Profile pr = Profile::fromPolyline({{-0.1, 0}, {0, -0.1}, {0.1, 0}});
  ScratchPerturbation pert;
  pert.fade_length_mm = 20;
  LayerStack paint;
  paint.layers = {{"clear_coat", 0.04}, {"base_coat", 0.015}, {"primer", 0.03}, {"steel", 0}};
  Scratch deep = Scratch::fromProfile(path, pr, pert, paint);
  // Solve the smoothstep for 0.85 by bisection.
  double lo = 0, hi = 1;
  for (int i = 0; i < 60; ++i) {
    double m = 0.5 * (lo + hi);
    (3 * m * m - 2 * m * m * m < 0.85 ? lo : hi) = m;
  }
  auto runs = deep.exposedRuns();
  ASSERT_EQ(runs.size(), 1u);
  EXPECT_NEAR(runs[0].first, 20 * lo, 0.02);
  EXPECT_NEAR(runs[0].second, 100 - 20 * lo, 0.02);
  EXPECT_NEAR(deep.attributes()["substrate_exposed_mm"].get<double>(), 100 - 40 * lo, 0.04);
  // A groove in the clear coat only bares nothing.
  Scratch shallow = Scratch::fromProfile(path, pr.scaled(0.5), pert, paint);
  EXPECT_TRUE(shallow.exposedRuns().empty());
  // Bare metal (one layer) is exposed wherever the groove has depth: all but the end points.
  Scratch bare = Scratch::fromProfile(path, pr.scaled(0.1), pert);
  runs = bare.exposedRuns();
  ASSERT_EQ(runs.size(), 1u);
  EXPECT_LT(runs[0].first, 0.5);
  EXPECT_GT(runs[0].second, 99.5);
  // Random depth variation splits the bared stretch where the depth dips under the coating.
  ScratchPerturbation wobbly = pert;
  wobbly.noise_amplitude = 0.3;
  wobbly.noise_wavelength_mm = 4;
  wobbly.noise_seed = 3;
  Scratch w = Scratch::fromProfile(path, pr.scaled(0.9), wobbly, paint);
  runs = w.exposedRuns();
  ASSERT_GT(runs.size(), 1u);
  for (size_t i = 0; i < runs.size(); ++i) {
    EXPECT_LT(runs[i].first, runs[i].second);
    if (i > 0) {
      EXPECT_GT(runs[i].first, runs[i - 1].second);
    }
    // Inside a run the groove is deeper than the coating, just outside it shallower.
    double mid = 0.5 * (runs[i].first + runs[i].second);
    EXPECT_GT(w.scaleAt(float(mid)) * 0.09, 0.085 - 1e-6) << "run " << i;
    EXPECT_LT(w.scaleAt(float(runs[i].first - 0.05)) * 0.09, 0.085 + 1e-3) << "run " << i;
  }
}
