// Tests of render/groove_area (Bosch 2007 §4.2.4, area sampling with polygons at crossings and
// ends): convex clipping and differences, the pieces against a direct evaluation of the composite
// height field, and the visible shares, lit fractions and scattered shares against brute force
// (many points over the footprint, each ray-marched through the height field), on a crossing, a
// tapered end and a single groove, where they must also agree with 1-D line sampling.
#include "render/groove_area.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <vector>

#include "core/rng.h"
#include "defects/scratch.h"
#include "render/groove.h"

namespace dg::groove::area {
namespace {

Poly rect(double x0, double y0, double x1, double y1) {
  Poly p;
  p.push({x0, y0});
  p.push({x1, y0});
  p.push({x1, y1});
  p.push({x0, y1});
  return p;
}

Vec3d unit(Vec3d v) { return v / length(v); }

// A groove's height at p straight from its definition (independent of the pieces). A corner's
// groove: the part whose domain holds p.
double grooveHeight(const Groove& g, Vec2d p) {
  if (g.parts) {
    for (const Groove& q : *g.parts) {
      bool in = true;
      for (int k = 0; k < q.n_dom; ++k) in = in && q.dom[k].a.x * p.x + q.dom[k].a.y * p.y + q.dom[k].c <= 0;
      if (in) return grooveHeight(q, p);
    }
    return 0;
  }
  double t = g.t0 + g.tdir.x * p.x + g.tdir.y * p.y;
  double b = g.b0 + g.bdir.x * p.x + g.bdir.y * p.y;
  double r = 1 + g.rho * t;
  if (t < g.t_lo || t > g.t_hi || !(r > 0)) return 0;
  const auto& P = *g.pts;
  double u = b / r;
  if (u <= P.front().x || u >= P.back().x) return 0;
  for (size_t j = 0; j + 1 < P.size(); ++j)
    if (u >= P[j].x && u <= P[j + 1].x && P[j + 1].x > P[j].x)
      return r * (P[j].y + (P[j + 1].y - P[j].y) * (u - P[j].x) / (P[j + 1].x - P[j].x));
  return 0;
}

double composite(const std::vector<Groove>& gs, Vec2d p) {
  double lo = 0, hi = 0;
  for (const Groove& g : gs) {
    double h = grooveHeight(g, p);
    lo = std::min(lo, h);
    hi = std::max(hi, h);
  }
  return lo < 0 ? lo : hi;
}

// Does the ray from (p, z) towards d pass below the height field before rising above zmax?
bool blocked(const std::vector<Groove>& gs, Vec2d p, double z, Vec3d d, double zmax) {
  const double step = 2e-4;  // mm along the ray
  for (double s = step; s < 10; s += step) {
    Vec2d q(p.x + d.x * s, p.y + d.y * s);
    double zr = z + d.z * s;
    if (zr > zmax) return false;
    if (zr < composite(gs, q) - 1e-7) return true;
  }
  return false;
}

// The piece of the composite (not a wall) over p.
int pieceAt(const Surface& s, Vec2d p) {
  for (size_t i = 0; i < s.pieces().size(); ++i) {
    if (s.pieces()[i].wall) continue;
    const Poly& q = s.pieces()[i].poly;
    bool in = true;
    for (int k = 0; k < q.n && in; ++k) {
      Vec2d a = q.v[size_t(k)], b = q.v[size_t((k + 1) % q.n)];
      in = (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x) >= -1e-15;
    }
    if (in) return int(i);
  }
  return -1;
}

// Over an n x n grid on the footprint centre +- half (by default [-0.06, 0.06]^2) seen head-on:
// the share of points whose piece faces d (side +1) or faces away from it (side -1), and the
// share of those for which `met(p)` holds (a ray marched from there meets the surface).
struct GridShares {
  double side = 0, met = 0;
};
template <class Met>
GridShares gridShares(const Surface& s, Vec3d d, int side, Met met, Vec2d centre = {0, 0}, double half = 0.06,
                      int n = 80) {
  int on_side = 0, hits = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      Vec2d p(centre.x - half + 2 * half * (i + 0.5) / n, centre.y - half + 2 * half * (j + 0.5) / n);
      int k = pieceAt(s, p);
      EXPECT_GE(k, 0);
      if (k < 0) continue;
      Vec3d nn = s.pieces()[size_t(k)].plane.normal();
      if (side * (nn.x * d.x + nn.y * d.y + nn.z * d.z) <= 0) continue;
      ++on_side;
      hits += met(p);
    }
  return {double(on_side) / (n * n), double(hits) / (n * n)};
}

// A V-groove with pile-up peaks (mm): 0.1 wide, 0.02 deep.
const std::vector<Vec2d> kProfile = {{-0.07, 0}, {-0.06, 0.004}, {-0.05, 0}, {0, -0.02},
                                     {0.05, 0}, {0.06, 0.004}, {0.07, 0}};
const std::vector<int> kLayers = {0, 0, 1, 2, 0, 0};

// The same with its two sides unlike, as a tilted tool cuts it: one pile-up higher, the bottom off
// the centre line.
const std::vector<Vec2d> kTiltedProfile = {{-0.07, 0}, {-0.06, 0.007}, {-0.05, 0}, {0.012, -0.02},
                                           {0.05, 0}, {0.06, 0.002}, {0.07, 0}};

// A profile's height at b, as the explicit geometry takes it (straight between its points).
double profileAt(double b, const std::vector<Vec2d>& P = kProfile) {
  if (b <= P.front().x || b >= P.back().x) return 0.0;
  for (size_t j = 0; j + 1 < P.size(); ++j)
    if (b >= P[j].x && b <= P[j + 1].x) return P[j].y + (P[j + 1].y - P[j].y) * (b - P[j].x) / (P[j + 1].x - P[j].x);
  return 0.0;
}

// The differences over an 81 x 81 grid of [-half, half]^2 between s's height and `profile` at the
// signed distance to the closest point of `path` (Scratch::height's rule), one per point
// (infinite where a point is on no piece).
std::vector<double> closestProfileDifferences(const Surface& s, const ScratchPath& path,
                                              const std::vector<Vec2d>& profile, double half) {
  std::vector<double> diffs;
  for (int j = 0; j <= 80; ++j)
    for (int i = 0; i <= 80; ++i) {
      const Vec2d p(-half + 2 * half * (i + 0.31) / 81, -half + 2 * half * (j + 0.57) / 81);
      const double want = profileAt(double(path.closest(Vec2f(float(p.x), float(p.y))).offset), profile);
      const int k = pieceAt(s, p);
      if (k < 0) ADD_FAILURE() << "no piece at " << p.x << ", " << p.y;
      diffs.push_back(k < 0 ? std::numeric_limits<double>::infinity()
                            : std::fabs(s.pieces()[size_t(k)].plane.at(p) - want));
    }
  return diffs;
}

// The largest of those differences (with kProfile by default).
double offClosestProfile(const Surface& s, const ScratchPath& path, const std::vector<Vec2d>& profile = kProfile,
                         double half = 0.15) {
  const std::vector<double> d = closestProfileDifferences(s, path, profile, half);
  return *std::max_element(d.begin(), d.end());
}

// How many of them exceed `tol`. (Where the partition's cut runs close to a grid point across a
// step of the profile, one point can be off by the step: a count bounds what a largest difference
// cannot.)
int countOffClosestProfile(const Surface& s, const ScratchPath& path, const std::vector<Vec2d>& profile, double tol,
                           double half = 0.15) {
  const std::vector<double> d = closestProfileDifferences(s, path, profile, half);
  return int(std::count_if(d.begin(), d.end(), [&](double x) { return x > tol; }));
}

// A groove made of parts (cornerParts, chainParts, passParts), with id `id`.
Groove ofParts(const std::vector<Groove>& parts, int id = 0) {
  Groove g;
  g.parts = &parts;
  g.id = id;
  return g;
}

Groove along(Vec2d t, double b0, int id) {
  Groove g;
  g.tdir = t;
  g.bdir = Vec2d(-t.y, t.x);
  g.b0 = b0;
  g.pts = &kProfile;
  g.layer = &kLayers;
  g.id = id;
  return g;
}

std::vector<Groove> crossing() {
  return {along({1, 0}, 0.01, 0), along(Vec2d(std::cos(1.2), std::sin(1.2)), -0.015, 1)};
}

std::vector<Groove> taperedEnd() {
  Groove g = along({1, 0}, 0.0, 0);
  g.rho = -8;    // the cross-section shrinks to nothing 0.125 mm ahead,
  g.t_hi = 0.2;  // before the path stops (so there is no wall)
  return {g};
}

TEST(GrooveArea, ClipAndSubtractKeepAreas) {
  Poly r = rect(0, 0, 2, 1);
  EXPECT_DOUBLE_EQ(r.area(), 2.0);
  Poly half = clip(r, {1, 0}, -1);  // x <= 1
  EXPECT_NEAR(half.area(), 1.0, 1e-12);
  EXPECT_TRUE(clip(r, {0, 0}, 0, true).empty());  // a tie kept by nothing when strict
  EXPECT_NEAR(clip(r, {0, 0}, 0, false).area(), 2.0, 1e-12);
  std::vector<Poly> frags{r};
  size_t dropped = 0;
  subtract(frags, rect(0.5, 0.25, 1.0, 0.75), 48, dropped);
  EXPECT_NEAR(area(frags), 2.0 - 0.25, 1e-12);
  subtract(frags, rect(-1, -1, 3, 3), 48, dropped);
  EXPECT_NEAR(area(frags), 0.0, 1e-12);
  EXPECT_EQ(dropped, 0u);
  EXPECT_NEAR(intersect(r, rect(1.5, 0.5, 4, 4)).area(), 0.25, 1e-12);
}

// A short groove that starts and ends abruptly (no fade: vertical walls at both ends) across a
// long one.
std::vector<Groove> shortAcross() {
  Groove g = along(Vec2d(std::cos(1.4), std::sin(1.4)), 0.005, 0);
  g.t_lo = -0.045;
  g.t_hi = 0.03;
  return {g, along({1, 0}, -0.02, 1)};
}

// Legs of a path that turns at v from direction ta to tb (unit), with t = 0 at v.
std::pair<Groove, Groove> legs(Vec2d v, Vec2d ta, Vec2d tb) {
  Groove a = along(ta, 0, 0), b = along(tb, 0, 0);
  a.t0 = -(ta.x * v.x + ta.y * v.y);
  a.b0 = -(a.bdir.x * v.x + a.bdir.y * v.y);
  b.t0 = -(tb.x * v.x + tb.y * v.y);
  b.b0 = -(b.bdir.x * v.x + b.bdir.y * v.y);
  return {a, b};
}

Vec2d dirOf(double deg) { return Vec2d(std::cos(deg * M_PI / 180), std::sin(deg * M_PI / 180)); }

// A path turning right by 120 degrees just off the footprint's centre.
std::vector<Groove> corner() {
  static std::vector<Groove> parts;
  auto [a, b] = legs({0.005, -0.01}, dirOf(20), dirOf(-100));
  EXPECT_TRUE(cornerParts(a, b, 15 * M_PI / 180, parts));
  return {ofParts(parts)};
}

class Layouts : public ::testing::TestWithParam<int> {
 protected:
  std::vector<Groove> grooves() const {
    switch (GetParam()) {
      case 0: return crossing();
      case 1: return taperedEnd();
      case 2: return shortAcross();
      default: return corner();
    }
  }
  // The crossing and the short groove's abrupt ends step; the tapered end and the corner do not.
  bool stepped() const { return GetParam() == 0 || GetParam() == 2; }
  Vec3d view() const { return unit({0.35, -0.25, 1.0}); }
};

TEST_P(Layouts, PiecesTileTheRegionWithTheCompositeHeight) {
  auto gs = grooves();
  Surface s;
  Poly region = rect(-0.3, -0.3, 0.3, 0.3);
  ASSERT_TRUE(s.build(region, gs));
  double total = 0;
  size_t walls = 0;
  for (const Piece& p : s.pieces()) {
    EXPECT_GT(p.poly.area(), 0);
    if (p.wall) {
      ++walls;
      // Above the base plane a wall cuts pile-up: the top layer (as the 1-D sections' steps).
      double zmin = 1e300;
      for (int k = 0; k < p.poly.n; ++k) zmin = std::min(zmin, p.plane.at(p.poly.v[size_t(k)]));
      if (zmin > 1e-12) {
        EXPECT_EQ(p.layer, 0);
      }
    } else {
      total += p.poly.area();
    }
  }
  EXPECT_NEAR(total, region.area(), 1e-9);
  // Steps in the composite: a groove's edge against the other's pile-up (crossings) and the
  // abrupt ends; the tapered end has none. Each wall is at most two bands (below and above the
  // base plane) of at most three leaning triangles.
  EXPECT_EQ(s.walls().empty(), !stepped());
  EXPECT_LE(walls, 6 * s.walls().size());
  EXPECT_GE(walls, s.walls().size());
  for (const Surface::Wall& w : s.walls()) {
    // Each wall's foot and top are the composite's heights on either side of it.
    Vec2d m = (w.a + w.b) * 0.5, o = w.out * 1e-7;
    EXPECT_NEAR((w.za0 + w.zb0) * 0.5, composite(gs, m + o), 1e-6);
    EXPECT_NEAR((w.za1 + w.zb1) * 0.5, composite(gs, m - o), 1e-6);
  }
  for (int j = 0; j < 60; ++j)
    for (int i = 0; i < 60; ++i) {
      Vec2d p(-0.3 + (i + 0.37) * 0.01, -0.3 + (j + 0.61) * 0.01);
      int k = pieceAt(s, p);
      ASSERT_GE(k, 0);
      EXPECT_NEAR(s.pieces()[size_t(k)].plane.at(p), composite(gs, p), 1e-9) << p.x << " " << p.y;
    }
}

// Visible shares and lit fractions per piece normal against brute force over the footprint.
TEST_P(Layouts, VisibleAndLitSharesMatchRayMarching) {
  auto gs = grooves();
  Surface s;
  ASSERT_TRUE(s.build(rect(-0.4, -0.4, 0.4, 0.4), gs));
  Poly fp = rect(-0.06, -0.06, 0.06, 0.06);
  const Vec3d e = view();
  const Vec3d l = unit({-0.3, 1.0, 0.35});  // low light from +y
  std::vector<Portion> vis = s.visible(fp, e);
  double wsum = 0, lit = 0;
  for (const Portion& p : vis) {
    wsum += p.weight;
    lit += p.weight * s.litFraction(p, l);
  }
  // The shares sum to 1, walls included, up to the strips that the leaning walls count twice.
  double wall_share = 0;
  for (const Portion& p : vis) wall_share += s.pieces()[size_t(p.piece)].wall ? p.weight : 0.0;
  EXPECT_NEAR(wsum, 1.0, s.walls().empty() ? 1e-9 : 3e-4);
  EXPECT_EQ(wall_share > 0, stepped()) << wall_share;  // walls are seen where there are any
  // Brute force: a grid of viewing lines through the footprint; the first surface point along
  // each (marched down from above), then whether it sees the light.
  const int n = 80;
  int seen_lit = 0, seen_wall = 0;
  double zmax = 0.005;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      Vec2d u(-0.06 + 0.12 * (i + 0.5) / n, -0.06 + 0.12 * (j + 0.5) / n);
      // March from the top along -e until below the surface.
      double z = zmax, st = 2e-5;
      Vec2d p = u + Vec2d(e.x, e.y) * (zmax / e.z), prev = p;
      while (z > composite(gs, p)) {
        prev = p;
        p = p - Vec2d(e.x, e.y) * (st / e.z);
        z -= st;
      }
      if (composite(gs, p) - z > 4 * st) {
        // Stopped well below the surface: the line met a wall between prev and p. Its normal is
        // the horizontal direction in which the height drops (central differences across it).
        ++seen_wall;
        const double h = 5e-5;
        Vec2d g(composite(gs, prev + Vec2d(h, 0)) - composite(gs, prev - Vec2d(h, 0)),
                composite(gs, prev + Vec2d(0, h)) - composite(gs, prev - Vec2d(0, h)));
        if (-(g.x * l.x + g.y * l.y) > 0 && !blocked(gs, prev, z, l, zmax)) ++seen_lit;
        continue;
      }
      // Lit test from the surface point (slightly lifted).
      if (!blocked(gs, p, composite(gs, p) + 1e-6, l, zmax)) {
        int k = pieceAt(s, p);
        if (k >= 0 && s.pieces()[size_t(k)].plane.normal().x * l.x + s.pieces()[size_t(k)].plane.normal().y * l.y +
                              s.pieces()[size_t(k)].plane.normal().z * l.z > 0)
          ++seen_lit;
      }
    }
  double brute = double(seen_lit) / (n * n);
  EXPECT_NEAR(lit, brute, 0.02) << "lit share, polygons " << lit << " brute " << brute;
  EXPECT_NEAR(wall_share, double(seen_wall) / (n * n), 0.01);
  EXPECT_GT(brute, 0.3);
  EXPECT_LT(brute, 0.99);  // some of the footprint is in shadow
  EXPECT_EQ(s.overflow, 0u);
}

