// Local conforming refinement and true displacement of a mesh by defect height fields.
//
// Refinement is Rivara's longest-edge bisection along the longest-edge propagation path (LEPP;
// Rivara 1997, see displacement.h). Working state: three vertex ids and three neighbour slots per
// triangle (slot k is the edge from vertex k to vertex k+1). A slot holds the triangle across the
// edge, kBoundary, or (for an edge shared by three or more triangles) a reference to a "fan", the
// list of all triangles on that edge. Bisecting an edge splits every triangle of its fan at the same
// new midpoint, so no vertex ever hangs on another triangle's edge. A split triangle keeps its id
// for the child at the edge's first end (in its own winding) and appends the other child, so the
// input's untouched triangles keep their index and the run is sequential and deterministic.
#include "render/displacement.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>

namespace dg {
namespace {

constexpr int32_t kBoundary = -1;
constexpr int32_t kUnset = std::numeric_limits<int32_t>::min();
bool isFanSlot(int32_t s) { return s <= -2 && s != kUnset; }
int32_t fanSlot(size_t j) { return -int32_t(j) - 2; }
size_t fanIndex(int32_t s) { return size_t(-(int64_t(s) + 2)); }

Vec3d toD(Vec3f v) { return Vec3d(v); }

// An edge in the total order used to pick a triangle's longest edge: squared length, ties broken by
// the vertex ids. Both triangles on an edge compute the same key (the length is always measured from
// the lower id), which is what makes the longest-edge choice consistent across the edge.
struct EdgeKey {
  double len2;
  uint32_t lo, hi;
  bool operator<(const EdgeKey& o) const {
    if (len2 != o.len2) return len2 < o.len2;
    if (lo != o.lo) return lo < o.lo;
    return hi < o.hi;
  }
};

class Refiner {
 public:
  Refiner(const TriangleMesh& base, const std::vector<const Defect*>& defects,
          const DisplacementOptions& o)
      : base_(base), defects_(defects), max_edge2_(double(o.max_edge_mm) * o.max_edge_mm),
        max_tris_(size_t(std::max(0, o.max_triangles))) {
    for (const Defect* d : defects_) {
      Box2 s = d->support();
      supports_.push_back(s);
      all_.lo = {std::min(all_.lo.x, s.lo.x), std::min(all_.lo.y, s.lo.y)};
      all_.hi = {std::max(all_.hi.x, s.hi.x), std::max(all_.hi.y, s.hi.y)};
    }
    const size_t nv = base.positions.size();
    n_base_verts_ = nv;
    n_base_tris_ = base.triangleCount();
    pos_ = base.positions;
    uv_ = base.uvs;
    h_.assign(nv, std::numeric_limits<float>::quiet_NaN());
    tv_.assign(base.indices.begin(), base.indices.begin() + 3 * n_base_tris_);
    for (uint32_t i : tv_)
      if (i >= nv) throw std::invalid_argument("displaceMesh: triangle index out of range");
    origin_.resize(n_base_tris_);
    for (size_t t = 0; t < n_base_tris_; ++t) origin_[t] = uint32_t(t);
    frozen_.assign(n_base_tris_, 0);
    for (size_t t = 0; t < n_base_tris_; ++t) {
      const uint32_t* v = &tv_[3 * t];
      if (v[0] == v[1] || v[1] == v[2] || v[2] == v[0]) frozen_[t] = 1;
    }
    buildStars();
    freezeDuplicates();
    buildAdjacency();
    buildDirections();
  }

  void run() {
    for (size_t t = 0; t < n_base_tris_; ++t)
      if (!frozen_[t] && overlapsAny(uvBox(uint32_t(t)))) queue_.push_back(uint32_t(t));
    // Children of every bisection are appended to the queue, so a triangle split by another's
    // propagation is looked at again; the queue is processed in order (deterministic).
    for (size_t head = 0; head < queue_.size(); ++head) {
      const uint32_t t = queue_[head];
      while (needsRefine(t)) refine(t);
    }
  }

