#include "render/scratch_geometry.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <tuple>
#include <type_traits>
#include <stdexcept>
#include <unordered_map>

#include "core/memory.h"
#include "core/parallel.h"

#include <tbb/parallel_sort.h>

namespace dg {

float scratchHeight(const std::vector<const Scratch*>& scratches, Vec2f p, const Scratch** which) {
  float lowest = 0, highest = 0;
  const Scratch *low = nullptr, *high = nullptr;
  for (const Scratch* s : scratches) {
    if (!s->support().contains(p)) continue;
    const float h = s->height(p);
    if (h < lowest) lowest = h, low = s;
    if (h > highest) highest = h, high = s;
  }
  if (which) *which = low ? low : high;
  return lowest < 0 ? lowest : highest;
}

bool meetScratchHeight(const std::vector<const Scratch*>& scratches, Vec2d a, Vec2d du, double z0, double slope,
                       double len, double step, double tol, HeightMeet& out, bool plain, bool from_below) {
  if (!(step > 0) || !(len > 0)) return false;
  auto uvOf = [&](double x) { return Vec2f(float(a.x + du.x * x), float(a.y + du.y * x)); };
  // (`below`: past the surface, on the side away from where the ray starts.)
  auto below = [&](double x) {
    const double z = z0 + slope * x, h = double(scratchHeight(scratches, uvOf(x)));
    return from_below ? z > h + tol : z < h - tol;
  };
  double lo = 0, hi = 0;
  for (double x = std::min(step, len);; x = std::min(x + step, len)) {
    if (below(x)) {
      hi = x;
      break;
    }
    lo = x;
    if (x >= len) return false;
  }
  out.from = lo;
  for (int i = 0; i < 10; ++i) {
    const double mid = 0.5 * (lo + hi);
    (below(mid) ? hi : lo) = mid;
  }
  out.at = hi;
  scratchHeight(scratches, uvOf(hi), &out.scratch);
  return plain || out.scratch != nullptr;
}

namespace {

// A part triangle as the re-mesher sees it (doubles: the chart of a large part spans a metre, and
// its cells are micrometres).
struct PartTri {
  Vec2d t[3];   // UV corners
  Vec3d p[3];   // positions
  Vec3d n[3];   // outward unit normals at the corners: the mesh's, or the winding normal
  Vec3d ng;     // unit winding normal (the outside)
  Vec2d lo, hi; // UV box
  double area2; // twice the signed UV area (< 0: the chart is mirrored here)
  float mm_per_uv = 0;  // the part's chart scale on it (TriangleMesh::mmPerUv), 0 where unknown
};

bool uvLess(Vec2d a, Vec2d b) { return std::tie(a.x, a.y) < std::tie(b.x, b.y); }

// Whether two legs' lines (a point, a unit direction) are one line, parallel or opposite, to
// rounding.
bool oneLine(const std::pair<Vec2d, Vec2d>& a, const std::pair<Vec2d, Vec2d>& b) {
  const double s = 1 + std::max({std::fabs(a.first.x), std::fabs(a.first.y), std::fabs(b.first.x), std::fabs(b.first.y)});
  const Vec2d d = b.first - a.first;
  return std::fabs(a.second.x * b.second.y - a.second.y * b.second.x) <= 1e-9 &&
         std::fabs(d.x * a.second.y - d.y * a.second.x) <= 1e-9 * s;
}

// The distance from q to the segments first..last of a polyline (its points pts), in double.
// open_front / open_back: the first segment runs on backwards past its start, the last on past
// its end, as lines (a leg's end at a corner that it shares with the other leg asked).
double legDistance(const std::vector<Vec2d>& pts, size_t first, size_t last, Vec2d q, bool open_front,
                   bool open_back) {
  double best = std::numeric_limits<double>::infinity();
  for (size_t i = first; i <= last && i + 1 < pts.size(); ++i) {
    const Vec2d d = pts[i + 1] - pts[i];
    const double l2 = dot(d, d);
    if (!(l2 > 0)) continue;
    double t = dot(q - pts[i], d) / l2;
    if (!(i == first && open_front)) t = std::max(t, 0.0);
    if (!(i == last && open_back)) t = std::min(t, 1.0);
    const Vec2d e = pts[i] + d * t - q;
    best = std::min(best, dot(e, e));
  }
  return std::sqrt(best);
}

// The rotation that takes unit vector a to unit vector b, applied to v (a and b not opposite).
Vec3d turn(Vec3d a, Vec3d b, Vec3d v) {
  const double c = dot(a, b);
  if (c > 1 - 1e-15) return v;
  const Vec3d w = cross(a, b);
  return v * c + cross(w, v) + w * (dot(w, v) / (1 + c));
}

// The values of the kink functions at a piece's corner. A cell has a few kinks (a scratch's
// profile vertices and its two ends, and each pair's difference), so up to kInline values live in
// the corner itself: a heap array per corner, copied with every corner that a cut keeps, cost
// about 7% of the door view's sample in malloc, free and growing arrays.
class KinkValues {
 public:
  KinkValues() = default;
  KinkValues(const KinkValues& o) : heap_(o.heap_), n_(o.n_) { std::copy(o.local_, o.local_ + std::min(n_, kInline), local_); }
  KinkValues(KinkValues&& o) noexcept : heap_(std::move(o.heap_)), n_(o.n_) {
    std::copy(o.local_, o.local_ + std::min(n_, kInline), local_);
  }
  KinkValues& operator=(const KinkValues& o) {
    if (this != &o) *this = KinkValues(o);
    return *this;
  }
  KinkValues& operator=(KinkValues&& o) noexcept {
    heap_ = std::move(o.heap_);
    n_ = o.n_;
    std::copy(o.local_, o.local_ + std::min(n_, kInline), local_);
    return *this;
  }
  size_t size() const { return n_; }
  double operator[](size_t i) const { return n_ <= kInline ? local_[i] : heap_[i]; }
  double& operator[](size_t i) { return n_ <= kInline ? local_[i] : heap_[i]; }
  void push_back(double v) {
    if (n_ < kInline) {
      local_[n_++] = v;
      return;
    }
    if (n_ == kInline) heap_.assign(local_, local_ + kInline);
    heap_.push_back(v);
    ++n_;
  }
  void one(double v) {  // holds v alone
    heap_.clear();
    local_[0] = v;
    n_ = 1;
  }

