// The explicit-geometry reference for scratches and the normal-map baseline.
#include <gtest/gtest.h>

#include <algorithm>

#include <cmath>
#include <cstring>
#include <random>
#include <unordered_map>

#include "core/parallel.h"
#include "defects/scratch.h"
#include "render/groove.h"
#include "render/parts.h"
#include "render/scene.h"
#include "render/scratch_geometry.h"

using namespace dg;

namespace {
Scratch straightScratch() {
  // A symmetric V-groove 0.1 mm wide, 0.03 mm deep, along u through the plate's middle.
  Profile p = Profile::fromPolyline({{-0.05, 0.0}, {0.0, -0.03}, {0.05, 0.0}});
  return Scratch::fromProfile(ScratchPath::polyline({{5.0, 10.0}, {15.0, 10.0}}), p);
}
// A 20 mm plate in 5 mm triangles.
TriangleMesh plate20() {
  PlateParams pp;
  pp.width_mm = 20;
  pp.height_mm = 20;
  return makePlate(pp, 5);
}
// A groove 0.08 mm wide and 0.02 mm deep with pile-ups 0.005 mm high.
Profile pileUpProfile() {
  return Profile::fromPolyline({{-0.04, 0.0}, {-0.03, 0.005}, {0.0, -0.02}, {0.03, 0.005}, {0.04, 0.0}});
}
// The nearest hit of the ray o + t d (t > 0) among triangles `tris` of m, by brute force; 1e30
// for none.
double meshHitAmong(const TriangleMesh& m, const std::vector<size_t>& tris, Vec3d o, Vec3d d) {
  double best = 1e30;
  for (size_t t : tris) {
    Vec3d p0(m.positions[m.indices[3 * t]]), e1 = Vec3d(m.positions[m.indices[3 * t + 1]]) - p0,
        e2 = Vec3d(m.positions[m.indices[3 * t + 2]]) - p0;
    Vec3d q = cross(d, e2);
    double det = dot(e1, q);
    if (std::fabs(det) < 1e-18) continue;
    Vec3d sv = o - p0;
    double u = dot(sv, q) / det;
    if (u < 0 || u > 1) continue;
    Vec3d r = cross(sv, e1);
    double v = dot(d, r) / det;
    if (v < 0 || u + v > 1) continue;
    double tt = dot(e2, r) / det;
    if (tt > 0 && tt < best) best = tt;
  }
  return best;
}
// The same ray marched through the scratches' height field (world = uv + shift, z up) up to
// t_max: the first t where it is below the surface, refined by bisection; 1e30 for none.
double fieldHitOf(const std::vector<const Scratch*>& list, Vec3d shift, Vec3d o, Vec3d d, double t_max) {
  auto below = [&](double t) {
    Vec3d p = o + d * t - shift;
    return p.z <= double(scratchHeight(list, Vec2f(float(p.x), float(p.y))));
  };
  const double step = 2e-5;
  double t0 = 0;
  for (double t = step; t < t_max; t += step) {
    if (below(t)) {
      double lo = t0, hi = t;
      for (int i = 0; i < 40; ++i) (below(0.5 * (lo + hi)) ? hi : lo) = 0.5 * (lo + hi);
      return hi;
    }
    t0 = t;
  }
  return 1e30;
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
  TriangleMesh m = scratchedMesh(plate, list, {}, &st);
  EXPECT_NEAR(st.cell_mm, 0.1 / 16, 0.1 / 16);  // the automatic cell: width / 16, rounded to a power-of-2 split
  ASSERT_GT(m.triangleCount(), 500u);
  ASSERT_EQ(m.normals.size(), m.positions.size());
  // A piece's fan of triangles shares its polygon's vertices (once three per triangle; here 2.0 per
  // triangle), and every vertex is used.
  std::vector<char> used(m.positions.size(), 0);
  for (uint32_t i : m.indices) {
    ASSERT_LT(i, m.positions.size());
    used[i] = 1;
  }
  EXPECT_EQ(std::count(used.begin(), used.end(), 1), std::ptrdiff_t(m.positions.size()));
  EXPECT_LT(double(m.positions.size()), 2.2 * double(m.triangleCount())) << m.positions.size();
  // Plate normal and the chart's offset: a vertex's height above the plate equals the profile's.
  Vec3f n0 = normalize(cross(plate.positions[plate.indices[1]] - plate.positions[plate.indices[0]],
                             plate.positions[plate.indices[2]] - plate.positions[plate.indices[0]]));
  double zmin = 1e9, worst = 0;
  const double slope = 0.03 / 0.05, nz = 1 / std::sqrt(1 + slope * slope);
  for (size_t i = 0; i < m.positions.size(); ++i) {
    // On the lines of the abrupt ends (u = 5 and 15) a vertex has one side's height: the groove's
    // (the same a step along u inside it) or the plate's; the end walls join them.
    const Vec2f uv = m.uvs[i], du(1e-4f, 0.0f);
    double err = 1e30;
    for (Vec2f q : {uv, uv + du, uv - du * 1.0f})
      err = std::min(err, std::fabs(double(dot(m.positions[i] - plate.positions[0], n0)) - double(s.height(q))));
    // The plate lies in a plane through the origin's level: compare against the undisplaced point.
    double above = dot(m.positions[i] - plate.positions[0], n0);
    // Every vertex carries the height it was moved by (the integrator's layer lookup).
    ASSERT_EQ(m.heights.size(), m.positions.size());
    EXPECT_NEAR(m.heights[i], above, 1e-5) << "vertex " << i;
    worst = std::max(worst, err);
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
    // Away from the blunt ends, where the end walls stand (ABluntEndIsCutAlongItsFacetsUpToTheEndLine).
    Vec2f cu = (m.uvs[m.indices[3 * t]] + m.uvs[m.indices[3 * t + 1]] + m.uvs[m.indices[3 * t + 2]]) / 3.0f;
    if (cu.x < 6 || cu.x > 14) continue;
    Vec3f n = m.normals[m.indices[3 * t]];
    Vec3f g = cross(m.positions[m.indices[3 * t + 1]] - m.positions[m.indices[3 * t]], m.positions[m.indices[3 * t + 2]] - m.positions[m.indices[3 * t]]);
    float ga = length(g);
    const double c = dot(n, n0);
    const bool flat = std::fabs(c - 1) < 1e-4, tilted = std::fabs(c - nz) < 1e-4;
    ASSERT_TRUE(flat || tilted) << "triangle " << t << " normal . n0 = " << c << " uv " << m.uvs[m.indices[3 * t]].x << ","
                                << m.uvs[m.indices[3 * t]].y << " " << m.uvs[m.indices[3 * t + 1]].x << "," << m.uvs[m.indices[3 * t + 1]].y << " "
                                << m.uvs[m.indices[3 * t + 2]].x << "," << m.uvs[m.indices[3 * t + 2]].y << " z " << m.positions[m.indices[3 * t]].z
                                << " " << m.positions[m.indices[3 * t + 1]].z << " " << m.positions[m.indices[3 * t + 2]].z;
    if (ga > 1e-8f) {
      EXPECT_NEAR(std::fabs(dot(g / ga, n)), 1.0, 2e-3) << "triangle " << t;
    }
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
    TriangleMesh m = scratchedMesh(plate, list, o);
    double a = 0;
    tilted = 0;
    for (size_t t = 0; t < m.triangleCount(); ++t) {
      Vec3f g = cross(m.positions[m.indices[3 * t + 1]] - m.positions[m.indices[3 * t]], m.positions[m.indices[3 * t + 2]] - m.positions[m.indices[3 * t]]);
      a += 0.5 * length(g);
      // Facet area away from the blunt ends: centroids between 2 mm and L - 2 mm along the path.
      Vec2f c = (m.uvs[m.indices[3 * t]] + m.uvs[m.indices[3 * t + 1]] + m.uvs[m.indices[3 * t + 2]]) / 3.0f;
      double along = ((c.x - 5.0) * 10.0 + (c.y - 6.0) * 7.0) / std::hypot(10.0, 7.0);
      if (m.normals[m.indices[3 * t]].z < 0.9999f && along > 2 && along < std::hypot(10.0, 7.0) - 2) tilted += 0.5 * length(g);
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

// The cut runs on all threads: the tree of cells in subtrees, the blocks of leaves, and the copy of
// the blocks into the mesh. Two crossing scratches at a fine cell (about 550,000 triangles, cells
// spread over hundreds of subtrees and blocks) give the same mesh to the bit on 1 and 2 threads.
TEST(ScratchGeometry, TheMeshIsTheSameWhateverTheThreadCount) {
  TriangleMesh plate = plate20();
  Scratch a = straightScratch();
  Scratch b = Scratch::fromProfile(ScratchPath::polyline({{8.0, 4.0}, {12.0, 16.0}}), pileUpProfile());
  std::vector<const Scratch*> list{&a, &b};
  ScratchGeometryOptions o;
  o.cell_mm = 0.004;
  auto cut = [&](int threads) {
    ThreadLimit limit(threads);
    return scratchedMesh(plate, list, o);
  };
  const TriangleMesh one = cut(1), two = cut(2);
  ASSERT_GT(one.triangleCount(), 300000u);
  auto same = [](const auto& x, const auto& y) {
    return x.size() == y.size() && std::memcmp(x.data(), y.data(), x.size() * sizeof(x[0])) == 0;
  };
  EXPECT_TRUE(same(one.indices, two.indices));
  EXPECT_TRUE(same(one.positions, two.positions));
  EXPECT_TRUE(same(one.normals, two.normals));
  EXPECT_TRUE(same(one.uvs, two.uvs));
  EXPECT_TRUE(same(one.heights, two.heights));
  EXPECT_TRUE(same(one.mmPerUv, two.mmPerUv));
  // A cap that the tree of cells already passes is reported from its parallel part, as the same
  // error on any number of threads.
  for (int threads : {1, 2}) {
    ThreadLimit limit(threads);
    ScratchGeometryOptions small = o;
    small.max_triangles = 20000;
    try {
      scratchedMesh(plate, list, small);
      ADD_FAILURE() << threads << " threads";
    } catch (const std::runtime_error& e) {
      EXPECT_EQ(std::string(e.what()), "the scratch geometry would exceed 20000 triangles (cell 0.004000 mm)");
    }
  }
  // The kept part triangles come first with their own vertices, then the cut ones, all used.
  EXPECT_EQ(one.indices[0], 0u);
  std::vector<char> used(one.positions.size(), 0);
  for (uint32_t i : one.indices) used[i] = 1;
  EXPECT_EQ(std::count(used.begin(), used.end(), 1), std::ptrdiff_t(one.positions.size()));
}

// generate checks every sample before it writes (checkSample): counting alone must give the mesh's
// figures and refuse exactly where building it would. Two crossing scratches with abrupt ends, so
// that walls (two triangles per jump edge) are counted too.
TEST(ScratchGeometry, CountingAloneGivesTheMeshsFiguresAndItsErrors) {
  TriangleMesh plate = plate20();
  Scratch a = straightScratch();
  Scratch b = Scratch::fromProfile(ScratchPath::polyline({{8.0, 7.0}, {12.0, 13.0}}), pileUpProfile());
  std::vector<const Scratch*> list{&a, &b};
  ScratchGeometryStats full, counted;
  TriangleMesh m = scratchedMesh(plate, list, {}, &full);
  ScratchGeometryOptions o;
  o.count_only = true;
  TriangleMesh none = scratchedMesh(plate, list, o, &counted);
  EXPECT_EQ(none.triangleCount(), 0u);
  EXPECT_TRUE(none.positions.empty());
  ASSERT_GT(full.triangles, 1000u);
  EXPECT_EQ(full.triangles, m.triangleCount());
  EXPECT_EQ(counted.triangles, full.triangles);
  EXPECT_EQ(counted.part_triangles_cut, full.part_triangles_cut);
  EXPECT_EQ(counted.cell_mm, full.cell_mm);
  for (bool count_only : {false, true}) {
    ScratchGeometryOptions cap;
    cap.count_only = count_only;
    cap.max_triangles = full.triangles;
    EXPECT_NO_THROW(scratchedMesh(plate, list, cap)) << "count_only " << count_only;
    cap.max_triangles = full.triangles - 1;
    EXPECT_THROW(scratchedMesh(plate, list, cap), std::runtime_error) << "count_only " << count_only;
  }
  // The memory cap: 36 bytes per vertex and 196 per triangle, whether the mesh is kept or counted.
  const uint64_t need = uint64_t(m.positions.size()) * 36 + uint64_t(m.triangleCount()) * 196;
  for (bool count_only : {false, true}) {
    ScratchGeometryOptions cap;
    cap.count_only = count_only;
    cap.max_bytes = need;
    EXPECT_NO_THROW(scratchedMesh(plate, list, cap)) << "count_only " << count_only;
    cap.max_bytes = need - 1;
    try {
      scratchedMesh(plate, list, cap);
      ADD_FAILURE() << "count_only " << count_only;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("the cut mesh of " + std::to_string(full.triangles) +
                                           " triangles would need about"),
                std::string::npos)
          << e.what();
    }
  }
}

// A very fine process scratch (1 kg on HV 232: 4 micrometres deep, 50 profile vertices, some
// 40 nanometres apart) with long fades and a strong perturbation, far from the chart's origin (UV
// up to 40 mm, where a float offset is rounded to nanometres). Where the force law takes the depth
// to nearly 0 the whole section is a few nanometres wide and the kinks' order is rounding noise;
// cutting along each of them used to split every piece again (a fuzzed config's cell was cut into
// 3 million pieces: 12 GB and two minutes for 2 million triangles). Now the fades cost no more
// triangles than the unfaded scratch, no cell reaches the cap of pieces, and the vertices still
// lie on the cross-section.
TEST(ScratchGeometry, AFadeToNanometresAddsNoSlivers) {
  PlateParams pp;
  pp.width_mm = 40;
  pp.height_mm = 40;
  TriangleMesh plate = makePlate(pp, 10);
  ScratchProcess proc;
  proc.tool.apex_angle_rad = 85.5 * kPi / 180;
  proc.tool.tip_radius_mm = 0.002;
  proc.tool.theta_rad = 31.85 * kPi / 180;
  proc.tool.phi_rad = 15.6 * kPi / 180;
  proc.force_kg = 1;
  proc.hardness_hv = 232;
  proc.pileup = 0.098;
  const ScratchPath path = ScratchPath::polyline({{24.0, 11.3}, {31.0, 13.9}});
  ScratchPerturbation pert;
  pert.fade_length_mm = 3;
  pert.noise_amplitude = 0.84;
  pert.noise_wavelength_mm = 3;
  pert.noise_seed = 7;
  Scratch faded = Scratch::fromProcess(path, proc, pert);
  Scratch blunt = Scratch::fromProcess(path, proc);
  ASSERT_GT(faded.referenceProfile().pts.size(), 30u);
  ScratchGeometryStats sf, sb;
  TriangleMesh m = scratchedMesh(plate, {&faded}, {}, &sf);
  ScratchGeometryOptions count;
  count.count_only = true;
  scratchedMesh(plate, {&blunt}, count, &sb);
  ASSERT_GT(sb.triangles, 10000u);
  EXPECT_LE(sf.triangles, sb.triangles);
  EXPECT_EQ(sf.cells_capped, 0u);
  double worst = 0;
  for (size_t i = 0; i < m.positions.size(); ++i)
    worst = std::max(worst, std::fabs(double(m.positions[i].z) - double(faded.height(m.uvs[i]))));
  EXPECT_LT(worst, 2e-6);
}

// The cap of pieces per cell bounds a cell's cuts: at 1 a V-groove's cells are cut along one of
// its kinks only; the cells that reach it are counted, and the mesh still follows the section
// at its vertices.
TEST(ScratchGeometry, TheCapOfPiecesPerCellIsCounted) {
  PlateParams pp;
  pp.width_mm = 20;
  pp.height_mm = 20;
  TriangleMesh plate = makePlate(pp, 5);
  // Cells of 0.625 mm, the groove 0.1 mm wide inside one row of them: its three kinks cross each.
  Profile p = Profile::fromPolyline({{-0.05, 0.0}, {0.0, -0.03}, {0.05, 0.0}});
  Scratch s = Scratch::fromProfile(ScratchPath::polyline({{5.0, 10.3}, {15.0, 10.3}}), p);
  ScratchGeometryOptions o;
  o.cell_mm = 0.7;
  ScratchGeometryStats full, capped;
  TriangleMesh m0 = scratchedMesh(plate, {&s}, o, &full);
  o.max_pieces_per_cell = 1;
  TriangleMesh m1 = scratchedMesh(plate, {&s}, o, &capped);
  EXPECT_EQ(full.cells_capped, 0u);
  EXPECT_GT(capped.cells_capped, 0u);
  EXPECT_LT(capped.triangles, full.triangles);
  double worst = 0;
  for (size_t i = 0; i < m1.positions.size(); ++i)  // away from the abrupt ends: their walls need cut pieces
    if (m1.uvs[i].x > 8 && m1.uvs[i].x < 12)  // the ends reach 2.6 mm with cells this coarse
      worst = std::max(worst, std::fabs(double(m1.positions[i].z) - double(s.height(m1.uvs[i]))));
  EXPECT_LT(worst, 1e-5);
}

// On a curved part (a door skin bowed across its height, arc-length UVs): each vertex sits at the
// part's surface moved along its interpolated normal by the scratch's height; the walls' normals
// make the profile's slope with that normal and lie across the path; the pieces tile the chart;
// points shared by pieces (also across the part's triangle edges) are placed alike; triangles the
// scratch does not reach are the part's own.
TEST(ScratchGeometry, CurvedPartsAreCutAlongTheSurfaceNormal) {
  DoorPanelParams dp;
  dp.width_mm = 40;
  dp.height_mm = 40;
  dp.curvature_radius_mm = 60;
  dp.character_line_depth_mm = 0;
  TriangleMesh door = makeDoorPanel(dp, 6);
  ASSERT_EQ(door.normals.size(), door.positions.size());
  // An oblique V-groove (0.1 mm wide, 0.03 mm deep), so that it crosses the part's triangle edges
  // at angles and climbs the bow.
  Profile prof = Profile::fromPolyline({{-0.05, 0.0}, {0.0, -0.03}, {0.05, 0.0}});
  const Vec2d a(6.0, 8.0), b(34.0, 30.0);
  Scratch s = Scratch::fromProfile(ScratchPath::polyline({a, b}), prof);
  std::vector<const Scratch*> list{&s};
  ScratchGeometryOptions o;
  o.cell_mm = 0.1 / 8;
  ScratchGeometryStats st;
  TriangleMesh m = scratchedMesh(door, list, o, &st);
  ASSERT_GT(st.part_triangles_cut, 4u);
  ASSERT_LT(st.part_triangles_cut, door.triangleCount() / 2);

  // The part's surface at a UV point: position, interpolated normal, and the path's direction.
  struct Base {
    Vec3d p, n, t;
  };
  const Vec2d dir = (b - a) / std::hypot(b.x - a.x, b.y - a.y);
  auto base = [&](Vec2f q, Base& out) {
    for (size_t f = 0; f < door.triangleCount(); ++f) {
      const uint32_t* id = &door.indices[3 * f];
      Vec2d t0(door.uvs[id[0]].x, door.uvs[id[0]].y), t1(door.uvs[id[1]].x, door.uvs[id[1]].y),
          t2(door.uvs[id[2]].x, door.uvs[id[2]].y);
      Vec2d e1 = t1 - t0, e2 = t2 - t0, d = Vec2d(q.x, q.y) - t0;
      double det = e1.x * e2.y - e1.y * e2.x;
      double b1 = (d.x * e2.y - d.y * e2.x) / det, b2 = (e1.x * d.y - e1.y * d.x) / det, b0 = 1 - b1 - b2;
      if (b0 < -1e-6 || b1 < -1e-6 || b2 < -1e-6) continue;
      Vec3d p0(door.positions[id[0]]), p1(door.positions[id[1]]), p2(door.positions[id[2]]);
      out.p = p0 * b0 + p1 * b1 + p2 * b2;
      out.n = normalize(Vec3d(door.normals[id[0]]) * b0 + Vec3d(door.normals[id[1]]) * b1 + Vec3d(door.normals[id[2]]) * b2);
      Vec3d q1 = p1 - p0, q2 = p2 - p0;
      Vec3d dpdu = (q1 * e2.y - q2 * e1.y) / det, dpdv = (q2 * e1.x - q1 * e2.x) / det;
      Vec3d t = dpdu * dir.x + dpdv * dir.y;
      out.t = normalize(t - out.n * dot(t, out.n));
      return true;
    }
    return false;
  };
  const double slope = 0.03 / 0.05, nz = 1 / std::sqrt(1 + slope * slope);
  double worst_pos = 0, worst_tilt = 0, worst_along = 0, wall_area = 0, uv_area = 0, tiny_area = 0, checked_area = 0;
  size_t walls = 0;
  std::unordered_map<uint64_t, Vec3f> placed;
  size_t shared = 0, mismatched = 0;
  for (size_t t = 0; t < m.triangleCount(); ++t) {
    Vec2f c = (m.uvs[m.indices[3 * t]] + m.uvs[m.indices[3 * t + 1]] + m.uvs[m.indices[3 * t + 2]]) / 3.0f;
    Vec2f e1 = m.uvs[m.indices[3 * t + 1]] - m.uvs[m.indices[3 * t]], e2 = m.uvs[m.indices[3 * t + 2]] - m.uvs[m.indices[3 * t]];
    uv_area += 0.5 * std::fabs(double(e1.x) * e2.y - double(e1.y) * e2.x);
    const double len = std::hypot(b.x - a.x, b.y - a.y);
    double along = (double(c.x) - a.x) * dir.x + (double(c.y) - a.y) * dir.y;
    // Points shared by pieces are placed alike (the abrupt ends excepted: there the walls' top and
    // bottom share their UVs).
    for (int k = 0; k < 3 && along > 0.5 && along < len - 0.5; ++k) {
      const size_t v = m.indices[3 * t + k];
      uint64_t key;
      std::memcpy(&key, &m.uvs[v], sizeof key);
      auto [it, fresh] = placed.emplace(key, m.positions[v]);
      if (!fresh) {
        ++shared;
        if (length(it->second - m.positions[v]) > 1e-5f) ++mismatched;
      }
    }
    // Away from the blunt ends.
    if (along < 2 || along > len - 2) continue;
    const double offset = -(double(c.x) - a.x) * dir.y + (double(c.y) - a.y) * dir.x;
    if (std::fabs(offset) < 0.05)
      wall_area += 0.5 * length(cross(m.positions[m.indices[3 * t + 1]] - m.positions[m.indices[3 * t]], m.positions[m.indices[3 * t + 2]] - m.positions[m.indices[3 * t]]));
    if (t % 7 != 0) continue;  // every 7th triangle: brute-force lookups
    // Pieces a few float steps across (where a kink clips a cell's corner) take their facet from
    // heights computed in float, which is noise at that size; they are counted, not checked.
    const double area = 0.5 * length(cross(m.positions[m.indices[3 * t + 1]] - m.positions[m.indices[3 * t]], m.positions[m.indices[3 * t + 2]] - m.positions[m.indices[3 * t]]));
    const bool tiny = area < 1e-6;
    (tiny ? tiny_area : checked_area) += area;
    for (int k = 0; k < 3; ++k) {
      const size_t v = m.indices[3 * t + k];
      Base bs;
      ASSERT_TRUE(base(m.uvs[v], bs));
      worst_pos = std::max(worst_pos, length(Vec3d(m.positions[v]) - (bs.p + bs.n * double(s.height(m.uvs[v])))));
      if (tiny) continue;
      const double c = dot(Vec3d(m.normals[v]), bs.n);
      worst_tilt = std::max(worst_tilt, std::min(std::fabs(c - 1), std::fabs(c - nz)));
      worst_along = std::max(worst_along, std::fabs(dot(Vec3d(m.normals[v]), bs.t)));
      if (k == 0 && std::fabs(c - nz) < 1e-3) ++walls;
    }
  }
  EXPECT_LT(worst_pos, 2e-5);  // float positions on a part 40 mm across
  EXPECT_LT(worst_tilt, 1e-3);
  EXPECT_LT(worst_along, 1e-3);
  EXPECT_GT(walls, 50u);
  EXPECT_LT(tiny_area, 1e-4 * checked_area);
  // The walls' area: two walls sqrt(0.05^2 + 0.03^2) mm wide along the path between the cut lines
  // (triangles on those lines count by their centroid).
  const double len = std::hypot(b.x - a.x, b.y - a.y) - 4, walls_exact = 2 * len * std::sqrt(0.05 * 0.05 + 0.03 * 0.03);
  EXPECT_NEAR(wall_area, walls_exact, 2e-3 * walls_exact);
  // The pieces tile the chart exactly (no gap, no overlap).
  double door_uv = 0;
  for (size_t f = 0; f < door.triangleCount(); ++f) {
    const uint32_t* id = &door.indices[3 * f];
    Vec2f e1 = door.uvs[id[1]] - door.uvs[id[0]], e2 = door.uvs[id[2]] - door.uvs[id[0]];
    door_uv += 0.5 * std::fabs(double(e1.x) * e2.y - double(e1.y) * e2.x);
  }
  EXPECT_NEAR(uv_area, door_uv, 1e-6 * door_uv);
  EXPECT_GT(shared, 1000u);
  EXPECT_EQ(mismatched, 0u);
  // A part triangle far from the scratch is in the output unchanged.
  size_t far_tri = door.triangleCount() - 1;
  Vec3f far_p = door.positions[door.indices[3 * far_tri]];
  bool found = false;
  for (size_t v = 0; v < m.positions.size() && !found; ++v) found = m.positions[v] == far_p;
  EXPECT_TRUE(found);
}

// A blunt end (no fade) is cut along the cross-section's kinks up to its end line: every triangle of
// its end cells lies on one facet of the profile, on the plate, or on an end wall. Until 2026-11-28
// the kinks were undefined past the end line, so a cell across it kept pieces that spanned two
// facets (normals between theirs): at the pile-up's end under a low bar light, a bright column one
// cell wide, which finer cells narrowed (docs/grooves.md, "Reference and baseline").
TEST(ScratchGeometry, ABluntEndIsCutAlongItsFacetsUpToTheEndLine) {
  TriangleMesh plate = plate20();
  const Profile prof = pileUpProfile();
  // Oblique, so that the end line and the kinks cross the cells at an angle.
  const Vec2d a(5.0, 6.0), b(15.0, 13.0);
  Scratch s = Scratch::fromProfile(ScratchPath::polyline({a, b}), prof);
  std::vector<const Scratch*> list{&s};
  TriangleMesh m = scratchedMesh(plate, list);
  // The plate's normal; each facet's normal makes the angle atan(slope) with it.
  std::vector<double> allowed{1.0};
  for (size_t i = 0; i + 1 < prof.pts.size(); ++i) {
    const double slope = (prof.pts[i + 1].y - prof.pts[i].y) / (prof.pts[i + 1].x - prof.pts[i].x);
    allowed.push_back(1 / std::sqrt(1 + slope * slope));
  }
  const double L = std::hypot(b.x - a.x, b.y - a.y);
  size_t near_end = 0, off = 0;
  for (size_t t = 0; t < m.triangleCount(); ++t) {
    const Vec2f c = (m.uvs[m.indices[3 * t]] + m.uvs[m.indices[3 * t + 1]] + m.uvs[m.indices[3 * t + 2]]) / 3.0f;
    const double along = ((c.x - a.x) * (b.x - a.x) + (c.y - a.y) * (b.y - a.y)) / L;
    if (std::fabs(along) > 0.1 && std::fabs(along - L) > 0.1) continue;
    const Vec3f g = cross(m.positions[m.indices[3 * t + 1]] - m.positions[m.indices[3 * t]],
                          m.positions[m.indices[3 * t + 2]] - m.positions[m.indices[3 * t]]);
    if (!(length(g) > 1e-12f)) continue;
    ++near_end;
    const double cz = std::fabs(double(g.z) / double(length(g)));
    bool ok = cz < 0.05;  // an end wall (steep: its top leans back by 1/1000 of its height)
    for (double c : allowed) ok |= std::fabs(cz - c) < 1e-3;
    off += !ok;
  }
  EXPECT_GT(near_end, 200u);
  EXPECT_EQ(off, 0u) << "of " << near_end << " triangles near the ends";
}

// Where the composite height jumps (a groove cutting through another's pile-up; an abrupt end),
// the mesh has vertical walls, so it is the height field itself: rays cast at it hit where rays
// marched through the height field stop, also rays that meet a wall. Without the walls (each side's
// facets ramped into the other's over one cell), rays near the jumps stop early or late.
TEST(ScratchGeometry, JumpsBecomeWallsAndRaysHitTheHeightField) {
  PlateParams pp;
  pp.width_mm = 4;
  pp.height_mm = 4;
  TriangleMesh plate = makePlate(pp, 2);
  // Grooves with pile-ups: A along u with an abrupt end at u = 1, B along v through A.
  Profile pa = Profile::fromPolyline({{-0.09, 0.0}, {-0.06, 0.012}, {-0.04, 0.0}, {0.0, -0.03},
                                      {0.04, 0.0}, {0.06, 0.012}, {0.09, 0.0}});
  Profile pb = Profile::fromPolyline({{-0.07, 0.0}, {-0.05, 0.009}, {-0.03, 0.0}, {0.0, -0.02},
                                      {0.03, 0.0}, {0.05, 0.009}, {0.07, 0.0}});
  Scratch a = Scratch::fromProfile(ScratchPath::polyline({{1.0, 2.0}, {3.6, 2.0}}), pa);
  Scratch b = Scratch::fromProfile(ScratchPath::polyline({{2.0, 0.4}, {2.0, 3.6}}), pb);
  std::vector<const Scratch*> list{&a, &b};
  ScratchGeometryOptions o;
  o.cell_mm = 0.06 / 8;
  TriangleMesh m = scratchedMesh(plate, list, o);
  // The plate's chart: world = uv + shift, z up.
  const Vec3d shift = Vec3d(plate.positions[0]) - Vec3d(plate.uvs[0].x, plate.uvs[0].y, 0.0);
  // Triangles near the two spots, for brute-force intersection.
  std::vector<size_t> tris;
  for (size_t t = 0; t < m.triangleCount(); ++t) {
    Vec2f c = (m.uvs[m.indices[3 * t]] + m.uvs[m.indices[3 * t + 1]] + m.uvs[m.indices[3 * t + 2]]) / 3.0f;
    if ((std::fabs(c.x - 2) < 0.3 && std::fabs(c.y - 2) < 0.3) || (std::fabs(c.x - 1) < 0.3 && std::fabs(c.y - 2) < 0.3))
      tris.push_back(t);
  }
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(0, 1);
  int n = 0, off = 0, walls_hit = 0;
  double worst = 0;
  for (int i = 0; i < 300; ++i) {
    // Aim at the crossing (where B cuts A's pile-ups and A cuts B's) or at A's abrupt end.
    // At the end, from inside the groove toward the end wall (the rays travel toward -u).
    const bool at_end = i % 3 == 0;
    Vec3d target = at_end ? Vec3d(0.98 + 0.1 * U(rng), 1.93 + 0.14 * U(rng), 0.0)
                          : Vec3d(1.88 + 0.24 * U(rng), 1.88 + 0.24 * U(rng), 0.0);
    const double elev = 0.35 + 0.9 * U(rng), az = at_end ? kPi * (U(rng) - 0.5) : 2 * kPi * U(rng);
    Vec3d d(-std::cos(elev) * std::cos(az), -std::cos(elev) * std::sin(az), -std::sin(elev));
    Vec3d o = target + shift - d * (0.05 / std::sin(elev));  // 0.05 mm above the plate
    double tm = meshHitAmong(m, tris, o, d), tf = fieldHitOf(list, shift, o, d, 1.0);
    ASSERT_LT(tf, 1e29);
    ++n;
    const double err = std::fabs(tm - tf);
    worst = std::max(worst, err);
    if (err > 2e-4) {
      ++off;
      Vec3d pm = o + d * tm - shift, pf = o + d * tf - shift;
      ADD_FAILURE() << "ray " << i << ": mesh hit at (" << pm.x << ", " << pm.y << ", " << pm.z << "), field at (" << pf.x
                    << ", " << pf.y << ", " << pf.z << ")";
    }
    // A wall was hit when the surface's slope there is steeper than any facet's (tan 80 deg).
    Vec3d p = o + d * tf - shift, q = p - Vec3d(d.x, d.y, 0.0) * 1e-5;
    double dh = std::fabs(double(scratchHeight(list, Vec2f(float(p.x), float(p.y)))) -
                          double(scratchHeight(list, Vec2f(float(q.x), float(q.y)))));
    if (dh > 1e-3) ++walls_hit;
  }
  EXPECT_EQ(off, 0) << "of " << n << " rays; worst |t_mesh - t_field| " << worst;
  EXPECT_GT(walls_hit, 5);
}

// A groove that has nearly faded out still cuts through another's pile-up (the composite takes the
// lowest cut): a slot a few hundred nanometres wide and as deep as the pile-up is high. Its own
// pile-up kinks cut the pile-up beside it into pieces whose edges lie within 40-80 nm of the slot.
// The height beyond such an edge was extrapolated from two samples, 38 and 76 nm out on this
// 20 mm plate, one on the pile-up and one in the slot, and the wall there rose to twice the
// pile-up's height: a fin that mirrored the ring light into a glint the groove renderer rightly
// lacked (the clusters fuzzer's c62_5, 22 um above a 0.022 mm pile-up). No vertex may stand
// above the highest pile-up, and the slot is still cut.
TEST(ScratchGeometry, AThinSlotThroughAPileUpRaisesNoFins) {
  const TriangleMesh plate = plate20();
  const Scratch a = Scratch::fromProfile(ScratchPath::polyline({{5.0, 10.0}, {15.0, 10.0}}), pileUpProfile());
  // 110 nm wide below the base; its pile-up kinks 55 nm outside the cut's edges.
  const Profile thin = Profile::fromPolyline(
      {{-2e-4, 0.0}, {-1.1e-4, 3e-5}, {-5.5e-5, 0.0}, {0.0, -5e-5}, {5.5e-5, 0.0}, {1.1e-4, 3e-5}, {2e-4, 0.0}});
  const Scratch b = Scratch::fromProfile(ScratchPath::polyline({{10.0, 9.9}, {10.0, 10.1}}), thin);
  const std::vector<const Scratch*> list{&a, &b};
  ScratchGeometryOptions o;
  o.cell_mm = 0.004;  // (the automatic cell follows the thin groove: 13 s)
  const TriangleMesh m = scratchedMesh(plate, list, o);
  const double peak = 0.005;  // pileUpProfile's
  double highest = -1;
  size_t in_slot = 0;
  for (size_t i = 0; i < m.positions.size(); ++i) {
    highest = std::max(highest, double(m.positions[i].z));
    // Vertices on A's pile-up (|v - 10| in [0.031, 0.039]) at the slot's floor.
    const Vec2f uv = m.uvs[i];
    const double dv = std::fabs(uv.y - 10.0);
    if (std::fabs(uv.x - 10.0) < 6e-5 && dv > 0.031 && dv < 0.039 && m.positions[i].z < 1e-4) ++in_slot;
  }
  EXPECT_LE(highest, peak + 1e-6);
  EXPECT_GT(in_slot, 0u);
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

// Where the groove renderer point-samples the scratches (rays that meet the scratched face from
// inside a glass part, DefectQuery::point_grooves), overlapping scratches take the slope of the
// surface the explicit geometry cuts (scratchHeight), not the sum of their slopes: at a crossing of
// two grooves with pile-ups the sum tilted the normal by up to twice a wall's slope. Checked against
// central differences of scratchHeight at points over the crossing; the normal-map baseline keeps
// the sum.
TEST(ScratchNormalMap, PointSamplesTakeTheCompositeSurfacesSlope) {
  const Profile p = pileUpProfile();
  std::vector<Scratch> two;
  two.push_back(Scratch::fromProfile(ScratchPath::polyline({{5.0, 10.0}, {15.0, 10.0}}), p));
  two.push_back(Scratch::fromProfile(ScratchPath::polyline({{8.0, 7.0}, {12.0, 13.0}}), p));
  const std::vector<const Scratch*> list{&two[0], &two[1]};
  std::vector<Scratch> bumped = two;  // the normal-map baseline's
  for (Scratch& s : bumped) s.setBumpShading(true);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-0.06f, 0.06f);
  int checked = 0, summed_off = 0;
  for (int i = 0; i < 4000; ++i) {
    const Vec2f c{10.0f + u(rng), 10.0f + u(rng)};
    DefectQuery q;
    q.uv = c;
    q.point_grooves = true;
    DefectShading ds;
    for (const Scratch& s : two) s.shade(q, ds);
    EXPECT_EQ(ds.height_grad.x, 0.0f);  // the point samples go through grooveGrad() alone
    const Vec2f g = ds.grooveGrad();
    // Central differences at two steps; where they disagree the point is by a kink (a facet's
    // edge, where one groove takes over from the other), which has no single slope.
    auto fd = [&](float h) {
      return Vec2f((scratchHeight(list, {c.x + h, c.y}) - scratchHeight(list, {c.x - h, c.y})) / (2 * h),
                   (scratchHeight(list, {c.x, c.y + h}) - scratchHeight(list, {c.x, c.y - h})) / (2 * h));
    };
    const Vec2f a = fd(2e-4f), b = fd(1e-4f);
    if (std::fabs(a.x - b.x) > 1e-2f || std::fabs(a.y - b.y) > 1e-2f) continue;
    EXPECT_NEAR(g.x, b.x, 2e-2f) << c.x << " " << c.y;
    EXPECT_NEAR(g.y, b.y, 2e-2f) << c.x << " " << c.y;
    ++checked;
    // The baseline's sum differs wherever both grooves have a slope here.
    DefectShading sum;
    for (const Scratch& s : bumped) s.shade(q, sum);
    if (std::fabs(sum.height_grad.x - b.x) + std::fabs(sum.height_grad.y - b.y) > 0.1f) ++summed_off;
  }
  EXPECT_GT(checked, 3000);
  EXPECT_GT(summed_off, 500);
}

// A U-turn (a hairpin whose legs' pile-ups nearly meet at the midline, its turn in the cut): each
// triangle between the legs lies on the height field, checked at its centroid. The path's closest
// point hands over from one leg to the other along the midline, on which the cells' edges lie, and
// along the inner bisectors of the turn's corners. Before, the kinks were taken from the path's
// closest point: at the midline's vertices that is a tie, which goes to the lower leg, so a cell
// beside the midline on the upper leg's side had the lower leg's scale (the perturbation: another
// arc position) at its lower corners, and the upper pile-up's outer kink in it was cut in the wrong
// place. And a corner's legs were one pass, so the inner bisectors (where the closest point jumps
// from one leg to the other) were not cut. Under a ring light the U-turn of 0.18 mm showed a bright
// streak along its midline that finer cells narrowed.
TEST(ScratchGeometry, AUTurnsLegsAreEachCutAlongTheirOwnKinks) {
  TriangleMesh plate = plate20();
  ScratchGeometryOptions o;
  o.cell_mm = 0.005;  // cells of 20 / 4096 mm, with edges on the midline y = 10
  const double cell = 20.0 / 4096, D = 0.05;
  const ScratchPath uturn =
      ScratchPath::polyline({{6.0, 10.0 - D}, {10.05, 10.0 - D}, {10.05, 10.0 + D}, {6.0, 10.0 + D}});
  for (double amplitude : {0.0, 0.15}) {
    ScratchPerturbation pert;
    pert.noise_amplitude = amplitude;
    pert.noise_wavelength_mm = 3.0;
    pert.noise_seed = 5;
    // The legs' scales at x = 9.5 (the lower leg at arc position 3.5, the upper at L - 3.5): the
    // cross-section is sized so that the upper pile-up's outer end lies half a cell above the
    // midline there.
    const Scratch probe = Scratch::fromProfile(uturn, pileUpProfile(), pert);
    const double ku = probe.scaleAt(float(uturn.length() - 3.5)), kl = probe.scaleAt(3.5f);
    if (amplitude > 0) {
      ASSERT_GT(std::fabs(ku - kl), 0.02);  // the legs there at different scales
    }
    const double e = (D - 0.5 * cell) / ku;
    std::vector<Vec2d> pts = pileUpProfile().pts;
    for (Vec2d& q : pts) q = q * (e / 0.04);
    Scratch s = Scratch::fromProfile(uturn, Profile::fromPolyline(pts), pert);
    std::vector<const Scratch*> list{&s};
    TriangleMesh m = scratchedMesh(plate, list, o);
    size_t near = 0, off = 0, off_midline = 0, off_turn = 0;
    double worst = 0;
    for (size_t t = 0; t < m.triangleCount(); ++t) {
      const uint32_t* id = &m.indices[3 * t];
      const Vec2f a = m.uvs[id[0]], b = m.uvs[id[1]], c = m.uvs[id[2]];
      if (!(std::fabs(cross(b - a, c - a)) > 1e-14f)) continue;  // a wall
      const Vec2f g = (a + b + c) / 3.0f;
      // Between the legs, up to the turn (past the turn's corners the kinks are arcs about them,
      // cut along their chords).
      if (!(g.x > 9.0f && g.x < 10.05f && std::fabs(g.y - 10.0f) < D)) continue;
      ++near;
      const double hi = (double(m.heights[id[0]]) + m.heights[id[1]] + m.heights[id[2]]) / 3.0;
      const double err = std::fabs(hi - double(scratchHeight(list, g)));
      worst = std::max(worst, err);
      // (A jump smaller than the mesh's tolerance for one, 64 float steps of the chart's largest
      // coordinate, 1.5e-4 mm here, is kept as a ramp: the scale's step across a corner's inner
      // bisector leaves up to 4e-5 mm.)
      if (err > 1e-4) {
        ++off;
        off_midline += std::fabs(g.y - 10.0f) < cell && g.x < 10.05 - D;
        off_turn += g.x >= 10.05 - D;  // where the corners' inner bisectors are
      }
    }
    EXPECT_GT(near, 5000u);
    EXPECT_EQ(off, 0u) << "perturbation " << amplitude << ": " << off << " of " << near
                       << " triangles off the height field (" << off_midline << " beside the midline, "
                       << off_turn << " at the turn), worst " << worst << " mm";
  }
}

// A cut triangle keeps the chart scale of the part triangle it was cut from (as the children of a
// displaced mesh do), whatever its slope: the defects that a hit looks up in the chart (a dent's
// bump, weathering) must find the same place on a groove's wall as beside it. The plate's chart
// here is stretched (UV scaled by 1/2: 2 mm per UV unit). Measured on the cut mesh instead (before
// the forty-third session), the V-groove's walls (31 degrees) took 2.16, a dent on them was looked
// up 8% farther from its centre, and 84 slivers took 0 (read as 1).
TEST(ScratchGeometry, CutTrianglesKeepThePartsChartScale) {
  TriangleMesh plate = plate20();
  for (Vec2f& uv : plate.uvs) uv = uv * 0.5f;
  plate.computeMmPerUv();
  ASSERT_EQ(plate.mmPerUv.size(), plate.triangleCount());
  for (float k : plate.mmPerUv) ASSERT_NEAR(k, 2.0f, 1e-4f);
  // The scratch in the halved chart: along u through the middle, its profile in UV units.
  Profile p = Profile::fromPolyline({{-0.025, 0.0}, {0.0, -0.03}, {0.025, 0.0}});
  Scratch s = Scratch::fromProfile(ScratchPath::polyline({{2.5, 5.0}, {7.5, 5.0}}), p);
  std::vector<const Scratch*> list{&s};
  TriangleMesh m = scratchedMesh(plate, list, {});
  ASSERT_EQ(m.mmPerUv.size(), m.triangleCount());
  size_t walls = 0;
  for (size_t t = 0; t < m.triangleCount(); ++t) {
    const uint32_t* id = &m.indices[3 * t];
    const Vec3f n = cross(m.positions[id[1]] - m.positions[id[0]], m.positions[id[2]] - m.positions[id[0]]);
    if (std::fabs(n.z) < 0.95f * length(n)) ++walls;  // tilted more than 18 degrees
    ASSERT_NEAR(m.mmPerUv[t], 2.0f, 1e-4f) << "triangle " << t;
  }
  EXPECT_GT(walls, 50u);
}

// A groove's facets take their shading tangent from the part's chart as the explicit geometry's cut
// triangles do: the groove renderer frames a resolved paint flake's normal about the surface's dpdu
// carried up onto each facet along the normal (groove::facetTangent), and a cut triangle's dpdu,
// from the part's UVs at the points below, points the same way. Along a scratch at 35 degrees to u
// with 31-degree walls, the wall triangles agree to 1.7e-4 rad on average (by area); the orthogonal
// projection of dpdu onto the wall, which the groove renderer took before the forty-fourth session
// (and which turned every flake on the walls about the normal), is off by 0.144 rad (8 degrees).
TEST(ScratchGeometry, WallsTakeTheChartsTangentAsTheGrooveRendererCarriesIt) {
  TriangleMesh plate = plate20();
  const double a = 35.0 * kPi / 180.0;
  const Vec2d d(std::cos(a), std::sin(a));
  Profile p = Profile::fromPolyline({{-0.05, 0.0}, {0.0, -0.03}, {0.05, 0.0}});
  Scratch s = Scratch::fromProfile(ScratchPath::polyline({Vec2d(10.0, 10.0) - d * 5.0, Vec2d(10.0, 10.0) + d * 5.0}), p);
  std::vector<const Scratch*> list{&s};
  // Each triangle's dpdu and normal as the renderer takes them (PartGeometry::frame).
  const PartGeometry part(scratchedMesh(plate, list, {}));
  const TriangleMesh& m = part.mesh();
  const Vec3f W(0.0f, 0.0f, 1.0f);
  Vec3f t(0.0f, 0.0f, 0.0f);
  for (unsigned i = 0; i < m.triangleCount() && length(t) == 0; ++i)
    if (part.frame(i).uv_ok && part.frame(i).ng.z > 0.9999f) t = part.frame(i).dpdu;  // the plate's
  ASSERT_GT(length(t), 0.0f);
  auto angle = [](Vec3f x, Vec3f y) {
    return std::acos(std::clamp(double(dot(normalize(x), normalize(y))), -1.0, 1.0));
  };
  // Weighted by area: the triangles are a few micrometres across at 10 mm from the origin, so
  // their float positions and UVs leave slivers off by a few milliradians.
  size_t walls = 0;
  double area = 0, mean = 0, mean_orthogonal = 0;
  for (unsigned i = 0; i < m.triangleCount(); ++i) {
    const PartGeometry::TriFrame& fr = part.frame(i);
    if (!fr.uv_ok || fr.ng.z > 0.95f) continue;  // walls only (tilted more than 18 degrees)
    const uint32_t* id = &m.indices[3 * size_t(i)];
    const double ai = 0.5 * length(cross(Vec3d(m.positions[id[1]]) - Vec3d(m.positions[id[0]]),
                                         Vec3d(m.positions[id[2]]) - Vec3d(m.positions[id[0]])));
    ++walls;
    area += ai;
    mean += ai * angle(groove::facetTangent(t, W, fr.ng), fr.dpdu);
    mean_orthogonal += ai * angle(t - fr.ng * dot(t, fr.ng), fr.dpdu);
  }
  mean /= area, mean_orthogonal /= area;
  std::printf("[          ] %zu wall triangles: mean angle to their dpdu %.2e rad (orthogonal projection %.3f)\n",
              walls, mean, mean_orthogonal);
  EXPECT_GT(walls, 50u);
  EXPECT_LT(mean, 1e-3);
  EXPECT_GT(mean_orthogonal, 0.1);
}

// A path's corner whose round outer side (its cap, where the closest point is the vertex) lies
// near a later leg of the same path: the two hand over where the distance to the vertex equals the
// distance to the leg, a parabola, and with the perturbation the two are at different scales, so
// the height jumps along it. The builder cut the hand-over between two legs along |b_i| = |b_j|
// (b the distance from each leg's line), a straight line that is not where the closest point
// changes in the cap, so the pieces there straddled the jump and its walls stood on the cells'
// edges, facing along them (the corner fuzzer's c48_9: a glint the groove renderer drew from the
// parabola's wall was missing in the reference).
TEST(ScratchGeometry, ACornersCapHandsOverToAnotherLegAlongTheirCurve) {
  TriangleMesh plate = plate20();
  // Leg 0 runs right to the corner V = (10, 10.13), leg 1 goes back left to W = (9.2, 10), and
  // leg 2 runs right along y = 10 past V's cap.
  const Vec2d V(10.0, 10.13);
  const ScratchPath path = ScratchPath::polyline({{6.0, 10.13}, V, {9.2, 10.0}, {11.5, 10.0}});
  ASSERT_EQ(path.corners().size(), 2u);
  ScratchPerturbation pert;
  pert.noise_amplitude = 0.3;
  pert.noise_wavelength_mm = 1.5;
  pert.noise_seed = 3;
  std::vector<Vec2d> pts = pileUpProfile().pts;
  for (Vec2d& q : pts) q = q * 3.0;  // 0.24 mm wide, 0.06 deep, pile-ups 0.015 high
  Scratch s = Scratch::fromProfile(path, Profile::fromPolyline(pts), pert);
  const double s_v = path.corners()[0].s;
  const double s_leg2 = path.corners()[1].s + 0.85;  // leg 2's point beside V
  ASSERT_GT(std::fabs(s.scaleAt(float(s_v)) - s.scaleAt(float(s_leg2))), 0.05);
  std::vector<const Scratch*> list{&s};
  // The hand-over in the cap: |p - V| = y - 10, for x > 10.
  auto handover = [&](double x) {
    const double dx = x - V.x, c = V.y - 10.0;
    return 10.0 + (dx * dx + c * c) / (2.0 * c);
  };
  // The jump along it.
  double jump = 0;
  for (double x = 10.0; x <= 10.1; x += 0.01) {
    const double y = handover(x);
    jump = std::max(jump, std::fabs(double(scratchHeight(list, Vec2f(float(x), float(y - 2e-4)))) -
                                    double(scratchHeight(list, Vec2f(float(x), float(y + 2e-4))))));
  }
  ASSERT_GT(jump, 1e-3);
  ScratchGeometryOptions o;
  o.cell_mm = 0.01;
  TriangleMesh m = scratchedMesh(plate, list, o);
  const Vec3d shift = Vec3d(plate.positions[0]) - Vec3d(plate.uvs[0].x, plate.uvs[0].y, 0.0);
  std::vector<size_t> tris;
  size_t near = 0, off = 0;
  for (size_t t = 0; t < m.triangleCount(); ++t) {
    const uint32_t* id = &m.indices[3 * t];
    const Vec2f a = m.uvs[id[0]], b = m.uvs[id[1]], c = m.uvs[id[2]];
    const Vec2f g = (a + b + c) / 3.0f;
    if (!(g.x > 9.9f && g.x < 10.2f && g.y > 9.95f && g.y < 10.2f)) continue;
    tris.push_back(t);
    if (!(std::fabs(cross(b - a, c - a)) > 1e-14f)) continue;  // a wall
    // Within a band of the hand-over, but not so close to it that the centroid can lie between
    // the curve and the chord it is cut along (at most 1e-4 mm apart over a cell).
    const double dy = std::fabs(g.y - handover(g.x));
    if (!(g.x > 10.0f && g.x < 10.1f && dy < 0.01 && dy > 5e-4)) continue;
    ++near;
    const double h = (double(m.heights[id[0]]) + m.heights[id[1]] + m.heights[id[2]]) / 3.0;
    // (The cap's kinks are circles, also cut along chords: up to 2e-4 mm off in height.)
    off += std::fabs(h - double(scratchHeight(list, g))) > 1e-3;
  }
  EXPECT_GT(near, 50u);
  EXPECT_EQ(off, 0u) << off << " of " << near << " triangles beside the hand-over off the height field";
  // Rays at the hand-over's wall from both sides, against the height field marched.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> U(0, 1);
  int n = 0, rays_off = 0, walls_hit = 0;
  double worst = 0;
  for (int i = 0; i < 200; ++i) {
    // Aim at a point of the hand-over, along the normal of the curve, low (the jump is a few
    // micrometres): which side is low depends on the scales, so both directions.
    const double x = 10.005 + 0.09 * U(rng), y = handover(x);
    Vec2d nrm(-(x - V.x) / (V.y - 10.0), 1.0);  // the curve's normal (gradient of y - handover(x))
    nrm = nrm / std::sqrt(dot(nrm, nrm));
    const double sgn = i % 2 ? 1.0 : -1.0, elev = 0.05 + 0.3 * U(rng);
    // Halfway up the jump.
    const double z = 0.5 * (double(scratchHeight(list, Vec2f(float(x - 2e-4 * nrm.x), float(y - 2e-4 * nrm.y)))) +
                            double(scratchHeight(list, Vec2f(float(x + 2e-4 * nrm.x), float(y + 2e-4 * nrm.y)))));
    const Vec3d target(x, y, z);
    const Vec3d d = normalize(Vec3d(sgn * nrm.x * std::cos(elev), sgn * nrm.y * std::cos(elev), -std::sin(elev)));
    const Vec3d o = target + shift - d * 0.02;
    double tm = meshHitAmong(m, tris, o, d), tf = fieldHitOf(list, shift, o, d, 0.2);
    if (!(tf < 1e29)) continue;
    ++n;
    const double err = std::fabs(tm - tf);
    worst = std::max(worst, err);
    rays_off += err > 2e-4;
    Vec3d p = o + d * tf - shift, q = p - Vec3d(d.x, d.y, 0.0) * 1e-5;
    walls_hit += std::fabs(double(scratchHeight(list, Vec2f(float(p.x), float(p.y)))) -
                           double(scratchHeight(list, Vec2f(float(q.x), float(q.y))))) > 5e-4;
  }
  EXPECT_GT(n, 150);
  EXPECT_GT(walls_hit, 20);
  EXPECT_EQ(rays_off, 0) << "of " << n << " rays (" << walls_hit << " at the wall); worst |t_mesh - t_field| " << worst;
}

// meetScratchHeight (the groove renderer's rays rising low beyond a footprint's polygons): where a
// ray first goes below the composite height, against a fine march of the same field, and which
// scratch's height that is.
TEST(ScratchGeometry, ARisingRayMeetsThePileUpAheadWhereAFineMarchDoes) {
  // Two grooves with pile-ups along u, at v = 10 and v = 10.5 (UV = mm on the plate).
  const Profile prof = pileUpProfile();
  const Scratch near = Scratch::fromProfile(ScratchPath::polyline({{5.0, 10.0}, {15.0, 10.0}}), prof);
  const Scratch far = Scratch::fromProfile(ScratchPath::polyline({{5.0, 10.5}, {15.0, 10.5}}), prof);
  const std::vector<const Scratch*> list{&near, &far};
  int met = 0;
  // From the plate between them, 0.5 to 3 um up, towards either, rising 0.05 to 0.5 degrees, at 0
  // to 60 degrees from square to the grooves. (Higher, the part of a crest above the ray is
  // narrower than the march's step, 5 um here, and the march may pass over it: from 4.5 um up,
  // 1.6 um of the crest is above.)
  for (int side = -1; side <= 1; side += 2)
    for (double z0 : {0.0005, 0.002, 0.003})
      for (double elev_deg : {0.05, 0.2, 0.5})
        for (double turn_deg : {0.0, 30.0, 60.0}) {
          const double turn = turn_deg * M_PI / 180, slope = std::tan(elev_deg * M_PI / 180);
          const Vec2d a(10.0, 10.25), du(std::sin(turn), side * std::cos(turn));
          const double len = (0.005 - z0) / slope;
          HeightMeet m;
          const bool hit = meetScratchHeight(list, a, du, z0, slope, len, 0.04 / 8, 1e-7, m);
          // The fine march: the same ray in 3-D (world = uv here), 20 nm steps.
          const Vec3d d = normalize(Vec3d(du.x, du.y, slope));
          const double t = fieldHitOf(list, Vec3d(0, 0, 0), Vec3d(a.x, a.y, z0), d, len / std::sqrt(1 - d.z * d.z));
          SCOPED_TRACE(::testing::Message() << "side " << side << " z0 " << z0 << " elev " << elev_deg << " turn " << turn_deg);
          ASSERT_EQ(hit, t < 1e30);
          if (!hit) continue;
          ++met;
          const double x_fine = t * std::sqrt(1 - d.z * d.z);
          EXPECT_NEAR(m.at, x_fine, 2e-5 + 1e-7 / slope);
          EXPECT_LT(m.from, m.at);
          EXPECT_GE(m.from, m.at - 0.04 / 8 - 1e-9);
          // Towards +v the far groove's pile-up, towards -v the near one's.
          EXPECT_EQ(m.scratch, side > 0 ? &far : &near);
        }
  // 48 of the 54 meet one; the other six, rising 0.5 degrees (from 3 um up turned 30 or 60
  // degrees, from 2 um up turned 60), are above the crests (5 um) before they reach them.
  EXPECT_EQ(met, 48);
  // Above the crests it meets nothing; along the grooves, between them, nothing either.
  HeightMeet m;
  EXPECT_FALSE(meetScratchHeight(list, Vec2d(10.0, 10.25), Vec2d(0.0, 1.0), 0.0051, 0.001, 5.0, 0.005, 1e-7, m));
  EXPECT_FALSE(meetScratchHeight(list, Vec2d(10.0, 10.25), Vec2d(1.0, 0.0), 0.0001, 0.001, 5.0, 0.005, 1e-7, m));
  // Rising out of a groove's channel along it, turned 5 degrees: it meets that groove's wall.
  const double turn = 5 * M_PI / 180;
  ASSERT_TRUE(meetScratchHeight(list, Vec2d(8.0, 10.0), Vec2d(std::cos(turn), std::sin(turn)), -0.015, 0.01, 2.0,
                                0.005, 1e-7, m));
  EXPECT_EQ(m.scratch, &near);
  EXPECT_LT(m.at, 0.5);  // (the wall is within 0.04 mm of the centre line: 0.46 mm along)
}

// meetScratchHeight from below (the integrator's meetGrooves: a ray inside a glass part that meets
// the scratched face again): where the ray first goes above the composite height, against a fine
// march. Under a groove that is its floor or wall, before the plane the smooth surface's hit is on.
TEST(ScratchGeometry, ARayFromInsideLeavesWhereItFirstGoesAboveTheSurface) {
  const Scratch groove = Scratch::fromProfile(ScratchPath::polyline({{5.0, 10.0}, {15.0, 10.0}}), pileUpProfile());
  const std::vector<const Scratch*> list{&groove};
  auto fine = [&](Vec2d a, Vec2d du, double z0, double slope, double len) {
    for (double x = 1e-7; x < len; x += 1e-7)
      if (z0 + slope * x > double(scratchHeight(list, Vec2f(float(a.x + du.x * x), float(a.y + du.y * x)))))
        return x;
    return 1e30;
  };
  int walls = 0, plain = 0;
  // From 24 um below the plate (4 under the floor), rising 27 to 79 degrees (2.14: a ray at 25
  // degrees from the normal, as inside the fuzzer's p84_5), across the groove or along it turned
  // 30 degrees, from 0.06 mm on either side of the centre line.
  for (double b0 : {-0.06, -0.03, -0.01, 0.0, 0.02})
    for (double slope : {0.5, 2.14, 5.0})
      for (double turn_deg : {0.0, 60.0}) {
        const double turn = turn_deg * M_PI / 180;
        const Vec2d a(10.0, 10.0 + b0), du(std::sin(turn), std::cos(turn));
        const double z0 = -0.024, len = 0.04 / slope;  // (to 16 um above the pile-ups' crests)
        HeightMeet m;
        SCOPED_TRACE(::testing::Message() << "b0 " << b0 << " slope " << slope << " turn " << turn_deg);
        ASSERT_TRUE(meetScratchHeight(list, a, du, z0, slope, len, 0.0025, 1e-7, m, true, true));
        const double x_fine = fine(a, du, z0, slope, len);
        EXPECT_NEAR(m.at, x_fine, 5e-6);  // (the bisection's step / 1024, 2.4e-6, and float UV: 1e-6 at 10 mm)
        EXPECT_LE(m.from, m.at);
        if (m.scratch) {
          ++walls;
          EXPECT_EQ(m.scratch, &groove);
          // In a groove's channel, before the plane (z = 0, at x = 0.024 / slope).
          if (z0 + slope * m.at < -1e-4) EXPECT_LT(m.at, (0.024 - 1e-4) / slope);
        } else {
          ++plain;
          EXPECT_NEAR(m.at, 0.024 / slope, 3e-6);  // the plain part: the plane itself
        }
        // Without `plain` a meeting with the plain part does not count.
        HeightMeet m2;
        EXPECT_EQ(meetScratchHeight(list, a, du, z0, slope, len, 0.0025, 1e-7, m2, false, true), m.scratch != nullptr);
      }
  EXPECT_GT(walls, 15);
  EXPECT_GT(plain, 3);
  // From below the plain part far from the groove it meets the plane; rising too little to reach
  // it within len, nothing.
  HeightMeet m;
  ASSERT_TRUE(meetScratchHeight(list, Vec2d(10.0, 12.0), Vec2d(0.0, 1.0), -0.01, 1.0, 0.02, 0.0025, 1e-7, m, true, true));
  EXPECT_NEAR(m.at, 0.01, 3e-6);
  EXPECT_FALSE(meetScratchHeight(list, Vec2d(10.0, 12.0), Vec2d(0.0, 1.0), -0.01, 0.1, 0.05, 0.0025, 1e-7, m, true, true));
}

// The march of rays that leave the polygons downwards (the integrator's beyondRegion): past the
// end of a groove's leg its straight section has a channel and pile-ups that are not there. Over
// the plate beside the groove the ray meets the plain part, and down its channel the end's wall
// (an abrupt end: the plain part beyond); both count only with `plain` (no scratch's height there).
TEST(ScratchGeometry, ADescendingRayMeetsThePlainPartPastAGroovesEnd) {
  const Scratch groove = Scratch::fromProfile(ScratchPath::polyline({{5.0, 10.0}, {10.0, 10.0}}), pileUpProfile());
  const std::vector<const Scratch*> list{&groove};
  HeightMeet m;
  // In the channel, 10 um below the plate, along it and falling 1 um per mm: the end's wall, 1 mm on.
  EXPECT_FALSE(meetScratchHeight(list, Vec2d(9.0, 10.0), Vec2d(1.0, 0.0), -0.01, -0.001, 3.0, 0.005, 1e-7, m));
  ASSERT_TRUE(meetScratchHeight(list, Vec2d(9.0, 10.0), Vec2d(1.0, 0.0), -0.01, -0.001, 3.0, 0.005, 1e-7, m, true));
  EXPECT_EQ(m.scratch, nullptr);
  EXPECT_NEAR(m.at, 1.0, 1e-5);
  // Over the plate 0.06 mm beside it (past the pile-up's foot at 0.04), 2 um up: the plate at 2 mm,
  // 1 mm past the end.
  EXPECT_FALSE(meetScratchHeight(list, Vec2d(9.0, 10.06), Vec2d(1.0, 0.0), 0.002, -0.001, 3.0, 0.005, 1e-7, m));
  ASSERT_TRUE(meetScratchHeight(list, Vec2d(9.0, 10.06), Vec2d(1.0, 0.0), 0.002, -0.001, 3.0, 0.005, 1e-7, m, true));
  EXPECT_EQ(m.scratch, nullptr);
  EXPECT_NEAR(m.at, 2.0, 1e-3);
  // Beside the groove, 1 um above its pile-up's crest (5 um, 0.03 from the centre line), falling
  // 1 um per mm: the crest, before the end.
  ASSERT_TRUE(meetScratchHeight(list, Vec2d(8.0, 10.03), Vec2d(1.0, 0.0), 0.006, -0.001, 3.0, 0.005, 1e-7, m, true));
  EXPECT_EQ(m.scratch, &groove);
  EXPECT_NEAR(m.at, 1.0, 0.01);
}
