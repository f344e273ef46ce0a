// Part geometry: TriangleMesh measurements, the built-in parametric parts and mesh loading.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <numeric>
#include <set>
#include <string>

#include "core/error.h"
#include "render/mesh.h"
#include "render/mesh_io.h"
#include "render/parts.h"

namespace dg {
namespace {

std::string fixture(const std::string& name) {
  return std::string(DG_SOURCE_DIR) + "/tests/fixtures/meshes/" + name;
}

std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

Vec3d d3(Vec3f v) { return Vec3d(v); }

double meanMmPerUv(const TriangleMesh& m) {
  return std::accumulate(m.mmPerUv.begin(), m.mmPerUv.end(), 0.0) / double(m.mmPerUv.size());
}

double uvArea(const TriangleMesh& m) {
  double a = 0;
  for (size_t t = 0; t < m.triangleCount(); ++t) {
    const Vec2f p = m.uvs[m.indices[3 * t]], q = m.uvs[m.indices[3 * t + 1]], r = m.uvs[m.indices[3 * t + 2]];
    a += 0.5 * std::abs(double(q.x - p.x) * (r.y - p.y) - double(q.y - p.y) * (r.x - p.x));
  }
  return a;
}

// Topology of a triangle list: undirected edges used more than twice, directed edges used more than
// once (inconsistent winding), and the number of boundary loops (components of the boundary edges).
struct Topology {
  int nonManifoldEdges = 0, repeatedDirectedEdges = 0, boundaryLoops = 0;
};
Topology topology(const TriangleMesh& m) {
  std::map<std::pair<uint32_t, uint32_t>, int> directed, undirected;
  for (size_t t = 0; t < m.triangleCount(); ++t)
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = m.indices[3 * t + size_t(k)], b = m.indices[3 * t + size_t((k + 1) % 3)];
      ++directed[{a, b}];
      ++undirected[{std::min(a, b), std::max(a, b)}];
    }
  Topology topo;
  std::vector<uint32_t> parent(m.positions.size());
  std::iota(parent.begin(), parent.end(), 0u);
  std::function<uint32_t(uint32_t)> find = [&](uint32_t a) { return parent[a] == a ? a : parent[a] = find(parent[a]); };
  std::set<uint32_t> boundaryVerts;
  for (const auto& [e, n] : undirected) {
    if (n > 2) ++topo.nonManifoldEdges;
    if (n == 1) {
      parent[find(e.first)] = find(e.second);
      boundaryVerts.insert(e.first);
      boundaryVerts.insert(e.second);
    }
  }
  for (const auto& [e, n] : directed) topo.repeatedDirectedEdges += n > 1;
  std::set<uint32_t> roots;
  for (uint32_t v : boundaryVerts) roots.insert(find(v));
  topo.boundaryLoops = int(roots.size());
  return topo;
}

// Properties every built-in part must have.
void checkPart(const TriangleMesh& m, double maxEdge) {
  ASSERT_GT(m.triangleCount(), 0u);
  ASSERT_EQ(m.normals.size(), m.positions.size());
  ASSERT_EQ(m.uvs.size(), m.positions.size());
  ASSERT_EQ(m.mmPerUv.size(), m.triangleCount());
  for (size_t i = 0; i < m.positions.size(); ++i) {
    ASSERT_TRUE(isFinite(m.positions[i])) << i;
    ASSERT_NEAR(length(m.normals[i]), 1.0f, 1e-5f) << i;
    ASSERT_GE(m.uvs[i].x, -1e-4f) << i;
    ASSERT_GE(m.uvs[i].y, -1e-4f) << i;
  }
  Vec3d meanNormal(0.0);
  double longest = 0;
  for (size_t t = 0; t < m.triangleCount(); ++t) {
    const uint32_t* f = &m.indices[3 * t];
    const Vec3d g = cross(d3(m.positions[f[1]]) - d3(m.positions[f[0]]), d3(m.positions[f[2]]) - d3(m.positions[f[0]]));
    ASSERT_GT(length(g), 0.0) << "degenerate triangle " << t;
    for (int k = 0; k < 3; ++k) {
      ASSERT_GT(dot(normalize(g), d3(m.normals[f[k]])), 0.5) << "triangle " << t << " corner " << k;
      longest = std::max(longest, length(d3(m.positions[f[(k + 1) % 3]]) - d3(m.positions[f[k]])));
    }
    meanNormal += g;
    ASSERT_GT(m.mmPerUv[t], 0.0f) << t;
  }
  EXPECT_GT(normalize(meanNormal).z, 0.9) << "outside should face +z";
  EXPECT_LE(longest, maxEdge * (1 + 1e-5));
  Vec3f lo, hi;
  m.bounds(lo, hi);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(lo[k] + hi[k], 0.0f, 1e-3f * (hi[k] - lo[k]) + 1e-4f) << "axis " << k;
  const Topology topo = topology(m);
  EXPECT_EQ(topo.nonManifoldEdges, 0);
  EXPECT_EQ(topo.repeatedDirectedEdges, 0);
  EXPECT_EQ(topo.boundaryLoops, 1);
}

// Simpson's rule over [a, b] with n (even) intervals.
double simpson(const std::function<double(double)>& f, double a, double b, int n) {
  const double h = (b - a) / n;
  double s = f(a) + f(b);
  for (int k = 1; k < n; ++k) s += (k % 2 ? 4 : 2) * f(a + k * h);
  return s * h / 3;
}

// ------------------------------------------------------------------ TriangleMesh

TEST(Math, UnitOrUpNormalisesAndFallsBackToUp) {
  Vec3f n = unitOrUp(cross(Vec3d(2, 0, 0), Vec3d(0, 0, 3)));  // (0, -6, 0)
  EXPECT_NEAR(n.x, 0.0f, 1e-7f);
  EXPECT_NEAR(n.y, -1.0f, 1e-7f);
  EXPECT_NEAR(n.z, 0.0f, 1e-7f);
  n = unitOrUp(Vec3d(3e-30, 0, 4e-30));  // tiny but not zero: still a unit vector
  EXPECT_NEAR(n.x, 0.6f, 1e-6f);
  EXPECT_NEAR(n.z, 0.8f, 1e-6f);
  // A degenerate (collinear) triangle has no normal: +z.
  EXPECT_EQ(unitOrUp(cross(Vec3d(1, 1, 1), Vec3d(2, 2, 2))), Vec3f(0, 0, 1));
}

TEST(TriangleMesh, AreaBoundsAndMmPerUv) {
  TriangleMesh m;
  m.positions = {{0, 0, 0}, {4, 0, 0}, {0, 3, 0}, {4, 3, 5}};
  m.uvs = {{0, 0}, {2, 0}, {0, 1.5f}, {2, 1.5f}};
  m.indices = {0, 1, 2, 1, 3, 2};
  // Second triangle: legs (0,3,5)-ish; area = |(0,3,5) x (-4,3,0)| / 2.
  const double a2 = 0.5 * length(cross(Vec3d(0, 3, 5), Vec3d(-4, 3, 0)));
  EXPECT_NEAR(m.surfaceAreaMm2(), 6.0 + a2, 1e-9);
  Vec3f lo, hi;
  m.bounds(lo, hi);
  EXPECT_EQ(lo, Vec3f(0, 0, 0));
  EXPECT_EQ(hi, Vec3f(4, 3, 5));
  m.computeMmPerUv();
  ASSERT_EQ(m.mmPerUv.size(), 2u);
  EXPECT_NEAR(m.mmPerUv[0], 2.0f, 1e-6f);                       // UVs at half scale
  EXPECT_NEAR(m.mmPerUv[1], std::sqrt(a2 / 1.5), 1e-5);        // UV area of 2nd triangle = 1.5
  m.uvs[3] = {1, 0.75f};                                        // collinear with uv 1 and 2
  m.computeMmPerUv();
  EXPECT_EQ(m.mmPerUv[1], 0.0f);
  m.uvs.clear();
  m.computeMmPerUv();
  EXPECT_EQ(m.mmPerUv, std::vector<float>(2, 0.0f));
  TriangleMesh empty;
  empty.bounds(lo, hi);
  EXPECT_GT(lo.x, hi.x);
  EXPECT_EQ(empty.surfaceAreaMm2(), 0.0);
}

// ------------------------------------------------------------------ parts

TEST(Parts, PlateIsExact) {
  const TriangleMesh m = makePlate({300, 200}, 10);
  checkPart(m, 10);
  EXPECT_EQ(m.source, "builtin:plate");
  EXPECT_NEAR(m.surfaceAreaMm2(), 300.0 * 200.0, 1e-6 * 300 * 200);
  for (float s : m.mmPerUv) ASSERT_NEAR(s, 1.0f, 1e-5f);
  Vec3f lo, hi;
  m.bounds(lo, hi);
  EXPECT_NEAR(lo.x, -150, 1e-4);
  EXPECT_NEAR(hi.y, 100, 1e-4);
  EXPECT_EQ(lo.z, 0.0f);
  EXPECT_EQ(hi.z, 0.0f);
  for (size_t i = 0; i < m.positions.size(); ++i) {  // u = x + W/2, v = y + H/2
    ASSERT_NEAR(m.uvs[i].x, m.positions[i].x + 150, 1e-4);
    ASSERT_NEAR(m.uvs[i].y, m.positions[i].y + 100, 1e-4);
  }
}

TEST(Parts, DoorPanelBowArcLength) {
  DoorPanelParams p;
  p.character_line_depth_mm = 0;
  const TriangleMesh m = makeDoorPanel(p, 10);
  checkPart(m, 10);
  const double R = p.curvature_radius_mm, H = p.height_mm;
  const double arc = 2 * R * std::asin(H / (2 * R));
  EXPECT_NEAR(m.surfaceAreaMm2(), p.width_mm * arc, 1e-3 * p.width_mm * arc);
  EXPECT_NEAR(meanMmPerUv(m), 1.0, 0.02);
  float vmax = 0;
  for (const Vec2f& t : m.uvs) vmax = std::max(vmax, t.y);
  EXPECT_NEAR(vmax, arc, 1e-3 * arc);  // v is the true arc length, longer than the height
  EXPECT_GT(vmax, H + 1.0);
}

TEST(Parts, DoorPanelCharacterLine) {
  DoorPanelParams p;  // defaults: ridge 4 mm high, 20 mm wide at 0.6 of the height
  const TriangleMesh m = makeDoorPanel(p, 10);
  checkPart(m, 10);
  const double R = p.curvature_radius_mm, H = p.height_mm, d = p.character_line_depth_mm,
               w = p.character_line_width_mm, yc = -0.5 * H + p.character_line_height * H;
  auto slope = [&](double y) {
    double r = std::abs(y - yc) < 0.5 * w ? -d * kPi / w * std::sin(2 * kPi * (y - yc) / w) : 0;
    return -y / std::sqrt(R * R - y * y) + r;
  };
  // Arc length of the section, independently: Simpson on each smooth piece.
  auto speed = [&](double y) { return std::sqrt(1 + slope(y) * slope(y)); };
  const double arc = simpson(speed, -0.5 * H, yc - 0.5 * w, 20000) + simpson(speed, yc - 0.5 * w, yc + 0.5 * w, 20000) +
                     simpson(speed, yc + 0.5 * w, 0.5 * H, 20000);
  EXPECT_NEAR(m.surfaceAreaMm2(), p.width_mm * arc, 0.01 * p.width_mm * arc);
  EXPECT_NEAR(meanMmPerUv(m), 1.0, 0.02);
  // The ridge: z minus the bow is a constant (the centring shift) plus the ridge profile.
  double rmin = 1e9, rmax = -1e9, yAtMax = 0;
  for (const Vec3f& q : m.positions) {
    const double r = q.z - (std::sqrt(R * R - double(q.y) * q.y) - R);
    rmin = std::min(rmin, r);
    if (r > rmax) rmax = r, yAtMax = q.y;
  }
  EXPECT_NEAR(rmax - rmin, d, 0.03 * d);
  EXPECT_NEAR(yAtMax, yc, w / 12);
}

TEST(Parts, HoodCrownAndArea) {
  HoodParams p;
  const TriangleMesh m = makeHood(p, 15);
  checkPart(m, 15);
  const double W = p.width_mm, L = p.length_mm, c = p.crown_mm;
  Vec3f lo, hi;
  m.bounds(lo, hi);
  EXPECT_NEAR(hi.z - lo.z, c, 1e-3);  // corners at 0, centre at the crown
  // Area = double integral of sqrt(1 + zx^2 + zy^2), Simpson in both directions.
  auto inner = [&](double y) {
    return simpson([&](double x) {
      const double gx = 1 - 4 * x * x / (W * W), gy = 1 - 4 * y * y / (L * L);
      const double zx = -8 * c * x * gy / (W * W), zy = -8 * c * y * gx / (L * L);
      return std::sqrt(1 + zx * zx + zy * zy);
    }, -0.5 * W, 0.5 * W, 200);
  };
  const double area = simpson(inner, -0.5 * L, 0.5 * L, 200);
  EXPECT_GT(area, W * L * 1.001);  // the crown adds area measurably...
  EXPECT_NEAR(m.surfaceAreaMm2(), area, 2e-4 * area);  // ...and the mesh has it
  EXPECT_NEAR(meanMmPerUv(m), 1.0, 0.01);
  EXPECT_NEAR(uvArea(m), area, 0.01 * area);
}

TEST(Parts, FenderArchIsCutOut) {
  FenderParams p;
  const TriangleMesh m = makeFender(p, 10);
  checkPart(m, 10);
  const double a = p.arch_radius_mm, H = p.height_mm, R = p.curvature_radius_mm, L = p.length_mm;
  int onCircle = 0;
  for (const Vec3f& q : m.positions) {
    const double r = std::hypot(double(q.x), q.y + 0.5 * H);
    ASSERT_GE(r, a - 1e-3) << "vertex inside the arch at " << q.x << ", " << q.y;
    onCircle += r < a + 1e-3;
  }
  // The arch boundary is made of vertices on the circle, at most about one edge apart.
  EXPECT_GE(onCircle, int(kPi * a / 10));
  // Area: the unrolled cylinder minus the half disc seen from the side; on the cylinder an element
  // dx dy covers dx dy / cos(theta) = dx dy R / sqrt(R^2 - x^2).
  const double U = 2 * R * std::asin(L / (2 * R));
  const double hole = simpson([&](double x) { return std::sqrt(std::max(0.0, a * a - x * x)) * R / std::sqrt(R * R - x * x); },
                              -a, a, 20000);
  EXPECT_NEAR(m.surfaceAreaMm2(), U * H - hole, 1e-3 * (U * H - hole));
  EXPECT_NEAR(meanMmPerUv(m), 1.0, 0.01);  // developable: the chart is (nearly) isometric
}

TEST(Parts, RejectsBadParameters) {
  EXPECT_THROW(makePlate({0, 200}), std::invalid_argument);
  EXPECT_THROW(makePlate({300, std::nan("")}), std::invalid_argument);
  EXPECT_THROW(makePlate({300, 200}, -1), std::invalid_argument);
  EXPECT_THROW(makePlate({300, 200}, 1e-4), std::invalid_argument);  // absurdly fine
  DoorPanelParams door;
  door.curvature_radius_mm = 250;  // less than half of the 600 mm height
  EXPECT_THROW(makeDoorPanel(door), std::invalid_argument);
  door = {};
  door.character_line_height = 1.5;
  EXPECT_THROW(makeDoorPanel(door), std::invalid_argument);
  HoodParams hood;
  hood.crown_mm = -1;
  EXPECT_THROW(makeHood(hood), std::invalid_argument);
  FenderParams fender;
  fender.arch_radius_mm = 500;  // wider than half the length
  EXPECT_THROW(makeFender(fender), std::invalid_argument);
}

// ------------------------------------------------------------------ loading

// Runs loadMesh expecting an InputError; returns its message.
std::string loadError(const std::string& path, const MeshLoadOptions& opts = {}) {
  try {
    loadMesh(path, opts);
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no InputError for " << path;
  return "";
}

void expectBounds(const TriangleMesh& m, Vec3f lo, Vec3f hi, float tol = 1e-4f) {
  Vec3f l, h;
  m.bounds(l, h);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(l[k], lo[k], tol) << "axis " << k;
    EXPECT_NEAR(h[k], hi[k], tol) << "axis " << k;
  }
}

TEST(LoadMesh, ObjWithTexcoordsAndNormals) {
  const std::string path = fixture("quad_vt.obj");
  const TriangleMesh m = loadMesh(path);
  EXPECT_EQ(m.source, path);
  EXPECT_EQ(m.triangleCount(), 4u);  // two quads, fan-split
  EXPECT_EQ(m.positions.size(), 6u);
  expectBounds(m, {0, 0, 0}, {20, 10, 0});
  EXPECT_NEAR(m.surfaceAreaMm2(), 200.0, 1e-9);
  // vt = position / 20: the file chart scaled to mm (total UV area = area) is uv = position.
  for (size_t i = 0; i < m.positions.size(); ++i) {
    EXPECT_NEAR(m.uvs[i].x, m.positions[i].x, 1e-4) << i;
    EXPECT_NEAR(m.uvs[i].y, m.positions[i].y, 1e-4) << i;
    EXPECT_EQ(m.normals[i], Vec3f(0, 0, 1));
  }
  for (float s : m.mmPerUv) EXPECT_NEAR(s, 1.0f, 1e-5f);
  // Geometric normals agree with the file's: the winding is kept.
  const Vec3d g = cross(d3(m.positions[m.indices[1]]) - d3(m.positions[m.indices[0]]),
                        d3(m.positions[m.indices[2]]) - d3(m.positions[m.indices[0]]));
  EXPECT_GT(g.z, 0);
}

// Binary OFF (Geomview's "OFF BINARY"), with a colour after the first face: CGAL 5.5's reader
// took that colour's count for the next face's corner count and returned one of the two quads.
TEST(LoadMesh, BinaryOffWithNormalsTexcoordsAndFaceColours) {
  const TriangleMesh m = loadMesh(fixture("quads_binary.off"));
  EXPECT_EQ(m.triangleCount(), 4u);  // two quads, fan-split
  EXPECT_EQ(m.positions.size(), 6u);
  expectBounds(m, {0, 0, 0}, {20, 10, 0});
  EXPECT_NEAR(m.surfaceAreaMm2(), 200.0, 1e-9);
  for (size_t i = 0; i < m.positions.size(); ++i) {  // st = position / 20, scaled to mm
    EXPECT_NEAR(m.uvs[i].x, m.positions[i].x, 1e-4) << i;
    EXPECT_NEAR(m.uvs[i].y, m.positions[i].y, 1e-4) << i;
    EXPECT_EQ(m.normals[i], Vec3f(0, 0, 1));
  }
}

TEST(LoadMesh, BadBinaryOffIsRefusedWithTheByteItBreaksAt) {
  const std::string good = readFile(fixture("quads_binary.off"));
  const size_t data = good.find('\n') + 1;
  const size_t face0 = data + 12 + 6 * 32, face1 = face0 + 4 + 16 + 4 + 16;
  auto put = [](std::string s, size_t at, uint32_t v) {
    for (int k = 0; k < 4; ++k) s[at + size_t(k)] = char(v >> (24 - 8 * k));
    return s;
  };
  const std::string dir = ::testing::TempDir();
  auto error = [&](const std::string& name, const std::string& bytes) {
    std::ofstream(dir + "/" + name, std::ios::binary) << bytes;
    return loadError(dir + "/" + name);
  };
  std::string e = error("long.off", put(good, face1, 1500000000));
  EXPECT_NE(e.find("long.off: face 1 (counting from 0), at byte " + std::to_string(face1) +
                   ": a corner count of 1500000000, more than the 20 bytes left in the file can hold"), std::string::npos) << e;
  e = error("two.off", put(good, face1, 2));
  EXPECT_NE(e.find("face 1 (counting from 0), at byte " + std::to_string(face1) +
                   ": expected its number of corners (an integer >= 3), found 2"), std::string::npos) << e;
  e = error("index.off", put(good, face1 + 8, 6));
  EXPECT_NE(e.find("face 1 (counting from 0), at byte " + std::to_string(face1) + ": expected a vertex index from 0 to 5, found 6"),
            std::string::npos) << e;
  e = error("colours.off", put(good, face0 + 20, 5));
  EXPECT_NE(e.find("face 0 (counting from 0), at byte " + std::to_string(face0) +
                   ": expected its number of colour components (0 to 4, as many floats after it), found 5"), std::string::npos) << e;
  e = error("counts.off", put(good, data, 1000000));
  EXPECT_NE(e.find("counts.off: the header declares 1000000 vertices of 32 bytes and 2 faces, more than the"), std::string::npos) << e;
  e = error("nan.off", put(good, data + 12 + 32 + 4, 0x7fc00000u));
  EXPECT_NE(e.find("vertex 1 (counting from 0), at byte " + std::to_string(data + 12 + 32) + ": expected finite numbers, found nan"),
            std::string::npos) << e;
  e = error("short.off", good.substr(0, face1 + 2));
  EXPECT_NE(e.find("short.off: the file ends after 1 of the 2 faces the header declares"), std::string::npos) << e;
  e = error("colour.off", "C" + good.substr(2));  // "CNOFF BINARY": a vertex colour's size is not agreed on
  EXPECT_NE(e.find("colour.off:1:1: binary 'CNOFF' is not read"), std::string::npos) << e;
  // In ASCII, CGAL read a face of two corners and the loader dropped it without a word.
  e = error("edge.off", "OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n2 0 2\n");
  EXPECT_NE(e.find("edge.off:8:1: face 1 (counting from 0): expected its number of corners (an integer >= 3), found '2'"),
            std::string::npos) << e;
}

TEST(LoadMesh, UnitScaleIsApplied) {
  MeshLoadOptions o;
  o.unit_scale_to_mm = 2.5;
  const TriangleMesh m = loadMesh(fixture("quad_vt.obj"), o);
  expectBounds(m, {0, 0, 0}, {50, 25, 0});
  EXPECT_NEAR(m.surfaceAreaMm2(), 200.0 * 2.5 * 2.5, 1e-6);
  EXPECT_NEAR(uvArea(m), m.surfaceAreaMm2(), 1e-3);  // UVs stay in mm
  o.unit_scale_to_mm = 0;
  EXPECT_NE(loadError(fixture("quad_vt.obj"), o).find("unit_scale_to_mm"), std::string::npos);
}

TEST(LoadMesh, PlyClosedTetrahedron) {
  MeshLoadOptions o;
  o.compute_uvs_if_missing = false;
  const TriangleMesh m = loadMesh(fixture("tetra.ply"), o);
  EXPECT_EQ(m.triangleCount(), 4u);
  EXPECT_EQ(m.positions.size(), 4u);
  expectBounds(m, {0, 0, 0}, {1, 1, 1});
  EXPECT_TRUE(m.uvs.empty());
  // Area-weighted normals of a closed, outward-wound solid point away from its centroid.
  const Vec3d centroid(0.25, 0.25, 0.25);
  for (size_t i = 0; i < m.positions.size(); ++i) {
    EXPECT_NEAR(length(m.normals[i]), 1.0f, 1e-5f);
    EXPECT_GT(dot(d3(m.normals[i]), d3(m.positions[i]) - centroid), 0) << i;
  }
  const std::string e = loadError(fixture("tetra.ply"));
  EXPECT_NE(e.find("tetra.ply"), std::string::npos) << e;
  EXPECT_NE(e.find("closed mesh"), std::string::npos) << e;
}

TEST(LoadMesh, StlCubeScaledAndNotParameterizable) {
  MeshLoadOptions o;
  o.unit_scale_to_mm = 10;
  o.compute_uvs_if_missing = false;
  const TriangleMesh m = loadMesh(fixture("cube.stl"), o);
  EXPECT_EQ(m.triangleCount(), 12u);
  EXPECT_EQ(m.positions.size(), 8u);  // STL corners shared by position
  expectBounds(m, {0, 0, 0}, {10, 10, 10});
  EXPECT_NEAR(m.surfaceAreaMm2(), 600.0, 1e-6);
  const std::string e = loadError(fixture("cube.stl"));
  EXPECT_NE(e.find("cube.stl"), std::string::npos) << e;
  EXPECT_NE(e.find("cannot be parameterized"), std::string::npos) << e;
  EXPECT_NE(e.find("closed mesh with no boundary"), std::string::npos) << e;
  EXPECT_NE(e.find("add UVs"), std::string::npos) << e;
}

TEST(LoadMesh, OpenPatchGetsIsometricUvs) {
  const TriangleMesh m = loadMesh(fixture("curved_patch.off"));
  EXPECT_EQ(m.triangleCount(), 200u);  // 100 quads
  const double R = 50, half = 0.4;     // 40 mm of arc on a 50 mm radius
  expectBounds(m, {float(-R * std::sin(half)), 0, float(R * std::cos(half) - R)}, {float(R * std::sin(half)), 40, 0}, 1e-3f);
  ASSERT_EQ(m.uvs.size(), m.positions.size());
  const double area = m.surfaceAreaMm2();
  EXPECT_NEAR(uvArea(m), area, 1e-4 * area);
  EXPECT_NEAR(meanMmPerUv(m), 1.0, 0.01);
  for (float s : m.mmPerUv) EXPECT_NEAR(s, 1.0f, 0.02f);
  float umin = 1e9f, vmin = 1e9f, umax = -1e9f, vmax = -1e9f;
  for (const Vec2f& t : m.uvs) {
    umin = std::min(umin, t.x), vmin = std::min(vmin, t.y);
    umax = std::max(umax, t.x), vmax = std::max(vmax, t.y);
  }
  EXPECT_NEAR(std::min(umin, vmin), 0.0f, 1e-4f);
  // The cylinder unrolls isometrically: the chart's corners are 40 mm of arc apart along each side
  // and 40 sqrt(2) apart across; whatever the chart's rotation, the first corner pair shows it.
  auto find = [&](float x, float y, float z) {
    for (size_t i = 0; i < m.positions.size(); ++i)
      if (length(m.positions[i] - Vec3f(x, y, z)) < 1e-3f) return i;
    return size_t(-1);
  };
  const float xs = float(R * std::sin(half)), zs = float(R * std::cos(half) - R);
  const size_t c00 = find(-xs, 0, zs), c10 = find(xs, 0, zs), c11 = find(xs, 40, zs);
  ASSERT_NE(c00, size_t(-1));
  ASSERT_NE(c10, size_t(-1));
  ASSERT_NE(c11, size_t(-1));
  auto dist = [&](size_t i, size_t j) { return std::hypot(m.uvs[i].x - m.uvs[j].x, m.uvs[i].y - m.uvs[j].y); };
  EXPECT_NEAR(dist(c00, c10), 40.0, 0.2);
  EXPECT_NEAR(dist(c10, c11), 40.0, 0.2);
  EXPECT_NEAR(dist(c00, c11), 40.0 * std::sqrt(2.0), 0.3);
  // Orientation: counter-clockwise triangles stay counter-clockwise in UV.
  for (size_t t = 0; t < m.triangleCount(); ++t) {
    const Vec2f p = m.uvs[m.indices[3 * t]], q = m.uvs[m.indices[3 * t + 1]], r = m.uvs[m.indices[3 * t + 2]];
    ASSERT_GT((q.x - p.x) * (r.y - p.y) - (q.y - p.y) * (r.x - p.x), 0.0f) << t;
  }
}

// Writes an OFF grid of nu x nv vertices at position(i, j), two triangles per cell with the
// diagonal alternating from cell to cell; counter-clockwise when position grows along +x with i and
// +y with j.
std::string writeGridOff(const std::string& name, int nu, int nv, const std::function<Vec3d(int, int)>& position) {
  const std::string path = ::testing::TempDir() + "/" + name;
  std::ofstream f(path);
  f.precision(17);
  f << "OFF\n" << nu * nv << " " << 2 * (nu - 1) * (nv - 1) << " 0\n";
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const Vec3d q = position(i, j);
      f << q.x << " " << q.y << " " << q.z << "\n";
    }
  for (int j = 0; j + 1 < nv; ++j)
    for (int i = 0; i + 1 < nu; ++i) {
      const int a = j * nu + i, b = a + 1, c = a + nu, d = c + 1;
      if ((i + j) % 2)
        f << "3 " << a << " " << b << " " << d << "\n3 " << a << " " << d << " " << c << "\n";
      else
        f << "3 " << a << " " << b << " " << c << "\n3 " << b << " " << d << " " << c << "\n";
    }
  return path;
}

