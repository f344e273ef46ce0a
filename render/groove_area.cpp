#include "render/groove_area.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace dg::groove::area {

double Poly::area() const {
  // The shoelace sum over the edges v[i] -> v[i + 1], the closing edge last (no modulo: this is
  // called for every polygon the clipping makes).
  double a = 0;
  for (int i = 0; i + 1 < n; ++i) {
    const Vec2d& p = v[size_t(i)];
    const Vec2d& q = v[size_t(i + 1)];
    a += p.x * q.y - q.x * p.y;
  }
  if (n > 0) {
    const Vec2d& p = v[size_t(n - 1)];
    const Vec2d& q = v[0];
    a += p.x * q.y - q.x * p.y;
  }
  return 0.5 * a;
}

void Poly::extend(Vec2d& lo, Vec2d& hi) const {
  for (int i = 0; i < n; ++i) {
    const Vec2d& q = v[size_t(i)];
    lo = Vec2d(std::min(lo.x, q.x), std::min(lo.y, q.y));
    hi = Vec2d(std::max(hi.x, q.x), std::max(hi.y, q.y));
  }
}

namespace {

// The clipping of p by the sign of f[i] (one value per vertex, f <= 0 kept): the vertices kept, in
// order, and a new vertex where an edge's ends have strictly opposite signs. The values are taken
// once per vertex (the clipping is a fifth of a dense cluster's instructions).
inline void clipBy(const Poly& p, const double* f, Poly& out) {
  out.n = 0;
  for (int i = 0; i < p.n; ++i) {
    const int j = i + 1 < p.n ? i + 1 : 0;
    const double fs = f[i], fe = f[j];
    const Vec2d& s = p.v[size_t(i)];
    if (fs <= 0) out.push(s);
    if ((fs < 0 && fe > 0) || (fs > 0 && fe < 0)) {
      const Vec2d& e = p.v[size_t(j)];
      double t = fs / (fs - fe);
      out.push(s + (e - s) * t);
    }
  }
  if (out.n < 3) out.n = 0;
}

}  // namespace

Poly clip(const Poly& p, Vec2d a, double c, bool strict) {
  Poly out;
  if (p.n == 0) return out;
  if (std::fabs(a.x) + std::fabs(a.y) < 1e-12) {
    // A constant: all or nothing (ties between identical planes go by `strict`).
    bool keep = strict ? c < -1e-13 : c <= 1e-13;
    return keep ? p : out;
  }
  double f[Poly::kMaxVertices];
  bool any_in = false, any_out = false;
  for (int i = 0; i < p.n; ++i) {
    const Vec2d& s = p.v[size_t(i)];
    f[i] = a.x * s.x + a.y * s.y + c;
    any_in = any_in || f[i] <= 0;
    any_out = any_out || f[i] > 0;
  }
  // Wholly inside: every vertex kept, no new one (an edge changes sign only through a value > 0).
  if (!any_out) {
    if (p.n >= 3) out = p;
    return out;
  }
  if (!any_in) return out;  // wholly outside: nothing kept
  clipBy(p, f, out);
  return out;
}

namespace {

// The half-plane left of the directed edge a -> b (the inside of a counter-clockwise polygon) as
// (n, c) with n.p + c <= 0 inside. False for a degenerate edge, which bounds nothing.
inline bool edgeHalfPlane(Vec2d a, Vec2d b, Vec2d& n, double& c) {
  n = Vec2d(b.y - a.y, a.x - b.x);  // outward normal of a counter-clockwise edge
  c = -(n.x * a.x + n.y * a.y);
  return std::fabs(n.x) + std::fabs(n.y) >= 1e-12;
}

struct BBox {
  Vec2d lo{1e300, 1e300}, hi{-1e300, -1e300};
  BBox(Vec2d l, Vec2d h) : lo(l), hi(h) {}
  explicit BBox(const Poly& p) { p.extend(lo, hi); }
  bool overlaps(const BBox& o) const { return lo.x <= o.hi.x && o.lo.x <= hi.x && lo.y <= o.hi.y && o.lo.y <= hi.y; }
};

void reverse(Poly& p) { std::reverse(p.v, p.v + p.n); }

// Below this (mm^2) a piece or fragment is dropped as a sliver.
constexpr double kSliver = 1e-16;

}  // namespace

Poly intersect(const Poly& p, const Poly& q) {
  Poly r = p;
  for (int i = 0; i < q.n && !r.empty(); ++i) {
    Vec2d n;
    double c;
    if (edgeHalfPlane(q.v[size_t(i)], q.v[size_t((i + 1) % q.n)], n, c)) r = clip(r, n, c);
  }
  return r;
}

Vec3d Plane::normal() const {
  Vec3d n(-g.x, -g.y, 1.0);
  return n / length(n);
}

double area(const std::vector<Poly>& frags) {
  double a = 0;
  for (const Poly& f : frags) a += f.area();
  return a;
}

bool centroid(const std::vector<Poly>& frags, Vec2d& c) {
  // Each fragment's, by area (fan triangles from its first vertex).
  Vec2d m(0, 0);
  double a = 0;
  for (const Poly& f : frags)
    for (int i = 1; i + 1 < f.n; ++i) {
      const Vec2d v0 = f.v[0], v1 = f.v[size_t(i)], v2 = f.v[size_t(i) + 1];
      const double t = 0.5 * cross(v1 - v0, v2 - v0);
      m = m + (v0 + v1 + v2) * (t / 3.0);
      a += t;
    }
  if (!(a > 0)) return false;
  c = m * (1.0 / a);
  return true;
}

void subtract(std::vector<Poly>& frags, const Poly& s, size_t cap, size_t& dropped) {
  if (s.empty()) return;
  const BBox sb(s);
  bool any = false;
  for (const Poly& f : frags)
    if ((any = BBox(f).overlaps(sb))) break;
  if (!any) return;
  thread_local std::vector<Poly> out;  // swapped with frags below: both buffers are reused
  out.clear();
  for (const Poly& f : frags) {
    if (!BBox(f).overlaps(sb)) {
      out.push_back(f);
      continue;
    }
    // f minus s: the parts of f outside each edge of s in turn, then what is left is inside s.
    Poly rest = f;
    for (int i = 0; i < s.n && !rest.empty(); ++i) {
      Vec2d n;
      double c;
      if (!edgeHalfPlane(s.v[size_t(i)], s.v[size_t((i + 1) % s.n)], n, c)) continue;
      // The part outside the edge is clip(rest, -n, -c), whose values are exactly the negated
      // ones (IEEE rounding is symmetric): both parts from one evaluation per vertex.
      double fin[Poly::kMaxVertices], fout[Poly::kMaxVertices];
      int below = 0, above = 0;
      for (int k = 0; k < rest.n; ++k) {
        const Vec2d& q = rest.v[size_t(k)];
        fin[k] = n.x * q.x + n.y * q.y + c;
        below += fin[k] < 0;
        above += fin[k] > 0;
      }
      // With fewer than 3 vertices on the line, one side's part is empty when no vertex lies
      // strictly on that side, and the other's is then all of rest.
      const bool few_on_line = rest.n - below - above < 3;
      if (few_on_line && above == 0) continue;  // nothing outside this edge: rest stays
      if (few_on_line && below == 0) {          // wholly outside: all of rest goes out
        if (rest.area() > kSliver) out.push_back(rest);
        break;
      }
      for (int k = 0; k < rest.n; ++k) fout[k] = -fin[k];
      Poly part;
      clipBy(rest, fout, part);
      if (!part.empty() && part.area() > kSliver) out.push_back(part);
      clipBy(rest, fin, part);
      rest = part;
    }
  }
  if (out.size() > cap) {
    std::nth_element(out.begin(), out.begin() + long(cap), out.end(),
                     [](const Poly& a, const Poly& b) { return a.area() > b.area(); });
    dropped += out.size() - cap;
    out.resize(cap);
  }
  frags.swap(out);
}

// ------------------------------------------------------------------------------------------------
// Building the pieces
// ------------------------------------------------------------------------------------------------

namespace {

// A zone of one groove: where its height is one plane (zero outside its facets).
struct Zone {
  HalfPlane h[6];
  int nh = 0;
  Plane plane;
  int layer = 0;
  bool zero = true;
  // Zones across the groove (inside its length, where r > 0): the first n_inside half-planes say
  // so, and the zone is where the profile coordinate u = b / r lies in [ulo, uhi].
  bool across = false;
  int n_inside = 0;
  double ulo = -1e300, uhi = 1e300;
  void add(Vec2d a, double c) { h[nh++] = {a, c}; }
};

void zonesOf(const Groove& g, std::vector<Zone>& zones) {
  zones.clear();
  const std::vector<Vec2d>& P = *g.pts;
  const bool has_lo = g.t_lo > -1e29, has_hi = g.t_hi < 1e29;
  // t(p) = t0 + tdir.p; b(p) = b0 + bdir.p; r(p) = 1 + rho t(p).
  if (has_lo) {  // before the start: t <= t_lo
    Zone z;
    z.add(g.tdir, g.t0 - g.t_lo);
    zones.push_back(z);
  }
  if (has_hi) {  // past the end: t >= t_hi
    Zone z;
    z.add(g.tdir * -1.0, g.t_hi - g.t0);
    zones.push_back(z);
  }
  Zone inside;  // t_lo <= t <= t_hi
  if (has_lo) inside.add(g.tdir * -1.0, g.t_lo - g.t0);
  if (has_hi) inside.add(g.tdir, g.t0 - g.t_hi);
  {  // r <= 0: the cross-section has faded out
    Zone z = inside;
    z.add(g.tdir * g.rho, 1 + g.rho * g.t0);
    zones.push_back(z);
  }
  inside.add(g.tdir * -g.rho, -(1 + g.rho * g.t0));  // r >= 0
  inside.across = true;
  inside.n_inside = inside.nh;
  // b >= r x_j  <=>  -(bdir - x_j rho tdir).p - (b0 - x_j (1 + rho t0)) <= 0
  auto vertexLine = [&](double xj, bool right_of, Zone& z) {
    Vec2d a = g.bdir - g.tdir * (xj * g.rho);
    double c = g.b0 - xj * (1 + g.rho * g.t0);
    if (right_of)
      z.add(a * -1.0, -c);
    else
      z.add(a, c);
  };
  {
    Zone z = inside;
    vertexLine(P.front().x, false, z);
    z.uhi = P.front().x;
    zones.push_back(z);
  }
  for (size_t j = 0; j + 1 < P.size(); ++j) {
    double dx = P[j + 1].x - P[j].x;
    if (!(dx > 1e-12)) continue;  // a vertical facet covers no area
    double s = (P[j + 1].y - P[j].y) / dx;
    double cj = P[j].y - s * P[j].x;
    if (cj == 0 && s == 0) continue;  // a flat facet on the base plane: part of the zero zones
    Zone z = inside;
    vertexLine(P[j].x, true, z);
    vertexLine(P[j + 1].x, false, z);
    z.ulo = P[j].x;
    z.uhi = P[j + 1].x;
    // h = r c_j + s b = c_j (1 + rho t0) + s b0 + (c_j rho tdir + s bdir).p
    z.plane.z0 = cj * (1 + g.rho * g.t0) + s * g.b0;
    z.plane.g = g.tdir * (cj * g.rho) + g.bdir * s;
    z.layer = g.layer && j < g.layer->size() ? (*g.layer)[j] : 0;
    z.zero = false;
    zones.push_back(z);
  }
  // Flat facets inside the profile are left out above, so the zero zones are: before, after,
  // faded, left of the first vertex, right of the last, and (implicitly) flat facets. Those are
  // added as one more zone per flat facet so that the zones tile the plane.
  for (size_t j = 0; j + 1 < P.size(); ++j) {
    double dx = P[j + 1].x - P[j].x;
    if (!(dx > 1e-12)) continue;
    double s = (P[j + 1].y - P[j].y) / dx;
    double cj = P[j].y - s * P[j].x;
    if (!(cj == 0 && s == 0)) continue;
    Zone z = inside;
    vertexLine(P[j].x, true, z);
    vertexLine(P[j + 1].x, false, z);
    z.ulo = P[j].x;
    z.uhi = P[j + 1].x;
    zones.push_back(z);
  }
  {
    Zone z = inside;
    vertexLine(P.back().x, true, z);
    z.ulo = P.back().x;
    zones.push_back(z);
  }
}

// Whether the (plain) groove g is there at p: within its length and not faded out; r its scale.
inline bool existsAt(const Groove& g, Vec2d p, double& r) {
  const double t = g.t0 + g.tdir.x * p.x + g.tdir.y * p.y;
  r = 1 + g.rho * t;
  return !(t < g.t_lo || t > g.t_hi || !(r > 0));
}

// The height of the (plain) groove g at p, or 0 outside its length, where it has faded, and
// beyond its profile.
double grooveHeight(const Groove& g, Vec2d p) {
  double r;
  if (!existsAt(g, p, r)) return 0;
  double u = (g.b0 + g.bdir.x * p.x + g.bdir.y * p.y) / r;
  const std::vector<Vec2d>& P = *g.pts;
  if (u <= P.front().x || u >= P.back().x) return 0;
  size_t j = size_t(std::upper_bound(P.begin(), P.end(), u, [](double x, const Vec2d& q) { return x < q.x; }) - P.begin());
  j = std::min(std::max<size_t>(j, 1), P.size() - 1);
  const Vec2d &q0 = P[j - 1], &q1 = P[j];
  return q1.x > q0.x ? r * (q0.y + (q1.y - q0.y) * (u - q0.x) / (q1.x - q0.x)) : r * q0.y;
}

// The part of a corner's groove whose domain holds p (the first, on a boundary), or null.
const Groove* partAt(const Groove& g, Vec2d p) {
  for (const Groove& q : *g.parts)
    if (inDomain(q, p)) return &q;
  return nullptr;
}

}  // namespace

