// True displacement: conforming local refinement and vertex moves by the dents' height fields.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <set>
#include <stdexcept>
#include <utility>
#include <vector>

#include "defects/dent.h"
#include "render/displacement.h"
#include "render/mesh.h"

namespace dg {
namespace {

// A flat plate in z = 0 of nx x ny square cells of `cell` mm, each cut into two triangles along a
// diagonal (alternating, so that neither direction is favoured); UV (mm) equals (x, y).
TriangleMesh plate(int nx, int ny, float cell) {
  TriangleMesh m;
  m.source = "test:plate";
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      m.positions.push_back({i * cell, j * cell, 0.0f});
      m.normals.push_back({0, 0, 1});
      m.uvs.push_back({i * cell, j * cell});
    }
  auto id = [&](int i, int j) { return uint32_t(j * (nx + 1) + i); };
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const uint32_t a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
      if ((i + j) % 2 == 0)
        m.indices.insert(m.indices.end(), {a, b, c, a, c, d});
      else
        m.indices.insert(m.indices.end(), {a, b, d, b, c, d});
    }
  m.computeMmPerUv();
  return m;
}

std::unique_ptr<Dent> dent(Vec2f c, float radius, float depth) {
  DentParams p;
  p.center_uv = c;
  p.end_uv = c;  // a round dent
  p.radius_mm = radius;
  p.depth_mm = depth;
  return std::make_unique<Dent>(p);
}

using Edge = std::pair<uint32_t, uint32_t>;
Edge undirected(uint32_t a, uint32_t b) { return {std::min(a, b), std::max(a, b)}; }

std::map<Edge, int> edgeUse(const TriangleMesh& m) {
  std::map<Edge, int> use;
  for (size_t t = 0; t < m.triangleCount(); ++t)
    for (int k = 0; k < 3; ++k) ++use[undirected(m.indices[3 * t + k], m.indices[3 * t + (k + 1) % 3])];
  return use;
}

double edgeLen(const TriangleMesh& m, uint32_t a, uint32_t b) { return length(Vec3d(m.positions[a] - m.positions[b])); }

bool onPlateBorder(Vec2f p, float w, float h) { return p.x == 0 || p.y == 0 || p.x == w || p.y == h; }

// Vertices lying strictly inside an edge (in UV), found with a uniform bucket grid over the edges.
int countTJunctions(const TriangleMesh& m, float w, float h, float bucket) {
  const int nx = int(std::ceil(w / bucket)) + 1, ny = int(std::ceil(h / bucket)) + 1;
  std::vector<std::vector<Edge>> grid(size_t(nx) * ny);
  auto cellOf = [&](float x, float y) {
    return std::pair<int, int>{std::clamp(int(x / bucket), 0, nx - 1), std::clamp(int(y / bucket), 0, ny - 1)};
  };
  for (const auto& [e, n] : edgeUse(m)) {
    const Vec2f a = m.uvs[e.first], b = m.uvs[e.second];
    auto [x0, y0] = cellOf(std::min(a.x, b.x), std::min(a.y, b.y));
    auto [x1, y1] = cellOf(std::max(a.x, b.x), std::max(a.y, b.y));
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) grid[size_t(y) * nx + x].push_back(e);
  }
  int bad = 0;
  for (uint32_t v = 0; v < m.positions.size(); ++v) {
    const Vec2f p = m.uvs[v];
    auto [cx, cy] = cellOf(p.x, p.y);
    for (const Edge& e : grid[size_t(cy) * nx + cx]) {
      if (e.first == v || e.second == v) continue;
      const Vec2d a{m.uvs[e.first].x, m.uvs[e.first].y}, b{m.uvs[e.second].x, m.uvs[e.second].y};
      const Vec2d ab = b - a, ap = Vec2d{p.x, p.y} - a;
      const double len2 = ab.x * ab.x + ab.y * ab.y;
      const double t = (ap.x * ab.x + ap.y * ab.y) / len2;
      const double dist = std::abs(ab.x * ap.y - ab.y * ap.x) / std::sqrt(len2);
      if (t > 1e-6 && t < 1 - 1e-6 && dist < 1e-5) ++bad;
    }
  }
  return bad;
}