  TriangleMesh result(DisplacementStats* stats) {
    DisplacementStats st;
    st.triangles_split = tv_.size() / 3 - n_base_tris_;
    st.vertices_added = pos_.size() - n_base_verts_;
    const size_t nt = tv_.size() / 3, nv = pos_.size();

    // The triangles where heights can be non-zero; every vertex inside a support lies in one.
    std::vector<uint32_t> cand;
    for (size_t t = 0; t < nt; ++t) {
      if (t < n_base_tris_ && frozen_[t]) continue;
      if (!overlapsAny(uvBox(uint32_t(t)))) continue;
      cand.push_back(uint32_t(t));
      for (int k = 0; k < 3; ++k) height(tv_[3 * t + k]);
    }
    st.triangles_in_support = cand.size();
    std::vector<uint8_t> moved(nv, 0);
    for (size_t v = 0; v < nv; ++v)
      if (!std::isnan(h_[v]) && h_[v] != 0.0f) {
        moved[v] = 1;
        ++st.vertices_moved;
      }
    if (stats) *stats = st;
    if (st.triangles_split == 0 && st.vertices_moved == 0) return base_;

    TriangleMesh out;
    out.source = base_.source;
    out.indices = tv_;
    out.uvs = uv_;
    out.positions = pos_;
    for (size_t v = 0; v < nv; ++v)
      if (moved[v]) out.positions[v] = pos_[v] + dir_[v] * h_[v];

    const bool have_normals = base_.normals.size() == n_base_verts_;
    if (have_normals) {
      out.normals = base_.normals;
      out.normals.insert(out.normals.end(), dir_.begin() + n_base_verts_, dir_.end());
      if (st.vertices_moved > 0) tiltNormals(cand, moved, out);
    }

    if (base_.mmPerUv.size() == n_base_tris_) {
      out.mmPerUv.resize(nt);
      for (size_t t = 0; t < nt; ++t) out.mmPerUv[t] = base_.mmPerUv[origin_[t]];
    } else {
      out.computeMmPerUv();
    }
    return out;
  }

 private:
  // --- set-up -------------------------------------------------------------------------------

  // Triangles around each input vertex (compressed rows; frozen triangles left out).
  void buildStars() {
    star_start_.assign(n_base_verts_ + 1, 0);
    for (size_t t = 0; t < n_base_tris_; ++t)
      if (!frozen_[t])
        for (int k = 0; k < 3; ++k) ++star_start_[tv_[3 * t + k] + 1];
    for (size_t v = 0; v < n_base_verts_; ++v) star_start_[v + 1] += star_start_[v];
    star_.resize(star_start_[n_base_verts_]);
    std::vector<uint32_t> fill(star_start_.begin(), star_start_.end() - 1);
    for (size_t t = 0; t < n_base_tris_; ++t)
      if (!frozen_[t])
        for (int k = 0; k < 3; ++k) star_[fill[tv_[3 * t + k]]++] = uint32_t(t);
  }

  bool hasVertex(uint32_t t, uint32_t v) const {
    return tv_[3 * t] == v || tv_[3 * t + 1] == v || tv_[3 * t + 2] == v;
  }

  // A second copy of a triangle (same three vertices, e.g. two-sided geometry) is left as it is:
  // it would make an edge's neighbours ambiguous. It may end up with hanging vertices on it.
  void freezeDuplicates() {
    for (size_t t = 0; t < n_base_tris_; ++t) {
      if (frozen_[t]) continue;
      const uint32_t a = tv_[3 * t], b = tv_[3 * t + 1], c = tv_[3 * t + 2];
      for (uint32_t i = star_start_[a]; i < star_start_[a + 1]; ++i) {
        const uint32_t u = star_[i];
        if (u < t && !frozen_[u] && hasVertex(u, b) && hasVertex(u, c)) {
          frozen_[t] = 1;
          break;
        }
      }
    }
  }

