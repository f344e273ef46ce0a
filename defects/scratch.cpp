// Scratch geometry: paths, process-derived and explicit cross-sections, variation along the path,
// the Scratch defect and random placement. See scratch.h for the conventions and the sources
// (Bosch 2007 chapter 3; shared/reference/bosch-grooves.md §1.3-1.4, §5.2-5.3).
#include "defects/scratch.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <stdexcept>

namespace dg {

namespace {

double len2(Vec2d a) { return std::sqrt(dot(a, a)); }

// Distance from p to the segment [a, b].
double segDist(Vec2d p, Vec2d a, Vec2d b) {
  Vec2d d = b - a;
  double l2 = dot(d, d);
  double t = l2 > 0 ? std::clamp(dot(p - a, d) / l2, 0.0, 1.0) : 0.0;
  return len2(p - (a + d * t));
}

void flattenCubic(Vec2d p0, Vec2d p1, Vec2d p2, Vec2d p3, double tol, int depth,
                  std::vector<Vec2d>& out) {
  // Flat enough: the curve lies in the hull of its control points, and the distance to the chord
  // segment is convex, so its maximum over the hull is at a control point.
  if (depth >= 30 || (segDist(p1, p0, p3) <= tol && segDist(p2, p0, p3) <= tol)) {
    out.push_back(p3);
    return;
  }
  // de Casteljau at t = 1/2.
  Vec2d a = (p0 + p1) * 0.5, b = (p1 + p2) * 0.5, c = (p2 + p3) * 0.5;
  Vec2d d = (a + b) * 0.5, e = (b + c) * 0.5, m = (d + e) * 0.5;
  flattenCubic(p0, a, d, m, tol, depth + 1, out);
  flattenCubic(m, e, c, p3, tol, depth + 1, out);
}

// Douglas-Peucker on an open polyline, keeping both ends: a vertex is kept where it lies farther
// than allowed(i) from the chord of the run that holds it.
template <class Allowed>
void simplifyBy(const std::vector<Vec2d>& in, size_t i0, size_t i1, const Allowed& allowed, std::vector<char>& keep) {
  if (i1 <= i0 + 1) return;
  double worst = -1;
  size_t wi = i0;
  for (size_t i = i0 + 1; i < i1; ++i) {
    double d = segDist(in[i], in[i0], in[i1]) - allowed(i);
    if (d > worst) {
      worst = d;
      wi = i;
    }
  }
  if (worst > 0) {
    keep[wi] = 1;
    simplifyBy(in, i0, wi, allowed, keep);
    simplifyBy(in, wi, i1, allowed, keep);
  }
}
void simplify(const std::vector<Vec2d>& in, size_t i0, size_t i1, double tol, std::vector<char>& keep) {
  simplifyBy(in, i0, i1, [tol](size_t) { return tol; }, keep);
}

// Area between a polyline piece and w = 0 where w has the sign `sgn` (+1 above, -1 below).
double signedPartArea(Vec2d a, Vec2d b, int sgn) {
  double w0 = a.y * sgn, w1 = b.y * sgn, db = b.x - a.x;
  if (w0 >= 0 && w1 >= 0) return 0.5 * (w0 + w1) * db;
  if (w0 <= 0 && w1 <= 0) return 0.0;
  // One crossing: only the triangle on the positive side counts.
  double t = w0 / (w0 - w1);
  return w0 > 0 ? 0.5 * w0 * t * db : 0.5 * w1 * (1 - t) * db;
}

float lerpTable(const std::vector<float>& tab, float ds, float s) {
  if (tab.empty()) return 0.0f;
  float x = s / ds;
  if (!(x > 0)) return tab.front();
  size_t i = size_t(x);
  if (i + 1 >= tab.size()) return tab.back();
  float f = x - float(i);
  return tab[i] + (tab[i + 1] - tab[i]) * f;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// ScratchPath
// ---------------------------------------------------------------------------------------------

ScratchPath ScratchPath::polyline(std::vector<Vec2d> pts) {
  ScratchPath p;
  for (const Vec2d& q : pts) {
    if (!std::isfinite(q.x) || !std::isfinite(q.y))
      throw std::invalid_argument("ScratchPath: non-finite point");
    if (p.pts_.empty() || q.x != p.pts_.back().x || q.y != p.pts_.back().y) p.pts_.push_back(q);
  }
  if (p.pts_.size() < 2) throw std::invalid_argument("ScratchPath: needs two distinct points");
  p.snapRetraces();
  p.finish();
  return p;
}

// A segment that goes back along the line of the segment before it, or of the line its start was
// put on, and ends within kRetraceSnap of that line, is taken as exactly on it: its end moves to
// its foot on the line. Typed or rounded coordinates (four decimals) leave such a path 1e-6 to
// 1e-4 rad off its own line, not on one line by the renderer's tests, and the explicit geometry
// then took whichever pass rounded nearer at each point: bright specks along the groove
// (docs/grooves.md, "Nearly one line"). The move is below a tenth of a micrometre.
void ScratchPath::snapRetraces() {
  std::vector<Vec2d> on_a(pts_.size()), on_b(pts_.size());  // the line vertex i was put on
  std::vector<char> put(pts_.size(), 0);
  for (size_t i = 2; i < pts_.size(); ++i) {
    const Vec2d q = pts_[i - 1], e = pts_[i];
    // The lines through q: its own segment's, and the one q was put on.
    const Vec2d lines[2][2] = {{pts_[i - 2], q}, {on_a[i - 1], on_b[i - 1]}};
    for (int k = 0; k < (put[i - 1] ? 2 : 1); ++k) {
      const Vec2d a = lines[k][0], b = lines[k][1];
      const Vec2d d = b - a;
      const double dd = dot(d, d);
      if (!(dd > 0) || (e.x == a.x && e.y == a.y) || (e.x == b.x && e.y == b.y)) continue;
      const double back = -dot(e - q, d) / std::sqrt(dd);  // how far back along the line (> 0)
      const double off = std::fabs(d.x * (e.y - a.y) - d.y * (e.x - a.x)) / std::sqrt(dd);
      // Back along the line (not on along it, nor a jog across it: within 0.1 rad of it), and
      // near it.
      if (!(back > 0 && off > 0 && off <= kRetraceSnap && off <= 0.1 * back)) continue;
      pts_[i] = a + d * (dot(e - a, d) / dd);
      on_a[i] = a;
      on_b[i] = b;
      put[i] = 1;
      break;
    }
  }
  // (A foot that rounds onto the vertex before it would leave a segment of no length.)
  pts_.erase(std::unique(pts_.begin(), pts_.end(), [](const Vec2d& u, const Vec2d& v) { return u.x == v.x && u.y == v.y; }),
             pts_.end());
}

const ScratchPath::Corner* ScratchPath::nearestOf(const Corner* b, const Corner* e, Vec2d p, double max_dist) {
  const Corner* best = nullptr;
  double best_d = max_dist;
  for (const Corner* c = b; c != e; ++c) {
    const double d = len2(c->p - p);
    if (d <= best_d) {
      best_d = d;
      best = c;
    }
  }
  return best;
}

const ScratchPath::Corner* ScratchPath::nearestCorner(Vec2d p, double max_dist) const {
  return nearestOf(corners_.data(), corners_.data() + corners_.size(), p, max_dist);
}

const ScratchPath::Corner* ScratchPath::cornerAround(double s, Vec2d p, double max_dist) const {
  const Corner *b = corners_.data(), *e = b + corners_.size();
  const Corner* after = std::lower_bound(b, e, s, [](const Corner& c, double v) { return c.s < v; });
  return nearestOf(after == b ? b : after - 1, after == e ? e : after + 1, p, max_dist);
}

std::pair<double, double> ScratchPath::legSpan(const Corner& c) const {
  const size_t i = size_t(&c - corners_.data());
  return {i > 0 ? corners_[i - 1].s : 0.0, i + 1 < corners_.size() ? corners_[i + 1].s : length()};
}

std::pair<double, double> ScratchPath::spanAt(double s) const {
  const Corner *b = corners_.data(), *e = b + corners_.size();
  const Corner* after = std::upper_bound(b, e, s, [](double v, const Corner& c) { return v < c.s; });
  return {after == b ? 0.0 : (after - 1)->s, after == e ? length() : after->s};
}

void ScratchPath::keepRetracesAlike(size_t a, size_t b, std::vector<char>& keep) const {
  // Where the path goes exactly back over its own points (a cubic followed by its reverse, which
  // flattens into the same points), the kept vertices on the way out and on the way back must be
  // the same points, so that the legs of both passes lie on one line and the explicit geometry's
  // tie (to the earlier pass: ScratchPath::closest) can be kept by chainParts. The simplification
  // itself is not symmetric: Douglas-Peucker splits each run at its first farthest vertex, and a
  // run from a point back to that point has two (each vertex and its mirror image). Kept apart,
  // the legs of the two passes crossed at small angles and each held where it was the nearer: a
  // tilted tool's mirrored cross-section in wedges along the groove (docs/grooves.md, "Straight
  // back over itself").
  for (size_t m = a + 1; m < b; ++m) {
    if (!(pts_[m - 1].x == pts_[m + 1].x && pts_[m - 1].y == pts_[m + 1].y)) continue;
    keep[m] = 1;  // (the half turn itself: the two passes' legs meet there)
    for (size_t j = 1; j <= m - a && m + j <= b; ++j) {
      const size_t lo = m - j, hi = m + j;
      if (!(pts_[lo].x == pts_[hi].x && pts_[lo].y == pts_[hi].y)) break;
      // (The window's ends count as kept: the chain starts and ends there.)
      if (lo == a || hi == b || keep[lo] || keep[hi]) {
        if (lo > a) keep[lo] = 1;
        if (hi < b) keep[hi] = 1;
      }
    }
  }
}

bool ScratchPath::bendsAround(double s, Vec2d p, double reach, double tol, double growth, double min_stray,
                              size_t max_bends, double max_dev, std::vector<Corner>& out,
                              std::pair<double, double>& span, double near, size_t max_near) const {
  out.clear();
  // The window: from s's segment out to the first vertex on each side beyond `reach`.
  const size_t last = pts_.size() - 1;
  const ptrdiff_t after = std::upper_bound(arc_.begin(), arc_.end(), s) - arc_.begin();
  const size_t seg = std::min(last - 1, size_t(std::max<ptrdiff_t>(0, after - 1)));
  size_t a = seg, b = seg + 1;
  while (a > 0 && len2(pts_[a] - p) <= reach) --a;
  while (b < last && len2(pts_[b] - p) <= reach) ++b;
  if (b <= a + 1) return false;
  // Straight enough: every vertex within min_stray of the tangent at s.
  const Vec2d q = pointAt(s), t = tangentAt(s);
  bool strays = false;
  for (size_t i = a; i <= b && !strays; ++i) strays = std::fabs(cross(t, pts_[i] - q)) > min_stray;
  if (!strays) return false;
  thread_local std::vector<char> keep;
  // The window's segments within `near` of p beyond s's segment's distance (the same every round).
  thread_local std::vector<size_t> near_segs;
  near_segs.clear();
  if (near > 0) {
    const double d_max = segDist(p, pts_[seg], pts_[seg + 1]) + near;
    for (size_t j = a; j < b; ++j)
      if (segDist(p, pts_[j], pts_[j + 1]) <= d_max) near_segs.push_back(j);
  }
  double dp_tol = tol;
  for (int round = 0; round <= 16; ++round, (growth > 0 ? growth : dp_tol) *= 2) {
    keep.assign(pts_.size(), 0);
    simplifyBy(pts_, a, b, [&](size_t i) { return dp_tol + growth * len2(pts_[i] - p); }, keep);
    // The kept leg that holds segment j, where it turns from that segment by more than max_dev:
    // the segment's own ends as well. Returns whether it kept one.
    auto holdDirection = [&](size_t j) {
      size_t lo = j, hi = j + 1;
      while (lo > a && !keep[lo]) --lo;
      while (hi < b && !keep[hi]) ++hi;
      const Vec2d dl = pts_[hi] - pts_[lo], ds = pts_[j + 1] - pts_[j];
      if (!(std::fabs(std::atan2(cross(dl, ds), dot(dl, ds))) > max_dev)) return false;
      bool added = false;
      if (j > a && !keep[j]) keep[j] = 1, added = true;
      if (j + 1 < b && !keep[j + 1]) keep[j + 1] = 1, added = true;
      return added;
    };
    holdDirection(seg);
    auto countKept = [&] {
      size_t n = 0;
      for (size_t i = a + 1; i < b; ++i) n += keep[i] != 0;
      return n;
    };
    // The segments near p as well, while the bends stay within max_near. Keeping a vertex splits
    // a leg into chords that may turn from their segments anew, so until none does (each pass
    // keeps at least one more vertex of the window, or stops).
    size_t limit = max_bends;
    if (!near_segs.empty() && countKept() <= max_bends) {
      thread_local std::vector<char> before;
      before = keep;
      bool added = true;
      while (added) {
        added = false;
        for (size_t j : near_segs) added = holdDirection(j) || added;
      }
      const size_t near_cap = std::max(max_near, max_bends);
      if (countKept() > near_cap)
        keep = before;
      else
        limit = near_cap;
    }
    keepRetracesAlike(a, b, keep);
    const size_t kept = countKept();
    if (kept == 0) return false;
    if (kept > limit) continue;
    size_t prev = a;
    for (size_t i = a + 1; i < b; ++i) {
      if (!keep[i]) continue;
      size_t next = i + 1;
      while (next < b && !keep[next]) ++next;
      const Vec2d da = pts_[i] - pts_[prev], db = pts_[next] - pts_[i];
      const Vec2d ta = da * (1.0 / len2(da)), tb = db * (1.0 / len2(db));
      out.push_back({i, arc_[i], pts_[i], ta, tb, std::atan2(cross(ta, tb), dot(ta, tb))});
      prev = i;
    }
    span = {arc_[a], arc_[b]};
    return true;
  }
  return false;
}

ScratchPath ScratchPath::sub(double s0, double s1) const {
  const double L = length();
  s0 = std::clamp(s0, 0.0, L);
  s1 = std::clamp(s1, 0.0, L);
  if (!(s1 > s0)) throw std::invalid_argument("ScratchPath::sub: empty interval");
  std::vector<Vec2d> out{pointAt(s0)};
  for (size_t i = 0; i < pts_.size(); ++i)
    if (arc_[i] > s0 && arc_[i] < s1) out.push_back(pts_[i]);
  out.push_back(pointAt(s1));
  return polyline(std::move(out));
}

ScratchPath ScratchPath::bezier(const std::vector<Vec2d>& c, double tol) {
  if (c.size() < 4 || (c.size() - 1) % 3 != 0)
    throw std::invalid_argument("ScratchPath::bezier: needs 3k+1 control points (k >= 1)");
  if (!(tol > 0)) throw std::invalid_argument("ScratchPath::bezier: chord error must be > 0");
  std::vector<Vec2d> out{c[0]};
  for (size_t i = 0; i + 3 < c.size(); i += 3) flattenCubic(c[i], c[i + 1], c[i + 2], c[i + 3], tol, 0, out);
  return polyline(std::move(out));
}

ScratchPath ScratchPath::arc(Vec2d centre, double radius, double start, double sweep, double tol) {
  if (!(radius > 0) || !(tol > 0) || sweep == 0 || !std::isfinite(sweep))
    throw std::invalid_argument("ScratchPath::arc: radius > 0, tol > 0, sweep != 0 required");
  // Sagitta of a chord spanning angle d: r (1 - cos(d/2)) <= tol.
  double dmax = tol >= radius ? kPi / 2 : std::min(kPi / 2, 2.0 * std::acos(1.0 - tol / radius));
  int n = std::clamp(int(std::ceil(std::fabs(sweep) / dmax)), 1, 1 << 20);
  std::vector<Vec2d> pts(size_t(n) + 1);
  for (int i = 0; i <= n; ++i) {
    double a = start + sweep * double(i) / n;
    pts[size_t(i)] = {centre.x + radius * std::cos(a), centre.y + radius * std::sin(a)};
  }
  return polyline(std::move(pts));
}

void ScratchPath::finish() {
  size_t n = pts_.size();
  arc_.assign(n, 0.0);
  ptsf_.resize(n);
  arcf_.resize(n);
  box_ = Box2{};
  for (size_t i = 0; i < n; ++i) {
    if (i > 0) arc_[i] = arc_[i - 1] + len2(pts_[i] - pts_[i - 1]);
    ptsf_[i] = {float(pts_[i].x), float(pts_[i].y)};
    arcf_[i] = float(arc_[i]);
    box_.lo = {std::min(box_.lo.x, ptsf_[i].x), std::min(box_.lo.y, ptsf_[i].y)};
    box_.hi = {std::max(box_.hi.x, ptsf_[i].x), std::max(box_.hi.y, ptsf_[i].y)};
  }
  corners_.clear();
  for (size_t i = 1; i + 1 < n; ++i) {
    const Vec2d a = pts_[i] - pts_[i - 1], b = pts_[i + 1] - pts_[i];
    const double la = len2(a), lb = len2(b);
    const Vec2d ta = a * (1.0 / la), tb = b * (1.0 / lb);
    const double turn = std::atan2(ta.x * tb.y - ta.y * tb.x, ta.x * tb.x + ta.y * tb.y);
    if (std::fabs(turn) >= kCornerTurn) corners_.push_back({i, arc_[i], pts_[i], ta, tb, turn});
  }
  // Segment grid: square cells, about two per segment along the longer box side.
  size_t nseg = n - 1;
  gx_ = gy_ = 0;
  cell_start_.clear();
  cell_seg_.clear();
  if (nseg < 8) return;
  float ext = std::max(box_.hi.x - box_.lo.x, box_.hi.y - box_.lo.y);
  int per_side = std::clamp(int(std::ceil(2.0 * std::sqrt(double(nseg)))), 1, 256);
  float cell = std::max(ext / float(per_side), 1e-6f);
  cell_w_ = cell_h_ = cell;
  gx_ = std::max(1, int(std::ceil((box_.hi.x - box_.lo.x) / cell)) + 1);
  gy_ = std::max(1, int(std::ceil((box_.hi.y - box_.lo.y) / cell)) + 1);
  auto cellRange = [&](size_t i, int& x0, int& x1, int& y0, int& y1) {
    Vec2f a = ptsf_[i], b = ptsf_[i + 1];
    x0 = std::clamp(int((std::min(a.x, b.x) - box_.lo.x) / cell), 0, gx_ - 1);
    x1 = std::clamp(int((std::max(a.x, b.x) - box_.lo.x) / cell), 0, gx_ - 1);
    y0 = std::clamp(int((std::min(a.y, b.y) - box_.lo.y) / cell), 0, gy_ - 1);
    y1 = std::clamp(int((std::max(a.y, b.y) - box_.lo.y) / cell), 0, gy_ - 1);
  };
  std::vector<uint32_t> count(size_t(gx_) * gy_ + 1, 0);
  for (size_t i = 0; i < nseg; ++i) {
    int x0, x1, y0, y1;
    cellRange(i, x0, x1, y0, y1);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) ++count[size_t(y) * gx_ + x + 1];
  }
  for (size_t c = 1; c < count.size(); ++c) count[c] += count[c - 1];
  cell_start_ = count;
  cell_seg_.resize(count.back());
  for (size_t i = 0; i < nseg; ++i) {
    int x0, x1, y0, y1;
    cellRange(i, x0, x1, y0, y1);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) cell_seg_[count[size_t(y) * gx_ + x]++] = uint32_t(i);
  }
}

Vec2d ScratchPath::pointAt(double s) const {
  s = std::clamp(s, 0.0, length());
  size_t i = size_t(std::upper_bound(arc_.begin(), arc_.end(), s) - arc_.begin());
  i = std::clamp(i, size_t(1), pts_.size() - 1) - 1;
  double l = arc_[i + 1] - arc_[i];
  double t = l > 0 ? (s - arc_[i]) / l : 0.0;
  return pts_[i] + (pts_[i + 1] - pts_[i]) * t;
}

Vec2d ScratchPath::tangentAt(double s) const {
  s = std::clamp(s, 0.0, length());
  size_t i = size_t(std::upper_bound(arc_.begin(), arc_.end(), s) - arc_.begin());
  i = std::clamp(i, size_t(1), pts_.size() - 1) - 1;
  Vec2d d = pts_[i + 1] - pts_[i];
  return d / len2(d);
}

void ScratchPath::closestOnSegment(size_t i, Vec2f p, float& best_d2, size_t& best_i,
                                   float& best_t) const {
  Vec2f a = ptsf_[i], d = ptsf_[i + 1] - ptsf_[i];
  float l2 = d.x * d.x + d.y * d.y;
  float t = l2 > 0 ? clampf(((p.x - a.x) * d.x + (p.y - a.y) * d.y) / l2, 0.0f, 1.0f) : 0.0f;
  float ex = a.x + d.x * t - p.x, ey = a.y + d.y * t - p.y;
  float d2 = ex * ex + ey * ey;
  // Nearer, or as near on a lower segment index: deterministic ties. Where the two segments lie on
  // one line (a path going exactly back over itself), "as near" is within what the float
  // coordinates resolve (eps, about 8 units in the last place of p's): their distances are one up
  // to rounding, and the earlier pass is taken everywhere, not whichever rounded lower (with an
  // asymmetric profile, a tilted tool's, the explicit geometry's surface was a random mix of the two
  // passes' cross-sections). Elsewhere the nearer is taken as computed: segments of a flattened
  // curve, near a point's foot on it, are all within eps, and the lower would pull the closest
  // point back along the curve.
  const float diff = d2 - best_d2;
  const float s = 1.0f + std::max(std::fabs(p.x), std::fabs(p.y)), eps = 1e-6f * s;
  bool take = diff < 0 || (diff == 0 && i < best_i);
  if (std::fabs(diff) <= 0.01f * best_d2 + 1e-9f * s * s && best_i < pts_.size() - 1) {
    // (The square roots and the test for one line only where the two are that close.)
    const Vec2f b = ptsf_[best_i], e = ptsf_[best_i + 1] - b;
    const float l = std::sqrt(l2), le = std::sqrt(e.x * e.x + e.y * e.y);
    const bool one_line = (l > 0 && le > 0 && std::fabs(d.x * e.y - d.y * e.x) <= 1e-6f * l * le &&
                           std::fabs((b.x - a.x) * d.y - (b.y - a.y) * d.x) <= eps * l) ||
                          segmentsOnOneLine(i, best_i);
    if (one_line) {
      const float gap = std::sqrt(d2) - std::sqrt(best_d2);
      take = i < best_i ? gap <= eps : gap < -eps;
    }
  }
  if (take) {
    best_d2 = d2;
    best_i = i;
    best_t = t;
  }
}

bool ScratchPath::segmentsOnOneLine(size_t i, size_t j) const {
  if (i + 1 >= pts_.size() || j + 1 >= pts_.size()) return false;
  const Vec2d a = pts_[i], d = pts_[i + 1] - a, e = pts_[j + 1] - pts_[j], w = pts_[j] - a;
  const double l = std::sqrt(dot(d, d)), le = std::sqrt(dot(e, e));
  const double s = 1 + std::max({std::fabs(a.x), std::fabs(a.y), std::fabs(pts_[j].x), std::fabs(pts_[j].y)});
  return l > 0 && le > 0 && std::fabs(d.x * e.y - d.y * e.x) <= 1e-9 * l * le &&
         std::fabs(w.x * d.y - w.y * d.x) <= 1e-9 * s * l;
}

template <class Visit>
bool ScratchPath::forSegmentsNear(Vec2f p, float max_dist, Visit&& visit) const {
  if (!(gx_ > 0 && std::isfinite(max_dist))) return false;
  // Cell indices clamped in float first, so far-away queries cannot overflow the int cast.
  auto cellOf = [](float v, float lo, float c, int n) { return int(std::floor(clampf((v - lo) / c, -1.0f, float(n)))); };
  int x0 = cellOf(p.x - max_dist, box_.lo.x, cell_w_, gx_);
  int x1 = cellOf(p.x + max_dist, box_.lo.x, cell_w_, gx_);
  int y0 = cellOf(p.y - max_dist, box_.lo.y, cell_h_, gy_);
  int y1 = cellOf(p.y + max_dist, box_.lo.y, cell_h_, gy_);
  if (x1 < 0 || y1 < 0 || x0 >= gx_ || y0 >= gy_) return true;  // nothing near
  x0 = std::max(x0, 0);
  y0 = std::max(y0, 0);
  x1 = std::min(x1, gx_ - 1);
  y1 = std::min(y1, gy_ - 1);
  if (size_t(x1 - x0 + 1) * size_t(y1 - y0 + 1) >= pts_.size() - 1) return false;  // a scan is cheaper
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      size_t c = size_t(y) * gx_ + x;
      for (uint32_t k = cell_start_[c]; k < cell_start_[c + 1]; ++k) visit(size_t(cell_seg_[k]));
    }
  return true;
}