double signedUvArea(const TriangleMesh& m, size_t t) {
  const Vec2f a = m.uvs[m.indices[3 * t]], b = m.uvs[m.indices[3 * t + 1]], c = m.uvs[m.indices[3 * t + 2]];
  return 0.5 * (double(b.x - a.x) * (c.y - a.y) - double(b.y - a.y) * (c.x - a.x));
}

TEST(Displacement, RefinementIsConformingAndKeepsTheBoundary) {
  const float W = 100, H = 60;
  TriangleMesh base = plate(10, 6, 10.0f);
  auto d = dent({43.7f, 31.2f}, 12.0f, 2.0f);
  DisplacementStats st;
  TriangleMesh out = displaceMesh(base, {d.get()}, {1.0f, 1'000'000}, &st);
  ASSERT_GT(st.triangles_split, 500u);
  EXPECT_EQ(out.triangleCount(), base.triangleCount() + st.triangles_split);
  EXPECT_EQ(out.positions.size(), base.positions.size() + st.vertices_added);
  EXPECT_EQ(out.uvs.size(), out.positions.size());
  EXPECT_EQ(out.normals.size(), out.positions.size());
  EXPECT_EQ(out.mmPerUv.size(), out.triangleCount());

  // Every edge used once (on the plate's border) or twice (inside), each direction at most once.
  std::set<Edge> directed;
  for (size_t t = 0; t < out.triangleCount(); ++t)
    for (int k = 0; k < 3; ++k)
      EXPECT_TRUE(directed.insert({out.indices[3 * t + k], out.indices[3 * t + (k + 1) % 3]}).second);
  size_t boundary = 0;
  const auto use = edgeUse(out);
  for (const auto& [e, n] : use) {
    const bool border = onPlateBorder(out.uvs[e.first], W, H) && onPlateBorder(out.uvs[e.second], W, H) &&
                        (out.uvs[e.first].x == out.uvs[e.second].x || out.uvs[e.first].y == out.uvs[e.second].y);
    EXPECT_EQ(n, border ? 1 : 2) << e.first << "-" << e.second;
    boundary += n == 1;
  }
  EXPECT_EQ(boundary, 2u * (10 + 6));  // the dent does not reach the border here
  // A disc: V - E + F = 1.
  EXPECT_EQ(int64_t(out.positions.size()) - int64_t(use.size()) + int64_t(out.triangleCount()), 1);
  EXPECT_EQ(countTJunctions(out, W, H, 2.0f), 0);
  // Orientation kept: every triangle still faces +z in UV (= xy).
  for (size_t t = 0; t < out.triangleCount(); ++t) ASSERT_GT(signedUvArea(out, t), 0.0) << t;
  // The refined triangles tile the plate exactly.
  double area = 0;
  for (size_t t = 0; t < out.triangleCount(); ++t) area += signedUvArea(out, t);
  EXPECT_NEAR(area, W * H, 1e-6 * W * H);
}

TEST(Displacement, VerticesFollowTheDentAndEdgesAreShort) {
  TriangleMesh base = plate(10, 6, 10.0f);
  auto d = dent({43.7f, 31.2f}, 12.0f, 2.0f);
  const float max_edge = 0.8f;
  TriangleMesh out = displaceMesh(base, {d.get()}, {max_edge, 1'000'000});
  double deepest = 0;
  for (size_t v = 0; v < out.positions.size(); ++v) {
    EXPECT_EQ(out.positions[v].x, out.uvs[v].x);
    EXPECT_EQ(out.positions[v].y, out.uvs[v].y);
    EXPECT_NEAR(out.positions[v].z, d->height(out.uvs[v]), 1e-5) << v;
    deepest = std::min(deepest, double(out.positions[v].z));
  }
  EXPECT_LT(deepest, -1.98);  // a vertex lies within ~0.5 mm of the centre
  const Box2 s = d->support();
  size_t in_support = 0;
  for (size_t t = 0; t < out.triangleCount(); ++t) {
    Box2 b;
    for (int k = 0; k < 3; ++k) {
      const Vec2f p = out.uvs[out.indices[3 * t + k]];
      b.lo = {std::min(b.lo.x, p.x), std::min(b.lo.y, p.y)};
      b.hi = {std::max(b.hi.x, p.x), std::max(b.hi.y, p.y)};
    }
    if (!b.overlaps(s)) continue;
    ++in_support;
    for (int k = 0; k < 3; ++k)
      EXPECT_LE(edgeLen(out, out.indices[3 * t + k], out.indices[3 * t + (k + 1) % 3]), max_edge + 1e-5);
  }
  // Bisection from 10 mm cells gives right isosceles triangles with a 10 sqrt2 / 16 = 0.884 mm
  // hypotenuse (area 0.195 mm2) at 1 mm, and half that area one level further at 0.8 mm.
  EXPECT_GT(double(in_support), 24.0 * 24.0 / 0.196);
  // mmPerUv of the children is their input triangle's (1 on this isometric chart).
  for (float k : out.mmPerUv) EXPECT_NEAR(k, 1.0f, 1e-6f);
}