  void buildAdjacency() {
    nb_.assign(3 * n_base_tris_, kUnset);
    std::vector<uint32_t> others;
    for (size_t t = 0; t < n_base_tris_; ++t) {
      for (int k = 0; k < 3; ++k) {
        if (frozen_[t]) {
          nb_[3 * t + k] = kBoundary;
          continue;
        }
        if (nb_[3 * t + k] != kUnset) continue;
        const uint32_t a = tv_[3 * t + k], b = tv_[3 * t + (k + 1) % 3];
        others.clear();
        for (uint32_t i = star_start_[a]; i < star_start_[a + 1]; ++i) {
          const uint32_t u = star_[i];
          if (u != t && !frozen_[u] && hasVertex(u, b)) others.push_back(u);
        }
        if (others.empty()) {
          nb_[3 * t + k] = kBoundary;
        } else if (others.size() == 1) {
          nb_[3 * t + k] = int32_t(others[0]);
          nb_[3 * others[0] + slotOf(others[0], a, b)] = int32_t(t);
        } else {
          // Non-manifold edge: every triangle on it refers to one shared list.
          others.push_back(uint32_t(t));
          std::sort(others.begin(), others.end());
          const int32_t s = fanSlot(fans_.size());
          fans_.push_back(others);
          for (uint32_t u : others) nb_[3 * u + slotOf(u, a, b)] = s;
        }
      }
    }
    if (n_base_tris_ > size_t(std::numeric_limits<int32_t>::max()))
      throw std::runtime_error("displaceMesh: mesh too large");
  }

  // Unit displacement direction per vertex: the input's normal, or where it has none, the
  // area-weighted normal of the input's faces around the vertex.
  void buildDirections() {
    dir_.resize(n_base_verts_);
    if (base_.normals.size() == n_base_verts_) {
      for (size_t v = 0; v < n_base_verts_; ++v) dir_[v] = normalize(base_.normals[v]);
      return;
    }
    std::vector<Vec3d> acc(n_base_verts_, Vec3d(0.0));
    for (size_t t = 0; t < n_base_tris_; ++t) {
      if (frozen_[t]) continue;
      const uint32_t* v = &tv_[3 * t];
      const Vec3d c = cross(toD(pos_[v[1]]) - toD(pos_[v[0]]), toD(pos_[v[2]]) - toD(pos_[v[0]]));
      for (int k = 0; k < 3; ++k) acc[v[k]] += c;
    }
    for (size_t v = 0; v < n_base_verts_; ++v) dir_[v] = Vec3f(normalize(acc[v]));
  }

  // --- queries ------------------------------------------------------------------------------

  int slotOf(uint32_t t, uint32_t a, uint32_t b) const {
    for (int k = 0; k < 3; ++k) {
      const uint32_t p = tv_[3 * t + k], q = tv_[3 * t + (k + 1) % 3];
      if ((p == a && q == b) || (p == b && q == a)) return k;
    }
    throw std::logic_error("displaceMesh: adjacency broken (edge not in its neighbour)");
  }

  Box2 uvBox(uint32_t t) const {
    Box2 b;
    for (int k = 0; k < 3; ++k) {
      const Vec2f p = uv_[tv_[3 * t + k]];
      b.lo = {std::min(b.lo.x, p.x), std::min(b.lo.y, p.y)};
      b.hi = {std::max(b.hi.x, p.x), std::max(b.hi.y, p.y)};
    }
    return b;
  }

  bool overlapsAny(const Box2& b) const {
    if (!all_.overlaps(b)) return false;
    for (const Box2& s : supports_)
      if (s.overlaps(b)) return true;
    return false;
  }

