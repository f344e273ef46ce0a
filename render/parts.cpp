// Built-in parametric car parts: regular grid tessellations with analytic normals and arc-length UVs.
//
// Conventions shared by every part (see parts.h):
//  - The stated sizes (width, height, length) are the extents of the part projected on the x-y
//    plane; a curved part is therefore longer than that along its surface, and its UVs (arc length
//    in mm) run further than the size.
//  - u runs along +x, v along +y, both from 0 at a corner; the outside faces +z, triangles are
//    counter-clockwise seen from there, and the bounding box is centred on the origin.
//  - Grid spacing is chosen so that no edge (the cell diagonals included) is longer than max_edge_mm.
#include "render/parts.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

namespace dg {

namespace {

// Largest vertex count a built-in part may have; a finer request is almost surely a unit mistake.
constexpr double kMaxVertices = 2.0e7;

void requireFinitePositive(const char* fn, const char* name, double v) {
  if (!(std::isfinite(v) && v > 0)) {
    std::ostringstream s;
    s << fn << ": " << name << " must be a positive finite number, got " << v;
    throw std::invalid_argument(s.str());
  }
}

void requireFiniteNonNegative(const char* fn, const char* name, double v) {
  if (!(std::isfinite(v) && v >= 0)) {
    std::ostringstream s;
    s << fn << ": " << name << " must be a finite number >= 0, got " << v;
    throw std::invalid_argument(s.str());
  }
}

void requireGridSize(const char* fn, double cols, double rows) {
  if ((cols + 1) * (rows + 1) > kMaxVertices) {
    std::ostringstream s;
    s << fn << ": max_edge_mm is too small for the part size (would need about "
      << (cols + 1) * (rows + 1) << " vertices)";
    throw std::invalid_argument(s.str());
  }
}

int cellsFor(double length, double step) { return std::max(1, int(std::ceil(length / step - 1e-9))); }
int evenCellsFor(double length, double step) { return 2 * cellsFor(0.5 * length, step); }

// Accumulates vertices (in double) and triangles, then produces the final float mesh.
struct MeshBuilder {
  std::vector<Vec3d> pos, nrm;
  std::vector<Vec2d> uv;
  std::vector<uint32_t> idx;

  uint32_t add(const Vec3d& p, const Vec3d& n, const Vec2d& t) {
    pos.push_back(p);
    nrm.push_back(normalize(n));
    uv.push_back(t);
    return uint32_t(pos.size() - 1);
  }
  void tri(uint32_t a, uint32_t b, uint32_t c) { idx.insert(idx.end(), {a, b, c}); }

  // Vertices laid out row by row (rows along v), `cols` vertices per row: two triangles per cell,
  // counter-clockwise seen from +z when u grows with x and v with y.
  void gridTriangles(int cols, int rows) {
    for (int j = 0; j + 1 < rows; ++j)
      for (int i = 0; i + 1 < cols; ++i) {
        const uint32_t a = uint32_t(j * cols + i), b = a + 1, c = a + uint32_t(cols) + 1,
                       d = a + uint32_t(cols);
        tri(a, b, c);
        tri(a, c, d);
      }
  }

  // Drops vertices no triangle uses, centres the bounding box on the origin, converts to float.
  TriangleMesh finish(const std::string& name) {
    std::vector<int64_t> remap(pos.size(), -1);
    TriangleMesh m;
    for (uint32_t& i : idx) {
      if (remap[i] < 0) {
        remap[i] = int64_t(m.positions.size());
        m.positions.push_back(Vec3f(pos[i]));
        m.normals.push_back(Vec3f(nrm[i]));
        m.uvs.push_back(Vec2f(float(uv[i].x), float(uv[i].y)));
      }
    }
    // Centre in double before converting, so the float positions are rounded once.
    Vec3d lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
    for (size_t i = 0; i < pos.size(); ++i) {
      if (remap[i] < 0) continue;
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], pos[i][k]);
        hi[k] = std::max(hi[k], pos[i][k]);
      }
    }
    const Vec3d centre = (lo + hi) * 0.5;
    for (size_t i = 0; i < pos.size(); ++i)
      if (remap[i] >= 0) m.positions[size_t(remap[i])] = Vec3f(pos[i] - centre);
    m.indices.reserve(idx.size());
    for (uint32_t i : idx) m.indices.push_back(uint32_t(remap[i]));
    m.source = "builtin:" + name;
    m.computeMmPerUv();
    return m;
  }
};