bool inDomain(const Groove& q, Vec2d p) {
  for (int k = 0; k < q.n_dom; ++k)
    if (!q.dom[k].holds(p)) return false;
  return true;
}

void Surface::indexParts(const Poly& region) {
  part_index_.resize(std::max(part_index_.size(), grooves_.size()));
  Vec2d rlo(1e300, 1e300), rhi(-1e300, -1e300);
  region.extend(rlo, rhi);
  rlo = rlo - Vec2d(kPartMargin, kPartMargin);
  rhi = rhi + Vec2d(kPartMargin, kPartMargin);
  Poly grown;
  grown.push(rlo);
  grown.push(Vec2d(rhi.x, rlo.y));
  grown.push(rhi);
  grown.push(Vec2d(rlo.x, rhi.y));
  for (size_t gi = 0; gi < grooves_.size(); ++gi) {
    PartIndex& ix = part_index_[gi];
    ix.box_lo.clear();
    ix.box_hi.clear();
    const Groove& g = grooves_[gi];
    if (!g.parts || g.parts->size() < kPartsIndexed) continue;
    ix.lo = rlo;
    ix.hi = rhi;
    ix.inv = Vec2d(kPartBins / std::max(rhi.x - rlo.x, 1e-300), kPartBins / std::max(rhi.y - rlo.y, 1e-300));
    const size_t np = g.parts->size();
    ix.box_lo.resize(np);
    ix.box_hi.resize(np);
    ix.start.assign(size_t(kPartBins * kPartBins + 1), 0);
    for (int pass = 0; pass < 2; ++pass) {
      if (pass == 1) {
        for (size_t b = 1; b < ix.start.size(); ++b) ix.start[b] += ix.start[b - 1];
        ix.list.resize(ix.start.back());
      }
      for (size_t q = 0; q < np; ++q) {
        Vec2d& lo = ix.box_lo[q];
        Vec2d& hi = ix.box_hi[q];
        if (pass == 0) {
          const Groove& part = (*g.parts)[q];
          Poly d = grown;
          // Each domain line moved out by the margin: a domain of no width (two lines that meet
          // along their length) still has a box, where clipping a cell to it can leave a sliver.
          for (int k = 0; k < part.n_dom && !d.empty(); ++k) {
            const HalfPlane& h = part.dom[k];
            d = clip(d, h.a, h.c - kPartMargin * std::hypot(h.a.x, h.a.y));
          }
          lo = Vec2d(1e300, 1e300);
          hi = Vec2d(-1e300, -1e300);
          if (d.empty()) continue;
          d.extend(lo, hi);
          lo = lo - Vec2d(kPartMargin, kPartMargin);
          hi = hi + Vec2d(kPartMargin, kPartMargin);
        }
        if (!(lo.x <= hi.x)) continue;
        const int x0 = partBin(ix, lo.x, 0), x1 = partBin(ix, hi.x, 0);
        const int y0 = partBin(ix, lo.y, 1), y1 = partBin(ix, hi.y, 1);
        for (int y = y0; y <= y1; ++y)
          for (int x = x0; x <= x1; ++x) {
            const size_t b = size_t(y * kPartBins + x);
            if (pass == 0)
              ++ix.start[b + 1];
            else
              ix.list[ix.start[b]++] = uint32_t(q);
          }
      }
    }
    // (The fill moved each start to the next bin's; back by one bin.)
    for (size_t b = ix.start.size() - 1; b > 0; --b) ix.start[b] = ix.start[b - 1];
    ix.start[0] = 0;
  }
  parts_indexed_ = true;
}

int Surface::partBin(const PartIndex& ix, double v, int axis) {
  const double f = axis == 0 ? (v - ix.lo.x) * ix.inv.x : (v - ix.lo.y) * ix.inv.y;  // monotone in v
  if (!(f > 0)) return 0;
  if (!(f < double(kPartBins - 1))) return kPartBins - 1;
  return int(f);
}

const Groove* Surface::partOf(size_t gi, Vec2d p) const {
  const Groove& g = grooves_[gi];
  if (!parts_indexed_) return partAt(g, p);
  const PartIndex& ix = part_index_[gi];
  if (ix.box_lo.empty()) return partAt(g, p);  // (few parts: not indexed)
  // Outside the grown region (a point the surface was not built for): every part.
  if (!(p.x >= ix.lo.x && p.x <= ix.hi.x && p.y >= ix.lo.y && p.y <= ix.hi.y)) return partAt(g, p);
  const size_t b = size_t(partBin(ix, p.y, 1) * kPartBins + partBin(ix, p.x, 0));
  for (uint32_t k = ix.start[b]; k < ix.start[b + 1]; ++k) {
    const size_t q = ix.list[k];
    if (!BBox(ix.box_lo[q], ix.box_hi[q]).overlaps(BBox(p, p))) continue;
    if (inDomain((*g.parts)[q], p)) return &(*g.parts)[q];
  }
  return nullptr;
}

bool Surface::heightOf(size_t gi, Vec2d p, double& h) const {
  const Groove& g = grooves_[gi];
  const Groove* q = g.parts ? partOf(gi, p) : &g;
  if (!q) return false;
  h = grooveHeight(*q, p);
  return true;
}

double Surface::heightAt(Vec2d p) const {
  double lo = 0, hi = 0;
  for (size_t gi = 0; gi < grooves_.size(); ++gi) {
    double h;
    if (!heightOf(gi, p, h)) continue;
    lo = std::min(lo, h);
    hi = std::max(hi, h);
  }
  return lo < 0 ? lo : hi;
}

bool Surface::above(Vec2d p, double z) const {
  // The composite is the lowest groove height where one is below the base, else the highest: once
  // a groove is below the base, the answer is no for z >= 0, and for z < 0 as soon as the lowest so
  // far is not above z (it only falls). NaN heights are passed over, as std::min and std::max
  // pass them over in heightAt.
  double lo = 0, hi = 0;
  for (size_t gi = 0; gi < grooves_.size(); ++gi) {
    double h;
    if (!heightOf(gi, p, h)) continue;
    if (h < 0) {
      lo = std::min(lo, h);
      if (z >= 0 || lo <= z) return false;
    } else {
      hi = std::max(hi, h);
    }
  }
  return (lo < 0 ? lo : hi) > z;
}