  // Sum of the defects' heights at the vertex's UV (mm, along its direction); cached.
  float height(uint32_t v) {
    float& h = h_[v];
    if (!std::isnan(h)) return h;
    const Vec2f p = uv_[v];
    double s = 0.0;
    if (all_.contains(p))
      for (size_t i = 0; i < defects_.size(); ++i)
        if (supports_[i].contains(p)) s += defects_[i]->height(p);
    if (!std::isfinite(s))
      throw std::runtime_error(std::string("displaceMesh: a ") + "defect's height is not finite at uv (" +
                               std::to_string(p.x) + ", " + std::to_string(p.y) + ")");
    h = float(s);
    return h;
  }

  Vec3f displaced(uint32_t v) { return pos_[v] + dir_[v] * height(v); }

  EdgeKey edgeKey(uint32_t a, uint32_t b) const {
    const uint32_t lo = std::min(a, b), hi = std::max(a, b);
    const Vec3d d = toD(pos_[hi]) - toD(pos_[lo]);
    return {dot(d, d), lo, hi};
  }

  int longestEdge(uint32_t t) const {
    int best = 0;
    EdgeKey bk = edgeKey(tv_[3 * t], tv_[3 * t + 1]);
    for (int k = 1; k < 3; ++k) {
      const EdgeKey e = edgeKey(tv_[3 * t + k], tv_[3 * t + (k + 1) % 3]);
      if (bk < e) {
        bk = e;
        best = k;
      }
    }
    return best;
  }

  // Whether t meets a support and has an edge longer than the limit, before or after displacement.
  bool needsRefine(uint32_t t) {
    if (t < n_base_tris_ && frozen_[t]) return false;
    if (!overlapsAny(uvBox(t))) return false;
    const uint32_t* v = &tv_[3 * t];
    for (int k = 0; k < 3; ++k)
      if (edgeKey(v[k], v[(k + 1) % 3]).len2 > max_edge2_) return true;
    const Vec3d q[3] = {toD(displaced(v[0])), toD(displaced(v[1])), toD(displaced(v[2]))};
    for (int k = 0; k < 3; ++k) {
      const Vec3d d = q[(k + 1) % 3] - q[k];
      if (dot(d, d) > max_edge2_) return true;
    }
    return false;
  }

  // The triangles other than t on t's edge k.
  void neighbours(uint32_t t, int k, std::vector<uint32_t>& out) const {
    out.clear();
    const int32_t s = nb_[3 * t + k];
    if (s >= 0) {
      out.push_back(uint32_t(s));
    } else if (isFanSlot(s)) {
      for (uint32_t u : fans_[fanIndex(s)])
        if (u != t) out.push_back(u);
    }
  }

  // --- refinement ---------------------------------------------------------------------------

  // Bisects t once (LEPP): walk from t across longest edges until an edge that is the longest of
  // every triangle on it (or a boundary edge), bisect that edge, and repeat until t itself is split.
  // Keys strictly increase along the path, so it ends.
  void refine(uint32_t t) {
    stack_.clear();
    stack_.push_back(t);
    while (!stack_.empty()) {
      const uint32_t x = stack_.back();
      const int k = longestEdge(x);
      const uint32_t a = tv_[3 * x + k], b = tv_[3 * x + (k + 1) % 3];
      neighbours(x, k, scratch_);
      bool pushed = false;
      for (uint32_t u : scratch_) {
        const int ku = longestEdge(u);
        const uint32_t p = tv_[3 * u + ku], q = tv_[3 * u + (ku + 1) % 3];
        if (!((p == a && q == b) || (p == b && q == a))) {
          stack_.push_back(u);
          pushed = true;
          break;
        }
      }
      if (pushed) continue;
      const bool splits_t = x == t || std::find(scratch_.begin(), scratch_.end(), t) != scratch_.end();
      bisect(x, k);
      if (splits_t) return;
      stack_.pop_back();
    }
  }

