#include "render/scratch_geometry.h"

#include <algorithm>
#include <cmath>
#include <tuple>
#include <stdexcept>
#include <unordered_map>

#include "core/parallel.h"

namespace dg {

float scratchHeight(const std::vector<const Scratch*>& scratches, Vec2f p) {
  float lowest = 0, highest = 0;
  for (const Scratch* s : scratches) {
    if (!s->support().contains(p)) continue;
    float h = s->height(p);
    lowest = std::min(lowest, h);
    highest = std::max(highest, h);
  }
  return lowest < 0 ? lowest : highest;
}

namespace {

struct Affine {
  Vec3d o, u, v, n;  // p = o + u * uv.x + v * uv.y; n the winding normal
  Vec2f lo, hi;      // the chart's rectangle
};

// The affine map from the chart to the part, or an error when the part is not flat and affine.
Affine planarChart(const TriangleMesh& m) {
  if (m.uvs.size() != m.positions.size() || m.triangleCount() == 0)
    throw std::runtime_error("the part has no UV chart");
  Affine a;
  bool found = false;
  double area_uv = 0;
  Vec2f lo(1e30f, 1e30f), hi(-1e30f, -1e30f);
  for (Vec2f t : m.uvs) {
    lo = {std::min(lo.x, t.x), std::min(lo.y, t.y)};
    hi = {std::max(hi.x, t.x), std::max(hi.y, t.y)};
  }
  for (size_t f = 0; f < m.triangleCount(); ++f) {
    const uint32_t* id = &m.indices[3 * f];
    Vec3d p0(m.positions[id[0]]), p1(m.positions[id[1]]), p2(m.positions[id[2]]);
    Vec2d t0(m.uvs[id[0]].x, m.uvs[id[0]].y), t1(m.uvs[id[1]].x, m.uvs[id[1]].y), t2(m.uvs[id[2]].x, m.uvs[id[2]].y);
    Vec2d e1 = t1 - t0, e2 = t2 - t0;
    double det = e1.x * e2.y - e1.y * e2.x;
    area_uv += 0.5 * std::fabs(det);
    if (found || std::fabs(det) < 1e-9) continue;
    Vec3d q1 = p1 - p0, q2 = p2 - p0;
    // [u v] [e1 e2] = [q1 q2]
    a.u = (q1 * e2.y - q2 * e1.y) / det;
    a.v = (q2 * e1.x - q1 * e2.x) / det;
    a.o = p0 - a.u * t0.x - a.v * t0.y;
    Vec3d n = cross(q1, q2);
    if (!(length(n) > 0)) continue;
    a.n = n / length(n);
    found = true;
  }
  if (!found) throw std::runtime_error("the part's UV chart is degenerate");
  double size = std::max(1e-3, length(a.u) * (hi.x - lo.x) + length(a.v) * (hi.y - lo.y));
  for (size_t i = 0; i < m.positions.size(); ++i) {
    Vec3d p(m.positions[i]);
    Vec3d q = a.o + a.u * double(m.uvs[i].x) + a.v * double(m.uvs[i].y);
    if (length(p - q) > 1e-5 * size)
      throw std::runtime_error("explicit scratch geometry needs a flat part whose UVs are an affine image of "
                               "its positions (such as part: plate); this part is not (vertex " +
                               std::to_string(i) + " is " + std::to_string(length(p - q)) + " mm off the plane)");
  }
  double box = double(hi.x - lo.x) * double(hi.y - lo.y);
  if (std::fabs(area_uv - box) > 1e-3 * box)
    throw std::runtime_error("explicit scratch geometry needs a UV chart that fills its rectangle (a part with "
                             "holes or a non-rectangular outline is not supported)");
  a.lo = lo;
  a.hi = hi;
  return a;
}

}  // namespace

TriangleMesh scratchedPlanarMesh(const TriangleMesh& part, const std::vector<const Scratch*>& scratches,
                                 const ScratchGeometryOptions& opt, ScratchGeometryStats* stats) {
  const Affine a = planarChart(part);
  const Vec2f lo = a.lo, hi = a.hi;
  double cell = opt.cell_mm;
  if (!(cell > 0)) {
    double narrowest = 1e30;
    for (const Scratch* s : scratches) {
      double w = s->referenceProfile().width() * s->maxScale();
      if (w > 0) narrowest = std::min(narrowest, w);
    }
    cell = narrowest < 1e30 ? std::max(5e-4, narrowest / 32.0) : 1.0;
  }
  const double W = double(hi.x) - lo.x, H = double(hi.y) - lo.y;
  int base_depth = 0;
  while (std::max(W, H) / double(1 << base_depth) > cell && base_depth < 26) ++base_depth;
  const int depth = base_depth;  // + kKinkLevels
  const double du = W / double(1 << depth), dv = H / double(1 << depth);

  // Quadtree over the chart's rectangle. A cell is split while it is coarser than the finest level
  // and some scratch's cross-section may reach into it.
  // Cells at the finest level that hold a kink of a cross-section (a profile vertex line) may be
  // split kKinkLevels levels further (0 = off: the exact facet normals below already remove the
  // kink's glint; splitting only sharpens where the kink lies).
  constexpr int kKinkLevels = 0;
  auto reaches = [&](double u0, double v0, double u1, double v1, bool kinks_only) {
    Box2 cb;
    cb.lo = {float(u0), float(v0)};
    cb.hi = {float(u1), float(v1)};
    Vec2f c(float(0.5 * (u0 + u1)), float(0.5 * (v0 + v1)));
    float half_diag = float(0.5 * std::hypot(u1 - u0, v1 - v0));
    for (const Scratch* s : scratches) {
      if (!s->support().overlaps(cb)) continue;
      float reach = float(s->referenceProfile().halfExtent()) * s->maxScale() + half_diag;
      PathPoint pp = s->path().closest(c, reach);
      if (!pp.found) continue;
      if (!kinks_only) return true;
      float k = s->scaleAt(pp.s);
      if (pp.beyond > 0 || !(k > 0)) return true;  // ends: refine fully
      for (const Vec2d& q : s->referenceProfile().pts)
        if (std::fabs(pp.offset - k * float(q.x)) <= half_diag) return true;
    }
    return false;
  };
  struct Leaf {
    uint32_t i0, j0, size;  // in finest-cell units
  };
  std::vector<Leaf> leaves;
  const uint32_t full = 1u << depth;
  std::vector<Leaf> stack{{0, 0, full}};
  while (!stack.empty()) {
    Leaf c = stack.back();
    stack.pop_back();
    if (c.size > 1 && reaches(lo.x + c.i0 * du, lo.y + c.j0 * dv, lo.x + (c.i0 + c.size) * du,
                              lo.y + (c.j0 + c.size) * dv, c.size <= (1u << kKinkLevels))) {
      uint32_t h = c.size / 2;
      stack.push_back({c.i0, c.j0, h});
      stack.push_back({c.i0 + h, c.j0, h});
      stack.push_back({c.i0, c.j0 + h, h});
      stack.push_back({c.i0 + h, c.j0 + h, h});
      if (stack.size() + leaves.size() > opt.max_triangles / 2)
        throw std::runtime_error("the scratch geometry would exceed " + std::to_string(opt.max_triangles) +
                                 " triangles (cell " + std::to_string(cell) + " mm)");
    } else {
      leaves.push_back(c);
    }
  }
  // Deterministic order: by row, then column, then size.
  std::sort(leaves.begin(), leaves.end(), [](const Leaf& x, const Leaf& y) {
    return std::tie(x.j0, x.i0, x.size) < std::tie(y.j0, y.i0, y.size);
  });

  TriangleMesh m;
  m.source = part.source + "+scratches";
  std::unordered_map<uint64_t, uint32_t> vid;
  vid.reserve(leaves.size() * 2);
  std::vector<std::pair<uint32_t, uint32_t>> grid;  // (i, j) per vertex
  auto vertex = [&](uint32_t i, uint32_t j) {
    uint64_t key = (uint64_t(i) << 32) | j;
    auto it = vid.find(key);
    if (it != vid.end()) return it->second;
    uint32_t id = uint32_t(grid.size());
    grid.push_back({i, j});
    vid.emplace(key, id);
    return id;
  };
  // Counter-clockwise seen from the winding normal: flip when the chart is mirrored.
  bool flip = dot(cross(a.u, a.v), a.n) < 0;
  m.indices.reserve(leaves.size() * 6);
  for (const Leaf& c : leaves) {
    uint32_t v00 = vertex(c.i0, c.j0), v10 = vertex(c.i0 + c.size, c.j0), v01 = vertex(c.i0, c.j0 + c.size),
             v11 = vertex(c.i0 + c.size, c.j0 + c.size);
    uint32_t t[6] = {v00, v10, v11, v00, v11, v01};
    if (flip) {
      std::swap(t[1], t[2]);
      std::swap(t[4], t[5]);
    }
    m.indices.insert(m.indices.end(), t, t + 6);
  }
  m.positions.resize(grid.size());
  m.uvs.resize(grid.size());
  parallelFor((grid.size() + 4095) / 4096, [&](size_t blk) {
    size_t e = std::min(grid.size(), (blk + 1) * 4096);
    for (size_t k = blk * 4096; k < e; ++k) {
      double u = grid[k].first == full ? hi.x : lo.x + grid[k].first * du;
      double v = grid[k].second == full ? hi.y : lo.y + grid[k].second * dv;
      Vec2f uv{float(u), float(v)};
      double h = scratchHeight(scratches, uv);
      m.uvs[k] = uv;
      m.positions[k] = Vec3f(a.o + a.u * u + a.v * v + a.n * h);
    }
  });
  // Shading normals: every triangle gets the exact normal of the cross-section facet under its
  // centroid (from the height field's slope there), as three vertices of its own. A flat-shaded
  // triangle straddling a kink would have a normal between the two facets' that the faceted
  // model does not have: at a peak's apex, a glint line whose strength depends on the cell size
  // (measured: 6.5% of pixels >= 10 against the groove renderer under the bar light at cell = width
  // / 48, 1.8% with kinks refined 8x finer). The silhouette and occlusion stay the mesh's.
  const Vec3d dpdu_flat = a.u, dpdv_flat = a.v;
  // A tenth of a cell: small enough to stay on one facet mostly, large against float rounding of
  // the UV coordinates (about 1e-6 mm at 10 mm).
  const double eps = std::min(du, dv) * 0.1;
  TriangleMesh out;
  out.source = m.source;
  const size_t nt = m.triangleCount();
  out.positions.resize(3 * nt);
  out.uvs.resize(3 * nt);
  out.normals.resize(3 * nt);
  out.indices.resize(3 * nt);
  parallelFor((nt + 4095) / 4096, [&](size_t blk) {
    size_t e = std::min(nt, (blk + 1) * 4096);
    for (size_t t = blk * 4096; t < e; ++t) {
      const uint32_t* id = &m.indices[3 * t];
      Vec2f c = (m.uvs[id[0]] + m.uvs[id[1]] + m.uvs[id[2]]) / 3.0f;
      double h0 = scratchHeight(scratches, c);
      double gu = (scratchHeight(scratches, c + Vec2f(float(eps), 0.0f)) - h0) / eps;
      double gv = (scratchHeight(scratches, c + Vec2f(0.0f, float(eps))) - h0) / eps;
      Vec3d n = cross(dpdu_flat + a.n * gu, dpdv_flat + a.n * gv);
      n = n / length(n);
      if (dot(n, a.n) < 0) n = -n;
      Vec3f nf(n);
      for (int k = 0; k < 3; ++k) {
        out.positions[3 * t + k] = m.positions[id[k]];
        out.uvs[3 * t + k] = m.uvs[id[k]];
        out.normals[3 * t + k] = nf;
        out.indices[3 * t + k] = uint32_t(3 * t + k);
      }
    }
  });
  m = std::move(out);
  m.computeMmPerUv();
  if (stats) {
    stats->triangles = m.triangleCount();
    stats->cell_mm = std::max(du, dv);
  }
  return m;
}

}  // namespace dg