namespace {

Vec2d unitOf(Vec2d v) {
  const double l = std::hypot(v.x, v.y);
  return l > 0 ? v * (1.0 / l) : v;
}

// The signed turn (rad) from direction ta to tb.
double turnOf(Vec2d ta, Vec2d tb) {
  ta = unitOf(ta);
  tb = unitOf(tb);
  return std::atan2(ta.x * tb.y - ta.y * tb.x, ta.x * tb.x + ta.y * tb.y);
}

// The sign of the first leg's b on a corner's outer side: away from where the second leg goes (tb
// its direction). (Where the path turns back, within kMaxCornerTurn of a half turn, the second
// leg's direction no longer tells the sides apart: the turn's sign does, with the side that b is
// measured to.)
double outerOf(const Groove& in, Vec2d tb, double turn) {
  if (std::fabs(turn) > kMaxCornerTurn) return turn * (in.tdir.x * in.bdir.y - in.tdir.y * in.bdir.x) > 0 ? -1.0 : 1.0;
  return (in.bdir.x * tb.x + in.bdir.y * tb.y) > 0 ? -1.0 : 1.0;
}

// The refinement of a fan's sectors about a straight candidate's axis (appendFan): the ratio of
// consecutive edges' angles from the axis, and the least phi_0 refined: below it the parabola's
// strip at the partition's reach is under a thousandth of that reach wide (a path going back over
// itself has its other pass a rounding away from each bend's vertex: refined, the accuracy test's
// `recurve` took 1.75 times its time).
constexpr double kFanRefineRatio = 1.5;
constexpr double kFanRefineMin = 1e-3;

// Another candidate's centre line as a fan sees it: the unit direction from the line through the
// vertex (the parabola's axis) and the line's distance from the vertex.
struct FanAxis {
  Vec2d dir;
  double near = 0;
};

// The round outer side of a corner at v where the path turns by `turn` from leg `in` to a leg
// along tb: sectors no wider than max_sector, each a straight groove through v (with `like`'s
// profile, layers and id) across its middle ray, clipped to its wedge and stretched by 1 /
// cos(half the sector) so that on the wedge's edges its offset is the exact distance from v.
//
// `axes` (optional): other candidates' centre lines near v (FanAxis: the direction from each line
// through v, and its distance `near` from v), with `reach` the largest distance from v that the
// partition covers. Where a fan and a straight candidate compete, the points nearer the
// vertex than the line lie inside a parabola (focus v, directrix the line), and each sector cuts
// it along a chord: the cut b_fan = b_line is linear, exact on the sector's two edges. Where the
// line passes close to v the parabola is narrow (at distance r it spans sqrt(2 near / r) rad each
// side of its axis) and a sector several times wider than that cuts it far from the curve: on the
// corner fuzzer's c60_0, a path's last leg 0.7 um from one of its vertices, a strip 15 um wide of
// the cap (a tilted tool's outer half, 20 um high) went to the leg's flat side. About each such
// axis the sectors' edges then lie at +-phi_0 q^k (phi_0 = sqrt(2 near / reach), where the
// parabola leaves the partition, q = kFanRefineRatio) out to where the steps reach max_sector, so
// that no chord spans more than a ratio q in angle from the axis. (Where phi_0 < kFanRefineMin the
// whole strip is too thin to matter, and the fan is left as it is.)
void appendFan(const Groove& in, const Groove& like, Vec2d v, Vec2d tb, double turn, double max_sector,
               std::vector<Groove>& parts, const std::vector<FanAxis>* axes = nullptr, double reach = 0) {
  const double outer = outerOf(in, tb, turn);
  // The cap's rays run from the first leg's outer normal to the second's, turning with the path
  // (with the legs on one line, by a half turn: the half disc beyond the vertex).
  const Vec2d na = unitOf(in.bdir) * outer;
  const bool on_one_line = std::fabs(turn) >= kPiTurn - kOneLineTurn;
  const double sweep = on_one_line ? (turn > 0 ? kPiTurn : -kPiTurn) : turn;
  // Where the two legs lie on one line, the explicit geometry measures the offset from the vertex
  // with the first leg's sides (the closest point's tangent is the first leg's), and the cap takes
  // on each side of its line the profile's half on that side: an even number of sectors, those
  // past the middle with b the other way. (Short of that, the vertex's tangent is the legs' mean,
  // across the first leg, and the whole cap takes the outer half.)
  // The sectors' edges, as angles from na in the sense of the sweep: uniform, or refined about the
  // axes (above).
  thread_local std::vector<double> edges;
  edges.clear();
  const double dir = sweep < 0 ? -1.0 : 1.0, span = std::fabs(sweep);
  if (axes)
    for (const FanAxis& ax : *axes) {
      const Vec2d a = ax.dir;
      // The axis's angle from na, turning with the sweep, in [-pi, pi] (and a turn either way of
      // it: an axis just past a half turn's end, at -pi + x, refines that end's sectors).
      const double alpha = dir * std::atan2(na.x * a.y - na.y * a.x, na.x * a.x + na.y * a.y);
      const double phi0 = std::sqrt(2 * ax.near / reach);
      if (!(phi0 >= kFanRefineMin) || !(phi0 < max_sector / (kFanRefineRatio - 1))) continue;
      for (double phi = phi0; phi * (kFanRefineRatio - 1) < max_sector; phi *= kFanRefineRatio)
        for (double at : {alpha - 2 * kPiTurn, alpha, alpha + 2 * kPiTurn})
          for (double e : {at - phi, at + phi})
            if (e > 0 && e < span) edges.push_back(e);
    }
  int n = 0;
  if (edges.empty()) {
    n = std::max(1, int(std::ceil(span / max_sector - 1e-9)));
    if (on_one_line) n += n % 2;
  } else {
    // Required edges (the ends, the middle where the legs lie on one line, the refined ones), then
    // each gap split evenly into steps no wider than max_sector.
    edges.push_back(0.0);
    edges.push_back(span);
    if (on_one_line) edges.push_back(0.5 * span);
    std::sort(edges.begin(), edges.end());
    thread_local std::vector<double> all;
    all.assign(1, 0.0);
    for (size_t i = 1; i < edges.size(); ++i) {
      const double gap = edges[i] - all.back();
      if (!(gap > 1e-9)) continue;  // (the same edge twice)
      const int m = std::max(1, int(std::ceil(gap / max_sector - 1e-9)));
      const double start = all.back();
      for (int j = 1; j < m; ++j) all.push_back(start + gap * j / m);
      all.push_back(edges[i]);
    }
    all.back() = span;
    edges.swap(all);
    n = int(edges.size()) - 1;
  }
  for (int k = 0; k < n; ++k) {
    // The sector's half-width and middle ray (signed with the sweep).
    double half = 0.5 * sweep / n, ang = half * (2 * k + 1);
    bool past_middle = 2 * k >= n;
    if (!edges.empty()) {
      half = 0.5 * dir * (edges[size_t(k) + 1] - edges[size_t(k)]);
      ang = 0.5 * dir * (edges[size_t(k) + 1] + edges[size_t(k)]);
      past_middle = edges[size_t(k)] + edges[size_t(k) + 1] > span;  // (its middle past the fan's)
    }
    const double stretch = 1 / std::cos(half), tan_half = std::tan(std::fabs(half));
    const double side = on_one_line && past_middle ? -1.0 : 1.0;
    const Vec2d u(na.x * std::cos(ang) - na.y * std::sin(ang), na.x * std::sin(ang) + na.y * std::cos(ang));
    const Vec2d w(-u.y, u.x);  // across the ray
    Groove c = like;
    c.parts = nullptr;
    c.rho = 0;
    c.t_lo = -1e30;
    c.t_hi = 1e30;
    // b = outer (p - v).u / cos(half): the outer offset, on the sector's edges exactly its distance
    // from the vertex, as on the legs' end lines.
    c.bdir = u * (side * outer * stretch);
    c.b0 = -(c.bdir.x * v.x + c.bdir.y * v.y);
    c.tdir = w * side;  // (the frame's hand kept)
    c.t0 = -(c.tdir.x * v.x + c.tdir.y * v.y);
    // The wedge |(p - v).w| <= (p - v).u tan(half).
    const Vec2d e1 = w - u * tan_half, e2 = w * -1.0 - u * tan_half;
    c.dom[0] = {e1, -(e1.x * v.x + e1.y * v.y)};
    c.dom[1] = {e2, -(e2.x * v.x + e2.y * v.y)};
    c.n_dom = 2;
    // (The two halves meet along the first leg's line, where their heights differ for an
    // asymmetric profile by a profile's worth along it: not a max of linear functions, so the
    // three samples per edge of Surface::build's step test can miss where it rises.)
    c.has_split = on_one_line;
    if (on_one_line) c.split = {na, -(na.x * v.x + na.y * v.y)};
    parts.push_back(c);
  }
}

// The other side of h: -h.a . p - h.c <= 0.
HalfPlane flip(const HalfPlane& h) { return HalfPlane{h.a * -1.0, -h.c}; }

// Whether h is zero everywhere (the difference or sum of two identical offsets).
bool zero(const HalfPlane& h) { return std::hypot(h.a.x, h.a.y) <= 1e-12 && std::fabs(h.c) <= 1e-12; }

// The point of g at (t, b) = (t, 0).
bool pointAt(const Groove& g, double t, Vec2d& v) {
  const double det = g.tdir.x * g.bdir.y - g.tdir.y * g.bdir.x;
  if (!(std::fabs(det) > 1e-12)) return false;
  const double tt = t - g.t0;
  v = Vec2d((tt * g.bdir.y + g.b0 * g.tdir.y) / det, (-g.b0 * g.tdir.x - tt * g.bdir.x) / det);
  return true;
}

}  // namespace

bool cornerParts(const Groove& in, const Groove& out, double max_sector, std::vector<Groove>& parts) {
  parts.clear();
  const double turn = turnOf(in.tdir, out.tdir);
  if (!(std::fabs(turn) >= 1e-6) || !(max_sector > 0)) return false;
  // The vertex: t = 0 and b = 0 on the leg before it.
  Vec2d v;
  if (!pointAt(in, 0, v)) return false;
  if (std::fabs(turn) >= kPiTurn - kOneLineTurn) {
    // The legs lie on one line: the path goes back along itself. The first leg holds up to the
    // vertex on both sides of its line (the explicit geometry's tie goes to the earlier segment),
    // and the cap is the half disc beyond it.
    Groove a = in;
    a.parts = nullptr;
    a.t_hi = 0;
    a.dom[0] = {in.tdir, in.t0};
    a.n_dom = 1;
    parts.push_back(a);
    appendFan(in, in, v, unitOf(out.tdir), turn, max_sector, parts);
    return true;
  }
  // The legs: each on its side of the bisector, t_in + t_out <= 0 before the corner (the two
  // t's measured from the vertex along each leg; on the bisector they are opposite). Past
  // kMaxCornerTurn that sum is too short for its direction to survive the legs' rounding, and the
  // bisector's normal is the first leg's inner normal turned towards its direction by half of
  // what the turn lacks of a half turn (the turn's own rounding is absolute, about 1e-7 rad).
  HalfPlane before{in.tdir + out.tdir, in.t0 + out.t0};
  if (std::fabs(turn) > kMaxCornerTurn) {
    const double outer = outerOf(in, unitOf(out.tdir), turn);
    const double lack = 0.5 * (kPiTurn - std::fabs(turn));
    const Vec2d n = unitOf(in.tdir) * std::sin(lack) + unitOf(in.bdir) * (-outer * std::cos(lack));
    before = {n, -(n.x * v.x + n.y * v.y)};
  }
  Groove a = in, b = out;
  a.parts = b.parts = nullptr;
  a.t_hi = 0;
  b.t_lo = 0;
  a.dom[0] = before;
  b.dom[0] = flip(before);
  // (and each before or after the vertex along itself: past the end line the cap holds)
  a.dom[1] = {in.tdir, in.t0};
  b.dom[1] = {out.tdir * -1.0, -out.t0};
  a.n_dom = b.n_dom = 2;
  parts.push_back(a);
  parts.push_back(b);
  appendFan(in, in, v, unitOf(out.tdir), turn, max_sector, parts);
  return true;
}

