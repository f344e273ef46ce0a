// Footprint integration over grooves in cross-section space: Bosch 2007 §4.2.3 ("1-D line
// sampling") and the specular recursion of §4.3, after shared/reference/bosch-grooves.md §2.2.3
// and §2.3. The contract of every function is in groove.h; this file records the conventions it
// settles (signs, half-open rules, what happens outside the section).
//
// Geometry used throughout: the BW plane with b across the groove and w up (out of the material);
// the material lies below the polyline, which is a height field in b except for vertical facets.
// A point (b, w) seen or lit along a direction d = (d_b, d_w) lands on the base line w = 0 at
// x = b - w * d_b / d_w (Bosch Eq. 4.3, with tan(theta') = -d_b / d_w).
#include "render/groove.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace dg::groove {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

double clamp01(double v) { return std::min(1.0, std::max(0.0, v)); }

// ------------------------------------------------------------------------------------------------
// Footprint
// ------------------------------------------------------------------------------------------------

// Cumulative footprint weight C(x) = integral of the density over (-inf, x]. The density is the
// convolution of centred boxes of widths 2L >= 2s (L, s half-widths, unit area each): a trapezoid
// that is flat at 1/(2L) on |x| <= L - s, falls linearly to 0 over L - s <= |x| <= L + s. On the
// left half:
//   C(x) = 0                          x <= -(L + s)
//        = (x + L + s)^2 / (8 L s)    -(L + s) <= x <= -(L - s)     (the ramp; only when s > 0)
//        = (x + L) / (2 L)            -(L - s) <= x <= 0
// and C(x) = 1 - C(-x) on the right. Written per piece (no difference of large squares), so a
// very narrow second box (s << L) keeps full precision.
double footprintCdf(double w1, double w2, double x) {
  const double L = 0.5 * std::max(w1, w2), s = 0.5 * std::min(w1, w2);
  if (!(L > 0)) return x > 0 ? 1.0 : 0.0;  // point mass at 0, see Footprint::weight
  const bool left = x <= 0;
  const double u = left ? x : -x;
  const double y = u + L + s;
  double c;
  if (y <= 0)
    c = 0;
  else if (u < -(L - s))  // unreachable for s = 0: then y > 0 means u > -L
    c = y * y / (8.0 * L * s);
  else
    c = (u + L) / (2.0 * L);
  c = clamp01(c);
  return left ? c : 1.0 - c;
}

// ------------------------------------------------------------------------------------------------
// Merge helpers (Bosch 2007 §4.2.3.1)
// ------------------------------------------------------------------------------------------------

// One profile placed in footprint coordinates: points with b non-decreasing, lo/hi its b range.
struct Placed {
  std::vector<Vec2d> pts;
  std::vector<int> layer;
  double lo = 0, hi = 0;
  double offset = 0, rho = 0, turn = 0;  // PlacedProfile's
};

double lerpW(Vec2d a, Vec2d c, double b) {
  return c.x > a.x ? a.y + (c.y - a.y) * (b - a.x) / (c.x - a.x) : a.y;
}

// Height approached from the left at b (lo < b <= hi): the first vertex at b if there is one
// (the top or bottom of a vertical facet met first), else the facet spanning b.
double leftValue(const Placed& p, double b) {
  auto it = std::lower_bound(p.pts.begin(), p.pts.end(), b,
                             [](const Vec2d& q, double v) { return q.x < v; });
  if (it == p.pts.end()) return p.pts.back().y;
  if (it->x == b || it == p.pts.begin()) return it->y;
  return lerpW(*(it - 1), *it, b);
}

// Height approached from the right at b (lo <= b < hi): the last vertex at b, else interpolated.
double rightValue(const Placed& p, double b) {
  auto it = std::upper_bound(p.pts.begin(), p.pts.end(), b,
                             [](double v, const Vec2d& q) { return v < q.x; });
  if (it == p.pts.begin()) return it->y;
  const auto prev = it - 1;
  if (prev->x == b || it == p.pts.end()) return prev->y;
  return lerpW(*prev, *it, b);
}

// Layer of the (non-vertical) facet of p that spans the open interval (u, v), lo <= u < v <= hi.
int layerSpanning(const Placed& p, double u) {
  auto it = std::upper_bound(p.pts.begin(), p.pts.end(), u,
                             [](double v, const Vec2d& q) { return v < q.x; });
  size_t k = it == p.pts.begin() ? 0 : size_t(it - p.pts.begin()) - 1;
  k = std::min(k, p.layer.size() - 1);
  return p.layer[k];
}

