// Tests of render/groove (Bosch 2007 §4.2.3 1-D line sampling, §4.3 specular recursion): the
// trapezoid footprint weight against quadrature, partition of unity of visible() (grazing views
// included), masking / shadowing / scattering against an independent brute-force 2-D ray cast
// (digest §7 C.18), the head-on V-groove and depth -> 0 limits, analytic shadow and reflection
// cases, and merge() of placed, mirrored and overlapping profiles.
#include "render/groove.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <vector>

namespace dg::groove {
namespace {

// ---------------------------------------------------------------------------------------------
// Helpers (independent of the implementation under test)
// ---------------------------------------------------------------------------------------------

Vec2d unitAngle(double theta) { return {std::sin(theta), std::cos(theta)}; }  // from +w
Vec2d reflect(Vec2d v, Vec2d n) { return v - n * (2.0 * dot(v, n)); }

struct Prof {
  std::vector<Vec2d> pts;
  std::vector<int> layer;
};

Prof vGroove(double half_width, double depth) {
  return {{{-half_width, 0}, {0, -depth}, {half_width, 0}}, {0, 0}};
}

Section single(const Prof& p, double offset, double extent, bool mirrored = false) {
  return merge({PlacedProfile{&p.pts, &p.layer, offset, mirrored}}, extent);
}

// Footprint density by direct box convolution: |[x-a, x+a] n [-c, c]| / (w1 w2).
double density(const Footprint& fp, double x) {
  if (fp.w1 > 0 && fp.w2 > 0) {
    const double a = 0.5 * fp.w1, c = 0.5 * fp.w2;
    return std::max(0.0, std::min(x + a, c) - std::max(x - a, -c)) / (fp.w1 * fp.w2);
  }
  const double w = std::max(fp.w1, fp.w2);
  return std::fabs(x) < 0.5 * w ? 1.0 / w : 0.0;
}

// The facet seen along the viewing line through base point (x, 0): of all intersections of the
// line {(x, 0) + s e} with the section, the one with the largest s (nearest the viewer).
int seenFacet(const Section& s, double x, Vec2d e) {
  int best = -1;
  double best_s = -1e300;
  const Vec2d P{x, 0};
  for (size_t k = 0; k + 1 < s.pts.size(); ++k) {
    const Vec2d A = s.pts[k], d = s.pts[k + 1] - A;
    const double den = cross(e, d);
    if (den == 0) continue;
    const double t = cross(A - P, d) / den, u = cross(A - P, e) / den;
    if (u >= 0 && u <= 1 && t > best_s) best_s = t, best = int(k);
  }
  return best;
}

// First facet (other than `self`) that the ray P + s d, s > 0, meets; -1 if none.
int castRay(const Section& s, Vec2d P, Vec2d d, int self) {
  int best = -1;
  double best_s = 1e300;
  for (size_t k = 0; k + 1 < s.pts.size(); ++k) {
    if (int(k) == self) continue;
    const Vec2d A = s.pts[k], e = s.pts[k + 1] - A;
    const double den = cross(d, e);
    if (den == 0) continue;
    const double t = cross(A - P, e) / den, u = cross(A - P, d) / den;
    if (t > 1e-12 && u >= 0 && u <= 1 && t < best_s) best_s = t, best = int(k);
  }
  return best;
}

// Height of a (non-vertical at b) section at b, for merge checks.
double heightAt(const std::vector<Vec2d>& pts, double b) {
  for (size_t k = 0; k + 1 < pts.size(); ++k)
    if (pts[k].x <= b && b <= pts[k + 1].x && pts[k + 1].x > pts[k].x)
      return pts[k].y + (pts[k + 1].y - pts[k].y) * (b - pts[k].x) / (pts[k + 1].x - pts[k].x);
  return 0;
}

struct Rand {
  std::mt19937_64 gen;
  explicit Rand(uint64_t seed) : gen(seed) {}
  double operator()(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(gen); }
  int integer(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(gen); }
};

// A random monotone profile from (0, 0) to (width, 0): grooves below, pile-up peaks above the base
// line, and now and then a vertical facet (two points at the same b).
Prof randomProfile(Rand& rnd, double width) {
  const int n = rnd.integer(1, 7);
  std::vector<double> bs;
  for (int i = 0; i < n; ++i) bs.push_back(rnd(0.02, 0.98) * width);
  std::sort(bs.begin(), bs.end());
  Prof p;
  p.pts.push_back({0, 0});
  for (double b : bs) {
    const double w = rnd(0, 1) < 0.75 ? -rnd(0, 0.6) * width : rnd(0, 0.25) * width;
    if (rnd(0, 1) < 0.2 && p.pts.back().x != 0) {
      p.pts.push_back({p.pts.back().x, w});  // vertical facet
    } else {
      p.pts.push_back({b, w});
    }
  }
  p.pts.push_back({width, 0});
  p.layer.assign(p.pts.size() - 1, 0);
  for (size_t k = 0; k < p.layer.size(); ++k) p.layer[k] = int(k % 3);
  return p;
}

// A random footprint: box, trapezoid, occasionally very thin on one axis.
Footprint randomFootprint(Rand& rnd) {
  Footprint fp;
  fp.w1 = rnd(0.2, 2.0);
  const double c = rnd(0, 1);
  fp.w2 = c < 0.2 ? 0.0 : (c < 0.3 ? 1e-7 : rnd(0.0, 2.0));
  return fp;
}

// A random set of one to three placed profiles near the footprint (they may overlap).
struct Scene {
  std::vector<Prof> profs;
  Section sec;
};
Scene randomScene(Rand& rnd, const Footprint& fp) {
  Scene sc;
  const int g = rnd.integer(1, 3);
  for (int i = 0; i < g; ++i) sc.profs.push_back(randomProfile(rnd, rnd(0.1, 1.2)));
  std::vector<PlacedProfile> placed;
  const double hw = fp.halfWidth();
  for (const Prof& p : sc.profs)
    placed.push_back({&p.pts, &p.layer, rnd(-hw - 1.0, hw + 0.2), rnd(0, 1) < 0.3});
  sc.sec = merge(placed, hw + rnd(0.0, 0.5));
  return sc;
}

Vec2d randomView(Rand& rnd) {
  const double c = rnd(0, 1);
  if (c < 0.1) return {rnd(-1, 1) < 0 ? -1.0 : 1.0, 1e-4};  // grazing
  return unitAngle(rnd(-1.55, 1.55));
}

std::map<int, double> perFacet(const std::vector<Portion>& ps) {
  std::map<int, double> m;
  for (const Portion& p : ps) m[p.facet] += p.weight;
  return m;
}

// ---------------------------------------------------------------------------------------------
// Footprint
// ---------------------------------------------------------------------------------------------

TEST(Groove, FootprintWeightTotalsAndSymmetry) {
  const double widths[][2] = {{1, 1}, {2, 0.5}, {0.5, 2}, {1, 0}, {0, 3}, {1e-12, 1}, {1, 1e-9}};
  for (auto& w : widths) {
    const Footprint fp{w[0], w[1]};
    EXPECT_NEAR(fp.weight(-1e3, 1e3), 1.0, 1e-15);
    EXPECT_NEAR(fp.weight(-fp.halfWidth(), fp.halfWidth()), 1.0, 1e-15);
    EXPECT_NEAR(fp.weight(-1e3, 0), 0.5, 1e-15);
    EXPECT_EQ(fp.weight(fp.halfWidth(), 1e3), 0.0);
    for (double x0 = -2; x0 < 2; x0 += 0.173)
      for (double x1 = x0; x1 < 2.1; x1 += 0.219) {
        EXPECT_NEAR(fp.weight(x0, x1), fp.weight(-x1, -x0), 1e-14);
        EXPECT_EQ(fp.weight(x0, x1), fp.weight(x1, x0));  // either order
        EXPECT_GE(fp.weight(x0, x1), 0.0);
      }
  }
}

TEST(Groove, FootprintWeightMatchesQuadrature) {
  Rand rnd(11);
  for (int c = 0; c < 60; ++c) {
    const Footprint fp{rnd(0.05, 2), rnd(0, 1) < 0.3 ? 0.0 : rnd(0.05, 2)};
    const double x0 = rnd(-1.5, 1.0), x1 = x0 + rnd(0, 1.5);
    const int n = 200000;
    double sum = 0;
    for (int i = 0; i < n; ++i) sum += density(fp, x0 + (x1 - x0) * (i + 0.5) / n);
    sum *= (x1 - x0) / n;
    EXPECT_NEAR(fp.weight(x0, x1), sum, 2e-5) << fp.w1 << " " << fp.w2 << " [" << x0 << ", " << x1 << "]";
  }
  // Box cases exactly: a single box of width 2 has density 1/2.
  EXPECT_NEAR((Footprint{2, 0}.weight(-0.3, 0.5)), 0.4, 1e-15);
  EXPECT_NEAR((Footprint{0, 2}.weight(0.5, 3)), 0.25, 1e-15);
  // Trapezoid w1 = 2, w2 = 1: flat 1/2 on |x| <= 0.5, ramps on 0.5..1.5 each holding 1/4.
  EXPECT_NEAR((Footprint{2, 1}.weight(-0.5, 0.5)), 0.5, 1e-15);
  EXPECT_NEAR((Footprint{2, 1}.weight(0.5, 1.5)), 0.25, 1e-15);
  EXPECT_NEAR((Footprint{2, 1}.weight(1.0, 1.5)), 1.0 / 16.0, 1e-15);  // (0.5)^2 / (8 * 1 * 0.5)
}

TEST(Groove, PointFootprintIsHalfOpen) {
  const Footprint fp{0, 0};
  EXPECT_EQ(fp.halfWidth(), 0.0);
  EXPECT_EQ(fp.weight(-1, 1), 1.0);
  EXPECT_EQ(fp.weight(0, 1), 1.0);   // [x0, x1) holds 0
  EXPECT_EQ(fp.weight(-1, 0), 0.0);  // ... and its neighbour does not
  EXPECT_EQ(fp.weight(0.1, 1), 0.0);
  EXPECT_EQ(fp.weight(-1, -0.1), 0.0);
}

// ---------------------------------------------------------------------------------------------
// visible(): masking and clipping
// ---------------------------------------------------------------------------------------------

TEST(Groove, VisibleWeightsSumToOne) {
  Rand rnd(1);
  for (int c = 0; c < 600; ++c) {
    const Footprint fp = randomFootprint(rnd);
    const Scene sc = randomScene(rnd, fp);
    const Vec2d e = randomView(rnd);
    const std::vector<Portion> vis = visible(sc.sec, e, fp);
    double sum = 0;
    const double r = e.x / std::max(e.y, 1e-6);
    for (const Portion& p : vis) {
      sum += p.weight;
      ASSERT_GT(p.weight, 0.0);
      ASSERT_TRUE(std::isfinite(p.x0) && std::isfinite(p.x1));
      ASSERT_LE(0.0, p.t0);
      ASSERT_LE(p.t0, p.t1);
      ASSERT_LE(p.t1, 1.0);
      ASSERT_LT(p.x0, p.x1);
      ASSERT_GE(p.x0, -fp.halfWidth());
      ASSERT_LE(p.x1, fp.halfWidth());
      // x0, x1 are the view projections of the portion's ends (Eq. 4.3).
      const Vec2d a = pointOn(sc.sec, p.facet, p.t0), b = pointOn(sc.sec, p.facet, p.t1);
      const double tol = 1e-9 * (1 + std::fabs(r));
      EXPECT_NEAR(a.x - a.y * r, p.x0, tol);
      EXPECT_NEAR(b.x - b.y * r, p.x1, tol);
    }
    EXPECT_NEAR(sum, 1.0, 1e-9) << "case " << c << " e = (" << e.x << ", " << e.y << ")";
  }
  // Grazing and below-horizon views are clamped (e_w >= 1e-6) and stay finite.
  const Prof v = vGroove(0.3, 0.4);
  const Section s = single(v, 0.1, 2);
  for (Vec2d e : {Vec2d{1, 0}, Vec2d{-1, 0}, Vec2d{1, -0.2}, Vec2d{-1, 1e-4}}) {
    double sum = 0;
    for (const Portion& p : visible(s, e, Footprint{1, 0.5})) sum += p.weight;
    EXPECT_NEAR(sum, 1.0, 1e-9);
  }
}

TEST(Groove, VisibleMatchesBruteForceRayCast) {
  Rand rnd(2);
  const int n = 20000;
  for (int c = 0; c < 250; ++c) {
    const Footprint fp = randomFootprint(rnd);
    const Scene sc = randomScene(rnd, fp);
    const Vec2d e = randomView(rnd);
    std::map<int, double> brute;
    const double hw = fp.halfWidth(), dx = 2 * hw / n;
    for (int i = 0; i < n; ++i) {
      const double x = -hw + (i + 0.5) * dx;
      const int k = seenFacet(sc.sec, x, e);
      ASSERT_GE(k, 0);
      brute[k] += density(fp, x) * dx;
    }
    std::map<int, double> got = perFacet(visible(sc.sec, e, fp));
    for (auto& kv : brute) got[kv.first] += 0;
    for (auto& kv : got)
      EXPECT_NEAR(kv.second, brute[kv.first], 1e-3)
          << "case " << c << " facet " << kv.first << " e = (" << e.x << ", " << e.y << ")";
  }
}

TEST(Groove, PointFootprintSeesOneFacet) {
  Rand rnd(3);
  for (int c = 0; c < 300; ++c) {
    const Footprint fp{0, 0};
    const Scene sc = randomScene(rnd, Footprint{0.5, 0});
    const Vec2d e = randomView(rnd);
    const std::vector<Portion> vis = visible(sc.sec, e, fp);
    ASSERT_EQ(vis.size(), 1u);
    EXPECT_EQ(vis[0].weight, 1.0);
    EXPECT_EQ(vis[0].t0, vis[0].t1);
    EXPECT_EQ(vis[0].facet, seenFacet(sc.sec, 0.0, e));
  }
}

TEST(Groove, HeadOnSymmetricVGroove) {
  // V-groove of width 1 through F; facets: flat, left wall, right wall, flat.
  const Prof v = vGroove(0.5, 0.4);
  const Section s = single(v, 0.0, 3.0);
  ASSERT_EQ(s.facets(), 4u);
  for (Footprint fp : {Footprint{1.5, 0}, Footprint{0, 1.5}, Footprint{1.5, 0.3}, Footprint{3, 2}}) {
    const std::map<int, double> w = perFacet(visible(s, {0, 1}, fp));
    // Both walls lie where the density is flat (1 / max width) when |x| <= 0.5 <= L - s.
    const double wall = 0.5 / std::max(fp.w1, fp.w2);
    EXPECT_NEAR(w.at(1), wall, 1e-14);
    EXPECT_NEAR(w.at(2), wall, 1e-14);
    EXPECT_NEAR(w.at(0), 0.5 - wall, 1e-14);
    EXPECT_NEAR(w.at(3), 0.5 - wall, 1e-14);
  }
  // Mirror symmetry (digest §7 C.16): mirrored view swaps the walls' weights.
  for (double th = -1.5; th <= 1.5; th += 0.1) {
    const Footprint fp{1.2, 0.4};
    std::map<int, double> a = perFacet(visible(s, unitAngle(th), fp));
    std::map<int, double> b = perFacet(visible(s, unitAngle(-th), fp));
    for (int k = 0; k < 4; ++k) EXPECT_NEAR(a[k], b[3 - k], 1e-12) << th;
  }
}

TEST(Groove, VanishingDepthShadesLikeFlatSurface) {
  Rand rnd(4);
  for (int c = 0; c < 200; ++c) {
    Prof p = randomProfile(rnd, 0.8);
    double depth = 0;
    for (const Vec2d& q : p.pts) depth = std::max(depth, std::fabs(q.y));
    Prof flat = p, tiny = p;
    for (Vec2d& q : flat.pts) q.y *= 1e-9 / depth;                   // depth -> 0, same width
    for (Vec2d& q : tiny.pts) q = q * (1e-9 / std::max(depth, 0.8));  // whole groove -> 0
    const Footprint fp = randomFootprint(rnd);
    // Not grazing: a facet of height h shifts the projection by h e_b / e_w, so the limit needs
    // depth << footprint * e_w.
    const Vec2d e = unitAngle(rnd(-1.5, 1.5));
    for (const Prof* q : {&flat, &tiny}) {
      const Section s = single(*q, rnd(-0.5, 0.2), fp.halfWidth() + 1);
      Vec2d n{0, 0};
      double non_flat = 0;
      for (const Portion& v : visible(s, e, fp)) {
        n += s.normal(size_t(v.facet)) * v.weight;
        if (s.pts[size_t(v.facet)].y != 0 || s.pts[size_t(v.facet) + 1].y != 0) non_flat += v.weight;
      }
      EXPECT_NEAR(n.x, 0.0, 1e-6);
      EXPECT_NEAR(n.y, 1.0, 1e-6);
      if (q == &tiny) {
        EXPECT_LT(non_flat, 1e-6);  // the groove covers a vanishing part
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------
// litFraction(): shadowing
// ---------------------------------------------------------------------------------------------

TEST(Groove, HeadOnLightLightsEveryVisibleFacet) {
  for (double half_angle_deg : {10.0, 45.0, 80.0}) {
    // Walls at half_angle from the horizontal, i.e. less than 90 degrees.
    const double d = 0.5 * std::tan(half_angle_deg * kPi / 180);
    const Prof v = vGroove(0.5, d);
    const Section s = single(v, 0.1, 3);
    const Footprint fp{2, 0.5};
    for (double th : {0.0, 0.3, -0.7}) {
      const std::vector<Portion> vis = visible(s, unitAngle(th), fp);
      ASSERT_FALSE(vis.empty());
      for (const Portion& p : vis) EXPECT_DOUBLE_EQ(litFraction(s, p, fp, {0, 1}), 1.0);
    }
  }
}

TEST(Groove, GrazingLightShadowsFarWallAnalytically) {
  // 90-degree V (walls at 45 degrees), head-on view, light theta above the horizon on the +b side.
  const Prof v = vGroove(1, 1);
  const Section s = single(v, 0, 4);
  const Footprint fp{3, 0};
  for (double deg : {5.0, 10.0, 30.0, 44.0}) {
    const double th = deg * kPi / 180;
    const Vec2d l{std::cos(th), std::sin(th)};
    double lit_total = 0;
    for (const Portion& p : visible(s, {0, 1}, fp)) {
      const double f = litFraction(s, p, fp, l);
      if (p.facet == 1)  // left wall faces the light: lit from its top down to the rim's shadow
        EXPECT_NEAR(f, 2 * std::tan(th) / (1 + std::tan(th)), 1e-12) << deg;
      else if (p.facet == 2)  // right wall faces away
        EXPECT_EQ(f, 0.0);
      else
        EXPECT_EQ(f, 1.0);  // the flat surface around is unshadowed
      lit_total += f * p.weight;
    }
    EXPECT_NEAR(lit_total, 1.0 / 3 + 1.0 / 3 * 2 * std::tan(th) / (1 + std::tan(th)), 1e-12);
  }
}

TEST(Groove, LitFractionMatchesBruteForce) {
  Rand rnd(5);
  const int n = 4000;
  for (int c = 0; c < 250; ++c) {
    const Footprint fp = randomFootprint(rnd);
    const Scene sc = randomScene(rnd, fp);
    const Vec2d e = randomView(rnd);
    const double lc = rnd(0, 1);
    const Vec2d l = lc < 0.1 ? unitAngle(rnd(1.6, 2.0) * (rnd(0, 1) < 0.5 ? -1 : 1))  // below
                             : unitAngle(rnd(-1.56, 1.56));
    double total_lit = 0, total_brute = 0;
    for (const Portion& p : visible(sc.sec, e, fp)) {
      const double f = litFraction(sc.sec, p, fp, l);
      ASSERT_GE(f, 0.0);
      ASSERT_LE(f, 1.0);
      const bool facing = dot(l, sc.sec.normal(size_t(p.facet))) > 0;
      double lit = 0, all = 0;
      for (int i = 0; i < n; ++i) {
        const double t = p.t0 + (p.t1 - p.t0) * (i + 0.5) / n;
        const double w = density(fp, p.xAt(t));
        all += w;
        const bool open = castRay(sc.sec, pointOn(sc.sec, p.facet, t), l, p.facet) < 0 &&
                          l.y >= 0;
        if (facing && open) lit += w;
      }
      const double brute = all > 0 ? p.weight * lit / all : 0;
      EXPECT_NEAR(f * p.weight, brute, 2e-3) << "case " << c << " facet " << p.facet;
      total_lit += f * p.weight;
      total_brute += brute;
    }
    EXPECT_NEAR(total_lit, total_brute, 4e-3) << "case " << c;
    EXPECT_LE(total_lit, 1.0 + 1e-9);
  }
}

// The precomputed shadowing (ordered projection) gives what the per-piece ray casting gives, for
// random sections, footprints, views and lights from every side (below the base line, straight
// up, grazing).
TEST(Groove, ShadowingMatchesLitFraction) {
  Rand rnd(17);
  int compared = 0, partial = 0;
  for (int c = 0; c < 600; ++c) {
    const Footprint fp = c % 7 == 0 ? Footprint{0, 0} : randomFootprint(rnd);
    const Scene sc = randomScene(rnd, c % 7 == 0 ? Footprint{0.5, 0} : fp);
    const Vec2d e = randomView(rnd);
    const double lc = rnd(0, 1);
    const Vec2d l = lc < 0.05 ? Vec2d(0, 1)
                    : lc < 0.1 ? unitAngle(rnd(1.6, 2.0) * (rnd(0, 1) < 0.5 ? -1 : 1))
                               : unitAngle(rnd(-1.569, 1.569));
    const Shadowing sh(sc.sec, l);
    std::vector<Portion> ps = visible(sc.sec, e, fp);
    // Portions hit after a reflection too (their x range runs differently from their t range).
    for (const Portion& p : visible(sc.sec, e, fp)) {
      const Vec2d d = reflect(e * (-1.0 / std::sqrt(dot(e, e))), sc.sec.normal(size_t(p.facet)));
      for (const Portion& h : scatter(sc.sec, p, fp, d).hits) ps.push_back(h);
    }
    for (const Portion& p : ps) {
      const double a = litFraction(sc.sec, p, fp, l), b = sh.litFraction(p, fp);
      ASSERT_NEAR(a, b, 1e-9) << "case " << c << " facet " << p.facet;
      ++compared;
      partial += a > 1e-6 && a < 1 - 1e-6;
    }
  }
  EXPECT_GT(compared, 1000);
  EXPECT_GT(partial, 100);  // partly shadowed portions were among them
}

// ---------------------------------------------------------------------------------------------
// scatter(): specular transport between facets
// ---------------------------------------------------------------------------------------------

TEST(Groove, ScatterRightAngleVGrooveReflectsAcross) {
  const Prof v = vGroove(1, 1);
  const Section s = single(v, 0, 4);
  const Footprint fp{3, 0};
  const std::vector<Portion> vis = visible(s, {0, 1}, fp);
  const Portion* left = nullptr;
  for (const Portion& p : vis)
    if (p.facet == 1) left = &p;
  ASSERT_NE(left, nullptr);
  // Light arriving straight down leaves the 45-degree left wall horizontally towards +b.
  const Vec2d r = reflect({0, -1}, s.normal(1));
  EXPECT_NEAR(r.x, 1.0, 1e-15);
  EXPECT_NEAR(r.y, 0.0, 1e-15);
  const Vec2d d{1, 0};  // exactly, so that no rounding sliver grazes the rim
  const Scatter sc = scatter(s, *left, fp, d);
  EXPECT_EQ(sc.escaped, 0.0);
  ASSERT_EQ(sc.hits.size(), 1u);
  const Portion& h = sc.hits[0];
  EXPECT_EQ(h.facet, 2);
  // (-1 + t, -t) travels to (1 - t, -t) = (0, -1) + (1 - t) (1, 1) on the right wall.
  EXPECT_NEAR(h.t0, 1 - left->t1, 1e-14);
  EXPECT_NEAR(h.t1, 1 - left->t0, 1e-14);
  EXPECT_NEAR(h.x0, left->x1, 1e-14);  // footprint coordinates travel with the rays
  EXPECT_NEAR(h.x1, left->x0, 1e-14);
  EXPECT_NEAR(h.weight, left->weight, 1e-15);
  // Directions into the facet scatter nothing.
  const Scatter none = scatter(s, *left, fp, {-1, 0});
  EXPECT_TRUE(none.hits.empty());
  EXPECT_EQ(none.escaped, 0.0);
  // Straight up from the left wall: everything escapes.
  const Scatter up = scatter(s, *left, fp, {0, 1});
  EXPECT_TRUE(up.hits.empty());
  EXPECT_NEAR(up.escaped, left->weight, 1e-15);
}

// Checks a scatter result s of the rays leaving portion p in direction d against n rays cast one
// by one (castRay): the shares per facet hit and escaped, and that every hit point lies in a
// returned portion mapping it back to the footprint coordinate its ray started from. `facing`:
// the sign of dot(d, normal) that hit facets show (-1 met from outside, +1 from inside). Returns
// the number of rays that hit a facet.
int expectLikeCastRays(const Section& sec, const Portion& p, const Footprint& fp, Vec2d d, const Scatter& s,
                       double facing, int n, int c) {
  int hits_seen = 0;
  double sum = s.escaped;
  std::map<int, double> got;
  for (const Portion& h : s.hits) {
    sum += h.weight;
    got[h.facet] += h.weight;
    EXPECT_LE(0.0, h.t0);
    EXPECT_LE(h.t0, h.t1);
    EXPECT_LE(h.t1, 1.0);
    EXPECT_GT(facing * dot(d, sec.normal(size_t(h.facet))), -1e-12);
  }
  EXPECT_NEAR(sum, p.weight, 1e-12);
  std::map<int, double> brute;
  double all = 0;
  for (int i = 0; i < n; ++i) {
    const double t = p.t0 + (p.t1 - p.t0) * (i + 0.5) / n;
    const double w = density(fp, p.xAt(t));
    all += w;
    const Vec2d P = pointOn(sec, p.facet, t);
    const int k = castRay(sec, P, d, p.facet);
    brute[k] += w;
    if (k < 0) continue;
    ++hits_seen;
    const Vec2d A = sec.pts[size_t(k)], ed = sec.pts[size_t(k) + 1] - A;
    const double u = cross(A - P, d) / cross(d, ed);
    bool found = false;
    for (const Portion& h : s.hits)
      if (h.facet == k && u >= h.t0 - 1e-9 && u <= h.t1 + 1e-9) {
        found = true;
        EXPECT_NEAR(h.xAt(u), p.xAt(t), 1e-6 * (1 + std::fabs(p.xAt(t))));
      }
    EXPECT_TRUE(found || w == 0) << "case " << c << " t " << t;
  }
  if (!(all > 0)) return hits_seen;
  for (auto& kv : brute) {
    const double expect = p.weight * kv.second / all;
    const double have = kv.first < 0 ? s.escaped : got[kv.first];
    EXPECT_NEAR(have, expect, 2e-3 * std::max(1.0, p.weight)) << "case " << c << " facet " << kv.first;
  }
  return hits_seen;
}

TEST(Groove, ScatterMatchesBruteForce) {
  Rand rnd(6);
  const int n = 3000;
  int hits_seen = 0;
  for (int c = 0; c < 250; ++c) {
    const Footprint fp = randomFootprint(rnd);
    const Scene sc = randomScene(rnd, fp);
    const Vec2d e = randomView(rnd);
    for (const Portion& p : visible(sc.sec, e, fp)) {
      // Mirror reflection of the view ray (towards the surface: -e) off the facet.
      const Vec2d nrm = sc.sec.normal(size_t(p.facet));
      const Vec2d ee = e * (1.0 / std::sqrt(dot(e, e)));
      const Vec2d d = rnd(0, 1) < 0.7 ? reflect(ee * -1.0, nrm) : unitAngle(rnd(-3.1, 3.1));
      const Scatter s = scatter(sc.sec, p, fp, d);
      if (dot(d, nrm) <= 0) {
        EXPECT_TRUE(s.hits.empty());
        EXPECT_EQ(s.escaped, 0.0);
        continue;
      }
      hits_seen += expectLikeCastRays(sc.sec, p, fp, d, s, -1.0, n, c);
    }
  }
  EXPECT_GT(hits_seen, 1000);  // the random cases do exercise inter-reflection
}

// scatterInside(): rays refracted into a glass part meet the section again from inside.
TEST(Groove, ScatterInsideCrossesAPileUpsRidge) {
  const Prof ridge{{{-0.5, 0}, {0, 0.5}, {0.5, 0}}, {0, 0}};
  const Section s = single(ridge, 0, 4);
  const Footprint fp{3, 0};
  const Portion* left = nullptr;
  const std::vector<Portion> vis = visible(s, {0, 1}, fp);
  for (const Portion& p : vis)
    if (p.facet == 1) left = &p;
  ASSERT_NE(left, nullptr);
  // Level through the ridge: (-0.5 + 0.5 t, 0.5 t) leaves by (0.5 (1 - t), 0.5 t) on the far side.
  const Scatter across = scatterInside(s, *left, fp, {1, 0});
  EXPECT_EQ(across.escaped, 0.0);
  ASSERT_EQ(across.hits.size(), 1u);
  EXPECT_EQ(across.hits[0].facet, 2);
  EXPECT_NEAR(across.hits[0].t0, 1 - left->t1, 1e-14);
  EXPECT_NEAR(across.hits[0].t1, 1 - left->t0, 1e-14);
  EXPECT_NEAR(across.hits[0].weight, left->weight, 1e-15);
  // Straight down it meets nothing again; out of the facet into the air is not scatterInside's.
  const Scatter down = scatterInside(s, *left, fp, {0, -1});
  EXPECT_TRUE(down.hits.empty());
  EXPECT_NEAR(down.escaped, left->weight, 1e-15);
  const Scatter out = scatterInside(s, *left, fp, {-1, 0});
  EXPECT_TRUE(out.hits.empty());
  EXPECT_EQ(out.escaped, 0.0);
}

TEST(Groove, ScatterInsideMatchesBruteForce) {
  Rand rnd(16);
  const int n = 2000;
  int hits_seen = 0;
  for (int c = 0; c < 150; ++c) {
    const Footprint fp = randomFootprint(rnd);
    const Scene sc = randomScene(rnd, fp);
    const Vec2d e = randomView(rnd);
    for (const Portion& p : visible(sc.sec, e, fp)) {
      const Vec2d nrm = sc.sec.normal(size_t(p.facet));
      Vec2d d = unitAngle(rnd(-3.1, 3.1));
      if (dot(d, nrm) >= 0) d = d * -1.0;  // into the solid
      if (!(dot(d, nrm) < -1e-9)) continue;
      const Scatter s = scatterInside(sc.sec, p, fp, d);
      hits_seen += expectLikeCastRays(sc.sec, p, fp, d, s, 1.0, n, c);
    }
  }
  EXPECT_GT(hits_seen, 1000);  // rays do meet the section again from inside
}

// castInto(): a ray from a point in the open space above the section (where the area sampling
// hands on the rays that leave its region down a groove) meets the facet that a brute-force cast
// meets first, at the point where it meets it; one that meets nothing is reported so.
TEST(Groove, CastIntoMeetsTheFirstFacetOnTheRay) {
  Rand rnd(23);
  int met = 0, missed = 0;
  for (int c = 0; c < 400; ++c) {
    const Footprint fp = randomFootprint(rnd);
    const Scene sc = randomScene(rnd, fp);
    for (int i = 0; i < 20; ++i) {
      const double b = rnd(sc.sec.pts.front().x, sc.sec.pts.back().x);
      const Vec2d P{b, heightAt(sc.sec.pts, b) + rnd(1e-4, 0.3)};
      const Vec2d d = unitAngle(rnd(-3.1, 3.1));
      int facet = -1;
      double t = -1;
      const bool hit = castInto(sc.sec, P, d, facet, t);
      const int want = castRay(sc.sec, P, d, -1);
      ASSERT_EQ(hit, want >= 0) << c << " " << i;
      if (!hit) {
        ++missed;
        continue;
      }
      ++met;
      EXPECT_EQ(facet, want) << c << " " << i;
      ASSERT_GE(t, 0.0);
      ASSERT_LE(t, 1.0);
      const Vec2d q = pointOn(sc.sec, facet, t) - P;
      EXPECT_NEAR(cross(q, d), 0.0, 1e-9) << c << " " << i;  // on the ray,
      EXPECT_GT(dot(q, d), 0.0) << c << " " << i;            // ahead of its start,
      EXPECT_LT(dot(d, sc.sec.normal(size_t(facet))), 0.0);  // on the facet's front
    }
  }
  EXPECT_GT(met, 3000);
  EXPECT_GT(missed, 1000);  // rising rays leave
}

TEST(Groove, PointFootprintLightAndScatter) {
  // With a point footprint the seen portion is a single point carrying weight 1: it is lit or not
  // as a whole, and one ray carries its reflection.
  Rand rnd(8);
  const Footprint fp{0, 0};
  int lit = 0, dark = 0, hit = 0, esc = 0;
  for (int c = 0; c < 400; ++c) {
    const Scene sc = randomScene(rnd, Footprint{0.5, 0});
    const Vec2d e = randomView(rnd);
    const std::vector<Portion> vis = visible(sc.sec, e, fp);
    ASSERT_EQ(vis.size(), 1u);
    const Portion& p = vis[0];
    const Vec2d P = pointOn(sc.sec, p.facet, p.t0);
    const Vec2d nrm = sc.sec.normal(size_t(p.facet));
    const Vec2d l = unitAngle(rnd(-1.5, 1.5));
    const bool open = dot(l, nrm) > 0 && castRay(sc.sec, P, l, p.facet) < 0;
    const double f = litFraction(sc.sec, p, fp, l);
    EXPECT_EQ(f, open ? 1.0 : 0.0);
    (open ? lit : dark)++;
    const Vec2d d = reflect(e * (-1.0 / std::sqrt(dot(e, e))), nrm);
    const Scatter s = scatter(sc.sec, p, fp, d);
    const int k = castRay(sc.sec, P, d, p.facet);
    if (k < 0) {
      EXPECT_EQ(s.escaped, 1.0);
      EXPECT_TRUE(s.hits.empty());
      ++esc;
    } else {
      ASSERT_EQ(s.hits.size(), 1u);
      EXPECT_EQ(s.hits[0].facet, k);
      EXPECT_EQ(s.hits[0].weight, 1.0);
      EXPECT_EQ(s.hits[0].t0, s.hits[0].t1);
      const Vec2d Q = pointOn(sc.sec, k, s.hits[0].t0);
      EXPECT_NEAR(cross(Q - P, d), 0.0, 1e-9);  // the hit point is on the reflected ray
      EXPECT_GT(dot(Q - P, d), 0.0);
      ++hit;
    }
  }
  EXPECT_GT(lit, 20);
  EXPECT_GT(dark, 20);
  EXPECT_GT(hit, 20);
  EXPECT_GT(esc, 20);
  // Zero-weight portions and lights behind the facet give 0.
  const Prof v = vGroove(1, 1);
  const Section s = single(v, 0, 4);
  Portion p{1, 0, 1, -1, 0, 0};
  EXPECT_EQ(litFraction(s, p, Footprint{3, 0}, {0, 1}), 0.0);
  p.weight = 1.0 / 3;
  EXPECT_EQ(litFraction(s, p, Footprint{3, 0}, {-1, 0.2}), 0.0);
  EXPECT_NEAR(litFraction(s, p, Footprint{3, 0}, {1, 0.2}), 0.4 / 1.2, 1e-12);  // 2 tan / (1 + tan)
}

// ---------------------------------------------------------------------------------------------
// merge()
// ---------------------------------------------------------------------------------------------

TEST(Groove, MergeTwoGroovesApartAndMirrored) {
  const Prof v{{{-1, 0}, {0, -1}, {1, 0}}, {1, 2}};
  const Prof asym{{{0, 0}, {1, -1}, {3, 0}}, {1, 2}};
  // Given out of order: merge sorts them along b.
  const Section s = merge({PlacedProfile{&asym.pts, &asym.layer, 5.0, true},
                           PlacedProfile{&v.pts, &v.layer, -2.0, false}},
                          10.0);
  // asym mirrored: b -> -b, order reversed: (-3,0) (-1,-1) (0,0), then + 5.
  const std::vector<Vec2d> want{{-10, 0}, {-3, 0}, {-2, -1}, {-1, 0}, {2, 0}, {4, -1}, {5, 0}, {10, 0}};
  const std::vector<int> want_layer{0, 1, 2, 0, 2, 1, 0};
  ASSERT_EQ(s.pts.size(), want.size());
  for (size_t i = 0; i < want.size(); ++i) {
    EXPECT_EQ(s.pts[i].x, want[i].x) << i;
    EXPECT_EQ(s.pts[i].y, want[i].y) << i;
  }
  EXPECT_EQ(s.layer, want_layer);
  EXPECT_NEAR(s.normal(0).y, 1.0, 0);
  EXPECT_NEAR(s.normal(1).x, std::sqrt(0.5), 1e-15);  // left wall faces +b
  EXPECT_NEAR(s.normal(1).y, std::sqrt(0.5), 1e-15);
  EXPECT_EQ(pointOn(s, 1, 0.25).x, -2.75);
  EXPECT_EQ(pointOn(s, 1, 0.25).y, -0.25);

  // No grooves: one flat facet; grooves wider than extent: ends reach past them.
  const Section flat = merge({}, 2.0);
  ASSERT_EQ(flat.pts.size(), 2u);
  EXPECT_EQ(flat.pts[0].x, -2.0);
  EXPECT_EQ(flat.pts[1].x, 2.0);
  const Section narrow = single(v, 0.5, 0.25);
  EXPECT_EQ(narrow.pts.front().x, -0.5);
  EXPECT_EQ(narrow.pts.back().x, 1.5);
  EXPECT_EQ(narrow.facets(), 2u);

  // Touching profiles: no zero-length flat facet in between.
  const Section touch = merge({PlacedProfile{&v.pts, &v.layer, -1, false},
                               PlacedProfile{&v.pts, &v.layer, 1, false}},
                              3);
  EXPECT_EQ(touch.facets(), 6u);
  for (size_t k = 0; k < touch.facets(); ++k) EXPECT_FALSE(touch.pts[k].x == touch.pts[k + 1].x && touch.pts[k].y == touch.pts[k + 1].y);
}

TEST(Groove, MergeKeepsVerticalFacetsAndLayers) {
  const Prof box{{{0, 0}, {0, -0.5}, {0, -1}, {1, -1}, {1, 0}}, {1, 2, 3, 2}};
  const Section s = single(box, 0, 2);
  const std::vector<Vec2d> want{{-2, 0}, {0, 0}, {0, -0.5}, {0, -1}, {1, -1}, {1, 0}, {2, 0}};
  ASSERT_EQ(s.pts.size(), want.size());
  for (size_t i = 0; i < want.size(); ++i) EXPECT_EQ(s.pts[i].y, want[i].y) << i;
  EXPECT_EQ(s.layer, (std::vector<int>{0, 1, 2, 3, 2, 0}));
  EXPECT_EQ(s.normal(2).x, 1.0);  // vertical wall going down faces +b
  const Section m = single(box, 0, 2, true);
  EXPECT_EQ(m.layer, (std::vector<int>{0, 2, 3, 2, 1, 0}));
  EXPECT_EQ(m.pts[4].x, 0.0);
  EXPECT_EQ(m.pts[4].y, -0.5);
}

// Overlapping profiles: removed material stays removed, piled-up material stays piled up. The
// surface is the lowest height where one is below the base, else the highest (the base counted),
// as in the explicit geometry's scratchHeight and the polygons of groove_area.
TEST(Groove, MergeOverlapRemovesWhatAnyGrooveRemovesAndKeepsEveryPileUp) {
  Rand rnd(7);
  for (int c = 0; c < 300; ++c) {
    std::vector<Prof> ps;
    const int g = rnd.integer(2, 3);
    std::vector<PlacedProfile> placed;
    for (int i = 0; i < g; ++i) ps.push_back(randomProfile(rnd, rnd(0.3, 1.5)));
    std::vector<double> off;
    for (int i = 0; i < g; ++i) off.push_back(rnd(-1, 0.5));
    for (int i = 0; i < g; ++i) placed.push_back({&ps[i].pts, &ps[i].layer, off[i], false});
    const double extent = 2.5;
    const Section s = merge(placed, extent);
    ASSERT_EQ(s.layer.size() + 1, s.pts.size());
    EXPECT_EQ(s.pts.front().x, -extent);
    EXPECT_EQ(s.pts.back().x, extent);
    EXPECT_EQ(s.pts.front().y, 0.0);
    EXPECT_EQ(s.pts.back().y, 0.0);
    for (size_t k = 0; k + 1 < s.pts.size(); ++k) {
      EXPECT_LE(s.pts[k].x, s.pts[k + 1].x);
      EXPECT_FALSE(s.pts[k].x == s.pts[k + 1].x && s.pts[k].y == s.pts[k + 1].y);
    }
    // At generic b the merged height is the lowest of the profiles defined there where that is
    // below 0, else the highest of them and 0; its scratchHeight as in scratch_geometry.cpp.
    for (int i = 0; i < 400; ++i) {
      const double b = rnd(-extent, extent);
      double lowest = 0, highest = 0;
      for (int j = 0; j < g; ++j) {
        const double lo = ps[j].pts.front().x + off[j], hi = ps[j].pts.back().x + off[j];
        if (b > lo && b < hi) {
          std::vector<Vec2d> q = ps[j].pts;
          for (Vec2d& p : q) p.x += off[j];
          lowest = std::min(lowest, heightAt(q, b));
          highest = std::max(highest, heightAt(q, b));
        }
      }
      EXPECT_NEAR(heightAt(s.pts, b), lowest < 0 ? lowest : highest, 1e-12) << "case " << c << " b " << b;
    }
  }
  // Two V-grooves overlapping: the shallower one only shows where it is deeper.
  const Prof deep{{{-1, 0}, {0, -1}, {1, 0}}, {1, 1}};
  const Prof shallow{{{-1, 0}, {0, -0.5}, {1, 0}}, {2, 2}};
  const Section s = merge({PlacedProfile{&deep.pts, &deep.layer, 0, false},
                           PlacedProfile{&shallow.pts, &shallow.layer, 0.5, false}},
                          3);
  // Deep: (-1, 0) (0, -1) (1, 0). Shallow, placed at 0.5: (-0.5, 0) (0.5, -0.5) (1.5, 0). They meet
  // at (0.5, -0.5); the deep one is lower left of it, the shallow one right of it.
  EXPECT_NEAR(heightAt(s.pts, 0.75), -0.375, 1e-15);
  EXPECT_NEAR(heightAt(s.pts, 0.25), -0.75, 1e-15);
  EXPECT_NEAR(heightAt(s.pts, 1.25), -0.125, 1e-15);
  for (size_t k = 0; k < s.facets(); ++k) {
    const double mid = 0.5 * (s.pts[k].x + s.pts[k + 1].x);
    const bool in_shallow_part = mid > 0.5 + 1e-12 && mid < 1.5;
    if (mid > -1 && mid < 0.5) {
      EXPECT_EQ(s.layer[k], 1) << k;
    }
    if (in_shallow_part) {
      EXPECT_EQ(s.layer[k], 2) << k;
    }
  }

  // Two grooves with pile-ups (layer 0) 0.12 apart: the second's outer flank does not shave the
  // first's pile-up down (a lower envelope would), and where the pile-ups overlap the higher one
  // stands; the second's groove cuts through the first's pile-up.
  const Prof piled{{{-0.1, 0}, {-0.06, 0.02}, {-0.04, 0}, {0, -0.03}, {0.04, 0}, {0.06, 0.02}, {0.1, 0}},
                   {0, 0, 1, 1, 0, 0}};
  const Section two = merge({PlacedProfile{&piled.pts, &piled.layer, 0, false},
                             PlacedProfile{&piled.pts, &piled.layer, 0.12, false}},
                            0.5);
  // Between 0.02 and 0.1 the first's right pile-up (peak 0.02 at 0.06) meets the second's left
  // one (from 0 at 0.02 up to 0.02 at 0.06, down to 0 at 0.08, into its groove).
  EXPECT_NEAR(heightAt(two.pts, 0.03), -0.0075, 1e-15); // the first's groove is not filled by the second's pile-up
  EXPECT_NEAR(heightAt(two.pts, 0.05), 0.015, 1e-15);   // the second's, higher than the first's 0.01
  EXPECT_NEAR(heightAt(two.pts, 0.06), 0.02, 1e-15);    // both peaks
  EXPECT_NEAR(heightAt(two.pts, 0.07), 0.015, 1e-15);   // the first's, higher than the second's 0.01
  EXPECT_NEAR(heightAt(two.pts, 0.09), -0.0075, 1e-15); // the second's groove cuts the first's pile-up
  EXPECT_NEAR(heightAt(two.pts, 0.12), -0.03, 1e-15);
  for (size_t k = 0; k < two.facets(); ++k) {
    const double mid = 0.5 * (two.pts[k].x + two.pts[k + 1].x);
    if (mid > 0.04 && mid < 0.08) {
      EXPECT_EQ(two.layer[k], 0) << k;  // pile-up, whichever profile's
    }
  }
}

// Merges 200 random sets of one to three profiles, each with a force fade (rho) and, with
// `turns`, a turn of up to 2 degrees, and checks every facet's tilt against the slope of the merged
// surface itself: -n_w dw/dt (the 3-D normal (tilt, n_b, n_w) is orthogonal to (1, 0, dw/dt)),
// with dw/dt from merging the profiles as they lie at t = +-h (scaled by 1 +- rho h, their centre
// lines moved across by +-turn h). Returns how many facets were checked.
int tiltsMatchDifferences(Rand& rnd, bool turns) {
  const double h = 1e-6, extent = 2.5;
  int checked = 0;
  for (int c = 0; c < 200; ++c) {
    const int g = rnd.integer(1, 3);
    std::vector<Prof> ps, plus, minus;
    std::vector<PlacedProfile> placed, at_plus, at_minus;
    for (int i = 0; i < g; ++i) ps.push_back(randomProfile(rnd, rnd(0.3, 1.5)));
    plus = minus = ps;
    for (int i = 0; i < g; ++i) {
      const double off = rnd(-1, 0.5), rho = rnd(-2, 2), turn = turns ? rnd(-0.035, 0.035) : 0.0;
      const bool mirrored = rnd(0, 1) < 0.3;
      for (Vec2d& q : plus[size_t(i)].pts) q = q * (1 + rho * h);
      for (Vec2d& q : minus[size_t(i)].pts) q = q * (1 - rho * h);
      placed.push_back({&ps[size_t(i)].pts, &ps[size_t(i)].layer, off, mirrored});
      placed.back().rho = rho;
      placed.back().turn = turn;
      at_plus.push_back({&plus[size_t(i)].pts, &plus[size_t(i)].layer, off + turn * h, mirrored});
      at_minus.push_back({&minus[size_t(i)].pts, &minus[size_t(i)].layer, off - turn * h, mirrored});
    }
    const Section s = merge(placed, extent), sp = merge(at_plus, extent), sm = merge(at_minus, extent);
    EXPECT_EQ(s.tilt.size(), s.facets());
    if (s.tilt.size() != s.facets()) continue;
    for (size_t k = 0; k < s.facets(); ++k) {
      const Vec2d a = s.pts[k], b = s.pts[k + 1];
      if (!(b.x - a.x > 1e-3)) continue;  // vertical or too short to difference across
      const double mid = 0.5 * (a.x + b.x);
      const double dwdt = (heightAt(sp.pts, mid) - heightAt(sm.pts, mid)) / (2 * h);
      EXPECT_NEAR(s.tilt[k], -s.normal(k).y * dwdt, 1e-5 * (1 + std::fabs(dwdt))) << "case " << c << " facet " << k;
      ++checked;
    }
  }
  return checked;
}

// A force fade scales a profile along the path, r(t) = 1 + rho t about its own origin, so its
// facets slope along t. Each merged facet's tilt must be the slope of the merged surface itself
// (tiltsMatchDifferences).
TEST(Groove, MergeTiltsFacetsAsTheirFadingProfilesMove) {
  // One V-groove deepening along t: its left wall (normal (1, 1)/sqrt2, 1/sqrt2 from the origin
  // on the inside) goes down as t grows, so its normal leans towards +t: tilt = rho / sqrt2.
  const Prof v = vGroove(1, 1);
  PlacedProfile pv{&v.pts, &v.layer, 0.3, false};
  pv.rho = 0.2;
  const Section sv = merge({pv}, 3);
  ASSERT_EQ(sv.tilt.size(), sv.facets());
  for (size_t k = 0; k < sv.facets(); ++k) {
    const double mid = 0.5 * (sv.pts[k].x + sv.pts[k + 1].x);
    const double expect = mid < -0.7 || mid > 1.3 ? 0.0 : 0.2 / std::sqrt(2.0);
    EXPECT_NEAR(sv.tilt[k], expect, 1e-15) << k;
  }
  // Without a fade there is no tilt.
  EXPECT_TRUE(single(v, 0.3, 3).tilt.empty());

  Rand rnd(11);
  EXPECT_GT(tiltsMatchDifferences(rnd, false), 1000);
}

// A groove turned from the section's t by an angle of tangent `turn` (merged with grooves within
// 2 degrees of parallel) has its centre line at b = offset + turn t, so its facets slope along t
// as they move across: tilt = -turn n_b. Checked as above, by merging the profiles at t = +-h
// (each also scaled by its force fade, so that the two slopes add), and on one V-groove against
// the exactly turned normal.
TEST(Groove, MergeTiltsFacetsOfATurnedGrooveWithItsOwnNormal) {
  const Prof v = vGroove(1, 1);
  PlacedProfile pv{&v.pts, &v.layer, 0.3, false};
  const double a = 2.0 * M_PI / 180;  // the merging tolerance
  pv.turn = std::tan(a);
  const Section sv = merge({pv}, 3);
  ASSERT_EQ(sv.tilt.size(), sv.facets());
  int walls = 0;
  for (size_t k = 0; k < sv.facets(); ++k) {
    const Vec2d n2 = sv.normal(k);
    if (n2.x == 0) {
      EXPECT_EQ(sv.tilt[k], 0.0) << k;  // the flat base keeps its normal
      continue;
    }
    // The wall's normal in the groove's own frame, (n_b, n_w), turned by a about w: in (t, b, w)
    // it is (-n_b sin a, n_b cos a, n_w).
    const Vec3d exact(-n2.x * std::sin(a), n2.x * std::cos(a), n2.y);
    Vec3d got(sv.tilt[k], n2.x, n2.y);
    got = got / std::sqrt(dot(got, got));
    EXPECT_LT(std::acos(std::min(1.0, dot(got, exact))), 5e-4) << k;  // second order in a
    ++walls;
  }
  EXPECT_EQ(walls, 2);

  Rand rnd(12);
  EXPECT_GT(tiltsMatchDifferences(rnd, true), 1000);
}

}  // namespace
}  // namespace dg::groove
