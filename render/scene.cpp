#include "render/scene.h"

#include "core/parallel.h"
#include "core/rng.h"
#include "render/groove_area.h"

#include <algorithm>
#include <cmath>
#include <mutex>
#include <stdexcept>
#include <string>

namespace dg {

RTCDevice embreeDevice() {
  static RTCDevice device = [] {
    RTCDevice d = rtcNewDevice("verbose=0");
    if (!d) throw std::runtime_error("Embree: cannot create device (error " +
                                     std::to_string(int(rtcGetDeviceError(nullptr))) + ")");
    return d;
  }();
  return device;
}

namespace {

// Attaches a triangle mesh to the scene as the next geometry. Embree reads the mesh's own arrays
// (shared buffers: the mesh lives as long as the scene, PartGeometry owns both and never changes
// them); copying them cost the scratch reference's 21 million triangles 1.5 GB. Embree loads a
// vertex 16 bytes at a time, so the vertex array gets one more vertex's room past its end, written
// once (a zero vertex pushed and popped) so that what is read there is defined.
void attachTriangles(RTCDevice dev, RTCScene scene, TriangleMesh& m) {
  static_assert(sizeof(Vec3f) == 3 * sizeof(float), "Embree's FLOAT3 layout");
  static_assert(sizeof(m.indices[0]) == sizeof(unsigned), "Embree's UINT3 layout");
  RTCGeometry geom = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
  const size_t nv = m.positions.size(), nt = m.triangleCount();
  if (m.positions.capacity() < nv + 1) m.positions.reserve(nv + 1);
  m.positions.push_back(Vec3f(0.0f));
  m.positions.pop_back();
  rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, m.positions.data(), 0, sizeof(Vec3f),
                             nv);
  rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, m.indices.data(), 0,
                             3 * sizeof(unsigned), nt);
  rtcCommitGeometry(geom);
  rtcAttachGeometry(scene, geom);
  rtcReleaseGeometry(geom);
}

}  // namespace

PartGeometry::PartGeometry(TriangleMesh mesh, TriangleMesh shell) : mesh_(std::move(mesh)), shell_(std::move(shell)) {
  RTCDevice dev = embreeDevice();
  scene_ = rtcNewScene(dev);
  rtcSetSceneBuildQuality(scene_, RTC_BUILD_QUALITY_HIGH);
  // A mesh of millions of triangles (the explicit-geometry scratch reference) gets Embree's
  // compact BVH: on the door's 20.7 million triangles the peak fell by 10% (4.75 to 4.27 GB) and
  // the sample's time too (23.5 to 20.9 s, less memory to fill), the same bytes. On small meshes
  // its traversal was 6-8% slower (quickstart, rusty_fender), so they keep the default layout.
  if (mesh_.triangleCount() + shell_.triangleCount() >= kCompactBvhTriangles)
    rtcSetSceneFlags(scene_, RTC_SCENE_FLAG_COMPACT);
  attachTriangles(dev, scene_, mesh_);  // geometry 0
  if (shell_.triangleCount() > 0) {
    attachTriangles(dev, scene_, shell_);  // geometry 1 (kShellGeometry)
    shell_ng_.resize(shell_.triangleCount());
    for (size_t t = 0; t < shell_ng_.size(); ++t) {
      const uint32_t* f = &shell_.indices[3 * t];
      shell_ng_[t] = unitOrUp(cross(Vec3d(shell_.positions[f[1]]) - Vec3d(shell_.positions[f[0]]),
                                    Vec3d(shell_.positions[f[2]]) - Vec3d(shell_.positions[f[0]])));
    }
  }
  rtcCommitScene(scene_);
  size_t nv = mesh_.positions.size(), nt = mesh_.triangleCount();

  // Tangent frames from the UV chart (shared/reference/blinn-bump.md §8.1): exact dP/du, dP/dv of
  // the piecewise-linear surface, with a guard for degenerate UV triangles.
  // Per triangle, on all threads in slices (one thread took 1 s of the scratch reference's 17 on
  // the door's 21 million triangles); the area sums and the UV box are then gathered in order, so
  // the bits do not depend on the thread count.
  resizeInParallel(frames_, nt);
  resizeInParallel(area_cdf_, nt);
  Vec3f lo, hi;
  mesh_.bounds(lo, hi);
  center_ = (lo + hi) * 0.5f;
  radius_ = 0.5f * length(hi - lo);
  const bool has_uv = mesh_.uvs.size() == nv;
  constexpr size_t kSlice = 65536;
  const size_t slices = (nt + kSlice - 1) / kSlice;
  std::vector<Box2> slice_uv(slices);
  std::vector<size_t> slice_degenerate(slices, 0);
  parallelForSlices(nt, kSlice, [&](size_t sl, size_t begin, size_t end) {
    Box2& ub = slice_uv[sl];
    for (size_t t = begin; t < end; ++t) {
      const uint32_t* f = &mesh_.indices[3 * t];
      Vec3d p0(mesh_.positions[f[0]]), p1(mesh_.positions[f[1]]), p2(mesh_.positions[f[2]]);
      Vec3d e1 = p1 - p0, e2 = p2 - p0;
      Vec3d n = cross(e1, e2);
      double nl = length(n);
      area_cdf_[t] = 0.5 * nl;  // the triangle's area; summed below
      TriFrame& fr = frames_[t];
      fr.ng = unitOrUp(n);
      fr.uv_ok = false;
      if (has_uv) {
        Vec2f a = mesh_.uvs[f[0]], b = mesh_.uvs[f[1]], c = mesh_.uvs[f[2]];
        for (Vec2f q : {a, b, c}) {
          ub.lo.x = std::min(ub.lo.x, q.x);
          ub.lo.y = std::min(ub.lo.y, q.y);
          ub.hi.x = std::max(ub.hi.x, q.x);
          ub.hi.y = std::max(ub.hi.y, q.y);
        }
        double du1 = b.x - a.x, dv1 = b.y - a.y, du2 = c.x - a.x, dv2 = c.y - a.y;
        double det = du1 * dv2 - du2 * dv1;
        double uv_scale = std::fabs(du1 * dv1) + std::fabs(du2 * dv2) + du1 * du1 + dv2 * dv2 + 1e-30;
        if (std::fabs(det) > 1e-9 * uv_scale && nl > 0) {
          Vec3d pu = (e1 * dv2 - e2 * dv1) / det;
          Vec3d pv = (e2 * du1 - e1 * du2) / det;
          if (isFinite(pu) && isFinite(pv)) {
            fr.dpdu = Vec3f(pu);
            fr.dpdv = Vec3f(pv);
            fr.uv_ok = true;
          }
        }
      }
      if (!fr.uv_ok) {
        Frame on = Frame::fromNormal(fr.ng);
        fr.dpdu = on.t;
        fr.dpdv = on.b;
        ++slice_degenerate[sl];
      }
    }
  });
  for (size_t t = 1; t < nt; ++t) area_cdf_[t] += area_cdf_[t - 1];  // in triangle order, as one sum
  for (size_t sl = 0; sl < slices; ++sl) {
    const Box2& ub = slice_uv[sl];
    uv_bounds_.lo.x = std::min(uv_bounds_.lo.x, ub.lo.x);
    uv_bounds_.lo.y = std::min(uv_bounds_.lo.y, ub.lo.y);
    uv_bounds_.hi.x = std::max(uv_bounds_.hi.x, ub.hi.x);
    uv_bounds_.hi.y = std::max(uv_bounds_.hi.y, ub.hi.y);
    degenerate_uv_ += slice_degenerate[sl];
  }
}