bool chainParts(const std::vector<Groove>& legs, double max_sector, const Poly& bound, std::vector<Groove>& parts,
                const std::vector<size_t>& run_starts) {
  parts.clear();
  const size_t n = legs.size();
  if (n < 2 || !(max_sector > 0) || bound.empty()) return false;
  // The candidates: each leg over its strip, then the sectors of the corner at its end.
  struct Candidate {
    Groove g;  // dom[0, n_dom): where it is a candidate
    HalfPlane b;  // its offset b(p) = b.a . p + b.c
    double e = 0;  // |b| beyond which it is flat over `bound`
  };
  thread_local std::vector<Candidate> cands;
  thread_local std::vector<Groove> fan;
  thread_local std::vector<FanAxis> axes;
  cands.clear();
  auto starts = [&](size_t k) {
    return k == 0 || k == n || std::find(run_starts.begin(), run_starts.end(), k) != run_starts.end();
  };
  for (size_t k = 0; k < n; ++k) {
    Groove g = legs[k];
    g.parts = nullptr;
    g.n_dom = 0;
    // Within its corners' normals (a run's first leg only before its first corner, its last only
    // after its start, a run of one leg everywhere); the interior legs' own ends are those
    // normals, so their t range is left open.
    const bool first = starts(k), last = starts(k + 1);
    if (!first) g.dom[g.n_dom++] = {g.tdir * -1.0, g.t_lo - g.t0};
    if (!last) g.dom[g.n_dom++] = {g.tdir, g.t0 - g.t_hi};
    if (!first && !last) {
      g.t_lo = -1e30;
      g.t_hi = 1e30;
    }
    cands.push_back({g, {g.bdir, g.b0}});
    if (last) continue;
    // Corner k, at the start of leg k + 1.
    const double turn = turnOf(legs[k].tdir, legs[k + 1].tdir);
    if (!std::isfinite(turn)) return false;
    if (!(std::fabs(turn) >= 1e-6)) continue;
    Vec2d v;
    if (!pointAt(legs[k + 1], 0, v)) return false;
    fan.clear();
    // The other legs' centre lines that pass near the vertex (appendFan's axes): each leg but the
    // corner's own two, whose domains end on the fan's edges.
    axes.clear();
    double reach = 0;
    for (int j = 0; j < bound.n; ++j) reach = std::max(reach, std::hypot(bound.v[size_t(j)].x - v.x, bound.v[size_t(j)].y - v.y));
    for (size_t j = 0; j < n; ++j) {
      if (j == k || j == k + 1) continue;
      const double lb = std::hypot(legs[j].bdir.x, legs[j].bdir.y);
      if (!(lb > 0)) continue;
      const double b = (legs[j].bdir.x * v.x + legs[j].bdir.y * v.y + legs[j].b0) / lb;
      axes.push_back({legs[j].bdir * ((b < 0 ? -1.0 : 1.0) / lb), std::fabs(b)});
    }
    // (Past kMaxCornerTurn, a half turn: the fan is the half disc beyond the vertex, as in
    // cornerParts.)
    appendFan(legs[k], legs[k + 1], v, unitOf(legs[k + 1].tdir), turn, max_sector, fan, &axes, reach);
    for (const Groove& c : fan) cands.push_back({c, {c.bdir, c.b0}});
  }
  // The partition of `bound`, one candidate at a time: each takes, within its own domain, the part
  // of every cell where its |b| is below the cell's owner's (or the cell has none yet). A cell
  // keeps the half-planes that cut it from `bound`; one that no longer bounds it is dropped (a
  // convex cell that touches a line along no edge keeps off it as it shrinks).
  struct Cell {
    Poly poly;
    HalfPlane h[2 * Groove::kMaxDom + 1];
    int nh = 0;
    int owner = -1;
    Cell() {}
    // (Copies only the half-planes in use: cells are copied at every cut.)
    Cell(const Cell& o) : poly(o.poly), nh(o.nh), owner(o.owner) { std::copy(o.h, o.h + o.nh, h); }
    Cell& operator=(const Cell& o) {
      if (this != &o) {
        poly = o.poly;
        nh = o.nh;
        owner = o.owner;
        std::copy(o.h, o.h + o.nh, h);
      }
      return *this;
    }
  };
  thread_local std::vector<Cell> cells, next;
  cells.assign(1, Cell{});
  cells[0].poly = bound;
  auto prune = [](Cell& c) {
    int m = 0;
    for (int i = 0; i < c.nh; ++i) {
      const HalfPlane& h = c.h[i];
      const double tol = 1e-9 * (std::fabs(h.a.x) + std::fabs(h.a.y));
      // It bounds the cell only along an edge: two vertices on its line (a line through one
      // vertex alone, such as the fan's through its corner, cuts nothing off).
      // (The clipping can leave a vertex twice: the two must be apart.)
      int on = 0;
      Vec2d first;
      for (int j = 0; j < c.poly.n && on < 2; ++j) {
        const Vec2d& q = c.poly.v[size_t(j)];
        if (!(h.a.x * q.x + h.a.y * q.y + h.c > -tol)) continue;
        if (on == 0) {
          first = q;
          on = 1;
        } else if (std::fabs(q.x - first.x) + std::fabs(q.y - first.y) > 1e-9) {
          on = 2;
        }
      }
      if (on >= 2) c.h[m++] = h;
    }
    c.nh = m;
  };
  bool overflow = false;
  // c cut by h (kept where h holds); false where nothing of area is left. A line that passes
  // within kThinCut of the cell's far side cuts nothing: the cell stays whole on the side of its
  // bulk. Without that, lines that are one line in exact arithmetic (a leg's end normal and the
  // edge of its corner's fan, each computed in its own frame) left strips 1e-9 to 1e-7 mm wide,
  // given to whichever candidate's domain still held them: on the accuracy test's `curl`, 12% of
  // the surface's pieces, and on the fuzzer's p1_11 fins 0.02 mm tall and picometres thin,
  // whose walls stood in the light's way (docs/grooves.md, "Bends").
  auto cut = [&](const Cell& c, const HalfPlane& h, Cell& out) {
    const double lh = std::hypot(h.a.x, h.a.y);
    double beyond = -std::numeric_limits<double>::infinity(), within = beyond;
    for (int j = 0; j < c.poly.n; ++j) {
      const double f = h.a.x * c.poly.v[size_t(j)].x + h.a.y * c.poly.v[size_t(j)].y + h.c;
      beyond = std::max(beyond, f);
      within = std::max(within, -f);
    }
    // (A cell thin across h as a whole goes to the side that holds more of it, so that h and
    // flip(h) never both keep it.)
    if (std::min(beyond, within) <= kThinCut * lh) {
      if (beyond < within) {
        out = c;
        return true;
      }
      if (within < beyond) return false;
    }
    Poly p = clip(c.poly, h.a, h.c);
    if (p.empty() || p.area() <= kSliver) return false;
    out.nh = c.nh;
    out.owner = c.owner;
    std::copy(c.h, c.h + c.nh, out.h);
    out.poly = p;
    // (Lines met again, such as a leg's end normal that is also its corner's first sector's
    // edge, are kept once.)
    bool again = false;
    for (int i = 0; i < out.nh && !again; ++i) {
      const HalfPlane& o = out.h[i];
      const double lo = std::hypot(o.a.x, o.a.y);
      again = std::fabs(h.a.x / lh - o.a.x / lo) + std::fabs(h.a.y / lh - o.a.y / lo) + std::fabs(h.c / lh - o.c / lo) < 1e-12;
    }
    if (!again) out.h[out.nh++] = h;
    prune(out);
    if (out.nh == 2 * Groove::kMaxDom + 1) {  // (a cell with that many sides: give up)
      overflow = true;
      out.nh = 0;
    }
    return true;
  };
  // Beyond e = the cross-section's half-width at the largest scale over `bound`, a candidate is
  // flat: whether it is over a whole cell.
  for (Candidate& cd : cands) {
    double r_max = 0;
    for (int j = 0; j < bound.n; ++j)
      r_max = std::max(r_max, 1 + cd.g.rho * (cd.g.t0 + cd.g.tdir.x * bound.v[size_t(j)].x + cd.g.tdir.y * bound.v[size_t(j)].y));
    cd.e = std::max(std::fabs(cd.g.pts->front().x), std::fabs(cd.g.pts->back().x)) * r_max;
  }
  auto flat = [](const Cell& c, const Candidate& cd) {
    int above = 0, below = 0;
    for (int j = 0; j < c.poly.n; ++j) {
      const double b = cd.b.a.x * c.poly.v[size_t(j)].x + cd.b.a.y * c.poly.v[size_t(j)].y + cd.b.c;
      above += b >= cd.e;
      below += b <= -cd.e;
    }
    return above == c.poly.n || below == c.poly.n;
  };
  for (size_t ci = 0; ci < cands.size() && !overflow; ++ci) {
    const Candidate& cd = cands[ci];
    next.clear();
    for (const Cell& c0 : cells) {
      // Where both are flat (beyond their cross-sections) which one holds makes no difference.
      if (c0.owner >= 0 && flat(c0, cd) && flat(c0, cands[size_t(c0.owner)])) {
        next.push_back(c0);
        continue;
      }
      // A cell wholly outside one of the candidate's domain lines stays whole (as the cuts below
      // would leave it).
      bool outside = false;
      for (int k = 0; k < cd.g.n_dom && !outside; ++k) {
        const HalfPlane& h = cd.g.dom[k];
        bool all_out = std::fabs(h.a.x) + std::fabs(h.a.y) >= 1e-12;  // (clip's rule)
        for (int j = 0; j < c0.poly.n && all_out; ++j)
          all_out = h.a.x * c0.poly.v[size_t(j)].x + h.a.y * c0.poly.v[size_t(j)].y + h.c > 0;
        outside = all_out;
      }
      if (outside) {
        next.push_back(c0);
        continue;
      }
      // Cut where the candidate takes over; a cell of which it takes nothing stays whole.
      const size_t mark = next.size();
      bool took = false;
      // Outside the candidate's domain the cell stays as it is, in pieces.
      Cell rest = c0, piece;
      bool any = true;
      for (int k = 0; k < cd.g.n_dom && any; ++k) {
        if (cut(rest, flip(cd.g.dom[k]), piece)) next.push_back(piece);
        Cell in;
        any = cut(rest, cd.g.dom[k], in);
        rest = in;
      }
      if (any && rest.owner < 0) {
        rest.owner = int(ci);
        next.push_back(rest);
        took = true;
      } else if (any) {
        // The candidate holds where |b| < |b_owner|: u = b - b_owner and v = b + b_owner of
        // opposite signs.
        const HalfPlane& bo = cands[size_t(rest.owner)].b;
        const HalfPlane u{cd.b.a - bo.a, cd.b.c - bo.c}, v{cd.b.a + bo.a, cd.b.c + bo.c};
        // On the owner's line, |b| the same everywhere, the owner (the earlier) keeps the cell: as
        // closely as float frames give one line (a path going exactly back along itself), 1e-6 in
        // direction and 1e-6 mm in place. (The difference of the two, a line at any angle through
        // the rounding, cut the cell at random, which shows where the two legs' cross-sections
        // differ: a tilted tool's asymmetric profile.)
        auto same = [&](const HalfPlane& h) {
          return std::hypot(h.a.x, h.a.y) <= 1e-6 * std::hypot(bo.a.x, bo.a.y) && std::fabs(h.c) <= 1e-6;
        };
        if (zero(u) || zero(v) || same(u) || same(v)) {
          next.push_back(rest);
        } else {
          Cell a, b;
          if (cut(rest, u, a)) {  // u <= 0
            if (cut(a, flip(v), b)) b.owner = int(ci), next.push_back(b), took = true;
            if (cut(a, v, b)) next.push_back(b);
          }
          if (cut(rest, flip(u), a)) {  // u >= 0
            if (cut(a, v, b)) b.owner = int(ci), next.push_back(b), took = true;
            if (cut(a, flip(v), b)) next.push_back(b);
          }
        }
      }
      if (!took) {
        next.resize(mark);
        next.push_back(c0);
      }
    }
    cells.swap(next);
    overflow = overflow || cells.size() > kMaxChainCells;
  }
  if (overflow) return false;
  // A sliver that no candidate took: the end line of a leg and the edge of the fan at its corner,
  // each computed in its own leg's frame, can miss the vertex by rounding (about 1e-8 of the
  // footprint's distance from it; bends seen from far, by a long light reach), leaving a strip of
  // that width out to `bound`. It goes to the candidate with the least |b| at its centre.
  const double sliver = 1e-7 * bound.area();
  for (Cell& c : cells) {
    if (c.owner >= 0 || !(c.poly.area() < sliver)) continue;
    Vec2d m(0, 0);
    for (int j = 0; j < c.poly.n; ++j) m = m + c.poly.v[size_t(j)] * (1.0 / c.poly.n);
    double best = std::numeric_limits<double>::infinity();
    for (size_t ci = 0; ci < cands.size(); ++ci) {
      const double b = std::fabs(cands[ci].b.a.x * m.x + cands[ci].b.a.y * m.y + cands[ci].b.c);
      if (b < best) best = b, c.owner = int(ci);
    }
  }
  // A cell with more lines than a part's domain holds: those that its other lines imply are
  // dropped, one at a time, where the others' intersection over `bound` grown by its size lies
  // within kThinCut outside the line. The clipping can leave a vertex as a cluster of points a
  // rounding apart, and every line through it then counts as bounding the cell (prune); at a
  // corner's vertex, where all the edges of its fan's sectors meet, a leg's cell kept them all,
  // only two of them bounding it. The lines kept at the end must still imply every dropped one,
  // else the chain is refused, so no domain reaches more than kThinCut past its cell's lines.
  // (Those lines are kept where the cap is not reached: so the partitions that fit it are as they
  // were.)
  Vec2d blo = bound.v[0], bhi = bound.v[0];
  bound.extend(blo, bhi);
  const Vec2d grow = bhi - blo;
  const Poly box = [&] {
    Poly b;
    b.push({blo.x - grow.x, blo.y - grow.y});
    b.push({bhi.x + grow.x, blo.y - grow.y});
    b.push({bhi.x + grow.x, bhi.y + grow.y});
    b.push({blo.x - grow.x, bhi.y + grow.y});
    return b;
  }();
  // Whether the lines h[0, n) except `skip` hold h within kThinCut over the grown region.
  auto implies = [&](const HalfPlane* hs, int n, int skip, const HalfPlane& h) {
    Poly rest = box;
    for (int k = 0; k < n && !rest.empty(); ++k)
      if (k != skip) rest = clip(rest, hs[k].a, hs[k].c);
    const double tol = kThinCut * std::hypot(h.a.x, h.a.y);
    bool held = !rest.empty();
    for (int j = 0; j < rest.n && held; ++j)
      held = h.a.x * rest.v[size_t(j)].x + h.a.y * rest.v[size_t(j)].y + h.c <= tol;
    return held;
  };
  for (Cell& c : cells) {
    if (c.nh <= Groove::kMaxDom) continue;
    HalfPlane dropped[2 * Groove::kMaxDom + 1];
    int nd = 0;
    for (int i = c.nh - 1; i >= 0 && c.nh > Groove::kMaxDom; --i) {
      if (!implies(c.h, c.nh, i, c.h[i])) continue;
      dropped[nd++] = c.h[i];
      std::copy(c.h + i + 1, c.h + c.nh, c.h + i);
      --c.nh;
    }
    // Each was implied by the lines kept at its turn; the lines kept at the end must imply them
    // all, or the chain is refused (below).
    for (int d = 0; d < nd && c.nh <= Groove::kMaxDom; ++d)
      if (!implies(c.h, c.nh, -1, dropped[d])) c.nh = Groove::kMaxDom + 1;
  }
  for (const Cell& c : cells) {
    // (Every point has a nearest candidate: the path's closest point is on a leg's strip or, on
    // a corner's outer side, in its fan.)
    if (c.owner < 0 || c.nh > Groove::kMaxDom) {
      parts.clear();
      return false;
    }
    Groove q = cands[size_t(c.owner)].g;
    q.n_dom = c.nh;
    for (int k = 0; k < c.nh; ++k) q.dom[k] = c.h[k];
    parts.push_back(q);
  }
  return true;
}

bool passParts(const Groove& a, const Groove& b, std::vector<Groove>& parts) {
  return passPieces(&a, 1, &b, 1, parts);
}