TEST(Displacement, FarTrianglesAreUntouched) {
  TriangleMesh base = plate(30, 20, 10.0f);
  auto d = dent({143.7f, 101.2f}, 15.0f, 1.0f);
  TriangleMesh out = displaceMesh(base, {d.get()}, {1.0f, 1'000'000});
  // Far = more than 20 mm (two cells) from the support box.
  Box2 near = d->support();
  near.lo = near.lo - Vec2f{20, 20};
  near.hi = near.hi + Vec2f{20, 20};
  auto centroid = [](const TriangleMesh& m, size_t t) {
    return (m.uvs[m.indices[3 * t]] + m.uvs[m.indices[3 * t + 1]] + m.uvs[m.indices[3 * t + 2]]) * (1.0f / 3);
  };
  size_t far_in = 0, far_out = 0;
  for (size_t t = 0; t < base.triangleCount(); ++t) {
    if (near.contains(centroid(base, t))) continue;
    ++far_in;
    for (int k = 0; k < 3; ++k) {
      ASSERT_EQ(out.indices[3 * t + k], base.indices[3 * t + k]) << t;
      EXPECT_EQ(out.positions[out.indices[3 * t + k]], base.positions[base.indices[3 * t + k]]);
      EXPECT_EQ(out.normals[out.indices[3 * t + k]], base.normals[base.indices[3 * t + k]]);
    }
    EXPECT_EQ(out.mmPerUv[t], base.mmPerUv[t]);
  }
  for (size_t t = 0; t < out.triangleCount(); ++t) far_out += !near.contains(centroid(out, t));
  EXPECT_EQ(far_out, far_in);
  EXPECT_GT(far_in, base.triangleCount() / 2);
  // Input vertices keep their index and, outside the support, their position.
  for (size_t v = 0; v < base.positions.size(); ++v) {
    if (!d->support().contains(base.uvs[v])) {
      EXPECT_EQ(out.positions[v], base.positions[v]);
    }
  }
}

TEST(Displacement, VolumeMatchesThePolynomialBowl) {
  TriangleMesh base = plate(12, 12, 5.0f);
  const float R = 15.0f, depth = 1.5f;
  auto d = dent({30.3f, 29.6f}, R, depth);
  TriangleMesh out = displaceMesh(base, {d.get()}, {0.5f, 1'000'000});
  // Volume between the surface and z = 0: projected area times the mean height, per triangle.
  double vol = 0;
  for (size_t t = 0; t < out.triangleCount(); ++t) {
    const Vec3f a = out.positions[out.indices[3 * t]], b = out.positions[out.indices[3 * t + 1]],
                c = out.positions[out.indices[3 * t + 2]];
    const double proj = 0.5 * (double(b.x - a.x) * (c.y - a.y) - double(b.y - a.y) * (c.x - a.x));
    vol += proj * (double(a.z) + b.z + c.z) / 3.0;
  }
  const double analytic = -kPi * depth * R * R / 3.0;
  EXPECT_NEAR(vol / analytic, 1.0, 0.002) << vol << " vs " << analytic;
}