  // In the triangle (or fan) that referred to `old` across edge {a,b}, refer to `now` instead.
  void relink(int32_t slot, uint32_t old, uint32_t now, uint32_t a, uint32_t b) {
    if (slot >= 0) {
      const uint32_t w = uint32_t(slot);
      nb_[3 * w + slotOf(w, a, b)] = int32_t(now);
    } else if (isFanSlot(slot)) {
      for (uint32_t& u : fans_[fanIndex(slot)])
        if (u == old) u = now;
    }
  }

  // Splits edge k of x, and with it every other triangle on that edge, at the edge's midpoint.
  void bisect(uint32_t x, int k) {
    const uint32_t a = tv_[3 * x + k], b = tv_[3 * x + (k + 1) % 3];
    const int32_t edge_slot = nb_[3 * x + k];
    fan_.clear();
    fan_.push_back(x);
    neighbours(x, k, scratch_);
    fan_.insert(fan_.end(), scratch_.begin(), scratch_.end());

    const size_t nt = tv_.size() / 3;
    if (nt + fan_.size() > max_tris_)
      throw std::runtime_error("displaceMesh: refining to max_edge " + std::to_string(std::sqrt(max_edge2_)) +
                               " mm needs more than " + std::to_string(max_tris_) +
                               " triangles; raise the edge length or lower the number of displaced defects");
    if (pos_.size() >= size_t(std::numeric_limits<uint32_t>::max()))
      throw std::runtime_error("displaceMesh: too many vertices");

    // The midpoint. Its direction is the normalized mean of the end directions (the face normal of
    // x where they cancel). Float sums commute, so the result does not depend on which end is a.
    const uint32_t m = uint32_t(pos_.size());
    pos_.push_back((pos_[a] + pos_[b]) * 0.5f);
    uv_.push_back((uv_[a] + uv_[b]) * 0.5f);
    Vec3f d = dir_[a] + dir_[b];
    if (!(length(d) > 1e-6f)) {
      const uint32_t* v = &tv_[3 * x];
      d = cross(pos_[v[1]] - pos_[v[0]], pos_[v[2]] - pos_[v[0]]);
    }
    dir_.push_back(normalize(d));
    h_.push_back(std::numeric_limits<float>::quiet_NaN());

    side_a_.clear();
    side_b_.clear();
    for (uint32_t y : fan_) {
      const int ky = slotOf(y, a, b);
      const uint32_t p = tv_[3 * y + ky], q = tv_[3 * y + (ky + 1) % 3], r = tv_[3 * y + (ky + 2) % 3];
      const int32_t n_qr = nb_[3 * y + (ky + 1) % 3], n_rp = nb_[3 * y + (ky + 2) % 3];
      const uint32_t z = uint32_t(tv_.size() / 3);
      // y becomes (p, m, r); z is (m, q, r). Both keep y's winding; slot 0 is the half of the split edge.
      tv_[3 * y] = p;
      tv_[3 * y + 1] = m;
      tv_[3 * y + 2] = r;
      nb_[3 * y] = kBoundary;
      nb_[3 * y + 1] = int32_t(z);
      nb_[3 * y + 2] = n_rp;
      tv_.insert(tv_.end(), {m, q, r});
      nb_.insert(nb_.end(), {kBoundary, n_qr, int32_t(y)});
      origin_.push_back(origin_[y]);
      relink(n_qr, y, z, q, r);
      side_a_.push_back(p == a ? y : z);
      side_b_.push_back(p == a ? z : y);
      queue_.push_back(y);
      queue_.push_back(z);
    }
    if (fan_.size() == 2) {
      nb_[3 * side_a_[0]] = int32_t(side_a_[1]);
      nb_[3 * side_a_[1]] = int32_t(side_a_[0]);
      nb_[3 * side_b_[0]] = int32_t(side_b_[1]);
      nb_[3 * side_b_[1]] = int32_t(side_b_[0]);
    } else if (fan_.size() > 2) {
      const size_t ja = fanIndex(edge_slot), jb = fans_.size();
      fans_[ja] = side_a_;
      fans_.push_back(side_b_);
      for (uint32_t u : side_a_) nb_[3 * u] = fanSlot(ja);
      for (uint32_t u : side_b_) nb_[3 * u] = fanSlot(jb);
    }
  }

