// TriangleMesh measurements: bounding box, surface area and the per-triangle chart scale.
#include "render/mesh.h"

#include <cmath>
#include <limits>

namespace dg {

namespace {

Vec3d toD(Vec3f v) { return Vec3d(v); }

// Twice the area of the 3-D triangle (length of the edge cross product), in double.
double twiceArea3(const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  return length(cross(toD(b) - toD(a), toD(c) - toD(a)));
}

}  // namespace

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
  mmPerUv.assign(n, 0.0f);
  if (uvs.size() != positions.size()) return;  // no chart: the scale is unknown (0 everywhere)
  for (size_t t = 0; t < n; ++t) {
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
}

}  // namespace dg