PathPoint ScratchPath::closest(Vec2f p, float max_dist) const {
  if (pts_.size() < 2) return PathPoint();
  float best_d2 = std::numeric_limits<float>::infinity();
  size_t best_i = pts_.size();
  float best_t = 0;
  const size_t nseg = pts_.size() - 1;
  if (!forSegmentsNear(p, max_dist, [&](size_t i) { closestOnSegment(i, p, best_d2, best_i, best_t); }))
    for (size_t i = 0; i < nseg; ++i) closestOnSegment(i, p, best_d2, best_i, best_t);
  if (best_i >= nseg) return PathPoint();
  return pointOn(p, best_i, best_t, best_d2, max_dist);
}

PathPoint ScratchPath::closestOnSegments(Vec2f p, float max_dist, size_t first, size_t last) const {
  if (pts_.size() < 2) return PathPoint();
  const size_t nseg = pts_.size() - 1;
  float best_d2 = std::numeric_limits<float>::infinity();
  size_t best_i = nseg;
  float best_t = 0;
  for (size_t i = first; i <= last && i < nseg; ++i) closestOnSegment(i, p, best_d2, best_i, best_t);
  if (best_i >= nseg) return PathPoint();
  return pointOn(p, best_i, best_t, best_d2, max_dist);
}