 private:
  static constexpr size_t kInline = 16;
  double local_[kInline];
  std::vector<double> heap_;  // all of them, past kInline
  size_t n_ = 0;
};

// A corner of a cell piece: its UV, the part-triangle edges it lies on (bit k: edge from corner k
// to k + 1), and the values of the kink functions there.
struct Vtx {
  Vec2d uv;
  unsigned on = 0;
  KinkValues f;
};

// Cuts the polygon along the zero set of value `fi` of its vertices' f; keeps the side f >= 0
// (keep_neg false) and, when `both`, also the side f <= 0. A new vertex lies on the edges that both
// ends of its segment lie on, plus `on_bit`, and takes its f from `eval`. Values curved_lo to
// curved_hi - 1 are curved kinks: a crossing of one is moved onto it to within `refine`, and a new
// vertex on a segment along one's cut takes 0 for it.
template <class Eval>
void cutPolygon(std::vector<Vtx>& poly, size_t fi, unsigned on_bit, bool both, const Eval& eval,
                std::vector<std::vector<Vtx>>& out, size_t curved_lo = 0, size_t curved_hi = 0,
                double refine = 0) {
  bool neg = false, pos = false;
  for (const Vtx& v : poly) {
    neg |= v.f[fi] < 0;
    pos |= v.f[fi] > 0;
  }
  if (!(neg && pos)) {
    if (pos || both || !neg) out.push_back(std::move(poly));
    return;
  }
  std::vector<Vtx> lo_side, hi_side;
  for (size_t k = 0; k < poly.size(); ++k) {
    const Vtx& p0 = poly[k];
    const Vtx& p1 = poly[(k + 1) % poly.size()];
    const double x0 = p0.f[fi], x1 = p1.f[fi];
    if (!(x0 > 0)) lo_side.push_back(p0);
    if (!(x0 < 0)) hi_side.push_back(p0);
    if ((x0 < 0 && x1 > 0) || (x0 > 0 && x1 < 0)) {
      // The crossing, computed from the segment's ends in a fixed order, so that the neighbouring
      // piece finds the same point on a shared segment.
      const bool swap = uvLess(p1.uv, p0.uv);
      const Vtx& e0 = swap ? p1 : p0;
      const Vtx& e1 = swap ? p0 : p1;
      double t = e0.f[fi] / (e0.f[fi] - e1.f[fi]);
      Vtx c;
      c.uv = e0.uv + (e1.uv - e0.uv) * t;
      c.on = (p0.on & p1.on) | on_bit;
      c.f = eval(c.uv);
      // A curved kink (fi in [curved_lo, curved_hi)): the crossing moved onto it, to within
      // `refine` in value, by regula falsi (the Illinois variant) on the segment.
      const bool curved = fi >= curved_lo && fi < curved_hi;
      double ta = 0, fa = e0.f[fi], tb = 1, fb = e1.f[fi];
      for (int it = 0, last = 0; curved && it < 16 && std::fabs(c.f[fi]) > refine; ++it) {
        if ((c.f[fi] < 0) == (fa < 0)) {
          ta = t, fa = c.f[fi];
          if (last < 0) fb *= 0.5;
          last = -1;
        } else {
          tb = t, fb = c.f[fi];
          if (last > 0) fa *= 0.5;
          last = 1;
        }
        t = ta + (tb - ta) * fa / (fa - fb);
        c.uv = e0.uv + (e1.uv - e0.uv) * t;
        c.f = eval(c.uv);
      }
      // On a segment along a curved kink's cut (both ends on it), the point is on that cut too (on
      // its chord), whatever its value there.
      for (size_t g = curved_lo; g < curved_hi; ++g)
        if (e0.f[g] == 0 && e1.f[g] == 0) c.f[g] = 0.0;
      c.f[fi] = 0.0;
      lo_side.push_back(c);
      hi_side.push_back(std::move(c));
    }
  }
  if (both && lo_side.size() >= 3) out.push_back(std::move(lo_side));
  if (hi_side.size() >= 3) out.push_back(std::move(hi_side));
}

}  // namespace

TriangleMesh scratchedMesh(const TriangleMesh& part, const std::vector<const Scratch*>& scratches,
                           const ScratchGeometryOptions& opt, ScratchGeometryStats* stats) {
  if (part.uvs.size() != part.positions.size() || part.triangleCount() == 0)
    throw std::runtime_error("the part has no UV chart");
  const bool has_normals = part.normals.size() == part.positions.size();
  Vec2d lo(1e300, 1e300), hi(-1e300, -1e300);
  for (Vec2f t : part.uvs) {
    lo = {std::min(lo.x, double(t.x)), std::min(lo.y, double(t.y))};
    hi = {std::max(hi.x, double(t.x)), std::max(hi.y, double(t.y))};
  }
  double cell = opt.cell_mm;
  if (!(cell > 0)) {
    double narrowest = 1e30;
    for (const Scratch* s : scratches) {
      double w = s->referenceProfile().width() * s->maxScale();
      if (w > 0) narrowest = std::min(narrowest, w);
    }
    cell = narrowest < 1e30 ? std::max(5e-4, narrowest / 16.0) : 1.0;
  }
  const double W = std::max(hi.x - lo.x, 1e-9), H = std::max(hi.y - lo.y, 1e-9);
  int depth = 0;
  while (std::max(W, H) / double(1 << depth) > cell && depth < 26) ++depth;
  const double du = W / double(1 << depth), dv = H / double(1 << depth);
  const uint32_t full = 1u << depth;
  const double merge = 4.0 * std::max({std::fabs(lo.x), std::fabs(lo.y), std::fabs(hi.x), std::fabs(hi.y)}) *
                       double(std::numeric_limits<float>::epsilon());
  // Heights come from float UVs: differences below jump_tol are rounding, not a jump; the height
  // beyond an edge is sampled jump_step and twice that outside it. Two samples that differ by more
  // than kStraddle * jump_tol (a slope of 16, 86 degrees, over jump_step) have a jump between them.
  const double jump_tol = 16.0 * merge, jump_step = 4.0 * merge;
  constexpr double kStraddle = 4.0;

  // Does some scratch's cross-section reach into the UV box? (With kinks_only, into a kink line
  // of it: a profile vertex's offset, or an end.)
  auto reaches = [&](Vec2d b0, Vec2d b1, bool kinks_only) {
    Box2 cb;
    cb.lo = {float(b0.x), float(b0.y)};
    cb.hi = {float(b1.x), float(b1.y)};
    Vec2f c(float(0.5 * (b0.x + b1.x)), float(0.5 * (b0.y + b1.y)));
    float half_diag = float(0.5 * std::hypot(b1.x - b0.x, b1.y - b0.y));
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

  // The part's triangles: those no cross-section reaches are kept as they are.
  std::vector<PartTri> cut;
  std::vector<uint32_t> kept;
  for (size_t f = 0; f < part.triangleCount(); ++f) {
    const uint32_t* id = &part.indices[3 * f];
    PartTri pt;
    for (int k = 0; k < 3; ++k) {
      pt.t[k] = Vec2d(part.uvs[id[k]].x, part.uvs[id[k]].y);
      pt.p[k] = Vec3d(part.positions[id[k]]);
    }
    pt.lo = {std::min({pt.t[0].x, pt.t[1].x, pt.t[2].x}), std::min({pt.t[0].y, pt.t[1].y, pt.t[2].y})};
    pt.hi = {std::max({pt.t[0].x, pt.t[1].x, pt.t[2].x}), std::max({pt.t[0].y, pt.t[1].y, pt.t[2].y})};
    pt.area2 = cross(pt.t[1] - pt.t[0], pt.t[2] - pt.t[0]);
    const Vec3d g = cross(pt.p[1] - pt.p[0], pt.p[2] - pt.p[0]);
    const double scale = std::max({pt.hi.x - pt.lo.x, pt.hi.y - pt.lo.y, 1e-30});
    // A triangle without UV area or 3-D area carries no scratch (none can be placed on it).
    if (!(std::fabs(pt.area2) > 1e-12 * scale * scale) || !(length(g) > 0) || !reaches(pt.lo, pt.hi, false)) {
      kept.push_back(uint32_t(f));
      continue;
    }
    pt.ng = g / length(g);
    if (part.mmPerUv.size() == part.triangleCount()) pt.mm_per_uv = part.mmPerUv[f];
    for (int k = 0; k < 3; ++k) {
      Vec3d n = has_normals ? normalize(Vec3d(part.normals[id[k]])) : pt.ng;
      pt.n[k] = dot(n, pt.ng) > 0 ? n : pt.ng;  // as the renderer: a normal facing inward is ignored
    }
    cut.push_back(pt);
  }

  // Quadtree over the chart's rectangle, only where triangles are cut. A cell is split while it
  // is coarser than the finest level and some scratch's cross-section may reach into it.
  struct Leaf {
    uint32_t i0, j0, size;  // in finest-cell units
  };
  auto corner = [&](uint32_t i, uint32_t j) {
    return Vec2d(i == full ? hi.x : lo.x + i * du, j == full ? hi.y : lo.y + j * dv);
  };
  // A uniform grid of the cut triangles' UV boxes, to find those under a cell.
  const int G = std::clamp(int(std::sqrt(double(cut.size()))), 1, 1024);
  std::vector<std::vector<uint32_t>> bins(size_t(G) * G);
  auto binRange = [&](Vec2d b0, Vec2d b1, int& x0, int& x1, int& y0, int& y1) {
    x0 = std::clamp(int((b0.x - lo.x) / W * G), 0, G - 1);
    x1 = std::clamp(int((b1.x - lo.x) / W * G), 0, G - 1);
    y0 = std::clamp(int((b0.y - lo.y) / H * G), 0, G - 1);
    y1 = std::clamp(int((b1.y - lo.y) / H * G), 0, G - 1);
  };
  for (size_t i = 0; i < cut.size(); ++i) {
    int x0, x1, y0, y1;
    binRange(cut[i].lo, cut[i].hi, x0, x1, y0, y1);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) bins[size_t(y) * G + x].push_back(uint32_t(i));
  }
  auto trianglesUnder = [&](Vec2d b0, Vec2d b1, std::vector<uint32_t>& out) {
    out.clear();
    int x0, x1, y0, y1;
    binRange(b0, b1, x0, x1, y0, y1);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x)
        for (uint32_t i : bins[size_t(y) * G + x])
          if (cut[i].lo.x <= b1.x && b0.x <= cut[i].hi.x && cut[i].lo.y <= b1.y && b0.y <= cut[i].hi.y) out.push_back(i);
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
  };