// Scattering conserves the portion's weight, and the hit share matches brute force.
TEST_P(Layouts, ScatterSharesMatchRayMarching) {
  auto gs = grooves();
  Surface s;
  ASSERT_TRUE(s.build(rect(-0.4, -0.4, 0.4, 0.4), gs));
  Poly fp = rect(-0.06, -0.06, 0.06, 0.06);
  std::vector<Portion> vis = s.visible(fp, {0, 0, 1});
  const Vec3d d = unit({0.2, 0.95, 0.25});
  double hit = 0, total = 0;
  for (const Portion& p : vis) {
    Hits h = s.scatter(p, d);
    double sum = h.escaped;
    for (const Portion& q : h.hits) sum += q.weight;
    const Vec3d n = s.pieces()[size_t(p.piece)].plane.normal();
    if (n.x * d.x + n.y * d.y + n.z * d.z > 0) {
      // Every ray leaving the portion either hits a piece (walls included) or escapes.
      EXPECT_NEAR(sum, p.weight, 1e-9 + 1e-6 * p.weight);
      total += p.weight;
      hit += p.weight - h.escaped;
    }
  }
  // Brute force over the same footprint seen head-on.
  const GridShares g = gridShares(s, d, +1, [&](Vec2d p) { return blocked(gs, p, composite(gs, p) + 1e-6, d, 0.005); });
  EXPECT_NEAR(total, g.side, 0.02);
  EXPECT_NEAR(hit, g.met, 0.02);
  EXPECT_GT(g.met, 0);
}

// Rays refracted into the solid (scatterInside): the share of each portion that meets the surface
// again from inside, against rays marched one by one from below the surface until they rise
// above it (a hit) or sink below every groove (escaped). One direction slants down under the
// pile-ups towards the grooves' walls; the other rises, into the pile-ups' slopes that face away
// from it, and leaves through their far sides or the walls beyond.
TEST_P(Layouts, ScatterInsideSharesMatchRayMarching) {
  auto gs = grooves();
  Surface s;
  ASSERT_TRUE(s.build(rect(-0.4, -0.4, 0.4, 0.4), gs));
  Poly fp = rect(-0.06, -0.06, 0.06, 0.06);
  std::vector<Portion> vis = s.visible(fp, {0, 0, 1});
  // Does the ray from (p, z) towards d, inside the solid, rise above the surface before it sinks
  // below every groove?
  auto exits = [&](Vec2d p, double z, Vec3d d) {
    const double step = 2e-5;
    for (double t = step; t < 1; t += step) {
      Vec2d q(p.x + d.x * t, p.y + d.y * t);
      double zr = z + d.z * t;
      if (zr < -0.025) return false;
      if (zr > composite(gs, q) + 1e-7) return true;
    }
    return false;
  };
  for (const Vec3d d : {unit({0.2, 0.95, -0.25}), unit({0.45, -0.85, 0.3})}) {
    double hit = 0, total = 0, on_walls = 0;
    for (const Portion& p : vis) {
      const Vec3d n = s.pieces()[size_t(p.piece)].plane.normal();
      Hits h = s.scatterInside(p, d);
      if (n.x * d.x + n.y * d.y + n.z * d.z >= 0) {
        EXPECT_TRUE(h.hits.empty() && h.escaped == 0) << "a ray out of the front side is scatter()'s";
        continue;
      }
      double sum = h.escaped;
      for (const Portion& q : h.hits) {
        sum += q.weight;
        if (s.pieces()[size_t(q.piece)].wall) on_walls += q.weight;
        // A hit lies where the ray meets the piece from below: the piece faces away from d.
        const Vec3d nq = s.pieces()[size_t(q.piece)].plane.normal();
        EXPECT_GT(nq.x * d.x + nq.y * d.y + nq.z * d.z, 0);
      }
      EXPECT_NEAR(sum, p.weight, 1e-9 + 1e-6 * p.weight);
      total += p.weight;
      hit += p.weight - h.escaped;
    }
    const GridShares g = gridShares(s, d, -1, [&](Vec2d p) { return exits(p, composite(gs, p) - 1e-6, d); });
    EXPECT_NEAR(total, g.side, 0.02) << d.z;
    EXPECT_NEAR(hit, g.met, 0.02) << d.z;
    EXPECT_GT(g.met, 0.003) << d.z;
    EXPECT_EQ(s.overflow, 0u);
    std::printf("[          ] d.z %.2f: back side %.4f, meets the surface again %.4f (marched %.4f), on walls %.4f\n", d.z,
                total, hit, g.met, on_walls);
  }
}

// The shadow polygons cached per piece and light give the lit fractions computed afresh.
TEST_P(Layouts, CachedShadowsGiveTheSameLitFractions) {
  auto gs = grooves();
  Surface s;
  ASSERT_TRUE(s.build(rect(-0.4, -0.4, 0.4, 0.4), gs));
  std::vector<Vec3d> lights = {unit({-0.3, 1.0, 0.35}), unit({0.9, 0.2, 0.3}), unit({0.1, -0.2, 1.0})};
  std::vector<Portion> vis = s.visible(rect(-0.06, -0.06, 0.06, 0.06), view());
  // Deeper-level portions too: what a reflection reaches.
  std::vector<Portion> all = vis;
  for (const Portion& p : vis)
    for (Portion& q : s.scatter(p, unit({0.2, 0.95, 0.25})).hits) all.push_back(std::move(q));
  s.cacheLights(lights.size());
  int partly = 0;
  for (int pass = 0; pass < 2; ++pass)  // the second pass reads the cache
    for (const Portion& p : all)
      for (size_t k = 0; k < lights.size(); ++k) {
        double fresh = s.litFraction(p, lights[k]), cached = s.litFraction(p, lights[k], k);
        EXPECT_NEAR(cached, fresh, 1e-12);
        partly += pass == 0 && fresh > 0.01 && fresh < 0.99;
      }
  EXPECT_GT(partly, 0);
}

// Grazing views, lights and reflections give finite shares in [0, 1] (digest §7).
TEST_P(Layouts, GrazingDirectionsStayFinite) {
  auto gs = grooves();
  Surface s;
  ASSERT_TRUE(s.build(rect(-0.4, -0.4, 0.4, 0.4), gs));
  for (double z : {1e-2, 1e-4, 1e-7}) {
    const Vec3d e = unit({0.6, -0.8, z}), l = unit({-0.8, 0.6, z});
    std::vector<Portion> vis = s.visible(rect(-0.06, -0.06, 0.06, 0.06), e);
    double wsum = 0;
    for (const Portion& p : vis) {
      ASSERT_TRUE(std::isfinite(p.weight));
      EXPECT_GE(p.weight, 0);
      wsum += p.weight;
      double lit = s.litFraction(p, l);
      ASSERT_TRUE(std::isfinite(lit));
      EXPECT_GE(lit, 0);
      EXPECT_LE(lit, 1);
      Hits h = s.scatter(p, l);
      ASSERT_TRUE(std::isfinite(h.escaped));
      for (const Portion& q : h.hits) ASSERT_TRUE(std::isfinite(q.weight));
    }
    EXPECT_LE(wsum, 1 + 2e-3) << "view elevation " << z;
  }
}

INSTANTIATE_TEST_SUITE_P(CrossingEndsAndCorner, Layouts, ::testing::Values(0, 1, 2, 3));

// A path that turns a corner: the pieces against the surface the explicit geometry cuts
// (Scratch::height: the profile at the signed distance to the path's closest point, which is the
// vertex itself on the corner's outer side), for turns either way from 30 to 179.8 degrees (a path
// that all but doubles back: its legs side by side, the bisector between them), and past
// kMaxCornerTurn up to a half turn (a path going back along itself: the leg before the vertex on
// both sides of its line, as the explicit geometry breaks the tie, and a half disc as the cap). The
// round outer side is a fan of 15-degree sectors: within 0.4 (the profile's steepest slope) x
// 0.07 mm (its half-width) x (1 / cos 7.5 degrees - 1) = 2.4e-4 mm of it. One straight groove
// through the vertex (the leg before it, carried on) is off by far more.
TEST(GrooveArea, ACornersPiecesFollowTheClosestPointOnThePath) {
  for (double turn : {30.0, 90.0, 150.0, 170.0, 177.0, 179.8, -60.0, -120.0, -179.0, 179.95, -179.9999, 180.0, -180.0}) {
    const Vec2d v(0.01, 0.02), ta = dirOf(10), tb = dirOf(10 + turn);
    auto [a, b] = legs(v, ta, tb);
    std::vector<Groove> parts;
    ASSERT_TRUE(cornerParts(a, b, 15 * M_PI / 180, parts));
    // Past 179.9 degrees a fan of a half turn; on one line, one leg.
    const bool back = std::fabs(turn) > 179.9, one_line = std::fabs(turn) == 180;
    EXPECT_EQ(parts.size(), (one_line ? 1 : 2) + size_t(std::ceil((back ? 180 : std::fabs(turn)) / 15 - 1e-9)));
    Groove g = ofParts(parts);
    Surface s, straight;
    ASSERT_TRUE(s.build(rect(-0.2, -0.2, 0.2, 0.2), {g}));
    Groove on = a;
    on.t_hi = 1e30;
    ASSERT_TRUE(straight.build(rect(-0.2, -0.2, 0.2, 0.2), {on}));
    EXPECT_TRUE(s.walls().empty());
    const ScratchPath path = ScratchPath::polyline({v - ta, v, v + tb});
    double area = 0;
    for (const Piece& pc : s.pieces()) area += pc.wall ? 0.0 : pc.poly.area();
    EXPECT_NEAR(area, 0.16, 1e-9);
    const double worst = offClosestProfile(s, path), worst_straight = offClosestProfile(straight, path);
    std::printf("[          ] turn %9.4f: %zu parts, height off by at most %.2e mm (one straight groove %.2e)\n", turn,
                parts.size(), worst, worst_straight);
    EXPECT_LT(worst, 2.5e-4) << "turn " << turn;
    EXPECT_GT(worst_straight, 0.01) << "turn " << turn;
  }
  // Straight on: no corner.
  std::vector<Groove> parts;
  auto [a, b] = legs({0, 0}, dirOf(10), dirOf(10));
  EXPECT_FALSE(cornerParts(a, b, 0.26, parts));
  EXPECT_TRUE(parts.empty());
}

// A path going back over itself, with a tilted tool's profile, whose two sides differ. With the
// legs on one line the cap beyond the vertex takes, on each side of the first leg's line, the
// profile's half on that side, as the explicit geometry measures the offset from the vertex with
// the first leg's sides; with one side's half over the whole cap, the heights were off by the
// difference of the two pile-ups. Just short of a half turn each leg holds its outer side, and the
// cap takes the outer half. (Within about 1e-5 rad of a half turn the reference itself is
// rounding: the two legs' float distances differ by less than their last bits.)
TEST(GrooveArea, AHalfTurnsCapTakesEachSideOfAnAsymmetricProfile) {
  for (double turn : {180.0, -180.0, 179.95}) {
    const Vec2d v(0.01, 0.02), ta = dirOf(10), tb = dirOf(10 + turn);
    auto [a, b] = legs(v, ta, tb);
    a.pts = b.pts = &kTiltedProfile;
    std::vector<Groove> parts;
    ASSERT_TRUE(cornerParts(a, b, 15 * M_PI / 180, parts));
    EXPECT_EQ(parts.size(), std::fabs(turn) == 180 ? 13u : 14u);
    Groove g = ofParts(parts);
    Surface s;
    ASSERT_TRUE(s.build(rect(-0.2, -0.2, 0.2, 0.2), {g}));
    const double worst = offClosestProfile(s, ScratchPath::polyline({v - ta, v, v + tb}), kTiltedProfile);
    std::printf("[          ] turn %9.4f: height off by at most %.2e mm\n", turn, worst);
    EXPECT_LT(worst, 4.5e-4) << "turn " << turn;  // (steepest slope 0.7: 0.7 x 0.07 x (1 / cos 7.5 degrees - 1))
  }
}

