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
  EXPECT_NEAR(st.cell_mm, 0.1 / 16, 0.1 / 16);  // the automatic cell: width / 16, rounded to a power-of-2 split
  ASSERT_GT(m.triangleCount(), 500u);
  ASSERT_EQ(m.normals.size(), m.positions.size());
  // Plate normal and the chart's offset: a vertex's height above the plate equals the profile's.
  Vec3f n0 = normalize(cross(plate.positions[plate.indices[1]] - plate.positions[plate.indices[0]],
                             plate.positions[plate.indices[2]] - plate.positions[plate.indices[0]]));
  double zmin = 1e9, worst = 0;
  const double slope = 0.03 / 0.05, nz = 1 / std::sqrt(1 + slope * slope);
  for (size_t i = 0; i < m.positions.size(); ++i) {
    float h = s.height(m.uvs[i]);
    // The plate lies in a plane through the origin's level: compare against the undisplaced point.
    Vec3f base = plate.positions[0] + Vec3f(0.0f);  // any plate point: the plane's offset
    double above = dot(m.positions[i] - base, n0);
    worst = std::max(worst, std::fabs(above - h));
    zmin = std::min(zmin, above);
  }
  EXPECT_LT(worst, 1e-5);
  // Cells are cut along the kinks, so the groove's bottom line is in the mesh exactly.
  EXPECT_NEAR(zmin, -0.03, 1e-5);
  // Every triangle lies on one facet: its normal is the flat plate's or one wall's (tilt atan(0.6)),
  // its geometric normal agrees with it, and the walls' area is the analytic one.
  size_t wall = 0;
  double wall_area = 0;
  for (size_t t = 0; t < m.triangleCount(); ++t) {
    // Away from the blunt ends, where the groove's end face becomes a ramp one cell long.
    Vec2f cu = (m.uvs[3 * t] + m.uvs[3 * t + 1] + m.uvs[3 * t + 2]) / 3.0f;
    if (cu.x < 6 || cu.x > 14) continue;
    Vec3f n = m.normals[3 * t];
    Vec3f g = cross(m.positions[3 * t + 1] - m.positions[3 * t], m.positions[3 * t + 2] - m.positions[3 * t]);
    float ga = length(g);
    const double c = dot(n, n0);
    const bool flat = std::fabs(c - 1) < 1e-4, tilted = std::fabs(c - nz) < 1e-4;
    ASSERT_TRUE(flat || tilted) << "triangle " << t << " normal . n0 = " << c;
    if (ga > 1e-8f) EXPECT_NEAR(std::fabs(dot(g / ga, n)), 1.0, 2e-3) << "triangle " << t;
    if (tilted) {
      ++wall;
      wall_area += 0.5 * ga;
    }
  }
  EXPECT_GT(wall, 100u);
  // Two walls, each 8 mm long (between u = 6 and 14) and sqrt(0.05^2 + 0.03^2) mm wide; cells
  // on the cut lines u = 6 and 14 count by their centroid.
  EXPECT_NEAR(wall_area, 2 * 8 * std::sqrt(0.05 * 0.05 + 0.03 * 0.03), 2e-3);
}

// The cut cells make the mesh exact at any cell size: the same surface at width / 4 and / 32.
TEST(ScratchGeometry, CellSizeDoesNotChangeTheSurface) {
  PlateParams pp;
  pp.width_mm = 20;
  pp.height_mm = 20;
  TriangleMesh plate = makePlate(pp, 5);
  Profile prof = Profile::fromPolyline({{-0.06, 0.0}, {-0.05, 0.004}, {-0.02, -0.02}, {0.0, -0.03},
                                        {0.03, -0.01}, {0.05, 0.006}, {0.07, 0.0}});
  // Oblique, so that kinks cross the cells at an angle.
  Scratch s = Scratch::fromProfile(ScratchPath::polyline({{5.0, 6.0}, {15.0, 13.0}}), prof);
  std::vector<const Scratch*> list{&s};
  auto area = [&](double cell, double& tilted) {
    ScratchGeometryOptions o;
    o.cell_mm = cell;
    TriangleMesh m = scratchedPlanarMesh(plate, list, o);
    double a = 0;
    tilted = 0;
    for (size_t t = 0; t < m.triangleCount(); ++t) {
      Vec3f g = cross(m.positions[3 * t + 1] - m.positions[3 * t], m.positions[3 * t + 2] - m.positions[3 * t]);
      a += 0.5 * length(g);
      // Facet area away from the blunt ends: centroids between 2 mm and L - 2 mm along the path.
      Vec2f c = (m.uvs[3 * t] + m.uvs[3 * t + 1] + m.uvs[3 * t + 2]) / 3.0f;
      double along = ((c.x - 5.0) * 10.0 + (c.y - 6.0) * 7.0) / std::hypot(10.0, 7.0);
      if (m.normals[3 * t].z < 0.9999f && along > 2 && along < std::hypot(10.0, 7.0) - 2) tilted += 0.5 * length(g);
    }
    return a;
  };
  double t1, t2;
  double a1 = area(0.14 / 4, t1), a2 = area(0.14 / 32, t2);
  EXPECT_NEAR(a1, a2, 1e-4 * a1);
  // The facets' area: the profile's arc length times the path length, less its width.
  double arc = 0;
  for (size_t i = 0; i + 1 < prof.pts.size(); ++i) arc += std::hypot(prof.pts[i + 1].x - prof.pts[i].x, prof.pts[i + 1].y - prof.pts[i].y);
  const double L = std::hypot(10.0, 7.0) - 4;
  EXPECT_NEAR(t1, L * arc, 1e-2 * L * arc);  // cells on the two cut lines count by their centroid
  EXPECT_NEAR(t2, L * arc, 2e-3 * L * arc);
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