TEST(Displacement, DentOnTheEdgeChangesTheOutline) {
  const float W = 100, H = 60;
  TriangleMesh base = plate(10, 6, 10.0f);
  auto d = dent({52.5f, 0.0f}, 10.0f, 2.0f);
  TriangleMesh out = displaceMesh(base, {d.get()}, {1.0f, 1'000'000});
  const auto use = edgeUse(out);
  double lowest = 0;
  size_t boundary_moved = 0;
  for (const auto& [e, n] : use) {
    if (n != 1) continue;
    // Boundary edges stay on the plate's border (in UV) ...
    EXPECT_TRUE(onPlateBorder(out.uvs[e.first], W, H) && onPlateBorder(out.uvs[e.second], W, H));
    for (uint32_t v : {e.first, e.second}) {
      boundary_moved += out.positions[v].z != 0.0f;
      lowest = std::min(lowest, double(out.positions[v].z));
    }
  }
  // ... but the border now dips: the outline seen edge-on follows the dent's profile.
  EXPECT_GT(boundary_moved, 20u);
  EXPECT_LT(lowest, -0.99 * 2.0);
  EXPECT_EQ(countTJunctions(out, W, H, 2.0f), 0);
}

TEST(Displacement, ZeroDepthMovesNothingAndNoDefectChangesNothing) {
  TriangleMesh base = plate(10, 6, 10.0f);
  auto flat = dent({43.7f, 31.2f}, 12.0f, 0.0f);
  DisplacementStats st;
  TriangleMesh out = displaceMesh(base, {flat.get()}, {1.0f, 1'000'000}, &st);
  EXPECT_GT(st.triangles_split, 0u);  // refined ...
  EXPECT_EQ(st.vertices_moved, 0u);   // ... but nothing moved
  for (size_t v = 0; v < base.positions.size(); ++v) EXPECT_EQ(out.positions[v], base.positions[v]);
  for (size_t v = 0; v < out.positions.size(); ++v) {
    EXPECT_EQ(out.positions[v].z, 0.0f);
    EXPECT_EQ(out.normals[v], Vec3f(0, 0, 1));
  }

  auto same = [](const TriangleMesh& a, const TriangleMesh& b) {
    return a.positions == b.positions && a.normals == b.normals && a.indices == b.indices &&
           a.mmPerUv == b.mmPerUv && a.source == b.source && a.uvs.size() == b.uvs.size() &&
           std::equal(a.uvs.begin(), a.uvs.end(), b.uvs.begin(),
                      [](Vec2f p, Vec2f q) { return p.x == q.x && p.y == q.y; });
  };
  EXPECT_TRUE(same(displaceMesh(base, {}, {}), base));
  // A dent that misses the part changes nothing either.
  auto away = dent({500.0f, 500.0f}, 10.0f, 2.0f);
  EXPECT_TRUE(same(displaceMesh(base, {away.get()}, {}), base));
}

TEST(Displacement, NormalsAreUnitAndTiltTowardTheCentre) {
  TriangleMesh base = plate(12, 12, 5.0f);
  const Vec2f c{30.3f, 29.6f};
  const float R = 15.0f, depth = 2.0f;
  auto d = dent(c, R, depth);
  TriangleMesh out = displaceMesh(base, {d.get()}, {0.5f, 1'000'000});
  double worst_deg = 0;
  size_t flank = 0;
  for (size_t v = 0; v < out.positions.size(); ++v) {
    const Vec3f n = out.normals[v];
    EXPECT_NEAR(length(n), 1.0f, 1e-5f);
    const double dx = out.uvs[v].x - c.x, dy = out.uvs[v].y - c.y, r = std::hypot(dx, dy);
    if (r >= R) {
      EXPECT_EQ(n, Vec3f(0, 0, 1));  // outside the dent: the input's normal, exactly
      continue;
    }
    if (r < 0.3 * R || r > 0.8 * R) continue;
    ++flank;
    EXPECT_GT(-(n.x * dx + n.y * dy) / r, 0.02) << "normal does not lean toward the centre";
    // Analytic normal of z = F(r): (-F'(r) dx/r, -F'(r) dy/r, 1), normalized.
    const double s = d->slope(r);
    const Vec3d exact = normalize(Vec3d{-s * dx / r, -s * dy / r, 1.0});
    worst_deg = std::max(worst_deg, std::acos(std::min(1.0, dot(exact, Vec3d(n)))) * 180.0 / kPi);
  }
  EXPECT_GT(flank, 1000u);
  EXPECT_LT(worst_deg, 0.1);  // the tilt reaches 11.7 degrees here
}