// Appends a point to the section, with the layer of the facet that ends at it and the placed
// profile it lies on (`from`, an index into the sorted profiles; -1 for the base plane and for cuts
// that no one profile's facet makes), recorded in `src`; repeated points (zero-length facets) are
// dropped.
void emit(Section& s, std::vector<int>& src, Vec2d q, int layer, int from) {
  if (!s.pts.empty()) {
    const Vec2d& last = s.pts.back();
    if (last.x == q.x && last.y == q.y) return;
    s.layer.push_back(layer);
    src.push_back(from);
  }
  s.pts.push_back(q);
}

// The vertical step of the merged surface at b, from the current last point up or down to wTo.
// It is cut at every vertex any profile has at b (and at w = 0) so that the layers of vertical
// facets survive; each piece takes the layer of a profile whose own vertical facet at b covers
// it. A piece that no profile's vertical facet covers is a cut through material that another
// profile's envelope exposes: above the base plane that is pile-up (layer 0, as Profile::withLayers
// assigns), below it we keep the layer of the facet just emitted.
// The piece's profile (for its tilt) is the one whose vertical facet covers it, else one with a
// vertex at b (a groove's edge), else none.
void verticalStep(Section& out, std::vector<int>& src, const std::vector<Placed>& ps, double b, double wTo) {
  const double wFrom = out.pts.back().y;
  if (wFrom == wTo) return;
  const double lo = std::min(wFrom, wTo), hi = std::max(wFrom, wTo);
  std::vector<double> levels;
  if (0 > lo && 0 < hi) levels.push_back(0);
  for (const Placed& p : ps) {
    if (b < p.lo || b > p.hi) continue;
    for (const Vec2d& q : p.pts)
      if (q.x == b && q.y > lo && q.y < hi) levels.push_back(q.y);
  }
  std::sort(levels.begin(), levels.end());
  levels.erase(std::unique(levels.begin(), levels.end()), levels.end());
  if (wTo < wFrom) std::reverse(levels.begin(), levels.end());
  levels.push_back(wTo);

  double prev = wFrom;
  for (double w : levels) {
    const double mid = 0.5 * (prev + w);
    int layer = -1, from = -1;
    for (size_t j = 0; j < ps.size(); ++j) {
      const Placed& p = ps[j];
      if (b < p.lo || b > p.hi || layer >= 0) continue;
      for (size_t k = 0; k + 1 < p.pts.size(); ++k) {
        const Vec2d a = p.pts[k], c = p.pts[k + 1];
        if (from < 0 && (a.x == b || c.x == b)) from = int(j);
        if (a.x == b && c.x == b && mid >= std::min(a.y, c.y) && mid <= std::max(a.y, c.y)) {
          layer = p.layer[k];
          from = int(j);
          break;
        }
      }
    }
    if (layer < 0) layer = (mid >= 0 || out.layer.empty()) ? 0 : out.layer.back();
    emit(out, src, {b, w}, layer, from);
    prev = w;
  }
}

// ------------------------------------------------------------------------------------------------
// 2-D ray casting against the section (shadowing and scattering)
// ------------------------------------------------------------------------------------------------

struct Hit {
  int facet = -1;
  double s = kInf;  // ray parameter of the hit
};

// The highest point of the section (rays climbing above it meet nothing more).
double sectionTop(const Section& sec) {
  double top = -kInf;
  for (const Vec2d& q : sec.pts) top = std::max(top, q.y);
  return top;
}

// Where the ray P + s d crosses facet j's line within the facet (parameter u in [0, 1]): u and s.
// False for a facet parallel to d (or of no length), or a crossing outside it.
bool crossing(const Section& sec, size_t j, Vec2d P, Vec2d d, double& u, double& s) {
  const Vec2d A = sec.pts[j], e = sec.pts[j + 1] - sec.pts[j];
  const double den = cross(d, e);
  if (den == 0) return false;
  const Vec2d AP = A - P;
  // Where the ray's line crosses the facet first: most facets are missed there, and the ray
  // parameter is then not needed.
  u = cross(AP, d) / den;
  if (!(u >= 0 && u <= 1)) return false;
  s = cross(AP, e) / den;
  return true;
}