  // Cells at the finest level that hold a kink of a cross-section (a profile vertex line) may be
  // split kKinkLevels levels further (0 = off: the exact facet normals below already remove the
  // kink's glint; splitting only sharpens where the kink lies).
  constexpr int kKinkLevels = 0;
  // What becomes of a cell: nothing to cut under it, a leaf, or four children.
  enum class Fate { Drop, Leaf, Split };
  auto fate = [&](const Leaf& c, std::vector<uint32_t>& under) {
    const Vec2d b0 = corner(c.i0, c.j0), b1 = corner(c.i0 + c.size, c.j0 + c.size);
    trianglesUnder(b0, b1, under);
    if (under.empty()) return Fate::Drop;  // only kept triangles (or none) there
    return c.size > 1 && reaches(b0, b1, c.size <= (1u << kKinkLevels)) ? Fate::Split : Fate::Leaf;
  };
  auto children = [](const Leaf& c, std::vector<Leaf>& to) {
    const uint32_t h = c.size / 2;
    to.push_back({c.i0, c.j0, h});
    to.push_back({c.i0 + h, c.j0, h});
    to.push_back({c.i0, c.j0 + h, h});
    to.push_back({c.i0 + h, c.j0 + h, h});
  };
  // The leaves (their count is all the cap needs: it grows only, so whether it passes the cap does
  // not depend on the threads' order).
  std::atomic<size_t> leaf_count{0};
  auto addLeaf = [&](const Leaf& c, std::vector<Leaf>& to) {
    to.push_back(c);
    if (leaf_count.fetch_add(1, std::memory_order_relaxed) + 1 > opt.max_triangles / 2)
      throw std::runtime_error("the scratch geometry would exceed " + std::to_string(opt.max_triangles) +
                               " triangles (cell " + std::to_string(cell) + " mm)");
  };
  // The tree's top breadth first on this thread, until there are cells enough to share out; then
  // each of those cells' subtrees depth first on its own task (one thread took 1 s of the door's
  // 17 here).
  std::vector<Leaf> leaves, top{{0, 0, full}}, next;
  std::vector<uint32_t> under;
  while (!top.empty() && top.size() < 256) {
    next.clear();
    for (const Leaf& c : top) {
      const Fate f = fate(c, under);
      if (f == Fate::Split) children(c, next);
      if (f == Fate::Leaf) addLeaf(c, leaves);
    }
    top.swap(next);
  }
  std::vector<std::vector<Leaf>> subtree_leaves(top.size());
  parallelFor(top.size(), [&](size_t r) {
    std::vector<Leaf> stack{top[r]};
    std::vector<uint32_t> under_here;
    while (!stack.empty()) {
      const Leaf c = stack.back();
      stack.pop_back();
      const Fate f = fate(c, under_here);
      if (f == Fate::Split) children(c, stack);
      if (f == Fate::Leaf) addLeaf(c, subtree_leaves[r]);
    }
  });
  std::vector<size_t> at(top.size() + 1, leaves.size());
  for (size_t r = 0; r < top.size(); ++r) at[r + 1] = at[r] + subtree_leaves[r].size();
  resizeInParallel(leaves, at.back());
  parallelFor(top.size(), [&](size_t r) {
    std::copy(subtree_leaves[r].begin(), subtree_leaves[r].end(), leaves.begin() + at[r]);
    std::vector<Leaf>().swap(subtree_leaves[r]);
  });
  // Deterministic order: by row, then column, then size. No two leaves share a corner (they do not
  // overlap), so the order is the same whatever the sort and the threads.
  tbb::parallel_sort(leaves.begin(), leaves.end(), [](const Leaf& x, const Leaf& y) {
    return std::tie(x.j0, x.i0, x.size) < std::tie(y.j0, y.i0, y.size);
  });