TEST(Displacement, CurvedPartKeepsSmoothNormalsWhereNothingMoves) {
  // A half cylinder of radius 50 mm along x, smooth normals, UV = (x, arc length).
  const float Rc = 50.0f;
  const int nx = 10, na = 12;
  TriangleMesh m;
  for (int j = 0; j <= na; ++j)
    for (int i = 0; i <= nx; ++i) {
      const float a = float(kPi) * j / na;
      m.positions.push_back({10.0f * i, Rc * std::cos(a), Rc * std::sin(a)});
      m.normals.push_back({0.0f, std::cos(a), std::sin(a)});
      m.uvs.push_back({10.0f * i, Rc * a});
    }
  for (int j = 0; j < na; ++j)
    for (int i = 0; i < nx; ++i) {
      const uint32_t a = j * (nx + 1) + i, b = a + 1, cc = a + nx + 2, dd = a + nx + 1;
      m.indices.insert(m.indices.end(), {a, b, cc, a, cc, dd});
    }
  m.computeMmPerUv();
  auto flat = dent({50.0f, Rc * float(kPi) / 2}, 20.0f, 0.0f);
  DisplacementStats st;
  TriangleMesh out = displaceMesh(m, {flat.get()}, {1.0f, 1'000'000}, &st);
  ASSERT_GT(st.vertices_added, 100u);
  double worst = 0;
  for (size_t v = m.positions.size(); v < out.positions.size(); ++v) {
    EXPECT_NEAR(length(out.normals[v]), 1.0f, 1e-6f);
    // The smooth normal at the new vertex's angle (from its UV), not the facet's normal.
    const double a = out.uvs[v].y / Rc;
    worst = std::max(worst, length(Vec3d(out.normals[v]) - Vec3d{0, std::cos(a), std::sin(a)}));
  }
  EXPECT_LT(worst, 2e-3);
  for (size_t v = 0; v < m.positions.size(); ++v) EXPECT_EQ(out.normals[v], m.normals[v]);
  // mmPerUv of children equals their parent's.
  for (size_t t = 0; t < out.triangleCount(); ++t) EXPECT_GT(out.mmPerUv[t], 0.98f);

  // A real dent on the curve: the surface moves inward along the normals, toward the axis.
  auto deep = dent({50.0f, Rc * float(kPi) / 2}, 20.0f, 3.0f);
  TriangleMesh dented = displaceMesh(m, {deep.get()}, {1.0f, 1'000'000});
  // The input vertex at the centre (on the cylinder) moves by the full depth; the others lie on the
  // input's flat facets, at most the sagitta 50 (1 - cos 7.5 deg) = 0.428 mm inside the cylinder.
  const uint32_t centre = 6 * (nx + 1) + 5;
  ASSERT_EQ(dented.uvs[centre].x, 50.0f);
  EXPECT_NEAR(std::hypot(double(dented.positions[centre].y), double(dented.positions[centre].z)), Rc - 3.0, 1e-4);
  for (size_t v = 0; v < dented.positions.size(); ++v) {
    const double r = std::hypot(double(dented.positions[v].y), double(dented.positions[v].z));
    EXPECT_GE(r, Rc - 3.0 - 0.429);
    EXPECT_LE(r, Rc + 1e-4);
    EXPECT_NEAR(r - Rc, deep->height(dented.uvs[v]), 0.429);
  }
}