void ScratchPath::closestBranches(Vec2f p, float max_dist, std::vector<PathPoint>& out, float rise,
                                  std::vector<std::pair<size_t, size_t>>* runs) const {
  out.clear();
  if (runs) runs->clear();
  if (pts_.size() < 2) return;
  const size_t nseg = pts_.size() - 1;
  // The segments within max_dist (the test closest makes), each with its nearest point, in path
  // order.
  struct Near {
    size_t i;
    float d2, t;
  };
  thread_local std::vector<Near> within;
  within.clear();
  auto test = [&](size_t i) {
    Near n{nseg, std::numeric_limits<float>::infinity(), 0};
    closestOnSegment(i, p, n.d2, n.i, n.t);
    if (std::sqrt(n.d2) <= max_dist) within.push_back(n);
  };
  if (!forSegmentsNear(p, max_dist, test))
    for (size_t i = 0; i < nseg; ++i) test(i);
  if (within.empty()) return;
  std::sort(within.begin(), within.end(), [](const Near& a, const Near& b) { return a.i < b.i; });
  within.erase(std::unique(within.begin(), within.end(), [](const Near& a, const Near& b) { return a.i == b.i; }),
               within.end());
  // Runs of consecutive segments, each cut further where the path goes away by `rise` and comes
  // back (below); the closest point of each branch (the nearest, on a tie the lower segment, as
  // closestOnSegment keeps it). The branch that holds the path's closest point goes first, so
  // that out[0] is closest(p, max_dist).
  size_t first = 0;
  float first_d2 = std::numeric_limits<float>::infinity();
  // The branch of within[g0..g1] with its nearest point within[best].
  auto emit = [&](size_t best, size_t g0, size_t g1) {
    const float d2 = within[best].d2;
    PathPoint pp = pointOn(p, within[best].i, within[best].t, d2, max_dist);
    if (!pp.found) return;
    // (Strictly nearer: on a tie the lower segment, as in closest.)
    if (d2 < first_d2) {
      first_d2 = d2;
      first = out.size();
    }
    out.push_back(pp);
    if (runs) runs->push_back({within[g0].i, within[g1].i});
  };
  for (size_t a = 0; a < within.size();) {
    size_t b = a + 1;
    while (b < within.size() && within[b].i == within[b - 1].i + 1) ++b;
    // Within the run the distance along the path is convex on each segment, so between two
    // segments' nearest points it peaks at their shared vertex. A new branch starts where, since
    // the branch's nearest point so far, it has risen by `rise` and fallen by as much again.
    size_t best = a, g0 = a;
    float best_d = std::sqrt(within[a].d2), peak = 0;
    for (size_t k = a + 1; k < b; ++k) {
      const Vec2f v = ptsf_[within[k].i] - p;
      peak = std::max(peak, std::sqrt(v.x * v.x + v.y * v.y));
      const float d = std::sqrt(within[k].d2);
      if (peak >= best_d + rise && d <= peak - rise) {
        emit(best, g0, k - 1);
        g0 = k;
        best = k;
        best_d = d;
        peak = 0;
      } else if (within[k].d2 < within[best].d2) {
        best = k;
        best_d = d;
        peak = 0;
      }
    }
    emit(best, g0, b - 1);
    a = b;
  }
  if (first > 0) std::rotate(out.begin(), out.begin() + std::ptrdiff_t(first), out.begin() + std::ptrdiff_t(first) + 1);
  if (runs && first > 0)
    std::rotate(runs->begin(), runs->begin() + std::ptrdiff_t(first), runs->begin() + std::ptrdiff_t(first) + 1);
}