// Counts UV triangles that are clockwise (folded over) or degenerate.
int foldedUvTriangles(const TriangleMesh& m) {
  int n = 0;
  for (size_t t = 0; t < m.triangleCount(); ++t) {
    const Vec2f p = m.uvs[m.indices[3 * t]], q = m.uvs[m.indices[3 * t + 1]], r = m.uvs[m.indices[3 * t + 2]];
    n += !((double(q.x) - p.x) * (double(r.y) - p.y) - (double(q.y) - p.y) * (double(r.x) - p.x) > 0);
  }
  return n;
}

TEST(LoadMesh, GradedCylinderUnrollsIsometrically) {
  // A developable patch with triangle sizes varying 40-fold: 300 mm of arc on a 400 mm radius,
  // arc positions graded quadratically, 120 mm high. Whatever LSCM weights each triangle with,
  // the exact minimizer is the unrolling, so every triangle must keep its size.
  const int nu = 31, nv = 13;
  const double R = 400, arc = 300, H = 120;
  auto arcAt = [&](int i) { const double s = double(i) / (nu - 1); return arc * s * s; };
  const std::string path = writeGridOff("graded_cylinder.off", nu, nv, [&](int i, int j) {
    const double a = arcAt(i) / R;
    return Vec3d(R * std::sin(a), H * j / (nv - 1), R * std::cos(a) - R);
  });
  const TriangleMesh m = loadMesh(path);
  ASSERT_EQ(m.uvs.size(), m.positions.size());
  const double area = m.surfaceAreaMm2();
  EXPECT_NEAR(area, arc * H, 0.01 * arc * H);  // chords slightly shorter than the arc
  EXPECT_NEAR(uvArea(m), area, 1e-4 * area);
  EXPECT_EQ(foldedUvTriangles(m), 0);
  for (size_t t = 0; t < m.triangleCount(); ++t) ASSERT_NEAR(m.mmPerUv[t], 1.0f, 2e-3f) << t;
  // Distances in UV equal the (polyline) distances along the surface: corner to corner along the
  // arc, up the straight side, and across.
  auto find = [&](int i, int j) {
    const double a = arcAt(i) / R;
    const Vec3f q(float(R * std::sin(a)), float(H * j / (nv - 1)), float(R * std::cos(a) - R));
    for (size_t k = 0; k < m.positions.size(); ++k)
      if (length(m.positions[k] - q) < 1e-3f) return k;
    return size_t(-1);
  };
  double chordSum = 0;  // the unrolled bottom edge is the sum of the chords
  for (int i = 0; i + 1 < nu; ++i) chordSum += 2 * R * std::sin((arcAt(i + 1) - arcAt(i)) / (2 * R));
  const size_t c00 = find(0, 0), c10 = find(nu - 1, 0), c11 = find(nu - 1, nv - 1);
  ASSERT_NE(c00, size_t(-1));
  ASSERT_NE(c10, size_t(-1));
  ASSERT_NE(c11, size_t(-1));
  auto dist = [&](size_t i, size_t j) { return std::hypot(double(m.uvs[i].x) - m.uvs[j].x, double(m.uvs[i].y) - m.uvs[j].y); };
  EXPECT_NEAR(dist(c00, c10), chordSum, 0.05);
  EXPECT_NEAR(dist(c10, c11), H, 0.05);
  EXPECT_NEAR(dist(c00, c11), std::hypot(chordSum, H), 0.05);
}