// Cumulative arc length of the graph of a function z(t) over [t0, t1], tabulated finely so it can be
// inverted: s(t) = integral of sqrt(1 + z'(t)^2) dt, by Simpson's rule on each table interval.
class ArcLengthTable {
 public:
  ArcLengthTable(std::function<double(double)> dz, double t0, double t1, int intervals)
      : dz_(std::move(dz)), t0_(t0), h_((t1 - t0) / intervals), s_(size_t(intervals) + 1, 0.0) {
    for (int k = 0; k < intervals; ++k) {
      const double a = t0 + k * h_, b = a + h_;
      s_[size_t(k) + 1] = s_[size_t(k)] + h_ / 6 * (speed(a) + 4 * speed(0.5 * (a + b)) + speed(b));
    }
  }
  double total() const { return s_.back(); }
  double arcAt(double t) const {
    const double f = std::clamp((t - t0_) / h_, 0.0, double(s_.size() - 1));
    const size_t k = std::min(size_t(f), s_.size() - 2);
    const double a = t0_ + double(k) * h_;
    // Simpson from the tabulated node to t keeps the table's accuracy between nodes.
    const double w = t - a;
    return s_[k] + w / 6 * (speed(a) + 4 * speed(a + 0.5 * w) + speed(t));
  }
  // The parameter t at which the arc length from t0 equals s.
  double paramAt(double s) const {
    if (s <= 0) return t0_;
    if (s >= total()) return t0_ + h_ * double(s_.size() - 1);
    const size_t k = size_t(std::upper_bound(s_.begin(), s_.end(), s) - s_.begin()) - 1;
    double t = t0_ + h_ * (double(k) + (s - s_[k]) / (s_[k + 1] - s_[k]));
    for (int it = 0; it < 3; ++it) t -= (arcAt(t) - s) / speed(t);  // Newton: ds/dt = speed
    return t;
  }

 private:
  double speed(double t) const {
    const double d = dz_(t);
    return std::sqrt(1 + d * d);
  }
  std::function<double(double)> dz_;
  double t0_, h_;
  std::vector<double> s_;
};

// Splits [a, b] into equal steps no longer than `step`, appending the interior and end points.
void appendUniform(std::vector<double>& out, double a, double b, double step) {
  if (!(b > a)) return;
  const int n = cellsFor(b - a, step);
  for (int k = 1; k <= n; ++k) out.push_back(k == n ? b : a + (b - a) * k / n);
}

}  // namespace

TriangleMesh makePlate(const PlateParams& p, double max_edge_mm) {
  const char* fn = "makePlate";
  requireFinitePositive(fn, "width_mm", p.width_mm);
  requireFinitePositive(fn, "height_mm", p.height_mm);
  requireFinitePositive(fn, "max_edge_mm", max_edge_mm);
  const double step = max_edge_mm / std::sqrt(2.0);  // the cell diagonal is the longest edge
  const int nx = cellsFor(p.width_mm, step), ny = cellsFor(p.height_mm, step);
  requireGridSize(fn, nx, ny);
  MeshBuilder b;
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      const double u = p.width_mm * i / nx, v = p.height_mm * j / ny;
      b.add({u, v, 0}, {0, 0, 1}, {u, v});
    }
  b.gridTriangles(nx + 1, ny + 1);
  return b.finish("plate");
}