// Beyond a half turn the cap's two halves meet along the first leg's line with heights that differ
// by a profile's worth along it (P(r) on one side, P(-r) on the other): where the tilted tool's two
// pile-ups reach unlike distances, one side is flat where the other rises. The walls there are
// looked for along the whole line (Groove::split); with the three samples per edge that other
// edges take, the flat side's long edge missed the rise, and rays from it towards the line passed
// through the missing wall: 0.29 of a footprint's rays met the surface where 0.74 do. The share of
// each footprint's rays that meet the surface, against rays marched through the heights as the
// parts define them (composite(), independent of the pieces).
TEST(GrooveArea, AHalfTurnsStepHasItsWalls) {
  static const std::vector<Vec2d> lopsided = {{-0.09, 0}, {-0.075, 0.008}, {-0.06, 0}, {0.005, -0.04},
                                              {0.035, 0}, {0.045, 0.004}, {0.055, 0}};
  const Vec2d v(0.0, 0.0), ta = dirOf(10), tb = dirOf(190);
  auto [a, b] = legs(v, ta, tb);
  a.pts = b.pts = &lopsided;
  std::vector<Groove> parts;
  ASSERT_TRUE(cornerParts(a, b, 15 * M_PI / 180, parts));
  const std::vector<Groove> gs = {ofParts(parts)};
  Surface s;
  ASSERT_TRUE(s.build(rect(-0.3, -0.3, 0.3, 0.3), gs));
  double worst = 0;
  int compared = 0;
  for (Vec2d c : {Vec2d(0.05, 0.02), Vec2d(0.05, -0.02), Vec2d(0.04, 0.05), Vec2d(0.04, -0.05), Vec2d(0.07, 0.0)}) {
    const Poly fp = rect(c.x - 0.01, c.y - 0.01, c.x + 0.01, c.y + 0.01);
    const std::vector<Portion> vis = s.visible(fp, {0, 0, 1});
    for (double az = 0; az < 360; az += 30)
      for (double el : {10.0, 30.0}) {
        const double ca = std::cos(az * M_PI / 180), sa = std::sin(az * M_PI / 180), ce = std::cos(el * M_PI / 180);
        const Vec3d d = unit({ca * ce, sa * ce, std::sin(el * M_PI / 180)});
        double facing = 0, hit = 0;
        for (const Portion& p : vis) {
          const Vec3d n = s.pieces()[size_t(p.piece)].plane.normal();
          if (n.x * d.x + n.y * d.y + n.z * d.z <= 0) continue;
          facing += p.weight;
          hit += p.weight - s.scatter(p, d).escaped;
        }
        // (Rising at 10 degrees or more, a ray passes 0.02 mm, where it is marched no farther,
        // well inside the region.)
        const GridShares m = gridShares(s, d, +1, [&](Vec2d p) { return blocked(gs, p, composite(gs, p) + 1e-7, d, 0.02); },
                                        c, 0.01, 40);
        if (!(facing > 0.2 && m.side > 0)) continue;
        ++compared;
        worst = std::max(worst, std::fabs(hit / facing - m.met / m.side));
        EXPECT_NEAR(hit / facing, m.met / m.side, 0.05)
            << "footprint at " << c.x << ", " << c.y << ", direction azimuth " << az << " elevation " << el;
      }
  }
  std::printf("[          ] %d footprints and directions, hit shares off by at most %.3f\n", compared, worst);
  EXPECT_GT(compared, 50);
}

// A path that turns at several corners within the region: a U-turn made of two corners, a hook,
// a zigzag, three corners in a row. chainParts gives the explicit geometry's surface (the profile
// at the signed distance to the path's closest point) within the fans' bound, as
// ACornersPiecesFollowTheClosestPointOnThePath does for one corner; the groove of the middle
// corner alone (cornerParts, its legs stopping at the next corners) is off by far more, where a
// leg stops inside the groove or the other leg's pile-up is missing.
TEST(GrooveArea, AChainOfCornersFollowsTheClosestPointOnThePath) {
  struct Case {
    const char* name;
    std::vector<Vec2d> pts;  // the corners; the path comes from far away and leaves far away
    Vec2d in, out;           // its directions before the first corner and after the last
    bool float_dirs = false;  // each leg's direction and normal rounded to float, as the integrator's frames are
  };
  const Case cases[] = {
      {"U-turn, legs 0.1 apart", {{0.03, -0.05}, {0.03, 0.05}}, dirOf(0), dirOf(180)},
      {"hook, 41 and -161 degrees", {{-0.02, -0.03}, {0.03, 0.0}}, dirOf(-10), dirOf(230)},
      {"zigzag, -154 and 144 degrees", {{-0.04, 0.0}, {0.03, 0.02}}, dirOf(170), dirOf(160)},
      {"three corners, 80, -95 and -75 degrees", {{-0.05, -0.02}, {0.0, 0.04}, {0.05, -0.01}}, dirOf(-30), dirOf(-120)},
      {"Z, -45 and 45 degrees", {{-0.02, 0.02}, {0.03, -0.03}}, dirOf(0), dirOf(0)},
      // A path going back along itself for 0.05 mm, then away: the two legs on one line, the
      // earlier holding what they share (as the explicit geometry breaks the tie).
      {"half turn, then -90 degrees", {{0.03, 0.0}, {-0.02, 0.0}}, dirOf(0), dirOf(90)},
      {"half turn, then 90 degrees, float frames", {{0.03, 0.01}, Vec2d(0.03, 0.01) - dirOf(20) * 0.05}, dirOf(20),
       dirOf(290), true},
  };
  const Poly region = rect(-0.2, -0.2, 0.2, 0.2);
  for (const Case& c : cases) {
    const size_t m = c.pts.size();
    std::vector<Vec2d> path_pts{c.pts.front() - c.in * 20};
    for (const Vec2d& p : c.pts) path_pts.push_back(p);
    path_pts.push_back(c.pts.back() + c.out * 20);
    const ScratchPath path = ScratchPath::polyline(path_pts);
    ASSERT_EQ(path.corners().size(), m) << c.name;
    // Leg k runs from path_pts[k] to path_pts[k + 1]; leg 0 has t = 0 at its end, the others at
    // their start.
    std::vector<Groove> legs_of;
    for (size_t k = 0; k <= m; ++k) {
      const Vec2d a = path_pts[k], b = path_pts[k + 1], d = b - a;
      const double len = std::hypot(d.x, d.y);
      const Vec2d t = d * (1 / len), o = k == 0 ? b : a;
      Groove g = along(t, 0, 3);
      if (c.float_dirs) {
        g.tdir = Vec2d(double(float(t.x)), double(float(t.y)));
        g.bdir = Vec2d(double(float(-t.y)), double(float(t.x)));
      }
      g.t0 = -(t.x * o.x + t.y * o.y);
      g.b0 = -(g.bdir.x * o.x + g.bdir.y * o.y);
      g.t_lo = k == 0 ? -len : 0;
      g.t_hi = k == 0 ? 0 : len;
      legs_of.push_back(g);
    }
    std::vector<Groove> parts;
    ASSERT_TRUE(chainParts(legs_of, 15 * M_PI / 180, region, parts)) << c.name;
    Groove g = ofParts(parts, 3);
    Surface s;
    ASSERT_TRUE(s.build(region, {g})) << c.name;
    EXPECT_TRUE(s.walls().empty()) << c.name;
    double area = 0;
    for (const Piece& pc : s.pieces()) area += pc.wall ? 0.0 : pc.poly.area();
    EXPECT_NEAR(area, 0.16, 1e-9) << c.name;
    // The middle corner alone, its legs stopping at the corners next to it.
    const size_t mid = (m - 1) / 2;
    std::vector<Groove> one_parts;
    Groove a = legs_of[mid], b = legs_of[mid + 1];
    if (mid > 0) {  // a as cornerParts wants it: t = 0 at its end
      const double len = a.t_hi;
      a.t0 -= len;
      a.t_lo = -len;
      a.t_hi = 0;
    }
    ASSERT_TRUE(cornerParts(a, b, 15 * M_PI / 180, one_parts));
    Groove one = ofParts(one_parts);
    Surface s1;
    ASSERT_TRUE(s1.build(region, {one}));
    const double worst = offClosestProfile(s, path), worst_one = offClosestProfile(s1, path);
    std::printf("[          ] %s: %zu parts, height off by at most %.2e mm (one corner %.2e)\n", c.name, parts.size(),
                worst, worst_one);
    EXPECT_LT(worst, 2.5e-4) << c.name;
    EXPECT_GT(worst_one, 2e-3) << c.name;
  }
}

// The legs between a path's bends over the window `span` (ScratchPath::bendsAround), as kProfile
// grooves of id 3: each leg's positions are the projections of the path's points on it (the
// integrator's chainGroove with chords). With `float_dirs`, each leg's direction and normal are
// rounded to float, as the integrator's frames give them (its offsets stay exact).
std::vector<Groove> legsOfBends(const ScratchPath& path, const std::vector<ScratchPath::Corner>& bends,
                                std::pair<double, double> span, bool float_dirs = false) {
  std::vector<Groove> legs;
  for (size_t j = 0; j <= bends.size(); ++j) {
    const ScratchPath::Corner& k = bends[j == 0 ? 0 : j - 1];
    const Vec2d t = j == 0 ? k.t_in : k.t_out;
    Groove g = along(t, 0, 3);
    if (float_dirs) {
      g.tdir = Vec2d(double(float(t.x)), double(float(t.y)));
      g.bdir = Vec2d(double(float(-t.y)), double(float(t.x)));
    }
    g.t0 = -(t.x * k.p.x + t.y * k.p.y);
    g.b0 = -(g.bdir.x * k.p.x + g.bdir.y * k.p.y);
    auto at = [&](Vec2d q) { return (q.x - k.p.x) * t.x + (q.y - k.p.y) * t.y; };
    g.t_lo = j == 0 ? at(path.pointAt(span.first)) : 0;
    g.t_hi = j == 0 ? 0 : at(j < bends.size() ? bends[j].p : path.pointAt(span.second));
    legs.push_back(g);
  }
  return legs;
}

// Curves flattened into turns below a corner's (ScratchPath::bendsAround): a tight U-turn of a
// cubic, a small loop that crosses itself and a quarter circle 0.1 mm in radius. Their bends, as
// legs between the kept vertices (positions along a leg are the projections of the path's points:
// the integrator's chainGroove with chords), give through chainParts the explicit geometry's
// surface within the simplification's tolerance times the profile's steepest slope; the tangent at
// the closest point alone (a straight groove) is off by far more.
TEST(GrooveArea, BendsOfACurveFollowTheClosestPointOnThePath) {
  struct Case {
    const char* name;
    ScratchPath path;  // mm, the region about the origin
  };
  const Case cases[] = {
      {"U-turn of a cubic, 0.05 mm in radius (its vertices corners)",
       ScratchPath::bezier({{-3, -0.04}, {-2, -0.04}, {-1, -0.04}, {0, -0.04}, {0.07, -0.04}, {0.07, 0.06}, {0, 0.06},
                            {-1, 0.06}, {-2, 0.06}, {-3, 0.06}})},
      {"loop of a cubic", ScratchPath::bezier({{-2, -1}, {0.35, 0.3}, {-0.35, 0.3}, {2, -1}})},
      {"arc 0.3 mm in radius (no corners)", ScratchPath::arc({0, -0.3}, 0.3, M_PI / 6, 2 * M_PI / 3)},
  };
  const Poly region = rect(-0.2, -0.2, 0.2, 0.2);
  const double tol = 2e-3;
  for (const Case& c : cases) {
    const ScratchPath& path = c.path;
    const PathPoint pp = path.closest(Vec2f(0, 0));
    std::vector<ScratchPath::Corner> bends;
    std::pair<double, double> span;
    ASSERT_TRUE(path.bendsAround(double(pp.s), {0, 0}, 0.3, 0.5 * tol, 0.0, 0.0, 12, M_PI, bends, span)) << c.name;
    const std::vector<Groove> legs_of = legsOfBends(path, bends, span);
    std::vector<Groove> parts;
    ASSERT_TRUE(chainParts(legs_of, 15 * M_PI / 180, region, parts)) << c.name << ", " << bends.size() << " bends";
    Groove g = ofParts(parts, 3);
    Surface s;
    ASSERT_TRUE(s.build(region, {g})) << c.name;
    // The tangent at the closest point alone.
    Groove straight = along(Vec2d(double(pp.tangent.x), double(pp.tangent.y)), double(pp.offset), 3);
    Surface s1;
    ASSERT_TRUE(s1.build(region, {straight}));
    const double worst = offClosestProfile(s, path), worst_straight = offClosestProfile(s1, path);
    std::printf("[          ] %s: %zu bends, %zu parts, height off by at most %.2e mm (tangent %.2e)\n", c.name,
                bends.size(), parts.size(), worst, worst_straight);
    EXPECT_LT(worst, 0.4 * tol) << c.name;
    EXPECT_GT(worst_straight, 4e-3) << c.name;
  }
}

// Half a convex polygon's perimeter: a strip's length.
double lengthOf(const Poly& p) {
  double per = 0;
  for (int i = 0; i < p.n; ++i) {
    const Vec2d d = p.v[size_t((i + 1) % p.n)] - p.v[size_t(i)];
    per += std::hypot(d.x, d.y);
  }
  return 0.5 * per;
}
// Its width across its narrowest direction, about: its area over its length (a strip's width,
// half a thin wedge's widest).
double widthOf(const Poly& p) {
  const double len = lengthOf(p);
  return len > 0 ? p.area() / len : 0;
}

// Lines of a chain's partition that are one line in exact arithmetic (a leg's end normal and the
// edge of its corner's fan, each computed in its own frame) cross at a tiny angle or run a
// rounding apart. Cut as they are, they left strips picometres wide that went to whichever
// candidate still held them, often a far pass with another height there: on the accuracy test's
// `curl` 12% of the surface's pieces, and fins that stood in the light's way on the fuzzer's
// p1_11. No part's domain over the region is thinner than kThinCut / 2, and no piece of the
// surface as thin is longer than 1e-5 mm (where several lines meet, a piece can be a speck).
TEST(GrooveArea, AChainsPartitionHasNoSlivers) {
  const ScratchPath paths[] = {
      ScratchPath::bezier({{-2, -1}, {0.35, 0.3}, {-0.35, 0.3}, {2, -1}}),
      ScratchPath::bezier({{-3, -0.04}, {-2, -0.04}, {-1, -0.04}, {0, -0.04}, {0.07, -0.04}, {0.07, 0.06}, {0, 0.06},
                           {-1, 0.06}, {-2, 0.06}, {-3, 0.06}}),
      ScratchPath::arc({0, -0.3}, 0.3, M_PI / 6, 2 * M_PI / 3),
  };
  const Poly region = rect(-0.3, -0.3, 0.3, 0.3);
  size_t total = 0;
  double thinnest_part = 1e300, longest_thin = 0;
  for (const ScratchPath& path : paths)
    for (double tol : {2e-4, 5e-4, 1e-3})
      for (int fp = 0; fp < 5; ++fp) {
        const Vec2d F(0.01 * fp, -0.007 * fp);
        const PathPoint pp = path.closest(Vec2f(float(F.x), float(F.y)));
        std::vector<ScratchPath::Corner> bends;
        std::pair<double, double> span;
        if (!path.bendsAround(double(pp.s), F, 0.4, tol, 0.0, 0.0, 16, M_PI, bends, span)) continue;
        std::vector<Groove> parts;
        if (!chainParts(legsOfBends(path, bends, span, true), 15 * M_PI / 180, region, parts)) continue;
        for (const Groove& q : parts) {
          Poly d = region;
          for (int k = 0; k < q.n_dom && !d.empty(); ++k) d = clip(d, q.dom[k].a, q.dom[k].c);
          if (!d.empty()) thinnest_part = std::min(thinnest_part, widthOf(d));
        }
        Groove g = ofParts(parts, 3);
        Surface s;
        if (!s.build(rect(-0.15, -0.15, 0.15, 0.15), {g})) continue;
        for (const Piece& pc : s.pieces())
          if (!pc.wall && widthOf(pc.poly) < 5e-8) longest_thin = std::max(longest_thin, lengthOf(pc.poly));
        total += parts.size();
      }
  std::printf("[          ] %zu parts: the thinnest %.2e mm wide; pieces under 5e-8 mm wide at most %.2e mm long\n",
              total, thinnest_part, longest_thin);
  EXPECT_GT(total, 5000u);
  EXPECT_GT(thinnest_part, 5e-8);
  EXPECT_LT(longest_thin, 1e-5);
}