TEST(LoadMesh, DoublyCurvedCapGetsFoldFreeChart) {
  // A hood-like cap (not developable): z = c (1 - 4 s^2)(1 - 4 t^2) over 600 x 400 mm, c = 60.
  // The chart cannot be isometric; LSCM keeps it conformal, so the stretch varies smoothly and
  // only a little for so flat a cap, and nothing folds over.
  const int nu = 49, nv = 33;
  const TriangleMesh m = loadMesh(writeGridOff("cap.off", nu, nv, [&](int i, int j) {
    const double s = double(i) / (nu - 1) - 0.5, t = double(j) / (nv - 1) - 0.5;
    return Vec3d(600 * s, 400 * t, 60 * (1 - 4 * s * s) * (1 - 4 * t * t));
  }));
  ASSERT_EQ(m.uvs.size(), m.positions.size());
  const double area = m.surfaceAreaMm2();
  EXPECT_GT(area, 600.0 * 400.0 * 1.01);
  EXPECT_NEAR(uvArea(m), area, 1e-4 * area);
  EXPECT_EQ(foldedUvTriangles(m), 0);
  EXPECT_NEAR(meanMmPerUv(m), 1.0, 0.005);
  const auto [lo, hi] = std::minmax_element(m.mmPerUv.begin(), m.mmPerUv.end());
  EXPECT_GT(*lo, 0.95f);
  EXPECT_LT(*hi, 1.05f);
  // Conformal: each triangle keeps its angles, so its three edges keep their length ratios (the
  // stretch within one triangle is uniform); check the worst edge against its triangle's stretch.
  double worst = 0;
  for (size_t t = 0; t < m.triangleCount(); ++t)
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = m.indices[3 * t + size_t(k)], b = m.indices[3 * t + size_t((k + 1) % 3)];
      const double e3 = length(d3(m.positions[b]) - d3(m.positions[a]));
      const double e2 = std::hypot(double(m.uvs[b].x) - m.uvs[a].x, double(m.uvs[b].y) - m.uvs[a].y);
      worst = std::max(worst, std::abs(e3 / (e2 * m.mmPerUv[t]) - 1));
    }
  EXPECT_LT(worst, 0.02);
}