PathPoint ScratchPath::pointOn(Vec2f p, size_t best_i, float best_t, float best_d2, float max_dist) const {
  PathPoint r;
  const size_t nseg = pts_.size() - 1;
  float dist = std::sqrt(best_d2);
  if (dist > max_dist) return r;

  Vec2f a = ptsf_[best_i], b = ptsf_[best_i + 1];
  Vec2f d = b - a;
  float l = std::sqrt(d.x * d.x + d.y * d.y);
  Vec2f t = l > 0 ? d / l : Vec2f{1, 0};
  r.found = true;
  r.seg = int(best_i);
  r.distance = dist;
  r.point = a + d * best_t;
  r.s = arcf_[best_i] + (arcf_[best_i + 1] - arcf_[best_i]) * best_t;
  Vec2f e = p - r.point;
  bool at_start = best_i == 0 && best_t <= 0.0f;
  bool at_end = best_i == nseg - 1 && best_t >= 1.0f;
  auto segT = [&](size_t i) {
    Vec2f q = ptsf_[i + 1] - ptsf_[i];
    float m = std::sqrt(q.x * q.x + q.y * q.y);
    return m > 0 ? q / m : Vec2f{1, 0};
  };
  if (!at_start && !at_end && (best_t <= 0.0f || best_t >= 1.0f)) {
    // Interior vertex: mean of the adjoining tangents, so the side is right in the outer wedge.
    Vec2f t2 = best_t <= 0.0f ? segT(best_i - 1) : segT(best_i + 1);
    Vec2f m = t + t2;
    float ml = std::sqrt(m.x * m.x + m.y * m.y);
    if (ml > 1e-6f) t = m / ml;
  }
  r.tangent = t;
  float lateral = -t.y * e.x + t.x * e.y;  // e . B, B = (-T.y, T.x)
  float along = t.x * e.x + t.y * e.y;
  if (at_start || at_end) {
    r.offset = lateral;
    r.beyond = at_start ? std::max(0.0f, -along) : std::max(0.0f, along);
  } else {
    r.offset = std::copysign(dist, lateral);
  }
  return r;
}

// ---------------------------------------------------------------------------------------------
// Layers and profiles
// ---------------------------------------------------------------------------------------------

int LayerStack::layerAtDepth(double depth) const {
  double acc = 0;
  for (size_t i = 0; i + 1 < layers.size(); ++i) {
    acc += layers[i].thickness_mm;
    if (depth < acc) return int(i);
  }
  return int(layers.size()) - 1;
}

std::vector<double> LayerStack::interfaces() const {
  std::vector<double> out;
  double acc = 0;
  for (size_t i = 0; i + 1 < layers.size(); ++i) {
    acc += layers[i].thickness_mm;
    out.push_back(acc);
  }
  return out;
}

Profile Profile::fromPolyline(std::vector<Vec2d> in) {
  Profile p;
  for (const Vec2d& q : in) {
    if (!std::isfinite(q.x) || !std::isfinite(q.y))
      throw std::invalid_argument("Profile: non-finite point");
    if (!p.pts.empty()) {
      if (q.x < p.pts.back().x)
        throw std::invalid_argument("Profile: offsets b must be non-decreasing (no overhangs)");
      if (q.x == p.pts.back().x && q.y == p.pts.back().y) continue;  // zero-length facet
    }
    p.pts.push_back(q);
  }
  if (p.pts.size() < 2) throw std::invalid_argument("Profile: needs at least two distinct points");
  if (std::fabs(p.pts.front().y) > 1e-12 || std::fabs(p.pts.back().y) > 1e-12)
    throw std::invalid_argument("Profile: must start and end on the base surface (w = 0)");
  p.pts.front().y = 0;
  p.pts.back().y = 0;
  p.layer.assign(p.pts.size() - 1, 0);
  return p;
}

double Profile::depth() const {
  double m = 0;
  for (const Vec2d& q : pts) m = std::min(m, q.y);
  return -m;
}

double Profile::peakHeight() const {
  double m = 0;
  for (const Vec2d& q : pts) m = std::max(m, q.y);
  return m;
}

double Profile::grooveArea() const {
  double a = 0;
  for (size_t k = 0; k + 1 < pts.size(); ++k) a += signedPartArea(pts[k], pts[k + 1], -1);
  return a;
}

double Profile::peakArea() const {
  double a = 0;
  for (size_t k = 0; k + 1 < pts.size(); ++k) a += signedPartArea(pts[k], pts[k + 1], +1);
  return a;
}