// above(p, z), which the wall search asks of every piece's edges, stops at the first groove that
// settles it; it must say what heightAt(p) > z says, on every side of every kind of height: over a
// crossing and a chain of bends, for levels below, at and above the composite and about the base.
TEST(GrooveArea, AboveAgreesWithTheHeight) {
  const ScratchPath path = ScratchPath::bezier({{-2, -1}, {0.35, 0.3}, {-0.35, 0.3}, {2, -1}});
  const PathPoint pp = path.closest(Vec2f(0, 0));
  std::vector<ScratchPath::Corner> bends;
  std::pair<double, double> span;
  ASSERT_TRUE(path.bendsAround(double(pp.s), {0, 0}, 0.3, 2.5e-4, 0.0, 0.0, 16, M_PI, bends, span));
  std::vector<Groove> parts;
  ASSERT_TRUE(chainParts(legsOfBends(path, bends, span), 15 * M_PI / 180, rect(-0.3, -0.3, 0.3, 0.3), parts));
  std::vector<Groove> gs = crossing();
  gs.push_back(ofParts(parts, 3));
  Surface s;
  ASSERT_TRUE(s.build(rect(-0.2, -0.2, 0.2, 0.2), gs, Surface::kMaxPiecesClose));
  int n = 0, below = 0, up = 0;
  for (int j = 0; j <= 50; ++j)
    for (int i = 0; i <= 50; ++i) {
      const Vec2d p(-0.2 + 0.4 * (i + 0.29) / 51, -0.2 + 0.4 * (j + 0.53) / 51);
      const double h = s.heightAt(p);
      below += h < 0;
      up += h > 0;
      for (double z : {h - 1e-3, std::nextafter(h, -1.0), h, std::nextafter(h, 1.0), h + 1e-3, -0.05, -1e-12, 0.0,
                       1e-12, 0.05}) {
        ASSERT_EQ(s.above(p, z), h > z) << p.x << " " << p.y << " z " << z << " h " << h;
        ++n;
      }
    }
  EXPECT_EQ(n, 26010);
  // Both kinds of composite were met: inside the grooves and on their pile-ups.
  EXPECT_GT(below, 200);
  EXPECT_GT(up, 200);
}

// The composite height at p with grooves of parts: each part's height where its domain holds p
// (the first such part), from the grooves' definitions alone.
double compositeOfParts(const std::vector<Groove>& gs, Vec2d p) {
  double lo = 0, hi = 0;
  for (const Groove& g : gs) {
    const Groove* q = &g;
    if (g.parts) {
      q = nullptr;
      for (const Groove& part : *g.parts) {
        bool holds = true;
        for (int k = 0; k < part.n_dom && holds; ++k) holds = part.dom[k].holds(p);
        if (holds) {
          q = &part;
          break;
        }
      }
      if (!q) continue;
    }
    const double h = grooveHeight(*q, p);
    lo = std::min(lo, h);
    hi = std::max(hi, h);
  }
  return lo < 0 ? lo : hi;
}

// Every piece edge of s (within `half` of the centre) whose far side stands higher than the piece
// by 1e-6 mm, at its midpoint or near its ends, with a wall along it facing the piece, up to that
// height? Counts the edges looked at, the steps found and the steps without a wall.
struct StepCount {
  int edges = 0, steps = 0, missing = 0;
};
StepCount stepsAndWalls(const Surface& s, const std::vector<Groove>& gs, double half) {
  StepCount c;
  for (const Piece& pc : s.pieces()) {
    if (pc.wall) continue;
    for (int k = 0; k < pc.poly.n; ++k) {
      const Vec2d e0 = pc.poly.v[size_t(k)], e1 = pc.poly.v[size_t((k + 1) % pc.poly.n)];
      const Vec2d t = e1 - e0;
      const double len = std::hypot(t.x, t.y);
      if (!(len > 1e-6)) continue;
      const Vec2d n(t.y / len, -t.x / len);
      ++c.edges;
      for (double f : {0.01, 0.5, 0.99}) {
        const Vec2d m = e0 + t * f;
        const double beyond = compositeOfParts(gs, m + n * 1e-9), here = pc.plane.at(m);
        if (std::fabs(m.x) > half || std::fabs(m.y) > half || !(beyond > here + 1e-6)) continue;
        ++c.steps;
        bool found = false;
        for (const Surface::Wall& w : s.walls()) {
          const Vec2d ab = w.b - w.a;
          const double l2 = ab.x * ab.x + ab.y * ab.y;
          const double u = ((m.x - w.a.x) * ab.x + (m.y - w.a.y) * ab.y) / l2;
          const Vec2d foot = w.a + ab * u;
          if (u < -1e-9 || u > 1 + 1e-9 || std::hypot(foot.x - m.x, foot.y - m.y) > 1e-9) continue;
          if (w.out.x * n.x + w.out.y * n.y > -0.999) continue;
          found = found || std::fabs(w.za1 + (w.zb1 - w.za1) * u - beyond) < 1e-6;
        }
        c.missing += !found;
        EXPECT_TRUE(found) << "a step of " << beyond - here << " mm at " << m.x << " " << m.y;
      }
    }
  }
  return c;
}

// Surface::build asks for a step only along the edges that can have one (a piece below the base
// within kDeep of it, or with an end on an end line; with grooves of parts, also every edge that
// is not well inside one part of each). Over six grooves through one spot, some ending abruptly
// and some tapering, every step up beyond a piece edge has its wall.
TEST(GrooveArea, EveryStepUpHasItsWall) {
  std::vector<Groove> gs;
  for (int i = 0; i < 6; ++i) {
    Groove g = along(dirOf(17 + 29 * i), 0.004 * (i - 2.5), i);
    if (i % 3 == 1) g.t_hi = 0.02 + 0.01 * i;      // an abrupt end in the region
    if (i % 3 == 2) g.rho = -6, g.t_hi = 0.2;  // a tapered one
    gs.push_back(g);
  }
  Surface s;
  ASSERT_TRUE(s.build(rect(-0.12, -0.12, 0.12, 0.12), gs, Surface::kMaxPiecesClose));
  const StepCount c = stepsAndWalls(s, gs, 0.119);
  // Both the grooves' edges against pile-ups and the abrupt ends step.
  EXPECT_GT(c.edges, 400);
  EXPECT_GT(c.steps, 60);
  EXPECT_EQ(c.missing, 0);
}

// The same with a corner's groove among them: a path turning by 120 degrees next to the spot,
// crossed by four straight grooves, two of them ending abruptly. Its first part (a leg) is given a
// profile 1.5 times as deep, so that it steps down from the parts next to it on their seams, as the
// parts of a chain of bends do where the force changes from one bend to the next: the wall search
// must ask the edges on the seams even where the piece lies deep in a groove.
TEST(GrooveArea, EveryStepUpHasItsWallWithACorner) {
  std::vector<Groove> parts;
  auto [a, b] = legs({0.01, -0.005}, dirOf(20), dirOf(-100));
  ASSERT_TRUE(cornerParts(a, b, 15 * M_PI / 180, parts));
  static std::vector<Vec2d> deeper;
  deeper.clear();
  for (const Vec2d& q : kProfile) deeper.push_back(Vec2d(q.x, 1.5 * q.y));
  parts.front().pts = &deeper;
  std::vector<Groove> gs = {ofParts(parts, 0)};
  for (int i = 0; i < 4; ++i) {
    Groove g = along(dirOf(63 + 37 * i), 0.006 * (i - 1.5), i + 1);
    if (i % 2 == 1) g.t_hi = 0.015 + 0.01 * i;  // an abrupt end in the region
    gs.push_back(g);
  }
  Surface s;
  ASSERT_TRUE(s.build(rect(-0.12, -0.12, 0.12, 0.12), gs, Surface::kMaxPiecesClose));
  const StepCount c = stepsAndWalls(s, gs, 0.119);
  std::printf("[          ] %zu parts, %d edges, %d steps, %d without a wall\n", parts.size(), c.edges, c.steps,
              c.missing);
  EXPECT_GT(c.edges, 400);
  EXPECT_GT(c.steps, 40);
  EXPECT_EQ(c.missing, 0);
}

// Up to kMaxGrooves (16) grooves make one surface: the cells of more than kSmallGrooves (8) hold
// the larger arrays of planes. Twelve grooves through one spot (some ending abruptly, some
// tapering) give pieces that tile the region with the composite's height everywhere and a wall at
// every step up; with one groove more than the cap, build() refuses.
TEST(GrooveArea, TwelveGroovesMakeOneSurface) {
  std::vector<Groove> gs;
  for (int i = 0; i < 12; ++i) {
    Groove g = along(dirOf(11 + 15 * i), 0.005 * (i - 5.5), i);
    if (i % 4 == 1) g.t_hi = 0.03 + 0.005 * i;  // an abrupt end in the region
    if (i % 4 == 3) g.rho = -5, g.t_hi = 0.2;   // a tapered one
    gs.push_back(g);
  }
  static_assert(Surface::kMaxGrooves >= 12 && Surface::kSmallGrooves < 12, "the test needs the larger cells");
  Surface s;
  ASSERT_TRUE(s.build(rect(-0.1, -0.1, 0.1, 0.1), gs, Surface::kMaxPiecesClose));
  double area = 0;
  for (const Piece& pc : s.pieces())
    if (!pc.wall) area += pc.poly.area();
  EXPECT_NEAR(area, 0.04, 1e-9);
  double worst = 0;
  for (int j = 0; j < 60; ++j)
    for (int i = 0; i < 60; ++i) {
      const Vec2d p(-0.1 + (i + 0.37) * 0.2 / 60, -0.1 + (j + 0.61) * 0.2 / 60);
      const int k = pieceAt(s, p);
      ASSERT_GE(k, 0);
      worst = std::max(worst, std::fabs(s.pieces()[size_t(k)].plane.at(p) - composite(gs, p)));
    }
  EXPECT_LT(worst, 1e-9);
  const StepCount c = stepsAndWalls(s, gs, 0.099);
  std::printf("[          ] %zu pieces, %zu walls, %d steps up, %d without a wall, heights off by %.1e mm\n",
              s.pieces().size(), s.walls().size(), c.steps, c.missing, worst);
  EXPECT_GT(c.steps, 20);
  EXPECT_EQ(c.missing, 0);
  std::vector<Groove> more = gs;
  while (more.size() <= Surface::kMaxGrooves) more.push_back(along(dirOf(double(more.size())), 0.02, int(more.size())));
  EXPECT_FALSE(s.build(rect(-0.1, -0.1, 0.1, 0.1), more, Surface::kMaxPiecesClose));
}

// A chain of bends has tens to hundreds of parts; Surface finds the part that holds a point through a grid
// of the parts' boxes over its region (heightAt, and the cells of build). Over a small region and
// over a large one (other bins, other boxes) it gives the same height to the last bit, inside the
// small region, just outside it (1e-9 mm, where the walls are looked for) and far outside (every
// part tried), and that height is the explicit geometry's within the bends' tolerance.
TEST(GrooveArea, TheGridOfPartsFindsThePartThatHoldsAPoint) {
  const ScratchPath path = ScratchPath::bezier({{-2, -1}, {0.35, 0.3}, {-0.35, 0.3}, {2, -1}});
  const PathPoint pp = path.closest(Vec2f(0, 0));
  std::vector<ScratchPath::Corner> bends;
  std::pair<double, double> span;
  const double tol = 5e-4;
  ASSERT_TRUE(path.bendsAround(double(pp.s), {0, 0}, 0.3, 0.5 * tol, 0.0, 0.0, 16, M_PI, bends, span));
  const std::vector<Groove> legs_of = legsOfBends(path, bends, span);
  std::vector<Groove> parts;
  ASSERT_TRUE(chainParts(legs_of, 15 * M_PI / 180, rect(-0.3, -0.3, 0.3, 0.3), parts));
  ASSERT_GE(parts.size(), Surface::kPartsIndexed);
  Groove g = ofParts(parts, 3);
  Surface small, large;
  const Poly small_region = rect(-0.04, -0.03, 0.05, 0.06);
  ASSERT_TRUE(small.build(small_region, {g}));
  ASSERT_TRUE(large.build(rect(-0.2, -0.2, 0.2, 0.2), {g}));
  double worst = 0;
  int n = 0, differ = 0;
  auto check = [&](Vec2d p) {
    const double hs = small.heightAt(p), hl = large.heightAt(p);
    differ += hs != hl;
    worst = std::max(worst, std::fabs(hs - profileAt(double(path.closest(Vec2f(float(p.x), float(p.y))).offset))));
    ++n;
  };
  for (int j = 0; j <= 60; ++j)
    for (int i = 0; i <= 60; ++i) check(Vec2d(-0.15 + 0.3 * (i + 0.37) / 61, -0.15 + 0.3 * (j + 0.61) / 61));
  // Along the small region's edges, 1e-9 mm outside.
  for (int k = 0; k < small_region.n; ++k) {
    const Vec2d a = small_region.v[size_t(k)], b = small_region.v[size_t((k + 1) % small_region.n)];
    const Vec2d t = b - a, out = Vec2d(t.y, -t.x) * (1e-9 / std::hypot(t.x, t.y));
    for (int i = 0; i < 50; ++i) check(a + t * ((i + 0.5) / 50) + out);
  }
  std::printf("[          ] %zu parts, %d points: %d heights differ, off the explicit geometry by at most %.2e mm\n",
              parts.size(), n, differ, worst);
  EXPECT_EQ(differ, 0);
  EXPECT_LT(worst, 0.4 * tol);
}