TEST(LoadMesh, NotDiskLikeIsExplained) {
  std::string e = loadError(fixture("annulus.off"));
  EXPECT_NE(e.find("annulus.off"), std::string::npos) << e;
  EXPECT_NE(e.find("2 boundary loops"), std::string::npos) << e;
  e = loadError(fixture("two_pieces.off"));
  EXPECT_NE(e.find("2 connected components"), std::string::npos) << e;
  const std::string dir = ::testing::TempDir();
  std::ofstream(dir + "/fin.off") << "OFF\n5 3 0\n0 0 0\n1 0 0\n0.5 1 0\n0.5 -1 0\n0.5 0 1\n3 0 1 2\n3 1 0 3\n3 0 1 4\n";
  e = loadError(dir + "/fin.off");  // three triangles on one edge
  EXPECT_NE(e.find("not manifold"), std::string::npos) << e;
  std::ofstream(dir + "/bowtie.off") << "OFF\n5 2 0\n0 0 0\n1 0 0\n0 1 0\n-1 0 0\n0 -1 0\n3 0 1 2\n3 0 3 4\n";
  e = loadError(dir + "/bowtie.off");  // two triangles sharing one vertex only
  EXPECT_NE(e.find("not manifold"), std::string::npos) << e;
  EXPECT_NE(e.find("single vertex"), std::string::npos) << e;
  MeshLoadOptions o;
  o.compute_uvs_if_missing = false;
  const TriangleMesh m = loadMesh(fixture("annulus.off"), o);
  EXPECT_EQ(m.triangleCount(), 16u);
  EXPECT_NEAR(m.surfaceAreaMm2(), 800.0, 1e-6);
}