Vec2f PartGeometry::sampleSurfaceUv(double u0, double u1, double u2) const {
  if (area_cdf_.empty() || mesh_.uvs.empty()) return {0, 0};
  double target = u0 * area_cdf_.back();
  size_t t = size_t(std::upper_bound(area_cdf_.begin(), area_cdf_.end(), target) - area_cdf_.begin());
  t = std::min(t, area_cdf_.size() - 1);
  return uvInTriangle(t, u1, u2);
}

namespace {
// Uniform barycentrics from (u1, u2) in [0, 1)^2 by the square-root warp (Osada et al. 2002,
// eq. 1): the point b0 A + b1 B + b2 C is uniform by area in the triangle ABC.
void uniformBarycentrics(double u1, double u2, double& b0, double& b1, double& b2) {
  const double s = std::sqrt(u1);
  b1 = 1 - s;
  b2 = u2 * s;
  b0 = 1 - b1 - b2;
}
}  // namespace

Vec2f PartGeometry::uvInTriangle(size_t t, double u1, double u2) const {
  double b0, b1, b2;
  uniformBarycentrics(u1, u2, b0, b1, b2);
  const uint32_t* f = &mesh_.indices[3 * t];
  return mesh_.uvs[f[0]] * float(b0) + mesh_.uvs[f[1]] * float(b1) + mesh_.uvs[f[2]] * float(b2);
}