// First facet other than `skip` that the ray P + s d (s > 0) meets, P a point of facet `skip`.
// Callers start rays from the interior of a facet away from every breakpoint, so no tolerance is
// needed at vertices. The facets are in order of b, so a ray with d_b > 0 can only meet those after
// `skip`, and meets them in that order (its b grows with s): the first one it meets is the
// nearest, and a rising ray that has climbed above `top` (sectionTop) at a facet's near end meets
// nothing from there on. (d_b < 0 the same way down; d_b = 0 tests every facet.)
Hit firstHit(const Section& sec, Vec2d P, Vec2d d, size_t skip, double top) {
  Hit best;
  // Facet j's crossing with the ray, kept when it is the nearest so far.
  auto test = [&](size_t j) {
    double u, s;
    if (!crossing(sec, j, P, d, u, s) || !(s > 0 && s < best.s)) return false;
    best = {int(j), s};
    return true;
  };
  const size_t nf = sec.facets();
  // The ray's height where it reaches b (d_b != 0), against the top with a margin far above
  // rounding and far below any facet.
  const double slope = d.x != 0 ? d.y / d.x : 0.0;
  const double above = top + 1e-9 * (1.0 + std::fabs(top));
  if (d.x > 0) {
    for (size_t j = skip + 1; j < nf; ++j) {
      if (d.y > 0 && P.y + (sec.pts[j].x - P.x) * slope > above) break;
      if (test(j)) break;
    }
    return best;
  }
  if (d.x < 0) {
    for (size_t j = std::min(skip, nf); j-- > 0;) {
      if (d.y > 0 && P.y + (sec.pts[j + 1].x - P.x) * slope > above) break;
      if (test(j)) break;
    }
    return best;
  }
  for (size_t j = 0; j < nf; ++j)
    if (j != skip) test(j);
  return best;
}

// Parameter on facet j's line where the line through P along d crosses it (affine in P).
double lineParam(const Section& sec, size_t j, Vec2d P, Vec2d d) {
  const Vec2d A = sec.pts[j], e = sec.pts[j + 1] - sec.pts[j];
  const double den = cross(d, e);
  return den != 0 ? cross(A - P, d) / den : 0.0;
}

// Sorted parameters in [t0, t1] on facet k where the line through some section vertex along d
// crosses the facet, plus t0 and t1. Between consecutive ones, rays along d from the facet meet
// the same first facet (the order along d only changes where a ray grazes a vertex), so one ray
// from each sub-interval's midpoint decides it: the ordered-projection idea of Bosch 2007
// §4.2.3.3, evaluated by ray casting so that it holds for any sign of d_w.
// (Into `ts`, whose storage the callers reuse.)
void breakpoints(const Section& sec, size_t k, Vec2d d, double t0, double t1, std::vector<double>& ts) {
  ts.assign({t0, t1});
  // q = cross(d, P) is constant along lines parallel to d, affine along the facet.
  const double qa = cross(d, sec.pts[k]), dq = cross(d, sec.pts[k + 1]) - qa;
  if (dq != 0)
    for (const Vec2d& V : sec.pts) {
      const double t = (cross(d, V) - qa) / dq;
      if (t > t0 && t < t1) ts.push_back(t);
    }
  std::sort(ts.begin(), ts.end());
  ts.erase(std::unique(ts.begin(), ts.end()), ts.end());
}

// Footprint weights of the sub-ranges [ts[i], ts[i+1]] of portion p (through Portion::xAt).
// Where the footprint gives them no weight at all (the portion's x range is a single point of a
// point footprint) the parameter lengths stand in, so the shares still split p in proportion.
void subWeights(const Portion& p, const Footprint& fp, const std::vector<double>& ts, std::vector<double>& w) {
  w.assign(ts.size() - 1, 0.0);
  double total = 0;
  for (size_t i = 0; i + 1 < ts.size(); ++i) {
    const double xa = p.xAt(ts[i]), xb = p.xAt(ts[i + 1]);
    w[i] = fp.weight(std::min(xa, xb), std::max(xa, xb));
    total += w[i];
  }
  if (!(total > 0))
    for (size_t i = 0; i + 1 < ts.size(); ++i) w[i] = ts[i + 1] - ts[i];
}

bool validPortion(const Section& s, const Portion& p) {
  return p.facet >= 0 && size_t(p.facet) < s.facets();
}

}  // namespace

// ------------------------------------------------------------------------------------------------
// Section
// ------------------------------------------------------------------------------------------------