double Profile::heightAt(double b) const {
  if (pts.size() < 2 || b < bMin() || b > bMax()) return 0.0;
  for (size_t k = 0; k + 1 < pts.size(); ++k) {
    const Vec2d &a = pts[k], &c = pts[k + 1];
    if (b <= c.x) {
      if (c.x <= a.x) return a.y;  // vertical facet
      return a.y + (c.y - a.y) * (b - a.x) / (c.x - a.x);
    }
  }
  return 0.0;
}

Profile Profile::scaled(double k) const {
  Profile p = *this;
  for (Vec2d& q : p.pts) q = q * k;
  return p;
}

Profile Profile::withLayers(const LayerStack& stack) const {
  Profile out;
  std::vector<double> cuts = stack.interfaces();
  if (pts.empty()) return out;
  out.pts.push_back(pts[0]);
  auto push = [&](Vec2d q) {
    Vec2d a = out.pts.back();
    double wm = 0.5 * (a.y + q.y);
    out.pts.push_back(q);
    out.layer.push_back(wm >= 0 ? 0 : stack.layerAtDepth(-wm));
  };
  for (size_t k = 0; k + 1 < pts.size(); ++k) {
    Vec2d a = pts[k], c = pts[k + 1];
    // Interface crossings inside the facet, in order along it.
    std::vector<double> ts;
    for (double d : cuts) {
      double w = -d;
      if ((a.y - w) * (c.y - w) < 0) ts.push_back((w - a.y) / (c.y - a.y));
    }
    std::sort(ts.begin(), ts.end());
    for (double t : ts) push(a + (c - a) * t);
    push(c);
  }
  return out;
}

void Profile::keepSide(double bc, bool below) {
  std::vector<Vec2d>& P = pts;
  std::vector<int>& L = layer;
  if (P.size() < 2 || (below ? bc >= P.back().x : bc <= P.front().x)) return;  // all kept
  if (below ? bc <= P.front().x : bc >= P.back().x) {
    P.clear();
    L.clear();
    return;
  }
  // The facet k across bc: P[k].x < bc <= P[k + 1].x (below), P[k].x <= bc < P[k + 1].x (above).
  size_t k = 0;
  if (below)
    while (P[k + 1].x < bc) ++k;
  else
    while (P[k + 1].x <= bc) ++k;
  const Vec2d a = P[k], b = P[k + 1];
  const double h = a.y + (b.y - a.y) * (bc - a.x) / (b.x - a.x);
  const int lk = k < L.size() ? L[k] : 0;
  std::vector<Vec2d> np;
  std::vector<int> nl;
  if (below) {
    np.assign(P.begin(), P.begin() + long(k) + 1);
    nl.assign(L.begin(), L.begin() + long(std::min(k, L.size())));
    np.push_back({bc, h});
    nl.push_back(lk);
    if (h != 0) {
      np.push_back({bc, 0.0});
      nl.push_back(lk);
    }
  } else {
    if (h != 0) {
      np.push_back({bc, 0.0});
      nl.push_back(lk);
    }
    np.push_back({bc, h});
    nl.push_back(lk);
    np.insert(np.end(), P.begin() + long(k) + 1, P.end());
    if (L.size() > k + 1) nl.insert(nl.end(), L.begin() + long(k) + 1, L.end());
  }
  P = std::move(np);
  L = std::move(nl);
}

// ---------------------------------------------------------------------------------------------
// Process model (Bosch §3.2.2)
// ---------------------------------------------------------------------------------------------

double scratchDepthMm(double force_kg, double hardness_hv) {
  if (!(force_kg > 0) || !(hardness_hv > 0)) return 0.0;
  // Bosch §3.2.2: p = 0.182 sqrt(F_N / H_V + 0.0055) - 0.014, p in mm, F_N in kg, H_V in kg/mm^2.
  double p = 0.182 * std::sqrt(force_kg / hardness_hv + 0.0055) - 0.014;
  return std::max(0.0, p);
}

double peakTanBetaRaw(double tan_alpha) { return -0.56 + 2.54 * tan_alpha; }  // Bosch §3.2.2

double peakBeta(double alpha) {
  double b = std::atan(peakTanBetaRaw(std::tan(alpha)));
  return std::max(b, kMinPeakBetaRad);
}

double peakHeight(double peak_area, double alpha, double beta) {
  if (!(peak_area > 0)) return 0.0;
  // Triangle of height h with runs h cot(alpha) and h cot(beta): area h^2 (cot a + cot b) / 2.
  double c = 1.0 / std::tan(alpha) + 1.0 / std::tan(beta);
  return std::sqrt(2.0 * peak_area / c);
}

namespace {

struct P3 {
  double x, y, z;  // (b, t, w) in the scratch frame
};

double edgeHalfAngle(const ToolSpec& t) {
  const double g = 0.5 * t.apex_angle_rad;
  return t.shape == ToolSpec::Shape::Pyramid ? std::atan(std::tan(g) / std::cos(kPi / t.pyramid_faces)) : g;
}

void validateTool(const ToolSpec& t, double& edge_half_angle) {
  double apex = t.apex_angle_rad;
  if (!(apex >= 10.0 * kPi / 180.0 && apex <= 170.0 * kPi / 180.0))
    throw std::invalid_argument("scratch tool: apex angle must be in [10, 170] degrees");
  if (!(t.tip_radius_mm >= 0)) throw std::invalid_argument("scratch tool: tip radius must be >= 0");
  if (t.shape == ToolSpec::Shape::Pyramid && (t.pyramid_faces < 3 || t.pyramid_faces > 64))
    throw std::invalid_argument("scratch tool: a pyramid needs 3 to 64 faces");
  edge_half_angle = edgeHalfAngle(t);
  const double limit = maxToolTilt(t);
  if (!(t.theta_rad >= 0) || t.theta_rad > limit) {
    std::ostringstream m;
    m << std::setprecision(4) << "scratch tool: a tilt of " << t.theta_rad * 180.0 / kPi << " degrees would put the "
      << (t.shape == ToolSpec::Shape::Pyramid ? "pyramid's edge" : "cone's flank") << " below its tip (apex "
      << apex * 180.0 / kPi << " degrees); expected a tilt in [0, " << std::max(0.0, limit * 180.0 / kPi)
      << "] degrees";
    throw std::invalid_argument(m.str());
  }
}

}  // namespace

double maxToolTilt(const ToolSpec& tool) { return 0.5 * kPi - edgeHalfAngle(tool) - kPi / 180.0; }