// Door panel cross-section (y-z plane, the same for every x):
//   z(y) = sqrt(R^2 - y^2) - R + ridge(y),   y in [-H/2, H/2]
// a circular bow of radius R bulging towards +z, plus the character line, a raised-cosine (Hann)
// ridge of height d and full width w centred at y_c = -H/2 + f H:
//   ridge(y) = d/2 (1 + cos(2 pi (y - y_c) / w)) for |y - y_c| < w/2, else 0,
// whose value and slope are continuous, so the analytic normals are continuous too.
TriangleMesh makeDoorPanel(const DoorPanelParams& p, double max_edge_mm) {
  const char* fn = "makeDoorPanel";
  requireFinitePositive(fn, "width_mm", p.width_mm);
  requireFinitePositive(fn, "height_mm", p.height_mm);
  requireFinitePositive(fn, "curvature_radius_mm", p.curvature_radius_mm);
  requireFiniteNonNegative(fn, "character_line_depth_mm", p.character_line_depth_mm);
  requireFinitePositive(fn, "character_line_width_mm", p.character_line_width_mm);
  requireFinitePositive(fn, "max_edge_mm", max_edge_mm);
  if (!(p.character_line_height >= 0 && p.character_line_height <= 1))
    throw std::invalid_argument("makeDoorPanel: character_line_height must be in [0, 1], got " +
                                std::to_string(p.character_line_height));
  const double R = p.curvature_radius_mm, H = p.height_mm, W = p.width_mm;
  if (!(R > 0.5 * H))
    throw std::invalid_argument("makeDoorPanel: curvature_radius_mm (" + std::to_string(R) +
                                ") must exceed half the height (" + std::to_string(0.5 * H) + ")");
  const double d = p.character_line_depth_mm, w = p.character_line_width_mm;
  const double yc = -0.5 * H + p.character_line_height * H;

  auto z = [=](double y) {
    double r = 0;
    if (std::abs(y - yc) < 0.5 * w) r = 0.5 * d * (1 + std::cos(2 * kPi * (y - yc) / w));
    return std::sqrt(R * R - y * y) - R + r;
  };
  auto dz = [=](double y) {
    double r = 0;
    if (std::abs(y - yc) < 0.5 * w) r = -d * kPi / w * std::sin(2 * kPi * (y - yc) / w);
    return -y / std::sqrt(R * R - y * y) + r;
  };

  // Table fine enough to resolve the ridge (at least 200 intervals across it) and the bow.
  const int intervals = int(std::clamp(std::max(H / 0.05, 200 * H / w), 2000.0, 2.0e6));
  const ArcLengthTable arc(dz, -0.5 * H, 0.5 * H, intervals);
  const double S = arc.total();

  // Rows in arc length: uniform steps, finer across the ridge so its shape is resolved by the
  // geometry and not only by the normals.
  const double step = max_edge_mm / std::sqrt(2.0);
  const double fine = std::min(step, w / 12);
  double sa = arc.arcAt(std::clamp(yc - 0.5 * w, -0.5 * H, 0.5 * H));
  double sb = arc.arcAt(std::clamp(yc + 0.5 * w, -0.5 * H, 0.5 * H));
  if (d == 0) sa = sb = S;  // no ridge: no refinement
  std::vector<double> rows{0.0};
  appendUniform(rows, 0.0, sa, step);
  appendUniform(rows, sa, sb, fine);
  appendUniform(rows, sb, S, step);
  const int nx = cellsFor(W, step);
  requireGridSize(fn, nx, double(rows.size()));

  MeshBuilder b;
  for (double v : rows) {
    const double y = arc.paramAt(v);
    const double zy = z(y), slope = dz(y);
    for (int i = 0; i <= nx; ++i) {
      const double u = W * i / nx;
      b.add({u - 0.5 * W, y, zy}, {0, -slope, 1}, {u, v});
    }
  }
  b.gridTriangles(nx + 1, int(rows.size()));
  return b.finish("door_panel");
}

// Hood: z = c (1 - (2x/W)^2) (1 - (2y/L)^2), x in [-W/2, W/2], y in [-L/2, L/2].
// Along a row (y fixed) the surface is the parabola z = c g(y) - k x^2 / 2, whose slope is
// z_x = -k x with k = 8 c g(y) / W^2, so the arc length from the edge has the closed form
//   integral sqrt(1 + k^2 t^2) dt = (t sqrt(1 + k^2 t^2) + asinh(k t) / k) / 2.
// u is that arc length along the row and v the same along the column: each is exact along its own
// grid line, but a doubly curved surface has no isometric chart, so mmPerUv deviates slightly from
// 1 (by about the square of the slopes) and records that.
namespace {
double parabolaArc(double t, double k) {
  const double kt = k * t;
  if (std::abs(k) < 1e-12) return t;
  return 0.5 * (t * std::sqrt(1 + kt * kt) + std::asinh(kt) / k);
}
}  // namespace