Vec2d Section::normal(size_t k) const {
  const Vec2d d = pts[k + 1] - pts[k];
  const double len = std::sqrt(dot(d, d));
  if (!(len > 0)) return {0, 1};  // zero-length facet (merge never makes one): treat as flat
  return {-d.y / len, d.x / len};
}

Vec2d pointOn(const Section& s, int k, double t) {
  const Vec2d a = s.pts[size_t(k)], b = s.pts[size_t(k) + 1];
  return a + (b - a) * t;
}

// ------------------------------------------------------------------------------------------------
// Merge (Bosch 2007 §4.2.3.1, Eq. 4.2)
// ------------------------------------------------------------------------------------------------

// Where profiles overlap, material removed by any of them is gone and material piled up by any
// of them stays: the surface is the lowest of the heights where one is below the base (w < 0), else
// the highest (the base w = 0 counted as a height). This is the composite height of the explicit
// geometry (scratchHeight) and of the polygons (groove_area.cpp), so that all three describe the
// same surface; a lower envelope everywhere would shave one groove's pile-up down to the flank of
// the next one's (two parallel scratches 0.12 mm apart, under the bar light: 3.6% of pixels at
// S-CIELAB dE >= 10 against the explicit geometry, 0% with the common rule).
// A sweep over b through every vertex of every placed profile: on each interval between
// consecutive vertex positions every profile defined there is linear, so the merged surface
// follows one of those lines between their crossings and their zero crossings; the flat base
// w = 0 where no profile is defined; at each vertex position the surface steps vertically from
// the left-hand limit to the right-hand limit. A single profile is reproduced verbatim; on exact
// ties the earlier profile (in order of b) is kept.
// (A zero-width vertical slit down and up again at one b is not representable as a height step
// and is lost where profiles overlap; nothing removes material there anyway.)
Section merge(const std::vector<PlacedProfile>& grooves, double extent) {
  std::vector<Placed> ps;
  for (const PlacedProfile& g : grooves) {
    if (!g.pts || g.pts->size() < 2) continue;
    Placed p;
    const size_t n = g.pts->size();
    p.pts.resize(n);
    p.layer.assign(n - 1, 0);
    for (size_t i = 0; i < n; ++i) {
      // Mirroring reverses the order so that b stays non-decreasing (digest §2.2.3 (1)).
      const Vec2d q = (*g.pts)[g.mirrored ? n - 1 - i : i];
      p.pts[i] = {(g.mirrored ? -q.x : q.x) + g.offset, q.y};
    }
    if (g.layer && g.layer->size() == n - 1)
      for (size_t k = 0; k + 1 < n; ++k) p.layer[k] = (*g.layer)[g.mirrored ? n - 2 - k : k];
    p.lo = p.pts.front().x;
    p.hi = p.pts.back().x;
    p.offset = g.offset;
    p.rho = g.rho;
    p.turn = g.turn;
    if (!(p.hi > p.lo)) continue;  // zero width: removes no material
    ps.push_back(std::move(p));
  }
  std::stable_sort(ps.begin(), ps.end(), [](const Placed& a, const Placed& b) {
    return a.lo < b.lo || (a.lo == b.lo && a.hi < b.hi);
  });

  // Flat ends to +-extent, or further when a profile reaches beyond.
  const double e = std::max(0.0, extent);
  double start = -e, end = e;
  for (const Placed& p : ps) {
    start = std::min(start, p.lo);
    end = std::max(end, p.hi);
  }
  std::vector<double> bs{start, end};
  for (const Placed& p : ps)
    for (const Vec2d& q : p.pts) bs.push_back(q.x);
  std::sort(bs.begin(), bs.end());
  bs.erase(std::unique(bs.begin(), bs.end()), bs.end());

  Section out;
  thread_local std::vector<int> src;
  src.clear();
  emit(out, src, {start, 0.0}, 0, -1);
  thread_local std::vector<size_t> active;
  thread_local std::vector<double> ru, lv, cuts;
  for (size_t i = 0; i < bs.size(); ++i) {
    const double b = bs[i];
    // Vertical step at b to the composite of the right-hand limits of the profiles continuing
    // past b.
    double lowest = 0, highest = 0;
    for (const Placed& p : ps)
      if (p.lo <= b && b < p.hi) {
        const double w = rightValue(p, b);
        lowest = std::min(lowest, w);
        highest = std::max(highest, w);
      }
    verticalStep(out, src, ps, b, lowest < 0 ? lowest : highest);
    if (i + 1 == bs.size()) break;

    // Interval (u, v): the composite of the profiles spanning it.
    const double u = b, v = bs[i + 1];
    active.clear();
    ru.clear();
    lv.clear();
    for (size_t j = 0; j < ps.size(); ++j)
      if (ps[j].lo <= u && ps[j].hi >= v) {
        active.push_back(j);
        ru.push_back(rightValue(ps[j], u));
        lv.push_back(leftValue(ps[j], v));
      }
    if (active.empty()) {
      emit(out, src, {v, 0.0}, 0, -1);  // flat base surface between profiles
      continue;
    }
    auto value = [&](size_t a, double x) { return ru[a] + (lv[a] - ru[a]) * (x - u) / (v - u); };
    cuts.assign(1, u);
    for (size_t a = 0; a < active.size(); ++a)
      for (size_t c = a + 1; c < active.size(); ++c) {
        const double du = ru[a] - ru[c], dv = lv[a] - lv[c];
        if ((du < 0 && dv > 0) || (du > 0 && dv < 0)) {
          const double x = u + (v - u) * du / (du - dv);
          if (x > u && x < v) cuts.push_back(x);
        }
      }
    for (size_t a = 0; a < active.size(); ++a)  // where the lowest line may cross the base
      if ((ru[a] < 0 && lv[a] > 0) || (ru[a] > 0 && lv[a] < 0)) {
        const double x = u + (v - u) * ru[a] / (ru[a] - lv[a]);
        if (x > u && x < v) cuts.push_back(x);
      }
    cuts.push_back(v);
    std::sort(cuts.begin(), cuts.end());
    cuts.erase(std::unique(cuts.begin(), cuts.end()), cuts.end());
    // Steps shorter than this are rounding (lines evaluated at their own crossing points).
    double scale = 0;
    for (size_t a = 0; a < active.size(); ++a) scale = std::max({scale, std::abs(ru[a]), std::abs(lv[a])});
    const double tiny = 1e-12 * scale;
    int was_below = -1;  // the previous piece's branch: 1 below the base, 0 not, -1 none yet
    for (size_t c = 0; c + 1 < cuts.size(); ++c) {
      const double mid = 0.5 * (cuts[c] + cuts[c + 1]);
      size_t low = 0, high = 0;
      for (size_t a = 1; a < active.size(); ++a) {  // ties keep the earlier profile
        if (value(a, mid) < value(low, mid)) low = a;
        if (value(a, mid) > value(high, mid)) high = a;
      }
      const bool below = value(low, mid) < 0;
      const size_t win = below ? low : high;
      // Where the lowest line rises through the base, the surface steps up from 0 to the highest
      // line (a groove's edge cutting through another's pile-up); where it falls through the base,
      // down from the highest line to 0. On the interval's first piece, the step at b (taken with
      // the heights at b) may have chosen the other branch, for a line that leaves the base there
      // downwards under a pile-up: then it steps again.
      if (was_below >= 0 && int(below) != was_below) {
        if (was_below) out.pts.back().y = 0.0;
        const double w0 = below ? 0.0 : value(win, cuts[c]);
        if (std::abs(w0 - out.pts.back().y) > tiny) verticalStep(out, src, ps, cuts[c], w0);
        else out.pts.back().y = w0;
      } else if (was_below < 0 && std::abs(ru[win] - out.pts.back().y) > tiny) {
        verticalStep(out, src, ps, u, ru[win]);
      }
      was_below = int(below);
      const double x = cuts[c + 1];
      const double w = x == v ? lv[win] : value(win, x);
      emit(out, src, {x, w}, layerSpanning(ps[active[win]], u), int(active[win]));
    }
  }
  // The facets' slopes along t from the force fades and the turns of their profiles.
  bool tilted = false;
  for (const Placed& p : ps) tilted = tilted || p.rho != 0 || p.turn != 0;
  if (tilted) {
    out.tilt.assign(out.facets(), 0.0);
    for (size_t k = 0; k < out.facets(); ++k)
      if (src[k] >= 0) {
        const Placed& p = ps[size_t(src[k])];
        const Vec2d n = out.normal(k);
        out.tilt[k] = -p.rho * dot(out.pts[k] - Vec2d(p.offset, 0.0), n) - p.turn * n.x;
      }
  }
  return out;
}