bool PartGeometry::sampleSurfaceUvIn(const Box2& box, Rng& rng, Vec2f& out) const {
  namespace ga = groove::area;
  if (mesh_.uvs.empty() || !(box.hi.x >= box.lo.x && box.hi.y >= box.lo.y)) return false;
  // Every triangle's UV triangle clipped to the box (a convex polygon, in double), weighted by the
  // surface area it stands for: the triangle's 3-D area times the share of its UV area kept.
  std::vector<ga::Poly> pieces;
  std::vector<double> cdf;
  double total = 0;
  for (size_t t = 0; 3 * t + 2 < mesh_.indices.size(); ++t) {
    const uint32_t* f = &mesh_.indices[3 * t];
    const Vec2f a = mesh_.uvs[f[0]], b = mesh_.uvs[f[1]], c = mesh_.uvs[f[2]];
    Box2 tb;
    tb.lo = {std::min({a.x, b.x, c.x}), std::min({a.y, b.y, c.y})};
    tb.hi = {std::max({a.x, b.x, c.x}), std::max({a.y, b.y, c.y})};
    if (!box.overlaps(tb)) continue;
    const double area3 = area_cdf_[t] - (t > 0 ? area_cdf_[t - 1] : 0.0);
    ga::Poly poly;
    for (const Vec2f& q : {a, b, c}) poly.push(Vec2d(q.x, q.y));
    const double full = std::fabs(poly.area());
    if (!(area3 > 0) || !(full > 0)) continue;
    // The box's four sides as half-planes a.p + c <= 0.
    poly = ga::clip(poly, {-1, 0}, box.lo.x);
    poly = ga::clip(poly, {1, 0}, -box.hi.x);
    poly = ga::clip(poly, {0, -1}, box.lo.y);
    poly = ga::clip(poly, {0, 1}, -box.hi.y);
    const double kept = std::fabs(poly.area());
    if (poly.empty() || !(kept > 0)) continue;
    total += area3 * std::min(1.0, kept / full);
    pieces.push_back(poly);
    cdf.push_back(total);
  }
  if (pieces.empty() || !(total > 0)) return false;
  // A piece by its surface area, a triangle of its fan by UV area (the piece's chart is affine, so
  // UV area is surface area up to one factor), a point in it by the square-root warp.
  size_t k = size_t(std::upper_bound(cdf.begin(), cdf.end(), rng.uniformD() * total) - cdf.begin());
  const ga::Poly& p = pieces[std::min(k, pieces.size() - 1)];
  std::vector<double> fan;
  double fan_total = 0;
  for (size_t i = 1; i + 1 < size_t(p.n); ++i) {
    fan_total += std::fabs(cross(p.v[i] - p.v[0], p.v[i + 1] - p.v[0]));
    fan.push_back(fan_total);
  }
  size_t i = size_t(std::upper_bound(fan.begin(), fan.end(), rng.uniformD() * fan_total) - fan.begin());
  i = std::min(i, fan.size() - 1) + 1;
  const double u1 = rng.uniformD(), u2 = rng.uniformD();
  double b0, b1, b2;
  uniformBarycentrics(u1, u2, b0, b1, b2);
  const Vec2d q = p.v[0] * b0 + p.v[i] * b1 + p.v[i + 1] * b2;
  // Rounding may put it a float step outside.
  out = Vec2f(std::clamp(float(q.x), box.lo.x, box.hi.x), std::clamp(float(q.y), box.lo.y, box.hi.y));
  return true;
}

void PartGeometry::computeOcclusion(int rays, float max_distance) {
  size_t nv = mesh_.positions.size();
  occlusion_.assign(nv, 0.0f);
  std::vector<Vec3f> vn(nv, Vec3f(0.0f));
  if (mesh_.normals.size() == nv) {
    vn = mesh_.normals;
  } else {
    for (size_t t = 0; t < frames_.size(); ++t)
      for (int k = 0; k < 3; ++k) vn[mesh_.indices[3 * t + k]] += frames_[t].ng;
    for (auto& n : vn) n = normalize(n);
  }
  parallelFor((nv + 255) / 256, [&](size_t chunk) {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    for (size_t v = chunk * 256; v < std::min(nv, (chunk + 1) * 256); ++v) {
      Frame fr = Frame::fromNormal(vn[v]);
      Vec3f p = mesh_.positions[v] + vn[v] * 1e-3f;
      int hits = 0;
      for (int i = 0; i < rays; ++i) {
        Rng rng(hashKey(0x0CC1, v, uint64_t(i)));
        float u1 = rng.uniform(), u2 = rng.uniform();
        float r = std::sqrt(u1), phi = 2 * kPiF * u2;  // cosine-weighted hemisphere
        Vec3f d = fr.toWorld({r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(0.0f, 1 - u1))});
        RTCRay ray;
        ray.org_x = p.x;
        ray.org_y = p.y;
        ray.org_z = p.z;
        ray.dir_x = d.x;
        ray.dir_y = d.y;
        ray.dir_z = d.z;
        ray.tnear = 0;
        ray.tfar = max_distance;
        ray.time = 0;
        ray.mask = ~0u;
        ray.id = 0;
        ray.flags = 0;
        rtcOccluded1(scene_, &ctx, &ray);
        hits += ray.tfar < 0;
      }
      occlusion_[v] = float(hits) / float(rays);
    }
  });
}

float PartGeometry::occlusionAt(unsigned prim, float b1, float b2) const {
  if (occlusion_.empty()) return 0.0f;
  const uint32_t* f = &mesh_.indices[3 * prim];
  return occlusion_[f[0]] * (1 - b1 - b2) + occlusion_[f[1]] * b1 + occlusion_[f[2]] * b2;
}

PartGeometry::~PartGeometry() {
  if (scene_) rtcReleaseScene(scene_);
}

}  // namespace dg