  // Every leaf is clipped to each cut triangle under it, and the piece, if it is a finest cell
  // that a kink of the height field crosses, is cut along it, so that every output triangle lies
  // on one facet and the mesh is exactly the faceted surface (up to the chord of a curved kink
  // inside a cell). Kinks are the zero sets of:
  //  - offset - k(s) b_i for each cross-section vertex b_i of a scratch reaching the cell (k the
  //    scale at the closest point's arc position s), and
  //  - h_a - h_b for each pair of scratches reaching it (where overlapping grooves or pile-ups
  //    trade places in the composite height).
  // Without the cuts a triangle straddling a kink lies between the two facets: at a peak's apex
  // under a grazing light the apex is cut low and the shadow behind it comes out short (measured:
  // 4% too much light in a lit wall's pixels at cell = width / 32 under a 12 degree bar light,
  // converging only as the cell shrinks).
  // Each block's triangles: vertices and indices local to the block (a piece's fan of triangles
  // shares its polygon's vertices, which saves a third of the vertices or more); with count_only
  // just how many triangles.
  struct Soup {
    bool count_only = false;
    size_t triangles = 0;
    size_t capped = 0;  // cells (per part triangle) that reached the cap of pieces
    std::vector<Vec3f> positions, normals;
    std::vector<Vec2f> uvs;
    std::vector<float> heights;
    std::vector<uint32_t> indices;
    // Per triangle, the chart scale of the part triangle it was cut from (`scale`, set per part
    // triangle): a cut surface keeps the part's chart, whatever its slope.
    std::vector<float> chart;
    float scale = 0;
    size_t vertices = 0;
    uint32_t vertex(Vec3f p, Vec2f uv, Vec3f n, float h) {
      ++vertices;
      if (count_only) return 0;
      positions.push_back(p);
      uvs.push_back(uv);
      normals.push_back(n);
      heights.push_back(h);
      return uint32_t(positions.size() - 1);
    }
    void triangle(uint32_t a, uint32_t b, uint32_t c) {
      ++triangles;
      if (count_only) return;
      indices.insert(indices.end(), {a, b, c});
      chart.push_back(scale);
    }
  };
  const size_t block = 1024;
  const size_t nblocks = (leaves.size() + block - 1) / block;
  std::vector<Soup> soups(nblocks);
  parallelFor(nblocks, [&](size_t blk) {
    Soup& out = soups[blk];
    out.count_only = opt.count_only;
    std::vector<const Scratch*> near;
    // The ends of the scratches in `near`: where the scale is still > 0 at an end, the height drops
    // to 0 across the line through it perpendicular to the path (PathPoint::beyond > 0 past it).
    struct End {
      Vec2d p, t;          // the end point and the path's tangent there
      double sign = 1;     // +: the values are >= 0 on the scratch's side
      double reach = 0;    // the line matters within this distance of the point
      bool abrupt = false;
    };
    std::vector<std::array<End, 2>> ends;
    // Per scratch in `near`: its legs near the cell, each a run of consecutive segments (first and
    // last index): the runs of its passes (ScratchPath::closestBranches), each split at the path's
    // corners. Its kinks are each leg's own, from the closest point on that leg alone.
    std::vector<std::vector<std::pair<size_t, size_t>>> legs;
    // Per scratch in `near`, per leg: which profile vertices' kinks cut the cell.
    std::vector<std::vector<std::vector<char>>> kinks;
    // Per scratch in `near` with two legs or more near the cell (a hairpin, a loop that crosses
    // itself, the legs of a corner): each leg's line (a point and its unit tangent) at the cell's
    // centre; empty for one leg.
    std::vector<std::vector<std::pair<Vec2d, Vec2d>>> passes;
    // The pairs of legs whose handover cuts the cell (legs i < j of near[k], not on one line), and
    // which of them runs into the other at a corner.
    struct Handover {
      size_t k, i, j;
      bool i_then_j, j_then_i;
    };
    std::vector<Handover> handovers;
    std::vector<PathPoint> branches;
    std::vector<std::pair<size_t, size_t>> runs;
    std::vector<uint32_t> tris;
    std::vector<std::vector<Vtx>> polys, next;
    constexpr uint32_t kNoVertex = ~uint32_t(0);
    std::vector<uint32_t> shared;  // per vertex of the piece being written: its index in the block
    // Per vertex of the piece being written: displaced position, normal, position in the flat
    // triangle, base point, float UV and height (kept across pieces instead of allocated for each
    // of the door's millions: 2% less CPU time for its cut, the same bytes).
    std::vector<Vec3d> P, N, F, Bs;
    std::vector<Vec2f> T;
    std::vector<double> hv;
    const float far = 4.0f * float(std::max(du, dv));
    auto eval = [&](Vec2d q) {
      KinkValues f;
      const Vec2f p(float(q.x), float(q.y));
      // Before all others, where a path passing more than once (or turning a corner) hands over
      // from one leg to the next (Scratch::height takes the closest point): d_i - d_j for each two
      // of its legs, d the distance to the leg's segments (legDistance). Within each side the
      // closest point is on one leg and the kinks below are affine. First the signed distance b_i
      // from each leg's line: d_i bends along it, so where that line crosses the cell (near a
      // corner's vertex, at a loop's crossing) the chord of d_i - d_j = 0 over a piece across it
      // missed the handover.
      //
      // Where a leg's closest point is its end (beyond a corner's vertex: the corner's round outer
      // side, its cap), d_i is the distance to that point, and the handover with a leg passing
      // beside the cap is a parabola. With the perturbation the two are at different scales and the
      // height jumps along it. Until the forty-eighth session the handover was |b_i| - |b_j|, from
      // the legs' lines, a straight line that is not where the closest point changes in a cap: the
      // pieces there straddled the jump, and the walls stood on the cells' edges, facing along them
      // (the corner fuzzer's c48_9 lacked a glint that the groove renderer drew from the parabola's
      // wall). Two legs that meet at a corner run on past it as lines (legDistance's open ends):
      // in the wedge beyond its vertex both would be the distance to the vertex, the same value,
      // and d_i - d_j rounding noise, where now it is zero on the outer bisector, as it was.
      auto side = [&](const std::pair<Vec2d, Vec2d>& l) {
        const Vec2d d = q - l.first;
        return d.x * l.second.y - d.y * l.second.x;
      };
      for (const auto& ps : passes)
        for (const auto& l : ps) f.push_back(side(l));
      // (`handovers` leaves out two legs on one line, a path going exactly back over itself: the
      // closest point stays on the earlier, ScratchPath::closest breaking the tie, and d_i - d_j
      // is rounding noise, whose zero set cut the cell at random.)
      for (const Handover& ho : handovers) {
        const std::vector<Vec2d>& pts = near[ho.k]->path().points();
        const auto& li = legs[ho.k][ho.i];
        const auto& lj = legs[ho.k][ho.j];
        f.push_back(legDistance(pts, li.first, li.second, q, ho.j_then_i, ho.i_then_j) -
                    legDistance(pts, lj.first, lj.second, q, ho.i_then_j, ho.j_then_i));
      }
      // First every scratch's own kinks, then where two trade places: h_a - h_b is affine only
      // within pieces that are already on one facet of each (cut the other way round, the chord
      // of its bent zero set would leave pieces straddling it).
      for (size_t k = 0; k < near.size(); ++k) {
        const Scratch* sc = near[k];
        float reach = float(sc->referenceProfile().halfExtent()) * sc->maxScale() + far;
        const std::vector<Vec2d>& pts = sc->referenceProfile().pts;
        // Each leg's kinks from the closest point on that leg alone: the path's closest point
        // jumps to another leg where the two hand over (on a cell's edge, too: at the midline of a
        // hairpin's legs a tie goes to the lower segment), and a kink function taken from whichever
        // leg is the nearer jumps there, so that a piece on one leg's side, with corners on that
        // line, was cut at the wrong places or not at all. (Until 2026-11-29: the bright streak along
        // the midline of a U-turn with the perturbation, where a pile-up's outer kink lay in the
        // cell beside the midline and the corners on it took the other leg's scale.)
        for (size_t g = 0; g < legs[k].size(); ++g) {
          PathPoint pp = sc->path().closestOnSegments(p, reach, legs[k][g].first, legs[k][g].second);
          float kk = pp.found ? sc->scaleAt(pp.s) : 0.0f;
          // Past an abrupt end (scale > 0 there) the kink lines run on along the end's tangent, so
          // that a piece across the end line is cut along them on both sides before the end line
          // cuts it. (Until 2026-11-28 they were undefined past the end: such a piece was not cut
          // exactly, and the end's cell kept a facet across kinks, a bright column one cell wide at
          // a blunt end's pile-up under the bar light that finer cells narrowed. Past a faded end
          // the scale is 0 and there is nothing to cut.)
          for (size_t i = 0; i < pts.size(); ++i)
            if (kinks[k][g][i])
              f.push_back(pp.found && kk > 0 ? double(pp.offset) - double(kk) * pts[i].x : std::nan(""));
        }
        // An abrupt end's line (across the end tangent, where the height drops to 0), near that end.
        for (int e = 0; e < 2; ++e) {
          const End& en = ends[k][e];
          const Vec2d d = q - en.p;
          f.push_back(en.abrupt && std::hypot(d.x, d.y) <= en.reach ? en.sign * (d.x * en.t.x + d.y * en.t.y) : std::nan(""));
        }
      }
      for (size_t k = 0; k < near.size(); ++k)
        for (size_t l = k + 1; l < near.size(); ++l) f.push_back(double(near[k]->height(p)) - double(near[l]->height(p)));
      return f;
    };
    // The heights in a finest cell (and a little beyond its edges, where the walls at jumps
    // sample them) come from the scratches that reach that far (`near_h`), the same values as
    // from all of them: the others are 0 there. Coarser cells ask all.
    std::vector<const Scratch*> near_h;
    const std::vector<const Scratch*>* heights = &scratches;
    auto heightAt = [&](Vec2d q) { return double(scratchHeight(*heights, Vec2f(float(q.x), float(q.y)))); };
    // A piece's own height at its vertex q, from a point 1/64 of the way to its centre c (hc the
    // height there): exact where the height is affine over the piece.
    auto insideHeight = [&](Vec2d q, Vec2d c, double hc) {
      constexpr double e = 1.0 / 64;
      return (heightAt(q + (c - q) * e) - e * hc) / (1 - e);
    };
    bool jumpy = false;
    for (size_t li = blk * block; li < std::min(leaves.size(), (blk + 1) * block); ++li) {
      const Leaf& c = leaves[li];
      const Vec2d q00 = corner(c.i0, c.j0), q10 = corner(c.i0 + c.size, c.j0),
                  q11 = corner(c.i0 + c.size, c.j0 + c.size), q01 = corner(c.i0, c.j0 + c.size);
      near.clear();
      near_h.clear();
      passes.clear();
      legs.clear();
      handovers.clear();
      bool passing = false;  // some path has two legs near the cell (two passes, or a corner's legs)
      if (c.size == 1) {
        Box2 cb{Vec2f(float(q00.x), float(q00.y)), Vec2f(float(q11.x), float(q11.y))};
        Box2 cb_h{cb.lo - Vec2f(far, far), cb.hi + Vec2f(far, far)};
        Vec2f centre(float(0.5 * (q00.x + q11.x)), float(0.5 * (q00.y + q11.y)));
        float half_diag = float(0.5 * std::hypot(q11.x - q00.x, q11.y - q00.y));
        for (const Scratch* sc : scratches) {
          if (!sc->support().overlaps(cb_h)) continue;
          float reach = float(sc->referenceProfile().halfExtent()) * sc->maxScale() + half_diag;
          // One query at the wider reach answers both: the nearest segment within the narrower
          // one is also the nearest found within the wider, at the same distance.
          const PathPoint pc = sc->path().closest(centre, reach + far);
          if (!pc.found) continue;
          near_h.push_back(sc);
          if (sc->support().overlaps(cb) && pc.distance <= reach) {
            near.push_back(sc);
            // Its passes, where it comes back into the reach, and their legs between corners.
            const ScratchPath& path = sc->path();
            path.closestBranches(centre, reach, branches, std::numeric_limits<float>::infinity(), &runs);
            legs.emplace_back();
            for (const auto& r : runs) {
              size_t from = r.first;
              for (const ScratchPath::Corner& cn : path.corners())
                if (cn.vertex > r.first && cn.vertex <= r.second) {
                  legs.back().push_back({from, cn.vertex - 1});
                  from = cn.vertex;
                }
              legs.back().push_back({from, r.second});
            }
            passes.emplace_back();
            if (legs.back().size() >= 2) {
              // Each leg's line: its segment nearest the centre.
              const std::vector<Vec2d>& pp = path.points();
              const Vec2d cd(centre.x, centre.y);
              for (const auto& lg : legs.back()) {
                double best = 1e300;
                std::pair<Vec2d, Vec2d> line;
                for (size_t i = lg.first; i <= lg.second; ++i) {
                  const Vec2d d = pp[i + 1] - pp[i];
                  const double l2 = dot(d, d);
                  if (!(l2 > 0)) continue;
                  const double t = std::clamp(dot(cd - pp[i], d) / l2, 0.0, 1.0);
                  const Vec2d e = pp[i] + d * t - cd;
                  if (dot(e, e) < best) {
                    best = dot(e, e);
                    line = {pp[i], d / std::sqrt(l2)};
                  }
                }
                passes.back().push_back(line);
              }
              passing = true;
            }
          }
        }
      }
      heights = c.size == 1 ? &near_h : &scratches;
      // The handovers, and where their values lie in eval's: after each leg's line, [h_lo, h_hi).
      // They are curved where a leg's closest point is its end (a corner's cap): cutPolygon moves
      // their crossings onto them, and a wall along one is asked for near the ends of its chords.
      size_t h_lo = 0;
      for (size_t k = 0; k < passes.size(); ++k) {
        h_lo += passes[k].size();
        for (size_t i = 0; i < passes[k].size(); ++i)
          for (size_t j = i + 1; j < passes[k].size(); ++j)
            if (!oneLine(passes[k][i], passes[k][j]))
              handovers.push_back({k, i, j, legs[k][i].second + 1 == legs[k][j].first,
                                   legs[k][j].second + 1 == legs[k][i].first});
      }
      const size_t h_hi = h_lo + handovers.size();
      // The kinks that cut this cell. One closer to the last kept than the offsets' rounding
      // (`merge`) at the scale of the cell's centre is left out: where a fade or the perturbation
      // shrinks the cross-section to nanometres, the order of its kinks is rounding noise, and
      // cutting along each of them split a cell into millions of slivers (3 million in one cell of
      // a 4 micrometre deep scratch: 12 GB and two minutes for 2 million triangles). The facets
      // left uncut are narrower than `merge`, which would merge their vertices anyway.
      kinks.resize(near.size());
      for (size_t k = 0; k < near.size(); ++k) {
        const std::vector<Vec2d>& pts = near[k]->referenceProfile().pts;
        kinks[k].resize(legs[k].size());
        for (size_t g = 0; g < legs[k].size(); ++g) {
          kinks[k][g].assign(pts.size(), 1);
          // The leg's point nearest the cell's centre (within the reach plus `far`, as the
          // query for the scratch at the centre).
          const float reach = float(near[k]->referenceProfile().halfExtent()) * near[k]->maxScale() +
                              float(0.5 * std::hypot(q11.x - q00.x, q11.y - q00.y)) + far;
          const PathPoint pc = near[k]->path().closestOnSegments(
              Vec2f(float(0.5 * (q00.x + q11.x)), float(0.5 * (q00.y + q11.y))), reach, legs[k][g].first,
              legs[k][g].second);
          const double kc = pc.found && pc.beyond <= 0 ? double(near[k]->scaleAt(pc.s)) : 0.0;
          if (!(kc > 0)) continue;
          double last = pts[0].x;
          for (size_t i = 1; i < pts.size(); ++i) {
            if (pts[i].x > last && kc * (pts[i].x - last) <= merge)
              kinks[k][g][i] = 0;
            else
              last = pts[i].x;
          }
        }
      }
      // Cells where the composite height can jump (two scratches meet, two passes of one path with
      // different scales meet, or an abrupt end is near) get exact facets up to the jump lines and
      // walls along them (below).
      ends.assign(near.size(), {});
      jumpy = near.size() >= 2 || passing;
      for (size_t k = 0; k < near.size(); ++k) {
        const ScratchPath& path = near[k]->path();
        const float half = float(near[k]->referenceProfile().halfExtent()) * near[k]->maxScale();
        for (int e = 0; e < 2; ++e) {
          End& en = ends[k][e];
          const double s = e == 0 ? 0.0 : path.length();
          en.p = path.pointAt(s);
          en.t = path.tangentAt(s);
          en.sign = e == 0 ? 1.0 : -1.0;
          en.reach = 2.0 * half + 4.0 * std::max(du, dv);
          en.abrupt = near[k]->scaleAt(float(s)) > 0;
          const Vec2d d = Vec2d(0.5 * (q00.x + q11.x), 0.5 * (q00.y + q11.y)) - en.p;
          jumpy |= en.abrupt && std::hypot(d.x, d.y) <= en.reach;
        }
      }
      trianglesUnder(q00, q11, tris);
      for (uint32_t ti : tris) {
        const PartTri& pt = cut[ti];
        out.scale = pt.mm_per_uv;
        // Clip the cell to the triangle: keep where each edge function (the signed distance from
        // the edge's line, computed from its ends in a fixed order, positive inside) is >= 0.
        // Values within a rounding distance of the line count as on it.
        polys.assign(1, {});
        for (Vec2d q : {q00, q10, q11, q01}) polys[0].push_back({q, 0u, {}});
        for (int e = 0; e < 3 && !polys.empty(); ++e) {
          Vec2d A = pt.t[e], B = pt.t[(e + 1) % 3];
          if (uvLess(B, A)) std::swap(A, B);
          const Vec2d AB = B - A;
          const double len = std::hypot(AB.x, AB.y);
          const double side = cross(AB, pt.t[(e + 2) % 3] - A) > 0 ? 1.0 : -1.0;
          const double tol = 1e-12 * (W + H) * len;
          auto edgeF = [&](Vec2d q) {
            double g = side * cross(AB, q - A);
            return std::fabs(g) <= tol ? 0.0 : g;
          };
          next.clear();
          for (auto& poly : polys) {
            for (Vtx& v : poly) {
              v.f.one(edgeF(v.uv));
              if (v.f[0] == 0) v.on |= 1u << e;
            }
            cutPolygon(poly, 0, 1u << e, false,
                       [&](Vec2d q) {
                         KinkValues f;
                         f.one(edgeF(q));
                         return f;
                       },
                       next);
          }
          std::swap(polys, next);
        }
        if (polys.empty()) continue;
        // Cut along the kinks.
        for (auto& poly : polys)
          for (Vtx& v : poly) v.f = eval(v.uv);
        // A cell cut into more pieces than the cap keeps them and is not cut further (counted in
        // the stats): each piece still lies on the part, with the heights of its corners.
        const size_t nf = polys[0][0].f.size();
        for (size_t fi = 0; fi < nf; ++fi) {
          if (polys.size() > opt.max_pieces_per_cell) {
            ++out.capped;
            break;
          }
          next.clear();
          for (auto& poly : polys) cutPolygon(poly, fi, 0u, true, eval, next, h_lo, h_hi, merge);
          std::swap(polys, next);
        }
        // Map the pieces through the triangle. A point on an edge is placed along that edge alone
        // (from its ends in a fixed order), and a corner is the corner, so that the neighbouring
        // triangle places it alike.
        auto place = [&](const Vtx& v, Vec3d& p, Vec3d& n) {
          for (int e = 0; e < 3; ++e) {
            const unsigned both = (1u << e) | (1u << ((e + 2) % 3));
            if ((v.on & both) == both) {  // on the edges into and out of corner e
              p = pt.p[e];
              n = pt.n[e];
              return;
            }
          }
          for (int e = 0; e < 3; ++e)
            if (v.on & (1u << e)) {
              int a = e, b = (e + 1) % 3;
              if (uvLess(pt.t[b], pt.t[a])) std::swap(a, b);
              const Vec2d AB = pt.t[b] - pt.t[a];
              const double s = std::clamp(((v.uv.x - pt.t[a].x) * AB.x + (v.uv.y - pt.t[a].y) * AB.y) /
                                              (AB.x * AB.x + AB.y * AB.y), 0.0, 1.0);
              p = pt.p[a] + (pt.p[b] - pt.p[a]) * s;
              n = normalize(pt.n[a] + (pt.n[b] - pt.n[a]) * s);
              return;
            }
          const double b1 = cross(v.uv - pt.t[0], pt.t[2] - pt.t[0]) / pt.area2;
          const double b2 = cross(pt.t[1] - pt.t[0], v.uv - pt.t[0]) / pt.area2;
          const double b0 = 1 - b1 - b2;
          p = pt.p[0] * b0 + pt.p[1] * b1 + pt.p[2] * b2;
          n = normalize(pt.n[0] * b0 + pt.n[1] * b1 + pt.n[2] * b2);
        };
        // Counter-clockwise seen from the outside: the pieces are counter-clockwise in UV, so
        // flip where the chart is mirrored.
        const bool flip = pt.area2 < 0;
        for (auto& poly : polys) {
          // Merge vertices that lie within a few float steps of their predecessor: the heights
          // are computed from float UVs, so a piece that small has no reliable facet.
          size_t w = 0;
          for (size_t k = 0; k < poly.size(); ++k)
            if (w == 0 || std::fabs(poly[k].uv.x - poly[w - 1].uv.x) + std::fabs(poly[k].uv.y - poly[w - 1].uv.y) > merge) {
              if (w != k) poly[w] = std::move(poly[k]);  // (a move onto itself would empty its values)
              ++w;
            }
          while (w > 1 && std::fabs(poly[0].uv.x - poly[w - 1].uv.x) + std::fabs(poly[0].uv.y - poly[w - 1].uv.y) <= merge) --w;
          poly.resize(w);
          const size_t m = poly.size();
          if (m < 3) continue;
          P.resize(m);  // every entry is written below before it is read
          N.resize(m);
          F.resize(m);
          Bs.resize(m);
          T.resize(m);
          hv.resize(m);
          Vec2d c(0, 0);
          for (const Vtx& v : poly) c += v.uv;
          c = c / double(m);
          const double hc = jumpy ? heightAt(c) : 0.0;
          for (size_t k = 0; k < m; ++k) {
            T[k] = Vec2f(float(poly[k].uv.x), float(poly[k].uv.y));
            place(poly[k], Bs[k], N[k]);
            hv[k] = scratchHeight(*heights, T[k]);
            // On a jump line a point's height is one side's; the piece on the other side takes its
            // own facet's value there, extrapolated from a point just inside (the facet is affine
            // across the piece).
            if (jumpy) {
              const double hu = insideHeight(poly[k].uv, c, hc);
              if (std::fabs(hu - hv[k]) > jump_tol) hv[k] = hu;
            }
            P[k] = Bs[k] + N[k] * hv[k];
            F[k] = Bs[k] + pt.ng * hv[k];
          }
          // Walls: along each edge where the height beyond the edge is higher than this piece's
          // (a groove cutting through another's pile-up, an abrupt end), this, the lower piece,
          // raises a wall up to it. The height beyond is extrapolated to the edge from two points
          // outside it. Whether there is a step is asked at the edge's midpoint, or, on an edge
          // along a kink's cut (both ends on it), just inside its ends: a curved jump (a handover in
          // a corner's cap) is cut along chords, whose midpoints lie up to 1e-4 mm off the curve at
          // the automatic cell, more than the points asked beyond (jump_step); its ends lie on it.
          if (jumpy) {
            Vec3d bc;
            Vec3d nc;
            place(Vtx{c, 0u, {}}, bc, nc);
            for (size_t k = 0; k < m; ++k) {
              const size_t k1 = (k + 1) % m;
              const Vec2d a = poly[k].uv, b = poly[k1].uv, mid = (a + b) * 0.5;
              Vec2d n(b.y - a.y, a.x - b.x);
              const double ln = std::hypot(n.x, n.y);
              if (!(ln > 0)) continue;
              n = n / ln;
              if ((mid.x - c.x) * n.x + (mid.y - c.y) * n.y < 0) n = n * -1.0;
              // Where the two samples straddle another jump (a slot narrower than a few hundred
              // nanometres runs alongside the edge: a scratch faded nearly to nothing through a
              // pile-up), the line through them would reach as far above the far side as the slot
              // is deep, and the wall would stand up as a fin above the surface (22 um above a
              // pile-up in the clusters fuzzer's c62_5). There the nearer sample is the height
              // beyond, within its slope times jump_step of it.
              auto beyond = [&](Vec2d q) {
                const double h1 = heightAt(q + n * jump_step), h2 = heightAt(q + n * (2.0 * jump_step));
                return std::fabs(h1 - h2) > kStraddle * jump_tol ? h1 : 2.0 * h1 - h2;
              };
              bool chord = false;  // (values are read after the merge above, which keeps them)
              for (size_t fi = h_lo; fi < h_hi && !chord; ++fi) chord = poly[k].f[fi] == 0 && poly[k1].f[fi] == 0;
              const Vec2d a1 = a + (b - a) * 0.01, b1 = b + (a - b) * 0.01;
              const double step_mid = beyond(mid) - insideHeight(mid, c, hc);
              const double step = chord ? std::max(step_mid, std::min(beyond(a1) - insideHeight(a1, c, hc),
                                                                      beyond(b1) - insideHeight(b1, c, hc)))
                                        : step_mid;
              if (!(step > jump_tol)) continue;
              const double ta = std::max(hv[k], beyond(a)), tb = std::max(hv[k1], beyond(b));
              const Vec3d A0 = P[k], B0 = P[k1], A1 = Bs[k] + N[k] * ta, B1 = Bs[k1] + N[k1] * tb;
              const Vec3d inward = bc - (Bs[k] + Bs[k1]) * 0.5;  // the wall faces the lower piece
              auto wall = [&](Vec3d p0, Vec3d p1, Vec3d p2, Vec2f u0, Vec2f u1, Vec2f u2, double h0, double h1, double h2) {
                Vec3d g = cross(p1 - p0, p2 - p0);
                const double ee = std::max(dot(p1 - p0, p1 - p0), dot(p2 - p0, p2 - p0));
                if (!(length(g) > 1e-10 * ee)) return;
                if (dot(g, inward) < 0) {
                  std::swap(p1, p2);
                  std::swap(u1, u2);
                  std::swap(h1, h2);
                  g = -g;
                }
                const Vec3f nf(g / length(g));
                const uint32_t a = out.vertex(Vec3f(p0), u0, nf, float(h0));
                const uint32_t b = out.vertex(Vec3f(p1), u1, nf, float(h1));
                out.triangle(a, b, out.vertex(Vec3f(p2), u2, nf, float(h2)));
              };
              wall(A0, B0, B1, T[k], T[k1], T[k1], hv[k], hv[k1], tb);
              wall(A0, B1, A1, T[k], T[k1], T[k], hv[k], tb, ta);
            }
          }
          // The facet's normal in the triangle's plane (the piece's area vector, so that a sliver of
          // it does not take its direction from the heights' rounding), then turned with the
          // interpolated normal at each vertex.
          Vec3d nf(0.0);
          for (size_t k = 1; k + 1 < m; ++k) nf += cross(F[k] - F[0], F[k + 1] - F[0]);
          if (!(length(nf) > 0)) continue;
          nf = nf / length(nf);
          if (dot(nf, pt.ng) < 0) nf = -nf;
          // The fan's triangles share the polygon's vertices, each added when a triangle first
          // uses it (its normal is the same in every triangle of the piece).
          shared.assign(m, kNoVertex);
          for (size_t k = 1; k + 1 < m; ++k) {
            size_t id[3] = {0, k, k + 1};
            if (flip) std::swap(id[1], id[2]);
            const Vec3d e1 = P[id[1]] - P[id[0]], e2 = P[id[2]] - P[id[0]];
            const double ee = std::max(dot(e1, e1), dot(e2, e2));
            if (!(length(cross(e1, e2)) > 1e-10 * ee)) continue;  // degenerate sliver
            uint32_t vi[3];
            for (int j = 0; j < 3; ++j) {
              const size_t v = id[j];
              if (shared[v] == kNoVertex)
                shared[v] = out.vertex(Vec3f(P[v]), T[v], Vec3f(normalize(turn(pt.ng, N[v], nf))), float(hv[v]));
              vi[j] = shared[v];
            }
            out.triangle(vi[0], vi[1], vi[2]);
          }
        }
      }
    }
  });
  size_t nt = kept.size(), nv = 3 * kept.size(), capped = 0;
  for (const Soup& sp : soups) {
    nt += sp.triangles;
    nv += sp.vertices;
    capped += sp.capped;
  }
  if (nt > opt.max_triangles)
    throw std::runtime_error("the scratch geometry would exceed " + std::to_string(opt.max_triangles) + " triangles");
  // Per vertex: position, normal, UV and height (36 bytes). Per triangle: indices and mm per UV
  // (16), the renderer's frame (40) and Embree's BVH with its build (about 140, measured: the door's
  // 20.7 million triangles peaked at 5.75 GB with 2.0 vertices per triangle).
  const uint64_t need = uint64_t(nv) * 36 + uint64_t(nt) * (16 + 40 + 140);
  if (opt.max_bytes > 0 && need > opt.max_bytes)
    throw std::runtime_error("the cut mesh of " + std::to_string(nt) + " triangles would need about " +
                             formatBytes(need) + ", more than the " + formatBytes(opt.max_bytes) +
                             " this process may use");
  if (stats) {
    stats->triangles = nt;
    stats->part_triangles_cut = cut.size();
    stats->cells_capped = capped;
    stats->cell_mm = std::max(du, dv);
  }
  TriangleMesh out;
  if (opt.count_only) return out;
  out.source = part.source + "+scratches";
  // The kept triangles first, then each block's, in block order; the blocks are copied into place
  // on all threads (one thread copying 20 million triangles, with the kernel paging in the new
  // arrays, took 3 s of the door's 17 on 2 cores).
  std::vector<size_t> vbase(nblocks + 1), ibase(nblocks + 1);
  vbase[0] = 3 * kept.size();
  ibase[0] = 3 * kept.size();
  for (size_t b = 0; b < nblocks; ++b) {
    vbase[b + 1] = vbase[b] + soups[b].positions.size();
    ibase[b + 1] = ibase[b] + soups[b].indices.size();
  }
  // One array at a time, each block's part of it freed once copied, so that the peak holds the
  // blocks and one array more rather than two copies of the mesh.
  auto gather = [&](auto& dst, size_t n, auto member, const std::vector<size_t>& at) {
    resizeInParallel(dst, n);
    parallelFor(nblocks, [&](size_t b) {
      auto& src = soups[b].*member;
      if constexpr (std::is_same_v<std::decay_t<decltype(src)>, std::vector<uint32_t>>) {
        const uint32_t shift = uint32_t(vbase[b]);  // the block's vertices' place in the mesh
        for (size_t k = 0; k < src.size(); ++k) dst[at[b] + k] = shift + src[k];
      } else {
        std::copy(src.begin(), src.end(), dst.begin() + at[b]);
      }
      std::decay_t<decltype(src)>().swap(src);
    });
  };
  out.positions.reserve(nv + 1);  // the room past the last vertex that Embree reads (render/scene.cpp)
  gather(out.positions, nv, &Soup::positions, vbase);
  gather(out.uvs, nv, &Soup::uvs, vbase);
  gather(out.normals, nv, &Soup::normals, vbase);
  gather(out.heights, nv, &Soup::heights, vbase);
  gather(out.indices, 3 * nt, &Soup::indices, ibase);
  // The kept part triangles, each with its own three vertices, come first.
  for (size_t q = 0; q < kept.size(); ++q) {
    const uint32_t* id = &part.indices[3 * kept[q]];
    const Vec3f g = normalize(cross(part.positions[id[1]] - part.positions[id[0]], part.positions[id[2]] - part.positions[id[0]]));
    for (int k = 0; k < 3; ++k) {
      const size_t v = 3 * q + k;
      out.positions[v] = part.positions[id[k]];
      out.uvs[v] = part.uvs[id[k]];
      out.normals[v] = has_normals ? part.normals[id[k]] : g;
      out.heights[v] = 0.0f;
      out.indices[v] = uint32_t(v);
    }
  }
  // The chart's scale: each cut triangle keeps its part triangle's, as render/displacement.cpp's
  // children do. Measured on the cut mesh, a groove's wall took the stretch of its slope (1.3 on a
  // 40 degree wall), and a dent's bump on it was looked up that much farther from its centre
  // (docs/grooves.md, "Reference and baseline").
  if (part.mmPerUv.size() == part.triangleCount()) {
    std::vector<size_t> tbase(nblocks + 1);
    for (size_t b = 0; b <= nblocks; ++b) tbase[b] = ibase[b] / 3;
    gather(out.mmPerUv, nt, &Soup::chart, tbase);
    for (size_t q = 0; q < kept.size(); ++q) out.mmPerUv[q] = part.mmPerUv[kept[q]];
  } else {
    out.computeMmPerUv();
  }
  return out;
}

}  // namespace dg