// ------------------------------------------------------------------------------------------------
// Footprint (Bosch 2007 §4.2.3.2)
// ------------------------------------------------------------------------------------------------

// Integral of the density over [x0, x1]; the ends are taken in either order. For a point
// footprint (w1 = w2 = 0) the mass at 0 is counted half-open: weight 1 iff x0 <= 0 < x1, so that
// abutting intervals [a, b], [b, c] never count it twice (visible() relies on this).
double Footprint::weight(double x0, double x1) const {
  if (x1 < x0) std::swap(x0, x1);
  const double a = std::max(0.0, w1), b = std::max(0.0, w2);
  return clamp01(footprintCdf(a, b, x1) - footprintCdf(a, b, x0));
}

// ------------------------------------------------------------------------------------------------
// Masking and clipping (Bosch 2007 §4.2.3.2-4.2.3.3, Eqs. 4.3-4.4)
// ------------------------------------------------------------------------------------------------

// Derivation of the occlusion order (checked against a brute-force 2-D ray cast in the tests).
// With r = e_b / e_w, the ray from a section point P towards the viewer is P + s (e_b, e_w). It
// is blocked by a point Q = (b', w') of the section above it; for a height field this requires
// b' on the side the ray moves to, and Q above the ray at b' reduces to a comparison of the
// projections x = b - w r:
//   r > 0 (e_b > 0, viewer on the +b side; Bosch's theta' < 0): Q occludes P iff b' > b_P and
//     x_Q < x_P. P is seen iff x_P <= min of x over everything after it: scan right to left with
//     a running minimum m; facet k shows [x_k, m] where x_k < m, m = min_{j > k} x_j.
//   r <= 0 (viewer on the -b side or overhead; theta' >= 0): Q occludes P iff b' < b_P and
//     x_Q > x_P: scan left to right with a running maximum M; facet k shows [M, x_{k+1}] where
//     x_{k+1} > M, M = max_{j <= k} x_j.
// Either way a facet whose projection runs backwards (x_{k+1} <= x_k) faces away and is hidden.
// The visible intervals tile [min_j x_j, x_last] exactly (abutting ends are the same doubles),
// and since the section starts at b <= -extent and ends at b >= extent on w = 0 they cover the
// footprint whenever extent >= its half width: the weights sum to 1.
std::vector<Portion> visible(const Section& s, Vec2d e_bw, const Footprint& fp) {
  std::vector<Portion> out;
  const size_t n = s.pts.size();
  if (n < 2) return out;
  const double r = e_bw.x / std::max(e_bw.y, 1e-6);  // grazing clamp keeps x finite
  thread_local std::vector<double> x;
  x.resize(n);
  for (size_t j = 0; j < n; ++j) x[j] = s.pts[j].x - s.pts[j].y * r;  // Eq. 4.3
  const double hw = fp.halfWidth();

  // Clip the visible projected interval [xa, xb] of facet k to the footprint (Eq. 4.4) and
  // convert it to facet parameters (the projection is affine along the facet, x_k < x_{k+1}).
  auto add = [&](size_t k, double xa, double xb) {
    const double dx = x[k + 1] - x[k];
    if (!(dx > 0)) return;
    Portion p;
    p.facet = int(k);
    if (hw > 0) {
      const double lo = std::max(xa, -hw), hi = std::min(xb, hw);
      if (!(lo < hi)) return;
      p.weight = fp.weight(lo, hi);
      if (!(p.weight > 0)) return;
      p.t0 = clamp01((lo - x[k]) / dx);
      p.t1 = clamp01((hi - x[k]) / dx);
      p.x0 = lo;
      p.x1 = hi;
    } else {
      // Point footprint: the single line through F; half-open so exactly one portion holds it.
      if (!(xa <= 0 && 0 < xb)) return;
      p.t0 = p.t1 = clamp01(-x[k] / dx);
      p.x0 = p.x1 = 0;
      p.weight = 1;
    }
    out.push_back(p);
  };

  if (r > 0) {
    double m = kInf;
    for (size_t k = n - 1; k-- > 0;) {
      m = std::min(m, x[k + 1]);
      if (x[k] < m) add(k, x[k], m);
    }
    std::reverse(out.begin(), out.end());  // report in facet order
  } else {
    double M = -kInf;
    for (size_t k = 0; k + 1 < n; ++k) {
      M = std::max(M, x[k]);
      if (x[k + 1] > M) add(k, M, x[k + 1]);
    }
  }
  return out;
}