TEST(LoadMesh, GltfNodeTransformAndTexcoords) {
  const TriangleMesh m = loadMesh(fixture("quad_uv.gltf"));
  EXPECT_EQ(m.triangleCount(), 2u);
  // Node: scale 10, then translation (5, 0, 0), applied to the 2 x 1 quad.
  expectBounds(m, {5, 0, 0}, {25, 10, 0});
  ASSERT_EQ(m.uvs.size(), m.positions.size());
  // TEXCOORD_0 spans u 0..1, v 0.5..1 (glTF, origin top left); assimp flips v to the bottom-left
  // origin, and the chart scaled to mm is then uv = position - (5, 0).
  for (size_t i = 0; i < m.positions.size(); ++i) {
    EXPECT_NEAR(m.uvs[i].x, m.positions[i].x - 5, 1e-4) << i;
    EXPECT_NEAR(m.uvs[i].y, m.positions[i].y, 1e-4) << i;
    EXPECT_NEAR(m.normals[i].z, 1.0f, 1e-6f);  // computed: the file has no normals
  }
  for (float s : m.mmPerUv) EXPECT_NEAR(s, 1.0f, 1e-5f);
}

TEST(LoadMesh, GlbMirroringNodeKeepsOutsideFacing) {
  // The quad under a node with scale (-10, 10, 10); no UVs (computed) and no normals (computed).
  const TriangleMesh m = loadMesh(fixture("mirrored_quad.glb"));
  EXPECT_EQ(m.triangleCount(), 2u);
  expectBounds(m, {-20, 0, 0}, {0, 10, 0});
  // glTF: a negative-determinant node makes the front faces clockwise; the loader swaps the
  // winding, so the triangles still face +z like the unmirrored quad.
  for (size_t t = 0; t < m.triangleCount(); ++t) {
    const Vec3d g = cross(d3(m.positions[m.indices[3 * t + 1]]) - d3(m.positions[m.indices[3 * t]]),
                          d3(m.positions[m.indices[3 * t + 2]]) - d3(m.positions[m.indices[3 * t]]));
    EXPECT_GT(g.z, 0) << t;
  }
  for (const Vec3f& n : m.normals) EXPECT_NEAR(n.z, 1.0f, 1e-6f);
  EXPECT_NEAR(uvArea(m), 200.0, 1e-3);
  for (float s : m.mmPerUv) EXPECT_NEAR(s, 1.0f, 1e-4f);
}