namespace {

// (Pieces of one pass share its line: direction and offset.)
bool piecesOnOneLine(const Groove* g, size_t n) {
  for (size_t k = 1; k < n; ++k)
    if (!(g[k].tdir.x == g[0].tdir.x && g[k].tdir.y == g[0].tdir.y && g[k].bdir.x == g[0].bdir.x &&
          g[k].bdir.y == g[0].bdir.y && g[k].b0 == g[0].b0))
      return false;
  return true;
}

// Each piece of g[0..n) over each of the `nw` domains given by wedge[2 i] and wedge[2 i + 1] (none:
// the whole plane), within its stretch of the line: tdir . p between the cuts, in the pieces'
// order along it. Appended to parts.
void appendStretches(const Groove* g, size_t n, const HalfPlane* wedge, size_t nw, std::vector<Groove>& parts) {
  thread_local std::vector<size_t> order;
  order.resize(n);
  for (size_t k = 0; k < n; ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t i, size_t j) { return g[i].t_lo - g[i].t0 < g[j].t_lo - g[j].t0; });
  auto cut = [&](size_t k) {  // between the k-th and (k + 1)-th pieces, as tdir . p
    const Groove &p = g[order[k]], &q = g[order[k + 1]];
    return 0.5 * ((p.t_hi - p.t0) + (q.t_lo - q.t0));
  };
  for (size_t k = 0; k < n; ++k) {
    const Groove& piece = g[order[k]];
    for (size_t w = 0; w < std::max<size_t>(nw, 1); ++w) {
      Groove q = piece;
      q.parts = nullptr;
      q.n_dom = 0;
      if (nw > 0) {
        q.dom[q.n_dom++] = wedge[2 * w];
        q.dom[q.n_dom++] = wedge[2 * w + 1];
      }
      if (k > 0) q.dom[q.n_dom++] = {piece.tdir * -1.0, cut(k - 1)};  // tdir . p >= the cut before
      if (k + 1 < n) q.dom[q.n_dom++] = {piece.tdir, -cut(k)};        // tdir . p <= the cut after
      parts.push_back(q);
    }
  }
}

}  // namespace

bool passPieces(const Groove* a, size_t na, const Groove* b, size_t nb, std::vector<Groove>& parts) {
  parts.clear();
  if (na == 0 || nb == 0) return false;
  // u = b_a - b_b and v = b_a + b_b; pass a is the nearer where u v <= 0.
  const HalfPlane u{a[0].bdir - b[0].bdir, a[0].b0 - b[0].b0}, v{a[0].bdir + b[0].bdir, a[0].b0 + b[0].b0};
  // One of them zero everywhere: the passes lie on one line (a path going back over itself), and
  // the four wedges would not tile the plane.
  if (zero(u) || zero(v)) return false;
  if (!piecesOnOneLine(a, na) || !piecesOnOneLine(b, nb)) return false;
  const HalfPlane nu = flip(u), nv = flip(v);
  const HalfPlane wa[4] = {u, nv, nu, v};  // u <= 0 <= v, and v <= 0 <= u
  const HalfPlane wb[4] = {nu, nv, u, v};  // u, v >= 0, and u, v <= 0
  appendStretches(a, na, wa, 2, parts);
  appendStretches(b, nb, wb, 2, parts);
  return true;
}

bool pieceParts(const Groove* g, size_t n, std::vector<Groove>& parts) {
  parts.clear();
  if (n == 0 || !piecesOnOneLine(g, n)) return false;
  for (size_t k = 0; k < n; ++k)
    if (g[k].parts) return false;
  appendStretches(g, n, nullptr, 0, parts);
  return true;
}

bool centreLinesWithin(const Groove& a, const Groove& b, double r, double w) {
  // Each centre line within the disc: the point at t is tdir (t - t0) - bdir b0, at distance
  // sqrt((t - t0)^2 + b0^2) from the origin.
  Vec2d p[2], q[2];
  auto inDisc = [r](const Groove& g, Vec2d* e) {
    if (!(std::fabs(g.b0) <= r)) return false;
    const double h = std::sqrt(r * r - g.b0 * g.b0);
    const double t_lo = std::max(g.t_lo, g.t0 - h), t_hi = std::min(g.t_hi, g.t0 + h);
    if (!(t_lo <= t_hi)) return false;
    e[0] = g.tdir * (t_lo - g.t0) - g.bdir * g.b0;
    e[1] = g.tdir * (t_hi - g.t0) - g.bdir * g.b0;
    return true;
  };
  if (!inDisc(a, p) || !inDisc(b, q)) return false;
  // Crossing segments are at distance 0.
  const Vec2d da = p[1] - p[0], db = q[1] - q[0];
  const double s1 = cross(da, q[0] - p[0]), s2 = cross(da, q[1] - p[0]);
  const double s3 = cross(db, p[0] - q[0]), s4 = cross(db, p[1] - q[0]);
  if (((s1 < 0 && s2 > 0) || (s1 > 0 && s2 < 0)) && ((s3 < 0 && s4 > 0) || (s3 > 0 && s4 < 0))) return true;
  // Else the nearest pair has an end point of one of them.
  auto dist2 = [](Vec2d x, Vec2d e0, Vec2d e1) {
    const Vec2d d = e1 - e0, v = x - e0;
    const double dd = dot(d, d);
    const Vec2d n = v - d * (dd > 0 ? std::clamp(dot(v, d) / dd, 0.0, 1.0) : 0.0);
    return dot(n, n);
  };
  const double d2 = std::min(std::min(dist2(p[0], q[0], q[1]), dist2(p[1], q[0], q[1])),
                             std::min(dist2(q[0], p[0], p[1]), dist2(q[1], p[0], p[1])));
  return d2 <= w * w;
}

// Cuts the region into the pieces of the composite, without walls (build()); N >= grooves.size().
template <size_t N>
bool Surface::cutPieces(const Poly& region, const std::vector<Groove>& grooves, size_t max_pieces) {
  struct Cell {
    Poly poly;
    Plane f[N];
    int layer[N];
    bool zero[N];
  };
  // Reused between calls: at the caps the cells take megabytes, and fresh buffers for every
  // footprint cost more in page faults than the clipping does.
  thread_local std::vector<Cell> cells, next;
  cells.assign(1, Cell{});
  cells[0].poly = region;
  const size_t cell_cap = 4 * max_pieces;
  thread_local std::vector<std::vector<Zone>> part_zones;
  for (size_t gi = 0; gi < grooves.size(); ++gi) {
    const Groove& g0 = grooves[gi];
    // A corner's groove: each part over the part of the cell within its domain.
    const size_t np = g0.parts ? g0.parts->size() : 1;
    const PartIndex& ix = part_index_[gi];
    const bool indexed = g0.parts && !ix.box_lo.empty();
    // (A part whose domain misses the region takes no cell.)
    auto misses = [&](size_t q) { return indexed && !(ix.box_lo[q].x <= ix.box_hi[q].x); };
    if (part_zones.size() < np) part_zones.resize(np);
    for (size_t q = 0; q < np; ++q)
      if (!misses(q)) zonesOf(g0.parts ? (*g0.parts)[q] : g0, part_zones[q]);
    next.clear();
    for (const Cell& c : cells) {
      Vec2d clo(1e300, 1e300), chi(-1e300, -1e300);
      if (indexed) c.poly.extend(clo, chi);
      for (size_t q = 0; q < np; ++q) {
        // A part whose box misses the cell's: their intersection is empty.
        if (indexed && !BBox(ix.box_lo[q], ix.box_hi[q]).overlaps(BBox(clo, chi))) continue;
        const Groove& g = g0.parts ? (*g0.parts)[q] : g0;
        const std::vector<Zone>& zones = part_zones[q];
        thread_local Poly clipped;
        const Poly* src = &c.poly;
        if (g.n_dom) {
          clipped = c.poly;
          for (int k = 0; k < g.n_dom && !clipped.empty(); ++k) clipped = clip(clipped, g.dom[k].a, g.dom[k].c);
          if (clipped.empty() || clipped.area() <= kSliver) continue;
          src = &clipped;
        }
        const Poly& cp = *src;
        // A cell wholly inside the groove's length where r > 0 (the common case) meets only the
        // zones across it whose u range overlaps the cell's (u = b / r is extreme at vertices);
        // one such zone takes the cell as it is.
        bool inside = true;
        double umin = 1e300, umax = -1e300;
        for (int k = 0; k < cp.n && inside; ++k) {
          Vec2d v = cp.v[size_t(k)];
          double t = g.t0 + g.tdir.x * v.x + g.tdir.y * v.y, r = 1 + g.rho * t;
          inside = t >= g.t_lo && t <= g.t_hi && r > 1e-9;
          double u = (g.b0 + g.bdir.x * v.x + g.bdir.y * v.y) / r;
          umin = std::min(umin, u);
          umax = std::max(umax, u);
        }
        int overlapping = 0;
        if (inside)
          for (const Zone& z : zones) overlapping += z.across && z.ulo <= umax && z.uhi >= umin;
        for (const Zone& z : zones) {
          if (inside && (!z.across || z.ulo > umax || z.uhi < umin)) continue;
          Poly p = cp;
          if (inside) {
            if (overlapping > 1)
              for (int k = z.n_inside; k < z.nh && !p.empty(); ++k) p = clip(p, z.h[k].a, z.h[k].c);
          } else {
            for (int k = 0; k < z.nh && !p.empty(); ++k) p = clip(p, z.h[k].a, z.h[k].c);
          }
          if (p.empty() || p.area() <= kSliver) continue;
          if (next.size() >= cell_cap) return false;
          next.push_back(c);
          Cell& n = next.back();
          n.poly = p;
          n.f[gi] = z.plane;
          n.layer[gi] = z.layer;
          n.zero[gi] = z.zero;
        }
      }
    }
    cells.swap(next);
  }
  // In each cell every groove's height is one plane f_i (f = 0 for the base). The composite is the
  // lowest f_i where one is below 0, else the highest: cut the cell where each f_a wins, with ties
  // (identical planes) going to the lower index, the base first.
  const size_t G = grooves.size();
  for (const Cell& c : cells) {
    auto diff = [&](const Plane& x, const Plane& y) { return std::make_pair(x.g - y.g, x.z0 - y.z0); };
    const Plane zero;
    // The winner at a point, with the same rule and ties: (a, below?).
    auto winner = [&](Vec2d q) {
      size_t lo_a = 0, hi_a = 0;
      double lo = 0, hi = 0;
      for (size_t j = 1; j <= G; ++j) {
        if (c.zero[j - 1]) continue;
        double v = c.f[j - 1].at(q);
        if (v < lo) lo = v, lo_a = j;
        if (v > hi) hi = v, hi_a = j;
      }
      return lo < 0 ? std::make_pair(lo_a, true) : std::make_pair(hi_a, false);
    };
    // The regions where one plane wins are convex, so when every vertex has the same winner (by
    // a margin) the whole cell is one piece.
    {
      auto w0 = winner(c.poly.v[0]);
      bool same = true;
      for (int k = 1; k < c.poly.n && same; ++k) same = winner(c.poly.v[size_t(k)]) == w0;
      // A margin against vertices on a boundary: the runner-up must be clearly behind.
      for (int k = 0; k < c.poly.n && same; ++k) {
        Vec2d q = c.poly.v[size_t(k)];
        double best = w0.first == 0 ? 0.0 : c.f[w0.first - 1].at(q);
        if (w0.second ? !(best < -1e-12) : false) same = false;
        for (size_t j = 0; j <= G && same; ++j) {
          if (j == w0.first || (j > 0 && c.zero[j - 1])) continue;
          double v = j == 0 ? 0.0 : c.f[j - 1].at(q);
          if (w0.second ? !(v > best + 1e-12) : !(v < best - 1e-12 || (v <= 0 && best == 0 && w0.first == 0)))
            same = false;
        }
      }
      if (same) {
        size_t a = w0.first;
        if (pieces_.size() >= max_pieces) return false;
        pieces_.push_back({c.poly, a == 0 ? zero : c.f[a - 1], a == 0 ? -1 : grooves[a - 1].id, a == 0 ? 0 : c.layer[a - 1]});
        pieces_.back().raised = !w0.second;
        continue;
      }
    }
    // Where every f_j >= 0: the same for every a below, so cut once.
    Poly above_all = c.poly;
    for (size_t j = 1; j <= G && !above_all.empty(); ++j)
      above_all = clip(above_all, c.f[j - 1].g * -1.0, -c.f[j - 1].z0);
    for (size_t a = 0; a <= G; ++a) {
      if (a > 0 && c.zero[a - 1]) continue;  // a zero plane never wins over the base
      const Plane& fa = a == 0 ? zero : c.f[a - 1];
      // Case "below": f_a < 0 and f_a lowest (only grooves can be below the base).
      if (a > 0) {
        Poly p = clip(c.poly, fa.g, fa.z0, true);
        for (size_t j = 1; j <= G && !p.empty(); ++j) {
          if (j == a) continue;
          auto [g, k] = diff(fa, c.f[j - 1]);  // f_a - f_j <= 0 (< 0 for j < a)
          p = clip(p, g, k, j < a);
        }
        if (!p.empty() && p.area() > kSliver) {
          if (pieces_.size() >= max_pieces) return false;
          pieces_.push_back({p, fa, grooves[a - 1].id, c.layer[a - 1]});
        }
      }
      // Case "above": every f_j >= 0 and f_a highest.
      Poly p = above_all;
      for (size_t j = 0; j <= G && !p.empty(); ++j) {
        if (j == a) continue;
        const Plane& fj = j == 0 ? zero : c.f[j - 1];
        auto [g, k] = diff(fj, fa);  // f_j - f_a <= 0 (< 0 for j < a)
        p = clip(p, g, k, j < a);
      }
      if (!p.empty() && p.area() > kSliver) {
        if (pieces_.size() >= max_pieces) return false;
        pieces_.push_back({p, fa, a == 0 ? -1 : grooves[a - 1].id, a == 0 ? 0 : c.layer[a - 1]});
        pieces_.back().raised = true;
      }
    }
  }
  return true;
}