// ------------------------------------------------------------------------------------------------
// Shadowing (Bosch 2007 §4.2.3.3, applied along L; the visible part is intersected in t)
// ------------------------------------------------------------------------------------------------

// A point is lit when the 2-D ray from it towards the light meets no other facet. A ray that
// leaves the section going down (l_w < 0) would meet the base plane beyond the flat ends, so it
// counts as shadowed; l_w = 0 rays that leave the section are lit (a measure-zero case).
// The fraction is the lit share of the portion's own footprint weight (recomputed from its x
// range; equal to p.weight for portions from visible() and scatter()).
double litFraction(const Section& s, const Portion& p, const Footprint& fp, Vec2d l_bw) {
  if (!validPortion(s, p) || !(p.weight > 0)) return 0;
  const size_t k = size_t(p.facet);
  if (dot(l_bw, s.normal(k)) <= 0) return 0;  // facet faces away from the light
  const double top = sectionTop(s);
  auto lit = [&](double t) {
    return firstHit(s, pointOn(s, p.facet, t), l_bw, k, top).facet < 0 && l_bw.y >= 0;
  };
  if (!(p.t1 > p.t0)) return lit(p.t0) ? 1.0 : 0.0;
  thread_local std::vector<double> ts, w;
  breakpoints(s, k, l_bw, p.t0, p.t1, ts);
  subWeights(p, fp, ts, w);
  double on = 0, total = 0;
  for (size_t i = 0; i < w.size(); ++i) {
    total += w[i];
    if (lit(0.5 * (ts[i] + ts[i + 1]))) on += w[i];
  }
  return total > 0 ? clamp01(on / total) : 0.0;
}