std::vector<Vec2d> toolGroove(const ToolSpec& tool, double depth) {
  double edge_g = 0;
  validateTool(tool, edge_g);
  if (!(depth > 0)) return {};
  const double g = 0.5 * tool.apex_angle_rad;
  const double r = tool.shape == ToolSpec::Shape::Cone ? tool.tip_radius_mm : 0.0;
  const double th = tool.theta_rad;
  // Tall enough that its top rim is well above the base surface once the tip is at -depth.
  double lift = std::cos(th) - std::tan(edge_g) * std::sin(th);  // > 0 by validation
  double H = 4.0 * (depth + 2.0 * r) / lift + 4.0 * r;

  // Tool points in its own frame: axis +z, (virtual) apex at the origin.
  std::vector<P3> pts;
  if (tool.shape == ToolSpec::Shape::Cone) {
    const int na = 720;  // azimuths; 0 and pi are sampled exactly (extremes of an upright cone)
    std::vector<double> ca(na), sa(na);  // the same for every ring
    for (int i = 0; i < na; ++i) {
      double a = 2.0 * kPi * i / na;
      ca[size_t(i)] = std::cos(a);
      sa[size_t(i)] = std::sin(a);
    }
    auto ring = [&](double z, double rho) {
      for (int i = 0; i < na; ++i) pts.push_back({rho * ca[size_t(i)], rho * sa[size_t(i)], z});
    };
    if (r > 0) {
      // Spherical tip tangent to the cone: centre at r / sin(g) above the apex, cap up to the
      // polar angle 90 deg - g; polar step so that chords deviate <= 1% of the depth.
      double zc = r / std::sin(g);
      double cap = 0.5 * kPi - g;
      double dmax = 2.0 * std::acos(std::max(-1.0, 1.0 - 0.01 * depth / r));
      int nr = std::clamp(int(std::ceil(cap / std::max(dmax, 1e-6))), 2, 400);
      pts.push_back({0, 0, zc - r});
      for (int k = 1; k <= nr; ++k) {
        double ph = cap * k / nr;
        ring(zc - r * std::cos(ph), r * std::sin(ph));
      }
    } else {
      pts.push_back({0, 0, 0});
    }
    ring(H, H * std::tan(g));
  } else {
    int n = tool.pyramid_faces;
    double rc = H * std::tan(g) / std::cos(kPi / n);  // circumradius of the base polygon
    pts.push_back({0, 0, 0});
    for (int k = 0; k < n; ++k) {
      double a = tool.roll_rad + (k + 0.5) * 2.0 * kPi / n;  // faces at roll + k 2pi/n
      pts.push_back({rc * std::cos(a), rc * std::sin(a), H});
    }
  }

  // Tilt: rotate +z onto the axis a = (sin th sin phi, sin th cos phi, cos th) in (B, T, W),
  // Rodrigues about k = z x a / |z x a|.
  double sp = std::sin(tool.phi_rad), cp = std::cos(tool.phi_rad);
  double ax = std::sin(th) * sp, ay = std::sin(th) * cp;
  double kx = -ay, ky = ax;  // z x a (its z component is 0)
  double kl = std::sqrt(kx * kx + ky * ky);
  const double c = std::cos(th), s = std::sin(th);
  std::vector<Vec2d> proj;
  proj.reserve(pts.size());
  for (const P3& q : pts) {
    double x = q.x, y = q.y, z = q.z;
    if (kl > 1e-15) {
      double ux = kx / kl, uy = ky / kl;  // unit k, uz = 0
      double kv = ux * x + uy * y;
      // k x v with k = (ux, uy, 0) is (uy z, -ux z, ux y - uy x); t is dropped by the projection.
      double cx = uy * z, cz = ux * y - uy * x;
      double nx = x * c + cx * s + ux * kv * (1 - c);
      double nz = z * c + cz * s;
      x = nx;
      z = nz;
    }
    proj.push_back({x, z});  // project along T: keep (b, w)
  }

  // Lower convex hull of the projection (Andrew's monotone chain): the swept envelope.
  std::sort(proj.begin(), proj.end(),
            [](const Vec2d& a, const Vec2d& b) { return a.x < b.x || (a.x == b.x && a.y < b.y); });
  std::vector<Vec2d> hull;
  for (const Vec2d& q : proj) {
    while (hull.size() >= 2 && cross(hull.back() - hull[hull.size() - 2], q - hull[hull.size() - 2]) <= 0)
      hull.pop_back();
    hull.push_back(q);
  }
  double wmin = 1e300;
  for (const Vec2d& q : hull) wmin = std::min(wmin, q.y);
  for (Vec2d& q : hull) q.y = q.y - wmin - depth;

  // A strongly tilted tool overhangs on one side (its far flank leans over the groove, theta_t >
  // apex/2): the extreme point of the envelope is then below the surface and the sweep leaves a
  // vertical wall there.
  if (hull.front().y < 0) hull.insert(hull.begin(), Vec2d{hull.front().x, 0.0});
  if (hull.back().y < 0) hull.push_back(Vec2d{hull.back().x, 0.0});
  // Clip to w <= 0.
  size_t k0 = hull.size(), k1 = hull.size();
  for (size_t k = 0; k + 1 < hull.size(); ++k) {
    if (k0 == hull.size() && hull[k].y >= 0 && hull[k + 1].y < 0) k0 = k;
    if (hull[k].y < 0 && hull[k + 1].y >= 0) k1 = k;
  }
  if (k0 == hull.size() || k1 == hull.size() || k1 < k0)
    throw std::logic_error("toolGroove: tool envelope does not cross the surface");
  auto cross0 = [&](size_t k) {
    const Vec2d &a = hull[k], &b = hull[k + 1];
    double t = a.y / (a.y - b.y);
    return Vec2d{a.x + (b.x - a.x) * t, 0.0};
  };
  std::vector<Vec2d> groove{cross0(k0)};
  for (size_t k = k0 + 1; k <= k1; ++k) groove.push_back(hull[k]);
  groove.push_back(cross0(k1));
  // Drop near-collinear points from the sampled envelope (tolerance 1e-4 of the depth).
  std::vector<char> keep(groove.size(), 0);
  keep.front() = keep.back() = 1;
  // Keep the lowest point so the depth is exact.
  size_t low = 0;
  for (size_t k = 0; k < groove.size(); ++k)
    if (groove[k].y < groove[low].y) low = k;
  keep[low] = 1;
  simplify(groove, 0, low, 1e-4 * depth, keep);
  simplify(groove, low, groove.size() - 1, 1e-4 * depth, keep);
  std::vector<Vec2d> out;
  for (size_t k = 0; k < groove.size(); ++k)
    if (keep[k]) out.push_back(groove[k]);
  return out;
}

ProcessCrossSection deriveCrossSectionForDepth(const ToolSpec& tool, double depth, double pileup) {
  if (!(pileup >= 0 && pileup <= 1)) throw std::invalid_argument("scratch: pileup must be in [0, 1]");
  ProcessCrossSection cs;
  std::vector<Vec2d> groove = toolGroove(tool, depth);  // validates the tool
  if (groove.size() < 3) {
    cs.profile.pts = {{0, 0}, {0, 0}};
    cs.profile.layer = {0};
    return cs;
  }
  cs.depth = depth;
  cs.b_left = groove.front().x;
  cs.b_right = groove.back().x;
  // A: area between the groove and w = 0 (shoelace of the closed groove polygon).
  double a2 = 0;
  for (size_t k = 0; k + 1 < groove.size(); ++k) a2 += cross(groove[k], groove[k + 1]);
  cs.groove_area = std::fabs(0.5 * a2);
  // alpha per side: the flank's angle with the surface where it crosses w = 0 (digest §1.4.3.4).
  Vec2d dl = groove[1] - groove[0], dr = groove[groove.size() - 1] - groove[groove.size() - 2];
  cs.alpha[0] = std::atan2(std::fabs(dl.y), std::fabs(dl.x));
  cs.alpha[1] = std::atan2(std::fabs(dr.y), std::fabs(dr.x));
  std::vector<Vec2d> prof;
  double peak_area = 0.5 * pileup * cs.groove_area;  // each peak takes A/2 (digest §1.4.2.4)
  for (int side = 0; side < 2; ++side) {
    // Steep or vertical walls (overhanging tools): the beta fit diverges and the peak would have
    // no width, so the peak's inner slope is capped (our choice, digest §5.3).
    double a = std::min(cs.alpha[side], kMaxPeakAlphaRad);
    cs.beta[side] = peakBeta(a);
    cs.h[side] = peakHeight(peak_area, a, cs.beta[side]);
    cs.w_inner[side] = cs.h[side] / std::tan(a);
    cs.w_outer[side] = cs.h[side] / std::tan(cs.beta[side]);
  }
  if (cs.h[0] > 0) {
    prof.push_back({cs.b_left - cs.w_inner[0] - cs.w_outer[0], 0.0});
    prof.push_back({cs.b_left - cs.w_inner[0], cs.h[0]});
  }
  prof.insert(prof.end(), groove.begin(), groove.end());
  if (cs.h[1] > 0) {
    prof.push_back({cs.b_right + cs.w_inner[1], cs.h[1]});
    prof.push_back({cs.b_right + cs.w_inner[1] + cs.w_outer[1], 0.0});
  }
  cs.profile = Profile::fromPolyline(std::move(prof));
  return cs;
}

ProcessCrossSection deriveCrossSection(const ScratchProcess& proc) {
  return deriveCrossSectionForDepth(proc.tool, scratchDepthMm(proc.force_kg, proc.hardness_hv),
                                    proc.pileup);
}

double scratchFade(double s, double length, double fade) {
  if (!(fade > 0)) return (s >= 0 && s <= length) ? 1.0 : 0.0;
  double u = std::clamp(std::min(s, length - s) / fade, 0.0, 1.0);
  return u * u * (3.0 - 2.0 * u);
}

// ---------------------------------------------------------------------------------------------
// Scratch
// ---------------------------------------------------------------------------------------------

Scratch Scratch::fromProcess(ScratchPath path, const ScratchProcess& proc,
                             const ScratchPerturbation& pert, LayerStack layers) {
  Scratch sc;
  sc.path_ = std::move(path);
  sc.layers_ = std::move(layers);
  sc.is_process_ = true;
  sc.proc_ = proc;
  sc.f_ref_ = proc.force_kg;
  if (!pert.force_keys.empty()) {
    sc.f_ref_ = 0;
    for (auto& k : pert.force_keys) sc.f_ref_ = std::max(sc.f_ref_, k.second);
  }
  sc.p_ref_ = scratchDepthMm(sc.f_ref_, proc.hardness_hv);
  sc.proc_cs_ = deriveCrossSectionForDepth(proc.tool, sc.p_ref_, proc.pileup);
  sc.ref_ = sc.proc_cs_.profile;
  sc.build(pert);
  return sc;
}