bool Surface::build(const Poly& region, const std::vector<Groove>& grooves, size_t max_pieces) {
  pieces_.clear();
  cache_keys_ = 0;
  mirror_built_ = false;
  walls_.clear();
  grooves_ = grooves;
  parts_indexed_ = false;
  region_lo_ = Vec2d(1e300, 1e300);
  region_hi_ = Vec2d(-1e300, -1e300);
  region.extend(region_lo_, region_hi_);
  if (grooves.size() > kMaxGrooves) return false;
  indexParts(region);
  // The cells hold a plane per groove: the smaller array where it will do. With kMaxGrooves planes
  // in every cell, surfaces of 8 grooves or fewer (nearly all) took 3-8% longer to build.
  if (!(grooves.size() <= kSmallGrooves ? cutPieces<kSmallGrooves>(region, grooves, max_pieces)
                                        : cutPieces<kMaxGrooves>(region, grooves, max_pieces)))
    return false;
  // Steps of the composite: along every piece edge, the surface just outside higher than the
  // piece. Each wall is found once, from its low side, split where the piece beyond changes (the
  // top is then one plane's, straight), and becomes two steep pieces (kWallLean).
  constexpr double kStep = 1e-9;  // mm outside the edge
  constexpr double kTall = 1e-7;  // mm: lower steps are a slope over kStep, or rounding
  const size_t n_flat = pieces_.size();
  auto bound = [](Piece& pc) {
    pc.lo = pc.hi = pc.poly.v[0];
    pc.poly.extend(pc.lo, pc.hi);
    pc.zmax = -1e300;
    for (int k = 0; k < pc.poly.n; ++k) pc.zmax = std::max(pc.zmax, pc.plane.at(pc.poly.v[size_t(k)]));
  };
  for (Piece& pc : pieces_) bound(pc);
  // The pieces beyond a stepping edge (below) are those whose boxes meet the edge's. Testing every
  // piece for every stepping edge was half of build()'s own time on a close view of twelve
  // crossing scratches (1,000 and more pieces, hundreds of steps). After kWallScans such edges the
  // flat pieces are binned as for the shadows (binPieces, made again with the walls at the end)
  // and each edge tests only the pieces whose bins meet its box's, in their order.
  constexpr int kWallScans = 16;
  int scans = 0;
  bool binned = false;
  thread_local std::vector<size_t> beyond;  // candidate pieces of one edge, in order
  // The end lines where a groove's cross-section has not faded out (t = t_lo or t_hi), once each
  // (a chain's parts of one leg share its line) and only those that pass near the region: a piece
  // edge along one of them is looked at for a step.
  struct EndLine {
    double t0;
    Vec2d tdir;
    double te;
  };
  thread_local std::vector<EndLine> end_lines;
  end_lines.clear();
  auto addEndLine = [&](double t0, Vec2d tdir, double te) {
    for (const EndLine& el : end_lines)
      if (el.t0 == t0 && el.tdir.x == tdir.x && el.tdir.y == tdir.y && el.te == te) return;
    end_lines.push_back({t0, tdir, te});
  };
  for (size_t gi = 0; gi < grooves.size(); ++gi)
    for (size_t q = 0; q < (grooves[gi].parts ? grooves[gi].parts->size() : 1); ++q) {
      const Groove& g = grooves[gi].parts ? (*grooves[gi].parts)[q] : grooves[gi];
      double tmin = 1e300, tmax = -1e300;  // t over the region (linear: extreme at its vertices)
      for (int k = 0; k < region.n; ++k) {
        const double t = g.t0 + g.tdir.x * region.v[size_t(k)].x + g.tdir.y * region.v[size_t(k)].y;
        tmin = std::min(tmin, t);
        tmax = std::max(tmax, t);
      }
      if (g.has_split) addEndLine(g.split.c, g.split.a, 0.0);
      const double slack = 1e-6 * (1 + std::fabs(tmin) + std::fabs(tmax));
      for (double te : {g.t_lo, g.t_hi})
        if (std::fabs(te) < 1e29 && 1 + g.rho * te > 1e-9 && te >= tmin - slack && te <= tmax + slack)
          addEndLine(g.t0, g.tdir, te);
    }
  // Where every groove's height is continuous (no groove of parts, whose parts may meet with a
  // step, nor a split line), the composite can step up beyond an edge only where the lowest
  // groove below the base there comes up to it and gives way to another's pile-up. Beyond an edge
  // of a raised piece it is the highest height, which is continuous, or lower (a groove cutting
  // below the base); beyond an edge lying deeper than kDeep the groove that made the piece is still
  // below the base just outside, so the lowest height there is no higher than the piece. Such
  // edges are not asked (Surface::above at three points each: a sixth to a quarter of a dense
  // crossing's time), unless an end of theirs lies on an end line: the points asked next to that
  // end can fall beyond the line, and what they find there is kept as before.
  //
  // A groove of parts is continuous within each part's domain (a part is a plain groove; its end
  // lines are among end_lines), but the parts may meet with a step on their seams, and beyond a
  // seam another part holds. So with grooves of parts an edge is not asked only where, for each
  // such groove, the part that holds the piece (at its centroid) holds both ends of the edge by more
  // than kSeam inside every line of its domain, and has no split line: then that part holds the
  // whole edge and the points just beyond it (its domain is convex), and the argument above holds.
  bool continuous = true, parted = false;
  for (const Groove& g : grooves) {
    continuous = continuous && !g.has_split;
    parted = parted || g.parts;
  }
  constexpr double kDeep = 1e-6;  // mm below the base
  constexpr double kSeam = 1e-7;  // mm, against the points asked kStep beyond an edge
  thread_local std::vector<const Groove*> holding;  // per groove of parts: the piece's part (or null)
  std::vector<Piece> leaning;  // appended to pieces_ at the end
  for (size_t pi = 0; pi < n_flat; ++pi)
    for (int k = 0; k < pieces_[pi].poly.n; ++k) {
      const Piece& pc = pieces_[pi];
      if (parted && k == 0) {
        Vec2d c(0, 0);
        for (int j = 0; j < pc.poly.n; ++j) c = c + pc.poly.v[size_t(j)];
        c = c * (1.0 / pc.poly.n);
        holding.clear();
        for (size_t gi = 0; gi < grooves.size(); ++gi)
          if (grooves[gi].parts) holding.push_back(partOf(gi, c));
      }
      const Vec2d e0 = pc.poly.v[size_t(k)], e1 = pc.poly.v[size_t((k + 1) % pc.poly.n)];
      const Vec2d t = e1 - e0;
      const double len = std::sqrt(t.x * t.x + t.y * t.y);
      if (!(len > 1e-9)) continue;
      const Vec2d n(t.y / len, -t.x / len);  // outward (the piece is counter-clockwise)
      // Is there a step anywhere along the edge? The composite jumps only where a groove's cut
      // (its height below the base) gives way to others' pile-ups, and across abrupt ends. On the
      // first kind of edge the heights beyond are the largest of linear functions along it,
      // convex, so higher than the piece somewhere only if at an end; on an abrupt end line, and
      // on a half turn's split line (Groove::split), the heights beyond can be anything, so the
      // pieces beyond are always looked at.
      // (A corner's parts: each leg's end line at the vertex is checked too; the cap beyond it
      // meets it without a step, so no wall is found there.)
      bool step = false, touches = false;
      for (size_t k = 0; k < end_lines.size() && !step; ++k) {
        const EndLine& el = end_lines[k];
        const double ta = el.t0 + el.tdir.x * e0.x + el.tdir.y * e0.y, tb = el.t0 + el.tdir.x * e1.x + el.tdir.y * e1.y;
        const bool a_on = std::fabs(ta - el.te) < 1e-9, b_on = std::fabs(tb - el.te) < 1e-9;
        step = a_on && b_on;
        touches = touches || a_on || b_on;
      }
      bool smooth = continuous && !touches && (pc.raised || std::max(pc.plane.at(e0), pc.plane.at(e1)) < -kDeep);
      for (size_t h = 0; h < (parted ? holding.size() : 0) && smooth; ++h) {
        const Groove* q = holding[h];
        smooth = q && !q->has_split;
        for (int j = 0; j < (q ? q->n_dom : 0) && smooth; ++j) {
          const HalfPlane& d = q->dom[j];
          const double m = kSeam * std::hypot(d.a.x, d.a.y);
          smooth = dot(d.a, e0) + d.c < -m && dot(d.a, e1) + d.c < -m;
        }
      }
      for (double f : {kStep / len, 0.5, 1 - kStep / len}) {
        if (step || smooth) break;
        const Vec2d q = e0 + t * f;
        step = above(q + n * kStep, pc.plane.at(q) + kTall);
      }
      if (!step) continue;
      // The pieces beyond: the edge moved kStep outwards, clipped to each (tau in [0, 1] along it).
      const Vec2d s0 = e0 + n * kStep;
      const Vec2d slo(std::min(e0.x, e1.x) - 2 * kStep, std::min(e0.y, e1.y) - 2 * kStep);
      const Vec2d shi(std::max(e0.x, e1.x) + 2 * kStep, std::max(e0.y, e1.y) + 2 * kStep);
      beyond.clear();
      const bool all = !binned && scans++ < kWallScans;  // every piece, in order
      if (!all) {
        if (!binned) binPieces();
        binned = true;
        inBins(binOf(slo.x, 0), binOf(shi.x, 0), binOf(slo.y, 1), binOf(shi.y, 1), beyond);
      }
      for (size_t k = 0, count = all ? n_flat : beyond.size(); k < count; ++k) {
        const size_t qi = all ? k : beyond[k];
        const Piece& Q = pieces_[qi];
        if (qi == pi || !BBox(Q.lo, Q.hi).overlaps(BBox(slo, shi))) continue;
        double t0 = 0, t1 = 1;
        for (int j = 0; j < Q.poly.n && t0 < t1; ++j) {
          Vec2d hn;
          double hc;
          if (!edgeHalfPlane(Q.poly.v[size_t(j)], Q.poly.v[size_t((j + 1) % Q.poly.n)], hn, hc)) continue;
          // hn.(s0 + tau t) + hc <= 0
          double f0 = hn.x * s0.x + hn.y * s0.y + hc, ft = hn.x * t.x + hn.y * t.y;
          if (std::fabs(ft) < 1e-300) {
            if (f0 > 0) t1 = t0 - 1;
          } else if (ft > 0) {
            t1 = std::min(t1, -f0 / ft);
          } else {
            t0 = std::max(t0, -f0 / ft);
          }
        }
        if (!(t1 - t0 > 1e-12)) continue;
        const Vec2d a = e0 + t * t0, b = e0 + t * t1;
        const Wall w{a, b, pc.plane.at(a), pc.plane.at(b), std::max(Q.plane.at(a), pc.plane.at(a)),
                     std::max(Q.plane.at(b), pc.plane.at(b)), n * -1.0};
        const double tall = std::max(w.za1 - w.za0, w.zb1 - w.zb0);
        if (!(tall > kTall)) continue;
        walls_.push_back(w);
        // The wall in its own coordinates (s along a-b in [0, 1], z), cut at the base plane: the
        // part above it is pile-up, of the top layer (as the 1-D sections' vertical steps take
        // it); below, it is cut at the low groove's layer interfaces, each band showing its
        // layer (or, without them, the layer at the foot).
        const std::vector<double>* cuts = nullptr;
        for (const Groove& g : grooves)
          if (pc.groove >= 0 && g.id == pc.groove) cuts = g.interfaces;
        std::vector<double> levels{0.0};  // band boundaries, top first
        if (cuts)
          for (double dep : *cuts)
            if (-dep > std::min(w.za0, w.zb0)) levels.push_back(-dep);
        Poly quad;
        quad.push(Vec2d(0, w.za0));
        quad.push(Vec2d(1, w.zb0));
        quad.push(Vec2d(1, w.zb1));
        quad.push(Vec2d(0, w.za1));
        // A point (s, z) of the wall in 3-D, leaning back: moved towards the high side by
        // kWallLean * tall times its height's fraction of the wall at s (0 on the foot).
        auto place = [&](Vec2d sz) {
          const double foot = w.za0 + (w.zb0 - w.za0) * sz.x, top = w.za1 + (w.zb1 - w.za1) * sz.x;
          const double frac = top - foot > kTall * 1e-3 ? std::min(1.0, std::max(0.0, (sz.y - foot) / (top - foot))) : 0.0;
          const Vec2d xy = w.a + (w.b - w.a) * sz.x + n * (kWallLean * tall * frac);
          return Vec3d(xy.x, xy.y, sz.y);
        };
        for (size_t bi = 0; bi <= levels.size(); ++bi) {
          // Band bi: between levels[bi - 1] (above; none for the first) and levels[bi] (below;
          // none for the last). Band 0 is above the base plane.
          Poly band = quad;
          if (bi > 0) band = clip(band, Vec2d(0, 1), -levels[bi - 1]);  // z <= upper level
          if (bi < levels.size()) band = clip(band, Vec2d(0, -1), levels[bi]);  // z >= lower level
          const int band_layer = bi == 0 ? 0 : cuts ? int(bi) - 1 : pc.layer;
          for (int j = 1; j + 1 < band.n; ++j) {
            const Vec2d t0 = band.v[0], t1 = band.v[size_t(j)], t2 = band.v[size_t(j + 1)];
            // Triangles of no height (a wall's end where it has none) only cover its lean's strip.
            if (!(std::fabs((t1.x - t0.x) * (t2.y - t0.y) - (t2.x - t0.x) * (t1.y - t0.y)) > 1e-9 * tall)) continue;
            const Vec3d v[3] = {place(t0), place(t1), place(t2)};
            Vec2d d1(v[1].x - v[0].x, v[1].y - v[0].y), d2(v[2].x - v[0].x, v[2].y - v[0].y);
            double det = d1.x * d2.y - d1.y * d2.x;
            if (!(std::fabs(det) > 1e-24)) continue;  // degenerate: no area
            double dz1 = v[1].z - v[0].z, dz2 = v[2].z - v[0].z;
            Piece wp;
            wp.plane.g = Vec2d((dz1 * d2.y - dz2 * d1.y) / det, (d1.x * dz2 - d2.x * dz1) / det);
            wp.plane.z0 = v[0].z - wp.plane.g.x * v[0].x - wp.plane.g.y * v[0].y;
            for (int i = 0; i < 3; ++i) wp.poly.push(Vec2d(v[i].x, v[i].y));
            if (wp.poly.area() < 0) reverse(wp.poly);
            // Its scratch: the low side's groove, else (a pile-up over the base) the high side's.
            wp.groove = pc.groove >= 0 ? pc.groove : Q.groove;
            wp.layer = band_layer;
            wp.wall = true;
            if (leaning.size() >= max_pieces) return false;  // walls have a cap of their own
            leaning.push_back(wp);
          }
        }
      }
    }
  for (Piece& pc : leaning) bound(pc);
  pieces_.insert(pieces_.end(), leaning.begin(), leaning.end());
  binPieces();
  return true;
}