TEST(Displacement, EdgeSharedByThreeTrianglesIsSplitInAll) {
  // Three fins on the spine (0,0,0)-(10,0,0): a non-manifold edge.
  TriangleMesh m;
  m.positions = {{0, 0, 0}, {10, 0, 0}, {5, 5, 0}, {5, -5, 0}, {5, 0, 5}};
  m.uvs = {{0, 0}, {10, 0}, {5, 5}, {5, -5}, {5, 5}};
  m.indices = {0, 1, 2, 1, 0, 3, 0, 1, 4};
  m.computeMmPerUv();
  auto flat = dent({5.0f, 0.0f}, 3.0f, 0.0f);
  DisplacementStats st;
  TriangleMesh out = displaceMesh(m, {flat.get()}, {1.0f, 100000}, &st);
  ASSERT_GT(st.triangles_split, 10u);
  size_t spine = 0;
  for (const auto& [e, n] : edgeUse(out)) {
    const Vec3f a = out.positions[e.first], b = out.positions[e.second];
    const bool on_spine = a.y == 0 && a.z == 0 && b.y == 0 && b.z == 0;
    EXPECT_EQ(n, on_spine ? 3 : (n == 1 ? 1 : 2));
    spine += on_spine;
  }
  EXPECT_GE(spine, 10u);  // the spine has at least 10 pieces of <= 1 mm
  double area = 0;
  for (size_t t = 0; t < out.triangleCount(); ++t) {
    const Vec3d a(out.positions[out.indices[3 * t]]), b(out.positions[out.indices[3 * t + 1]]),
        c(out.positions[out.indices[3 * t + 2]]);
    area += 0.5 * length(cross(b - a, c - a));
  }
  EXPECT_NEAR(area, 3 * 25.0, 1e-3);
}

TEST(Displacement, DeterministicAndBounded) {
  TriangleMesh base = plate(10, 6, 10.0f);
  auto d1 = dent({43.7f, 31.2f}, 12.0f, 2.0f);
  auto d2 = dent({55.0f, 25.0f}, 8.0f, 1.0f);  // overlapping: heights add
  TriangleMesh a = displaceMesh(base, {d1.get(), d2.get()}, {0.7f, 1'000'000});
  TriangleMesh b = displaceMesh(base, {d1.get(), d2.get()}, {0.7f, 1'000'000});
  EXPECT_TRUE(a.positions == b.positions && a.normals == b.normals && a.indices == b.indices &&
              a.mmPerUv == b.mmPerUv);
  const Vec2f p = a.uvs[a.positions.size() - 1];
  EXPECT_NEAR(a.positions.back().z, d1->height(p) + d2->height(p), 1e-5);
  EXPECT_THROW(displaceMesh(base, {d1.get()}, {0.1f, 20'000}), std::runtime_error);
  EXPECT_THROW(displaceMesh(base, {d1.get()}, {0.0f, 20'000}), std::invalid_argument);
  TriangleMesh no_uv = base;
  no_uv.uvs.clear();
  EXPECT_THROW(displaceMesh(no_uv, {d1.get()}, {}), std::invalid_argument);
}

TEST(Displacement, DoorPanelCostIsLocal) {
  // 1000 x 600 mm with 10 mm cells (12,000 triangles), three 30 mm dents, 1 mm edges.
  TriangleMesh base = plate(100, 60, 10.0f);
  auto d1 = dent({203.3f, 151.7f}, 30.0f, 2.0f);
  auto d2 = dent({611.1f, 402.2f}, 30.0f, 3.0f);
  auto d3 = dent({850.0f, 590.0f}, 30.0f, 1.0f);  // over the top border
  DisplacementStats st;
  const auto t0 = std::chrono::steady_clock::now();
  TriangleMesh out = displaceMesh(base, {d1.get(), d2.get(), d3.get()}, {1.0f, 4'000'000}, &st);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  std::printf("door panel: %zu -> %zu triangles, %zu vertices moved, %.1f ms\n", base.triangleCount(),
              out.triangleCount(), st.vertices_moved, ms);
  // Each 60 x 60 mm support (a bit more: the triangles overlapping it) at 0.195 mm2 per triangle is
  // ~18,500 triangles; the whole panel at that size would be 3 million.
  EXPECT_LT(st.triangles_split, 3u * 30000u);
  EXPECT_GT(st.triangles_split, 2u * 18000u);
  EXPECT_EQ(countTJunctions(out, 1000, 600, 5.0f), 0);
}

}  // namespace
}  // namespace dg