TEST(LoadMesh, BadFilesThrowInputErrorsNamingTheFile) {
  std::string e = loadError(fixture("nan.obj"));
  EXPECT_NE(e.find("nan.obj:4"), std::string::npos) << e;  // file:line
  EXPECT_NE(e.find("non-finite"), std::string::npos) << e;
  EXPECT_NE(e.find("vertex 3 "), std::string::npos) << e;  // OBJ numbering, from 1
  try {
    loadMesh(fixture("nan.obj"));
  } catch (const InputError& err) {
    EXPECT_EQ(err.line(), 4);
  }

  e = loadError(fixture("nan_binary.stl"));
  EXPECT_NE(e.find("nan_binary.stl"), std::string::npos) << e;
  EXPECT_NE(e.find("non-finite"), std::string::npos) << e;
  EXPECT_NE(e.find("facet 0, corner 1"), std::string::npos) << e;

  e = loadError(fixture("degenerate_only.obj"));
  EXPECT_NE(e.find("degenerate_only.obj"), std::string::npos) << e;
  EXPECT_NE(e.find("degenerate (zero-area)"), std::string::npos) << e;
  EXPECT_NE(e.find("all 2 triangles"), std::string::npos) << e;

  e = loadError(fixture("does_not_exist.obj"));
  EXPECT_NE(e.find("does_not_exist.obj"), std::string::npos) << e;
  EXPECT_NE(e.find("cannot open"), std::string::npos) << e;

  e = loadError(fixture("part.fbx"));
  EXPECT_NE(e.find("part.fbx"), std::string::npos) << e;
  EXPECT_NE(e.find("unsupported"), std::string::npos) << e;
  EXPECT_NE(e.find(".obj .ply .stl .off .gltf .glb"), std::string::npos) << e;
}