// A path that passes the region twice, with its vertices far outside it: a loop that crosses
// itself at 40 and 90 degrees, a hairpin whose legs' pile-ups overlap (0.11 mm apart, each 0.14
// mm wide) and one whose legs are 3 degrees apart. The surface of passParts is the explicit
// geometry's (the profile at the path's closest point) to rounding; two grooves composited, as two
// scratches would be, stand one pass's pile-up over the other's groove.
TEST(GrooveArea, APathsTwoPassesEachHoldWhereTheyAreTheNearer) {
  // Each pass: a point on it and its direction; the path runs along the first, turns far away
  // and comes back along the second.
  struct Case {
    const char* name;
    Vec2d pa, ta, pb, tb;
  };
  const Case cases[] = {
      {"crossing at 40 degrees", {0.01, -0.005}, dirOf(20), {0.01, -0.005}, dirOf(160)},
      {"crossing at 90 degrees", {-0.02, 0.01}, dirOf(-45), {-0.02, 0.01}, dirOf(225)},
      {"hairpin", {0, 0.055}, dirOf(0), {0, -0.055}, dirOf(180)},
      {"hairpin, 3 degrees", {0, 0.055}, dirOf(1.5), {0, -0.055}, dirOf(178.5)},
  };
  for (const Case& c : cases) {
    auto pass = [](Vec2d p, Vec2d t) {
      Groove g = along(t, 0, 7);
      g.t0 = -(t.x * p.x + t.y * p.y);
      g.b0 = -(g.bdir.x * p.x + g.bdir.y * p.y);
      return g;
    };
    const Groove a = pass(c.pa, c.ta), b = pass(c.pb, c.tb);
    std::vector<Groove> parts;
    ASSERT_TRUE(passParts(a, b, parts));
    ASSERT_EQ(parts.size(), 4u);
    Groove g = ofParts(parts, 7);
    Surface s, composite;
    ASSERT_TRUE(s.build(rect(-0.2, -0.2, 0.2, 0.2), {g}));
    ASSERT_TRUE(composite.build(rect(-0.2, -0.2, 0.2, 0.2), {a, b}));
    double area = 0;
    for (const Piece& pc : s.pieces()) area += pc.wall ? 0.0 : pc.poly.area();
    EXPECT_NEAR(area, 0.16, 1e-9) << c.name;
    // The path: out along pass a, round far outside the region, back along pass b.
    const Vec2d a0 = c.pa - c.ta * 20, a1 = c.pa + c.ta * 20, b0 = c.pb - c.tb * 20, b1 = c.pb + c.tb * 20;
    const ScratchPath path = ScratchPath::polyline({a0, a1, b0, b1});
    const double worst = offClosestProfile(s, path), worst_composite = offClosestProfile(composite, path);
    std::printf("[          ] %s: height off by at most %.2e mm (composite %.2e)\n", c.name, worst, worst_composite);
    EXPECT_LT(worst, 1e-5) << c.name;
    EXPECT_GT(worst_composite, 1e-3) << c.name;
  }
  // A path going back over itself: the same line twice, either way round, is no pair of passes.
  std::vector<Groove> parts;
  const Groove g = along(dirOf(30), 0.01, 7);
  Groove back = along(dirOf(210), -0.01, 7);
  EXPECT_FALSE(passParts(g, back, parts));
  EXPECT_FALSE(passParts(g, g, parts));
  EXPECT_TRUE(parts.empty());
}

// Three passes of one path (a path going back and forth, its vertices far outside the region;
// legs 0.11 mm apart at the centre, their pile-ups overlapping, the middle one tilted): chainParts
// with each pass a run of one leg (as the integrator builds three or more straight passes) gives
// the explicit geometry's surface to rounding; two passes split by passParts and the third
// composited with them do not.
TEST(GrooveArea, ThreePassesOfAPathAreOnePartition) {
  auto pass = [](Vec2d p, Vec2d t) {
    Groove g = along(t, 0, 7);
    g.t0 = -(t.x * p.x + t.y * p.y);
    g.b0 = -(g.bdir.x * p.x + g.bdir.y * p.y);
    return g;
  };
  const Vec2d pa(0, 0.11), ta = dirOf(0), pb(0, 0), tb = dirOf(180.4), pc(0, -0.11), tc = dirOf(0.2);
  const Groove a = pass(pa, ta), b = pass(pb, tb), c = pass(pc, tc);
  std::vector<Groove> parts, pair;
  const Poly region = rect(-0.2, -0.2, 0.2, 0.2);
  ASSERT_TRUE(chainParts({a, b, c}, 15 * M_PI / 180, region, parts, {1, 2}));
  ASSERT_TRUE(passParts(a, b, pair));
  const Groove g = ofParts(parts, 7), ab = ofParts(pair, 7);
  Surface s, two;
  ASSERT_TRUE(s.build(region, {g}));
  ASSERT_TRUE(two.build(region, {ab, c}));
  const ScratchPath path =
      ScratchPath::polyline({pa - ta * 20, pa + ta * 20, pb - tb * 20, pb + tb * 20, pc - tc * 20, pc + tc * 20});
  const double worst = offClosestProfile(s, path), worst_two = offClosestProfile(two, path);
  std::printf("[          ] %zu parts: height off by at most %.2e mm (two split, the third composited: %.2e)\n",
              parts.size(), worst, worst_two);
  EXPECT_LT(worst, 1e-6);
  EXPECT_GT(worst_two, 1e-3);
}

// A path's sharp corner (163 degrees, its round outer side a fan of eleven sectors) with a later
// pass of the path running straight across both its legs 0.12 mm from the vertex, their pile-ups
// overlapping: the corner fuzzer's c47_4, its legs exactly as the integrator gave them to
// chainParts in one footprint seen at 2 degrees. chainParts with the pass and the corner's legs as
// two runs gives each point the cross-section of the nearer pass, as the explicit geometry does.
// The out-leg's cell at the vertex keeps every sector's edge (12 lines through the vertex, left as
// a cluster of points a rounding apart), more than Groove::kMaxDom allowed until 2026-12-01 (10):
// chainParts refused the chain, the two passes were composited, and the pass's pile-up stood up
// to 0.035 mm over the corner's groove. The light it mirrored made 0.26% of c47_4's pixels >= 10.
TEST(GrooveArea, ACornerAndAPassAcrossItsLegsAreOnePartition) {
  // The profile (c47_4's 2.8 kg on HV 20) at the pass's scale, and scaled to the corner's legs.
  const std::vector<Vec2d> at_pass = {
      {-0.14260803176115402, 0},        {-0.11830170256410152, 0.038192852120949035},
      {-0.072785233429348256, 0},       {-0.0014012148041347722, -0.059898303163199183},
      {-0.00074557082391304638, -0.060276839388777502}, {0, -0.060408303640213733},
      {0.00074557082391304638, -0.060276839388777502},  {0.0014012148041347722, -0.059898303163199183},
      {0.072785233429348242, 0},        {0.1183017025641015, 0.038192852120949035},
      {0.142608031761154, 0}};
  auto scaled = [&](double k) {
    std::vector<Vec2d> p = at_pass;
    for (Vec2d& v : p) v = v * k;
    return p;
  };
  const std::vector<Vec2d> at_c1 = scaled(0.14095594431494085 / 0.142608031761154),
                           at_c2 = scaled(0.13455793847468545 / 0.142608031761154);
  const std::vector<int> layers(at_pass.size() - 1, 0);
  auto leg = [&](Vec2d t, double t0, double b0, double rho, double t_lo, double t_hi, const std::vector<Vec2d>& pts) {
    Groove g = along(t, b0, 7);
    g.pts = &pts;
    g.layer = &layers;
    g.t0 = t0;
    g.rho = rho;
    g.t_lo = t_lo;
    g.t_hi = t_hi;
    return g;
  };
  // (The directions are the integrator's, rounded to float.)
  const Groove pass = leg({1, 0}, -3.1990930438041687e-07, 0.034524865448474884, 0.056271468877812182,
                          -1.4241402716014271, 2.5757710999166967, at_pass);
  const Groove a = leg({0.53086161613464355, -0.8474586009979248}, 0.77451120693748265, 0.39384727137431763,
                       -0.044482533689705013, -3.9999564560129914, 0, at_c1);
  const Groove b = leg({0.76996105909347534, -0.63809090852737427}, 0.85897538654032424, 0.13093726802806072,
                       -0.048450841595070619, 0, 0.93682810589776677, at_c1);
  const Groove c = leg({-0.92461252212524414, 0.38090911507606506}, 0.035497728309978473, -0.14814022193459783,
                       -0.047988577327606745, 0, 1.0057542145076992, at_c2);
  const Poly region = rect(-0.61592717498913407, -0.62054469652846456, 0.61592717498913407, 0.62054469652846456);
  // The nearer pass's height: the straight one's where its |b| is below the distance to the
  // corner's legs (the polyline c1, c2 and on), else the corner's.
  auto toSegment = [](Vec2d p, Vec2d q0, Vec2d q1) {
    const Vec2d d = q1 - q0;
    const double f = std::clamp(((p.x - q0.x) * d.x + (p.y - q0.y) * d.y) / (d.x * d.x + d.y * d.y), 0.0, 1.0);
    return std::hypot(p.x - q0.x - d.x * f, p.y - q0.y - d.y * f);
  };
  const Vec2d c1(-0.744927, 0.447288), c2(-0.023606, -0.150494), far_a = c1 - Vec2d(0.530862, -0.847459) * 4,
              far_c = c2 + Vec2d(-0.924613, 0.380909) * 1.005754;
  const double sector = 15.0;  // (the integrator's sectors: at most 15 degrees, eleven here)
  std::vector<Groove> parts, corner_parts;
  ASSERT_TRUE(chainParts({pass, a, b, c}, sector * M_PI / 180, region, parts, {1}));
  int most = 0;
  for (const Groove& q : parts) most = std::max(most, q.n_dom);
  Surface s;
  ASSERT_TRUE(s.build(region, {ofParts(parts, 7)}));
  // The corner's legs alone, and composited with the pass.
  ASSERT_TRUE(chainParts({a, b, c}, sector * M_PI / 180, region, corner_parts));
  const Groove corner = ofParts(corner_parts, 7);
  Surface two;
  ASSERT_TRUE(two.build(region, {pass, corner}));
  // (On the corner's round outer sides, where a vertex is the closest point, the fans differ: with
  // the pass beside them chainParts refines a fan about the pass's axis, appendFan, and each fan is
  // within 1.6 (the profile's steepest slope) x 0.143 (its half-width) x (1 / cos 7.5 degrees - 1)
  // = 1.9e-3 mm of the round cap. Elsewhere the two partitions are one to rounding.)
  double worst = 0, worst_fan = 0, worst_two = 0;
  for (int j = 0; j <= 120; ++j)
    for (int i = 0; i <= 120; ++i) {
      const Vec2d p(-0.6 + 1.2 * (i + 0.31) / 121, -0.6 + 1.2 * (j + 0.57) / 121);
      const double d_pass = std::fabs(p.y + 0.034525);
      const double d_corner = std::min({toSegment(p, far_a, c1), toSegment(p, c1, c2), toSegment(p, c2, far_c)});
      const double want = d_pass <= d_corner ? grooveHeight(pass, p) : grooveHeight(corner, p);
      const bool fan = d_pass > d_corner && std::min(std::hypot(p.x - c1.x, p.y - c1.y), std::hypot(p.x - c2.x, p.y - c2.y)) <=
                                                d_corner + 1e-9;
      const int k = pieceAt(s, p), k2 = pieceAt(two, p);
      ASSERT_GE(k, 0);
      ASSERT_GE(k2, 0);
      (fan ? worst_fan : worst) = std::max(fan ? worst_fan : worst, std::fabs(s.pieces()[size_t(k)].plane.at(p) - want));
      worst_two = std::max(worst_two, std::fabs(two.pieces()[size_t(k2)].plane.at(p) - want));
    }
  std::printf("[          ] sectors of %.0f degrees: %zu parts, at most %d half-planes each: height off by at most "
              "%.2e mm, %.2e on the fans (composited: %.2e)\n",
              sector, parts.size(), most, worst, worst_fan, worst_two);
  EXPECT_GT(most, 10);  // (the case that needed the wider cap)
  EXPECT_LT(worst, 1e-9);
  EXPECT_LT(worst_fan, 2e-3);
  EXPECT_GT(worst_two, 0.03);
}

// A path's corner (a turn of 156 degrees, a tilted tool's profile) whose later leg runs straight
// past the vertex 0.7 um away, on the side of the corner's legs, as the corner fuzzer's c60_0 drew
// it. Above the vertex the points nearer to it than to the later leg lie inside a narrow parabola
// (at 0.1 mm from the vertex, within 12 um of its axis), where the cap's outer half (a pile-up
// 7 um high) holds; outside it the later leg's other half (2 um). A fan of 15-degree sectors cut
// that parabola along chords far from the curve, and points of the cap took the leg's height.
// chainParts refines the fan about the leg's axis. Against the explicit geometry's surface (the
// profile at the signed distance to the path's closest point) the grid points off by more than
// the fan's own bound: with uniform sectors 15 of 6,561 on c60_0's corner, and up to 18 (600 in
// all) over 116 corners and axes; refined, 0, and up to 3 (41 in all). (Across the cut between
// the cap and the leg the tilted profile's two halves differ by up to 8 um, so a point that the
// cut misses by a little is off by that much: a count bounds what a largest difference cannot.)
// (Without the axis's angle taken a turn either way, nearly a half turn with its axis just past
// the fan's end kept 8.)
TEST(GrooveArea, AFansSectorsFollowALegThatPassesCloseToItsVertex) {
  const Vec2d v(0.0, 0.0);
  const double delta = 7e-4;
  const Poly region = rect(-0.15, -0.15, 0.15, 0.15);
  // The corner (legs along ta, tb) and the leg (along tp, its line delta from the vertex): the
  // grid points whose height is off by more than the fan's own bound (0.7 x 0.07 x (1 / cos 7.5
  // degrees - 1) = 4.5e-4 mm), and the parts.
  auto off = [&](Vec2d ta, Vec2d tb, Vec2d tp, Vec2d u, size_t& n_parts) {
    auto [a, b] = legs(v, ta, tb);
    a.pts = b.pts = &kTiltedProfile;
    a.t_hi = 0;
    b.t_lo = 0;
    const Vec2d pp = u * -delta;  // the leg's point nearest the vertex
    Groove pass = along(tp, 0, 0);
    pass.pts = &kTiltedProfile;
    pass.t0 = -(tp.x * pp.x + tp.y * pp.y);
    pass.b0 = -(pass.bdir.x * pp.x + pass.bdir.y * pp.y);
    std::vector<Groove> parts;
    EXPECT_TRUE(chainParts({a, b, pass}, 15 * M_PI / 180, region, parts, {2}));
    n_parts = parts.size();
    Surface s;
    EXPECT_TRUE(s.build(region, {ofParts(parts)}));
    return countOffClosestProfile(
        s, ScratchPath::polyline({v - ta * 20, v, v + tb * 20, pp - tp * 20, pp + tp * 20}), kTiltedProfile, 4.5e-4);
  };
  // c60_0's: a turn of 156 degrees, the leg 4 degrees from the horizontal below the vertex.
  size_t n_parts = 0;
  const int at_c60 = off(dirOf(100), dirOf(256), dirOf(4), dirOf(94), n_parts);
  std::printf("[          ] %zu parts: %d of 6561 points off\n", n_parts, at_c60);
  EXPECT_LE(at_c60, 2);
  // The same with the leg's axis (the normal from its line through the vertex) anywhere about the
  // fan and just past its ends, corners either way and nearly a half turn (whose fan's end lies
  // next to the angle -pi from its start).
  int cases = 0, most = 0, total = 0;
  for (double turn : {156.0, -120.0, 178.0, -179.5})
    for (double rel = -20; rel <= std::fabs(turn) + 20; rel += 7) {
      const Vec2d ta = dirOf(100), tb = dirOf(100 + turn);
      // The fan runs from the first leg's outer normal, turning with the path.
      const double start = 100 + (turn > 0 ? -90 : 90), axis = start + (turn > 0 ? rel : -rel);
      const Vec2d u = dirOf(axis);
      Vec2d tp(-u.y, u.x);
      if (tp.x * tb.x + tp.y * tb.y > 0) tp = tp * -1.0;  // (the path's far joint stays far away)
      size_t np = 0;
      const int k = off(ta, tb, tp, u, np);
      EXPECT_LE(k, 3) << "turn " << turn << ", axis " << rel << " degrees from the fan's start";
      most = std::max(most, k);
      total += k;
      ++cases;
    }
  std::printf("[          ] %d corners and axes: at most %d of 6561 points off, %d in all\n", cases, most, total);
}

