// The explicit-geometry reference for scratches and the normal-map baseline.
#include <gtest/gtest.h>

#include <cmath>

#include "defects/scratch.h"
#include "render/parts.h"
#include "render/scratch_geometry.h"

using namespace dg;

namespace {
Scratch straightScratch() {
  // A symmetric V-groove 0.1 mm wide, 0.03 mm deep, along u through the plate's middle.
  Profile p = Profile::fromPolyline({{-0.05, 0.0}, {0.0, -0.03}, {0.05, 0.0}});
  return Scratch::fromProfile(ScratchPath::polyline({{5.0, 10.0}, {15.0, 10.0}}), p);
}
}  // namespace

TEST(ScratchGeometry, VerticesFollowTheCrossSectionAndNormalsAreTheFacets) {
  PlateParams pp;
  pp.width_mm = 20;
  pp.height_mm = 20;
  TriangleMesh plate = makePlate(pp, 5);
  Scratch s = straightScratch();
  std::vector<const Scratch*> list{&s};
  ScratchGeometryStats st;
  TriangleMesh m = scratchedPlanarMesh(plate, list, {}, &st);
  EXPECT_NEAR(st.cell_mm, 0.1 / 32, 0.1 / 32);  // the automatic cell: width / 32, rounded to a power-of-2 split
  ASSERT_GT(m.triangleCount(), 1000u);
  ASSERT_EQ(m.normals.size(), m.positions.size());
  // Plate normal and the chart's offset: a vertex's height above the plate equals the profile's.
  Vec3f n0 = normalize(cross(plate.positions[plate.indices[1]] - plate.positions[plate.indices[0]],
                             plate.positions[plate.indices[2]] - plate.positions[plate.indices[0]]));
  double zmin = 1e9, worst = 0;
  size_t wall = 0;
  const double slope = 0.03 / 0.05, nz = 1 / std::sqrt(1 + slope * slope);
  for (size_t i = 0; i < m.positions.size(); ++i) {
    float h = s.height(m.uvs[i]);
    // The plate lies in a plane through the origin's level: compare against the undisplaced point.
    Vec3f base = plate.positions[0] + Vec3f(0.0f);  // any plate point: the plane's offset
    double above = dot(m.positions[i] - base, n0);
    worst = std::max(worst, std::fabs(above - h));
    zmin = std::min(zmin, above);
  }
  EXPECT_LT(worst, 1e-4);
  EXPECT_NEAR(zmin, -0.03, 2e-3);
  // Triangles well inside a wall carry that wall's exact normal (tilt atan(0.6)).
  for (size_t t = 0; t < m.triangleCount(); ++t) {
    Vec2f c = (m.uvs[3 * t] + m.uvs[3 * t + 1] + m.uvs[3 * t + 2]) / 3.0f;
    float b = c.y - 10.0f;
    if (c.x < 8 || c.x > 12 || std::fabs(std::fabs(b) - 0.025f) > 0.01f) continue;
    ++wall;
    Vec3f n = m.normals[3 * t];
    EXPECT_NEAR(dot(n, n0), nz, 1e-3);
  }
  EXPECT_GT(wall, 100u);
}

TEST(ScratchGeometry, RejectsCurvedParts) {
  DoorPanelParams dp;
  TriangleMesh door = makeDoorPanel(dp, 40);
  Scratch s = straightScratch();
  std::vector<const Scratch*> list{&s};
  EXPECT_THROW(scratchedPlanarMesh(door, list), std::runtime_error);
}

TEST(ScratchNormalMap, GradientIsTheFacetSlopeAndOffWithoutBumpShading) {
  Scratch s = straightScratch();
  DefectQuery q;
  q.uv = {10.0f, 10.02f};  // left of the path (b = +0.02): the wall rising toward +b
  DefectShading off;
  s.shade(q, off);
  EXPECT_EQ(off.height_grad.x, 0.0f);
  EXPECT_EQ(off.height_grad.y, 0.0f);
  s.setBumpShading(true);
  DefectShading on;
  s.shade(q, on);
  EXPECT_NEAR(on.height_grad.x, 0.0, 1e-6);
  EXPECT_NEAR(on.height_grad.y, 0.6, 1e-4);  // dh/db = 0.03 / 0.05 with B = +v
  q.uv = {10.0f, 11.0f};  // off the groove
  DefectShading flat;
  s.shade(q, flat);
  EXPECT_EQ(flat.height_grad.y, 0.0f);
}