int Surface::binOf(double v, int axis) const {
  const double lo = axis == 0 ? bin_lo_.x : bin_lo_.y, size = axis == 0 ? bin_size_.x : bin_size_.y;
  const double f = (v - lo) / size;  // monotone in v, so overlapping ranges get overlapping bins
  if (!(f > 0)) return 0;            // also NaN: the whole range, which is safe
  if (!(f < double(kBins - 1))) return kBins - 1;
  return int(f);
}

void Surface::binPieces() {
  Vec2d lo(1e300, 1e300), hi(-1e300, -1e300);
  zmax_all_ = -1e300;
  for (const Piece& pc : pieces_) {
    lo = Vec2d(std::min(lo.x, pc.lo.x), std::min(lo.y, pc.lo.y));
    hi = Vec2d(std::max(hi.x, pc.hi.x), std::max(hi.y, pc.hi.y));
    zmax_all_ = std::max(zmax_all_, pc.zmax);
  }
  bin_lo_ = lo;
  bin_size_ = Vec2d(std::max((hi.x - lo.x) / kBins, 1e-300), std::max((hi.y - lo.y) / kBins, 1e-300));
  words_ = (pieces_.size() + 63) / 64;
  cull_.resize(pieces_.size());
  for (size_t i = 0; i < pieces_.size(); ++i) {
    const Piece& pc = pieces_[i];
    cull_[i] = {pc.plane.g.x, pc.plane.g.y, pc.plane.z0, pc.lo.x, pc.lo.y, pc.hi.x, pc.hi.y, pc.zmax};
  }
  col_bits_.assign(size_t(kBins) * words_, 0);
  row_bits_.assign(size_t(kBins) * words_, 0);
  for (size_t i = 0; i < pieces_.size(); ++i) {
    const uint64_t bit = uint64_t(1) << (i % 64);
    for (int c = binOf(pieces_[i].lo.x, 0), c1 = binOf(pieces_[i].hi.x, 0); c <= c1; ++c)
      col_bits_[size_t(c) * words_ + i / 64] |= bit;
    for (int r = binOf(pieces_[i].lo.y, 1), r1 = binOf(pieces_[i].hi.y, 1); r <= r1; ++r)
      row_bits_[size_t(r) * words_ + i / 64] |= bit;
  }
  rows_or_.assign(size_t(kBins * (kBins + 1) / 2) * words_, 0);
  for (int r0 = 0; r0 < kBins; ++r0)
    for (int r1 = r0; r1 < kBins; ++r1)
      for (size_t w = 0; w < words_; ++w)
        rows_or_[rowRange(r0, r1) * words_ + w] =
            row_bits_[size_t(r1) * words_ + w] | (r1 > r0 ? rows_or_[rowRange(r0, r1 - 1) * words_ + w] : 0);
}

void Surface::candidates(const Plane& P, double den, Vec3d d, Vec2d lo, Vec2d hi, std::vector<size_t>& out) const {
  // No piece reaches higher than zmax_all_ nor lies outside the bins' box, over which P is at
  // least pmin. So every piece that shadowsOn's reaches() lets through lies within [lo, hi] moved
  // by up to lmax d_xy (one bound for all pieces at once), and its bins meet that box's. A margin
  // covers the rounding of the two ways of putting it.
  out.clear();
  const Vec2d blo = bin_lo_, bhi = bin_lo_ + bin_size_ * double(kBins);
  const double pmin = P.z0 + std::min(P.g.x * blo.x, P.g.x * bhi.x) + std::min(P.g.y * blo.y, P.g.y * bhi.y);
  const double lmax = std::max(0.0, (zmax_all_ - pmin) / den);
  const double margin = 1e-9 * (bhi.x - blo.x + bhi.y - blo.y) + 1e-12;
  const int c0 = binOf(std::min(lo.x, lo.x + lmax * d.x) - margin, 0);
  const int c1 = binOf(std::max(hi.x, hi.x + lmax * d.x) + margin, 0);
  const int r0 = binOf(std::min(lo.y, lo.y + lmax * d.y) - margin, 1);
  const int r1 = binOf(std::max(hi.y, hi.y + lmax * d.y) + margin, 1);
  // Those points lie in the strip {p + lambda d_xy: p in [lo, hi], 0 <= lambda <= lmax}, which
  // for a slanted d fills a small part of its box: within column c's slab of x, only the rows that
  // the strip crosses there can hold them.
  int rlo[kBins], rhi[kBins];
  for (int c = c0; c <= c1; ++c) {
    const double x0 = c == 0 ? -1e300 : bin_lo_.x + bin_size_.x * c - margin;
    const double x1 = c == kBins - 1 ? 1e300 : bin_lo_.x + bin_size_.x * (c + 1) + margin;
    double la = 0, lb = lmax;  // the lambdas for which the strip meets the slab
    if (d.x > 0) {
      la = std::max(la, (x0 - hi.x) / d.x);
      lb = std::min(lb, (x1 - lo.x) / d.x);
    } else if (d.x < 0) {
      la = std::max(la, (x1 - lo.x) / d.x);
      lb = std::min(lb, (x0 - hi.x) / d.x);
    }
    if (!(la <= lb)) {  // rounding or NaN: the whole range, which is safe
      la = 0;
      lb = lmax;
    }
    rlo[c] = std::max(r0, binOf(lo.y + std::min(la * d.y, lb * d.y) - margin, 1));
    rhi[c] = std::min(r1, binOf(hi.y + std::max(la * d.y, lb * d.y) + margin, 1));
  }
  for (size_t w = 0; w < words_; ++w) {
    uint64_t m = 0;
    for (int c = c0; c <= c1; ++c)
      if (rlo[c] <= rhi[c]) m |= col_bits_[size_t(c) * words_ + w] & rows_or_[rowRange(rlo[c], rhi[c]) * words_ + w];
    for (; m; m &= m - 1) out.push_back(w * 64 + size_t(__builtin_ctzll(m)));
  }
}

void Surface::inBins(int c0, int c1, int r0, int r1, std::vector<size_t>& out) const {
  for (size_t w = 0; w < words_; ++w) {
    uint64_t cols = 0, rows = 0;
    for (int c = c0; c <= c1; ++c) cols |= col_bits_[size_t(c) * words_ + w];
    for (int r = r0; r <= r1; ++r) rows |= row_bits_[size_t(r) * words_ + w];
    for (uint64_t m = cols & rows; m; m &= m - 1) out.push_back(w * 64 + size_t(__builtin_ctzll(m)));
  }
}

// ------------------------------------------------------------------------------------------------
// Masking, shadowing and inter-reflection
// ------------------------------------------------------------------------------------------------

namespace {
// N.d up to a positive factor (N = (-g, 1)).
inline double facing(double gx, double gy, Vec3d d) { return d.z - gx * d.x - gy * d.y; }
inline double facing(const Plane& p, Vec3d d) { return facing(p.g.x, p.g.y, d); }
}  // namespace