Shadowing::Shadowing(const Section& s, Vec2d l_bw) { reset(s, l_bw); }

void Shadowing::reset(const Section& s, Vec2d l_bw) {
  s_ = &s;
  l_ = l_bw;
  if (!(l_bw.y > 0)) {
    from_ = 2;
    return;
  }
  from_ = l_bw.x > 0 ? 1 : (l_bw.x < 0 ? -1 : 0);
  if (from_ == 0) return;
  const size_t n = s.pts.size();
  const double r = l_bw.x / l_bw.y;
  x_.resize(n);
  for (size_t i = 0; i < n; ++i) x_[i] = s.pts[i].x - s.pts[i].y * r;
  const size_t nf = s.facets();
  bound_.assign(nf, 0.0);
  if (from_ > 0) {
    double m = kInf;
    for (size_t k = nf; k-- > 0;) {
      m = std::min(m, x_[k + 1]);
      bound_[k] = m;
    }
  } else {
    double m = -kInf;
    for (size_t k = 0; k < nf; ++k) {
      m = std::max(m, x_[k]);
      bound_[k] = m;
    }
  }
}

double Shadowing::litFraction(const Portion& p, const Footprint& fp) const {
  const Section& s = *s_;
  if (!validPortion(s, p) || !(p.weight > 0)) return 0;
  const size_t k = size_t(p.facet);
  if (dot(l_, s.normal(k)) <= 0) return 0;  // facet faces away from the light
  if (from_ == 2) return l_.y == 0 ? groove::litFraction(s, p, fp, l_) : 0.0;  // grazing: exact path
  if (from_ == 0) return 1.0;  // straight up: nothing of a height field is above a point
  const double xa = x_[k], dx = x_[k + 1] - x_[k];
  // Facing the light makes the projection increase along the facet; a degenerate facet takes the
  // exact path.
  if (!(dx > 0)) return groove::litFraction(s, p, fp, l_);
  const double tb = (bound_[k] - xa) / dx;  // where the facet's projection meets the bound
  double la = p.t0, lb = p.t1;              // the lit parameter range
  if (from_ > 0)
    lb = std::min(lb, tb);
  else
    la = std::max(la, tb);
  if (!(p.t1 > p.t0)) return la <= p.t0 && p.t0 <= lb ? 1.0 : 0.0;
  if (!(lb > la)) return 0.0;
  auto w = [&](double ta, double tc) {
    const double xs = p.xAt(ta), xe = p.xAt(tc);
    return fp.weight(std::min(xs, xe), std::max(xs, xe));
  };
  const double total = w(p.t0, p.t1);
  if (!(total > 0)) return clamp01((lb - la) / (p.t1 - p.t0));
  return clamp01(w(la, lb) / total);
}