// A knot of four corners of one path (the corner fuzzer's c45_6 seen at 1 degree, a tilted
// tool's profile; its legs as the integrator gave them to chainParts, all with the first leg's
// profile), its fans cut into sectors of 7.6 degrees: a leg's cell at a vertex keeps the edges
// of all the sectors there (17 to 21 lines, the vertex left as a cluster of points a rounding
// apart), more than a domain holds. chainParts drops the lines that the others imply, and the
// partition stays whole: until 2026-12-01 it refused the chain (499 times over c45_6's image).
TEST(GrooveArea, AChainsCellsDropTheLinesTheirOthersImply) {
  const std::vector<Vec2d> profile = {
      {-0.066183887331041275, 0}, {-0.052498036115120765, 0.064641765799265977}, {-0.021420587887665713, 0},
      {-0.0021900190174026189, -0.040000000000000001}, {-0.00069946107621811013, -0.043100392819870062},
      {-0.00028427778483451822, -0.043670013961782134}, {-0.0002272267155698892, -0.043727730758957598},
      {-0.00014234674904060941, -0.043794295784543365}, {-2.9424319327589332e-05, -0.043869125217208579},
      {0.00010773046047953058, -0.043948493087124813}, {0.00039937054219463182, -0.044089503185869065},
      {0.00067725877091660911, -0.044190581009197094}, {0.0007871043059270317, -0.044217084201464363},
      {0.000870898394502041, -0.044226084383307135}, {0.0015790381909354845, -0.044194771809268639},
      {0.019945537554522032, -0.040000000000000001}, {0.19508259099809194, 0},
      {0.24370939641180869, 0.011106000576716239}, {0.45562451147011962, 0}};
  const std::vector<int> layers(profile.size() - 1, 0);
  struct Leg {  // a leg's Groove fields
    Vec2d tdir, bdir;
    double t0, b0, rho, t_lo, t_hi;
  };
  const Leg legs[] = {
      {{0.51754683256149292, 0.85565495491027832}, {-0.85565495491027832, 0.51754683256149292},
       0.20262896960341098, 0.23883648436760913, 0.011635021367304099, -4.0000364498339263, 0},
      {{0.51754617691040039, -0.85565531253814697}, {0.85565531253814697, 0.51754617691040039},
       -0.30561217594337475, 0.068575239720871414, 0.012458374490630815, 0, 0.38070579191811582},
      {{0.15144339203834534, 0.98846602439880371}, {-0.98846602439880371, 0.15144339203834534},
       0.57065302771297921, 0.38741455635315358, 0.012646366948406254, 0, 0.60944894782089865},
      {{-0.5495331883430481, 0.8354719877243042}, {-0.8354719877243042, -0.5495331883430481},
       0.23064953687158812, 0.3136812921298508, 0.0087234517679689611, 0, 0.68381922318694777},
      {{0.76536798477172852, -0.6435929536819458}, {0.6435929536819458, 0.76536798477172852},
       0.34463203252104935, -0.43010170865485398, 0.0049616722358536251, 0, 3.9999987624998097},
  };
  std::vector<Groove> chain;
  for (const Leg& l : legs) {
    Groove g = along(l.tdir, l.b0, 7);
    g.bdir = l.bdir;
    g.pts = &profile;
    g.layer = &layers;
    g.t0 = l.t0;
    g.rho = l.rho;
    g.t_lo = l.t_lo;
    g.t_hi = l.t_hi;
    chain.push_back(g);
  }
  const Poly region = rect(-0.67500783696211875, -0.6746906033474952, 0.67500783696211875, 0.6746906033474952);
  std::vector<Groove> parts;
  ASSERT_TRUE(chainParts(chain, 0.13297392943691924, region, parts));
  int most = 0;
  for (const Groove& q : parts) most = std::max(most, q.n_dom);
  EXPECT_LE(most, Groove::kMaxDom);
  Surface s;  // (at the close views' cap, as the integrator builds it)
  ASSERT_TRUE(s.build(region, {ofParts(parts, 7)}, Surface::kMaxPiecesClose));
  double area = 0;
  for (const Piece& pc : s.pieces()) area += pc.wall ? 0.0 : pc.poly.area();
  EXPECT_NEAR(area, region.area(), 1e-9);
  // The domains tile the region: each point of a grid over it lies in one of them (a line dropped
  // that bounds its cell would open the domain over a neighbour's).
  int shared = 0, missed = 0;
  for (int j = 0; j <= 150; ++j)
    for (int i = 0; i <= 150; ++i) {
      const Vec2d p(-0.67 + 1.34 * (i + 0.31) / 151, -0.67 + 1.34 * (j + 0.57) / 151);
      int in = 0;
      for (const Groove& q : parts) {
        bool holds = true;
        for (int k = 0; k < q.n_dom && holds; ++k) holds = q.dom[k].holds(p);
        in += holds;
      }
      shared += in > 1;
      missed += in == 0;
    }
  EXPECT_EQ(shared, 0);
  EXPECT_EQ(missed, 0);
  std::printf("[          ] %zu parts, at most %d half-planes each; grid points in two domains %d, in none %d\n",
              parts.size(), most, shared, missed);
}

// The same where each pass is in pieces along its line (the integrator's scaleSegments, within a
// force fade): a path that doubles back, its legs 1 degree apart and 0.02 mm apart at the centre,
// each leg in three pieces of scale 0.6, 1 and 1.4 (given in a shuffled order). passPieces gives
// each point the piece of the nearer pass over its stretch of the line, to rounding; the pieces
// composited as separate grooves (what the renderer did until 2026-11-29) stand the far pass's
// walls where the nearer one cuts them away. With one piece each it is passParts.
TEST(GrooveArea, APathsTwoPassesInPiecesEachHoldWhereTheyAreTheNearer) {
  std::vector<Vec2d> scaled[3];
  const double scale[3] = {0.6, 1.0, 1.4};
  for (int k = 0; k < 3; ++k)
    for (const Vec2d& q : kProfile) scaled[k].push_back(q * scale[k]);
  // Pass a along dirOf(0.5) through (0, 0.01), b back along dirOf(179.5) through (0, -0.01);
  // pieces cut at -0.05 and 0.06 mm along each.
  auto pieces = [&](Vec2d p, Vec2d t) {
    std::vector<Groove> out;
    const double cuts[4] = {-1e30, -0.05, 0.06, 1e30};
    for (int k : {2, 0, 1}) {
      Groove g = along(t, 0, 7);
      g.b0 = -(g.bdir.x * p.x + g.bdir.y * p.y);
      g.t0 = 0.3 * k - (t.x * p.x + t.y * p.y);  // each piece its own origin along the line
      g.t_lo = cuts[k] + 0.3 * k;
      g.t_hi = cuts[k + 1] + 0.3 * k;
      g.pts = &scaled[k];
      out.push_back(g);
    }
    return out;
  };
  const std::vector<Groove> a = pieces({0, 0.01}, dirOf(0.5)), b = pieces({0, -0.01}, dirOf(179.5));
  std::vector<Groove> parts;
  ASSERT_TRUE(passPieces(a.data(), a.size(), b.data(), b.size(), parts));
  ASSERT_EQ(parts.size(), 12u);
  Groove g = ofParts(parts, 7);
  Surface s, composite;
  const Poly region = rect(-0.2, -0.2, 0.2, 0.2);
  ASSERT_TRUE(s.build(region, {g}));
  std::vector<Groove> all = a;
  all.insert(all.end(), b.begin(), b.end());
  ASSERT_TRUE(composite.build(region, all));
  // The explicit geometry's height: the nearer pass, and on it the piece whose stretch holds p.
  auto want = [&](Vec2d p) {
    const std::vector<Groove>& pass =
        std::fabs(a[0].b0 + dot(a[0].bdir, p)) <= std::fabs(b[0].b0 + dot(b[0].bdir, p)) ? a : b;
    for (const Groove& q : pass) {
      const double t = q.t0 + dot(q.tdir, p);
      if (t >= q.t_lo && t <= q.t_hi) return grooveHeight(q, p);
    }
    return std::numeric_limits<double>::quiet_NaN();
  };
  double worst = 0, worst_composite = 0;
  for (int j = 0; j <= 100; ++j)
    for (int i = 0; i <= 100; ++i) {
      const Vec2d p(-0.19 + 0.38 * (i + 0.31) / 101, -0.19 + 0.38 * (j + 0.57) / 101);
      const int k = pieceAt(s, p), kc = pieceAt(composite, p);
      ASSERT_GE(k, 0) << p.x << ", " << p.y;
      ASSERT_GE(kc, 0) << p.x << ", " << p.y;
      worst = std::max(worst, std::fabs(s.pieces()[size_t(k)].plane.at(p) - want(p)));
      worst_composite = std::max(worst_composite, std::fabs(composite.pieces()[size_t(kc)].plane.at(p) - want(p)));
    }
  std::printf("[          ] height off by at most %.2e mm (pieces composited %.2e)\n", worst, worst_composite);
  EXPECT_LT(worst, 1e-9);
  EXPECT_GT(worst_composite, 5e-3);
  double area = 0;
  for (const Piece& pc : s.pieces()) area += pc.wall ? 0.0 : pc.poly.area();
  EXPECT_NEAR(area, 0.16, 1e-9);
  // One piece each: passParts' parts, domains and all.
  std::vector<Groove> one, whole;
  ASSERT_TRUE(passPieces(&a[1], 1, &b[1], 1, one));
  ASSERT_TRUE(passParts(a[1], b[1], whole));
  ASSERT_EQ(one.size(), whole.size());
  for (size_t k = 0; k < one.size(); ++k) {
    ASSERT_EQ(one[k].n_dom, whole[k].n_dom);
    for (int d = 0; d < one[k].n_dom; ++d) {
      EXPECT_EQ(one[k].dom[d].a.x, whole[k].dom[d].a.x);
      EXPECT_EQ(one[k].dom[d].c, whole[k].dom[d].c);
    }
  }
  // Pieces of a pass off its line, or a pass without pieces: refused.
  std::vector<Groove> off = a;
  off[1].b0 += 1e-3;
  EXPECT_FALSE(passPieces(off.data(), off.size(), b.data(), b.size(), parts));
  EXPECT_FALSE(passPieces(a.data(), 0, b.data(), b.size(), parts));
  EXPECT_TRUE(parts.empty());
}

// One groove in pieces along its line (scaleSegments, in a force fade) is one groove of parts
// (pieceParts): six grooves through one spot, each in three pieces of scale 0.6, 1 and 1.4 (given
// shuffled), give 18 grooves as pieces, past Surface::kMaxGrooves, and six as parts, which build
// with every point at the pieces' composite height, as five grooves' 15 pieces entered one by one
// do. Pieces off their line, none, or a piece of parts: refused.
TEST(GrooveArea, AGrooveInPiecesIsOneGrooveOfParts) {
  std::vector<Vec2d> scaled[3];
  const double scale[3] = {0.6, 1.0, 1.4};
  for (int k = 0; k < 3; ++k)
    for (const Vec2d& q : kProfile) scaled[k].push_back(q * scale[k]);
  auto pieces = [&](Vec2d t, double b0, int id) {
    std::vector<Groove> out;
    const double cuts[4] = {-1e30, -0.04, 0.05, 1e30};
    for (int k : {1, 2, 0}) {
      Groove g = along(t, b0, id);
      g.t0 = 0.25 * k;  // each piece its own origin along the line
      g.t_lo = cuts[k] + 0.25 * k;
      g.t_hi = cuts[k + 1] + 0.25 * k;
      g.pts = &scaled[k];
      out.push_back(g);
    }
    return out;
  };
  std::vector<std::vector<Groove>> each;
  for (int i = 0; i < 6; ++i) each.push_back(pieces(dirOf(7 + 31 * i), 0.006 * (i - 2.5), i));
  std::vector<std::vector<Groove>> parts(each.size());
  std::vector<Groove> as_parts, as_pieces;
  for (size_t i = 0; i < each.size(); ++i) {
    ASSERT_TRUE(pieceParts(each[i].data(), each[i].size(), parts[i]));
    ASSERT_EQ(parts[i].size(), 3u);
    as_parts.push_back(ofParts(parts[i], int(i)));
    as_pieces.insert(as_pieces.end(), each[i].begin(), each[i].end());
  }
  static_assert(3 * 6 > Surface::kMaxGrooves && 3 * 5 <= Surface::kMaxGrooves, "the test needs the cap between");
  const Poly region = rect(-0.15, -0.15, 0.15, 0.15);
  Surface s, by_pieces;
  EXPECT_FALSE(by_pieces.build(region, as_pieces, Surface::kMaxPiecesClose));
  ASSERT_TRUE(s.build(region, as_parts, Surface::kMaxPiecesClose));
  // The largest of f(p) over an n x n grid inside the region.
  auto most = [](int n, double fx, double fy, auto f) {
    double m = 0;
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) m = std::max(m, f(Vec2d(-0.14 + 0.28 * (i + fx) / n, -0.14 + 0.28 * (j + fy) / n)));
    return m;
  };
  const double worst = most(80, 0.37, 0.61, [&](Vec2d p) {
    const int k = pieceAt(s, p);
    EXPECT_GE(k, 0) << p.x << ", " << p.y;
    return k < 0 ? 1.0 : std::fabs(s.pieces()[size_t(k)].plane.at(p) - composite(as_pieces, p));
  });
  std::printf("[          ] six grooves of three pieces: %zu pieces, height off by at most %.2e mm\n",
              s.pieces().size(), worst);
  EXPECT_LT(worst, 1e-9);
  // Five grooves: the pieces one by one and the grooves of parts give the same surface heights.
  as_parts.pop_back();
  as_pieces.resize(15);
  Surface five_parts, five_pieces;
  ASSERT_TRUE(five_parts.build(region, as_parts, Surface::kMaxPiecesClose));
  ASSERT_TRUE(five_pieces.build(region, as_pieces, Surface::kMaxPiecesClose));
  const double apart =
      most(50, 0.29, 0.53, [&](Vec2d p) { return std::fabs(five_parts.heightAt(p) - five_pieces.heightAt(p)); });
  EXPECT_LT(apart, 1e-12);
  std::vector<Groove> out;
  std::vector<Groove> off = each[0];
  off[2].b0 += 1e-3;
  EXPECT_FALSE(pieceParts(off.data(), off.size(), out));
  EXPECT_FALSE(pieceParts(each[0].data(), 0, out));
  EXPECT_FALSE(pieceParts(&as_parts[0], 1, out));
  EXPECT_TRUE(out.empty());
}