Scratch Scratch::fromProfile(ScratchPath path, Profile profile, const ScratchPerturbation& pert,
                             LayerStack layers) {
  Scratch sc;
  sc.path_ = std::move(path);
  sc.layers_ = std::move(layers);
  sc.ref_ = std::move(profile);
  sc.build(pert);
  return sc;
}

void Scratch::build(const ScratchPerturbation& pert) {
  if (path_.points().size() < 2) throw std::invalid_argument("Scratch: empty path");
  if (layers_.layers.empty()) throw std::invalid_argument("Scratch: empty layer stack");
  interfaces_ = layers_.interfaces();
  if (!(pert.noise_amplitude >= 0 && pert.noise_amplitude < 1) || !(pert.noise_wavelength_mm > 0) ||
      !(pert.fade_length_mm >= 0))
    throw std::invalid_argument(
        "Scratch: noise amplitude in [0, 1), noise wavelength > 0, fade length >= 0 required");
  for (auto& k : pert.force_keys)
    if (!(k.first >= 0 && k.first <= 1) || !(k.second >= 0))
      throw std::invalid_argument("Scratch: force keys need positions in [0, 1] and forces >= 0");
  pert_ = pert;
  std::sort(pert_.force_keys.begin(), pert_.force_keys.end());
  const double L = path_.length();
  double step = L / 1024.0;
  if (pert.fade_length_mm > 0) step = std::min(step, pert.fade_length_mm / 32.0);
  if (pert.noise_amplitude > 0) step = std::min(step, pert.noise_wavelength_mm / 8.0);
  int n = std::clamp(int(std::ceil(L / std::max(step, 1e-12))), 1, 16384);
  ds_ = float(L / n);
  // Value-noise knots for the random perturbation.
  std::vector<double> knots;
  if (pert.noise_amplitude > 0) {
    Rng rng(hashKey(pert.noise_seed, 0x5c7a7c4ull));
    size_t nk = size_t(std::ceil(L / pert.noise_wavelength_mm)) + 2;
    for (size_t i = 0; i < nk; ++i) knots.push_back(2.0 * rng.uniformD() - 1.0);
  }
  auto force = [&](double s) {
    const auto& K = pert_.force_keys;
    if (K.empty()) return proc_.force_kg;
    double u = L > 0 ? s / L : 0.0;
    if (u <= K.front().first) return K.front().second;
    if (u >= K.back().first) return K.back().second;
    for (size_t i = 0; i + 1 < K.size(); ++i)
      if (u <= K[i + 1].first) {
        double du = K[i + 1].first - K[i].first;
        double t = du > 0 ? (u - K[i].first) / du : 1.0;
        return K[i].second + (K[i + 1].second - K[i].second) * t;
      }
    return K.back().second;
  };
  scale_.assign(size_t(n) + 1, 0.0f);
  max_scale_ = 0;
  for (int i = 0; i <= n; ++i) {
    double s = i == n ? L : i * double(ds_);
    double g = scratchFade(s, L, pert.fade_length_mm);
    double k;
    if (is_process_)
      k = p_ref_ > 0 ? scratchDepthMm(force(s) * g, proc_.hardness_hv) / p_ref_ : 0.0;
    else
      k = g;
    if (!knots.empty()) {
      double x = s / pert.noise_wavelength_mm;
      size_t j = size_t(x);
      double f = x - double(j);
      f = f * f * (3 - 2 * f);
      k *= 1.0 + pert.noise_amplitude * (knots[j] + (knots[j + 1] - knots[j]) * f);
    }
    scale_[size_t(i)] = float(k);
    max_scale_ = std::max(max_scale_, float(k));
  }
  float r = float(ref_.halfExtent()) * max_scale_;
  Box2 b = path_.bounds();
  support_.lo = {b.lo.x - r, b.lo.y - r};
  support_.hi = {b.hi.x + r, b.hi.y + r};
}

float Scratch::scaleAt(float s) const { return lerpTable(scale_, ds_, s); }

Profile Scratch::profileAt(double s) const {
  return ref_.scaled(scaleAt(float(s))).withLayers(layers_);
}

std::vector<std::pair<double, double>> Scratch::exposedRuns() const {
  std::vector<std::pair<double, double>> runs;
  std::vector<double> itf = layers_.interfaces();
  const double coat = itf.empty() ? 0.0 : itf.back();
  const double d0 = ref_.depth();
  if (!(d0 > 0)) return runs;
  // depth(s) - coat at table sample i; a run starts and ends where it changes sign.
  auto excess = [&](size_t i) { return double(scale_[i]) * d0 - coat; };
  const double L = path_.length();
  bool in = false;
  double start = 0;
  for (size_t i = 0; i < scale_.size(); ++i) {
    double s = std::min(L, double(i) * double(ds_));
    bool now = excess(i) > 0;
    if (now != in) {
      // Crossing between samples i-1 and i (or at the start).
      double x = s;
      if (i > 0) {
        double e0 = excess(i - 1), e1 = excess(i);
        x = std::min(L, (double(i - 1) + e0 / (e0 - e1)) * double(ds_));
      }
      if (now) start = x;
      else if (x > start) runs.push_back({start, x});
      in = now;
    }
  }
  if (in && L > start) runs.push_back({start, L});
  return runs;
}

bool Scratch::inMask(Vec2f p) const {
  if (!(ref_.width() > 0) || !(max_scale_ > 0)) return false;
  PathPoint q = path_.closest(p, float(ref_.halfExtent()) * max_scale_);
  if (!q.found || q.beyond > 0) return false;
  float k = scaleAt(q.s);
  if (!(k > 0)) return false;
  return q.offset >= k * float(ref_.bMin()) && q.offset <= k * float(ref_.bMax());
}

float Scratch::height(Vec2f p) const {
  if (!(ref_.width() > 0) || !(max_scale_ > 0)) return 0.0f;
  PathPoint q = path_.closest(p, float(ref_.halfExtent()) * max_scale_);
  if (!q.found || q.beyond > 0) return 0.0f;
  float k = scaleAt(q.s);
  if (!(k > 0)) return 0.0f;
  return k * float(ref_.heightAt(double(q.offset) / k));
}

void Scratch::shade(const DefectQuery& qy, DefectShading& out) const {
  if (!(bump_shading_ || qy.point_grooves) || !(ref_.width() > 0) || !(max_scale_ > 0)) return;
  PathPoint q = path_.closest(qy.uv, float(ref_.halfExtent()) * max_scale_);
  if (!q.found || q.beyond > 0) return;
  float k = scaleAt(q.s);
  if (!(k > 0)) return;
  // h(b, s) = k(s) H(b / k(s)), H the reference profile. Across the path a uniformly scaled
  // profile keeps its slopes: dh/db = H'(beta) at beta = b / k. Along it, where the scale changes
  // (the force fading at the ends, force keys, the perturbation), dh/ds = k'(s) (H - beta H'):
  // the facets tilt along the path as the groove grows shallower, as the groove renderer's facets
  // do (render/groove.h, rho).
  const double beta = double(q.offset) / k;
  const auto& p = ref_.pts;
  double slope = 0;
  for (size_t i = 0; i + 1 < p.size(); ++i)
    if (beta >= p[i].x && beta < p[i + 1].x) {
      double db = p[i + 1].x - p[i].x;
      slope = db > 0 ? (p[i + 1].y - p[i].y) / db : 0.0;
      break;
    }
  // k'(s) by a central difference over 1e-3 mm of the path (the scale table is piecewise linear).
  const double len = path_.length(), ds = 1e-3;
  const double s0 = std::max(0.0, double(q.s) - ds), s1 = std::min(len, double(q.s) + ds);
  const double dk = s1 > s0 ? (double(scaleAt(float(s1))) - scaleAt(float(s0))) / (s1 - s0) : 0.0;
  const double height = ref_.heightAt(beta);  // H(beta)
  double along = dk * (height - beta * slope);
  // Vertical facets have no finite slope; cap the tilt at 80 degrees.
  slope = std::max(-5.67, std::min(5.67, slope));
  along = std::max(-5.67, std::min(5.67, along));
  Vec2f B(-q.tangent.y, q.tangent.x);  // W x T in the UV plane
  const Vec2f grad = B * float(slope) + q.tangent * float(along);
  // The normal-map baseline adds every scratch's slope, as a texture of summed normals does; the
  // groove renderer's point samples take the composite surface's (DefectShading::addGroove).
  if (bump_shading_)
    out.height_grad += grad;
  else
    out.addGroove(k * float(height), grad);
}