// ------------------------------------------------------------------------------------------------
// Specular scattering between facets (Bosch 2007 §4.3)
// ------------------------------------------------------------------------------------------------

// The portion is cut where rays along d start grazing a section vertex; each piece's rays meet
// one facet first (or none), and the hit points are an affine image of the piece, so the two end
// rays give the hit portion. Consecutive pieces meeting the same facet are one affine image and
// are reported as one portion. A ray that meets nothing leaves the section: upwards it escapes,
// downwards (d_w <= 0) it passes the flat ends beyond +-extent, and it is counted as escaped too.
// The integrator continues the upward share with an ordinary scene ray and drops the downward one:
// the renderer's extents reach past the footprint's reach by 200 times the grooves' height and
// depth and a millimetre more (Tracer::sectionExtent), so only rays within 0.3 degrees of the base
// plane get that far. Shares are the footprint weights of the
// pieces scaled so that they sum to p.weight exactly.
Scatter scatter(const Section& s, const Portion& p, const Footprint& fp, Vec2d d_bw) {
  Scatter out;
  if (!validPortion(s, p)) return out;
  const size_t k = size_t(p.facet);
  if (dot(d_bw, s.normal(k)) <= 0) return out;

  // (Scratch buffers kept per thread: scatter runs for every sampled direction.)
  thread_local std::vector<double> ts, w;
  thread_local std::vector<int> hit;
  if (p.t1 > p.t0) {
    breakpoints(s, k, d_bw, p.t0, p.t1, ts);
    subWeights(p, fp, ts, w);
  } else {
    ts.assign({p.t0, p.t0});  // a point portion (point footprint): one ray carries everything
    w.assign(1, 1.0);
  }
  double total = 0;
  for (double v : w) total += v;
  const double scale = total > 0 ? p.weight / total : 0.0;

  // Outcome per piece: the facet hit first, or -1.
  const double top = d_bw.y > 0 ? sectionTop(s) : kInf;
  hit.resize(w.size());
  for (size_t i = 0; i < w.size(); ++i)
    hit[i] = firstHit(s, pointOn(s, p.facet, 0.5 * (ts[i] + ts[i + 1])), d_bw, k, top).facet;

  for (size_t i = 0; i < w.size();) {
    size_t j = i;
    double share = 0;
    while (j < w.size() && hit[j] == hit[i]) share += w[j++] * scale;
    const double ta = ts[i], tb = ts[j];
    if (hit[i] < 0) {
      out.escaped += share;
    } else if (share > 0) {
      const size_t f = size_t(hit[i]);
      const double ua = clamp01(lineParam(s, f, pointOn(s, p.facet, ta), d_bw));
      const double ub = clamp01(lineParam(s, f, pointOn(s, p.facet, tb), d_bw));
      Portion h;
      h.facet = hit[i];
      h.weight = share;
      if (ua <= ub) {
        h.t0 = ua, h.t1 = ub, h.x0 = p.xAt(ta), h.x1 = p.xAt(tb);
      } else {
        h.t0 = ub, h.t1 = ua, h.x0 = p.xAt(tb), h.x1 = p.xAt(ta);
      }
      out.hits.push_back(h);
    }
    i = j;
  }
  return out;
}

bool castInto(const Section& s, Vec2d P, Vec2d d, int& facet, double& t, double* ray_s) {
  // Every facet is tested: this runs for the few rays that leave a polygon region downwards, and
  // firstHit's ordered scan needs a start on a facet.
  double best = kInf;
  facet = -1;
  for (size_t j = 0; j < s.facets(); ++j) {
    if (!(dot(d, s.normal(j)) < 0)) continue;  // its back, or along it
    double u, r;
    if (!crossing(s, j, P, d, u, r) || !(r >= 0 && r < best)) continue;
    best = r;
    facet = int(j);
    t = u;
  }
  if (ray_s && facet >= 0) *ray_s = best;
  return facet >= 0;
}

Scatter scatterInside(const Section& s, const Portion& p, const Footprint& fp, Vec2d d_bw) {
  thread_local Section m;
  m.pts = s.pts;
  for (Vec2d& q : m.pts) q.y = -q.y;
  m.layer = s.layer;
  m.tilt.clear();
  return scatter(m, p, fp, Vec2d(d_bw.x, -d_bw.y));
}

}  // namespace dg::groove
