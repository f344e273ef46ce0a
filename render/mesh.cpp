// TriangleMesh measurements: bounding box, surface area and the per-triangle chart scale.
#include "render/mesh.h"

#include "core/parallel.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <unordered_map>

namespace dg {

namespace {

Vec3d toD(Vec3f v) { return Vec3d(v); }

// Twice the area of the 3-D triangle (length of the edge cross product), in double.
double twiceArea3(const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  return length(cross(toD(b) - toD(a), toD(c) - toD(a)));
}

// Directed edges of a mesh keyed by their undirected vertex pair, with how many triangles use each
// and the direction the (last) one runs.
struct EdgeUse {
  uint32_t from, to;
  int count;
};
std::unordered_map<uint64_t, EdgeUse> edgeUses(const TriangleMesh& m) {
  std::unordered_map<uint64_t, EdgeUse> edges;
  edges.reserve(m.indices.size());
  for (size_t t = 0; t + 2 < m.indices.size(); t += 3)
    for (int k = 0; k < 3; ++k) {
      uint32_t a = m.indices[t + size_t(k)], b = m.indices[t + size_t((k + 1) % 3)];
      uint64_t key = (uint64_t(std::min(a, b)) << 32) | std::max(a, b);
      auto [it, fresh] = edges.try_emplace(key, EdgeUse{a, b, 0});
      it->second.from = a;
      it->second.to = b;
      ++it->second.count;
    }
  return edges;
}

}  // namespace

size_t boundaryEdgeCount(const TriangleMesh& m) {
  size_t n = 0;
  for (const auto& [key, e] : edgeUses(m)) n += e.count == 1;
  return n;
}

TriangleMesh solidShell(const TriangleMesh& front, float thickness_mm) {
  if (!(thickness_mm > 0)) throw std::invalid_argument("a solid needs a thickness > 0");
  std::vector<std::pair<uint32_t, uint32_t>> outline;
  for (const auto& [key, e] : edgeUses(front)) {
    if (e.count > 2) throw std::invalid_argument("the mesh has an edge shared by more than two triangles");
    if (e.count == 1) outline.push_back({e.from, e.to});
  }
  TriangleMesh shell;
  shell.source = front.source + " (solid's back and rim)";
  if (outline.empty()) return shell;
  // Keep the order independent of the hash map's.
  std::sort(outline.begin(), outline.end());
  const size_t nv = front.positions.size();
  // Vertex normals: the mesh's own, else area-weighted face normals.
  std::vector<Vec3f> vn = front.normals;
  if (vn.size() != nv) {
    std::vector<Vec3d> acc(nv, Vec3d(0.0));
    for (size_t t = 0; t + 2 < front.indices.size(); t += 3) {
      const uint32_t* f = &front.indices[t];
      Vec3d n = cross(toD(front.positions[f[1]]) - toD(front.positions[f[0]]),
                      toD(front.positions[f[2]]) - toD(front.positions[f[0]]));
      for (int k = 0; k < 3; ++k) acc[f[k]] += n;
    }
    vn.resize(nv);
    for (size_t i = 0; i < nv; ++i) vn[i] = unitOrUp(acc[i]);
  }
  const bool has_h = front.heights.size() == nv;
  // The back: vertex i + 0 .. nv, facing the other way (reversed winding, negated normals).
  shell.positions.resize(nv);
  shell.normals.resize(nv);
  for (size_t i = 0; i < nv; ++i) {
    float h = has_h ? front.heights[i] : 0.0f;
    shell.positions[i] = front.positions[i] - vn[i] * (h + thickness_mm);
    shell.normals[i] = -vn[i];
  }
  for (size_t t = 0; t + 2 < front.indices.size(); t += 3) {
    shell.indices.push_back(front.indices[t]);
    shell.indices.push_back(front.indices[t + 2]);
    shell.indices.push_back(front.indices[t + 1]);
  }
  // The rim: a quad per outline edge a -> b (as its front triangle runs it), run b -> a so that
  // it matches the front's winding, with its own flat-shaded vertices.
  for (const auto& [a, b] : outline) {
    Vec3f fa = front.positions[a], fb = front.positions[b];
    Vec3f ba = shell.positions[a], bb = shell.positions[b];
    Vec3f nf = unitOrUp(cross(toD(fa) - toD(fb), toD(ba) - toD(fb)));
    uint32_t base = uint32_t(shell.positions.size());
    for (Vec3f p : {fb, fa, ba, bb}) {
      shell.positions.push_back(p);
      shell.normals.push_back(nf);
    }
    for (uint32_t k : {0u, 1u, 2u, 0u, 2u, 3u}) shell.indices.push_back(base + k);
  }
  return shell;
}

void TriangleMesh::bounds(Vec3f& lo, Vec3f& hi) const {
  // An empty mesh gives an empty box (lo > hi), so a caller cannot mistake it for a point at 0.
  const float big = std::numeric_limits<float>::max();
  lo = Vec3f(big);
  hi = Vec3f(-big);
  for (const Vec3f& p : positions) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
}

double TriangleMesh::surfaceAreaMm2() const {
  double sum = 0;
  for (size_t t = 0; t + 2 < indices.size(); t += 3)
    sum += 0.5 * twiceArea3(positions[indices[t]], positions[indices[t + 1]], positions[indices[t + 2]]);
  return sum;
}

void TriangleMesh::computeMmPerUv() {
  const size_t n = triangleCount();
  mmPerUv.clear();
  resizeInParallel(mmPerUv, n);  // zeros
  if (uvs.size() != positions.size()) return;  // no chart: the scale is unknown (0 everywhere)
  // Each triangle on its own, in slices on all threads (a cut mesh has tens of millions).
  parallelForSlices(n, 65536, [&](size_t, size_t begin, size_t end) {
    for (size_t t = begin; t < end; ++t) {
      const uint32_t i0 = indices[3 * t], i1 = indices[3 * t + 1], i2 = indices[3 * t + 2];
      const double a3 = twiceArea3(positions[i0], positions[i1], positions[i2]);
      const Vec2d e1{double(uvs[i1].x) - uvs[i0].x, double(uvs[i1].y) - uvs[i0].y};
      const Vec2d e2{double(uvs[i2].x) - uvs[i0].x, double(uvs[i2].y) - uvs[i0].y};
      const double auv = std::abs(e1.x * e2.y - e1.y * e2.x);
      // Degenerate UV triangle: its area is negligible against its squared edge lengths (a sliver
      // or a collapsed triangle), so the ratio would only amplify rounding noise.
      const double longest2 = std::max({e1.x * e1.x + e1.y * e1.y, e2.x * e2.x + e2.y * e2.y,
                                        (e2.x - e1.x) * (e2.x - e1.x) + (e2.y - e1.y) * (e2.y - e1.y)});
      if (!(auv > 1e-9 * longest2) || !std::isfinite(a3)) continue;
      mmPerUv[t] = float(std::sqrt(a3 / auv));
    }
  });
}

}  // namespace dg