// centreLinesWithin (the renderer's test for whether two passes of one path need one partition by
// nearness or can be composited): by hand, then against the least distance between points spaced
// 5 * 10^-4 mm along both centre lines within the disc, for random lines, ranges and widths.
TEST(GrooveArea, CentreLinesWithinIsTheirDistanceInTheDisc) {
  // Crossing lines; lines 0.3 mm apart; a crossing outside the disc; a groove that ends short of
  // the other's line.
  EXPECT_TRUE(centreLinesWithin(along({1, 0}, 0.0, 0), along(dirOf(70), 0.05, 0), 1.0, 1e-6));
  EXPECT_FALSE(centreLinesWithin(along({1, 0}, 0.0, 0), along({1, 0}, 0.3, 0), 1.0, 0.29));
  EXPECT_TRUE(centreLinesWithin(along({1, 0}, 0.0, 0), along({1, 0}, 0.3, 0), 1.0, 0.31));
  EXPECT_FALSE(centreLinesWithin(along({1, 0}, 0.0, 0), along({1, 0}, 0.3, 0), 0.29, 1.0));  // b off the disc
  Groove far = along(dirOf(90), 0.0, 0);  // the line x = 0 ...
  far.t0 = 2;                             // ... through (0, -2): t = 0 there
  EXPECT_TRUE(centreLinesWithin(along({1, 0}, 0.0, 0), far, 1.0, 1e-6));
  far.t_hi = 1.9;  // stops at y = -0.1
  EXPECT_FALSE(centreLinesWithin(along({1, 0}, 0.0, 0), far, 1.0, 0.09));
  EXPECT_TRUE(centreLinesWithin(along({1, 0}, 0.0, 0), far, 1.0, 0.11));
  // The lines x = -0.95 and y = -0.5 cross at (-0.95, -0.5), outside the disc of radius 1; within
  // it they come nearest at their ends, (-0.95, -0.312) and (-0.866, -0.5), 0.206 apart.
  Groove side = along(dirOf(90), -0.95, 0);
  EXPECT_FALSE(centreLinesWithin(along({1, 0}, 0.5, 0), side, 1.0, 0.2));
  EXPECT_TRUE(centreLinesWithin(along({1, 0}, 0.5, 0), side, 1.0, 0.21));

  Rng rng(20261129);
  auto uni = [&](double a, double b) { return a + (b - a) * rng.uniformD(); };
  int checked = 0, near = 0;
  for (int trial = 0; trial < 150; ++trial) {
    Groove g[2];
    for (Groove& q : g) {
      q = along(dirOf(uni(0, 360)), uni(-0.6, 0.6), 0);
      q.t0 = uni(-0.5, 0.5);
      q.t_lo = rng.uniformD() < 0.5 ? -1e30 : uni(-1, 0.2);
      q.t_hi = rng.uniformD() < 0.5 ? 1e30 : q.t_lo + uni(0.05, 1);
      if (q.t_hi > 1e29 && q.t_lo < -1e29) q.t_lo = uni(-1, 0.2);
    }
    const double r = 0.5;
    // The points of each centre line in the disc.
    std::vector<Vec2d> pts[2];
    for (int i = 0; i < 2; ++i)
      for (double t = std::max(g[i].t_lo, g[i].t0 - r); t <= std::min(g[i].t_hi, g[i].t0 + r); t += 5e-4) {
        const Vec2d p = g[i].tdir * (t - g[i].t0) - g[i].bdir * g[i].b0;
        if (std::hypot(p.x, p.y) <= r) pts[i].push_back(p);
      }
    double least2 = std::numeric_limits<double>::infinity();
    for (const Vec2d& p : pts[0])
      for (const Vec2d& q : pts[1]) least2 = std::min(least2, dot(p - q, p - q));
    const double least = std::sqrt(least2);
    // Any width, or one within 15% of the least distance either way.
    const double w = trial % 2 || !(least > 0.02) ? uni(0.01, 0.4) : least * (trial % 4 ? uni(0.85, 0.99) : uni(1.01, 1.15));
    if (std::fabs(least - w) < 5e-4) continue;  // too close to call at this spacing
    ++checked;
    near += least < w;
    EXPECT_EQ(centreLinesWithin(g[0], g[1], r, w), least < w) << "trial " << trial << ": least " << least << ", w " << w;
  }
  EXPECT_GT(checked, 140);
  EXPECT_GT(near, 15);  // both answers are checked
  EXPECT_LT(near, checked - 15);
}

// A groove that stops abruptly at x = 0: the wall across its end (the V's cross-section, 0.001
// mm^2) is seen, lit and hit like any other piece, with the shares that its geometry gives.
TEST(GrooveArea, AnAbruptEndsWallIsSeenLitAndHit) {
  Groove g = along({1, 0}, 0.0, 0);
  g.t_hi = 0;
  Surface s;
  ASSERT_TRUE(s.build(rect(-0.3, -0.3, 0.3, 0.3), {g}));
  const Poly fp = rect(-0.06, -0.06, 0.06, 0.06);
  auto onWall = [&](const Portion& p) { return s.pieces()[size_t(p.piece)].wall; };
  // Seen from the groove's side, 26.6 degrees off the normal: the wall's projection along the
  // view is its area times tan(26.6) = 0.5. (The pile-ups' end walls face the other way.)
  const Vec3d e = unit({-0.5, 0, 1});
  double wall = 0, wsum = 0;
  for (const Portion& p : s.visible(fp, e)) {
    wsum += p.weight;
    if (!onWall(p)) continue;
    wall += p.weight;
    EXPECT_NEAR(s.litFraction(p, unit({-1, 0, 1})), 1.0, 1e-6);  // nothing in front of it
    EXPECT_EQ(s.litFraction(p, unit({1, 0, 1})), 0.0);           // behind it
  }
  EXPECT_NEAR(wall, 0.001 * 0.5 / fp.area(), 1e-4);
  EXPECT_NEAR(wsum, 1.0, 1e-4);
  // From the other side the walls seen are the pile-ups' ends (each a triangle 0.01 mm wide at
  // the foot, 0.004 mm high, in the footprint), not the groove's.
  wall = 0;
  for (const Portion& p : s.visible(fp, unit({0.5, 0, 1}))) wall += onWall(p) ? p.weight : 0.0;
  EXPECT_NEAR(wall, 2 * 0.5 * 0.01 * 0.004 * 0.5 / fp.area(), 1e-4);
  // Rays leaving the floor (seen head-on) towards the end at slope 0.3 meet the wall where they
  // reach x = 0 below the base: from x > -depth(b) / 0.3.
  const Vec3d d = unit({1, 0, 0.3});
  double hit_wall = 0;
  for (const Portion& p : s.visible(fp, {0, 0, 1}))
    for (const Portion& q : s.scatter(p, d).hits) hit_wall += onWall(q) ? q.weight : 0.0;
  double expect = 0;
  const int n = 20000;
  for (int i = 0; i < n; ++i) {
    double b = -0.05 + 0.1 * (i + 0.5) / n, depth = 0.02 * (1 - std::fabs(b) / 0.05);
    expect += std::min(0.06, depth / 0.3) * (0.1 / n);
  }
  EXPECT_NEAR(hit_wall, expect / fp.area(), 1e-4);
  EXPECT_GT(hit_wall, 0.1);
}

// The wall across an abrupt end passes the coating's layers: each band of it shows the layer at
// its depth (interfaces at 4, 8 and 12 micrometres), and walls above the base plane (cut pile-ups)
// the top layer.
TEST(GrooveArea, WallsShowTheLayersTheyCut) {
  const std::vector<double> cuts = {0.004, 0.008, 0.012};
  std::vector<Groove> gs = shortAcross();
  for (Groove& g : gs) g.interfaces = &cuts;
  Surface s;
  ASSERT_TRUE(s.build(rect(-0.3, -0.3, 0.3, 0.3), gs));
  std::map<int, int> seen;
  for (const Piece& p : s.pieces()) {
    if (!p.wall) continue;
    double zlo = 1e300, zhi = -1e300;
    for (int k = 0; k < p.poly.n; ++k) {
      double z = p.plane.at(p.poly.v[size_t(k)]);
      zlo = std::min(zlo, z);
      zhi = std::max(zhi, z);
    }
    const double mid = 0.5 * (zlo + zhi);
    int expect = 0;
    for (double d : cuts) expect += mid < 0 && -mid >= d;
    EXPECT_EQ(p.layer, expect) << "wall piece from z " << zlo << " to " << zhi;
    // A band lies between two consecutive levels.
    for (double level : {0.0, -0.004, -0.008, -0.012}) EXPECT_FALSE(zlo < level - 1e-12 && zhi > level + 1e-12) << level;
    ++seen[p.layer];
  }
  EXPECT_GE(seen.size(), 4u);  // the top layer above the base and three below
}

// Numerical stress: random crossings, near-parallel and coincident grooves, abrupt and faded
// ends, footprints and directions. Whatever the layout, the pieces tile the region with the
// composite height, every wall stands between the heights on its two sides, the visible shares
// sum to 1 (up to the leaning walls' strips), lit fractions lie in [0, 1] and scattering keeps
// each portion's weight.
TEST(GrooveArea, RandomLayoutsKeepTheirInvariants) {
  Rng rng(20261125);
  auto uni = [&](double a, double b) { return a + (b - a) * rng.uniformD(); };
  auto dir = [&](double elev_lo) {
    double phi = uni(0, 2 * M_PI), z = uni(elev_lo, 1.0), r = std::sqrt(1 - z * z);
    return Vec3d(r * std::cos(phi), r * std::sin(phi), z);
  };
  int built = 0, with_walls = 0;
  for (int it = 0; it < 300; ++it) {
    const int ng = 1 + int(rng.uniformD() * 3);
    std::vector<Groove> gs;
    const double a0 = uni(0, M_PI);
    for (int i = 0; i < ng; ++i) {
      // Every third groove nearly parallel to the first (down to 1e-9 rad), or along it exactly.
      double a = i > 0 && it % 3 == 0 ? a0 + (it % 2 ? 0.0 : std::pow(10.0, -uni(3, 9))) : uni(0, M_PI);
      Groove g = along(Vec2d(std::cos(a), std::sin(a)), uni(-0.06, 0.06), i);
      if (rng.uniformD() < 0.4) g.t_lo = uni(-0.1, 0.0);
      if (rng.uniformD() < 0.4) g.t_hi = uni(0.0, 0.1);
      if (rng.uniformD() < 0.3) g.rho = uni(-12, 12);
      gs.push_back(g);
    }
    Surface s;
    const Poly region = rect(-0.3, -0.3, 0.3, 0.3);
    if (!s.build(region, gs)) continue;
    ++built;
    with_walls += !s.walls().empty();
    double total = 0;
    for (const Piece& p : s.pieces()) {
      ASSERT_TRUE(std::isfinite(p.plane.z0) && std::isfinite(p.plane.g.x) && std::isfinite(p.plane.g.y)) << it;
      if (!p.wall) total += p.poly.area();
    }
    ASSERT_NEAR(total, region.area(), 1e-9) << "layout " << it;
    for (const Surface::Wall& w : s.walls()) {
      Vec2d m = (w.a + w.b) * 0.5, o = w.out * 1e-8;
      if (length(Vec3d(w.b.x - w.a.x, w.b.y - w.a.y, 0)) < 1e-6) continue;  // too short to probe
      EXPECT_NEAR((w.za0 + w.zb0) * 0.5, composite(gs, m + o), 1e-6) << "layout " << it;
      EXPECT_NEAR((w.za1 + w.zb1) * 0.5, composite(gs, m - o), 1e-6) << "layout " << it;
    }
    const double h = uni(0.01, 0.06);
    const Vec2d c(uni(-0.1, 0.1), uni(-0.1, 0.1));
    const Poly fp = rect(c.x - h, c.y - h, c.x + h, c.y + h);
    const Vec3d e = dir(0.2), l = dir(0.05), d = dir(0.05);
    s.overflow = 0;
    std::vector<Portion> vis = s.visible(fp, e);
    double wsum = 0;
    for (const Portion& p : vis) {
      ASSERT_TRUE(std::isfinite(p.weight) && p.weight >= 0) << "layout " << it;
      wsum += p.weight;
      double lit = s.litFraction(p, l);
      ASSERT_TRUE(std::isfinite(lit)) << "layout " << it;
      EXPECT_GE(lit, 0.0);
      EXPECT_LE(lit, 1.0);
      const Vec3d n = s.pieces()[size_t(p.piece)].plane.normal();
      if (n.x * d.x + n.y * d.y + n.z * d.z <= 0) continue;
      Hits hs = s.scatter(p, d);
      double sum = hs.escaped;
      for (const Portion& q : hs.hits) sum += q.weight;
      if (s.overflow == 0) {
        EXPECT_NEAR(sum, p.weight, 1e-9 + 1e-6 * p.weight) << "layout " << it;
      }
    }
    if (s.overflow == 0) {
      EXPECT_NEAR(wsum, 1.0, 2e-3) << "layout " << it;
    }
  }
  EXPECT_GT(built, 250);
  EXPECT_GT(with_walls, 60);
}

// The search for occluders (Surface::shadowsOn) tests only the pieces binned near the receiving
// portion and its shadow's reach. Against a full scan of every piece, done here from the public
// pieces (each piece facing away from the light, cut to where it stands above the portion's
// plane, projected along the light onto it and subtracted), the lit fractions must agree: a piece
// the bins left out would leave its shadow out. Random layouts of up to six grooves, lights down
// to 1 degree above the plane (shadows across the whole region).
TEST(GrooveArea, LitFractionsFindEveryOccluder) {
  Rng rng(20261128);
  auto uni = [&](double a, double b) { return a + (b - a) * rng.uniformD(); };
  auto dir = [&](double z_lo, double z_hi) {
    double phi = uni(0, 2 * M_PI), z = uni(z_lo, z_hi), r = std::sqrt(1 - z * z);
    return Vec3d(r * std::cos(phi), r * std::sin(phi), z);
  };
  auto fullScan = [](const Surface& s, const Portion& p, Vec3d l) {
    const Plane& P = s.pieces()[size_t(p.piece)].plane;
    const double den = l.z - P.g.x * l.x - P.g.y * l.y;
    if (!(den > 0)) return 0.0;
    std::vector<Poly> frags = p.frags;
    size_t dropped = 0;
    for (const Piece& Q : s.pieces()) {
      if (!(l.z - Q.plane.g.x * l.x - Q.plane.g.y * l.y < 0)) continue;
      const Poly q = clip(Q.poly, P.g - Q.plane.g, P.z0 - Q.plane.z0);
      if (q.empty()) continue;
      Poly sh;
      for (int i = 0; i < q.n; ++i) {
        const Vec2d v = q.v[size_t(i)];
        const double lambda = (Q.plane.at(v) - P.at(v)) / den;
        sh.push(Vec2d(v.x - lambda * l.x, v.y - lambda * l.y));
      }
      if (sh.area() < 0) std::reverse(sh.v, sh.v + sh.n);
      if (sh.empty() || !(sh.area() > 1e-16)) continue;
      subtract(frags, sh, Surface::kMaxFragments, dropped);
    }
    return area(frags) / area(p.frags);
  };
  int compared = 0, shaded = 0, far_shadows = 0;
  for (int it = 0; it < 120; ++it) {
    const int ng = 2 + int(rng.uniformD() * 5);
    std::vector<Groove> gs;
    for (int i = 0; i < ng; ++i) {
      const double a = uni(0, M_PI);
      Groove g = along(Vec2d(std::cos(a), std::sin(a)), uni(-0.15, 0.15), i);
      if (rng.uniformD() < 0.3) g.t_hi = uni(-0.1, 0.2);
      if (rng.uniformD() < 0.3) g.rho = uni(-8, 8);
      gs.push_back(g);
    }
    Surface s;
    if (!s.build(rect(-0.3, -0.3, 0.3, 0.3), gs)) continue;
    const double h = uni(0.01, 0.05);
    const Vec2d c(uni(-0.2, 0.2), uni(-0.2, 0.2));
    for (int k = 0; k < 4; ++k) {
      const Vec3d e = dir(0.3, 1.0), l = k < 2 ? dir(0.017, 0.1) : dir(0.1, 0.9);
      s.overflow = 0;
      for (const Portion& p : s.visible(rect(c.x - h, c.y - h, c.x + h, c.y + h), e)) {
        if (!(area(p.frags) > 1e-12)) continue;
        const double lit = s.litFraction(p, l), full = fullScan(s, p, l);
        if (s.overflow > 0) break;  // fragments dropped at the cap: the two may differ
        ASSERT_NEAR(lit, full, 1e-9) << "layout " << it << ", light " << k;
        ++compared;
        shaded += full < 1 - 1e-9;
        far_shadows += k < 2 && full < 0.5;
      }
    }
  }
  std::printf("[          ] %d portions compared, %d in some shadow, %d under a grazing light more than half\n", compared,
              shaded, far_shadows);
  EXPECT_GT(compared, 1000);
  EXPECT_GT(shaded, 200);
  EXPECT_GT(far_shadows, 50);
}