// A face or list whose length the rest of the file cannot hold: CGAL's readers allocated (and
// zero-filled) that many entries before reading them, 12 to 17 GB for one bad number in a small
// file (scripts/fuzz-meshes seed 104). They are refused before CGAL reads the file.
TEST(LoadMesh, ListsLongerThanTheFileAreRefusedBeforeCgalReadsThem) {
  const std::string dir = ::testing::TempDir();
  auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream(dir + "/" + name, std::ios::binary) << text;
    return dir + "/" + name;
  };
  std::string e = loadError(write("long_face.off", "OFF\r\n3 1 0\r\n0 0 0\r\n1 0 0\r\n# the face\r\n0 1 0\r\n"
                                                   "1500000000 0 1 2\r\n"));
  EXPECT_NE(e.find("long_face.off:7:1: face 0 (counting from 0): a corner count of 1500000000, more than the 8 bytes "
                   "left in the file can hold"), std::string::npos) << e;
  const std::string vertices = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
  e = loadError(write("long_list.ply", "ply\nformat ascii 1.0\n" + vertices +
                                         "element face 1\nproperty list uint int vertex_indices\nend_header\n"
                                         "0 0 0\n1 0 0\n0 1 0\n4294967295 0 1 2\n"));
  EXPECT_NE(e.find("long_list.ply:13:1: face 0 (counting from 0): 'vertex_indices' of length 4294967295, more than the "
                   "7 bytes left in the file can hold"), std::string::npos) << e;
  // Binary, little and big endian: the list's length read with its own type.
  auto binary = [&](bool big, int32_t length) {
    std::string header = std::string("ply\nformat binary_") + (big ? "big" : "little") + "_endian 1.0\n" + vertices +
                         "element face 1\nproperty list int int vertex_indices\nend_header\n";
    auto put = [&](uint32_t v) {
      for (int k = 0; k < 4; ++k) header += char(big ? v >> (24 - 8 * k) : v >> (8 * k));
    };
    const float xyz[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    for (float x : xyz) {
      uint32_t u;
      std::memcpy(&u, &x, 4);
      put(u);
    }
    put(uint32_t(length));
    for (uint32_t i : {0u, 1u, 2u}) put(i);
    return header;
  };
  const std::string little = binary(false, 2147483647);
  const size_t at = little.size() - 16;  // the length's offset
  e = loadError(write("long_list_le.ply", little));
  EXPECT_NE(e.find("long_list_le.ply: face 0 (counting from 0), at byte " + std::to_string(at) +
                   ": 'vertex_indices' of length 2147483647, more than the 12 bytes left in the file can hold"),
            std::string::npos) << e;
  const std::string negative = binary(true, -5);
  e = loadError(write("negative_list_be.ply", negative));
  EXPECT_NE(e.find("negative_list_be.ply: face 0 (counting from 0), at byte " + std::to_string(negative.size() - 16) +
                   ": 'vertex_indices' has a negative length, -5"), std::string::npos) << e;
  // The same files with the right length load (the guard reads both byte orders as CGAL does).
  for (bool big : {false, true}) {
    const std::string path = write(big ? "good_be.ply" : "good_le.ply", binary(big, 3));
    const TriangleMesh m = loadMesh(path, {});
    EXPECT_EQ(m.indices.size(), 3u) << path;
    EXPECT_EQ(m.positions.size(), 3u) << path;
  }
}