void Surface::shadowsOn(size_t pi, Vec3d d, Vec2d lo, Vec2d hi, std::vector<Poly>& out, std::vector<double>* dist,
                        std::vector<size_t>* owner) const {
  out.clear();
  if (dist) dist->clear();
  if (owner) owner->clear();
  const Plane& P = pieces_[pi].plane;
  const double den = facing(P, d);  // > 0: P faces d
  if (!(den > 0)) return;
  // Can something over the box [qlo, qhi], at most zmax high, project into [lo, hi]? Its points
  // move by -lambda d_xy with 0 <= lambda <= (zmax - min of P over the box) / den.
  auto reaches = [&](Vec2d qlo, Vec2d qhi, double zmax) {
    double pmin = P.z0 + std::min(P.g.x * qlo.x, P.g.x * qhi.x) + std::min(P.g.y * qlo.y, P.g.y * qhi.y);
    if (!(zmax > pmin)) return false;  // wholly below P's plane
    double lmax = (zmax - pmin) / den;
    double sx = -lmax * d.x, sy = -lmax * d.y;
    return qlo.x + std::min(0.0, sx) <= hi.x && qhi.x + std::max(0.0, sx) >= lo.x &&
           qlo.y + std::min(0.0, sy) <= hi.y && qhi.y + std::max(0.0, sy) >= lo.y;
  };
  // Across d: moving along d keeps a point's coordinate along n = (-d.y, d.x), so an occluder's
  // box must overlap the receiving box there (with a margin for the rounding of the projection).
  const double nx = -d.y, ny = d.x;
  const double ra = std::min(nx * lo.x, nx * hi.x) + std::min(ny * lo.y, ny * hi.y);
  const double rb = std::max(nx * lo.x, nx * hi.x) + std::max(ny * lo.y, ny * hi.y);
  const double rmargin = 1e-9 * (std::fabs(nx) + std::fabs(ny)) * (bin_size_.x + bin_size_.y) * kBins + 1e-15;
  thread_local std::vector<size_t> near;
  candidates(P, den, d, lo, hi, near);
  for (size_t qi : near) {
    const Cull& C = cull_[qi];
    const double qa = std::min(nx * C.lox, nx * C.hix) + std::min(ny * C.loy, ny * C.hiy);
    const double qb = std::max(nx * C.lox, nx * C.hix) + std::max(ny * C.loy, ny * C.hiy);
    if (qa > rb + rmargin || qb < ra - rmargin) continue;
    if (!(facing(C.gx, C.gy, d) < 0)) continue;  // only pieces facing away from d block it
    if (!reaches(Vec2d(C.lox, C.loy), Vec2d(C.hix, C.hiy), C.zmax)) continue;
    const Piece& Q = pieces_[qi];
    // The part of Q on the d-side of P's plane: Q(p) - P(p) >= 0.
    Poly q = clip(Q.poly, P.g - Q.plane.g, P.z0 - Q.plane.z0);
    if (q.empty()) continue;
    // Projected along d onto P's plane: p' = p - lambda d_xy, lambda = (Q(p) - P(p)) / den.
    Poly s;
    double lc = 0;
    for (int i = 0; i < q.n; ++i) {
      Vec2d p = q.v[size_t(i)];
      double lambda = (Q.plane.at(p) - P.at(p)) / den;
      lc += lambda;
      s.push(Vec2d(p.x - lambda * d.x, p.y - lambda * d.y));
    }
    // The projection from a plane facing away from d onto one facing it flips the orientation.
    if (s.area() < 0) reverse(s);
    if (s.empty() || s.area() <= kSliver) continue;
    out.push_back(s);
    if (dist) dist->push_back(lc / q.n);
    if (owner) owner->push_back(qi);
  }
}

namespace {
void boxOf(const std::vector<Poly>& frags, Vec2d& lo, Vec2d& hi) {
  lo = Vec2d(1e300, 1e300);
  hi = Vec2d(-1e300, -1e300);
  for (const Poly& f : frags) f.extend(lo, hi);
}
}  // namespace

std::vector<Portion> Surface::visible(const Poly& fp, Vec3d e) const {
  std::vector<Portion> out;
  const double afp = std::fabs(fp.area());
  if (!(afp > 0) || !(e.z > 0)) return out;
  Vec2d exy(e.x / e.z, e.y / e.z);
  thread_local std::vector<Poly> shadows;
  // Below this elevation (about 0.0006 degrees) the walls' seen bands are too thin to place in
  // doubles (their heights times 1e5 along the view); they are left out there, as a vertical
  // wall's share of a footprint is then all but arbitrary anyway.
  const bool walls_seen = e.z > 1e-5 * length(e);
  for (size_t pi = 0; pi < pieces_.size(); ++pi) {
    const Piece& P = pieces_[pi];
    if (P.wall && !walls_seen) continue;
    // A point p of P is seen through the base-plane point u = p - P(p) e_xy / e_z, i.e.
    // M p = u + z0 e_xy / e_z with M = I - e_xy g^T / e_z; det M > 0 when P faces the viewer.
    double m00 = 1 - exy.x * P.plane.g.x, m01 = -exy.x * P.plane.g.y;
    double m10 = -exy.y * P.plane.g.x, m11 = 1 - exy.y * P.plane.g.y;
    double det = m00 * m11 - m01 * m10;
    if (!(det > 1e-9)) continue;
    Poly f;
    for (int i = 0; i < fp.n; ++i) {
      Vec2d u = fp.v[size_t(i)] + exy * P.plane.z0;
      f.push(Vec2d((m11 * u.x - m01 * u.y) / det, (-m10 * u.x + m00 * u.y) / det));
    }
    if (f.area() < 0) reverse(f);
    Poly frag = intersect(P.poly, f);
    if (frag.empty() || frag.area() <= kSliver) continue;
    Portion por;
    por.piece = int(pi);
    por.frags.push_back(frag);
    Vec2d lo, hi;
    boxOf(por.frags, lo, hi);
    shadowsOn(pi, e, lo, hi, shadows, nullptr, nullptr);
    for (const Poly& s : shadows) {
      subtract(por.frags, s, kMaxFragments, overflow);
      if (por.frags.empty()) break;
    }
    por.density = det / afp;
    por.weight = por.density * area(por.frags);
    if (por.weight > 0) out.push_back(std::move(por));
  }
  return out;
}

double Surface::litWith(const Portion& p, const Poly* shadows, size_t n) const {
  double a0 = area(p.frags);
  if (!(a0 > 0)) return 0.0;
  Vec2d lo, hi;
  boxOf(p.frags, lo, hi);
  const BBox pb(lo, hi);
  thread_local std::vector<Poly> frags;
  bool copied = false;
  for (size_t i = 0; i < n; ++i) {
    if (!BBox(shadows[i]).overlaps(pb)) continue;
    if (!copied) {
      frags = p.frags;
      copied = true;
    }
    subtract(frags, shadows[i], kMaxFragments, overflow);
    if (frags.empty()) return 0.0;
  }
  return copied ? std::min(1.0, area(frags) / a0) : 1.0;
}

double Surface::litFraction(const Portion& p, Vec3d l) const {
  if (!(facing(pieces_[size_t(p.piece)].plane, l) > 0)) return 0.0;
  thread_local std::vector<Poly> shadows;
  Vec2d lo, hi;
  boxOf(p.frags, lo, hi);
  shadowsOn(size_t(p.piece), l, lo, hi, shadows, nullptr, nullptr);
  return litWith(p, shadows.data(), shadows.size());
}

void Surface::cacheLights(size_t keys) const {
  cache_keys_ = keys;
  cache_range_.assign(pieces_.size() * keys, {-1, -1});
  cache_polys_.clear();
}

double Surface::litFraction(const Portion& p, Vec3d l, size_t key) const {
  const Piece& P = pieces_[size_t(p.piece)];
  if (!(facing(P.plane, l) > 0)) return 0.0;
  if (key >= cache_keys_) return litFraction(p, l);
  auto& r = cache_range_[size_t(p.piece) * cache_keys_ + key];
  if (r.first < 0) {
    // For the whole piece, so that every portion on it can use them.
    thread_local std::vector<Poly> shadows;
    shadowsOn(size_t(p.piece), l, P.lo, P.hi, shadows, nullptr, nullptr);
    r.first = int(cache_polys_.size());
    cache_polys_.insert(cache_polys_.end(), shadows.begin(), shadows.end());
    r.second = int(cache_polys_.size());
  }
  return litWith(p, cache_polys_.data() + r.first, size_t(r.second - r.first));
}

Hits Surface::scatter(const Portion& p, Vec3d d) const {
  Hits h;
  const Piece& P = pieces_[size_t(p.piece)];
  if (!(facing(P.plane, d) > 0)) return h;
  thread_local std::vector<Poly> shadows;
  thread_local std::vector<double> dist;
  thread_local std::vector<size_t> owner;
  Vec2d lo, hi;
  boxOf(p.frags, lo, hi);
  shadowsOn(size_t(p.piece), d, lo, hi, shadows, &dist, &owner);
  std::vector<size_t> order(shadows.size());
  std::iota(order.begin(), order.end(), size_t(0));
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return dist[a] < dist[b]; });
  std::vector<Poly> rest = p.frags;
  for (size_t k : order) {
    if (rest.empty()) break;
    const Poly& s = shadows[k];
    const Piece& Q = pieces_[owner[k]];
    const double den = facing(Q.plane, d);  // < 0
    Portion hit;
    hit.piece = int(owner[k]);
    double claimed = 0, mapped = 0;
    for (const Poly& f : rest) {
      Poly c = intersect(f, s);
      if (c.empty() || c.area() <= kSliver) continue;
      claimed += c.area();
      // Along d from P onto Q: p + mu d_xy with mu = (Q(p) - P(p)) / den_Q.
      Poly m;
      for (int i = 0; i < c.n; ++i) {
        Vec2d q = c.v[size_t(i)];
        double mu = (Q.plane.at(q) - P.plane.at(q)) / den;
        m.push(Vec2d(q.x + mu * d.x, q.y + mu * d.y));
      }
      if (m.area() < 0) reverse(m);
      if (m.empty()) continue;
      mapped += m.area();
      hit.frags.push_back(m);
    }
    if (!(claimed > 0) || !(mapped > 0)) continue;
    subtract(rest, s, kMaxFragments, overflow);
    hit.weight = p.density * claimed;
    hit.density = hit.weight / mapped;
    h.hits.push_back(std::move(hit));
  }
  h.escaped = p.density * area(rest);
  if (h.escaped > 0) {
    // The centroid of the rest.
    Vec2d c;
    if (centroid(rest, c)) h.escaped_at = c;
  }
  return h;
}

bool Surface::exitPoint(Vec3d o, Vec3d d, Vec3d& at) const {
  // The least s > 0 at which o + s d crosses the box's boundary (o inside it).
  double s = 1e300;
  if (d.x > 0) s = std::min(s, (region_hi_.x - o.x) / d.x);
  if (d.x < 0) s = std::min(s, (region_lo_.x - o.x) / d.x);
  if (d.y > 0) s = std::min(s, (region_hi_.y - o.y) / d.y);
  if (d.y < 0) s = std::min(s, (region_lo_.y - o.y) / d.y);
  if (!(s < 1e300)) return false;
  s = std::max(s, 0.0);
  at = Vec3d(o.x + s * d.x, o.y + s * d.y, o.z + s * d.z);
  return true;
}

const Groove* Surface::leaving(Vec3d o, Vec3d d, Vec3d& at) const {
  if (!exitPoint(o, d, at)) return nullptr;
  const Vec2d p(at.x, at.y);
  const Groove* best = nullptr;
  double best_u = 1e300;
  for (size_t gi = 0; gi < grooves_.size(); ++gi) {
    const Groove* q = grooves_[gi].parts ? partOf(gi, p) : &grooves_[gi];
    if (!q) continue;
    double r;
    if (!existsAt(*q, p, r)) continue;
    const double u = std::fabs(q->b0 + q->bdir.x * p.x + q->bdir.y * p.y) / r;  // in the profile's units
    if (u < best_u) {
      best_u = u;
      best = q;
    }
  }
  return best;
}

const Surface& Surface::mirrored() const {
  if (!mirror_) mirror_ = std::make_unique<Surface>();
  if (!mirror_built_) {
    // z -> -z: each piece's plane negated (its normal (-g, 1) becomes the mirror of the inward
    // normal), its highest point the negated lowest. The (x, y) polygons and bins are the same.
    Surface& m = *mirror_;
    m.pieces_ = pieces_;
    for (Piece& pc : m.pieces_) {
      double zmin = 1e300;
      for (int k = 0; k < pc.poly.n; ++k) zmin = std::min(zmin, pc.plane.at(pc.poly.v[size_t(k)]));
      pc.plane.z0 = -pc.plane.z0;
      pc.plane.g = Vec2d(-pc.plane.g.x, -pc.plane.g.y);
      pc.zmax = -zmin;
    }
    m.walls_.clear();
    m.grooves_.clear();
    m.cache_keys_ = 0;
    m.binPieces();
    mirror_built_ = true;
  }
  return *mirror_;
}

Hits Surface::scatterInside(const Portion& p, Vec3d d) const {
  const Surface& m = mirrored();
  const size_t before = m.overflow;
  Hits h = m.scatter(p, Vec3d(d.x, d.y, -d.z));
  overflow += m.overflow - before;
  return h;
}

}  // namespace dg::groove::area