// Past the caps build() refuses (the renderer then falls back to the blend): more than 8
// grooves, or more pieces than kMaxPieces.
TEST(GrooveArea, BuildRefusesPastItsCaps) {
  Surface s;
  std::vector<Groove> many;
  for (int i = 0; i < 9; ++i) many.push_back(along(Vec2d(std::cos(0.3 * i), std::sin(0.3 * i)), 0.001 * i, i));
  EXPECT_FALSE(s.build(rect(-0.3, -0.3, 0.3, 0.3), many));
  many.pop_back();
  // Eight grooves in eight directions through one point would need more than kMaxPieces pieces.
  EXPECT_FALSE(s.build(rect(-0.3, -0.3, 0.3, 0.3), many));
  // Three of them fit.
  many.resize(3);
  ASSERT_TRUE(s.build(rect(-0.3, -0.3, 0.3, 0.3), many));
  EXPECT_LE(s.pieces().size(), Surface::kMaxPieces);
  // Two crossing grooves are far below the cap.
  ASSERT_TRUE(s.build(rect(-0.3, -0.3, 0.3, 0.3), crossing()));
  EXPECT_LT(s.pieces().size(), Surface::kMaxPieces / 2);
}

// The renderer's cap for close views (the pixel small against the region) holds more pieces:
// seven grooves through one point need about 1,400, past the ordinary cap and within that one,
// and the surface built under it covers the whole region.
TEST(GrooveArea, TheCloseViewsCapHoldsMorePieces) {
  Surface s;
  std::vector<Groove> seven;
  for (int i = 0; i < 7; ++i) seven.push_back(along(Vec2d(std::cos(0.3 * i), std::sin(0.3 * i)), 0.001 * i, i));
  const Poly region = rect(-0.3, -0.3, 0.3, 0.3);
  EXPECT_FALSE(s.build(region, seven));
  ASSERT_TRUE(s.build(region, seven, Surface::kMaxPiecesClose));
  EXPECT_GT(s.pieces().size(), Surface::kMaxPieces);
  EXPECT_LE(s.pieces().size(), Surface::kMaxPiecesClose);
  double area = 0;
  for (const Piece& pc : s.pieces()) area += pc.wall ? 0.0 : pc.poly.area();
  EXPECT_NEAR(area, region.area(), 1e-9);
}

// Rays that leave a portion along the groove, a little down, meet nothing within a small region:
// scatter() says where they leave the portion (the escaped fragments' centroid), and leaving()
// where they cross the region's boundary, at their height on the ray, below the base, and the
// groove whose channel they are in there. The integrator hands them on to that groove's section.
TEST(GrooveArea, ARayThatLeavesTheRegionDownAGrooveFindsIt) {
  const std::vector<Groove> gs = crossing();
  Surface s;
  const double R = 0.08;
  ASSERT_TRUE(s.build(rect(-R, -R, R, R), gs));
  const Poly fp = rect(-0.01, -0.01, 0.01, 0.01);
  // Along groove 0 (t = x), off the wall under the footprint (its -b side faces -y) towards the
  // other one, and slightly down.
  const Vec3d d = unit({1.0, -0.08, -0.02});
  int handed = 0;
  for (const Portion& p : s.visible(fp, {0, 0, 1})) {
    const Piece& P = s.pieces()[size_t(p.piece)];
    const Vec3d n = P.plane.normal();
    if (!(n.x * d.x + n.y * d.y + n.z * d.z > 0)) continue;
    const Hits h = s.scatter(p, d);
    if (!(h.escaped > 1e-9)) continue;
    // The centroid lies within the portion's fragments' box.
    Vec2d lo(1e300, 1e300), hi(-1e300, -1e300);
    for (const Poly& f : p.frags) f.extend(lo, hi);
    EXPECT_GE(h.escaped_at.x, lo.x - 1e-12);
    EXPECT_LE(h.escaped_at.x, hi.x + 1e-12);
    EXPECT_GE(h.escaped_at.y, lo.y - 1e-12);
    EXPECT_LE(h.escaped_at.y, hi.y + 1e-12);
    const Vec3d o(h.escaped_at.x, h.escaped_at.y, P.plane.at(h.escaped_at));
    Vec3d at;
    const Groove* q = s.leaving(o, d, at);
    ASSERT_NE(q, nullptr);
    EXPECT_EQ(q->id, 0);
    // On the boundary x = R, on the ray.
    EXPECT_NEAR(at.x, R, 1e-12);
    const double sr = (at.x - o.x) / d.x;
    EXPECT_NEAR(at.y, o.y + sr * d.y, 1e-12);
    EXPECT_NEAR(at.z, o.z + sr * d.z, 1e-12);
    // Below the base, in groove 0's channel, and above the surface there: the ray from the centroid
    // did pass over everything on its way out.
    EXPECT_LT(at.z, 0.0);
    EXPECT_GT(at.z, composite(gs, {at.x, at.y}) - 1e-9);
    for (double u = 1e-4; u < sr; u += 1e-4)
      ASSERT_GT(o.z + 1e-6 + u * d.z, composite(gs, {o.x + u * d.x, o.y + u * d.y}) - 1e-7) << u << " of " << sr;
    ++handed;
  }
  EXPECT_GT(handed, 0);
  // A ray with no horizontal part leaves no way sideways.
  Vec3d at;
  EXPECT_EQ(s.leaving({0, 0, -0.01}, {0, 0, -1}, at), nullptr);
  // Past a groove's end nothing of it is there: a ray along the tapered end leaves the region
  // beyond it (t_hi = 0.2) with no groove to hand on to.
  Surface e;
  const std::vector<Groove> end = taperedEnd();
  ASSERT_TRUE(e.build(rect(-0.4, -0.4, 0.4, 0.4), end));
  EXPECT_EQ(e.leaving({0.0, 0.0, -0.01}, unit({1.0, 0.0, -0.01}), at), nullptr);
  EXPECT_NEAR(at.x, 0.4, 1e-12);
  ASSERT_NE(e.leaving({0.0, 0.0, -0.01}, unit({-1.0, 0.0, -0.01}), at), nullptr);
  EXPECT_NEAR(at.x, -0.4, 1e-12);
}

// One straight groove with no end: the polygons give what 1-D line sampling gives, facet by
// facet (the "isolated and general method agree where both apply" test of digest §7).
TEST(GrooveArea, AgreesWithLineSamplingOnASingleGroove) {
  std::vector<Groove> gs{along({1, 0}, 0.012, 0)};
  Surface s;
  ASSERT_TRUE(s.build(rect(-0.5, -0.5, 0.5, 0.5), gs));
  // Footprint: a square 0.1 mm wide, the same as a 1-D footprint of two boxes 0.1 and 0 wide.
  Poly fp = rect(-0.05, -0.05, 0.05, 0.05);
  groove::Footprint f1;
  f1.w1 = 0.1;
  // 1-D section in the frame (b, w): B is +y here, with the path at b = -b0.
  groove::Section sec = groove::merge({{&kProfile, &kLayers, -0.012, false}}, 2.0);
  const Vec3d e = unit({0.1, 0.3, 1.0}), l = unit({0.05, -1.0, 0.5});
  std::vector<Portion> vis = s.visible(fp, e);
  std::vector<groove::Portion> vis1 = groove::visible(sec, {e.y, e.z}, f1);
  groove::Shadowing sh(sec, {l.y, l.z});
  // Sums by facet slope (dz/dy), which identifies the facet in both.
  auto key = [](double slope) { return std::lround(slope * 1000); };
  std::map<long, std::pair<double, double>> a2, a1;  // slope -> (weight, lit weight)
  for (const Portion& p : vis) {
    auto& v = a2[key(s.pieces()[size_t(p.piece)].plane.g.y)];
    v.first += p.weight;
    v.second += p.weight * s.litFraction(p, l);
  }
  for (const groove::Portion& p : vis1) {
    Vec2d n = sec.normal(size_t(p.facet));
    auto& v = a1[key(-n.x / n.y)];
    v.first += p.weight;
    v.second += p.weight * sh.litFraction(p, f1);
  }
  ASSERT_EQ(a1.size(), a2.size());
  for (const auto& [k, v] : a1) {
    ASSERT_TRUE(a2.count(k)) << k;
    EXPECT_NEAR(a2[k].first, v.first, 1e-9) << "facet slope " << k;
    EXPECT_NEAR(a2[k].second, v.second, 1e-9) << "facet slope " << k;
  }
}

// A groove whose scale changes along it (a force fade, rho per mm): the polygons' planes slope
// along the path, and the 1-D section gives each facet the same slope as its tilt, so both
// methods shade a facet with one normal: (-g.x, -g.y, 1) ~ (tilt, n_b, n_w) with t = x, b = y.
TEST(GrooveArea, AFadingGroovesPlanesSlopeAsTheSectionsFacetsTilt) {
  for (double rho : {0.8, -2.5}) {
    Groove g = along({1, 0}, 0.012, 0);
    g.rho = rho;
    Surface s;
    ASSERT_TRUE(s.build(rect(-0.2, -0.2, 0.2, 0.2), {g}));
    groove::PlacedProfile pl{&kProfile, &kLayers, -0.012, false};
    pl.rho = rho;
    const groove::Section sec = groove::merge({pl}, 2.0);
    ASSERT_EQ(sec.tilt.size(), sec.facets());
    int matched = 0;
    for (const Piece& pc : s.pieces()) {
      if (pc.wall || pc.groove < 0) continue;
      // The section's facet with this piece's slope across the path, at the piece's centre b.
      const double yc = 0.5 * (pc.lo.y + pc.hi.y);
      for (size_t k = 0; k < sec.facets(); ++k) {
        const Vec2d n = sec.normal(k);
        if (!(sec.pts[k].x <= yc && yc <= sec.pts[k + 1].x) || std::fabs(n.y) < 1e-9) continue;
        if (std::fabs(-n.x / n.y - pc.plane.g.y) > 1e-9) continue;
        EXPECT_NEAR(pc.plane.g.x, -sec.tilt[k] / n.y, 1e-9) << "rho " << rho << " facet " << k;
        EXPECT_NE(sec.tilt[k], 0.0);
        ++matched;
      }
    }
    EXPECT_GE(matched, 4) << rho;  // the groove's two walls and the two pile-ups' outer flanks at least
  }
}

// Bends of a gentle curve 0.57 mm from the footprint (the fuzzer's p1_7 under the bar light, whose
// light reach is long), its legs as the renderer placed them: each leg's end line and the edge of
// the fan at its corner, computed in their own frames, missed the vertex by about 3e-8 mm, and the
// strip between them, out to the region's edge, had no owner: the chain was refused. Such slivers
// now go to the nearest candidate, and the parts tile the region.
TEST(GrooveArea, AChainSeenFromFarTilesTheRegion) {
  struct L { Vec2d t, b; double t0, b0, tlo, thi, rho; };
  std::vector<L> ls = {
  {{-0.80910462141036987, -0.58766472339630127}, {0.58766472339630127, -0.80910462141036987}, 0.2925268945729067, 0.57567348725419709, -0.22092919304752617, 0, -0.014060646047695732},
  {{-0.79180526733398438, -0.61077374219894409}, {0.61077374219894409, -0.79180526733398438}, 0.30902115393998331, 0.56699018897462217, 0, 0.38408112179990883, -0.0030668105526002101},
  {{-0.77009499073028564, -0.63792943954467773}, {0.63792943954467773, -0.77009499073028564}, -0.055304875531918207, 0.56925674691742556, 0, 0.16492854154429276, 0.0041959491909981826},
  {{-0.74299275875091553, -0.66929954290390015}, {0.66929954290390015, -0.74299275875091553}, -0.19645001032982543, 0.57789566130010495, 0, 0.28000967168958107, 0.0053787471396597028}};
  static std::vector<Vec2d> prof = {{-0.10415269119998495, 0}, {-0.086401203906597515, 0.027893143535860053}, {-0.053159449590877421, 0}, {-0.0012970277725123747, -0.043517738629482425}, {-0.00069013406234119657, -0.043868128873739268}, {0, -0.043989818128450382}, {0.00069013406234119657, -0.043868128873739268}, {0.0012970277725123747, -0.043517738629482425}, {0.053159449590877407, 0}, {0.086401203906597487, 0.027893143535860053}, {0.10415269119998492, 0}};
  static std::vector<int> lay(prof.size() - 1, 0);
  std::vector<Groove> legs_of;
  for (const L& l : ls) {
    Groove g;
    g.tdir = l.t; g.bdir = l.b; g.t0 = l.t0; g.b0 = l.b0; g.t_lo = l.tlo; g.t_hi = l.thi; g.rho = l.rho;
    g.pts = &prof; g.layer = &lay; g.id = 0;
    legs_of.push_back(g);
  }
  std::vector<Groove> parts;
  const Poly region = rect(-0.50440025476180017, -0.49237991876341403, 0.50440025476180017, 0.49237991876341403);
  ASSERT_TRUE(chainParts(legs_of, 15 * M_PI / 180, region, parts));
  Groove g = ofParts(parts);
  Surface surf;
  ASSERT_TRUE(surf.build(region, {g}));
  double area = 0;
  for (const Piece& pc : surf.pieces()) area += pc.wall ? 0.0 : pc.poly.area();
  EXPECT_NEAR(area, region.area(), 1e-9);
}
}  // namespace
}  // namespace dg::groove::area