TriangleMesh makeHood(const HoodParams& p, double max_edge_mm) {
  const char* fn = "makeHood";
  requireFinitePositive(fn, "width_mm", p.width_mm);
  requireFinitePositive(fn, "length_mm", p.length_mm);
  requireFiniteNonNegative(fn, "crown_mm", p.crown_mm);
  requireFinitePositive(fn, "max_edge_mm", max_edge_mm);
  const double W = p.width_mm, L = p.length_mm, c = p.crown_mm;
  // Slopes are bounded by sx = 4c/W and sy = 4c/L, so a cell of side h has a diagonal no longer
  // than h sqrt(2 + (sx + sy)^2).
  const double sx = 4 * c / W, sy = 4 * c / L;
  const double h = max_edge_mm / std::sqrt(2 + (sx + sy) * (sx + sy));
  // Even cell counts put a vertex on the crown's apex.
  const int nx = evenCellsFor(W, h), ny = evenCellsFor(L, h);
  requireGridSize(fn, nx, ny);
  MeshBuilder b;
  for (int j = 0; j <= ny; ++j) {
    const double y = -0.5 * L + L * j / ny;
    const double gy = 1 - (2 * y / L) * (2 * y / L);
    for (int i = 0; i <= nx; ++i) {
      const double x = -0.5 * W + W * i / nx;
      const double gx = 1 - (2 * x / W) * (2 * x / W);
      const double kx = 8 * c * gy / (W * W), ky = 8 * c * gx / (L * L);
      const double zx = -kx * x, zy = -ky * y;
      const double u = parabolaArc(x, kx) + parabolaArc(0.5 * W, kx);
      const double v = parabolaArc(y, ky) + parabolaArc(0.5 * L, ky);
      b.add({x, y, c * gx * gy}, {-zx, -zy, 1}, {u, v});
    }
  }
  b.gridTriangles(nx + 1, ny + 1);
  return b.finish("hood");
}