TEST(LoadMesh, MalformedFilesThrowInputErrors) {
  const std::string dir = ::testing::TempDir();
  auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream(dir + "/" + name, std::ios::binary) << text;
    return dir + "/" + name;
  };
  std::string e = loadError(write("bad_face.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n"));
  EXPECT_NE(e.find("bad_face.off:6:7: face 0 (counting from 0): expected a vertex index from 0 to 2, found '9'"),
            std::string::npos) << e;
  e = loadError(write("truncated.off", "OFF\n3 1 0\n0 0 0\n1 0\n"));
  EXPECT_NE(e.find("truncated"), std::string::npos) << e;
  e = loadError(write("short_vertex.off", "OFF\n3 1 0\n0 0 0\n1 0\n0 1 0\n3 0 1 2\n"));
  EXPECT_NE(e.find("short_vertex.off:4:4: vertex 1 (counting from 0): expected 3 numbers, found 2"), std::string::npos) << e;
  // A negative corner count made CGAL's reader throw std::length_error, whose text was the message.
  e = loadError(write("negative_corners.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n-3 0 1 2\n"));
  EXPECT_NE(e.find("negative_corners.off:6:1: face 0 (counting from 0): expected its number of corners (an integer >= 3), "
                   "found '-3'"), std::string::npos) << e;
  e = loadError(write("few_faces.off", "# a comment\nOFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"));
  EXPECT_NE(e.find("few_faces.off:7:8: the file ends after 1 of the 2 faces the header declares"), std::string::npos) << e;
  e = loadError(write("no_header.off", "3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"));
  EXPECT_NE(e.find("no_header.off:1:1: expected the header keyword OFF"), std::string::npos) << e;
  e = loadError(write("bad_keyword.stl", "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
                                         "vertex 0 1 0\nendloop\nendfacet\nfacet normal 0 0 1\nouter lop\n"));
  EXPECT_NE(e.find("bad_keyword.stl:10:7: expected 'loop' in facet 1 (counting from 0), found 'lop'"), std::string::npos) << e;
  e = loadError(write("short.stl", std::string(80, ' ') + std::string("\x02\0\0\0", 4) + std::string(60, '\0')));
  EXPECT_NE(e.find("short.stl: a binary STL declaring 2 facets is 184 bytes long, the file has 144"), std::string::npos) << e;
  e = loadError(write("huge.off", "OFF\n2000000000 1 0\n0 0 0\n"));
  EXPECT_NE(e.find("huge.off:2:1: the header declares 2000000000 vertices and 1 faces, more than a 25-byte file can hold"),
            std::string::npos) << e;
  e = loadError(write("negative_count.off", "OFF\n3 -1 0\n0 0 0\n1 0 0\n0 1 0\n"));
  EXPECT_NE(e.find("negative_count.off:2:3: expected the face count (an integer >= 0), found '-1'"), std::string::npos) << e;
  e = loadError(write("inf.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 inf 0\n3 0 1 2\n"));
  EXPECT_NE(e.find("inf.off:5:3"), std::string::npos) << e;  // line 5, column 3
  EXPECT_NE(e.find("non-finite"), std::string::npos) << e;
  e = loadError(write("garbage.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\nx y z\n"));
  EXPECT_NE(e.find("garbage.ply:6:1: vertex 0 (counting from 0): 'x': expected a number that a float holds, found 'x'"),
            std::string::npos) << e;
  e = loadError(write("big.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                 "property float z\nend_header\n0 0 0\n1 0 1e308\n0 1 0\n"));
  EXPECT_NE(e.find("big.ply:9:5: vertex 1 (counting from 0): 'z': expected a number that a float holds, found '1e308'"),
            std::string::npos) << e;
  e = loadError(write("no_edges.off", "OFF\n3 1\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"));
  EXPECT_NE(e.find("no_edges.off:2:4: expected the edge count after the vertex and face counts (0 will do)"),
            std::string::npos) << e;
  const std::string ply_header = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                 "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  e = loadError(write("bad_index.ply", ply_header + "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n"));
  EXPECT_NE(e.find("bad_index.ply:13:7: face 0 (counting from 0): expected a vertex index from 0 to 2, found '3'"),
            std::string::npos) << e;
  // An integer property's range comes from its type's size and sign: -32768 fits a short, 32768 not.
  e = loadError(write("short_range.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                         "property float z\nproperty short s\nelement face 1\n"
                                         "property list uchar int vertex_indices\nend_header\n"
                                         "0 0 0 1\n1 0 0 -32768\n0 1 0 32768\n3 0 1 2\n"));
  EXPECT_NE(e.find("short_range.ply:13:7: vertex 2 (counting from 0): 's': expected an integer that a short holds, "
                   "found '32768'"), std::string::npos) << e;
  e = loadError(write("bad_type.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty flaot x\nend_header\n0\n1\n2\n"));
  EXPECT_NE(e.find("bad_type.ply:4:10: expected a PLY type"), std::string::npos) << e;
  // A header whose 'element vertex' line is lost: CGAL's reader crashed on the property after it.
  e = loadError(write("no_element.ply", "ply\r\nformat ascii 1.0\r\ncomment a tetrahedron\r\nproperty float x\r\n"
                                        "property float y\r\nproperty float z\r\nelement face 1\r\n"
                                        "property list uchar int vertex_indices\r\nend_header\r\n0 0 0\r\n"));
  EXPECT_NE(e.find("no_element.ply:4:1: a property before any 'element'"), std::string::npos) << e;
  e = loadError(write("short.ply", ply_header + "0 0 0\n1 0 0\n"));
  EXPECT_NE(e.find("short.ply:11:6: the file ends after 2 of the 3 'vertex' lines the header declares"), std::string::npos) << e;
  e = loadError(write("bad_index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n"));
  EXPECT_NE(e.find("bad_index.obj:4"), std::string::npos) << e;
  EXPECT_NE(e.find("out of range"), std::string::npos) << e;
  e = loadError(write("bad_number.obj", "v 0 0 0\nv 1 zero 0\n"));
  EXPECT_NE(e.find("bad_number.obj:2:5"), std::string::npos) << e;
  EXPECT_NE(e.find("expected a number"), std::string::npos) << e;
  e = loadError(write("mixed_uv.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nf 1/1 2/1 3/1\nf 2 4 3\n"));
  EXPECT_NE(e.find("mixed_uv.obj:7"), std::string::npos) << e;
  // Binary PLY: CGAL reads the infinity; the loader names the vertex.
  const std::string header = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
                             "property float y\nproperty float z\nelement face 1\n"
                             "property list uchar int vertex_indices\nend_header\n";
  const float xyz[9] = {0, 0, 0, 1, 0, 0, 0, INFINITY, 0};
  const unsigned char count = 3;
  const int32_t face[3] = {0, 1, 2};
  std::string body(reinterpret_cast<const char*>(xyz), sizeof xyz);
  body += std::string(reinterpret_cast<const char*>(&count), 1) + std::string(reinterpret_cast<const char*>(face), sizeof face);
  e = loadError(write("inf_binary.ply", header + body));
  EXPECT_NE(e.find("vertex 2 (counting from 0) has a non-finite coordinate"), std::string::npos) << e;
  e = loadError(write("empty.stl", ""));
  EXPECT_NE(e.find("empty.stl: the file is empty"), std::string::npos) << e;
  e = loadError(write("not_gltf.gltf", "{\n  this is not json"));
  EXPECT_NE(e.find("not_gltf.gltf:2:4: invalid JSON: syntax error while parsing object key"), std::string::npos) << e;
  // A number JSON cannot hold: the JSON library throws out_of_range, not parse_error (it was an
  // internal error, exit 1).
  e = loadError(write("overflow.gltf", "{\"asset\": {\"version\": \"2.0\"},\n \"scene\": 1e999}"));
  EXPECT_NE(e.find("overflow.gltf:2:11: invalid JSON: number overflow parsing '1e999'"), std::string::npos) << e;
  e = loadError(write("version.gltf", "{\"asset\": {\"version\": \"\"}}"));
  EXPECT_NE(e.find("version.gltf: expected \"asset\": {\"version\": \"2.0\"}, found version \"\""), std::string::npos) << e;
  e = loadError(write("no_accessors.gltf", "{\"asset\": {\"version\": \"2.0\"}, \"meshes\": [{\"primitives\": "
                                             "[{\"attributes\": {\"POSITION\": 0}}]}]}"));
  EXPECT_NE(e.find("no_accessors.gltf: cannot parse the glTF file: "), std::string::npos) << e;
  // Binary glTF: assimp says only "no suitable reader" for a broken header.
  const std::string glb = readFile(fixture("mirrored_quad.glb"));
  ASSERT_GT(glb.size(), 100u);
  e = loadError(write("cut.glb", glb.substr(0, 100)));
  EXPECT_NE(e.find("cut.glb: the header declares " + std::to_string(glb.size()) + " bytes, the file has 100 (truncated?)"),
            std::string::npos) << e;
  e = loadError(write("magic.glb", "gLTF" + glb.substr(4)));
  EXPECT_NE(e.find("magic.glb: not a binary glTF: the file does not start with 'glTF'"), std::string::npos) << e;
  std::string bad_bin = glb;
  const size_t json_length = size_t(uint8_t(glb[12])) | size_t(uint8_t(glb[13])) << 8;
  bad_bin[20 + json_length + 4] = 'b';  // the chunk type after the JSON: 'bIN'
  e = loadError(write("bad_bin.glb", bad_bin));
  EXPECT_NE(e.find("bad_bin.glb: the chunk after the JSON is not the binary chunk ('BIN')"), std::string::npos) << e;
  std::string bad_json = glb;
  bad_json[21] = 'x';  // the JSON chunk's second character: {x...
  e = loadError(write("bad_json.glb", bad_json));
  EXPECT_NE(e.find("bad_json.glb: the JSON chunk, byte 1: invalid JSON"), std::string::npos) << e;
  // Degenerate triangles are dropped, the rest kept.
  const TriangleMesh m = loadMesh(write("some_degenerate.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\n"));
  EXPECT_EQ(m.triangleCount(), 1u);
  EXPECT_EQ(m.positions.size(), 3u);  // the unused vertex is gone
}

}  // namespace
}  // namespace dg
