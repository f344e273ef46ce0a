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
    cell = narrowest < 1e30 ? std::max(5e-4, narrowest / 16.0) : 1.0;
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

  // Every leaf becomes a triangle fan; a finest cell that a kink of the height field crosses is
  // first cut along it, so that every triangle lies on one facet and the mesh is exactly the
  // faceted surface (up to the chord of a curved kink inside a cell). Kinks are the zero sets of:
  //  - offset - k(s) b_i for each cross-section vertex b_i of a scratch reaching the cell (k the
  //    scale at the closest point's arc position s), and
  //  - h_a - h_b for each pair of scratches reaching it (where overlapping grooves or pile-ups
  //    trade places in the composite height).
  // Without the cuts a triangle straddling a kink lies between the two facets: at a peak's apex
  // under a grazing light the apex is cut low and the shadow behind it comes out short (measured:
  // 4% too much light in a lit wall's pixels at cell = width / 32 under a 12 degree bar light,
  // converging only as the cell shrinks).
  auto cornerUv = [&](uint32_t i, uint32_t j) {
    double u = i == full ? hi.x : lo.x + i * du;
    double v = j == full ? hi.y : lo.y + j * dv;
    return Vec2f(float(u), float(v));
  };
  // Counter-clockwise seen from the winding normal: flip when the chart is mirrored.
  const bool flip = dot(cross(a.u, a.v), a.n) < 0;
  struct Soup {
    std::vector<Vec3f> positions, normals;
    std::vector<Vec2f> uvs;
  };
  const size_t block = 1024;
  const size_t nblocks = (leaves.size() + block - 1) / block;
  std::vector<Soup> soups(nblocks);
  parallelFor(nblocks, [&](size_t blk) {
    Soup& out = soups[blk];
    struct Vtx {
      Vec2f uv;
      std::vector<double> f;  // kink function values
    };
    std::vector<const Scratch*> near;
    std::vector<std::vector<Vtx>> polys, next;
    for (size_t li = blk * block; li < std::min(leaves.size(), (blk + 1) * block); ++li) {
      const Leaf& c = leaves[li];
      Vec2f q00 = cornerUv(c.i0, c.j0), q10 = cornerUv(c.i0 + c.size, c.j0), q11 = cornerUv(c.i0 + c.size, c.j0 + c.size),
            q01 = cornerUv(c.i0, c.j0 + c.size);
      near.clear();
      if (c.size == 1) {
        Box2 cb{q00, q11};
        Vec2f centre = (q00 + q11) * 0.5f;
        float half_diag = 0.5f * std::hypot(q11.x - q00.x, q11.y - q00.y);
        for (const Scratch* sc : scratches) {
          if (!sc->support().overlaps(cb)) continue;
          float reach = float(sc->referenceProfile().halfExtent()) * sc->maxScale() + half_diag;
          if (sc->path().closest(centre, reach).found) near.push_back(sc);
        }
      }
      const float far = 4.0f * std::max(float(du), float(dv));
      auto eval = [&](Vec2f p) {
        std::vector<double> f;
        for (size_t k = 0; k < near.size(); ++k) {
          const Scratch* sc = near[k];
          float reach = float(sc->referenceProfile().halfExtent()) * sc->maxScale() + far;
          PathPoint pp = sc->path().closest(p, reach);
          float kk = pp.found ? sc->scaleAt(pp.s) : 0.0f;
          for (const Vec2d& b : sc->referenceProfile().pts)
            f.push_back(pp.found && pp.beyond <= 0 && kk > 0 ? double(pp.offset) - double(kk) * b.x
                                                              : std::nan(""));
          for (size_t l = k + 1; l < near.size(); ++l) f.push_back(double(sc->height(p)) - double(near[l]->height(p)));
        }
        return f;
      };
      polys.assign(1, {{q00, eval(q00)}, {q10, eval(q10)}, {q11, eval(q11)}, {q01, eval(q01)}});
      const size_t nf = polys[0][0].f.size();
      for (size_t fi = 0; fi < nf; ++fi) {
        next.clear();
        for (auto& poly : polys) {
          bool neg = false, pos = false;
          for (const Vtx& v : poly) {
            double x = v.f[fi];
            neg |= x < 0;
            pos |= x > 0;
          }
          if (!(neg && pos)) {
            next.push_back(std::move(poly));
            continue;
          }
          std::vector<Vtx> lo_side, hi_side;
          for (size_t k = 0; k < poly.size(); ++k) {
            const Vtx& p0 = poly[k];
            const Vtx& p1 = poly[(k + 1) % poly.size()];
            double x0 = p0.f[fi], x1 = p1.f[fi];
            if (!(x0 > 0)) lo_side.push_back(p0);
            if (!(x0 < 0)) hi_side.push_back(p0);
            if ((x0 < 0 && x1 > 0) || (x0 > 0 && x1 < 0)) {
              // The crossing, computed from the edge's endpoints in a fixed order so that the
              // neighbouring cell finds the same point on a shared edge.
              bool swap = std::tie(p1.uv.x, p1.uv.y) < std::tie(p0.uv.x, p0.uv.y);
              const Vtx& e0 = swap ? p1 : p0;
              const Vtx& e1 = swap ? p0 : p1;
              double t = e0.f[fi] / (e0.f[fi] - e1.f[fi]);
              Vec2f uv(float(e0.uv.x + (double(e1.uv.x) - e0.uv.x) * t), float(e0.uv.y + (double(e1.uv.y) - e0.uv.y) * t));
              Vtx cross_v{uv, eval(uv)};
              cross_v.f[fi] = 0.0;
              lo_side.push_back(cross_v);
              hi_side.push_back(std::move(cross_v));
            }
          }
          if (lo_side.size() >= 3) next.push_back(std::move(lo_side));
          if (hi_side.size() >= 3) next.push_back(std::move(hi_side));
        }
        std::swap(polys, next);
      }
      for (const auto& poly : polys) {
        std::vector<Vec3d> P(poly.size());
        for (size_t k = 0; k < poly.size(); ++k) {
          Vec2f t = poly[k].uv;
          P[k] = a.o + a.u * double(t.x) + a.v * double(t.y) + a.n * double(scratchHeight(scratches, t));
        }
        for (size_t k = 1; k + 1 < poly.size(); ++k) {
          size_t id[3] = {0, k, k + 1};
          if (flip) std::swap(id[1], id[2]);
          Vec3d n = cross(P[id[1]] - P[id[0]], P[id[2]] - P[id[0]]);
          double e2 = std::max(dot(P[id[1]] - P[id[0]], P[id[1]] - P[id[0]]), dot(P[id[2]] - P[id[0]], P[id[2]] - P[id[0]]));
          double ln = length(n);
          if (!(ln > 1e-10 * e2)) continue;  // degenerate sliver
          n = n / ln;
          if (dot(n, a.n) < 0) n = -n;
          Vec3f nf(n);
          for (size_t v : id) {
            out.positions.push_back(Vec3f(P[v]));
            out.uvs.push_back(poly[v].uv);
            out.normals.push_back(nf);
          }
        }
      }
    }
  });
  TriangleMesh out;
  out.source = part.source + "+scratches";
  size_t nv = 0;
  for (const Soup& sp : soups) nv += sp.positions.size();
  if (nv / 3 > opt.max_triangles)
    throw std::runtime_error("the scratch geometry would exceed " + std::to_string(opt.max_triangles) + " triangles");
  out.positions.reserve(nv);
  out.uvs.reserve(nv);
  out.normals.reserve(nv);
  for (Soup& sp : soups) {
    out.positions.insert(out.positions.end(), sp.positions.begin(), sp.positions.end());
    out.uvs.insert(out.uvs.end(), sp.uvs.begin(), sp.uvs.end());
    out.normals.insert(out.normals.end(), sp.normals.begin(), sp.normals.end());
    Soup().positions.swap(sp.positions);
  }
  out.indices.resize(nv);
  for (size_t k = 0; k < nv; ++k) out.indices[k] = uint32_t(k);
  out.computeMmPerUv();
  if (stats) {
    stats->triangles = out.triangleCount();
    stats->cell_mm = std::max(du, dv);
  }
  return out;
}

}  // namespace dg