// Fender: a cylinder of radius R with its axis along y (curved in plan view), x = R sin(theta),
// z = R cos(theta) - R, theta = (u - U/2) / R, where u is the arc length (exact: the cylinder
// unrolls isometrically) and U = 2 R asin(L / 2R). The wheel arch is the half disc of radius a
// centred on the bottom edge at x = 0, as seen from the side (in the x-y plane).
//
// Cut-out: the grid vertices within a fifth of a cell of the arch circle are snapped radially onto
// it; triangles crossing the circle are clipped at the points where their edges cross it (shared
// per edge, so the mesh stays conforming); what lies inside is dropped. The boundary is thus a
// polygon with every vertex on the circle, and no vertex inside it.
TriangleMesh makeFender(const FenderParams& p, double max_edge_mm) {
  const char* fn = "makeFender";
  requireFinitePositive(fn, "length_mm", p.length_mm);
  requireFinitePositive(fn, "height_mm", p.height_mm);
  requireFiniteNonNegative(fn, "arch_radius_mm", p.arch_radius_mm);
  requireFinitePositive(fn, "curvature_radius_mm", p.curvature_radius_mm);
  requireFinitePositive(fn, "max_edge_mm", max_edge_mm);
  const double L = p.length_mm, H = p.height_mm, a = p.arch_radius_mm, R = p.curvature_radius_mm;
  if (!(R > 0.5 * L))
    throw std::invalid_argument("makeFender: curvature_radius_mm (" + std::to_string(R) +
                                ") must exceed half the length (" + std::to_string(0.5 * L) + ")");
  if (!(a < 0.5 * L && a < H))
    throw std::invalid_argument("makeFender: arch_radius_mm (" + std::to_string(a) +
                                ") must be smaller than half the length and than the height");

  const double U = 2 * R * std::asin(0.5 * L / R);
  // Snapping moves a vertex by up to kSnap cells in the side view, which is up to 1/cos(theta) times
  // more on the surface (theta <= asin(a/R) along the arch), so a cell diagonal can grow by twice
  // that; the spacing leaves room for it.
  constexpr double kSnap = 0.2;
  const double stretch = 1 / std::sqrt(1 - (a / R) * (a / R));
  const double step = max_edge_mm / (std::sqrt(2.0) + 2 * kSnap * stretch);
  const int nu = cellsFor(U, step), nv = cellsFor(H, step);
  requireGridSize(fn, nu, nv);
  const double hmin = std::min(U / nu, H / nv);

  // Working coordinates are (u, y); the arch test needs x.
  auto xOf = [=](double u) { return R * std::sin((u - 0.5 * U) / R); };
  auto uOf = [=](double x) { return 0.5 * U + R * std::asin(x / R); };
  auto archDist = [=](Vec2d q) { return std::hypot(xOf(q.x), q.y + 0.5 * H) - a; };
  auto snapToCircle = [=](Vec2d q) {
    const double x = xOf(q.x), dy = q.y + 0.5 * H, r = std::hypot(x, dy);
    return Vec2d{uOf(x * a / r), -0.5 * H + dy * a / r};
  };

  enum Side : int8_t { kInside = -1, kOn = 0, kOutside = 1 };
  std::vector<Vec2d> q;  // (u, y) of every vertex, grid first, then edge crossings
  std::vector<int8_t> side;
  for (int j = 0; j <= nv; ++j)
    for (int i = 0; i <= nu; ++i) {
      Vec2d g{U * i / nu, -0.5 * H + H * j / nv};
      int8_t s = kOutside;
      if (a > 0) {
        const double dist = archDist(g);
        const double r = dist + a;
        if (std::abs(dist) < kSnap * hmin && r > 0) {
          g = snapToCircle(g);
          s = kOn;
        } else if (dist < 0) {
          s = kInside;
        }
      }
      q.push_back(g);
      side.push_back(s);
    }

  std::unordered_map<uint64_t, uint32_t> crossings;
  auto crossing = [&](uint32_t in, uint32_t out) {
    const uint64_t key = (uint64_t(std::min(in, out)) << 32) | std::max(in, out);
    auto it = crossings.find(key);
    if (it != crossings.end()) return it->second;
    double lo = 0, hi = 1;  // archDist < 0 at lo (inside end), > 0 at hi
    for (int it2 = 0; it2 < 60; ++it2) {
      const double mid = 0.5 * (lo + hi);
      (archDist(q[in] + (q[out] - q[in]) * mid) < 0 ? lo : hi) = mid;
    }
    const Vec2d c = snapToCircle(q[in] + (q[out] - q[in]) * (0.5 * (lo + hi)));
    q.push_back(c);
    side.push_back(kOn);
    const uint32_t id = uint32_t(q.size() - 1);
    crossings.emplace(key, id);
    return id;
  };

  std::vector<uint32_t> tris;
  auto emitClipped = [&](const uint32_t v[3]) {
    bool anyIn = false, anyOut = false;
    for (int k = 0; k < 3; ++k) {
      anyIn |= side[v[k]] == kInside;
      anyOut |= side[v[k]] == kOutside;
    }
    if (!anyOut) return;  // inside the arch, or a chord triangle with all corners on the circle
    if (!anyIn) {
      tris.insert(tris.end(), {v[0], v[1], v[2]});
      return;
    }
    // Walk the triangle's edges in order, keeping non-inside corners and the edge crossings: the
    // result is convex (points in order on a convex boundary), so a fan triangulates it.
    std::vector<uint32_t> poly;
    for (int k = 0; k < 3; ++k) {
      const uint32_t s = v[k], t = v[(k + 1) % 3];
      if (side[s] != kInside) poly.push_back(s);
      if (side[s] == kInside && side[t] == kOutside) poly.push_back(crossing(s, t));
      if (side[s] == kOutside && side[t] == kInside) poly.push_back(crossing(t, s));
    }
    for (size_t k = 1; k + 1 < poly.size(); ++k) tris.insert(tris.end(), {poly[0], poly[k], poly[k + 1]});
  };
  const uint32_t cols = uint32_t(nu + 1);
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const uint32_t a0 = uint32_t(j) * cols + uint32_t(i), b0 = a0 + 1, c0 = a0 + cols + 1, d0 = a0 + cols;
      const uint32_t t1[3] = {a0, b0, c0}, t2[3] = {a0, c0, d0};
      emitClipped(t1);
      emitClipped(t2);
    }

  MeshBuilder b;
  for (const Vec2d& g : q) {
    const double th = (g.x - 0.5 * U) / R;
    b.add({R * std::sin(th), g.y, R * std::cos(th) - R}, {std::sin(th), 0, std::cos(th)},
          {g.x, g.y + 0.5 * H});
  }
  // Drop slivers left where two clipped corners nearly coincide (area tiny against the cell).
  for (size_t t = 0; t < tris.size(); t += 3) {
    const Vec2d e1 = q[tris[t + 1]] - q[tris[t]], e2 = q[tris[t + 2]] - q[tris[t]];
    if (e1.x * e2.y - e1.y * e2.x > 1e-6 * hmin * hmin) b.tri(tris[t], tris[t + 1], tris[t + 2]);
  }
  return b.finish("fender");
}

}  // namespace dg