  // --- normals ------------------------------------------------------------------------------

  // Moved vertices: rotate the interpolated input normal by the rotation that takes the
  // area-weighted normal of the vertex's undisplaced fan to that of its displaced fan.
  void tiltNormals(const std::vector<uint32_t>& cand, const std::vector<uint8_t>& moved, TriangleMesh& out) {
    const size_t nv = pos_.size();
    std::vector<Vec3d> before(nv, Vec3d(0.0)), after(nv, Vec3d(0.0));
    for (uint32_t t : cand) {
      const uint32_t* v = &tv_[3 * t];
      if (!moved[v[0]] && !moved[v[1]] && !moved[v[2]]) continue;
      const Vec3d cb = cross(toD(pos_[v[1]]) - toD(pos_[v[0]]), toD(pos_[v[2]]) - toD(pos_[v[0]]));
      const Vec3d ca = cross(toD(out.positions[v[1]]) - toD(out.positions[v[0]]),
                             toD(out.positions[v[2]]) - toD(out.positions[v[0]]));
      for (int k = 0; k < 3; ++k)
        if (moved[v[k]]) {
          before[v[k]] += cb;
          after[v[k]] += ca;
        }
    }
    for (size_t v = 0; v < nv; ++v) {
      if (!moved[v]) continue;
      const double lb = length(before[v]), la = length(after[v]);
      if (!(lb > 0) || !(la > 0)) continue;
      const Vec3d from = before[v] / lb, to = after[v] / la;
      const Vec3d n = toD(dir_[v]);
      const double c = dot(from, to);
      Vec3d r;
      if (c > -0.9999) {
        // Rodrigues' rotation about w = from x to (|w| = sin of the angle).
        const Vec3d w = cross(from, to);
        r = n * c + cross(w, n) + w * (dot(w, n) / (1.0 + c));
      } else {
        r = to;
      }
      out.normals[v] = Vec3f(normalize(r));
    }
  }

  const TriangleMesh& base_;
  const std::vector<const Defect*>& defects_;
  std::vector<Box2> supports_;
  Box2 all_;
  double max_edge2_;
  size_t max_tris_;
  size_t n_base_verts_ = 0, n_base_tris_ = 0;

  std::vector<Vec3f> pos_;  // undisplaced
  std::vector<Vec3f> dir_;  // unit displacement direction
  std::vector<Vec2f> uv_;
  std::vector<float> h_;    // height per vertex, NaN until evaluated
  std::vector<uint32_t> tv_;
  std::vector<int32_t> nb_;
  std::vector<uint32_t> origin_;  // the input triangle each triangle came from
  std::vector<uint8_t> frozen_;   // input triangles left alone (repeated vertex, duplicate)
  std::vector<std::vector<uint32_t>> fans_;
  std::vector<uint32_t> star_start_, star_;

  std::vector<uint32_t> queue_, stack_, scratch_, fan_, side_a_, side_b_;
};

}  // namespace

TriangleMesh displaceMesh(const TriangleMesh& base, const std::vector<const Defect*>& defects,
                          const DisplacementOptions& o, DisplacementStats* stats) {
  if (stats) *stats = DisplacementStats{};
  std::vector<const Defect*> live;
  for (const Defect* d : defects)
    if (d) live.push_back(d);
  if (live.empty()) return base;
  if (!(o.max_edge_mm > 0.0f) || !std::isfinite(o.max_edge_mm))
    throw std::invalid_argument("displaceMesh: max_edge_mm must be a positive number");
  if (base.uvs.size() != base.positions.size())
    throw std::invalid_argument("displaceMesh: the mesh has no UV chart (" + base.source +
                                "); defects cannot be placed on it");
  Refiner r(base, live, o);
  r.run();
  return r.result(stats);
}

}  // namespace dg