nlohmann::json Scratch::attributes() const {
  const double deg = 180.0 / kPi;
  nlohmann::json j;
  j["model"] = is_process_ ? "process" : "profile";
  j["length_mm"] = path_.length();
  j["width_mm"] = ref_.width() * max_scale_;
  j["depth_mm"] = ref_.depth() * max_scale_;
  j["peak_height_mm"] = ref_.peakHeight() * max_scale_;
  j["facets"] = ref_.facets();
  j["deepest_layer"] = layers_.layers[size_t(layers_.layerAtDepth(ref_.depth() * max_scale_))].name;
  double bared = 0;
  for (const auto& r : exposedRuns()) bared += r.second - r.first;
  j["substrate_exposed_mm"] = bared;
  j["fade_length_mm"] = pert_.fade_length_mm;
  if (pert_.noise_amplitude > 0) {
    j["noise_amplitude"] = pert_.noise_amplitude;
    j["noise_wavelength_mm"] = pert_.noise_wavelength_mm;
  }
  if (is_process_) {
    j["force_kg"] = f_ref_;
    j["hardness_hv"] = proc_.hardness_hv;
    j["pileup"] = proc_.pileup;
    const ToolSpec& t = proc_.tool;
    j["tool"] = {{"shape", t.shape == ToolSpec::Shape::Cone ? "cone" : "pyramid"},
                 {"apex_angle_deg", t.apex_angle_rad * deg},
                 {"tip_radius_mm", t.tip_radius_mm},
                 {"theta_deg", t.theta_rad * deg},
                 {"phi_deg", t.phi_rad * deg}};
    j["alpha_deg"] = {proc_cs_.alpha[0] * deg, proc_cs_.alpha[1] * deg};
    j["beta_deg"] = {proc_cs_.beta[0] * deg, proc_cs_.beta[1] * deg};
  }
  return j;
}

// ---------------------------------------------------------------------------------------------
// Random placement
// ---------------------------------------------------------------------------------------------

ScratchPath arcScratch(Vec2d mid, double length, double theta, double kappa, double tol) {
  if (!(length > 0)) throw std::invalid_argument("arcScratch: length must be > 0");
  Vec2d t{std::cos(theta), std::sin(theta)};
  // Keep the arc below a full turn.
  double kmax = 1.9 * kPi / length;
  kappa = std::clamp(kappa, -kmax, kmax);
  if (std::fabs(kappa) * length < 1e-9)
    return ScratchPath::polyline({mid - t * (0.5 * length), mid + t * (0.5 * length)});
  Vec2d b{-t.y, t.x};
  Vec2d c = mid + b * (1.0 / kappa);
  Vec2d m = mid - c;
  double phim = std::atan2(m.y, m.x);
  double sweep = length * kappa;  // signed: > 0 counter-clockwise
  return ScratchPath::arc(c, 1.0 / std::fabs(kappa), phim - 0.5 * sweep, sweep, tol);
}

namespace {
bool inside(const Box2& r, Vec2d p) {
  return p.x >= r.lo.x && p.x <= r.hi.x && p.y >= r.lo.y && p.y <= r.hi.y;
}
}  // namespace

ScratchPath randomKeyScratch(Rng& rng, const Box2& region, const KeyScratchOptions& o) {
  double W = double(region.hi.x) - region.lo.x, H = double(region.hi.y) - region.lo.y;
  if (!(W > 0 && H > 0)) throw std::invalid_argument("randomKeyScratch: empty region");
  double diag = std::hypot(W, H);
  double shrink = 1.0;
  for (int attempt = 0; attempt < 256; ++attempt) {
    if (attempt > 0 && attempt % 32 == 0) shrink *= 0.5;
    double L = o.length_frac.sample(rng) * diag * shrink;
    double th = rng.uniformD() * 2.0 * kPi;
    double b1 = (2.0 * rng.uniformD() - 1.0) * o.bend_frac;
    double b2 = (2.0 * rng.uniformD() - 1.0) * o.bend_frac;
    double ux = rng.uniformD(), uy = rng.uniformD();
    Vec2d d{std::cos(th), std::sin(th)}, n{-d.y, d.x};
    // Extent of the control polygon about its mid-chord point.
    Vec2d c[4] = {d * (-0.5 * L), d * (-L / 6.0) + n * (b1 * L), d * (L / 6.0) + n * (b2 * L),
                  d * (0.5 * L)};
    double lx = 0, hx = 0, ly = 0, hy = 0;
    for (const Vec2d& q : c) {
      lx = std::min(lx, q.x);
      hx = std::max(hx, q.x);
      ly = std::min(ly, q.y);
      hy = std::max(hy, q.y);
    }
    if (hx - lx > W || hy - ly > H) continue;
    Vec2d mid{region.lo.x - lx + ux * (W - (hx - lx)), region.lo.y - ly + uy * (H - (hy - ly))};
    std::vector<Vec2d> ctrl;
    for (const Vec2d& q : c) ctrl.push_back(mid + q);
    return ScratchPath::bezier(ctrl, 1e-3);
  }
  throw std::invalid_argument("randomKeyScratch: region too small");
}

SwirlSet randomWashSwirls(Rng& rng, const Box2& region, const SwirlOptions& o) {
  if (o.count < 1 || !(o.spacing_jitter >= 0 && o.spacing_jitter < 0.5))
    throw std::invalid_argument("randomWashSwirls: count >= 1, spacing jitter in [0, 0.5)");
  double W = double(region.hi.x) - region.lo.x, H = double(region.hi.y) - region.lo.y;
  SwirlSet set;
  set.centre = o.fixed_centre ? o.centre
                              : Vec2d{region.lo.x + rng.uniformD() * W, region.lo.y + rng.uniformD() * H};
  double r0 = o.radius0_mm.sample(rng);
  double spacing = o.spacing_mm.sample(rng);
  // The brush sweeps towards the region's centre: arcs start around a common angle.
  Vec2d rc{region.lo.x + 0.5 * W, region.lo.y + 0.5 * H};
  double base = std::atan2(rc.y - set.centre.y, rc.x - set.centre.x);
  if (rc.x == set.centre.x && rc.y == set.centre.y) base = rng.uniformD() * 2.0 * kPi;
  for (int i = 0; i < o.count; ++i) {
    double r = r0 + spacing * (i + o.spacing_jitter * (2.0 * rng.uniformD() - 1.0));
    double sweep = o.sweep_rad.sample(rng);
    double start = base - 0.5 * sweep + 0.25 * sweep * (2.0 * rng.uniformD() - 1.0);
    if (!(r > 0)) continue;
    ScratchPath full = ScratchPath::arc(set.centre, r, start, sweep, 1e-3);
    // Longest run of vertices inside the region.
    const auto& P = full.points();
    size_t best0 = 0, best1 = 0, run0 = 0;
    bool in_run = false;
    for (size_t k = 0; k <= P.size(); ++k) {
      bool in = k < P.size() && inside(region, P[k]);
      if (in && !in_run) {
        run0 = k;
        in_run = true;
      } else if (!in && in_run) {
        in_run = false;
        if (k - run0 > best1 - best0) {
          best0 = run0;
          best1 = k;
        }
      }
    }
    if (best1 - best0 < 2) continue;
    std::vector<Vec2d> run(P.begin() + long(best0), P.begin() + long(best1));
    ScratchPath arc = ScratchPath::polyline(std::move(run));
    if (arc.length() < o.min_length_mm) continue;
    set.radii.push_back(r);
    set.arcs.push_back(std::move(arc));
  }
  return set;
}

ScratchPath randomScratch(Rng& rng, const Box2& region, const GenericScratchOptions& o) {
  double W = double(region.hi.x) - region.lo.x, H = double(region.hi.y) - region.lo.y;
  if (!(W > 0 && H > 0)) throw std::invalid_argument("randomScratch: empty region");
  double L = 0, th = 0, k = 0;
  for (int attempt = 0; attempt < 64; ++attempt) {
    if (attempt < 32) {
      L = o.length_mm.sample(rng);
      th = o.orientation_rad.sample(rng);
      k = o.curvature.sample(rng) * (rng.uniformD() < 0.5 ? -1.0 : 1.0);
    } else {
      L *= 0.5;
    }
    double ux = rng.uniformD(), uy = rng.uniformD();
    if (!(L > 0)) continue;
    ScratchPath at0 = arcScratch({0, 0}, L, th, k);
    Box2 b = at0.bounds();
    double bw = double(b.hi.x) - b.lo.x, bh = double(b.hi.y) - b.lo.y;
    if (bw > W || bh > H) continue;
    Vec2d mid{region.lo.x - double(b.lo.x) + ux * (W - bw), region.lo.y - double(b.lo.y) + uy * (H - bh)};
    return arcScratch(mid, L, th, k);
  }
  throw std::invalid_argument("randomScratch: region too small for the scratch lengths");
}

}  // namespace dg
