// PartGeometry (render/scene.h): its surface sampling within a UV region (the placement of defects
// whose region is a small part of a large chart), and the BVH layout it chooses by size.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>

#include "core/parallel.h"
#include "core/rng.h"
#include "render/mesh.h"
#include "render/parts.h"
#include "render/scene.h"

namespace dg {
namespace {

// A 1000 mm square chart in two triangles that do not share vertices: the lower-right one
// (v < u) flat and isometric, the upper-left one (v > u) with its 3-D positions `stretch` times
// larger, so it stands for stretch^2 times the surface per unit of UV area.
TriangleMesh twoTriangles(float stretch) {
  TriangleMesh m;
  m.source = "test";
  m.positions = {{0, 0, 0}, {1000, 0, 0}, {1000, 1000, 0},
                 {0, 0, 0}, {1000 * stretch, 1000 * stretch, 0}, {0, 1000 * stretch, 0}};
  m.uvs = {{0, 0}, {1000, 0}, {1000, 1000}, {0, 0}, {1000, 1000}, {0, 1000}};
  m.indices = {0, 1, 2, 3, 4, 5};
  return m;
}

Box2 box(float u0, float v0, float u1, float v1) {
  Box2 b;
  b.lo = {u0, v0};
  b.hi = {u1, v1};
  return b;
}

TEST(PartGeometry, ASurfacePointInATinyRegionIsFoundInOneDraw) {
  PartGeometry g(twoTriangles(1));
  // 0.1 mm square: 1e-8 of the chart; a draw over the two triangles would hit it once in 10^8.
  const Box2 tiny = box(500.35f, 200.05f, 500.45f, 200.15f);
  Rng rng(7);
  for (int i = 0; i < 100; ++i) {
    Vec2f uv;
    ASSERT_TRUE(g.sampleSurfaceUvIn(tiny, rng, uv));
    EXPECT_TRUE(tiny.contains(uv)) << uv.x << " " << uv.y;
  }
  // Outside the chart there is nothing to find.
  Vec2f uv;
  EXPECT_FALSE(g.sampleSurfaceUvIn(box(1200, 1200, 1300, 1300), rng, uv));
}

// Uniform by surface area: in a box split evenly by the diagonal, the stretched triangle's half
// (4 times the surface) gets 4/5 of the points; within each half the points are uniform.
TEST(PartGeometry, RegionSamplesAreUniformBySurfaceArea) {
  PartGeometry g(twoTriangles(2));
  const Box2 square = box(400, 400, 600, 600);
  Rng rng(11);
  const int n = 20000;
  int upper = 0, upper_left = 0;
  double mean_lower_x = 0;
  for (int i = 0; i < n; ++i) {
    Vec2f uv;
    ASSERT_TRUE(g.sampleSurfaceUvIn(square, rng, uv));
    ASSERT_TRUE(square.contains(uv));
    if (uv.y > uv.x) {
      ++upper;
      upper_left += uv.x < 500;
    } else {
      mean_lower_x += uv.x;
    }
  }
  const double share = double(upper) / n;  // 0.8, sigma 0.0028
  EXPECT_NEAR(share, 0.8, 0.012);
  // The upper half {y > x} of the box: x < 500 holds 3/4 of its area.
  EXPECT_NEAR(double(upper_left) / upper, 0.75, 0.015);
  // The lower half's mean x: (2/3) 600 + (1/3) 400 = 533.3 for a uniform triangle.
  EXPECT_NEAR(mean_lower_x / (n - upper), 533.33, 2.5);
}

// A mesh of a million triangles or more (the explicit-geometry scratch reference) gets Embree's
// compact BVH, a smaller one the default; both find the same triangle.
TEST(PartGeometry, OnlyALargeMeshGetsTheCompactBvh) {
  for (double edge : {20.0, std::sqrt(2.0)}) {  // 36 x 36 cells, then 710 x 710: 1.008 million triangles
    PartGeometry g(makePlate({710, 710}, edge));
    const bool large = g.mesh().triangleCount() >= PartGeometry::kCompactBvhTriangles;
    EXPECT_EQ(large, edge < 2) << g.mesh().triangleCount();
    EXPECT_EQ((rtcGetSceneFlags(g.scene()) & RTC_SCENE_FLAG_COMPACT) != 0, large);
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHit rh{};
    rh.ray.org_x = 300.3f;
    rh.ray.org_y = 200.6f;
    rh.ray.org_z = 50;
    rh.ray.dir_z = -1;
    rh.ray.tfar = 1e9f;
    rh.ray.mask = 0xFFFFFFFFu;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(g.scene(), &ctx, &rh);
    ASSERT_EQ(rh.hit.geomID, 0u);
    EXPECT_NEAR(rh.ray.tfar, 50.0f, 1e-4f);
    // The triangle found holds the point.
    const uint32_t* f = &g.mesh().indices[3 * rh.hit.primID];
    float lo_x = 1e9f, hi_x = -1e9f;
    for (int k = 0; k < 3; ++k) {
      lo_x = std::min(lo_x, g.mesh().positions[f[k]].x);
      hi_x = std::max(hi_x, g.mesh().positions[f[k]].x);
    }
    EXPECT_LE(lo_x, 300.3f);
    EXPECT_GE(hi_x, 300.3f);
  }
}


// The per-triangle frames, the area sums and the UV box are computed in slices on all threads;
// the result does not depend on the thread count, and a triangle late in the mesh (past the
// first slices) still counts: a collapsed UV triangle and the farthest UV are found.
TEST(PartGeometry, FramesAreTheSameWhateverTheThreadCount) {
  TriangleMesh m = makePlate({300, 300}, 1.0);  // 180,000 triangles: slices of 65,536
  ASSERT_GT(m.triangleCount(), 150000u);
  const size_t late = m.triangleCount() - 7;
  const uint32_t* f = &m.indices[3 * late];
  // Its own three vertices: collapsed in UV (a point), unchanged in 3-D.
  for (int k = 0; k < 3; ++k) {
    m.positions.push_back(m.positions[f[k]]);
    m.uvs.push_back({1234.5f, -77.25f});
    if (!m.normals.empty()) m.normals.push_back(m.normals[f[k]]);
  }
  const uint32_t first = uint32_t(m.positions.size() - 3);
  for (int k = 0; k < 3; ++k) m.indices[3 * late + k] = first + uint32_t(k);
  auto build = [&](int threads) {
    ThreadLimit limit(threads);
    return std::make_unique<PartGeometry>(m);
  };
  auto one = build(1), two = build(2);
  EXPECT_EQ(one->degenerateUvCount(), 1u);
  EXPECT_FALSE(one->frame(unsigned(late)).uv_ok);
  EXPECT_TRUE(one->frame(unsigned(late - 1)).uv_ok);
  EXPECT_EQ(one->uvBounds().hi.x, 1234.5f);
  EXPECT_EQ(one->uvBounds().lo.y, -77.25f);
  EXPECT_EQ(two->degenerateUvCount(), one->degenerateUvCount());
  const Box2 b1 = one->uvBounds(), b2 = two->uvBounds();
  EXPECT_EQ(std::memcmp(&b1, &b2, sizeof(Box2)), 0);
  size_t differ = 0;
  for (unsigned t = 0; t < m.triangleCount(); ++t) {
    const auto &a = one->frame(t), &b = two->frame(t);
    differ += std::memcmp(&a.dpdu, &b.dpdu, sizeof(Vec3f)) || std::memcmp(&a.dpdv, &b.dpdv, sizeof(Vec3f)) ||
              std::memcmp(&a.ng, &b.ng, sizeof(Vec3f)) || a.uv_ok != b.uv_ok;
  }
  EXPECT_EQ(differ, 0u);
  // Points drawn by area: the same triangle and point (the area sums' bits) on both.
  Rng rng(5);
  for (int i = 0; i < 1000; ++i) {
    const double u0 = rng.uniformD(), u1 = rng.uniformD(), u2 = rng.uniformD();
    const Vec2f p = one->sampleSurfaceUv(u0, u1, u2), q = two->sampleSurfaceUv(u0, u1, u2);
    ASSERT_EQ(std::memcmp(&p, &q, sizeof(Vec2f)), 0) << i;
  }
  // The whole plate is drawn from: the last draws land near its far corner (the sums run to its
  // end in order).
  const Vec2f end = one->sampleSurfaceUv(1.0 - 1e-12, 0.5, 0.5);
  EXPECT_GT(end.x + end.y, 590.0f);
}

}  // namespace
}  // namespace dg
