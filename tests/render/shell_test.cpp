// The solid made from an open part surface for glass (solidShell, PartGeometry's shell): closed,
// wound outward, the back at the thickness, and closed meshes left alone.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include <embree3/rtcore.h>

#include "core/rng.h"
#include "render/mesh.h"
#include "render/mesh_io.h"
#include "render/parts.h"
#include "render/scene.h"

namespace dg {
namespace {

struct RayHit {
  bool hit = false;
  unsigned geom = 0, prim = 0;
  Vec3f ng;  // unit, from the winding
  float t = 0;
};

RayHit cast(const PartGeometry& g, Vec3f o, Vec3f d) {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRayHit rh{};
  rh.ray.org_x = o.x;
  rh.ray.org_y = o.y;
  rh.ray.org_z = o.z;
  rh.ray.dir_x = d.x;
  rh.ray.dir_y = d.y;
  rh.ray.dir_z = d.z;
  rh.ray.tnear = 0;
  rh.ray.tfar = 1e30f;
  rh.ray.mask = ~0u;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(g.scene(), &ctx, &rh);
  RayHit r;
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return r;
  r.hit = true;
  r.geom = rh.hit.geomID;
  r.prim = rh.hit.primID;
  r.t = rh.ray.tfar;
  r.ng = r.geom == PartGeometry::kShellGeometry ? g.shellNormal(r.prim) : g.frame(r.prim).ng;
  return r;
}

Vec3f randomDirection(Rng& rng) {
  float z = 2 * rng.uniform() - 1, phi = 2 * kPiF * rng.uniform();
  float s = std::sqrt(std::max(0.0f, 1 - z * z));
  return {s * std::cos(phi), s * std::sin(phi), z};
}

// Rays from points inside the solid leave it through exactly the surface they meet first, and
// that surface's outward normal points along the ray (so the integrator's "arrived from outside"
// test is right everywhere): no leak, no face wound inward.
void expectClosedAndOutward(const PartGeometry& g, Vec3f inside_lo, Vec3f inside_hi) {
  Rng rng(7);
  int misses = 0, inward = 0, shell_hits = 0;
  const int n = 4000;
  for (int i = 0; i < n; ++i) {
    Vec3f o{inside_lo.x + (inside_hi.x - inside_lo.x) * rng.uniform(),
            inside_lo.y + (inside_hi.y - inside_lo.y) * rng.uniform(),
            inside_lo.z + (inside_hi.z - inside_lo.z) * rng.uniform()};
    Vec3f d = randomDirection(rng);
    RayHit h = cast(g, o, d);
    if (!h.hit) {
      ++misses;
      continue;
    }
    shell_hits += h.geom == PartGeometry::kShellGeometry;
    if (dot(h.ng, d) <= 0) ++inward;
  }
  EXPECT_EQ(misses, 0);
  EXPECT_EQ(inward, 0);
  EXPECT_GT(shell_hits, n / 4);  // the back and the rim are really there
  EXPECT_LT(shell_hits, n);      // and so is the front
}

TEST(SolidShell, PlateBecomesAClosedSlab) {
  TriangleMesh front = makePlate({40, 30}, 5);
  ASSERT_GT(boundaryEdgeCount(front), 0u);
  TriangleMesh shell = solidShell(front, 3.0f);
  ASSERT_GT(shell.triangleCount(), front.triangleCount());  // back + rim
  // The back lies 3 mm below the front (the plate faces +z at z = 0) and faces -z.
  float zmin = 1e30f, zmax = -1e30f;
  for (size_t t = 0; t < front.triangleCount(); ++t)
    for (int k = 0; k < 3; ++k) {
      float z = shell.positions[shell.indices[3 * t + size_t(k)]].z;
      zmin = std::min(zmin, z);
      zmax = std::max(zmax, z);
    }
  EXPECT_NEAR(zmin, -3.0f, 1e-5f);
  EXPECT_NEAR(zmax, -3.0f, 1e-5f);
  PartGeometry g(front, shell);
  for (size_t t = 0; t < front.triangleCount(); ++t) EXPECT_NEAR(g.shellNormal(unsigned(t)).z, -1.0f, 1e-6f);
  expectClosedAndOutward(g, {-19.5f, -14.5f, -2.9f}, {19.5f, 14.5f, -0.1f});
}

TEST(SolidShell, CurvedPartAndCutHeights) {
  // A bowed door skin: the back follows the vertex normals, and a vertex moved by `heights`
  // (a cut-in groove) puts its back copy where the unmoved vertex would have.
  DoorPanelParams dp;
  dp.width_mm = 120;
  dp.height_mm = 100;
  dp.curvature_radius_mm = 200;
  dp.character_line_depth_mm = 0;
  TriangleMesh front = makeDoorPanel(dp, 10);
  TriangleMesh shell = solidShell(front, 4.0f);
  PartGeometry g(front, shell);
  // Inside points: a few mm below the front at random spots, along the front's normals.
  Rng rng(3);
  int misses = 0, inward = 0;
  for (int i = 0; i < 3000; ++i) {
    size_t v = size_t(rng.uniform() * float(front.positions.size())) % front.positions.size();
    Vec3f n = front.normals.empty() ? Vec3f(0, 0, 1) : front.normals[v];
    // Stay away from the outline, where the slab is only as wide as the rim.
    if (std::fabs(front.uvs[v].x - 60) > 50 || std::fabs(front.uvs[v].y - 50) > 40) continue;
    Vec3f o = front.positions[v] - n * (0.5f + 3.0f * rng.uniform());
    Vec3f d = randomDirection(rng);
    RayHit h = cast(g, o, d);
    misses += !h.hit;
    inward += h.hit && dot(h.ng, d) <= 0;
  }
  EXPECT_EQ(misses, 0);
  EXPECT_EQ(inward, 0);

  TriangleMesh cut = front;
  cut.heights.assign(cut.positions.size(), 0.0f);
  const size_t v = cut.positions.size() / 2;
  Vec3f n = cut.normals[v];
  cut.positions[v] = cut.positions[v] - n * 0.05f;
  cut.heights[v] = -0.05f;
  TriangleMesh shell2 = solidShell(cut, 4.0f);
  Vec3f want = front.positions[v] - n * 4.0f;
  EXPECT_NEAR(length(Vec3d(shell2.positions[v]) - Vec3d(want)), 0.0, 1e-4);
}

TEST(SolidShell, ClosedMeshNeedsNoShellAndBadInputIsRefused) {
  MeshLoadOptions o;
  o.compute_uvs_if_missing = false;
  TriangleMesh tet = loadMesh(std::string(DG_SOURCE_DIR) + "/tests/fixtures/meshes/tetra.ply", o);
  EXPECT_EQ(boundaryEdgeCount(tet), 0u);
  EXPECT_EQ(solidShell(tet, 2.0f).triangleCount(), 0u);
  TriangleMesh front = makePlate({10, 10}, 5);
  EXPECT_THROW(solidShell(front, 0.0f), std::invalid_argument);
  EXPECT_THROW(solidShell(front, -1.0f), std::invalid_argument);
  EXPECT_THROW(solidShell(front, std::nanf("")), std::invalid_argument);
  // An edge shared by three triangles is no sheet.
  TriangleMesh fin;
  fin.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}};
  fin.indices = {0, 1, 2, 1, 0, 3, 0, 1, 4};
  EXPECT_THROW(solidShell(fin, 1.0f), std::invalid_argument);
}

}  // namespace
}  // namespace dg
