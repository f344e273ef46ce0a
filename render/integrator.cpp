#include "render/integrator.h"

#include <atomic>
#include <cmath>
#include <limits>
#include <optional>

#include "core/parallel.h"
#include "core/rng.h"
#include "render/groove.h"
#include "render/groove_area.h"
#include "render/light_pattern.h"
#include "render/scratch_geometry.h"

namespace dg {

namespace {

// The share of a light guide's density that stays uniform along each axis (LightGuide): 0.1 and
// 0.5 gave the same error as 0.25 on the accuracy scenes under the ring light.
constexpr float kGuideFloor = 0.25f;
// A light is guided where it gives at least this share of a shading point's unshadowed light
// (Tracer::buildGuides), estimated from kGuideProbes points along it.
constexpr float kGuideShare = 0.05f;
constexpr int kGuideProbes = 4;
// ... and where what it gives varies across the light by more than this factor (over those points
// and two more across the light's other axis): a uniform sample of a smooth integrand does about
// as well. On car paint under the ring (its diffuse base coat sees the whole ring alike) guides
// for every light cost 10% more time for the same error. At 2, the bench's door at 1 spp (paint
// under the long bar, whose near and far ends lie at other distances and angles: its probes
// differ by 2 to 4 times at some hits) was still guided at 7% more time for the same error; at 4
// it is not, and the ring scenes' errors stay the same (their aluminium's lobe tail differs
// 25-fold across the ring); at 8 they rise by 6-17% (docs/grooves.md, "Cost per sample").
constexpr float kGuidePeak = 4.0f;
// Light samples are guided only while a pixel takes at most this many per light (16 per camera
// sample: at 1 spp). From 2 spp on the pixel's 32 or more lattice points per light resolve most
// of a ring light's glossy reflection themselves: on parallel/ring the mean dE went 0.137 ->
// 0.132 at 2 spp and 0.103 -> 0.101 at 4 for 20-30% more time, against 0.223 -> 0.171 at 1 spp.
// On car paint under the bar of configs/scratched_door.yaml (4 spp) they cost 40% of the time
// for no visible change.
constexpr int kGuideMaxPerPixel = 16;

// Square tiles of the image, one task each: 8 pixels wide below 256 x 256 pixels, 16 from there.
// Small images need small tiles: a 96 x 96 image (the accuracy scenes) had 9 tiles of 32, so one
// of two threads rendered five and the other four, and the costly groove pixels sit in a few
// tiles, which one thread may still be rendering while the other has nothing left. On 2 threads
// the wash swirls' groove render at 1 spp took 10% less time with tiles of 16 than of 32 and 4%
// less again with tiles of 8; the scratched door 19% and 22%. At 512 x 512 tiles of 8 were 1%
// slower than of 16. Every pixel's samples draw from their own random stream, so the tiling never
// changes the image.
inline int tileSize(int W, int H) { return int64_t(W) * H >= 256 * 256 ? 16 : 8; }
constexpr float kInf = std::numeric_limits<float>::infinity();

// A ray with its two auxiliary rays (Igehy 1999, "Tracing ray differentials"), stored as the
// offsets of their origins and directions from the main ray for a one-pixel step in x and y.
struct DiffRay {
  Vec3f o, d;
  Vec3f dodx, dody, dddx, dddy;
};

// A ray with no footprint (zero differentials): the rays a groove footprint sends on.
DiffRay bareRay(Vec3f o, Vec3f d) {
  DiffRay r;
  r.o = o;
  r.d = d;
  r.dodx = r.dody = r.dddx = r.dddy = Vec3f(0.0f);
  return r;
}

struct Hit {
  bool hit = false;
  float t = kInf;
  unsigned prim = 0;
  float b1 = 0, b2 = 0;  // barycentrics of vertices 1 and 2
  bool shell = false;    // on the solid's back or rim (PartGeometry::shell), not the part's mesh
};

Hit intersect(RTCScene scene, Vec3f o, Vec3f d, float tnear, float tfar) {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRayHit rh;
  rh.ray.org_x = o.x;
  rh.ray.org_y = o.y;
  rh.ray.org_z = o.z;
  rh.ray.dir_x = d.x;
  rh.ray.dir_y = d.y;
  rh.ray.dir_z = d.z;
  rh.ray.tnear = tnear;
  rh.ray.tfar = tfar;
  rh.ray.time = 0;
  rh.ray.mask = 0xFFFFFFFFu;
  rh.ray.id = 0;
  rh.ray.flags = 0;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(scene, &ctx, &rh);
  Hit h;
  if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
    h.hit = true;
    h.t = rh.ray.tfar;
    h.prim = rh.hit.primID;
    h.b1 = rh.hit.u;
    h.b2 = rh.hit.v;
    h.shell = rh.hit.geomID == PartGeometry::kShellGeometry;
  }
  return h;
}

bool occluded(RTCScene scene, Vec3f o, Vec3f d, float tnear, float tfar) {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRay r;
  r.org_x = o.x;
  r.org_y = o.y;
  r.org_z = o.z;
  r.dir_x = d.x;
  r.dir_y = d.y;
  r.dir_z = d.z;
  r.tnear = tnear;
  r.tfar = tfar;
  r.time = 0;
  r.mask = 0xFFFFFFFFu;
  r.id = 0;
  r.flags = 0;
  rtcOccluded1(scene, &ctx, &r);
  return r.tfar < 0;  // Embree sets tfar to -inf on occlusion
}

float powerHeuristic(float a, float b) {
  float a2 = a * a, b2 = b * b;
  return a2 + b2 > 0 ? a2 / (a2 + b2) : 0.0f;
}

Vec3f reflect(Vec3f d, Vec3f n) { return d - n * (2.0f * dot(d, n)); }

// Latin-hypercube strata for n samples in `dims` dimensions: each dimension is cut into n
// intervals, and sample j takes interval perm_d[j] of dimension d, for independent random
// permutations perm_d. On the stack up to 64 samples (the groove recursion re-enters its users).
class LatinStrata {
 public:
  LatinStrata(int n, int dims, Rng& rng) : n_(n), inv_(1.0f / float(n)), p_(local_) {
    if (n * dims > int(sizeof(local_) / sizeof(int))) {
      heap_.resize(size_t(n * dims));
      p_ = heap_.data();
    }
    for (int d = 0; d < dims; ++d) {
      int* q = p_ + d * n;
      for (int i = 0; i < n; ++i) q[i] = i;
      for (int i = n - 1; i > 0; --i) std::swap(q[i], q[int(rng.uniform() * float(i + 1)) % (i + 1)]);
    }
  }
  LatinStrata(const LatinStrata&) = delete;
  LatinStrata& operator=(const LatinStrata&) = delete;
  // Sample j's coordinate in dimension d: a uniform point of its interval, below 1.
  float at(int d, int j, Rng& rng) const {
    return std::min((float(p_[d * n_ + j]) + rng.uniform()) * inv_, kOneMinusEps);
  }

 private:
  int n_;
  float inv_;
  int local_[3 * 64];
  std::vector<int> heap_;
  int* p_;
};

// Index of the item whose weight interval holds u (0 <= u < the weights' sum); the last item when
// rounding leaves u past the sum.
template <class Item>
size_t pickByWeight(const std::vector<Item>& items, double u) {
  double acc = 0;
  for (size_t i = 0; i < items.size(); ++i) {
    acc += items[i].weight;
    if (u < acc) return i;
  }
  return items.size() - 1;
}

// Everything the integrator needs to know about a surface point.
struct SurfacePoint {
  Vec3f p, ng, ns;  // ng and ns face the incoming ray
  Vec2f uv;
  Vec3f dpdu, dpdv;
  bool uv_ok;
  float mm_per_uv;
  Vec3f dpdx, dpdy;
  Vec2f duvdx, duvdy;
  bool outside = true;  // the ray arrived from the side the surface's outward normal faces
  bool shell = false;   // the solid's back or rim: no UVs, no defects, no paint
};

// Offset for spawning rays off the surface, scaled with the magnitude of the coordinates.
float rayEpsilon(Vec3f p) { return 1e-4f * std::max(1.0f, maxComponent(Vec3f(std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)))); }

// Strata of a pixel for groove rendering: sx * sy = spp with sy the largest divisor <= sqrt(spp).
void grooveStrata(int spp, int& sx, int& sy) {
  sy = 1;
  for (int d = 1; d * d <= spp; ++d)
    if (spp % d == 0) sy = d;
  sx = spp / sy;
}

class Tracer {
 public:
  Tracer(const RenderScene& s, const RenderSettings& st)
      : s_(s), st_(st), mesh_(s.part->mesh()), has_defects_(s.defects && !s.defects->empty()) {
    grooveStrata(st.spp, strata_x_, strata_y_);
    if (has_defects_)
      for (auto& d : *s.defects) {
        needs_cavity_ |= d->needsCavity();
        has_weathering_ |= d->cls() == DefectClass::Rust || d->cls() == DefectClass::Patina;
        has_other_defects_ |= d->cls() != DefectClass::Scratch;
      }
    has_paint_ = s.paint != nullptr && s.material.kind == MaterialKind::CarPaint;
    if (has_defects_)
      for (auto& d : *s.defects)
        if (d->cls() == DefectClass::Scratch) {
          const auto* sc = static_cast<const Scratch*>(d.get());
          has_scratches_ = true;
          max_height_ = std::max(max_height_, float(sc->referenceProfile().peakHeight()) * sc->maxScale());
          max_depth_ = std::max(max_depth_, float(sc->referenceProfile().depth()) * sc->maxScale());
          max_half_ = std::max(max_half_, float(sc->referenceProfile().halfExtent()) * sc->maxScale());
          if (sc->maxScale() > 0)
            min_half_ = std::min(min_half_, float(sc->referenceProfile().halfExtent()) * sc->maxScale());
        }
    grooves_ = s.groove_shading && has_scratches_;
    env_by_bsdf_ = grooves_ && !st.groove_env_light_samples && s.lights.env && s.lights.env->isConstant();
    guided_ = grooves_ && st.guide_light_samples && st.groove_light_samples > 1 &&
              st.groove_light_samples * st.spp <= kGuideMaxPerPixel;
    for (int d = 1; d * d <= st.groove_light_samples; ++d)
      if (st.groove_light_samples % d == 0) sub_count_ = d;
    findBlockers();
  }

  SurfacePoint surface(const Hit& h, const DiffRay& r, bool need_footprint) const {
    SurfacePoint sp;
    if (h.shell) return shellSurface(h, r);
    const uint32_t* f = &mesh_.indices[3 * h.prim];
    float b0 = 1 - h.b1 - h.b2;
    sp.p = r.o + r.d * h.t;
    const PartGeometry::TriFrame& fr = s_.part->frame(h.prim);
    sp.ng = fr.ng;
    if (!mesh_.normals.empty())
      sp.ns = normalize(mesh_.normals[f[0]] * b0 + mesh_.normals[f[1]] * h.b1 + mesh_.normals[f[2]] * h.b2);
    else
      sp.ns = sp.ng;
    if (!mesh_.uvs.empty())
      sp.uv = mesh_.uvs[f[0]] * b0 + mesh_.uvs[f[1]] * h.b1 + mesh_.uvs[f[2]] * h.b2;
    sp.dpdu = fr.dpdu;
    sp.dpdv = fr.dpdv;
    sp.uv_ok = fr.uv_ok;
    sp.mm_per_uv = mesh_.mmPerUv.empty() ? 1.0f : mesh_.mmPerUv[h.prim];
    if (!(sp.mm_per_uv > 0)) sp.mm_per_uv = 1.0f;
    faceTheRay(sp, r.d);
    if (need_footprint) {
      // Transfer of the auxiliary rays to the tangent plane (Igehy 1999, eq. 10 and 11).
      auto transfer = [&](Vec3f dod, Vec3f ddd) {
        Vec3f o = r.o + dod, d = r.d + ddd;
        float den = dot(sp.ng, d);
        if (std::fabs(den) < 1e-12f) return Vec3f(0.0f);
        float t = dot(sp.ng, sp.p - o) / den;
        return o + d * t - sp.p;
      };
      sp.dpdx = transfer(r.dodx, r.dddx);
      sp.dpdy = transfer(r.dody, r.dddy);
      // UV footprint through the dual basis of (dpdu, dpdv) (shared/reference/blinn-bump.md §3b).
      Vec3f N = cross(sp.dpdu, sp.dpdv);
      float n2 = dot(N, N);
      if (n2 > 0) {
        Vec3f du = cross(sp.dpdv, N) / n2, dv = cross(N, sp.dpdu) / n2;
        sp.duvdx = {dot(sp.dpdx, du), dot(sp.dpdx, dv)};
        sp.duvdy = {dot(sp.dpdy, du), dot(sp.dpdy, dv)};
      }
    }
    return sp;
  }

  // Two-sided: the normals turn to face the side the ray d came from (`outside` records whether
  // they already did), and a shading normal on the other side gives way to the geometric one.
  static void faceTheRay(SurfacePoint& sp, Vec3f d) {
    if (dot(sp.ng, d) > 0) {
      sp.ng = -sp.ng;
      sp.ns = -sp.ns;
      sp.outside = false;
    }
    if (dot(sp.ns, sp.ng) <= 0) sp.ns = sp.ng;
  }

  // A hit on the solid's back or rim: smooth-shaded (back) or flat (rim), no chart.
  SurfacePoint shellSurface(const Hit& h, const DiffRay& r) const {
    SurfacePoint sp;
    const TriangleMesh& m = s_.part->shell();
    const uint32_t* f = &m.indices[3 * h.prim];
    float b0 = 1 - h.b1 - h.b2;
    sp.shell = true;
    sp.p = r.o + r.d * h.t;
    sp.ng = s_.part->shellNormal(h.prim);
    sp.ns = normalize(m.normals[f[0]] * b0 + m.normals[f[1]] * h.b1 + m.normals[f[2]] * h.b2);
    sp.uv = Vec2f(0.0f, 0.0f);
    sp.uv_ok = false;
    sp.mm_per_uv = 1.0f;
    Frame on = Frame::fromNormal(sp.ng);
    sp.dpdu = on.t;
    sp.dpdv = on.b;
    faceTheRay(sp, r.d);
    sp.dpdx = sp.dpdy = Vec3f(0.0f);
    sp.duvdx = sp.duvdy = Vec2f(0.0f, 0.0f);
    return sp;
  }

  // A sampled direction is usable when the shading and the geometric normal agree on its side:
  // above both (reflection) or, through glass, below both (transmission).
  static bool sameSide(Vec3f wi_local, Vec3f wi_w, Vec3f ng) {
    const float g = dot(wi_w, ng);
    return wi_local.z > 0 ? g > 0 : (wi_local.z < 0 && g < 0);
  }

  // A glass part's interface seen from the ray's side: the relative index of the far side over
  // the near one (Material::ior holds the glass's own index against air).
  static Material facing(const Material& m, bool outside) {
    if (m.kind != MaterialKind::Glass || outside) return m;
    Material g = m;
    g.ior = 1.0f / m.ior;
    return g;
  }

  // Applies the defects at a surface point: their height gradients perturb the shading normal
  // (Blinn 1978 in surface-gradient form: n' = normalize(n - grad_s F), shared/reference/
  // blinn-bump.md §3b and §8.3), and weathering may replace the surface's look (returned cover and
  // appearance).
  // `extra_grad` is a height gradient from the surface itself (the clear coat's orange peel).
  DefectShading applyDefects(SurfacePoint& sp, Vec3f wo_world, const Hit& h, Vec2f extra_grad = {0, 0},
                             bool point_grooves = false) const {
    DefectShading ds;
    if (!sp.uv_ok) return ds;
    ds.height_grad = extra_grad;
    if (has_defects_) {
      DefectQuery q;
      q.point_grooves = point_grooves;
      q.uv = point_grooves ? meetGrooves(sp, wo_world) : sp.uv;
      q.duv_dx = sp.duvdx;
      q.duv_dy = sp.duvdy;
      q.mm_per_uv = sp.mm_per_uv;
      if (needs_cavity_) q.cavity = s_.part->occlusionAt(h.prim, h.b1, h.b2);
      s_.defect_index.forEach(sp.uv, q.footprint(), [&](const Defect& d) { d.shade(q, ds); });
      ds.height_grad += ds.grooveGrad();
    }
    if (ds.height_grad.x == 0 && ds.height_grad.y == 0) return ds;
    Vec3f n = normalize(sp.ns - surfaceGradient(sp, ds.height_grad));
    // Keep the perturbed normal in the hemisphere of the viewer (digest §8.3, hemisphere safety).
    float c = dot(n, wo_world);
    if (c < 0.02f) n = normalize(n + wo_world * (0.02f - c));
    sp.ns = n;
    return ds;
  }

  // Where a ray past the camera hit, arriving along -wo_world at sp on the part's smooth surface,
  // meets the scratches' surface (scratchHeight, the explicit geometry's): the UV point its
  // point sample is taken at. The smooth surface's hit is off by the height there times the
  // ray's tangent of incidence: a ray leaving a glass part from inside at 25 degrees through a
  // groove 0.06 mm deep meets its wall up to 0.03 mm before the plane, a pixel and more at 1
  // degree (docs/grooves.md, "Where a ray from inside meets a scratch"). Marched in the tangent
  // plane from the side the ray comes from, between the highest pile-up and the deepest floor.
  Vec2f meetGrooves(const SurfacePoint& sp, Vec3f wo_world) const {
    const Vec3f n_out = sp.outside ? sp.ns : -sp.ns;
    const Vec3f d = -wo_world;
    const double dn = double(dot(d, n_out));  // height gained per mm along the ray
    const double range = double(max_height_) + double(max_depth_);
    if (!(std::fabs(dn) > 1e-3) || !(range > 0)) return sp.uv;
    Vec3f pu, pv;
    dualBasis(sp, pu, pv);
    const Vec2d du(double(dot(pu, d)), double(dot(pv, d)));  // UV per mm along the ray
    const bool from_below = dn > 0;
    const double s0 = (from_below ? -double(max_depth_) : double(max_height_)) / dn;  // (<= 0)
    const Vec2d a(double(sp.uv.x) + du.x * s0, double(sp.uv.y) + du.y * s0);
    const double len = range / std::fabs(dn);
    const double reach = len * std::sqrt(dot(du, du));  // (UV)
    thread_local std::vector<const Scratch*> near;
    near.clear();
    const Vec2f mid(float(a.x + du.x * 0.5 * len), float(a.y + du.y * 0.5 * len));
    // Only the scratches whose cross-section reaches the ray's span (most such hits are on the
    // plain part, where the plane is the surface).
    s_.defect_index.forEach(mid, float(0.5 * reach) + max_half_, [&](const Defect& df) {
      if (df.cls() != DefectClass::Scratch) return;
      const auto* sc = static_cast<const Scratch*>(&df);
      const float half = float(sc->referenceProfile().halfExtent()) * sc->maxScale();
      if (sc->path().closest(mid, float(0.5 * reach) + half).found) near.push_back(sc);
    });
    if (near.empty()) return sp.uv;
    const double step = std::max(double(min_half_) * double(sp.mm_per_uv) / 8, len / kMarchSteps);
    HeightMeet m;
    const double z0 = from_below ? -double(max_depth_) : double(max_height_);
    if (!meetScratchHeight(near, a, du, z0, dn, len, step, marchTol(), m, true, from_below)) return sp.uv;
    return Vec2f(float(a.x + du.x * m.at), float(a.y + du.y * m.at));
  }

  // The dual basis of (dpdu, dpdv) in the tangent plane: dot(pu, d) and dot(pv, d) are the UV
  // change along a tangent displacement d.
  static void dualBasis(const SurfacePoint& sp, Vec3f& pu, Vec3f& pv) {
    Vec3f N = cross(sp.dpdu, sp.dpdv);
    float n2 = dot(N, N);
    pu = cross(sp.dpdv, N) / n2, pv = cross(N, sp.dpdu) / n2;
  }
  // The world vector that a height gradient h (per UV, in mm) at sp takes off the shading normal:
  // n' = normalize(ns - surfaceGradient(sp, h)).
  static Vec3f surfaceGradient(const SurfacePoint& sp, Vec2f h) {
    Vec3f pu, pv;
    dualBasis(sp, pu, pv);
    return inShadingPlane(sp, pu * h.x + pv * h.y);
  }
  // A gradient of the dual basis (dualBasis) in the shading plane, turned over for a ray from behind.
  static Vec3f inShadingPlane(const SurfacePoint& sp, Vec3f grad) {
    // The height is measured along the outward normal. A ray from behind (the back of a sheet, the
    // inside of a glass part) sees the same surface turned over: with the normal flipped, the
    // height is negated too (digest §8.3), so a dent seen from behind reads as a bump.
    grad = grad - sp.ns * dot(grad, sp.ns);
    return sp.outside ? grad : -grad;
  }

  // A groove footprint's camera hit with the whole pixel's differentials. Groove shading traces it
  // through the centre of the pixel's stratum with the stratum's (render's loop: the footprint is
  // the stratum), while what filters by the footprint, the paint's flakes and orange peel and the
  // other defects, takes the whole pixel's, as the plate's samples and the explicit geometry's do:
  // with the stratum's, the flakes sparkled resolved in every footprint near a scratch where the
  // pixel's footprint fades them out (docs/grooves.md, "Sparkling flakes beside a scratch").
  SurfacePoint wholePixel(const SurfacePoint& sp) const {
    SurfacePoint q = sp;
    q.dpdx = sp.dpdx * float(strata_x_), q.dpdy = sp.dpdy * float(strata_y_);
    q.duvdx = sp.duvdx * float(strata_x_), q.duvdy = sp.duvdy * float(strata_y_);
    return q;
  }
  static float footprintOf(const SurfacePoint& sp) {
    return std::max(std::max(std::fabs(sp.duvdx.x), std::fabs(sp.duvdx.y)),
                    std::max(std::fabs(sp.duvdy.x), std::fabs(sp.duvdy.y)));
  }

  // Car paint's variation at this point (Nilsson 2008 §4.3): base colour scaled, passive flakes
  // tint the flake lobe, and where a resolved flake is picked (probability = its sparkle weight)
  // the flake lobe becomes a near-mirror around that flake's normal; elsewhere the smooth flake
  // lobe keeps the rest of the flake energy, so the mean matches flake_amount.
  // With `resolve` false the flakes stay unresolved, the smooth flake lobe carrying all their
  // energy: the mean over where the flakes lie, which a groove footprint's bounced directions
  // meet (GrooveSet::beyond).
  static void applyPaint(Material& m, const PaintSample& ps, bool resolve = true) {
    m.base_color *= ps.base_color_scale;
    m.flake_tint_scale = ps.flake_specular_scale;
    if (!resolve) return;
    if (ps.use_flake_lobe) {
      m.flake_amount = 1.0f;
      m.flake_roughness = 0.1f;
      m.flake_normal = ps.flake_normal_local;
    } else {
      m.flake_amount = PaintVariation::residualFlakeAmount(m.flake_amount, ps);
    }
  }

  // The material at a shading point: the part's, or with probability `cover` the weathering's
  // Oren-Nayar surface (an unbiased stochastic mix of the two BSDFs).
  static Material weathered(const Material& base, const DefectShading& ds, float u) {
    if (!(ds.cover > 0) || u >= ds.cover) return base;
    Material m;
    m.kind = MaterialKind::RoughDiffuse;
    m.base_color = ds.appearance.albedo;
    m.sigma = ds.appearance.sigma_rad;
    return m;
  }

  // The point u of an area light's sample domain (lightPoint; an annulus's second coordinate is
  // its angle, periodic) as seen from `origin`: the unit direction, the distance and the
  // solid-angle pdf. False when the point is behind the light (one-sided emitters) or coincides
  // with the origin.
  static bool sampleAreaLight(const AreaLight& al, Vec2f u, Vec3f origin, Vec3f& wl, float& dist, float& pl) {
    Vec3f q = al.samplePoint(u);
    wl = q - origin;
    dist = length(wl);
    if (!(dist > 0)) return false;
    wl = wl / dist;
    if (-dot(wl, al.normal) <= 0) return false;
    pl = al.pdfSolidAngle(origin, q);
    return true;
  }

  // One LightGuide per area light (the first kMaxGuided; the others are sampled uniformly).
  static constexpr int kMaxGuided = 8;
  struct LightGuides {
    LightGuide g[kMaxGuided];
    LightGuide none;
    const LightGuide& at(int li) const { return li < kMaxGuided ? g[li] : none; }
    // The solid-angle pdf of light li's guided samples at `origin` toward the point q on it.
    float pdf(const AreaLight& al, int li, Vec3f origin, Vec3f q) const {
      const float pl = al.pdfSolidAngle(origin, q);
      const LightGuide& lg = at(li);
      return lg.on ? pl * lg.relDensity(al.domainPoint(q)) : pl;
    }
  };

  // Guides for the light samples of a shading point at `origin` (geometric normal ng, BSDF `bsdf`
  // in frame fr): each area light's bins weighted by what a uniform light sample at the bin's
  // centre would carry (guideWeight), along the major axis at the middle of the minor one, then
  // along the minor at the brightest major bin; a quarter of each axis's density stays uniform
  // (kGuideFloor). Shadows are not looked at: the light samples test them. A light is guided only
  // where it matters: a first pass of 4 points along its major axis (and 2 across it) estimates
  // what the point gets from it unshadowed, and a light that gives less than kGuideShare of what
  // all of them and the environment (its radiance toward the normal) give, or whose points differ
  // by less than kGuidePeak, is left uniform. Under a dark-field bar the plate sees the bar only
  // far in its lobe's tail, and the 48 evaluations of the BSDF would buy nothing there.
  // Returns whether any light is guided.
  bool buildGuides(Vec3f origin, Vec3f ng, const Frame& fr, const BsdfAt& bsdf, LightGuides& guides) const {
    const int nal = std::min(int(s_.lights.area.size()), kMaxGuided);
    float given[kMaxGuided];
    float total = s_.lights.env ? luminance(s_.lights.env->eval(ng)) : 0.0f;
    bool peaked[kMaxGuided];
    for (int li = 0; li < nal; ++li) {
      const AreaLight& al = s_.lights.area[size_t(li)];
      LightGuide& lg = guides.g[li];
      lg.major = al.majorAxis();
      lg.on = false;
      float sum = 0, hi = 0, lo = kInf, best_a = 0.5f;
      for (int j = 0; j < kGuideProbes; ++j) {
        const float a = (float(j) + 0.5f) / kGuideProbes;
        const float w = guideWeight(al, lg.major, a, 0.5f, origin, ng, fr, bsdf);
        sum += w;
        if (w > hi) hi = w, best_a = a;
        lo = std::min(lo, w);
      }
      for (float b : {0.125f, 0.875f}) {
        const float w = guideWeight(al, lg.major, best_a, b, origin, ng, fr, bsdf);
        hi = std::max(hi, w);
        lo = std::min(lo, w);
      }
      given[li] = sum / kGuideProbes * luminance(al.radiance);
      peaked[li] = hi > kGuidePeak * lo;
      total += given[li];
    }
    bool any = false;
    for (int li = 0; li < nal; ++li) {
      if (!peaked[li] || !(given[li] > kGuideShare * total)) continue;
      const AreaLight& al = s_.lights.area[size_t(li)];
      LightGuide& lg = guides.g[li];
      float wa[LightGuide::kMajor], wb[LightGuide::kMinor];
      int best = 0;
      for (int j = 0; j < LightGuide::kMajor; ++j) {
        wa[j] = guideWeight(al, lg.major, (float(j) + 0.5f) / LightGuide::kMajor, 0.5f, origin, ng, fr, bsdf);
        if (wa[j] > wa[best]) best = j;
      }
      for (int i = 0; i < LightGuide::kMinor; ++i)
        wb[i] = guideWeight(al, lg.major, (float(best) + 0.5f) / LightGuide::kMajor,
                            (float(i) + 0.5f) / LightGuide::kMinor, origin, ng, fr, bsdf);
      lg.build(wa, wb, kGuideFloor);
      any = any || lg.on;
    }
    return any;
  }
  // What a uniform light sample at domain point (a along the major axis, b along the other) of
  // light al would carry to the shading point, unshadowed and per unit radiance: f cos(theta_i) /
  // pdf (sampleAreaLight), the largest channel; 0 behind the light or below the surface.
  static float guideWeight(const AreaLight& al, int major, float a, float b, Vec3f origin, Vec3f ng, const Frame& fr,
                           const BsdfAt& bsdf) {
    Vec3f wl;
    float dist, pl;
    if (!sampleAreaLight(al, major == 0 ? Vec2f(a, b) : Vec2f(b, a), origin, wl, dist, pl) || !(pl > 0) ||
        dot(wl, ng) <= 0)
      return 0.0f;
    const Vec3f wi = fr.toLocal(wl);
    if (wi.z <= 0) return 0.0f;
    return maxComponent(bsdf.eval(wi)) * wi.z / pl;
  }

  // Sample k of the nl a camera hit takes on light li (area lights, then the environment), in the
  // light's sample domain: from the pixel's pattern where it has one for this count (a single
  // sample per light, or groove shading's nl per camera sample), else from the hit's own `pat`.
  static Vec2f lightPoint(const PixelPattern* pads, int s, int li, const LightPattern& pat, int k, bool periodic) {
    if (pads && pat.size() == 1) return pads->at(li, s, periodic);
    if (pads && pads->hasLights(pat.size())) return pads->light(pat.size(), li, k, s, periodic);
    return pat.at(k, periodic);
  }

  // The nl light samples per light that a point at `origin` takes, area lights first, then the
  // environment (lightPoint; `pads` and s as there, null away from a camera hit). For each one
  // visit(k, wl, dist, pdf, Le, env) gets the sample's index, unit direction, distance (area
  // lights), solid-angle pdf and radiance, and whether it is the environment's. Points behind an
  // area light are skipped. Without `with_env` the environment takes none (env_by_bsdf_).
  template <class Visit>
  void forEachLightSample(int nl, Vec3f origin, const PixelPattern* pads, int s, Rng& rng, Visit&& visit,
                          bool with_env = true, const LightGuides* guides = nullptr) const {
    const int nal = int(s_.lights.area.size());
    for (int li = 0; li < nal; ++li) {
      const AreaLight& al = s_.lights.area[size_t(li)];
      const LightPattern pat(nl, latticeGenerator(nl), rng);
      for (int k = 0; k < nl; ++k) {
        Vec3f wl;
        float dist, pl, rel = 1.0f;
        Vec2f u = lightPoint(pads, s, li, pat, k, al.shape == AreaLight::Shape::Disk);
        if (guides) u = guides->at(li).warp(u, rel);
        if (sampleAreaLight(al, u, origin, wl, dist, pl) && !behindAnotherLight(origin, wl, dist * (1 - 1e-4f), li))
          visit(k, wl, dist, pl * rel, al.radiance, false);
      }
    }
    if (s_.lights.env && with_env) {
      const LightPattern pat(nl, latticeGenerator(nl), rng);
      for (int k = 0; k < nl; ++k) {
        Rgb Le;
        float pe;
        Vec3f wl = s_.lights.env->sample(lightPoint(pads, s, nal, pat, k, false), Le, pe);
        if (!behindAnotherLight(origin, wl, kInf, -1)) visit(k, wl, kInf, pe, Le, true);
      }
    }
  }

  // The nearest area light that `ray` meets before the distance `t` (its index, its distance into
  // `t`), or -1. Emitters are not in the BVH; they are tested analytically against the part's hit
  // distance. The camera (`camera`) does not see those in its lens plane (visible_to_camera).
  int nearestEmitter(const DiffRay& ray, bool camera, float& t) const {
    int nearest = -1;
    for (size_t i = 0; i < s_.lights.area.size(); ++i) {
      const AreaLight& al = s_.lights.area[i];
      if (camera && !al.visible_to_camera) continue;
      float ti;
      if (al.intersect(ray.o, ray.d, 0.0f, t, ti)) {
        t = ti;
        nearest = int(i);
      }
    }
    return nearest;
  }

  // Whether an area light other than `self` faces `origin` across the way to a light sample at
  // distance `dist` along wl. A path's ray meets the nearest emitter's front and stops there
  // (continuePath, emitterToward), so the emitter hides what lies behind it from its BSDF
  // directions; its light samples must not see through it either. They did: under a ring light
  // and a dome, a plate's dome samples behind the ring counted with their MIS weight alone, so the
  // result depended on the sample counts (0.1% darker with one light sample and one direction
  // than with groove shading's 16 and 8). `self` is the area light's index, -1 for the
  // environment; only the emitters of findBlockers() are tested.
  bool behindAnotherLight(Vec3f origin, Vec3f wl, float dist, int self) const {
    for (int j : blockers_[size_t(self + 1)]) {
      float t;
      if (s_.lights.area[size_t(j)].intersect(origin, wl, 0.0f, dist, t)) return true;
    }
    return false;
  }
  // Which emitters can hide a light sample of each light (blockers_[i + 1] for area light i,
  // blockers_[0] for the environment). Emitter j stops a ray only where the ray crosses its
  // plane against its normal, so it can hide a point of light i only if that point lies behind
  // its plane: a light whose every point (the corners of its rectangle or of the square around
  // its disk) is in front of j's plane or on it (as strip lights side by side are) is never
  // hidden by j; a sample is tested only up to just short of its own distance. The environment
  // can be hidden by any of them. On configs/quickstart.yaml (six coplanar strips and a dome)
  // testing every emitter for every sample cost 8% of the render time, these lists about 2%.
  void findBlockers() {
    const auto& area = s_.lights.area;
    blockers_.assign(area.size() + 1, {});
    for (size_t j = 0; j < area.size(); ++j) blockers_[0].push_back(int(j));
    for (size_t i = 0; i < area.size(); ++i) {
      const AreaLight& li = area[i];
      const float hu = li.shape == AreaLight::Shape::Rect ? li.half_u : li.radius;
      const float hv = li.shape == AreaLight::Shape::Rect ? li.half_v : li.radius;
      for (size_t j = 0; j < area.size(); ++j) {
        if (j == i) continue;
        const AreaLight& lj = area[j];
        // Behind j's plane by more than its rounding (1e-5 of the distances involved).
        const float margin = 1e-5f * (length(li.center - lj.center) + hu + hv);
        bool behind = false;
        for (float a : {-hu, hu})
          for (float b : {-hv, hv})
            if (dot(li.center + li.axis_u * a + li.axis_v * b - lj.center, lj.normal) < -margin) behind = true;
        if (behind) blockers_[i + 1].push_back(int(j));
      }
    }
  }

  // Camera sample s of a pixel; `pads` (optional) spreads the first bounce's light samples and
  // BSDF direction over the pixel's samples (PixelPattern: dimension i < lights for area light i,
  // then the environment, then the BSDF; the last one is the position in the pixel, render()).
  // `plate` (groove shading): `ray` goes through the centre of the sample's stratum, whose
  // footprint the groove renderer integrates; where that footprint holds no groove, the sample is
  // traced along `plate` instead, a ray through a point drawn uniformly in the stratum.
  Rgb trace(DiffRay ray, Rng& rng, uint64_t& nrays, const PixelPattern* pads = nullptr, int s = 0,
            const DiffRay* plate = nullptr) const {
    // Camera rays count as "specular": no MIS on directly seen lights.
    return continuePath(ray, Rgb(1.0f), 0.0f, true, Vec3f(0.0f), 0, rng, nrays, 1, 1, 1.0f, pads, s, plate);
  }
  int padDimensions() const { return int(s_.lights.area.size()) + 3; }
  // BSDF directions a camera hit off the grooves splits into when groove shading is on: at most
  // camera_hit_bsdf_samples (and 64), and no more than camera_hit_bsdf_per_pixel / spp (on a
  // car-paint part camera_hit_bsdf_per_pixel_paint / spp). On glass at most 8: there each
  // direction is a path through the part, and 32 at 1 spp cost the lens scenes 35-40% more time
  // for the same error (mean dE 0.33, 0.31, 0.19 with either).
  int cameraHitSplit(bool glass = false) const {
    const bool paint = s_.material.kind == MaterialKind::CarPaint;
    const int per_pixel = paint ? st_.camera_hit_bsdf_per_pixel_paint : st_.camera_hit_bsdf_per_pixel;
    return std::clamp(per_pixel / std::max(1, st_.spp), 1,
                      std::min(glass ? 8 : 64, st_.camera_hit_bsdf_samples));
  }
  // Light samples per light at a camera hit off the grooves when groove shading is on: at most
  // groove_light_samples, and no more than camera_hit_light_per_pixel / spp.
  int cameraHitLights() const {
    return std::clamp(st_.camera_hit_light_per_pixel / std::max(1, st_.spp), 1, std::max(1, st_.groove_light_samples));
  }

  // The path from `ray` on, with throughput beta and the previous vertex's BSDF pdf (for MIS on
  // emitters the ray hits). `depth0` is the number of surface bounces before this ray.
  // `prev_nl` is the number of light samples the previous vertex took per light (MIS counts; the
  // expected number where they were a random subset), `prev_nl_env` the number it took of the
  // environment (0 where env_by_bsdf_ left the environment to the BSDF directions). `prev_share`
  // scales the MIS weight of an emitter hit by this first ray: the share of its strategy's
  // directions that this set of rays is (a groove footprint's continued BSDF directions share the
  // strategy with its direct-only lobe directions, shadeLevel).
  Rgb continuePath(DiffRay ray, Rgb beta, float prev_pdf, bool prev_specular, Vec3f prev_p, int depth0, Rng& rng,
                   uint64_t& nrays, float prev_nl, float prev_nl_env, float prev_share = 1.0f,
                   const PixelPattern* pads = nullptr, int pad_s = 0, const DiffRay* plate = nullptr,
                   const LightGuides* prev_guides = nullptr) const {
    Rgb L(0.0f);
    RTCScene scene = s_.part->scene();
    // Russian roulette looks at the throughput relative to the one this path started with (so a
    // path split into n does not lose its 1/n share to the roulette, which would undo the split)
    // and without the radiance scaling of refraction (eta_scale undoes the 1/eta^2 on entering
    // glass and the eta^2 on leaving it): else a path inside glass would be killed often and its
    // survivors, leaving the glass, would come out as fireflies.
    const float rr_ref = maxComponent(beta);
    float eta_scale = 1.0f;
    // The camera hit's grooves (depth 0 with groove shading on); `grooved`: whether they were
    // already gathered (1), found absent (0) or not looked for yet (-1).
    thread_local std::vector<GrooveSet> sets;
    int grooved = -1;
    for (int depth = depth0;; ++depth) {
      Hit h = intersect(scene, ray.o, ray.d, 0.0f, kInf);
      ++nrays;
      if (plate) {
        // Groove shading integrates a groove footprint over the stratum around the ray; away from
        // the grooves the stratum is point-sampled, at a random point in it: at its centre, every
        // pixel would sample a detail finer than a stratum (a highlight's mirror image of a light
        // on a curved panel) at the same place, and such a line would break into regular dashes.
        grooved = footprintHasGrooves(ray, h, sets) ? 1 : 0;
        if (!grooved) {
          ray = *plate;
          h = intersect(scene, ray.o, ray.d, 0.0f, kInf);
          ++nrays;
        }
        plate = nullptr;
      }
      float tl = h.t;
      const int light_hit = nearestEmitter(ray, depth == 0, tl);
      if (light_hit >= 0) {
        const AreaLight& al = s_.lights.area[light_hit];
        float w = 1.0f;
        if (!prev_specular) {
          const Vec3f q = ray.o + ray.d * tl;
          const float pl = prev_guides ? prev_guides->pdf(al, light_hit, prev_p, q) : al.pdfSolidAngle(prev_p, q);
          w = prev_share * powerHeuristic(prev_pdf, prev_nl * pl);
        }
        L += beta * al.radiance * w;
        break;
      }
      if (!h.hit) {
        if (s_.lights.env) {
          float w =
              prev_specular ? 1.0f : prev_share * powerHeuristic(prev_pdf, prev_nl_env * s_.lights.env->pdf(ray.d));
          L += beta * s_.lights.env->eval(ray.d) * w;
        }
        break;
      }
      prev_share = 1.0f;
      prev_guides = nullptr;
      if (depth >= st_.max_bounces) break;
      SurfacePoint sp = surface(h, ray, has_defects_ || has_paint_);
      Vec3f wo_w = -ray.d;
      Material m = facing(s_.material, sp.outside);
      // Seen by the camera, glass draws reflection at least a quarter of the time
      // (Material::reflect_share). At the next vertex on glass (mostly the lens's back face, from
      // inside) the path splits in two, one reflection and one refraction: both the image through
      // the lens and the ghost of a light off its back face then converge without the Fresnel
      // choice's noise (docs/grooves.md, "Glass"). Deeper, the Fresnel choice.
      if (depth == 0 && m.kind == MaterialKind::Glass) m.reflect_share = 0.25f;
      const bool glass_split = depth == 1 && m.kind == MaterialKind::Glass;
      if (glass_split) m.reflect_share = 0.5f;
      Vec2f peel(0.0f, 0.0f);
      bool flake_lobe = false;  // a resolved flake's lobe, its normal given in the frame (ns, dpdu)
      bool resolved = false;    // the paint's flakes are resolved here (drawn or not)
      Material m_beyond;        // the paint with its flakes unresolved (GrooveSet::beyond)
      // A groove footprint's camera hit came through its stratum's centre with the stratum's
      // differentials; what filters by the footprint looks at the whole pixel's (wholePixel).
      const bool stratum = depth == 0 && grooved == 1;
      float paint_fp = 0.0f;  // the footprint the paint is filtered over (set where it is evaluated)
      if (has_paint_ && sp.uv_ok) {
        paint_fp = footprintOf(stratum ? wholePixel(sp) : sp);
        PaintSample ps = s_.paint->evaluate(sp.uv, paint_fp, rng.uniform());
        peel = ps.coat_height_grad;
        flake_lobe = ps.use_flake_lobe;
        resolved = ps.sparkle_fade > 0 && ps.flake_coverage > 0;
        if (resolved && depth == 0 && grooves_) {
          m_beyond = m;
          applyPaint(m_beyond, ps, false);
        }
        applyPaint(m, ps);
      }
      // Camera hits on scratches: the groove renderer integrates the whole footprint.
      if (depth == 0 && grooves_ && sp.uv_ok && grooved != 0) {
        if (grooved == 1 || gatherGrooves(sp, h, wo_w, sets)) {
          setUvMap(sp, sets);
          if (has_paint_ && s_.paint->hasPeel()) setPeel(sp, paint_fp, sets);
          if (flake_lobe)
            for (GrooveSet& gs : sets) gs.frame_t = sp.dpdu;
          for (GrooveSet& gs : sets) gs.beyond = resolved ? &m_beyond : nullptr;
          // (A scratch has no slope or cover here: its footprints are the grooves themselves.)
          if (has_other_defects_) {
            SurfacePoint spw = stratum ? wholePixel(sp) : sp;
            DefectShading dw = applyDefects(spw, wo_w, h);
            // The other defects' slopes (a dent's bump) tilt every facet, as they tilt every hit of
            // the explicit geometry (GrooveSet::bump).
            if (dw.height_grad.x != 0 || dw.height_grad.y != 0) {
              const Vec3f g = surfaceGradient(sp, dw.height_grad);
              for (GrooveSet& gs : sets) gs.bump = g;
            }
            // Weathering over the groove (rust that grew from a bared scratch) covers its facets
            // too: with probability `cover` every facet takes the weathered surface.
            if (has_weathering_ && dw.cover > 0 && rng.uniform() < dw.cover) {
              m = weathered(m, dw, 0.0f);
              for (GrooveSet& gs : sets) gs.one_material = true, gs.beyond = nullptr;
            }
          }
          L += beta * shadeGrooves(sets, m, wo_w, rng, nrays, pads, pad_s);
          break;
        }
      }
      // The scratch reference's cut mesh: a hit inside a scratch (moved off the part's surface)
      // shows the coating layer at its depth, and the cut has no orange peel, as the groove
      // renderer's facets (facetMaterial; they are shaded before the peel is applied).
      if (const float z = h.shell ? 0.0f : cutHeight(h); z != 0.0f) {
        peel = Vec2f(0.0f, 0.0f);
        m = layerAt(z, m);
      }
      // Past the camera hit the groove renderer's scratches are point-sampled (DefectQuery).
      DefectShading ds = applyDefects(sp, wo_w, h, peel, depth > 0 && grooves_);
      Frame fr = Frame::fromNormalTangent(sp.ns, sp.dpdu);
      Vec3f wo = fr.toLocal(wo_w);
      if (wo.z <= 0) break;
      if (ds.cover > 0) m = weathered(m, ds, rng.uniform());
      float eps = rayEpsilon(sp.p);
      Vec3f origin = sp.p + sp.ng * eps;

      // Next-event estimation: nl samples on every light (1, or with groove shading on, up to the
      // groove's count at camera hits so that flat and grooved pixels converge alike at low spp;
      // cameraHitLights), MIS against the BSDF's sampling.
      const int nl = (depth == 0 && grooves_) ? cameraHitLights() : 1;
      // With groove shading on, camera hits also split into ns BSDF directions (below): glossy
      // surfaces lit by a wide light (a dome) are found mostly by BSDF sampling. A glass vertex
      // past the camera hit splits in two (above).
      const int ns = glass_split                 ? 2
                     : (depth == 0 && grooves_) ? cameraHitSplit(m.kind == MaterialKind::Glass)
                                                : 1;
      // A constant environment is left to those directions where they are at least as many as
      // the light samples and more than one (env_by_bsdf_): at 1 and 2 spp. From 4 spp on a
      // camera sample splits into fewer (the pixel's samples share 32), and from 128 spp it takes
      // one direction and one light sample, as the path tracer does: there the dome's light
      // samples are what brings the plate's noise down with spp, as they did before the camera
      // hits' light samples fell with spp (cameraHitLights). (Measured on car paint under a dome
      // alone with one of each per camera sample at 64 spp, before the lobe choice took strata
      // over the pixel: 1.14% of relative pixel noise with the dome left to the directions, 0.88%
      // with its light samples, as the path tracer's 0.89%; car paint now takes the rule below.)
      // On car paint the directions alone do better at every count: its clear coat's sharp lobe
      // and its base's cosine lobe are what BSDF sampling draws, while the dome's light samples
      // fall mostly where neither is. Measured (relative pixel noise on the plate, 2 threads):
      // configs/scratched_door.yaml at 4 spp 3.24% in 3.64 s with the dome's light samples, 3.13%
      // in 2.85 s without; a light grey paint under a dome alone 1.30% -> 1.07% at 4 spp and 0.93%
      // -> 0.70% at 64 in less time (at 16 spp 0.94% in 0.063 s -> 1.05% in 0.035 s); under the
      // ring light the same noise in 24-28% less time; the accuracy test's `layers` scenes the
      // same error to 0.0005. On aluminium it depends on the scene (under the ring light at
      // roughness 0.15 the light samples halve the noise at 16 spp, at 0.05 they quadruple it),
      // so other materials keep the rule by counts.
      const bool env_samples =
          !(depth == 0 && grooves_ && env_by_bsdf_ && ((ns >= nl && nl > 1) || m.kind == MaterialKind::CarPaint));
      const float nl_env = env_samples ? float(nl) : 0.0f;  // the MIS count of the environment's samples
      const BsdfAt bsdf(m, wo);
      // Groove shading's camera hits guide their nl light samples (buildGuides).
      const LightGuides* gp = nullptr;
      if (depth == 0 && guided_) {
        // One per thread: only camera hits (depth 0) build them, and the paths they start read
        // them only at their first vertex.
        thread_local LightGuides cam_guides;
        if (buildGuides(origin, sp.ng, fr, bsdf, cam_guides)) gp = &cam_guides;
      }
      // The camera hit's light samples and BSDF direction come from the pixel's pattern.
      forEachLightSample(nl, origin, depth == 0 ? pads : nullptr, pad_s, rng,
                         [&](int, Vec3f wl, float dist, float pl, const Rgb& Le, bool env) {
                           if (!(pl > 0) || dot(wl, sp.ng) <= 0) return;
                           Vec3f wi = fr.toLocal(wl);
                           if (wi.z <= 0 || (env && maxComponent(Le) <= 0)) return;
                           float pdf;
                           Rgb f = bsdf.evalPdf(wi, pdf);
                           if (maxComponent(f) <= 0) return;
                           ++nrays;
                           if (occluded(scene, origin, wl, 0.0f, env ? kInf : dist * (1 - 1e-4f))) return;
                           float w = powerHeuristic(nl * pl, ns * pdf);
                           L += beta * f * Le * (wi.z * w / (nl * pl));
                         }, env_samples, gp);

      // Auxiliary rays follow the mirror transfer about the shading normal (the surface's
      // curvature is neglected); after a rough bounce this underestimates the footprint. Through
      // glass (a direction below the surface) they keep their directions: the refraction's own
      // spread of the footprint is neglected too.
      auto nextRay = [&](Vec3f d) {
        DiffRay nr;
        nr.d = d;
        nr.dodx = sp.dpdx;
        nr.dody = sp.dpdy;
        if (dot(d, sp.ng) < 0) {
          nr.o = sp.p - sp.ng * eps;
          nr.dddx = ray.dddx;
          nr.dddy = ray.dddy;
          return nr;
        }
        nr.o = origin;
        Vec3f rx = reflect(ray.d + ray.dddx, sp.ns), ry = reflect(ray.d + ray.dddy, sp.ns);
        Vec3f r0 = reflect(ray.d, sp.ns);
        nr.dddx = rx - r0;
        nr.dddy = ry - r0;
        return nr;
      };
      if (ns > 1) {
        // Split: ns BSDF directions, each continued as its own path carrying 1/ns of the
        // throughput. At a camera hit (groove shading on) the 2-D direction samples are a
        // lattice, spread over the pixel's samples where it has a pattern for them
        // (PixelPattern::direction), and the lobe choice takes Latin strata over the same
        // directions of the pixel, in an order of their own so that it does not move in step with
        // the lattice's first coordinate (PixelPattern::lobe; on car paint, where it picks the
        // clear coat or the base, the plate's relative pixel noise on configs/scratch_rust.yaml
        // at 320 x 240 and 16 spp fell from 1.36% to 0.82% against Latin strata over each camera
        // sample's own 2 directions; at 1 spp, without a pattern, and on glass it stays so).
        // Past it (glass) the lobe choice takes stratum j and the directions a Latin hypercube.
        // (The same lattices for the first-level directions of groove footprints, in place of
        // their Latin hypercube, were worse on the bar-lit scenes: mean dE 0.74 against 0.69 at
        // 1 spp, 0.52 against 0.49 at 2, on parallel/bar.)
        const int n = ns;  // at most 64 (cameraHitSplit)
        const bool lattice = depth == 0 && !glass_split;
        LatinStrata lhs(n, lattice ? 1 : 2, rng);
        std::optional<LightPattern> dirs;
        if (lattice && !(pads && pads->directionCount() == n)) dirs.emplace(n, latticeGenerator(n), rng);
        const float inv = 1.0f / float(n);
        for (int j = 0; j < n; ++j) {
          BsdfSample bs;
          float ul;
          Vec2f ud;
          if (lattice) {
            ul = dirs || !st_.pixel_lobe_strata ? lhs.at(0, j, rng) : pads->lobe(j, pad_s, rng.uniform());
            ud = dirs ? dirs->at(j, false) : pads->direction(j, pad_s);
          } else {
            ul = std::min((float(j) + rng.uniform()) * inv, kOneMinusEps);
            const float ux = lhs.at(0, j, rng);
            ud = Vec2f{ux, lhs.at(1, j, rng)};
          }
          if (!bsdf.sample(ul, ud, bs) || !(bs.pdf > 0)) continue;
          Vec3f wi_w = fr.toWorld(bs.wi);
          if (!sameSide(bs.wi, wi_w, sp.ng)) continue;
          Rgb b = beta * bs.f * (std::fabs(bs.wi.z) / (bs.pdf * float(n)));
          if (!isFinite(b) || maxComponent(b) <= 0) continue;
          // Light samples never go through the surface, so a transmitted direction meets its
          // emitter with MIS weight 1 (as a specular one).
          L += continuePath(nextRay(wi_w), b, float(n) * bs.pdf, bs.wi.z < 0, origin, depth + 1, rng, nrays, float(nl),
                            nl_env, 1.0f, nullptr, 0, nullptr, gp);
        }
        break;
      }

      // Continue the path by sampling the BSDF. A camera hit with the pixel's pattern takes its
      // direction from it, and its lobe choice from Latin strata over the pixel's samples
      // (PixelPattern::lobeAt): groove shading at 64 spp on configs/scratch_rust.yaml, 320 x 240,
      // 0.79% -> 0.65% relative pixel noise on the plate; the path tracer 0.73% -> 0.71%.
      BsdfSample bs;
      float ul = rng.uniform();
      Vec2f ud{rng.uniform(), rng.uniform()};
      if (depth == 0 && pads) {
        if (st_.pixel_lobe_strata) ul = pads->lobeAt(pad_s, ul);
        ud = pads->at(int(s_.lights.area.size()) + 1, pad_s, false);
      }
      if (!sampleBsdf(m, wo, ul, ud, bs) || !(bs.pdf > 0)) break;
      Vec3f wi_w = fr.toWorld(bs.wi);
      if (!sameSide(bs.wi, wi_w, sp.ng)) break;
      beta *= bs.f * (std::fabs(bs.wi.z) / bs.pdf);
      if (!isFinite(beta) || maxComponent(beta) <= 0) break;
      prev_pdf = bs.pdf;
      prev_specular = bs.wi.z < 0;  // transmitted: no light sample covers it (see above)
      if (bs.wi.z < 0) eta_scale *= m.ior * m.ior;
      prev_nl = float(nl);
      prev_nl_env = nl_env;
      prev_guides = gp;
      prev_p = origin;
      ray = nextRay(wi_w);
      // Russian roulette after three bounces; the survival test uses the path's own random stream.
      if (depth >= 3 && rr_ref > 0) {
        float q = std::max(0.05f, 1.0f - maxComponent(beta) * eta_scale / rr_ref);
        if (rng.uniform() < q) break;
        beta = beta / (1.0f - q);
      }
    }
    return L;
  }

  // ---------------------------------------------------------------------------------------------
  // The groove renderer (Bosch 2007 §4.2-4.3; shared/reference/bosch-grooves.md §2.2-2.3)
  // ---------------------------------------------------------------------------------------------

  // The grooves under one camera hit, in the hit's cross-section frame: T along the (first)
  // groove, B across it, W the surface normal; the merged section and the footprint along B.
  struct GrooveSet {
    Vec3f T, B, W;
    Vec3f F;  // the footprint centre (the hit on the base surface)
    groove::Section section;
    groove::Footprint fp;
    // Ends and crossings (Bosch §4.2.4) are not integrated by polygon clipping here; the
    // documented fallback: a groove whose end lies in the footprint is blended by the share of
    // the footprint along T that it covers (`end_share`, rendered with and without it), and
    // crossing grooves are grouped by direction, each group rendered as its own section in its
    // own frame and weighted by the share of the footprint where it is the lowest surface
    // (`share`).
    float end_share = 1.0f;
    float share = 1.0f;
    groove::Section section_without;  // the section without the ending grooves (when end_share < 1)
    bool one_material = false;        // every facet shows the top material (weathered grooves)
    // The clear coat's orange peel on the uncut surface (car paint; docs/grooves.md, "Orange peel
    // beside a scratch"): the flat facets and the pieces at the base height take the peel's slope
    // at their own place (flatNormal), as the explicit geometry's uncut triangles do; cut ones
    // have none. Null where there is no peel.
    const PaintVariation* paint = nullptr;
    // The chart about F (setUvMap, at every camera hit): the peel's and pileUpAhead's.
    Vec2f uv0{0.0f, 0.0f};                      // the UV (mm) of F
    Vec2f uv_t{0.0f, 0.0f}, uv_b{0.0f, 0.0f};   // UV per mm along T and B
    float mm_per_uv = 1.0f;                     // the chart's scale there (SurfacePoint::mm_per_uv)
    Vec3f peel_u{0.0f, 0.0f, 0.0f}, peel_v{0.0f, 0.0f, 0.0f};  // slope per unit of the UV gradient
    float paint_fp = 0.0f;  // the pixel's footprint (UV mm), which filters the peel's octaves
    // The tangent of the facets' shading frames: T, or where the camera hit drew a resolved paint
    // flake's lobe, the surface's dpdu, the frame its flake normal is given in (as the path
    // tracer's frame at every hit), so that the same flake sparkles as in the explicit geometry.
    std::optional<Vec3f> frame_t;
    // The material of the facets that the footprint's bounced directions meet (every level past
    // the first, and the chains' far facets), where it differs from the camera hit's: those lie
    // elsewhere on the surface, not under the resolved flake that the camera hit drew or not, so
    // they take the paint with its flakes unresolved, their mean (Tracer::beyond). Null elsewhere.
    const Material* beyond = nullptr;
    // The other defects' slope at the footprint (a bump-mapped dent's: the world vector that
    // applyDefects takes off a hit's normal there; zero without), which tilts every facet's normal
    // (bumped), as it tilts every hit of the explicit geometry, cut or not.
    Vec3f bump{0.0f, 0.0f, 0.0f};
    // Crossings and ends: area sampling with polygons (Bosch §4.2.4, render/groove_area.h) over
    // the footprint polygon `fp2`, in the frame (T, B, W) centred on F. The fallback above is used
    // only when the pieces would pass groove::area::Surface's caps.
    bool area = false;
    groove::area::Surface surface;
    bool surface_built = false;  // buildArea ran on `surface` (its buffers came from spareSurface)
    bool trimmed = false;        // `surface` holds only the grooves nearest the footprint (past the caps)
    bool capped = false;         // buildArea failed at the caps (not for want of a groove in reach)
    bool shared = false;         // `surface` was built for another footprint (Tracer::SharedArea)
    groove::area::Poly fp2;
    double pixel_r = 0;  // the whole pixel's radius on the base plane (mm; fp2 is one stratum of it)
    // Where F lies in the surface's (T, B): (0, 0), unless the surface was built for a footprint
    // nearby in a close view and serves this one too (Tracer::SharedArea); fp2 is centred there.
    Vec2d org{0.0, 0.0};
  };

  // The polygons' buffers (pieces, walls, the shadows cached per light) are kept from one
  // footprint to the next: a GrooveSet lives for one camera hit, and freeing its Surface returned
  // megabytes to the system that the next footprint took back page by page (on the scratched door,
  // a third of the groove renderer's time was the kernel clearing those pages). One Surface per
  // thread is enough: a camera hit builds at most one.
  static groove::area::Surface& spareSurface() {
    thread_local groove::area::Surface spare;
    return spare;
  }
  static void recycle(std::vector<GrooveSet>& sets) {
    for (GrooveSet& s : sets)
      if (s.surface_built) {
        std::swap(s.surface, spareSurface());
        s.surface_built = false;
      }
    sets.clear();
  }

  // Candidate scratches near a hit: closest points within reach of the footprint.
  struct NearGroove {
    const Scratch* sc;
    PathPoint pp;
  };

  // Whether two closest points of one path lie on one line: parallel or opposite tangents (or
  // their segments on one line in the path's double coordinates: a short leg's float tangent is a
  // few 1e-6 rad off), and the same point (or, with `anywhere_along`, b anywhere on a's line),
  // within what float coordinates resolve (a few units in the last place).
  static bool onOneLine(const ScratchPath& path, const PathPoint& a, const PathPoint& b, bool anywhere_along = false) {
    const float scale = 1.0f + std::max(std::max(std::fabs(a.point.x), std::fabs(a.point.y)),
                                        std::max(std::fabs(b.point.x), std::fabs(b.point.y)));
    const Vec2f d = b.point - a.point;
    const float off = anywhere_along ? std::fabs(a.tangent.x * d.y - a.tangent.y * d.x) : std::max(std::fabs(d.x), std::fabs(d.y));
    return off <= 5e-7f * scale && (std::fabs(a.tangent.x * b.tangent.y - a.tangent.y * b.tangent.x) <= 1e-6f ||
                                    (a.seg >= 0 && b.seg >= 0 && path.segmentsOnOneLine(size_t(a.seg), size_t(b.seg))));
  }
  // Whether a later pass's closest point b is the path's end, on the line of an earlier pass's
  // closest point a: a path that comes back along its own line and ends there, seen past its
  // end, where the earlier is the nearer.
  static bool endOnLine(const ScratchPath& path, const PathPoint& a, const PathPoint& b) {
    return b.s >= float(path.length()) && onOneLine(path, a, b, true);
  }
  // Whether the path's start lies within r of p.
  static bool startWithin(const ScratchPath& path, Vec2f p, float r) {
    const Vec2d& e = path.points().front();
    return std::hypot(e.x - double(p.x), e.y - double(p.y)) <= double(r);
  }

  void nearGrooves(const SurfacePoint& sp, float reach_extra, std::vector<NearGroove>& out) const {
    out.clear();
    float fpr = footprintOf(sp);
    float reach = fpr + max_half_ + reach_extra;
    s_.defect_index.forEach(sp.uv, reach, [&](const Defect& d) {
      if (d.cls() != DefectClass::Scratch) return;
      const auto& sc = static_cast<const Scratch&>(d);
      float r = fpr + float(sc.referenceProfile().halfExtent()) * sc.maxScale() + reach_extra;
      if (!(sc.maxScale() > 0)) return;
      // One groove for each pass of the path near the footprint (a hairpin's two legs, a loop
      // that crosses itself), each at its own closest point; the first is the path's closest.
      // (With the closest point alone, a pass farther than that was missing from the footprint's
      // surface, shadows and reflections: docs/grooves.md, "A path that comes back".)
      // A pass is one where the path has gone away by more than the groove's half-width and the
      // footprint's radius and come back (else it is the same pass: a corner's inner side, a
      // bend): with a long reach (a dome light's, near the horizon) a hairpin's turn is within it,
      // and the two legs were one run of segments, of which only the nearer leg was taken.
      thread_local std::vector<PathPoint> passes;
      sc.path().closestBranches(sp.uv, r, passes, fpr + float(sc.referenceProfile().halfExtent()) * sc.maxScale());
      const size_t first = out.size();
      for (const PathPoint& pp : passes) {
        // A pass that lies on an earlier one's line (a path going exactly back over itself) is
        // left out where the path's start is not within reach: the explicit geometry takes the
        // earlier pass there (ScratchPath::closest breaks ties to the lower segment), and the two
        // as passes were split along their common centre line, a step between their two
        // cross-sections where the force differs (docs/grooves.md, "A path that comes back").
        // The path's end needs no exception: the later pass ends on the earlier's line, and
        // beyond its end the earlier is the nearer, so a later pass seen past that end (its
        // closest point the path's end, on the earlier's line) is left out too. (Until 2026-11-30
        // both ends kept the two, and a path that came back short of its start was split along
        // its line, the later pass's side flat where its force had faded: the accuracy test's
        // `shortback`.) Past the start the later pass may run on alone.
        size_t on = first;
        while (on < out.size() && !onOneLine(sc.path(), out[on].pp, pp) && !endOnLine(sc.path(), out[on].pp, pp)) ++on;
        if (on == out.size() || startWithin(sc.path(), sp.uv, r))
          out.push_back({&sc, pp});
        else if (pp.s < out[on].pp.s)  // (the earlier of the two along the path stays)
          out[on].pp = pp;
      }
    });
  }

  // Whether both legs of a path's corner (ScratchPath::corners) come within the groove's width of
  // the footprint: around the vertex, and on the inner side of a sharp corner, where the legs run
  // side by side, the footprint sees one leg and the other's walls shadow and light it, while the
  // sections take the closest point's leg alone. (Within one half-width instead of two, a 150-degree
  // turn under the ring light kept 0.37% of pixels >= 10 against geometry at 256 spp, where two give
  // 0% and four or eight the same for 3.6 and 7.7 times the polygon footprints; docs/grooves.md,
  // "Corners".) The vertex is looked for within r / sin(half of 180 degrees less kNearCornerTurn):
  // where a path doubles back by more than that, its legs run side by side farther out, and there
  // they are passes, which the sections split by nearness however many there are. (With the reach
  // of kMaxCornerTurn, 179.9 degrees, a path zigzagging back twice, its three legs 0.1 mm apart and
  // its vertices 5 mm out of view, went to the polygons, which split only two passes: 8.4% of
  // pixels >= 10 where the sections give 0.68%.)
  static constexpr double kNearCornerTurn = 175.0 * M_PI / 180.0;
  bool nearCorner(const SurfacePoint& sp, const std::vector<NearGroove>& near) const {
    const float fpr = footprintOf(sp);
    const Vec2d F(double(sp.uv.x), double(sp.uv.y));
    for (const NearGroove& ng : near) {
      if (ng.sc->path().corners().empty()) continue;
      const double r = double(fpr) + 2 * ng.sc->referenceProfile().halfExtent() * double(ng.sc->maxScale());
      // Within r of both legs: within r / sin(half the angle between them) of the vertex.
      const ScratchPath::Corner* c =
          ng.sc->path().nearestCorner(F, r / std::sin(0.5 * (M_PI - kNearCornerTurn)));
      if (!c) continue;
      const Vec2d d = F - c->p;
      const double la = std::max(0.0, -(d.x * c->t_in.x + d.y * c->t_in.y));
      const double lb = std::max(0.0, d.x * c->t_out.x + d.y * c->t_out.y);
      const Vec2d ea = d + c->t_in * la, eb = d - c->t_out * lb;
      if (std::hypot(ea.x, ea.y) <= r && std::hypot(eb.x, eb.y) <= r) return true;
    }
    return false;
  }
  // Orthonormal frame of a groove at a hit: T from the UV tangent, W the (unperturbed) normal,
  // B along the UV chart's W x T direction (so that the profile's b > 0 is the path's left, also
  // on a mirrored chart).
  static bool grooveFrame(const SurfacePoint& sp, Vec2f t_uv, Vec3f& T, Vec3f& B, Vec3f& W) {
    W = sp.ns;
    T = sp.dpdu * t_uv.x + sp.dpdv * t_uv.y;
    T = T - W * dot(T, W);
    B = sp.dpdu * (-t_uv.y) + sp.dpdv * t_uv.x;
    B = B - W * dot(B, W) - T * (dot(B, T) / std::max(1e-20f, dot(T, T)));
    float lt = length(T), lb = length(B);
    if (!(lt > 0) || !(lb > 0)) return false;
    T = T / lt;
    B = B / lb;
    return true;
  }

  // Only the outer side of the part carries grooves (seen from behind, the sheet is unscratched).
  bool outerSide(const Hit& h, Vec3f wo_w) const { return !h.shell && dot(s_.part->frame(h.prim).ng, wo_w) > 0; }

  // tan of the angle between the view and the normal, capped (grazing views, Bosch §4.2.1).
  static float viewTan(const SurfacePoint& sp, Vec3f wo_w) {
    float cos_v = std::max(1e-3f, dot(wo_w, sp.ns));
    return std::min(50.0f, std::sqrt(std::max(0.0f, 1 - cos_v * cos_v)) / cos_v);
  }

  // The pixel footprint's projection onto the cross-section axis B (Bosch §4.2.3 (2)), exact for
  // the pixel's parallelogram.
  static groove::Footprint footprintAcross(const SurfacePoint& sp, Vec3f B) {
    groove::Footprint fp;
    fp.w1 = std::fabs(dot(sp.dpdx, B));
    fp.w2 = std::fabs(dot(sp.dpdy, B));
    return fp;
  }

  // The groove's cross-section at its closest point, with b in mm of surface (the chart's stretch).
  static Profile surfaceProfile(const NearGroove& ng, float mm_per_uv) {
    return surfaceProfile(*ng.sc, ng.sc->scaleAt(ng.pp.s), mm_per_uv);
  }
  // The same at scale k (Scratch::profileAt's, for a scale that is not the path's own there).
  static Profile surfaceProfile(const Scratch& sc, float k, double mm_per_uv) {
    Profile p = sc.referenceProfile().scaled(double(k)).withLayers(sc.layers());
    for (auto& q : p.pts) q.x *= mm_per_uv;
    return p;
  }
  // How the cross-section's scale changes along the path at ng (the force fade, force keys and
  // random perturbation of defects/scratch.h): its relative change per mm (k the scale there), by
  // a central difference over 1e-3 of the path's length unit.
  static double scaleSlope(const NearGroove& ng, float k, double mm_per_uv) {
    const double len = ng.sc->path().length(), ds = 1e-3;
    const double s0 = std::max(0.0, double(ng.pp.s) - ds), s1 = std::min(len, double(ng.pp.s) + ds);
    if (!(s1 > s0)) return 0.0;
    return (double(ng.sc->scaleAt(float(s1))) - ng.sc->scaleAt(float(s0))) / ((s1 - s0) * k * mm_per_uv);
  }

  // Half-extent of a merged section: past `reach` (the farthest footprint coordinate in use) by
  // the largest projection of the grooves' heights at a capped grazing angle.
  double sectionExtent(double reach) const { return reach + 4 * (max_height_ + max_depth_) * 50.0 + 1.0; }

  // Collects the grooves whose cross-sections can affect the footprint (Bosch §4.2.1: the box is
  // enlarged by the projected heights toward the viewer and the lights) and merges the parallel
  // ones into one section. Returns false when no groove reaches the footprint.
  bool gatherGrooves(const SurfacePoint& sp, const Hit& h, Vec3f wo_w, std::vector<GrooveSet>& sets) const {
    recycle(sets);
    if (!outerSide(h, wo_w)) return false;
    const float view_reach = (max_height_ + max_depth_) * viewTan(sp, wo_w);
    float enlarge = std::max(view_reach, (max_height_ + max_depth_) * tan_light_max_);
    thread_local std::vector<NearGroove> near;
    nearGrooves(sp, enlarge, near);
    if (near.empty()) return false;
    // The reference direction: the deepest groove at the centre.
    size_t ref = 0;
    float best = 1e30f;
    for (size_t i = 0; i < near.size(); ++i) {
      float k = near[i].sc->scaleAt(near[i].pp.s);
      float depth_here = k * float(near[i].sc->referenceProfile().depth());
      float key = near[i].pp.distance - depth_here * 4.0f;
      if (key < best) {
        best = key;
        ref = i;
      }
    }
    // Directions: groups of grooves parallel within 2 degrees, the reference's first (at most
    // kMaxDirections; grooves of further directions are left out).
    constexpr size_t kMaxDirections = 3;
    thread_local std::vector<size_t> rep, group;
    rep.assign(1, ref);
    group.assign(near.size(), size_t(-1));
    for (size_t i = 0; i < near.size(); ++i) {
      for (size_t g = 0; g < rep.size() && group[i] == size_t(-1); ++g)
        if (parallel(near[i].pp.tangent, near[rep[g]].pp.tangent)) group[i] = g;
      if (group[i] == size_t(-1) && rep.size() < kMaxDirections) {
        group[i] = rep.size();
        rep.push_back(i);
      }
    }
    // Polygons over all the grooves near the footprint, in a set of their own. Where they cannot be
    // built, `capped` says whether the caps were why (without polygons every crossing goes to the
    // blend), and `tried` that they need not be tried again: the same grooves give the same result.
    bool capped = true, tried = false;
    auto polygons = [&] {
      tried = true;
      sets.emplace_back();
      if (buildArea(sp, near, ref, enlarge, view_reach, sets.back())) {
        sets.back().area = true;
        ++(sets.back().trimmed ? counts_.trimmed : counts_.polygons);
        counts_.shared += sets.back().shared;
        return true;
      }
      capped = sets.back().capped;
      recycle(sets);
      return false;
    };
    // Both legs of a path's corner within a groove's width of the footprint (nearCorner): polygons,
    // which give the corner its two legs and its round outer side; past their caps, as below.
    if (st_.groove_polygons && nearCorner(sp, near) && polygons()) return true;
    // One direction: the whole footprint is one section (the common case, and Bosch's).
    if (rep.size() == 1) {
      sets.emplace_back();
      if (!buildSet(sp, near, ref, enlarge, sets.back())) {
        recycle(sets);
        return false;
      }
      // An end inside the footprint: polygons, unless past their caps (then the end blend).
      if (sets.back().end_share < 1.0f) {
        GrooveSet& gs = sets.back();
        if (tried)
          gs.capped = capped;
        else
          gs.area = st_.groove_polygons && buildArea(sp, near, ref, enlarge, view_reach, gs);
        ++(gs.area ? (gs.trimmed ? counts_.trimmed : counts_.polygons)
                   : (!st_.groove_polygons || gs.capped ? counts_.fallbacks : counts_.sections));
        counts_.shared += gs.area && gs.shared;
      } else {
        ++counts_.sections;
      }
      return true;
    }
    // Crossings: polygons over all the grooves near the footprint.
    if (st_.groove_polygons && !tried && polygons()) return true;
    // The blend below; counted as a fallback where the polygons were past their caps, else with
    // the sections (no groove had a cross-section within the polygons' region).
    ++(capped ? counts_.fallbacks : counts_.sections);
    // Crossings: the share of the footprint where each direction's grooves are the lowest
    // surface (or, where no groove is below it, the highest pile-up), from a 4 x 4 grid of
    // points over the pixel footprint; points on the plain surface count for the reference.
    constexpr int kGrid = 4;
    float count[kMaxDirections] = {0, 0, 0};
    for (int j = 0; j < kGrid; ++j)
      for (int i = 0; i < kGrid; ++i) {
        float fx = (i + 0.5f) / kGrid - 0.5f, fy = (j + 0.5f) / kGrid - 0.5f;
        Vec2f q = sp.uv + sp.duvdx * fx + sp.duvdy * fy;
        size_t lo_g = 0, hi_g = 0;
        float lo = 0, hi = 0;
        for (size_t n = 0; n < near.size(); ++n) {
          if (group[n] == size_t(-1)) continue;
          float hn = near[n].sc->height(q);
          if (hn < lo) lo = hn, lo_g = group[n];
          if (hn > hi) hi = hn, hi_g = group[n];
        }
        count[lo < 0 ? lo_g : (hi > 0 ? hi_g : 0)] += 1;
      }
    for (size_t g = 0; g < rep.size(); ++g) {
      if (count[g] <= 0) continue;
      sets.emplace_back();
      if (!buildSet(sp, near, rep[g], enlarge, sets.back())) {
        sets.pop_back();
        continue;
      }
      sets.back().share = count[g] / float(kGrid * kGrid);
    }
    // Renormalise over the directions that could be built.
    float total = 0;
    for (const GrooveSet& gs : sets) total += gs.share;
    for (GrooveSet& gs : sets) gs.share /= total;
    return !sets.empty();
  }

  // Whether the camera ray `ray`, which hit `h`, shows grooves in its footprint (filling `sets`
  // with them): it must reach the part before any emitter the camera sees, and hit its chart.
  bool footprintHasGrooves(const DiffRay& ray, const Hit& h, std::vector<GrooveSet>& sets) const {
    if (!h.hit || st_.max_bounces < 1) return false;
    float t = h.t;
    if (nearestEmitter(ray, true, t) >= 0) return false;
    const SurfacePoint sp = surface(h, ray, true);
    return sp.uv_ok && gatherGrooves(sp, h, -ray.d, sets);
  }

  static bool parallel(Vec2f a, Vec2f b) { return std::fabs(dot(a, b)) >= 0.99939f; }

  // A footprint at the tip of a scratch whose force fades out: the closest point of its path is
  // the end, where the depth law leaves no cross-section (scale 0), yet the groove has depth a
  // little way in, within the polygons' region. Moves ng's reference inward along the path to the
  // first arc position, within `along` (uv), where the scale is positive, and returns that
  // scale; the polygons then extend its cross-section linearly to the tip (Groove::rho). 0 where
  // there is none within `along`: nothing of that groove reaches the polygons' region.
  static float depthInward(const SurfacePoint& sp, float along, NearGroove& ng) {
    const ScratchPath& path = ng.sc->path();
    const double len = path.length();
    const double dir = double(ng.pp.s) > 0.5 * len ? -1.0 : 1.0;
    constexpr int kSteps = 16;
    for (int j = 1; j <= kSteps; ++j) {
      const double s = double(ng.pp.s) + dir * double(along) * j / kSteps;
      if (!(s >= 0 && s <= len)) break;
      const float k = ng.sc->scaleAt(float(s));
      if (!(k > 0)) continue;
      const Vec2d p = path.pointAt(s), t = path.tangentAt(s);
      ng.pp.s = float(s);
      ng.pp.point = Vec2f(float(p.x), float(p.y));
      ng.pp.tangent = Vec2f(float(t.x), float(t.y));
      const Vec2f e = sp.uv - ng.pp.point;
      ng.pp.offset = -ng.pp.tangent.y * e.x + ng.pp.tangent.x * e.y;  // e . B, B = (-T.y, T.x)
      return k;
    }
    return 0.0f;
  }

  // The polygons take a groove's cross-section as linear in its scale along the path (Groove::rho,
  // the slope at the closest point). Where the scale is far from linear over the region, that
  // tangent can overshoot: from the middle of a 0.3 mm force fade it reaches 1.8 times the full
  // depth 0.3 mm further in, and 2.9 times at 0.5 mm, so a deep groove's pile-up stood three times
  // its height there and shadowed or cut the grooves around its tip (the fuzzer's c18_6,
  // docs/grooves.md, "Fading tips in the polygons"). Where the tangent rises above the scale by
  // more than kScaleTol of the largest scale in reach and more than `tol_abs` (the caller's bound,
  // from the height that error moves), the groove enters as pieces along its tangent line: the
  // tangent itself as far as it holds on either side of the closest point (so the footprint keeps
  // its exact scale and slope), and beyond that on either side up to kSidePieces pieces, linear
  // from the tangent's last value to the true scale at the end of the reach through the samples
  // where one line would be off by the most (the scale sampled at kScaleSamples points over
  // `reach` (uv) around the footprint's centre). Appends g as it is when the
  // tangent holds everywhere in reach, else the pieces (their profiles appended to `profiles`,
  // which must not reallocate: reserved by the caller). Returns how many grooves it appended.
  static constexpr int kScaleSamples = 33;
  // Beyond the tangent's piece on either side, up to kSidePieces pieces, each linear between the
  // scale at its two ends (samples): one until the fifty-second session, which went from the
  // footprint's fade across the plateau to the path's far fade in one line, 30% short of the
  // plateau's scale halfway (below).
  static constexpr int kSidePieces = 4;
  static constexpr int kScaleSegments = 1 + 2 * kSidePieces;  // the tangent's piece and the sides'
  static constexpr float kScaleTol = 0.05f;
  static size_t scaleSegments(const NearGroove& ng, float k, const groove::area::Groove& g, float reach, double mm,
                              float tol_abs, std::vector<Profile>& profiles, std::vector<groove::area::Groove>& out) {
    const double len = ng.sc->path().length();
    const double sc = double(ng.pp.s), mid = sc + g.t0 / mm;
    const double sa = std::max(0.0, mid - double(reach)), sb = std::min(len, mid + double(reach));
    if (!(sb > sa)) {
      out.push_back(g);
      return 1;
    }
    constexpr int M = kScaleSamples;
    double ss[M];
    float ks[M], lin[M];
    float kmax = 0;
    for (int j = 0; j < M; ++j) {
      ss[j] = sa + (sb - sa) * j / (M - 1);
      ks[j] = ng.sc->scaleAt(float(ss[j]));
      lin[j] = std::max(0.0f, k * float(1.0 + g.rho * (ss[j] - sc) * mm));
      kmax = std::max(kmax, ks[j]);
    }
    const float tol = std::max(kScaleTol * kmax, tol_abs);
    auto off = [&](int j) { return lin[j] - ks[j] > tol; };
    // The samples around the closest point where the tangent holds.
    int c = int(std::lround((sc - sa) / (sb - sa) * (M - 1)));
    c = std::clamp(c, 0, M - 1);
    int lo = c, hi = c;
    while (lo > 0 && !off(lo - 1)) --lo;
    while (hi < M - 1 && !off(hi + 1)) ++hi;
    if (lo == 0 && hi == M - 1) {
      out.push_back(g);
      return 1;
    }
    size_t added = 0;
    // The tangent's piece, between samples lo and hi (on to the path's ends where they are the
    // first and last).
    groove::area::Groove mid_g = g;
    if (lo > 0) mid_g.t_lo = (ss[lo] - sc) * mm;
    if (hi < M - 1) mid_g.t_hi = (ss[hi] - sc) * mm;
    if (hi > lo) {
      out.push_back(mid_g);
      ++added;
    }
    // Beyond the tangent's piece on either side, pieces from its last value (at sample lo or hi)
    // to the true scale at the end of the reach, each linear between the values at its ends: one
    // piece, split at the sample farthest from its line while that is off by more than `tol` and
    // the side has fewer than kSidePieces (a fade near the footprint, the plateau, and the far end's
    // fade: the clusters fuzzer's c56_1 seen at 11 micrometres per pixel had a pile-up 0.4 mm from
    // a footprint at 0.61 of its scale instead of 0.88, low enough for the light that its wall sends
    // back to the bar to pass over it; docs/grooves.md, "Fading tips in the polygons").
    auto val = [&](int j) { return j == lo || j == hi ? lin[j] : ks[j]; };
    auto piece = [&](int j0, int j1) {
      const float k0 = val(j0), k1 = val(j1);
      if (!(k0 > 0) && !(k1 > 0)) return;
      const int jr = k1 > k0 ? j1 : j0;  // the reference: the larger scale
      const double sr = ss[jr];
      const float want = val(jr);
      profiles.push_back(surfaceProfile(*ng.sc, want, mm));
      groove::area::Groove h = g;
      h.t0 = g.t0 - (sr - sc) * mm;
      h.rho = double(k1 - k0) / ((ss[j1] - ss[j0]) * mm * double(want));
      // Where the reach ends before the path does, the piece runs on to the path's end, as the
      // whole groove did (nothing past the reach is in the region).
      h.t_lo = j0 == 0 ? -sr * mm : (ss[j0] - sr) * mm;
      h.t_hi = j1 == M - 1 ? (len - sr) * mm : (ss[j1] - sr) * mm;
      h.pts = &profiles.back().pts;
      h.layer = &profiles.back().layer;
      out.push_back(h);
      ++added;
    };
    thread_local std::vector<int> cuts;
    auto side = [&](int from, int to) {
      if (from == to) return;
      cuts.assign({std::min(from, to), std::max(from, to)});
      while (int(cuts.size()) <= kSidePieces) {
        // The sample farthest from its piece's line, over all pieces.
        int at = -1;
        float worst = tol;
        for (size_t c = 0; c + 1 < cuts.size(); ++c) {
          const int a = cuts[c], b = cuts[c + 1];
          for (int j = a + 1; j < b; ++j) {
            const float line = val(a) + (val(b) - val(a)) * float(j - a) / float(b - a);
            const float off_by = std::fabs(ks[j] - line);
            if (off_by > worst) worst = off_by, at = j;
          }
        }
        if (at < 0) break;
        cuts.insert(std::upper_bound(cuts.begin(), cuts.end(), at), at);
      }
      for (size_t c = 0; c + 1 < cuts.size(); ++c) piece(cuts[c], cuts[c + 1]);
    };
    side(lo, 0);
    side(hi, M - 1);
    return added;
  }

  // g in the frame of gs: its direction t_uv on the surface at sp, its profile, layers and id (its
  // position, scale slope and ends are the caller's). False where the frame degenerates.
  static bool placeGroove(const SurfacePoint& sp, const GrooveSet& gs, Vec2f t_uv, const Profile& prof,
                          const Scratch& sc, int id, groove::area::Groove& g) {
    Vec3f Ti, Bi, Wi;
    if (!grooveFrame(sp, t_uv, Ti, Bi, Wi)) return false;
    g.tdir = Vec2d(dot(Ti, gs.T), dot(Ti, gs.B));
    g.bdir = Vec2d(dot(Bi, gs.T), dot(Bi, gs.B));
    g.pts = &prof.pts;
    g.layer = &prof.layer;
    g.interfaces = &sc.interfaces();
    g.id = id;
    return true;
  }

  // ng's groove along its tangent at its closest point, at scale k there (the path's, or
  // depthInward's), in the frame of gs, its profile appended to `profiles`: up to the corners
  // around it, or the path's ends. Past a corner the path turns, and a straight groove run on would
  // stand where it is not (a pass found on a short leg of a knot of corners; docs/grooves.md,
  // "Corners close together"). False where the frame degenerates.
  static bool straightGroove(const SurfacePoint& sp, const NearGroove& ng, int id, float k, const GrooveSet& gs,
                             double mm, std::vector<Profile>& profiles, groove::area::Groove& g) {
    profiles.push_back(surfaceProfile(ng, float(mm)));
    if (!placeGroove(sp, gs, ng.pp.tangent, profiles.back(), *ng.sc, id, g)) return false;
    const Vec2f rel = sp.uv - ng.pp.point;
    g.t0 = double(rel.x * ng.pp.tangent.x + rel.y * ng.pp.tangent.y) * mm;
    g.b0 = double(ng.pp.offset) * mm;
    g.rho = scaleSlope(ng, k, mm);  // per mm of surface
    const auto [s0, s1] = ng.sc->path().spanAt(double(ng.pp.s));
    g.t_lo = (s0 - double(ng.pp.s)) * mm;
    g.t_hi = (s1 - double(ng.pp.s)) * mm;
    return true;
  }

  // A view is close, for the cap of pieces (buildArea), where the reach toward the lights is at
  // least this many of the pixel's radii: the region's square is 8 pixels wide or more, and a
  // shadow lost beyond half the reach spans two pixels or more. Until the forty-fifth session it
  // was 32; the corner fuzzer's c41_7 (the accuracy test's `tiltpin`, 23 radii) kept 0.56% of
  // pixels >= 10 against geometry at 2,048 spp at the ordinary cap, 0% at the close views' cap.
  // Until the fifty-third it was 16; the clusters fuzzer's c58_4 (about 12 radii, the accuracy
  // test's `cluster58b`) kept 0.82%, now 0.04%, and 56 fuzzer layouts at 1 to 10 degrees took
  // the same time or less in all (264 s against 281 s): a build refused at the ordinary cap costs
  // about as much as one that passes at this one (docs/grooves.md, "Eight pixel radii").
  static constexpr double kCloseReach = 8.0;

  // A corner of ng's path at either end of its closest point's segment (ScratchPath::cornerAround:
  // the footprint's own leg is one of its two), within `reach` (uv) of the footprint's centre: the
  // groove as its two legs, each straight along its segment at the vertex, and the round outer side
  // between them (groove::area::cornerParts), in the frame of gs, with the cross-section at the
  // vertex. Where the corners next to it along the path lie within `reach` too (a hook, a U-turn
  // at two corners, a zigzag; up to kMaxChain corners in all), the groove takes them together
  // (groove::area::chainParts, over `bound`: the largest region the caller builds), so that their
  // legs and outer sides meet as the explicit geometry has them instead of a leg stopping at the
  // next corner. The profiles (one per corner) are appended to `profiles` (reserved by the
  // caller); `span` is the arc range the groove covers. False where there is no corner, or the path
  // has faded out at the vertex.
  static constexpr double kCornerSector = 15.0 * M_PI / 180.0;
  // A fan's sectors are planes, each with its own normal: seen so close that a 15-degree sector of
  // a cap spans several pixels, a sharp light's reflection off the cap breaks into bands (a half
  // turn seen from 20 mm at 1 degree, 3.6 micrometres per pixel, under the ring: 0.90% of pixels
  // >= 10 at 64 spp; docs/grooves.md, "A half turn's step, seen very close"). So a sector is no
  // wider than the angle over which its arc at the groove's edge (the legs' profiles' largest
  // half-extent R) spans two pixels (2 x the pixel's diameter / R), and no narrower than
  // kMinSector: the parts, cells and pieces grow with the sectors' number. The pixel, not the
  // footprint (a stratum of it), so that the choice does not change with spp. For R = 0.13 mm it
  // starts below 12 micrometres per pixel: the accuracy tests' and the fuzzers' views keep 15
  // degrees, but for `halftip` (3.6 micrometres per pixel, 5 degrees).
  static constexpr double kMinSector = 5.0 * M_PI / 180.0;
  static double fanSector(const groove::area::Groove* legs, size_t n, const GrooveSet& gs) {
    double R = 0;
    for (size_t k = 0; k < n; ++k)
      if (legs[k].pts)
        for (const Vec2d& q : *legs[k].pts) R = std::max(R, std::fabs(q.x));
    if (!(R > 0) || !(gs.pixel_r > 0)) return kCornerSector;
    return std::clamp(4.0 * gs.pixel_r / R, kMinSector, kCornerSector);
  }
  static constexpr size_t kMaxChain = 12;
  // A path's bends (ScratchPath::bendsAround) within kBendTol footprint radii of the path at the
  // footprint, and kBendGrowth mm more per mm away from it, at most kMaxBends of them. On a cubic
  // loop 0.3 mm across, seen at 2 degrees (docs/grooves.md, "Bends"), pixels >= 10: uniform
  // tolerance with 12 bends, 1.19% (ring) and 0.88% (bar); growth 0.03 with 16 bends, 0.13% and
  // 0.03%; with 20 or 24 bends more chains pass chainParts' caps and fall back.
  // Only where the path within the region strays from its tangent by more than kBendStray of the
  // groove's half-width at its largest scale or of the footprint's radius, whichever is larger (a
  // footprint wider than the groove, the door's at an inspection camera's scale, sees no bend
  // below its own size; with the half-width alone the door's key scratches took bends there, for
  // a quarter more time at 1 spp and no gain): a gently curved groove keeps its tangent and its
  // pieces along the path (scaleSegments), which follow a fading tip's scale where the bends' legs
  // are linear (the accuracy test's `tips` under the bar: 1.04% of pixels >= 10 with bends
  // everywhere, 0.195% with this rule, 0.174% without bends; `curl` at 1.5 half-widths: 0.53%).
  static constexpr double kBendTol = 0.05, kBendGrowth = 0.03, kBendStray = 1.0;
  static constexpr size_t kMaxBends = 16, kMinBends = 4;
  // Where the bends' leg over the closest point's segment turns from it by more than kBendDev, the
  // segment's ends are bends too (bendsAround): a groove wall's glint moves along a curve with its
  // direction (the accuracy test's `loop` under the bar: 0.141% of pixels >= 10 without, 0.043%).
  static constexpr double kBendDev = 1.0 * M_PI / 180.0;
  // And so do the segments within kBendNear footprint radii of the footprint beyond the closest
  // point's (bendsAround's `near`): inside a tight curl the footprint sees the walls of the legs
  // beside its own, and where a simplified chord stood for them the border between two legs'
  // walls (their angle bisector) turned with it. In the passes fuzzer's p75_0 (a cubic's tip of
  // radius 0.11 mm, seen from inside at 1 degree) a chord over three segments, 7 degrees off the
  // one beside the footprint's, moved that border 4 um and stood its wall's glint where the
  // path's own walls have none (docs/grooves.md, "Bends").
  static constexpr double kBendNear = 2.0;
  // Those segments may take the bends up to kNearBends times the window's max_bends (the
  // simplification itself keeps at most max_bends). Inside a loop the segments near a footprint
  // on the loop's inner wall are many: in the passes fuzzer's p82_2 (a cubic's loop of radius
  // about 0.15 mm, seen at 2 degrees from its inner wall 0.12 mm off the path) they took 13 bends
  // to 26-31, and at a cap of 16 the window dropped them all. Legs of 0.05 to 0.1 mm, turning 15
  // to 30 degrees at each bend, then stood for the wall; under the bar one of them, 10 degrees off
  // the path's own direction there, mirrored the bar into pixels that geometry has dark (0.52% of
  // pixels >= 10 against geometry at 2,048 spp; 0.17% with them held; docs/grooves.md, "Bends").
  static constexpr size_t kNearBends = 2;
  // The corners cornerGroove takes for ng: `at` the one cornerAround gives, [lo, hi] the chain
  // around it (on along the path both ways while the next corner is within `reach` of the
  // footprint's centre F, at most kMaxChain; the one corner alone where the path has faded out at
  // one of them). False where there is no corner.
  static bool chainRange(const NearGroove& ng, Vec2d F, double reach, size_t& at, size_t& lo, size_t& hi) {
    const ScratchPath& path = ng.sc->path();
    // (A corner next to the closest point's segment, so that the footprint's own leg is there.)
    const ScratchPath::Corner* c = path.cornerAround(double(ng.pp.s), F, reach);
    if (!c) return false;
    const std::vector<ScratchPath::Corner>& cs = path.corners();
    at = lo = hi = size_t(c - cs.data());
    auto within = [&](size_t i) { return std::hypot(cs[i].p.x - F.x, cs[i].p.y - F.y) <= reach; };
    while (hi - lo + 1 < kMaxChain && ((lo > 0 && within(lo - 1)) || (hi + 1 < cs.size() && within(hi + 1)))) {
      if (lo > 0 && within(lo - 1)) --lo;
      if (hi - lo + 1 < kMaxChain && hi + 1 < cs.size() && within(hi + 1)) ++hi;
    }
    for (size_t i = lo; i <= hi && lo < hi; ++i)
      if (!(ng.sc->scaleAt(float(cs[i].s)) > 0)) hi = lo = at;
    return true;
  }
  static bool cornerGroove(const SurfacePoint& sp, const NearGroove& ng, int id, size_t at, size_t lo, size_t hi,
                           const groove::area::Poly& bound, const GrooveSet& gs, double mm, std::vector<Profile>& profiles,
                           std::vector<groove::area::Groove>& parts, groove::area::Groove& out,
                           std::pair<double, double>& span) {
    const ScratchPath& path = ng.sc->path();
    const Vec2d F(double(sp.uv.x), double(sp.uv.y));
    const std::vector<ScratchPath::Corner>& cs = path.corners();
    const ScratchPath::Corner* c = &cs[at];
    const size_t profiles_at = profiles.size();
    if (lo < hi && chainGroove(sp, ng, id, &cs[lo], hi - lo + 1, path.legSpan(cs[lo]).first, path.legSpan(cs[hi]).second,
                               false, bound, gs, mm, profiles, parts, out)) {
      span = {path.legSpan(cs[lo]).first, path.legSpan(cs[hi]).second};
      return true;
    }
    profiles.resize(profiles_at);
    const float k = ng.sc->scaleAt(float(c->s));
    if (!(k > 0)) return false;
    NearGroove at_c = ng;
    at_c.pp.s = float(c->s);
    const double rho = scaleSlope(at_c, k, mm);
    profiles.push_back(surfaceProfile(*ng.sc, k, mm));
    const Vec2d d = F - c->p;  // from the vertex to the footprint's centre (uv)
    auto leg = [&](Vec2d t, groove::area::Groove& g) {
      if (!placeGroove(sp, gs, Vec2f(float(t.x), float(t.y)), profiles.back(), *ng.sc, id, g)) return false;
      g.t0 = (d.x * t.x + d.y * t.y) * mm;
      g.b0 = (d.y * t.x - d.x * t.y) * mm;  // d . B, B = (-t.y, t.x)
      g.rho = rho;
      return true;
    };
    groove::area::Groove a, b;
    if (!leg(c->t_in, a) || !leg(c->t_out, b)) return false;
    // The footprint's own leg takes its scale linear from the vertex to the closest point, where it
    // is then exact, as without a corner (a perturbed or fading path's scale is far from linear
    // over a leg).
    const double t_fp = (double(ng.pp.s) - c->s) * mm;
    if (std::fabs(t_fp) > 1e-6) (t_fp < 0 ? a : b).rho = (double(ng.sc->scaleAt(ng.pp.s)) / double(k) - 1) / t_fp;
    // Each leg up to the path's end or its next corner, where it stops. (Run on straight, it
    // stood out past that corner as a spur: the corner fuzzer's c1_18, three corners within 0.7 mm,
    // 1.35% of pixels >= 10 that way, 0.09% now; docs/grooves.md, "Corners".)
    span = path.legSpan(*c);
    a.t_lo = (span.first - c->s) * mm;
    b.t_hi = (span.second - c->s) * mm;
    const groove::area::Groove ab[2] = {a, b};
    if (!groove::area::cornerParts(a, b, fanSector(ab, 2, gs), parts)) return false;
    out = a;
    out.parts = &parts;
    return true;
  }

  // The groove of ng's path along corners cs[0..count) (count >= 1: corners of its path, or the
  // bends of bendsAround), all with the path's scale > 0 (cornerGroove); s_begin and s_end the
  // arc positions where its first leg starts and its last leg ends. Leg 0 ends at corner 0, each
  // later leg starts at a corner; each takes the cross-section at its corner (one profile per
  // corner, appended to `profiles`). The interior legs' scale runs linear from corner to corner, so
  // that neighbouring legs and fans meet without a step; the first and last take the path's slope
  // at their corner, or, where the footprint's closest point lies on them, run linear to its scale
  // there (as cornerGroove's own leg). With `chords` (bends, whose legs stand for the curve between
  // them) the positions along a leg are the projections of the path's points onto it, not arc
  // lengths.
  static bool chainGroove(const SurfacePoint& sp, const NearGroove& ng, int id, const ScratchPath::Corner* cs,
                          size_t count, double s_begin, double s_end, bool chords, const groove::area::Poly& bound,
                          const GrooveSet& gs, double mm, std::vector<Profile>& profiles,
                          std::vector<groove::area::Groove>& parts, groove::area::Groove& out) {
    thread_local std::vector<groove::area::Groove> legs;
    legs.clear();
    if (!chainLegs(sp, ng, id, cs, count, s_begin, s_end, chords, gs, mm, profiles, legs)) return false;
    if (!groove::area::chainParts(legs, fanSector(legs.data(), legs.size(), gs), bound, parts)) return false;
    out = legs.front();
    out.parts = &parts;
    return true;
  }
  // chainGroove's legs, appended to `legs` (count + 1 of them).
  static bool chainLegs(const SurfacePoint& sp, const NearGroove& ng, int id, const ScratchPath::Corner* cs,
                        size_t count, double s_begin, double s_end, bool chords, const GrooveSet& gs, double mm,
                        std::vector<Profile>& profiles, std::vector<groove::area::Groove>& legs) {
    const Vec2d F(double(sp.uv.x), double(sp.uv.y));
    const size_t first_profile = profiles.size();
    for (size_t i = 0; i < count; ++i) profiles.push_back(surfaceProfile(*ng.sc, ng.sc->scaleAt(float(cs[i].s)), mm));
    auto scale = [&](size_t i) { return double(ng.sc->scaleAt(float(cs[i].s))); };
    const double s_fp = double(ng.pp.s), k_fp = double(ng.sc->scaleAt(ng.pp.s));
    const size_t n = count + 1;
    const ScratchPath& path = ng.sc->path();
    // Where arc position s (at point q) lies along the leg through corner c in direction t (mm).
    auto along = [&](double s, Vec2d q, const ScratchPath::Corner& c, Vec2d t) {
      return (chords ? (q.x - c.p.x) * t.x + (q.y - c.p.y) * t.y : s - c.s) * mm;
    };
    for (size_t j = 0; j < n; ++j) {
      // Leg j: before corner 0 (j = 0), else from corner j - 1 on.
      const size_t ci = j == 0 ? 0 : j - 1;
      const ScratchPath::Corner& c = cs[ci];
      const Vec2d t = j == 0 ? c.t_in : c.t_out, d = F - c.p;
      groove::area::Groove g;
      if (!placeGroove(sp, gs, Vec2f(float(t.x), float(t.y)), profiles[first_profile + ci], *ng.sc, id, g))
        return false;
      g.t0 = (d.x * t.x + d.y * t.y) * mm;
      g.b0 = (d.y * t.x - d.x * t.y) * mm;  // d . B, B = (-t.y, t.x)
      const double k = scale(ci);
      if (j == 0) {
        g.t_lo = along(s_begin, chords ? path.pointAt(s_begin) : c.p, c, t);
        g.t_hi = 0;
      } else {
        g.t_lo = 0;
        g.t_hi = j + 1 < n ? along(cs[ci + 1].s, cs[ci + 1].p, c, t) : along(s_end, chords ? path.pointAt(s_end) : c.p, c, t);
      }
      if (j > 0 && j + 1 < n) {
        g.rho = (scale(ci + 1) / k - 1) / g.t_hi;
      } else {
        NearGroove at_c = ng;
        at_c.pp.s = float(c.s);
        g.rho = scaleSlope(at_c, float(k), mm);
        const double t_fp = along(s_fp, Vec2d(double(ng.pp.point.x), double(ng.pp.point.y)), c, t);
        if (t_fp >= g.t_lo && t_fp <= g.t_hi && std::fabs(t_fp) > 1e-6) g.rho = (k_fp / k - 1) / t_fp;
      }
      legs.push_back(g);
    }
    return true;
  }

  // The footprint of gs in the frame (gs.T, gs.B) with F at `org` of it (GrooveSet::org): the
  // stratum's parallelogram on the base plane (fp2) and the whole pixel's radius. False where it
  // is degenerate.
  bool placeFootprint(const SurfacePoint& sp, Vec2d org, GrooveSet& gs) const {
    gs.F = sp.p;
    gs.org = org;
    gs.fp = footprintAcross(sp, gs.B);
    return footprintIn(sp, gs.T, gs.B, org, gs.fp2, gs.pixel_r);
  }
  bool footprintIn(const SurfacePoint& sp, Vec3f T, Vec3f B, Vec2d org, groove::area::Poly& fp,
                   double& pixel_r) const {
    Vec2d a1(dot(sp.dpdx, T), dot(sp.dpdx, B)), a2(dot(sp.dpdy, T), dot(sp.dpdy, B));
    fp = groove::area::Poly();
    fp.push((a1 + a2) * -0.5);
    fp.push((a1 - a2) * 0.5);
    fp.push((a1 + a2) * 0.5);
    fp.push((a2 - a1) * 0.5);
    if (fp.area() < 0) std::reverse(fp.v, fp.v + fp.n);
    if (!(fp.area() > 1e-16)) return false;
    const Vec2d p1 = a1 * double(strata_x_), p2 = a2 * double(strata_y_);
    pixel_r = 0.5 * std::max(std::hypot(p1.x + p2.x, p1.y + p2.y), std::hypot(p1.x - p2.x, p1.y - p2.y));
    if (org.x != 0 || org.y != 0)
      for (int i = 0; i < fp.n; ++i) fp.v[size_t(i)] = fp.v[size_t(i)] + org;
    return true;
  }

  // Seen close (the reach at least kCloseReach pixel radii), the strata of a pixel have regions
  // that differ by a fraction of a pixel in 32 or more, and building each one's surface took two
  // thirds of the render's time (c41_7's spot seen from 15 mm, 5.5 micrometres per pixel: 2,240
  // pieces and 2 ms per footprint). There the region is grown by kShareGrowth of the pixel's
  // radius on every side (the cap of pieces with its area), and a footprint takes the surface of
  // the last one built on its thread (SharedArea) where its own region lies within that one's, on
  // the same base plane: the same grooves over at least its own reach, with the paths' tangents,
  // bends and scales taken at a point at most a pixel away. Its camera hit is placed where it lies
  // in that surface's frame (GrooveSet::org). At 4 spp a pixel's four strata share one surface.
  // A thread forgets the surface at the start of each tile (forgetSharedArea), so that what a
  // pixel gets does not depend on how the tiles were spread over the threads. Only surfaces built
  // at the full reach with every groove in it are shared. Measured (docs/grooves.md, "A pixel's
  // strata share one surface"): the accuracy scenes seen close take 1.2-2.8 times less time, the
  // fuzzer's close views 1.3-3.7 times, for the same figures within a pixel or two. Sharing over
  // more (a growth of 1.5 radii, or regions grown by a quarter of the reach, whose tangents, bends
  // and fading tips' scales were then taken up to a quarter of the reach away) was faster and
  // worse: the passes fuzzer's p46_7 0.13% of pixels >= 10 unshared, 0.13% at 1 radius, 0.65% at
  // a quarter of the reach; the accuracy test's `tips` 0.01%, 0.08% and 0.40%.
  static constexpr double kShareGrowth = 1.0;
  struct SharedArea {
    bool valid = false;
    Vec3f F{0.0f, 0.0f, 0.0f}, T{0.0f, 0.0f, 0.0f}, B{0.0f, 0.0f, 0.0f}, W{0.0f, 0.0f, 0.0f};
    Vec2d lo{0.0, 0.0}, hi{0.0, 0.0};  // the region's box in (T, B) about F
  };
  static SharedArea& sharedArea() {
    thread_local SharedArea ru;
    return ru;
  }
  static void forgetSharedArea() { sharedArea().valid = false; }

  // The polygon surface of every groove near the footprint (crossings and ends, Bosch §4.2.4), in
  // the frame of near[ref] (or, in a close view, the surface of a stratum beside it: SharedArea).
  // False when it cannot be built: a degenerate footprint, no groove with a cross-section within
  // the region, or (gs.capped) more grooves or pieces than groove::area allows even for the
  // nearest 4; the caller falls back.
  bool buildArea(const SurfacePoint& sp, const std::vector<NearGroove>& near, size_t ref, float enlarge,
                 float view_reach, GrooveSet& gs) const {
    SharedArea& ru = sharedArea();
    gs.trimmed = gs.capped = gs.shared = false;
    if (!grooveFrame(sp, near[ref].pp.tangent, gs.T, gs.B, gs.W)) return false;
    if (!placeFootprint(sp, Vec2d(0.0, 0.0), gs)) return false;
    const double R = std::max(double(view_reach), double(enlarge)) + 1e-3;  // the full reach
    const bool close = double(enlarge) >= kCloseReach * gs.pixel_r;
    if (st_.groove_share_polygons && close && ru.valid && dot(gs.W, ru.W) >= 1.0f - 1e-6f) {
      const Vec3f d = sp.p - ru.F;
      const Vec2d org(dot(d, ru.T), dot(d, ru.B));
      groove::area::Poly fp;
      double pixel_r = 0;
      if (std::fabs(double(dot(d, ru.W))) <= 1e-3 * gs.pixel_r && footprintIn(sp, ru.T, ru.B, org, fp, pixel_r)) {
        Vec2d lo = fp.v[0], hi = fp.v[0];
        fp.extend(lo, hi);
        if (lo.x - R >= ru.lo.x && lo.y - R >= ru.lo.y && hi.x + R <= ru.hi.x && hi.y + R <= ru.hi.y) {
          if (!gs.surface_built) {
            std::swap(gs.surface, spareSurface());
            gs.surface_built = true;
          }
          gs.T = ru.T, gs.B = ru.B, gs.W = ru.W;
          gs.shared = true;
          return placeFootprint(sp, org, gs);
        }
      }
    }
    ru.valid = false;  // (what follows builds over it)
    const double grow = close && st_.groove_share_polygons ? kShareGrowth * gs.pixel_r : 0.0;
    double built = 0;
    if (!buildRegion(sp, near, enlarge, view_reach, gs, true, &built, grow)) return false;
    if (grow > 0 && built == R + grow) {
      ru.valid = true;
      ru.F = gs.F, ru.T = gs.T, ru.B = gs.B, ru.W = gs.W;
      Vec2d lo = gs.fp2.v[0], hi = gs.fp2.v[0];
      gs.fp2.extend(lo, hi);
      ru.lo = lo - Vec2d(R + grow, R + grow);
      ru.hi = hi + Vec2d(R + grow, R + grow);
    }
    return true;
  }

  // buildArea's surface over the footprint's own region, in the frame and with the footprint that
  // buildArea gave gs. `built` (where given): the region's reach about the footprint's box where
  // it was built with every groove in reach, else 0.
  bool buildRegion(const SurfacePoint& sp, const std::vector<NearGroove>& near, float enlarge, float view_reach,
                   GrooveSet& gs, bool with_bends = true, double* built = nullptr, double grow = 0) const {
    namespace ga = groove::area;
    gs.trimmed = gs.capped = false;
    const double mm = sp.mm_per_uv;
    ga::Poly& fp = gs.fp2;
    Vec2d lo = fp.v[0], hi = fp.v[0];
    fp.extend(lo, hi);
    thread_local std::vector<Profile> profiles;
    thread_local std::vector<ga::Groove> grooves;
    thread_local std::vector<double> near_mm;
    thread_local std::vector<ga::Groove> within;
    // Each groove's pieces along its path (scaleSegments): [seg_at[i], seg_at[i + 1]) in segs.
    thread_local std::vector<ga::Groove> segs;
    thread_local std::vector<size_t> seg_at;
    profiles.clear();
    grooves.clear();
    near_mm.clear();
    segs.clear();
    seg_at.assign(1, 0);
    // (The grooves point into `profiles`, which must not reallocate. Per pass at most: a chain's,
    // one per corner (kMaxChain), again where a joined chain failed and it takes its own; else its
    // straight groove's, with kScaleSegments more for one cut into pieces along its path.)
    profiles.reserve(near.size() * (2 * kMaxChain + 2 + kScaleSegments + kMaxBends));
    // Each corner's parts (cornerGroove), one list per groove; the grooves point into them.
    thread_local std::vector<std::vector<ga::Groove>> corner_parts;
    if (corner_parts.size() < near.size()) corner_parts.resize(near.size());
    // The footprint's radius about its centre (mm), and how far along a path a groove can still
    // reach the region below (uv units).
    const double fp_r = std::max(std::hypot(lo.x, lo.y), std::hypot(hi.x, hi.y));
    const float along_uv = float((fp_r + std::max(double(view_reach), double(enlarge)) + 1e-3) / mm);
    // Each pass's corner groove (cornerGroove), built first over the largest region tried below.
    const Vec2d F(double(sp.uv.x), double(sp.uv.y));
    const double corner_reach = double(along_uv * float(M_SQRT2));
    const double reach_max = std::max(double(view_reach), double(enlarge)) + 1e-3;
    ga::Poly bound;
    bound.push({lo.x - reach_max, lo.y - reach_max});
    bound.push({hi.x + reach_max, lo.y - reach_max});
    bound.push({hi.x + reach_max, hi.y + reach_max});
    bound.push({lo.x - reach_max, hi.y + reach_max});
    thread_local std::vector<char> has_corner;
    thread_local std::vector<ga::Groove> corner_g;
    thread_local std::vector<std::pair<double, double>> corner_span;
    thread_local std::vector<size_t> corner_profile;
    has_corner.assign(near.size(), 0);
    corner_g.resize(near.size());
    corner_span.resize(near.size());
    corner_profile.resize(near.size());
    thread_local std::vector<std::array<size_t, 3>> chain;  // cornerGroove's corners: at, lo, hi
    chain.resize(near.size());
    for (size_t i = 0; i < near.size(); ++i)
      has_corner[i] = chainRange(near[i], F, corner_reach, chain[i][0], chain[i][1], chain[i][2]);
    // Two passes of one path whose chains share a corner or a leg (a knot of corners, where the
    // path goes away and comes back within the reach: nearGrooves) are one chain, the earlier
    // pass's, within kMaxChain; the later pass lies on its legs and is left out below. (As two
    // chains composited, each stood its legs' pile-ups over the other's grooves.)
    thread_local std::vector<size_t> merged_into;
    merged_into.assign(near.size(), size_t(-1));
    thread_local std::vector<std::array<size_t, 3>> own;
    own = chain;
    for (size_t i = 0; i < near.size(); ++i)
      for (size_t j = i + 1; j < near.size() && has_corner[i]; ++j) {
        if (!has_corner[j] || near[j].sc != near[i].sc) continue;
        const size_t lo = std::min(chain[i][1], chain[j][1]), hi = std::max(chain[i][2], chain[j][2]);
        if (chain[j][1] > chain[i][2] + 1 || chain[i][1] > chain[j][2] + 1 || hi - lo + 1 > kMaxChain) continue;
        chain[i][1] = lo;
        chain[i][2] = hi;
        has_corner[j] = 0;
        merged_into[j] = i;
      }
    auto build = [&](size_t i, const std::array<size_t, 3>& c) {
      corner_profile[i] = profiles.size();
      has_corner[i] = cornerGroove(sp, near[i], int(i), c[0], c[1], c[2], bound, gs, mm, profiles, corner_parts[i],
                                   corner_g[i], corner_span[i]);
    };
    // A pass whose path bends within the region beyond its corners (a tight U-turn or loop of a
    // cubic, flattened into turns below kCornerTurn, with or without corners among them): its bends
    // as a chain (bendsAround: the path within bendTol, its corners kept), in place of its tangent
    // or of its corners' straight legs. Its span is the window's: another pass of the path within
    // it is on its legs. (A chain that another pass joined keeps its corners.)
    thread_local std::vector<ScratchPath::Corner> bends;
    thread_local std::vector<char> bent;
    bent.assign(near.size(), 0);
    thread_local std::vector<std::vector<ScratchPath::Corner>> pass_bends;
    if (pass_bends.size() < near.size()) pass_bends.resize(near.size());
    const double fp_uv = double(footprintOf(sp));  // the footprint's radius (uv)
    for (size_t i = 0; i < near.size() && with_bends; ++i) {
      if (merged_into[i] != size_t(-1)) continue;
      const NearGroove& ng = near[i];
      const ScratchPath& path = ng.sc->path();
      std::pair<double, double> span;
      // (A pass with corners in reach stands its corners' legs, each straight along its segment,
      // not the tangent: its path is looked at for bends however near it stays to the tangent. A
      // cubic's hairpin tip flattened into eight corners of 12-17 degrees ran its last leg straight
      // on where the path curves away, through flat plate 0.1 mm off it: a glint on the passes
      // fuzzer's p3_18, 0.39% of pixels >= 10, 0% with its bends; docs/grooves.md, "Bends".)
      const double min_stray =
          has_corner[i] ? 0.0
                        : kBendStray * std::max(ng.sc->referenceProfile().halfExtent() * double(ng.sc->maxScale()), fp_uv);
      // Where chainParts refuses the chain at its caps, fewer bends before none: the tangent across
      // a tight curl stands a straight groove over it.
      for (size_t max_bends = kMaxBends; max_bends >= kMinBends && !bent[i]; max_bends /= 2) {
        if (!path.bendsAround(double(ng.pp.s), F, corner_reach, kBendTol * fp_uv, kBendGrowth, min_stray, max_bends,
                              kBendDev, bends, span, kBendNear * fp_uv, kNearBends * max_bends))
          break;
        // Just the corners chainRange found: those.
        bool same = has_corner[i] && bends.size() == chain[i][2] - chain[i][1] + 1;
        for (size_t k = 0; k < bends.size() && same; ++k) same = bends[k].vertex == path.corners()[chain[i][1] + k].vertex;
        bool faded = false;
        for (const ScratchPath::Corner& c : bends) faded = faded || !(ng.sc->scaleAt(float(c.s)) > 0);
        if (same || faded) break;
        corner_profile[i] = profiles.size();
        if (chainGroove(sp, ng, int(i), bends.data(), bends.size(), span.first, span.second, true, bound, gs, mm,
                        profiles, corner_parts[i], corner_g[i])) {
          has_corner[i] = bent[i] = 1;
          pass_bends[i] = bends;
          corner_span[i] = span;
          // A later pass joined to its chain (merged_into) that lies outside the window, which the
          // bends do not hold, is a pass of its own again, with its own corners, and is looked at
          // for bends when the loop comes to it. (Until the forty-fifth session such a window gave
          // up the bends, and both passes stood their corners' straight legs: on a cubic loop with
          // two corners, a leg ran straight across the loop, a groove 0.06 mm off the path; the
          // passes fuzzer's p45_3, glass seen at 1 degree under the back light, 2.43% of pixels
          // >= 10, 0% now; docs/grooves.md, "Bends".)
          for (size_t j = i + 1; j < near.size(); ++j)
            if (merged_into[j] == i && !(double(near[j].pp.s) >= span.first && double(near[j].pp.s) <= span.second)) {
              merged_into[j] = size_t(-1);
              has_corner[j] = 1;
              chain[j] = own[j];
            }
        } else {
          profiles.resize(corner_profile[i]);
        }
      }
    }
    for (size_t i = 0; i < near.size(); ++i)
      if (has_corner[i] && !bent[i]) build(i, chain[i]);
    // Where the joined chain could not be built (past chainParts' caps: cornerGroove fell back to
    // one corner), a pass that it would have held takes its own corner groove again.
    for (size_t j = 0; j < near.size(); ++j) {
      const size_t i = merged_into[j];
      if (i == size_t(-1)) continue;
      const double sj = double(near[j].pp.s);
      if (!has_corner[i] || sj < corner_span[i].first || sj > corner_span[i].second) build(j, own[j]);
    }
    // A path whose passes near the footprint lie apart along it, one of them with bends or corners
    // (a loop whose far side is out of the window; a leg that crosses the path's earlier leg next to
    // a corner): one groove of all their runs (chainParts with run_starts), each pass's bends,
    // corners or straight groove, as passParts does for two straight passes. (Composited, each
    // pass's pile-up stood over the other's groove where they cross: the accuracy test's `loop`
    // under the bar, 0.065% of pixels >= 10 without bends, 0.26% with them apart; its `hook` under
    // the bar, whose corner's legs were joined only since 2026-11-29, 0.55% composited.)
    thread_local std::vector<char> joined;
    joined.assign(near.size(), 0);
    thread_local std::vector<size_t> members, run_starts;
    thread_local std::vector<ga::Groove> run_legs;
    thread_local std::vector<std::vector<ga::Groove>> run_parts;
    if (run_parts.size() < near.size()) run_parts.resize(near.size());
    thread_local std::vector<float> run_dist;  // the nearest of a joined groove's passes
    run_dist.assign(near.size(), -1.0f);
    // (A pass joins with its bends or its corners; the path is taken once, at the first such pass.)
    auto joins = [&](size_t j) { return bent[j] || (has_corner[j] && merged_into[j] == size_t(-1)); };
    for (size_t i = 0; i < near.size(); ++i) {
      if (!joins(i)) continue;
      const Scratch* sc = near[i].sc;
      bool first = true;  // i is its path's first pass with bends or corners
      for (size_t j = 0; j < i; ++j) first = first && !(joins(j) && near[j].sc == sc);
      if (!first) continue;
      // The path's passes, less those joined to a chain and those on another's legs.
      members.clear();
      for (size_t j = 0; j < near.size(); ++j) {
        if (near[j].sc != sc || merged_into[j] != size_t(-1)) continue;
        bool on_legs = false;
        for (size_t m = 0; m < near.size() && !on_legs; ++m)
          on_legs = m != j && near[m].sc == sc && has_corner[m] && merged_into[m] == size_t(-1) &&
                    double(near[j].pp.s) >= corner_span[m].first && double(near[j].pp.s) <= corner_span[m].second;
        if (!on_legs) members.push_back(j);
      }
      // The joined groove stands in the place of the first member with bends or corners (i itself,
      // unless i lies on another pass's legs).
      const auto at = std::find_if(members.begin(), members.end(), joins);
      if (members.size() < 2 || at == members.end()) continue;
      const size_t a = *at;
      const size_t profiles_at = profiles.size();
      run_legs.clear();
      run_starts.clear();
      bool ok = true;
      for (size_t j : members) {
        if (!run_legs.empty()) run_starts.push_back(run_legs.size());
        const NearGroove& ng = near[j];
        const ScratchPath& path = ng.sc->path();
        if (bent[j]) {
          const auto& b = pass_bends[j];
          ok = chainLegs(sp, ng, int(a), b.data(), b.size(), corner_span[j].first, corner_span[j].second, true, gs, mm,
                         profiles, run_legs);
        } else if (has_corner[j]) {
          const auto& cs = path.corners();
          const size_t lo = chain[j][1], hi = chain[j][2];
          ok = chainLegs(sp, ng, int(a), &cs[lo], hi - lo + 1, path.legSpan(cs[lo]).first, path.legSpan(cs[hi]).second,
                         false, gs, mm, profiles, run_legs);
        } else {
          const float k = ng.sc->scaleAt(ng.pp.s);
          ga::Groove g;
          ok = k > 0 && straightGroove(sp, ng, int(a), k, gs, mm, profiles, g);
          if (ok) run_legs.push_back(g);
        }
        if (!ok) break;
      }
      // Without bends, only where two runs' legs come within the groove's width of each other
      // within the region (its square, in the disc about F that holds it): elsewhere the composite
      // of their grooves is the partition's surface, at a fraction of its cost. (The accuracy
      // test's `zigzag` under the bar, whose corners' legs lie 0.4 mm apart, took 1.3 times its
      // time joined everywhere, for the same figures.) Until the fifty-ninth session this looked
      // only where the footprint can be seen from (the view's reach, not the lights'), which the
      // camera rays see right; but the footprint's reflected rays cross the whole region, and
      // there the composite stood one pass's pile-up over the other's where the nearer pass holds:
      // in the corner fuzzer's c78_3 (legs 0.19 mm apart, ring light, 1 degree) the outer flank of
      // one leg's pile-up mirrored the ring into the other leg's wall, 0.69% of pixels >= 10
      // against geometry at 2,048 spp, 0% joined (docs/grooves.md, "A path that comes back").
      bool touch = false;
      for (size_t j : members) touch = touch || bent[j];
      if (ok && !touch) {
        const double w = 2 * sc->referenceProfile().halfExtent() * double(sc->maxScale()) * mm;  // (profile in uv)
        const double r = fp_r + (reach_max + grow) * std::sqrt(2.0);
        for (size_t k = 0, run_k = 0; k < run_legs.size() && !touch; ++k) {
          while (run_k < run_starts.size() && run_starts[run_k] <= k) ++run_k;  // leg k is in run run_k
          const size_t next = run_k < run_starts.size() ? run_starts[run_k] : run_legs.size();
          for (size_t m = next; m < run_legs.size() && !touch; ++m)
            touch = ga::centreLinesWithin(run_legs[k], run_legs[m], r + w, w);
        }
      }
      if (ok && touch &&
          ga::chainParts(run_legs, fanSector(run_legs.data(), run_legs.size(), gs), bound, run_parts[a], run_starts)) {
        corner_g[a] = run_legs.front();
        corner_g[a].parts = &run_parts[a];
        corner_profile[a] = profiles_at;
        run_dist[a] = near[a].pp.distance;
        for (size_t j : members) {
          joined[j] = j != a;
          run_dist[a] = std::min(run_dist[a], near[j].pp.distance);
        }
      } else {
        profiles.resize(profiles_at);
      }
    }
    // A path that passes the footprint more than once (nearGrooves) has a groove for each pass.
    // Where one pass enters as a corner its legs run to the next corners (or its chain's ends), so
    // another pass whose closest point lies on them is in it already; as a groove of its own it
    // would also run straight past the corner. Such a pass is left out, unless it enters as a
    // corner itself and comes first.
    thread_local std::vector<char> in_corner;
    in_corner.assign(near.size(), 0);
    for (size_t i = 0; i < near.size(); ++i)
      for (size_t j = 0; j < near.size() && !in_corner[i]; ++j) {
        if (j == i || near[j].sc != near[i].sc || !has_corner[j]) continue;
        const double si = double(near[i].pp.s);
        in_corner[i] = si >= corner_span[j].first && si <= corner_span[j].second && (j < i || !has_corner[i]);
      }
    for (size_t i = 0; i < near.size(); ++i) {
      if (in_corner[i] || joined[i]) continue;
      NearGroove ng = near[i];
      ga::Groove g;
      // A corner within the region: its legs and cap (cornerGroove), whole. Else the groove along
      // its tangent at the closest point, in pieces where its scale is far from linear.
      const bool corner = has_corner[i];
      if (corner) g = corner_g[i];
      float k = 0;
      if (!corner) {
        k = ng.sc->scaleAt(ng.pp.s);
        if (!(k > 0) && !(k = depthInward(sp, along_uv, ng))) continue;
        if (!straightGroove(sp, ng, int(i), k, gs, mm, profiles, g)) continue;
      }
      // How near the footprint's centre the cross-section comes (mm; <= 0 over it).
      const auto& q = (corner ? profiles[corner_profile[i]] : profiles.back()).pts;
      grooves.push_back(g);
      near_mm.push_back(double(run_dist[i] >= 0 ? run_dist[i] : ng.pp.distance) * mm -
                        std::max(std::fabs(q.front().x), std::fabs(q.back().x)));
      if (corner) {
        segs.push_back(g);
      } else {
        // A scale error that moves the groove's height by less than twice the footprint's radius
        // over the steepest light's tangent moves no shadow edge by more than that: the tangent is
        // kept. (With one footprint radius instead of two the ends scenes of the accuracy test,
        // whose 0.6 mm fades change none of their figures either way, took 1.3-1.4 times their
        // time at 1 spp; with two, 1.2 times.)
        const Profile& rp = ng.sc->referenceProfile();
        const double h_ref = std::max(rp.depth(), rp.peakHeight());
        const float tol_abs = h_ref > 0 ? float(2 * fp_r / (double(tan_light_max_) * h_ref)) : 1e30f;
        scaleSegments(ng, k, g, along_uv * float(M_SQRT2), mm, tol_abs, profiles, segs);
      }
      seg_at.push_back(segs.size());
    }
    // Two passes of one path, each straight: one groove of parts (ga::passParts), each pass where
    // it is the nearer, as the explicit geometry has them; as two grooves the composite would
    // stand one pass's pile-up over the other's (docs/grooves.md, "A path that comes back"). A pass
    // in pieces (scaleSegments: within a force fade, which a path's default 2 mm at each end makes
    // common) keeps them, each over its stretch of the pass (ga::passPieces), in the round with
    // pieces below; the whole grooves take passParts. (Until 2026-11-29 such passes were left
    // composited: a polyline doubling back by 179 degrees showed, from 0.84 mm out from its vertex,
    // the returning leg's lit wall where the nearer leg cuts it away; 2.39% of pixels >= 10 against
    // geometry at 512 spp, 0.38% with this split, the rest at its tip; docs/grooves.md, "Passes in
    // pieces".)
    thread_local std::vector<std::vector<ga::Groove>> pass_parts;
    if (pass_parts.size() < 2 * grooves.size()) pass_parts.resize(2 * grooves.size());  // (no reallocation below)
    size_t npass = 0;
    auto single = [&](size_t i) {
      if (grooves[i].parts || seg_at[i + 1] - seg_at[i] != 1) return false;
      const ga::Groove &g = grooves[i], &q = segs[seg_at[i]];  // (one piece, and the groove itself)
      return q.pts == g.pts && q.t0 == g.t0 && q.rho == g.rho && q.t_lo == g.t_lo && q.t_hi == g.t_hi;
    };
    // Groove b joined to groove a: b and its pieces leave the lists (a's nearness takes b's).
    auto drop = [&](size_t a, size_t b) {
      const size_t nb = seg_at[b + 1] - seg_at[b];
      near_mm[a] = std::min(near_mm[a], near_mm[b]);
      grooves.erase(grooves.begin() + long(b));
      near_mm.erase(near_mm.begin() + long(b));
      segs.erase(segs.begin() + long(seg_at[b]), segs.begin() + long(seg_at[b + 1]));
      seg_at.erase(seg_at.begin() + long(b) + 1);
      for (size_t k = b + 1; k < seg_at.size(); ++k) seg_at[k] -= nb;
    };
    // Three or more straight, whole passes of one path (a path zigzagging back and forth past the
    // footprint): one partition (chainParts, each pass a run of one leg), each pass where it is the
    // nearest. (Pairs of them composited with the rest, a zigzag whose three legs lie 0.1 mm apart
    // gave 0.68% of pixels >= 10 against geometry where the sections, which split any number of
    // passes, took it, and 8.4% where the polygons did.)
    thread_local std::vector<size_t> many;
    thread_local std::vector<std::vector<ga::Groove>> many_parts;
    thread_local std::vector<ga::Groove> many_legs;
    thread_local std::vector<size_t> many_starts;
    if (many_parts.size() < grooves.size()) many_parts.resize(grooves.size());  // (no reallocation below)
    size_t nmany = 0;
    for (size_t a = 0; a < grooves.size(); ++a) {
      if (!single(a)) continue;
      many.assign(1, a);
      for (size_t b = a + 1; b < grooves.size(); ++b)
        if (single(b) && near[size_t(grooves[b].id)].sc == near[size_t(grooves[a].id)].sc) many.push_back(b);
      if (many.size() < 3) continue;
      many_legs.clear();
      many_starts.clear();
      for (size_t k = 0; k < many.size(); ++k) {
        if (k) many_starts.push_back(k);
        many_legs.push_back(grooves[many[k]]);
      }
      if (!ga::chainParts(many_legs, fanSector(many_legs.data(), many_legs.size(), gs), bound, many_parts[nmany],
                          many_starts))
        continue;
      grooves[a].parts = &many_parts[nmany++];
      segs[seg_at[a]] = grooves[a];
      for (size_t k = many.size() - 1; k >= 1; --k) drop(a, many[k]);  // (the others, last first)
    }
    for (size_t a = 0; a < grooves.size(); ++a) {
      if (grooves[a].parts) continue;  // (a corner's groove)
      for (size_t b = a + 1; b < grooves.size(); ++b) {
        if (grooves[b].parts || near[size_t(grooves[b].id)].sc != near[size_t(grooves[a].id)].sc) continue;
        if (!ga::passParts(grooves[a], grooves[b], pass_parts[npass])) continue;
        const bool in_pieces = !single(a) || !single(b);
        const size_t na = seg_at[a + 1] - seg_at[a];
        if (in_pieces &&
            !ga::passPieces(&segs[seg_at[a]], na, &segs[seg_at[b]], seg_at[b + 1] - seg_at[b], pass_parts[npass + 1]))
          continue;
        grooves[a].parts = &pass_parts[npass];
        ga::Groove by_pieces = grooves[a];
        if (in_pieces) by_pieces.parts = &pass_parts[npass + 1];
        npass += in_pieces ? 2 : 1;
        // b's pieces go, a's become the one groove of both.
        drop(a, b);
        segs.erase(segs.begin() + long(seg_at[a]) + 1, segs.begin() + long(seg_at[a + 1]));
        for (size_t k = a + 1; k < seg_at.size(); ++k) seg_at[k] -= na - 1;
        segs[seg_at[a]] = by_pieces;
        break;
      }
    }
    // A groove left in several pieces (scaleSegments) enters the pieces' surface as one groove of
    // parts (ga::pieceParts), so that it counts as one groove against the surface's cap of
    // grooves, as it does whole. (Six scratches of three pieces each, 18 grooves, passed that cap
    // of 16 where the six whole did not, so the region took them whole, their fading ends at full
    // depth: the clusters fuzzer's c56_1, docs/grooves.md, "Pieces count as one groove".)
    thread_local std::vector<std::vector<ga::Groove>> piece_parts;
    if (piece_parts.size() < grooves.size()) piece_parts.resize(grooves.size());  // (no reallocation below)
    for (size_t i = 0, np = 0; i < grooves.size(); ++i) {
      const size_t n = seg_at[i + 1] - seg_at[i];
      if (n < 2 || !ga::pieceParts(&segs[seg_at[i]], n, piece_parts[np])) continue;
      ga::Groove one = segs[seg_at[i]];
      one.parts = &piece_parts[np++];
      segs.erase(segs.begin() + long(seg_at[i]) + 1, segs.begin() + long(seg_at[i + 1]));
      for (size_t k = i + 1; k < seg_at.size(); ++k) seg_at[k] -= n - 1;
      segs[seg_at[i]] = one;
    }
    if (grooves.empty()) return false;
    // The region whose surface can be seen, or can hide or shadow what is seen (§4.2.1): the
    // footprint's box enlarged by `enlarge`. Where its pieces pass the cap (many grooves close
    // together, cut pile-ups), the reach toward the lights is halved, then quartered, before the
    // nearest grooves alone (below) and the blend are used: a shadow cast from farther is lost,
    // and a ray reflected up out of the region leaves the grooves (one going down goes on in a
    // single groove's section, beyondRegion), but the crossing itself is still integrated
    // exactly. The reach toward the viewer (`view_reach`) is always kept, so what hides the
    // footprint is never lost. A smaller region also leaves out the grooves that do not
    // reach it (they add no piece), which counts for the cap of grooves per footprint (16 since
    // 2026-11-30: with 8, a dozen scratches seen close lost the shadows of those beyond half the
    // reach; docs/grooves.md, "Sixteen grooves"). On the accuracy test's `dense` scene (6 + 6
    // crossing scratches under the bar light) no footprint falls back any more, and the pixels
    // >= 10 went from 2.27% to 0.02% (docs/grooves.md, "Cost bound and fallback").
    if (!gs.surface_built) {
      std::swap(gs.surface, spareSurface());
      gs.surface_built = true;
    }
    auto square = [&](double R) {
      ga::Poly region;
      region.push({lo.x - R, lo.y - R});
      region.push({hi.x + R, lo.y - R});
      region.push({hi.x + R, hi.y + R});
      region.push({lo.x - R, hi.y + R});
      return region;
    };
    bool tried = false;  // a build was refused at the caps
    thread_local std::vector<size_t> order;  // the grooves within the last reach tried
    // Each reach, from the largest, first with the grooves in pieces along their paths where their
    // scale is far from linear (scaleSegments), then, where that passed the caps (a groove's pieces
    // add pieces of the surface, not grooves: they are one groove of parts), with every groove
    // whole, as before 2026-11-28. The reach comes first: the pieces
    // refine a groove's depth along its path, while a smaller region loses the walls beyond it
    // that shadow the footprint or send it light. The clusters fuzzer's c52_5 (17 scratches
    // crossing near the view's centre, ring light, 2 degrees) took the pieces at a quarter of the
    // reach where the grooves whole fitted at half of it: its bands of crossings lost the ring's
    // light bounced off walls beyond 0.18 mm, 0.78% of pixels >= 10 (mean dE 0.96) against 0.13%
    // (0.49) this way (docs/grooves.md, "Accuracy", the fuzzing of sessions 49 and 50).
    // Whether a groove within the largest reach is in pieces (else the second round would build
    // the same surfaces again).
    // (A groove's pieces differ from it where there are several, or where they are one groove of
    // parts of its own: two passes in pieces, passPieces.)
    auto pieced = [&](size_t i) {
      return seg_at[i + 1] - seg_at[i] != 1 || segs[seg_at[i]].parts != grooves[i].parts;
    };
    bool split = false;
    for (size_t i = 0; i < grooves.size(); ++i)
      split = split || (near_mm[i] <= reach_max * std::sqrt(2.0) + fp_r && pieced(i));
    // Seen close (the full reach at least kCloseReach pixel radii), each reach may take
    // kMaxPiecesClose pieces instead of kMaxPieces. There a pixel sees a single facet's image, and
    // the light it gets over facets beyond a smaller region shows as whole regions gone dark: the
    // passes fuzzer's loop p1_11 seen at 1 degree kept 7.1% of pixels >= 10 at the ordinary cap
    // and 3.5% at this one; eight deep grooves through one spot seen at 1 degree (most footprints
    // past the ordinary cap at every reach) 22.5% and 1.0%. Both took 2 to 2.4 times as long.
    // Where the smaller region leaves out a groove that shadows the footprint, a glint runs on
    // into the shadow (c41_7 at 22 micrometres per pixel: 0.56% and 0%, 1.4 times the time).
    // Farther away the larger cap cost up to twice the time and changed nothing that showed (100
    // fuzzer layouts at 48 x 48 and 3 to 10 degrees: mean dE 0.203 -> 0.208 over them), so it is
    // kept for close views (docs/grooves.md, "Cost bound and fallback"). The nearest grooves'
    // surfaces below keep the ordinary cap.
    size_t cap = double(enlarge) >= kCloseReach * gs.pixel_r ? ga::Surface::kMaxPiecesClose
                                                             : ga::Surface::kMaxPieces;
    if (grow > 0) cap = size_t(double(cap) * ((reach_max + grow) / reach_max) * ((reach_max + grow) / reach_max));
    if (built) *built = 0;
    double tried_at[2] = {-1, -1};  // the last reach tried in pieces [0] and whole [1]
    for (double f : {1.0, 0.5, 0.25}) {
      const double R = std::max(double(view_reach), f * double(enlarge)) + 1e-3 + grow;
      for (int whole = split ? 0 : 1; whole < 2; ++whole) {
        if (R == tried_at[whole]) continue;  // the view's reach is larger: the same region again
        tried_at[whole] = R;
        order.clear();
        within.clear();
        for (size_t i = 0; i < grooves.size(); ++i)
          if (near_mm[i] <= R * std::sqrt(2.0) + fp_r) {
            order.push_back(i);
            if (whole)
              within.push_back(grooves[i]);
            else
              within.insert(within.end(), segs.begin() + long(seg_at[i]), segs.begin() + long(seg_at[i + 1]));
          }
        if (within.empty()) continue;
        if (gs.surface.build(square(R), within, cap)) {
          if (built) *built = R;
          return true;
        }
        tried = true;
      }
    }
    // Past the caps at every reach (a dense cluster: more than 16 grooves within the smallest one,
    // or too many pieces): the polygons over the smallest region with only the grooves nearest the
    // footprint's centre, 16, then 8, 6 and 4 of them. The footprint's own surface stays exact as
    // long as no more grooves than that pass through it; what is lost is the shadows and
    // reflections of the farther ones. Only past that too does the footprint go to the blend,
    // which keeps at most three directions and no shadows between grooves (on the fuzzer's
    // cluster c10_15, 8.8% of its footprints past the caps: 5.2% of pixels >= 10 with the blend,
    // 0.69% this way, for 1.3 times the time; docs/grooves.md, "Cost bound and fallback").
    // With bends, first without them (each pass its tangent and its pieces, or its corners), before
    // any groove is left out: the bends are a refinement, the grooves' shadows are not (the
    // accuracy test's `tips` under the bar had one footprint past the caps with its bends).
    if (std::count(bent.begin(), bent.end(), 1))
      return buildRegion(sp, near, enlarge, view_reach, gs, false, nullptr, grow);
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return near_mm[a] < near_mm[b]; });
    for (size_t n : {ga::Surface::kMaxGrooves, ga::Surface::kSmallGrooves, size_t(6), size_t(4)}) {
      if (n >= order.size()) continue;  // as many as that were tried above
      within.clear();
      for (size_t k = 0; k < n; ++k) within.push_back(grooves[order[k]]);
      if (gs.surface.build(square(tried_at[1]), within)) return gs.trimmed = true;  // the smallest
    }
    gs.capped = tried;
    return false;
  }

  // tan of the angle from the section's direction T to a groove's (t_uv, taken T's way) on the
  // surface, towards B (groove::PlacedProfile::turn). Below 1e-6 it is float noise of parallel
  // paths and counts as 0, so that their sections keep no tilt.
  static double turnFrom(const SurfacePoint& sp, Vec3f T, Vec3f B, Vec2f t_uv) {
    const Vec3f t = sp.dpdu * t_uv.x + sp.dpdv * t_uv.y;
    const double c = dot(t, T), s = dot(t, B);
    if (!(c > 0)) return 0;
    const double turn = s / c;
    return std::fabs(turn) < 1e-6 ? 0.0 : turn;
  }

  // The section of the grooves parallel to near[ref] (within 2 degrees), in its frame. Each keeps
  // its own direction's facet normals (turnFrom).
  bool buildSet(const SurfacePoint& sp, const std::vector<NearGroove>& near, size_t ref, float enlarge,
                GrooveSet& gs) const {
    Vec2f t0 = near[ref].pp.tangent;
    if (!grooveFrame(sp, t0, gs.T, gs.B, gs.W)) return false;
    gs.F = sp.p;
    const float mm = sp.mm_per_uv;
    gs.fp = footprintAcross(sp, gs.B);
    // (merge() copies what it keeps, so the buffers are reused from set to set.)
    thread_local std::vector<Profile> profiles;
    thread_local std::vector<groove::PlacedProfile> placed, placed_without;
    thread_local std::vector<const Scratch*> placed_sc;  // each placed profile's scratch
    thread_local std::vector<char> placed_whole;         // and whether it runs through the footprint
    profiles.clear();
    placed.clear();
    placed_without.clear();
    placed_sc.clear();
    placed_whole.clear();
    profiles.reserve(near.size());
    double reach_b = gs.fp.halfWidth() + enlarge + max_half_ * mm;
    float end_share = 1.0f;
    for (const NearGroove& ng : near) {
      float c = t0.x * ng.pp.tangent.x + t0.y * ng.pp.tangent.y;
      if (!parallel(t0, ng.pp.tangent)) continue;  // another direction: its own set
      float sign = c >= 0 ? 1.0f : -1.0f;
      float k = ng.sc->scaleAt(ng.pp.s);
      if (!(k > 0)) continue;
      Profile p = surfaceProfile(ng, mm);
      double offset = -double(sign) * ng.pp.offset * mm;
      if (std::fabs(offset) > reach_b + p.halfExtent()) continue;
      // An end inside the footprint: the share of the footprint along T that the groove covers,
      // the masks' (endShare). Until 2026-11-28 it was taken only where the footprint's centre lay
      // past the end; one just before a blunt end took the groove through the whole footprint
      // (on the ends scene with blunt ends, fade_mm 0, under the ring at 4 spp: the largest dE
      // 8.4 -> 3.4 against geometry at 1024 spp; docs/grooves.md, "Crossings and ends").
      float share = endShare(sp, gs.T, ng);
      if (share <= 0) continue;
      profiles.push_back(std::move(p));
      groove::PlacedProfile pl;
      pl.pts = &profiles.back().pts;
      pl.layer = &profiles.back().layer;
      pl.offset = offset;
      pl.mirrored = sign < 0;
      // A changing scale tilts the facets along the path (Section::tilt; the sign turns it to t0's
      // way).
      pl.rho = double(sign) * scaleSlope(ng, k, mm);
      pl.turn = turnFrom(sp, gs.T, gs.B, ng.pp.tangent * sign);
      placed.push_back(pl);
      placed_sc.push_back(ng.sc);
      placed_whole.push_back(share >= 1.0f);
      if (share < 1.0f) end_share = std::min(end_share, share);
    }
    if (placed.empty()) return false;
    // Two passes of one path (nearGrooves): each on its side of their midline, the nearer pass,
    // as the explicit geometry has them; composited, a pass's groove took the other's pile-up
    // away where they overlap (a hairpin with legs 0.12 mm apart, 0.18 mm wide grooves: 6.1% of
    // pixels >= 10 under the bar; docs/grooves.md, "A path that comes back").
    for (size_t i = 0; i < placed.size(); ++i)
      for (size_t j = 0; j < placed.size(); ++j) {
        if (j == i || placed_sc[j] != placed_sc[i]) continue;
        const double oi = placed[i].offset, oj = placed[j].offset, m = 0.5 * (oi + oj);
        const double s_i = placed[i].mirrored ? -1.0 : 1.0;  // section x = offset + s_i b
        const bool left = oi < oj || (oi == oj && i < j);    // keeps x <= m
        profiles[i].keepSide(s_i * (m - oi), (s_i > 0) == left);
      }
    for (size_t i = 0; i < placed.size(); ++i)
      if (placed_whole[i]) placed_without.push_back(placed[i]);
    double extent = sectionExtent(reach_b);
    gs.section = groove::merge(placed, extent);
    gs.end_share = end_share;
    if (end_share < 1.0f) gs.section_without = groove::merge(placed_without, extent);
    return true;
  }

  // Where rays from a footprint's grooves start for the rest of the scene: above the highest
  // pile-up at the footprint centre.
  Vec3f aboveGrooves(const GrooveSet& gs) const { return gs.F + gs.W * (max_height_ + rayEpsilon(gs.F)); }
  // And where rays refracted into a glass part start: just inside the part's surface at the
  // footprint centre. They go down into the solid; the share that meets the grooves again from
  // inside was taken out before (throughGrooves).
  Vec3f insideGrooves(const GrooveSet& gs) const { return gs.F - gs.W * rayEpsilon(gs.F); }

  // One light sample shared by every facet of the footprint.
  struct LightSample {
    Vec3f wl;      // world direction from the footprint centre
    Rgb Le;        // radiance
    float pdf;     // solid angle
    bool visible;  // not occluded by the rest of the scene (tested once, from above the grooves)
    int k;         // its index among the light's stratified samples
    bool env;      // a sample of the environment (not of an area light)
  };
  // A footprint's light samples, and the guides they were drawn with (buildGuides; null: uniform),
  // whose density the MIS weights of the footprint's BSDF directions must count.
  struct LightSamples : std::vector<LightSample> {
    const LightGuides* guides = nullptr;
  };

  // The shading frame of a facet of normal N: about the groove's direction T, or where the camera
  // hit drew a resolved flake's lobe, about the surface's dpdu (GrooveSet::frame_t) carried onto
  // the facet as the explicit geometry's cut triangles carry it (groove::facetTangent).
  static Frame facetFrame(const GrooveSet& gs, Vec3f N) {
    return Frame::fromNormalTangent(N, gs.frame_t ? groove::facetTangent(*gs.frame_t, gs.W, N) : gs.T);
  }
  // The normal of the uncut surface at (t, b) of a groove set's frame: W tilted by the clear coat's
  // orange peel there (GrooveSet::paint), as applyDefects tilts a camera hit's. The peel is
  // filtered over the pixel's footprint, or over `extent` (mm) where a portion is larger.
  static Vec3f flatNormal(const GrooveSet& gs, double t, double b, double extent = 0) {
    const Vec2f uv = gs.uv0 + gs.uv_t * float(t) + gs.uv_b * float(b);
    const Vec2f h = gs.paint->coatHeightGrad(uv, std::max(gs.paint_fp, float(extent)));
    return normalize(gs.W - gs.peel_u * h.x - gs.peel_v * h.y - gs.bump);
  }
  // A facet's normal n tilted by the other defects' slope (GrooveSet::bump), taken in its plane.
  static Vec3f bumped(const GrooveSet& gs, Vec3f n) {
    if (gs.bump.x == 0 && gs.bump.y == 0 && gs.bump.z == 0) return n;
    return normalize(n - (gs.bump - n * dot(n, gs.bump)));
  }
  // Gives a camera hit's groove sets the chart about F (GrooveSet::uv0), in each one's frame.
  static void setUvMap(const SurfacePoint& sp, std::vector<GrooveSet>& sets) {
    Vec3f pu, pv;
    dualBasis(sp, pu, pv);
    for (GrooveSet& gs : sets) {
      gs.uv0 = sp.uv;  // (F is the hit)
      gs.uv_t = Vec2f(dot(gs.T, pu), dot(gs.T, pv));
      gs.uv_b = Vec2f(dot(gs.B, pu), dot(gs.B, pv));
      gs.mm_per_uv = sp.mm_per_uv;
    }
  }
  // Gives a camera hit's groove sets the peel (GrooveSet::paint), in each one's frame (after
  // setUvMap).
  void setPeel(const SurfacePoint& sp, float fp, std::vector<GrooveSet>& sets) const {
    Vec3f pu, pv;
    dualBasis(sp, pu, pv);
    // surfaceGradient of unit steps in u and v, without computing the dual basis twice more.
    const Vec3f gu = inShadingPlane(sp, pu), gv = inShadingPlane(sp, pv);
    for (GrooveSet& gs : sets) {
      gs.paint = s_.paint.get();
      gs.peel_u = gu, gs.peel_v = gv;
      gs.paint_fp = fp;
    }
  }
  // The two ways of integrating over a footprint share the shading below (shadeLevel); they
  // differ in their geometry, given by these policies: the facet normal and layer of a portion,
  // its lit fraction for light sample li, and where rays leaving it in a direction go.
  // 1-D line sampling over one merged section (Bosch §4.2.3).
  struct LineGeometry {
    using Portion = groove::Portion;
    using Scatter = groove::Scatter;
    const GrooveSet& gs;
    const groove::Section& sec;
    const std::vector<groove::Shadowing>& shadow;  // per light sample
    Vec3f normal(const Portion& p) const {
      const size_t k = size_t(p.facet);
      if (gs.paint && flat(k)) {
        const double b0 = groove::pointOn(sec, p.facet, p.t0).x, b1 = groove::pointOn(sec, p.facet, p.t1).x;
        return flatNormal(gs, 0.0, 0.5 * (b0 + b1), std::fabs(b1 - b0));
      }
      return facetNormal(k);
    }
    // The uncut base (w = 0 at both ends: the explicit geometry's triangles there have height 0).
    bool flat(size_t k) const { return sec.pts[k].y == 0 && sec.pts[k + 1].y == 0; }
    int layer(const Portion& p) const { return facetLayer(size_t(p.facet)); }
    double lit(const Portion& p, size_t li) const { return shadow[li].litFraction(p, gs.fp); }
    groove::Scatter scatter(const Portion& p, Vec3f d) const {
      return groove::scatter(sec, p, gs.fp, Vec2d(dot(d, gs.B), dot(d, gs.W)));
    }
    // Where rays refracted into the solid at p go (throughGrooves).
    groove::Scatter scatterInside(const Portion& p, Vec3f d) const {
      return groove::scatterInside(sec, p, gs.fp, Vec2d(dot(d, gs.B), dot(d, gs.W)));
    }
    // The facets (a portion lies on one), which a chain direction may aim at (Chain): every facet
    // of the section, the flat ones too (a groove's bottom and the plate between grooves also
    // mirror a bar into the walls).
    size_t facets() const { return sec.facets(); }
    Vec3f facetNormal(size_t k) const {
      // A flat facet's peel where it comes nearest the footprint's centre.
      if (gs.paint && flat(k)) return flatNormal(gs, 0.0, std::clamp(0.0, sec.pts[k].x, sec.pts[k + 1].x));
      Vec2d n2 = sec.normal(k);
      const double tilt = sec.tiltOf(k);
      if (tilt == 0) return bumped(gs, gs.B * float(n2.x) + gs.W * float(n2.y));
      return bumped(gs, normalize(gs.T * float(tilt) + gs.B * float(n2.x) + gs.W * float(n2.y)));
    }
    int facetLayer(size_t k) const { return sec.layer[k]; }
    // Whether facet k and portion p face each other (each has a point in front of the other's line).
    bool faces(size_t k, const Portion& p) const {
      const Vec2d k0 = groove::pointOn(sec, int(k), 0.0), k1 = groove::pointOn(sec, int(k), 1.0);
      const Vec2d p0 = groove::pointOn(sec, p.facet, p.t0), p1 = groove::pointOn(sec, p.facet, p.t1);
      const Vec2d nk = sec.normal(k), np = sec.normal(size_t(p.facet));
      const double eps = 1e-12;
      return std::max(dot(k0 - p0, np), dot(k1 - p0, np)) > eps && std::max(dot(p0 - k0, nk), dot(p1 - k0, nk)) > eps;
    }
  };
  // Area sampling with polygons at crossings and ends (Bosch §4.2.4).
  struct AreaGeometry {
    using Portion = groove::area::Portion;
    using Scatter = groove::area::Hits;
    const GrooveSet& gs;
    const std::vector<Vec3d>& light;  // per light sample, in (T, B, W)
    Vec3d local(Vec3f d) const { return Vec3d(dot(d, gs.T), dot(d, gs.B), dot(d, gs.W)); }
    Vec3f normal(const Portion& p) const {
      Vec2d c;
      if (gs.paint && flat(size_t(p.piece)) && groove::area::centroid(p.frags, c))
        return flatNormal(gs, c.x - gs.org.x, c.y - gs.org.y, std::sqrt(groove::area::area(p.frags)));
      return facetNormal(size_t(p.piece));
    }
    // A piece at the base height (the uncut surface).
    bool flat(size_t k) const {
      const groove::area::Plane& pl = gs.surface.pieces()[k].plane;
      return pl.z0 == 0 && pl.g.x == 0 && pl.g.y == 0;
    }
    int layer(const Portion& p) const { return facetLayer(size_t(p.piece)); }
    double lit(const Portion& p, size_t li) const { return gs.surface.litFraction(p, light[li], li); }
    groove::area::Hits scatter(const Portion& p, Vec3f d) const { return gs.surface.scatter(p, local(d)); }
    groove::area::Hits scatterInside(const Portion& p, Vec3f d) const { return gs.surface.scatterInside(p, local(d)); }
    // The facets (a portion lies on one), which a chain direction may aim at (Chain): the pieces.
    size_t facets() const { return gs.surface.pieces().size(); }
    Vec3f facetNormal(size_t k) const {
      if (gs.paint && flat(k)) return flatNormal(gs, 0.0, 0.0);  // the peel at the footprint's centre
      Vec3d n = gs.surface.pieces()[k].plane.normal();
      return bumped(gs, normalize(gs.T * float(n.x) + gs.B * float(n.y) + gs.W * float(n.z)));
    }
    int facetLayer(size_t k) const { return gs.surface.pieces()[k].layer; }
    // Whether piece k and portion p face each other: every piece is a height field with its
    // normal up, so in front of a piece's plane is above it.
    bool faces(size_t k, const Portion& p) const {
      const auto& ps = gs.surface.pieces();
      if (k == size_t(p.piece)) return false;
      const groove::area::Piece& a = ps[k];
      const groove::area::Piece& b = ps[size_t(p.piece)];
      const double eps = 1e-12;
      bool a_above = false;
      for (int i = 0; i < a.poly.n && !a_above; ++i) a_above = a.plane.at(a.poly.v[size_t(i)]) - b.plane.at(a.poly.v[size_t(i)]) > eps;
      if (!a_above) return false;
      for (const groove::area::Poly& f : p.frags)
        for (int i = 0; i < f.n; ++i)
          if (b.plane.at(f.v[size_t(i)]) - a.plane.at(f.v[size_t(i)]) > eps) return true;
      return false;
    }
  };

  // Reflected radiance of the footprint over a section (direct light on every visible facet
  // portion with exact masking and shadowing, and inter-reflection by recursion on portions).
  Rgb shadeSection(const GrooveSet& gs, const groove::Section& sec, const Material& top, Vec3f wo_w,
                   const LightSamples& ls, Rng& rng, uint64_t& nrays) const {
    Vec2d e_bw(dot(wo_w, gs.B), dot(wo_w, gs.W));
    std::vector<groove::Portion> portions = groove::visible(sec, e_bw, gs.fp);
    // The section's shadowing per light sample, shared by every portion at every level (kept per
    // thread with its storage: a footprint is shaded before the next one's section is built).
    thread_local std::vector<groove::Shadowing> shadow;
    shadow.resize(ls.size());
    for (size_t i = 0; i < ls.size(); ++i) shadow[i].reset(sec, Vec2d(dot(ls[i].wl, gs.B), dot(ls[i].wl, gs.W)));
    return shadeLevel(LineGeometry{gs, sec, shadow}, top, portions, wo_w, Rgb(1.0f), 0, ls, rng, nrays);
  }

  // The same over the polygon surface of a crossing or an end, whose pieces include the walls
  // where the surface steps (Surface::Wall). The visible shares are normalised to 1: they sum to
  // 1 up to what the leaning walls count twice and the fragments dropped at the cap.
  Rgb shadeArea(const GrooveSet& gs, const Material& top, Vec3f wo_w, const LightSamples& ls, Rng& rng,
                uint64_t& nrays) const {
    thread_local std::vector<Vec3d> light;
    light.clear();
    for (const LightSample& l : ls) light.push_back(Vec3d(dot(l.wl, gs.T), dot(l.wl, gs.B), dot(l.wl, gs.W)));
    AreaGeometry geo{gs, light};
    gs.surface.cacheLights(light.size());
    std::vector<groove::area::Portion> portions = gs.surface.visible(gs.fp2, geo.local(wo_w));
    double wsum = 0;
    for (const auto& p : portions) wsum += p.weight;
    if (!(wsum > 0)) return Rgb(0.0f);
    for (auto& p : portions) {
      p.weight /= wsum;
      p.density /= wsum;
    }
    return shadeLevel(geo, top, portions, wo_w, Rgb(1.0f), 0, ls, rng, nrays);
  }

  // Rays from a footprint's portion along d that meet nothing of its surface and do not rise
  // (sc.escaped, d not up): only the polygons' region is bounded, so only there do they occur
  // (LineGeometry's sections reach far past any footprint, and rays that leave them are dropped).
  Rgb beyondRegion(const LineGeometry&, const Material&, const groove::Portion&, Vec3f, const groove::Scatter&, Rgb,
                   int, const LightSamples&, Rng&, uint64_t&) const {
    return Rgb(0.0f);
  }
  // Under the polygons they leave the square region sideways, below the pile-ups' tops, most of
  // them down a groove's channel: seen very close, where the region is small against the groove,
  // the steep walls of a tilted tool's half turn sent half the weight of some footprints' directions
  // that way (docs/grooves.md, "A half turn's step, seen very close"). The explicit geometry's ray
  // meets that groove farther along. So the escaped share goes on as a point portion of the 1-D
  // section of the groove whose centre line is nearest where the rays leave (Surface::leaving):
  // that groove alone, straight, at its scale there, in its own frame (Bosch §4.2.3), where the ray
  // from the escaped fragments' centroid meets it, shaded at the next level. What that leaves out:
  // other grooves beyond the region, the fade's slope, and the spread of the escaped rays over the
  // fragments (one ray carries them all).
  Rgb beyondRegion(const AreaGeometry& geo, const Material& top, const groove::area::Portion& p, Vec3f d,
                   const groove::area::Hits& sc, Rgb beta, int level, const LightSamples& ls, Rng& rng,
                   uint64_t& nrays) const {
    namespace ga = groove::area;
    const GrooveSet& gs = geo.gs;
    const ga::Piece& P = gs.surface.pieces()[size_t(p.piece)];
    const Vec3d dl = geo.local(d);
    const Vec3d o(sc.escaped_at.x, sc.escaped_at.y, P.plane.at(sc.escaped_at));
    Vec3d at;
    const ga::Groove* q = gs.surface.leaving(o, dl, at);
    if (!q) return Rgb(0.0f);
    const Vec2d a2(at.x, at.y);
    const double r = 1 + q->rho * (q->t0 + dot(q->tdir, a2));
    const double b = q->b0 + dot(q->bdir, a2);
    // The section: the groove's profile at scale r, centred on its line, F on that line beside the
    // point where the rays leave.
    thread_local std::vector<Vec2d> pts;
    pts.assign(q->pts->begin(), q->pts->end());
    for (Vec2d& v : pts) v = v * r;
    thread_local GrooveSet hs;
    soleSection(gs, a2 - q->bdir * b - gs.org, q->bdir, pts, q->layer, std::fabs(b), hs);
    int facet = -1;
    double t = 0, s_hit = 0;
    const bool hit =
        groove::castInto(hs.section, Vec2d(b, at.z), Vec2d(dot(Vec2d(dl.x, dl.y), q->bdir), dl.z), facet, t, &s_hit);
    // The section runs on straight and without end, beside a flat plate, but the path may turn or
    // end, and other scratches may stand in the way or cut it, before the ray gets there: rays
    // leaving over the plate beside a groove, nearly along it, went on in its section to the plate
    // 0.5 to 1 mm on, past the half turn that ends the groove's leg, where the section's pile-up
    // beside them (which is not there) mirrored a low bar light into them (the corners fuzzer's
    // c68_4; docs/grooves.md, "Past the end of a groove's leg"). So the ray is marched over the
    // explicit geometry's height (scratchHeight) until it is below every groove's floor; where the
    // section's hit lies past the ends of the groove's leg (Groove::t_lo, t_hi) or outside its
    // domain, or the section has none, or the march meets the surface away from it (by more than
    // kSoleSlack of its distance and two steps), the surface the march meets is taken: a
    // scratch's, as beyondRise shades it, or the plain part's, by an ordinary ray from the march's
    // last sample above. A meeting in the march's first two steps, where the ray leaves the
    // polygons within their agreement with scratchHeight, keeps the section, and so does the plain
    // part met from below the base by more than the march's tolerance (an abrupt end's wall, which
    // no section holds).
    const double hor = std::hypot(dl.x, dl.y);
    if (dl.z < 0 && hor > 0) {
      PileUp pu;
      double step = 0;
      if (marchAhead(gs, at, dl, (at.z + double(max_depth_)) / -dl.z, pu, true, &step)) {
        const double x_m = std::hypot(pu.at.x - at.x, pu.at.y - at.y), x_h = s_hit * hor;
        const bool on_leg = hit && onLeg(*q, a2 + Vec2d(dl.x, dl.y) * s_hit);
        const double tol = marchTol();
        if (x_m > 2 * step && (pu.sc || pu.from.z > -2 * tol) &&
            (!on_leg || std::fabs(x_m - x_h) > kSoleSlack * x_h + 2 * step)) {
          if (pu.sc) return beyondRise(geo, top, pu, d, sc.escaped, beta, level, ls, rng, nrays);
          // (From no lower than the march's tolerance above the plate: the part's own surface.)
          const Vec3f from = gs.F + gs.T * float(pu.from.x - gs.org.x) + gs.B * float(pu.from.y - gs.org.y) +
                             gs.W * float(std::max(pu.from.z, tol));
          return continuePath(bareRay(from, d), beta * float(sc.escaped), 0.0f, true, from, 1 + level, rng, nrays,
                              1.0f, 1.0f);
        }
      }
    }
    if (!hit) return Rgb(0.0f);
    return shadeSole(hs, beyond(gs, top), facet, t, sc.escaped, d, beta, level, ls, rng, nrays);
  }
  static constexpr double kSoleSlack = 0.05;
  // Whether point p (the footprint's T, B) lies within groove g's length (t_lo, t_hi) and its
  // domain (a corner's part).
  static bool onLeg(const groove::area::Groove& g, Vec2d p) {
    const double t = g.t0 + dot(g.tdir, p);
    return t >= g.t_lo && t <= g.t_hi && groove::area::inDomain(g, p);
  }

  // Where a footprint's polygons hand rays to one groove's section beyond their region
  // (beyondRegion, beyondRise): the groove's profile `pts` (at its scale there, mm) centred on its
  // line with the base plane around it, holding `reach` (mm) either side, in a frame of its own:
  // B along bdir (in the footprint's (T, B)), W the surface's, T = B x W (so that B = W x T), F on
  // the centre line at c2 (mm from the footprint's F along its T and B).
  void soleSection(const GrooveSet& gs, Vec2d c2, Vec2d bdir, const std::vector<Vec2d>& pts,
                   const std::vector<int>* layer, double reach, GrooveSet& hs) const {
    groove::PlacedProfile placed;
    placed.pts = &pts;
    placed.layer = layer;
    hs.B = normalize(gs.T * float(bdir.x) + gs.B * float(bdir.y));
    hs.W = gs.W;
    hs.T = cross(hs.B, hs.W);
    hs.F = gs.F + gs.T * float(c2.x) + gs.B * float(c2.y);
    hs.one_material = gs.one_material;
    hs.frame_t = gs.frame_t;
    hs.beyond = gs.beyond;
    hs.bump = gs.bump;
    // The chart and the peel in its frame: its F at c2 of the footprint's (T, B), its B at bdir, and
    // its T = B x W = bdir.y T - bdir.x B.
    hs.uv0 = gs.uv0 + gs.uv_t * float(c2.x) + gs.uv_b * float(c2.y);
    hs.uv_b = gs.uv_t * float(bdir.x) + gs.uv_b * float(bdir.y);
    hs.uv_t = gs.uv_t * float(bdir.y) - gs.uv_b * float(bdir.x);
    hs.mm_per_uv = gs.mm_per_uv;
    hs.paint = gs.paint;
    if (hs.paint) hs.peel_u = gs.peel_u, hs.peel_v = gs.peel_v, hs.paint_fp = gs.paint_fp;
    hs.fp = groove::Footprint{0.0, 0.0};  // (a point portion: its weights do not use it)
    hs.section = groove::merge({placed}, sectionExtent(reach));
  }
  // The share `weight` of the rays along d that meet facet `facet` of hs's section at t, shaded as
  // a point portion there at the next level, with material m.
  Rgb shadeSole(const GrooveSet& hs, const Material& m, int facet, double t, double weight, Vec3f d, Rgb beta,
                int level, const LightSamples& ls, Rng& rng, uint64_t& nrays) const {
    groove::Portion hit;
    hit.facet = facet;
    hit.t0 = hit.t1 = t;
    hit.weight = weight;
    thread_local std::vector<groove::Shadowing> shadow;
    shadow.resize(ls.size());
    for (size_t i = 0; i < ls.size(); ++i)
      shadow[i].reset(hs.section, Vec2d(dot(ls[i].wl, hs.B), dot(ls[i].wl, hs.W)));
    return shadeLevel(LineGeometry{hs, hs.section, shadow}, m, {hit}, -d, beta, level + 1, ls, rng, nrays);
  }

  // The UV of point p of a footprint's polygons (mm along its T and B about the surface's origin).
  static Vec2f uvAt(const GrooveSet& gs, Vec2d p) {
    return gs.uv0 + gs.uv_t * float(p.x - gs.org.x) + gs.uv_b * float(p.y - gs.org.y);
  }
  // A UV direction v at the footprint in its (T, B) (the chart's map inverted; not normalised).
  static Vec2d localDir(const GrooveSet& gs, Vec2f v) {
    const double det = double(gs.uv_t.x) * gs.uv_b.y - double(gs.uv_b.x) * gs.uv_t.y;
    if (!(std::fabs(det) > 0)) return Vec2d(0.0, 0.0);
    return Vec2d((double(gs.uv_b.y) * v.x - double(gs.uv_b.x) * v.y) / det,
                 (double(gs.uv_t.x) * v.y - double(gs.uv_t.y) * v.x) / det);
  }

  // Rays rising low from a footprint's polygons that pass over pile-ups beyond their region.
  // The polygons hold the surface within the region; a ray that leaves it rising goes on as an
  // ordinary ray against the flat part, which has no pile-ups. The explicit geometry's ray meets
  // one where it comes within its height: seen at 1 degree, the foot of a corner's pile-up sent
  // the camera's rays out at 0 to 8 degrees above the plate, and those within about 1 degree met
  // the inner face of the same path's later leg 1 to 1.2 mm away, which mirrored the ring light
  // into them (the corners fuzzer's c60_2, 0.651% of pixels >= 10; docs/grooves.md, "Rising over
  // the pile-ups beyond"). pileUpAhead marches the ray from where it leaves the region over the
  // explicit geometry's height (scratchHeight, the scratches within reach), until it is above
  // every pile-up, and finds where it first goes below it; beyondRise shades that point on the
  // section of the scratch whose height it is there, as beyondRegion does.
  struct PileUp {
    const Scratch* sc = nullptr;
    Vec3d from;  // the ray's last sample above the surface (the polygons' (x, y, z))
    Vec2d at;    // where it meets the surface
  };
  // The march's steps: an eighth of the narrowest scratch's half extent, or the reach over this many.
  static constexpr double kMarchSteps = 2048;
  bool pileUpAhead(const LineGeometry&, const groove::Portion&, Vec3f, const groove::Scatter&, PileUp&) const {
    return false;
  }
  bool pileUpAhead(const AreaGeometry& geo, const groove::area::Portion& p, Vec3f d, const groove::area::Hits& sc,
                   PileUp& out) const {
    const GrooveSet& gs = geo.gs;
    const Vec3d dl = geo.local(d);
    if (!(sc.escaped > 0) || !(dl.z > 0)) return false;
    const groove::area::Piece& P = gs.surface.pieces()[size_t(p.piece)];
    Vec3d at;
    if (!gs.surface.exitPoint(Vec3d(sc.escaped_at.x, sc.escaped_at.y, P.plane.at(sc.escaped_at)), dl, at))
      return false;
    const double top = double(max_height_);
    if (!(at.z < top)) return false;
    return marchAhead(gs, at, dl, (top - at.z) / dl.z, out);  // until the ray is above every pile-up
  }
  // How far below scratchHeight the march's ray must go to meet it: a rounding of the polygons'
  // heights against it (they agree to about 0.03 um), a thousandth of the scratches' height range.
  double marchTol() const { return 1e-3 * double(max_height_ + max_depth_); }
  // Where the ray at + s dl (the polygons' local frame, mm) first goes below the explicit
  // geometry's height (scratchHeight of the scratches within reach) for s in (0, s_max]: marched
  // in steps of an eighth of the narrowest scratch's half extent, or the whole over kMarchSteps,
  // where that is more (`step_out`, where given, gets it). False where it stays above, or dl is
  // (nearly) vertical, or (without `plain`) it meets the plain part, where no scratch has a
  // height; with `plain` such a meeting counts, out.sc null.
  bool marchAhead(const GrooveSet& gs, Vec3d at, Vec3d dl, double s_max, PileUp& out, bool plain = false,
                  double* step_out = nullptr) const {
    const double hor = std::hypot(dl.x, dl.y);
    if (!(hor > 0) || !(s_max > 0)) return false;
    const double slope = dl.z / hor;
    const double len = s_max * hor;  // (mm along the plate)
    const double mm = gs.mm_per_uv;
    const double step = std::max(double(min_half_) * mm / 8, len / kMarchSteps);
    if (step_out) *step_out = step;
    const Vec2d a(at.x, at.y), u(dl.x / hor, dl.y / hor);
    thread_local std::vector<const Scratch*> near;
    near.clear();
    s_.defect_index.forEach(uvAt(gs, a + u * (0.5 * len)), float(0.5 * len / mm) + max_half_, [&](const Defect& df) {
      if (df.cls() == DefectClass::Scratch) near.push_back(static_cast<const Scratch*>(&df));
    });
    if (near.empty()) return false;
    // (Below by more than marchTol: where the ray leaves the region it is above the polygons.)
    const Vec2d du(double(gs.uv_t.x) * u.x + double(gs.uv_b.x) * u.y, double(gs.uv_t.y) * u.x + double(gs.uv_b.y) * u.y);
    const Vec2f a_uv = uvAt(gs, a);
    HeightMeet m;
    if (!meetScratchHeight(near, Vec2d(a_uv.x, a_uv.y), du, at.z, slope, len, step, marchTol(), m, plain))
      return false;
    out.from = Vec3d(a.x + u.x * m.from, a.y + u.y * m.from, at.z + m.from * slope);
    out.at = a + u * m.at;
    out.sc = m.scratch;
    return true;
  }
  // The share `weight` of the rays along d that pileUpAhead found meeting a pile-up: the section
  // of that scratch alone, straight along its tangent at its closest point to the meeting, at its
  // scale there, in its own frame, where the ray from its last sample above meets it, shaded at the
  // next level (soleSection). Nothing where the section misses the ray.
  Rgb beyondRise(const AreaGeometry& geo, const Material& top, const PileUp& pu, Vec3f d, double weight, Rgb beta,
                 int level, const LightSamples& ls, Rng& rng, uint64_t& nrays) const {
    const GrooveSet& gs = geo.gs;
    const PathPoint pp = pu.sc->path().closest(uvAt(gs, pu.at));
    const float k = pu.sc->scaleAt(pp.s);
    if (!(k > 0)) return Rgb(0.0f);
    // The path's T and its left (the profile's +b) in the footprint's (T, B), through the chart.
    const Vec2d t = localDir(gs, pp.tangent);
    Vec2d b = localDir(gs, Vec2f(-pp.tangent.y, pp.tangent.x));
    if (!(dot(t, t) > 0)) return Rgb(0.0f);
    b = b - t * (dot(b, t) / dot(t, t));
    const double lb = std::sqrt(dot(b, b));
    if (!(lb > 0)) return Rgb(0.0f);
    b = b / lb;
    const Vec2d c = localDir(gs, pp.point - gs.uv0) + gs.org;  // the closest point
    thread_local Profile prof;
    prof = surfaceProfile(*pu.sc, k, gs.mm_per_uv);
    const Vec3d dl = geo.local(d);
    const double b0 = dot(Vec2d(pu.from.x, pu.from.y) - c, b);
    thread_local GrooveSet hs;
    soleSection(gs, c - gs.org, b, prof.pts, &prof.layer, std::fabs(b0), hs);
    int facet = -1;
    double tf = 0;
    if (!groove::castInto(hs.section, Vec2d(b0, pu.from.z), Vec2d(dot(Vec2d(dl.x, dl.y), b), dl.z), facet, tf))
      return Rgb(0.0f);
    return shadeSole(hs, beyond(gs, top), facet, tf, weight, d, beta, level, ls, rng, nrays);
  }
  Rgb beyondRise(const LineGeometry&, const Material&, const PileUp&, Vec3f, double, Rgb, int, const LightSamples&,
                 Rng&, uint64_t&) const {
    return Rgb(0.0f);
  }

  // A direction drawn from a footprint's portions (drawDirection).
  template <class Geometry>
  struct Drawn {
    const typename Geometry::Portion* p = nullptr;
    Vec3f d;          // world direction
    float pdf = 0;    // its BSDF pdf (solid angle)
    Rgb ratio;        // f |cos| / pdf
    bool through = false;  // refracted into the part (glass): sc stays empty
    typename Geometry::Scatter sc;
  };
  // Chain directions: first-level directions drawn from the far side of the light's path.
  // Under a narrow light, the light that reaches the camera over two facets (the far one mirrors
  // the light, the seen one passes it on at its lobe's tail) arrives only through the few of the
  // portions' BSDF directions that land where the far facet's lobe meets the light: at 1 spp the
  // dark wall of a groove under the bar light was sprinkled with single bright pixels. A chain
  // direction is drawn the other way: take a light direction wl and a facet k facing it, draw v
  // from k's BSDF as if seen from wl (the BSDF is reciprocal), and take d = -v, then a portion by
  // weight among those that d leaves. Chain directions estimate only the direct light on what d
  // meets (shadeLevel with direct_only), shared with the portions' BSDF directions by the balance
  // heuristic over the joint density of portion and direction (jointDensity). The rest (the
  // emitter that d meets, and deeper levels) stays with the BSDF directions, which reach every
  // d, so the estimate stays unbiased whatever the chain's choices.
  struct Chain {
    int n = 0;  // chain directions drawn
    // A light direction and a facet facing it: the facet's BSDF seen from the light, its mirror
    // direction v0 (where the facet sends that light) and the cone around v0 that the chain keeps.
    struct Pair {
      Frame frame;
      BsdfAt bsdf;
      const Material* m;
      Vec3f wl_local, v0;
      float cone;
    };
    std::vector<Pair> pairs;
    // Density of drawing d (solid angle): the mean over the pairs of their BSDF densities of -d
    // inside their cones (a direction drawn outside its pair's cone is dropped).
    float pdf(Vec3f d) const {
      float sum = 0;
      for (const Pair& q : pairs) {
        if (dot(-d, q.v0) < q.cone) continue;
        Vec3f v = q.frame.toLocal(-d);
        if (v.z > 0) sum += q.bsdf.pdf(v);
      }
      return sum / float(pairs.size());
    }
  };
  // The cone (cosine of its half-angle) around a lobe's mirror direction that a chain keeps, and
  // that stands for the lobe when deciding whether a pair is needed: 8 alpha + 0.02 rad around
  // the sharpest lobe (GGX's D there is 0.2% of its peak), or -1 for a surface without a sharp
  // lobe, where a chain is never used.
  static float lobeCone(const Material& m) {
    float r;
    switch (m.kind) {
      case MaterialKind::Conductor:
      case MaterialKind::Plastic: r = m.roughness; break;
      case MaterialKind::CarPaint: r = m.coat_roughness; break;
      default: return -1.0f;
    }
    r = std::max(r, kMinRoughness);
    const float angle = 8.0f * r * r + 0.02f;
    return angle >= 1.5f ? -1.0f : std::cos(angle);
  }
  // A seen portion as makeChain needs it.
  template <class Portion>
  struct SeenPortion {
    const Portion* p;
    Vec3f N, mirror;  // the facet normal; the mirror direction of the view about it
    float cone;       // lobeCone of its material
    Frame frame;
    BsdfAt bsdf;      // seen from the view
  };
  // The share of a footprint's direct light under which a chain pair is not worth its cost.
  static constexpr float kChainMinShare = 0.1f;
  // The chain of a footprint (with `direct` its direct light), or false when it has none.
  // - Light directions: the two visible area-light samples whose components along T are nearest
  //   minus the view's (a mirror reflection off a wall parallel to T keeps that component, so these
  //   are the ones a path mirrored off two walls can reach).
  // - Pairs: with each, every facet k with a sharp lobe that faces it and faces a seen portion,
  //   kept only where (1) no seen portion facing the peak direction d0 = -v0 already sends its
  //   own BSDF directions there (d0 outside its cone around the mirror of the view: there its
  //   directions rarely find what the far facet mirrors), and (2) the light it would carry, at
  //   most about (sum over the portions facing d0 of weight x BSDF density toward d0, which
  //   bounds f cos) x the light's radiance x k's share of it (min(1, pdf(v0) / the light
  //   sample's pdf)) x the lobe's solid angle (1 / pdf(v0)), is at least kChainMinShare of
  //   `direct`. Under the ring light of the accuracy scenes the walls are lit directly and (2)
  //   drops nine pairs in ten; under the bar the dark walls keep theirs.
  // Decided before any direction is drawn, so the estimate stays unbiased whatever is kept.
  template <class Geometry>
  bool makeChain(const Geometry& geo, const Material& top, Vec3f wo_w, const LightSamples& ls,
                 const std::vector<typename Geometry::Portion>& portions, Rgb direct, Chain& c) const {
    if (st_.groove_chain_samples <= 0 || top.kind == MaterialKind::Glass) return false;
    const GrooveSet& gs = geo.gs;
    const float wo_t = dot(wo_w, gs.T);
    int best[2] = {-1, -1};
    float best_e[2] = {kInf, kInf};
    for (size_t i = 0; i < ls.size(); ++i) {
      if (!ls[i].visible || ls[i].env) continue;
      const float e = std::fabs(dot(ls[i].wl, gs.T) + wo_t);
      if (e < best_e[0]) {
        best[1] = best[0], best_e[1] = best_e[0];
        best[0] = int(i), best_e[0] = e;
      } else if (e < best_e[1]) {
        best[1] = int(i), best_e[1] = e;
      }
    }
    if (best[0] < 0) return false;
    std::vector<SeenPortion<typename Geometry::Portion>> seen;
    seen.reserve(portions.size());
    for (const auto& q : portions) {
      if (!(q.weight > 0)) continue;
      const Vec3f N = geo.normal(q);
      const Material& m = facetMaterial(gs, geo.layer(q), top);
      const Frame fr = facetFrame(gs, N);
      seen.push_back({&q, N, reflect(-wo_w, N), lobeCone(m), fr, BsdfAt(m, fr.toLocal(wo_w))});
    }
    // The facets with a sharp lobe that face a seen portion.
    struct Far {
      Vec3f N;
      const Material* m;
      float cone;
    };
    std::vector<Far> far;
    for (size_t k = 0; k < geo.facets(); ++k) {
      const Material& m = facetMaterial(gs, geo.facetLayer(k), beyond(gs, top));
      const float cone = lobeCone(m);
      if (cone < 0) continue;
      for (const auto& q : seen) {
        if (!geo.faces(k, *q.p)) continue;
        far.push_back({geo.facetNormal(k), &m, cone});
        break;
      }
    }
    const float least = kChainMinShare * maxComponent(direct);
    for (int li : best) {
      if (li < 0) continue;
      const LightSample& l = ls[size_t(li)];
      for (const Far& fk : far) {
        const Vec3f N = fk.N;
        if (dot(N, l.wl) <= 0) continue;
        const Material& m = *fk.m;
        const float cone = fk.cone;
        const Vec3f v0 = reflect(-l.wl, N), d0 = -v0;
        bool covered = false;
        for (const auto& q : seen)
          if (dot(q.N, d0) > 0) covered = covered || q.cone < 0 || dot(d0, q.mirror) >= q.cone;
        if (covered) continue;
        const Frame fr = facetFrame(gs, N);
        const Vec3f wl = fr.toLocal(l.wl), v0l = fr.toLocal(v0);
        const BsdfAt bk(m, wl);
        const float pk = bk.pdf(v0l);
        if (!(pk > 0)) continue;
        // f cos is at most the (visible-normal) density, and about it at a lobe's peak; so no
        // Fresnel term is evaluated here.
        const float reflectance = std::min(1.0f, pk / l.pdf);
        float passed = 0;
        for (const auto& q : seen) {
          const Vec3f dq = q.frame.toLocal(d0);
          if (dq.z > 0) passed += float(q.p->weight) * q.bsdf.pdf(dq);
        }
        if (!(passed > 0) || passed * reflectance * maxComponent(l.Le) / pk < least) continue;
        c.pairs.push_back(Chain::Pair{fr, bk, &m, wl, v0, cone});
      }
    }
    c.n = st_.groove_chain_samples;
    return !c.pairs.empty();
  }
  // The weight of the portions that direction d leaves (d on their facets' outer side): a chain
  // direction's portion is chosen by weight among them.
  template <class Geometry>
  static double facingWeight(const Geometry& geo, const std::vector<typename Geometry::Portion>& portions, Vec3f d) {
    double w = 0;
    for (const auto& q : portions)
      if (dot(geo.normal(q), d) > 0) w += q.weight;
    return w;
  }
  // The joint density of a portion of weight pw (of the portions' wsum) and direction d over the
  // first-level directions: nbm portions' BSDF directions (pdf: the portion's BSDF density of d)
  // and the chain's n directions (the chain's density of d, then the portion by weight among those
  // facing d, of weight wf: facingWeight).
  static double jointDensity(double pw, double wsum, double wf, float nbm, float pdf, const Chain& c, Vec3f d) {
    return double(nbm) * pw / wsum * pdf + (wf > 0 ? double(c.n) * c.pdf(d) * pw / wf : 0.0);
  }
  // The share of the direct light on what a portion's BSDF direction d meets that a set of `count`
  // such directions takes: count / nbm without a chain, their part of the joint density with.
  template <class Geometry>
  static float bsdfShare(const Chain* chain, const Geometry& geo, const std::vector<typename Geometry::Portion>& portions,
                         double wsum, const typename Geometry::Portion& p, int count, float nbm, float pdf, Vec3f d) {
    if (!chain) return float(count) / nbm;
    const double wf = facingWeight(geo, portions, d);
    return float(double(count) * p.weight / wsum * pdf / jointDensity(p.weight, wsum, wf, nbm, pdf, *chain, d));
  }

  // Direction j of n drawn from a footprint's portions: the portion by weight (stratum j of the
  // weights' sum), then a BSDF direction from it (the lobe and direction strata of `lhs`), and
  // where the rays leaving the portion that way go. False when the draw gives nothing.
  // `bsdfs` (optional, one entry per portion) keeps each portion's frame and BSDF from its first
  // draw on, for the many draws from the same portions (the same values as built anew).
  struct PortionBsdf {
    PortionBsdf(const Material& m, const Frame& f, Vec3f w) : fr(f), wo(w), bsdf(m, w) {}
    Frame fr;
    Vec3f wo;
    BsdfAt bsdf;
  };
  template <class Geometry>
  bool drawDirection(const Geometry& geo, const Material& top, const std::vector<typename Geometry::Portion>& portions,
                     double wsum, Vec3f wo_w, const LatinStrata& lhs, int j, int n, Rng& rng,
                     Drawn<Geometry>& out, std::vector<std::optional<PortionBsdf>>* bsdfs = nullptr) const {
    const size_t pi = pickByWeight(portions, (j + rng.uniformD()) / n * wsum);
    const auto& p = portions[pi];
    if (!(p.weight > 0)) return false;
    const Material& m = facetMaterial(geo.gs, geo.layer(p), top);
    std::optional<PortionBsdf> local;
    std::optional<PortionBsdf>& e = bsdfs ? (*bsdfs)[pi] : local;
    if (!e) {
      const Frame f = facetFrame(geo.gs, geo.normal(p));
      e.emplace(m, f, f.toLocal(wo_w));
    }
    const Frame& fr = e->fr;
    const Vec3f wo = e->wo;
    BsdfSample bs;
    float ul = lhs.at(0, j, rng);
    Vec2f ud{lhs.at(1, j, rng), lhs.at(2, j, rng)};
    if (wo.z <= 0 || !e->bsdf.sample(ul, ud, bs) || !(bs.pdf > 0) || bs.wi.z == 0) return false;
    out.p = &p;
    out.d = fr.toWorld(bs.wi);
    out.pdf = bs.pdf;
    out.ratio = bs.f * (std::fabs(bs.wi.z) / bs.pdf);
    if (!isFinite(out.ratio) || maxComponent(out.ratio) <= 0) return false;
    out.through = bs.wi.z < 0;
    // Into the part: the refracted rays are followed through the grooves (throughGrooves), also
    // those that run up into a pile-up.
    if (out.through) return true;
    out.sc = geo.scatter(p, out.d);
    return true;
  }

  // Rays refracted into a glass part at portion p of a 1-D section or of a polygon surface
  // (direction d, throughput beta per unit of the portion's weight, pdf the direction's), followed
  // through the grooves from inside (Geometry::scatterInside): what meets no facet again goes on
  // down into the solid as an ordinary ray; what meets a facet from inside (the far side of a
  // pile-up's ridge, a groove wall under it) is reflected or refracted there by the glass seen
  // from its solid side, one hit portion chosen by weight. Reflected, it goes on inside;
  // refracted out, into the air above that facet, it meets the grooves from outside (shadeLevel
  // on what it hits) or leaves them. Level `level` is the vertex that refracted; each hit is one
  // more, within max_bounces. No light sample reaches through a facet, so the rays count the
  // emitters they meet in full (as before, when every refracted ray went straight into the
  // solid: Bosch's E_t; a band of five or six merged deep scratches on glass lost 5% of its light
  // that way, and its crossings with other deep grooves 1.5-3%; docs/grooves.md, "Glass").
  template <class Geometry>
  Rgb throughGrooves(const Geometry& geo, const Material& top, const typename Geometry::Portion& p, Vec3f d, Rgb beta,
                     float pdf, int level, const LightSamples& ls, Rng& rng, uint64_t& nrays, float nl_eff,
                     float nl_env) const {
    const GrooveSet& gs = geo.gs;
    Rgb L(0.0f);
    const typename Geometry::Scatter in = geo.scatterInside(p, d);
    if (in.escaped > 0 && dot(d, gs.W) < 0) {
      const DiffRay r = bareRay(insideGrooves(gs), d);
      L += continuePath(r, beta * float(in.escaped), pdf, true, r.o, 1 + level, rng, nrays, nl_eff, nl_env);
    }
    if (in.hits.empty() || level + 1 >= st_.max_bounces) return L;
    double hsum = 0;
    for (const auto& h : in.hits) hsum += h.weight;
    if (!(hsum > 0)) return L;
    const typename Geometry::Portion& q = in.hits[pickByWeight(in.hits, rng.uniformD() * hsum)];
    if (!(q.weight > 0)) return L;
    // The facet seen from the solid: its normal turned into the solid, the relative index inverted.
    const Material& next = beyond(gs, top);
    const Material m = facing(facetMaterial(gs, geo.layer(q), next), false);
    const Frame fr = facetFrame(gs, -geo.normal(q));
    const Vec3f wo = fr.toLocal(-d);
    if (wo.z <= 0) return L;
    BsdfSample bs;
    const float ul = rng.uniform();
    const Vec2f ud{rng.uniform(), rng.uniform()};
    if (!BsdfAt(m, wo).sample(ul, ud, bs) || !(bs.pdf > 0) || bs.wi.z == 0) return L;
    const Vec3f d2 = fr.toWorld(bs.wi);
    // Per unit of q's weight: every hit portion's share, carried by the one chosen.
    const Rgb beta2 = beta * bs.f * float(std::fabs(bs.wi.z) / bs.pdf * hsum / q.weight);
    if (!isFinite(beta2) || maxComponent(beta2) <= 0) return L;
    if (bs.wi.z > 0)  // reflected, still inside the solid
      return L + throughGrooves(geo, next, q, d2, beta2, bs.pdf, level + 1, ls, rng, nrays, nl_eff, nl_env);
    const typename Geometry::Scatter out = geo.scatter(q, d2);
    if (out.escaped > 0 && dot(d2, gs.W) > 0) {
      const DiffRay r = bareRay(aboveGrooves(gs), d2);
      L += continuePath(r, beta2 * float(out.escaped), bs.pdf, true, r.o, 2 + level, rng, nrays, nl_eff, nl_env);
    }
    if (!out.hits.empty() && level + 2 < st_.max_bounces)
      L += shadeLevel(geo, next, out.hits, -d2, beta2, level + 2, ls, rng, nrays);
    return L;
  }

  // One level of the recursion: `portions` carry absolute footprint weights, seen from direction
  // wo_w, with throughput beta per unit weight. The direct light on them (the light samples and
  // the lights that their BSDF directions meet) is scaled by `direct_scale`: at the second level
  // two sets of first-level directions estimate it, each with its share (lobeDirect). With
  // `direct_only`, nothing more is estimated: no path is continued and no groove entered again.
  template <class Geometry>
  Rgb shadeLevel(const Geometry& geo, const Material& top, const std::vector<typename Geometry::Portion>& portions,
                 Vec3f wo_w, Rgb beta, int level, const LightSamples& ls, Rng& rng, uint64_t& nrays,
                 float direct_scale = 1.0f, bool direct_only = false) const {
    const GrooveSet& gs = geo.gs;
    const int nl = st_.groove_light_samples;
    // Directions sampled from the footprint at the first level (stratified over the portions);
    // deeper levels follow one.
    const int nb = level == 0 ? st_.groove_bsdf_samples : 1;
    // And at the first level nm more, four per portion up to groove_lobe_samples, for the direct
    // light only (not continued; lobeDirect): the BSDF strategy's count in the MIS weights is
    // nb + nm directions, of which the continued ones take the share nb / (nb + nm) and these
    // nm / (nb + nm).
    const int nm = level == 0 && !direct_only ? std::min(st_.groove_lobe_samples, 4 * int(portions.size())) : 0;
    const float nbm = float(nb + nm);
    // Deeper levels are reached by many first-level directions, so each takes one of nsub subsets
    // of every light's samples, chosen at random: the samples k = off (mod nsub), nsub the largest
    // divisor of nl up to sqrt(nl). Every sample is used with probability 1/nsub, so the estimate
    // stays unbiased with nl / nsub samples per light (also the MIS count). On the light pattern's
    // lattice such a subset is a coarser lattice, spread over the whole light as the full set is.
    const int nsub = level == 0 ? 1 : sub_count_;
    const int off = nsub > 1 ? std::min(nsub - 1, int(rng.uniform() * float(nsub))) : 0;
    const float nl_eff = float(nl) / float(nsub);
    const float nl_env = env_by_bsdf_ ? 0.0f : nl_eff;  // the environment's (env_by_bsdf_)
    Rgb L(0.0f);
    double wsum = 0;
    for (const auto& p : portions) wsum += p.weight;
    if (!(wsum > 0)) return L;
    // Direct light on every portion, MIS against nb BSDF samples.
    for (const auto& p : portions) {
      Vec3f N = geo.normal(p);
      const Material& m = facetMaterial(gs, geo.layer(p), top);
      Frame fr = facetFrame(gs, N);
      Vec3f wo = fr.toLocal(wo_w);
      if (wo.z <= 0) continue;
      const BsdfAt bsdf(m, wo);
      for (size_t li = 0; li < ls.size(); ++li) {
        const LightSample& l = ls[li];
        if (!l.visible || (nsub > 1 && l.k % nsub != off)) continue;
        Vec3f wi = fr.toLocal(l.wl);
        if (wi.z <= 0) continue;
        double lit = geo.lit(p, li);
        if (!(lit > 0)) continue;
        float pdf;
        Rgb f = bsdf.evalPdf(wi, pdf);
        float w = powerHeuristic(nl_eff * l.pdf, float(nbm * p.weight / wsum) * pdf);
        L += beta * f * l.Le * float(p.weight * lit * wi.z * w * direct_scale / (nl_eff * l.pdf));
      }
    }
    // At the last level the BSDF directions are still sampled (they carry their MIS share of the
    // direct light through the escaped rays), but the groove is not entered again.
    const bool last = level >= std::min(st_.max_groove_bounces, st_.max_bounces - 1);
    Chain chain_at;
    const Chain* chain = nullptr;
    if (level == 0 && !direct_only && !last && makeChain(geo, top, wo_w, ls, portions, L, chain_at)) chain = &chain_at;
    if (nm > 0) L += lobeDirect(geo, top, portions, wsum, wo_w, beta, nm, nbm, nl_eff, !last, ls, rng, nrays, chain);
    if (chain) L += chainDirect(geo, top, portions, wsum, wo_w, beta, nbm, *chain, ls, rng, nrays);
    Vec3f origin = aboveGrooves(gs);
    // Latin-hypercube strata for the lobe choice and the direction; the portion choice takes
    // stratum j of the weights.
    LatinStrata lhs(nb, 3, rng);
    std::vector<std::optional<PortionBsdf>> bsdfs(nb > 1 ? portions.size() : 0);
    for (int j = 0; j < nb; ++j) {
      // A portion chosen by weight, a BSDF direction from it, then the portions that direction
      // meets inside the groove (next level) and the share that escapes (an ordinary ray).
      Drawn<Geometry> dr;
      if (!drawDirection(geo, top, portions, wsum, wo_w, lhs, j, nb, rng, dr, nb > 1 ? &bsdfs : nullptr)) continue;
      const auto& p = *dr.p;
      const Vec3f d = dr.d;
      const auto& sc = dr.sc;
      Rgb beta_next = beta * dr.ratio * float(wsum / (p.weight * nb));
      if (dr.through) {
        // Refracted into glass (Bosch §4.3, E_t): an ordinary ray on from inside the part. No
        // light sample covers it (they stay above the surface), so its emitter counts in full.
        if (direct_only) continue;
        L += throughGrooves(geo, top, p, d, beta_next, float(nbm * p.weight / wsum) * dr.pdf, level, ls, rng, nrays,
                            nl_eff, nl_env);
        continue;
      }
      // Rising rays that meet a pile-up beyond the polygons' region (pileUpAhead) meet no emitter.
      PileUp pile;
      const bool rise = sc.escaped > 0 && dot(d, gs.W) > 0;
      const bool met = rise && pileUpAhead(geo, p, d, sc, pile);
      if (direct_only) {
        if (rise && !met)
          L += beta_next * float(sc.escaped * direct_scale) *
               emitterToward(origin, d, float(nbm * p.weight / wsum) * dr.pdf, nl_eff, ls.guides, nrays);
        continue;
      }
      // (Its next level's direct light is these directions' alone, as beyondRegion's below.)
      if (met && !last) L += beyondRise(geo, top, pile, d, sc.escaped, beta_next, level, ls, rng, nrays);
      if (rise && !met) {
        const DiffRay r = bareRay(origin, d);
        L += continuePath(r, beta_next * float(sc.escaped), float(nbm * p.weight / wsum) * dr.pdf, false, origin,
                          1 + level, rng, nrays, nl_eff, nl_env, direct_scale * float(nb) / nbm, nullptr, 0, nullptr,
                          ls.guides);
      }
      // Rays that leave a polygon region downwards (beyondRegion): their next level's direct
      // light is these directions' alone (lobeDirect and the chain follow only the hits).
      if (!last && sc.escaped > 0 && !(dot(d, gs.W) > 0))
        L += beyondRegion(geo, top, p, d, sc, beta_next, level, ls, rng, nrays);
      // The next level's direct light is shared with the direct-only directions when they were
      // followed there (lobeDirect), deeper levels' is not.
      if (!last && !sc.hits.empty())
        L += shadeLevel(geo, beyond(gs, top), sc.hits, -d, beta_next, level + 1, ls, rng, nrays,
                        level == 0 ? bsdfShare(chain, geo, portions, wsum, p, nb, nbm, dr.pdf, d) : 1.0f);
    }
    return L;
  }

  // Direct light from nm BSDF directions of the portions (chosen by weight, Latin-hypercube
  // stratified like the continued ones), not continued as paths: the share of a direction that
  // escapes the groove counts only the emitter it meets, and with `bounce` the share that meets
  // another wall counts only that wall's direct light (its light samples and the lights met by its
  // BSDF direction, shadeLevel with direct_only). Both are also estimated by the continued
  // directions; the two sets take the shares nm / (nb + nm) and nb / (nb + nm) of them.
  // Where they help: under a long light the light samples, spread over the whole light, seldom
  // fall inside the sharp lobe of a small portion, and the few continued directions of that
  // portion decide alone whether it shows the light; and the light that reaches the camera over
  // two walls varies most with the first direction (where it meets the far wall, and whether that
  // wall's lobe then meets the light). These directions cost a shadow ray each and no path.
  template <class Geometry>
  Rgb lobeDirect(const Geometry& geo, const Material& top, const std::vector<typename Geometry::Portion>& portions,
                 double wsum, Vec3f wo_w, Rgb beta, int nm, float nbm, float nl_eff, bool bounce,
                 const LightSamples& ls, Rng& rng, uint64_t& nrays, const Chain* chain) const {
    const GrooveSet& gs = geo.gs;
    const Vec3f origin = aboveGrooves(gs);
    LatinStrata lhs(nm, 3, rng);
    std::vector<std::optional<PortionBsdf>> bsdfs(portions.size());
    Rgb L(0.0f);
    for (int j = 0; j < nm; ++j) {
      Drawn<Geometry> dr;
      if (!drawDirection(geo, top, portions, wsum, wo_w, lhs, j, nm, rng, dr, &bsdfs)) continue;
      const auto& p = *dr.p;
      const Vec3f d = dr.d;
      const auto& sc = dr.sc;
      if (dr.through) continue;  // refracted: estimated by the continued directions alone
      Rgb beta_k = beta * dr.ratio * float(wsum / (p.weight * nm));
      const float share = float(nm) / nbm;
      PileUp pile;
      if (sc.escaped > 0 && dot(d, gs.W) > 0 && !pileUpAhead(geo, p, d, sc, pile))
        L += beta_k * float(sc.escaped * share) *
             emitterToward(origin, d, float(nbm * p.weight / wsum) * dr.pdf, nl_eff, ls.guides, nrays);
      if (bounce && !sc.hits.empty())
        L += shadeLevel(geo, beyond(gs, top), sc.hits, -d, beta_k, 1, ls, rng, nrays,
                        bsdfShare(chain, geo, portions, wsum, p, nm, nbm, dr.pdf, d), true);
    }
    return L;
  }

  // The chain's directions (Chain): each from pair j's stratum, its facet's BSDF seen from its
  // light direction (dropped outside the pair's cone), reversed, then a portion by weight among
  // those it leaves; the direct light on what it meets, by the balance heuristic against the
  // portions' nbm BSDF directions (jointDensity).
  template <class Geometry>
  Rgb chainDirect(const Geometry& geo, const Material& top, const std::vector<typename Geometry::Portion>& portions,
                  double wsum, Vec3f wo_w, Rgb beta, float nbm, const Chain& c, const LightSamples& ls,
                  Rng& rng, uint64_t& nrays) const {
    const GrooveSet& gs = geo.gs;
    LatinStrata lhs(c.n, 3, rng);
    const int nk = int(c.pairs.size());
    Rgb L(0.0f);
    for (int j = 0; j < c.n; ++j) {
      const size_t k = size_t(std::min(nk - 1, int((float(j) + rng.uniform()) * float(nk) / float(c.n))));
      BsdfSample bs;
      const Chain::Pair& pr = c.pairs[k];
      if (!sampleBsdf(*pr.m, pr.wl_local, lhs.at(0, j, rng), Vec2f{lhs.at(1, j, rng), lhs.at(2, j, rng)}, bs) ||
          !(bs.pdf > 0) || bs.wi.z <= 0)
        continue;
      const Vec3f v = pr.frame.toWorld(bs.wi);
      if (dot(v, pr.v0) < pr.cone) continue;  // outside the pair's cone: dropped (Chain::pdf)
      const Vec3f d = -v;
      const double wf = facingWeight(geo, portions, d);
      if (!(wf > 0)) continue;
      double u = rng.uniformD() * wf, acc = 0;
      const typename Geometry::Portion* pp = nullptr;
      for (const auto& q : portions) {
        if (!(dot(geo.normal(q), d) > 0)) continue;
        pp = &q;
        acc += q.weight;
        if (u < acc) break;
      }
      const auto& p = *pp;
      if (!(p.weight > 0)) continue;
      const Material& m = facetMaterial(gs, geo.layer(p), top);
      Frame fr = facetFrame(gs, geo.normal(p));
      const Vec3f wo = fr.toLocal(wo_w), wi = fr.toLocal(d);
      if (wo.z <= 0 || wi.z <= 0) continue;
      const BsdfAt bsdf(m, wo);
      float pdf;
      const Rgb f = bsdf.evalPdf(wi, pdf);
      if (maxComponent(f) <= 0) continue;
      const auto sc = geo.scatter(p, d);
      if (sc.hits.empty()) continue;
      const double density = jointDensity(p.weight, wsum, wf, nbm, pdf, c, d);
      const Rgb beta_k = beta * f * float(double(wi.z) / density);
      if (!isFinite(beta_k) || maxComponent(beta_k) <= 0) continue;
      L += shadeLevel(geo, beyond(gs, top), sc.hits, -d, beta_k, 1, ls, rng, nrays, 1.0f, true);
    }
    return L;
  }

  // The radiance of the emitter that direction d from `origin` (above the grooves) meets
  // unoccluded, the nearest area light or else the environment, times the MIS weight of a BSDF
  // direction of density `density` (count x pdf) against nl light samples per light.
  Rgb emitterToward(Vec3f origin, Vec3f d, float density, float nl, const LightGuides* guides, uint64_t& nrays) const {
    Rgb Le(0.0f);
    float pl = 0, tl = kInf;
    for (size_t i = 0; i < s_.lights.area.size(); ++i) {
      const AreaLight& al = s_.lights.area[i];
      float t;
      if (al.intersect(origin, d, 0.0f, tl, t)) {
        tl = t;
        Le = al.radiance;
        pl = guides ? guides->pdf(al, int(i), origin, origin + d * t) : al.pdfSolidAngle(origin, origin + d * t);
      }
    }
    if (tl == kInf && s_.lights.env) {
      Le = s_.lights.env->eval(d);
      pl = env_by_bsdf_ ? 0.0f : s_.lights.env->pdf(d);
    }
    if (maxComponent(Le) <= 0) return Rgb(0.0f);
    ++nrays;
    if (occluded(s_.part->scene(), origin, d, 0.0f, tl == kInf ? kInf : tl * (1 - 1e-4f))) return Rgb(0.0f);
    return Le * powerHeuristic(density, nl * pl);
  }

  // Whether every visible portion of the footprint lies on the base surface: 1-D sections only
  // (polygons hold a crossing or an end), whole (no end blended in), every visible facet flat
  // and level along the path.
  static bool seesOnlyFlat(const std::vector<GrooveSet>& sets, Vec3f wo_w) {
    for (const GrooveSet& set : sets) {
      if (set.area || set.end_share < 1.0f) return false;
      const Vec2d e_bw(dot(wo_w, set.B), dot(wo_w, set.W));
      for (const groove::Portion& p : groove::visible(set.section, e_bw, set.fp)) {
        const size_t k = size_t(p.facet);
        const Vec2d n = set.section.normal(k);
        if (n.x != 0.0 || set.section.tiltOf(k) != 0.0 || set.section.pts[k].y != 0.0) return false;
      }
    }
    return true;
  }

  Rgb shadeGrooves(const std::vector<GrooveSet>& sets, const Material& top, Vec3f wo_w, Rng& rng,
                   uint64_t& nrays, const PixelPattern* pads, int pad_s) const {
    const GrooveSet& gs = sets.front();  // every set shares the footprint centre and W
    const int nl = st_.groove_light_samples;
    // The light samples are shared by all facets (the shadowing inside the grooves is exact per
    // facet; the rest of the scene is tested once per sample).
    thread_local LightSamples ls;
    ls.clear();
    Vec3f origin = aboveGrooves(gs);
    RTCScene scene = s_.part->scene();
    // Where the footprint sees only the flat surface (a groove within reach may shadow it or light
    // it, but none lies in it), the samples are guided by what that surface (normal W, the top
    // material) makes of each light, as at the other camera hits. Where it sees a groove's walls
    // they stay uniform: guided by the flat surface, the swirls' walls under the bar light were
    // noisier (mean dE at 1 spp 0.25 -> 0.27, over four noise seeds). The cheap test of what the
    // footprint sees comes first, so that no guide is built only to be dropped.
    thread_local LightGuides guides;
    ls.guides = nullptr;
    if (guided_) {
      const Frame fr = facetFrame(gs, gs.W);
      const Vec3f wo = fr.toLocal(wo_w);
      if (wo.z > 0 && seesOnlyFlat(sets, wo_w) && buildGuides(origin, gs.W, fr, BsdfAt(top, wo), guides))
        ls.guides = &guides;
    }
    // nl samples per light (a light pattern); each carries 1/nl of the estimate and the MIS
    // weights count nl light samples per BSDF sample.
    forEachLightSample(nl, origin, pads, pad_s, rng, [&](int k, Vec3f wl, float dist, float pl, const Rgb& Le, bool env) {
      if (!(pl > 0) || (env && maxComponent(Le) <= 0)) return;
      ++nrays;
      bool vis = !occluded(scene, origin, wl, 0.0f, env ? kInf : dist * (1 - 1e-4f));
      ls.push_back({wl, Le, pl, vis, k, env});
    }, !env_by_bsdf_, ls.guides);
    Rgb L(0.0f);
    for (const GrooveSet& set : sets) {
      if (set.area) {
        L += shadeArea(set, top, wo_w, ls, rng, nrays) * set.share;
        continue;
      }
      Rgb Ls = shadeSection(set, set.section, top, wo_w, ls, rng, nrays);
      if (set.end_share < 1.0f) {
        Rgb L0 = shadeSection(set, set.section_without, top, wo_w, ls, rng, nrays);
        Ls = Ls * set.end_share + L0 * (1.0f - set.end_share);
      }
      L += Ls * set.share;
    }
    return L;
  }

  // The height of hit h above the part's own surface, for a mesh that keeps its vertices' heights
  // (the scratch reference; 0 for any other mesh), interpolated over the triangle.
  float cutHeight(const Hit& h) const {
    const TriangleMesh& mesh = s_.part->mesh();
    if (mesh.heights.size() != mesh.positions.size()) return 0.0f;
    const uint32_t* f = &mesh.indices[3 * size_t(h.prim)];
    return mesh.heights[f[0]] * (1 - h.b1 - h.b2) + mesh.heights[f[1]] * h.b1 + mesh.heights[f[2]] * h.b2;
  }
  // The material at height z: the coating layer at that depth, `top` above the surface or in the
  // top layer.
  const Material& layerAt(float z, const Material& top) const {
    const size_t layer = z < 0 ? size_t(s_.layer_stack.layerAtDepth(-double(z))) : 0;
    return layer == 0 || layer >= s_.layer_materials.size() ? top : s_.layer_materials[layer];
  }
  // The top material of the facets that a footprint's bounced directions meet (GrooveSet::beyond).
  static const Material& beyond(const GrooveSet& gs, const Material& top) { return gs.beyond ? *gs.beyond : top; }
  const Material& facetMaterial(const GrooveSet& gs, int layer, const Material& top) const {
    if (gs.one_material || layer <= 0 || size_t(layer) >= s_.layer_materials.size()) return top;
    return s_.layer_materials[size_t(layer)];
  }

  // Coverage of each scratch's visible facets in the pixel footprint (for the masks): per scratch,
  // its own section alone seen from the camera, the weight of its non-flat facets, times the share
  // of the footprint's length along the path that lies between the scratch's ends.
  void scratchCoverage(const SurfacePoint& sp, const Hit& h, Vec3f wo_w, std::vector<float>& cov) const {
    if (!outerSide(h, wo_w)) return;
    thread_local std::vector<NearGroove> near;
    nearGrooves(sp, (max_height_ + max_depth_) * viewTan(sp, wo_w), near);
    for (const NearGroove& ng : near) {
      Vec3f T, B, W;
      if (!grooveFrame(sp, ng.pp.tangent, T, B, W)) continue;
      // Where the closest point is an end, its scale is the end's: 0 at a faded tip (no groove
      // there), the full scale at a blunt one (fade_mm 0), whose groove stops at the end line.
      float k = ng.sc->scaleAt(ng.pp.s);
      if (!(k > 0)) continue;
      const float share = endShare(sp, T, ng);
      if (!(share > 0)) continue;
      Profile p = surfaceProfile(ng, sp.mm_per_uv);
      groove::PlacedProfile pl;
      pl.pts = &p.pts;
      pl.layer = &p.layer;
      pl.offset = -double(ng.pp.offset) * sp.mm_per_uv;
      groove::Footprint fp = footprintAcross(sp, B);
      groove::Section sec = groove::merge({pl}, sectionExtent(fp.halfWidth() + std::fabs(pl.offset) + p.halfExtent()));
      double lo = pl.offset + p.bMin(), hi = pl.offset + p.bMax();
      float c = 0;
      for (const auto& por : groove::visible(sec, Vec2d(dot(wo_w, B), dot(wo_w, W)), fp)) {
        Vec2d a = groove::pointOn(sec, por.facet, 0.0), b = groove::pointOn(sec, por.facet, 1.0);
        // Facets of the scratch: inside its b range and not on the base line.
        bool flat = a.y == 0 && b.y == 0;
        if (!flat && a.x >= lo - 1e-12 && b.x <= hi + 1e-12) c += float(por.weight);
      }
      uint16_t id = ng.sc->instanceId();
      if (id < cov.size()) cov[id] = std::max(cov[id], c * share);
    }
  }

  // The share of the pixel footprint's length along the path (its extent along T about its
  // centre, a box) that lies between the scratch's ends. 1 away from the ends; at a blunt end it
  // takes the pixels that the end line cuts to their covered share (a pixel whose centre lies just
  // past the end, whose coverage would otherwise be 0, and one just before it, which would count
  // whole), so that a mask ends where the groove does.
  static float endShare(const SurfacePoint& sp, Vec3f T, const NearGroove& ng) {
    const double mm = sp.mm_per_uv;
    const double half_t = 0.5 * (std::fabs(double(dot(sp.dpdx, T))) + std::fabs(double(dot(sp.dpdy, T))));
    const double len = ng.sc->path().length() * mm;
    // The footprint's centre along the path (mm from the start; past an end, beyond it).
    double x = double(ng.pp.s) * mm;
    if (ng.pp.beyond > 0) x = ng.pp.s > 0 ? len + double(ng.pp.beyond) * mm : -double(ng.pp.beyond) * mm;
    if (!(half_t > 0)) return x >= 0 && x <= len ? 1.0f : 0.0f;
    const double in = std::min(x + half_t, len) - std::max(x - half_t, 0.0);
    return float(std::clamp(in / (2 * half_t), 0.0, 1.0));
  }

  // Groove footprints by method (RenderStats), counted per thread and taken at each tile's end.
  struct GrooveCounts {
    uint64_t sections = 0, polygons = 0, trimmed = 0, fallbacks = 0, shared = 0;
  };
  static thread_local GrooveCounts counts_;
  static GrooveCounts takeCounts() {
    GrooveCounts c = counts_;
    counts_ = GrooveCounts();
    return c;
  }

  const RenderScene& s_;
  const RenderSettings& st_;
  const TriangleMesh& mesh_;
  bool has_defects_;
  bool has_weathering_ = false;  // rust or patina: covers that also reach into grooves
  bool needs_cavity_ = false;
  bool has_paint_ = false;
  bool has_scratches_ = false;
  // Whether a defect other than a scratch is present: their masks are sampled on the coverage
  // grid (render()), a scratch's coverage is analytic; and only they have a slope or a cover to
  // give a groove footprint.
  bool has_other_defects_ = false;
  bool grooves_ = false;
  // A constant environment (a dome) takes no light samples where groove shading samples many
  // BSDF directions (camera hits and groove footprints): those directions find it with a density
  // that follows the BSDF (zero variance on a diffuse surface, nearly so in a glossy lobe), while
  // light samples spread over the sphere seldom fall in a glossy lobe and cost a shadow test and a
  // BSDF evaluation on every facet portion each. Its BSDF directions then meet it with MIS weight
  // 1. Measured on the bench's scenes at 1 spp (2026-11-27, the mean over six noise seeds): the
  // same or lower mean dE (parallel/bar 0.465 and 0.465, parallel/ring 0.227 and 0.220, swirls
  // 0.304 and 0.270) in 13% less time. An environment map keeps its light samples (a sun in it
  // is small and bright).
  bool env_by_bsdf_ = false;
  // Whether camera hits and flat groove footprints guide their light samples (buildGuides).
  bool guided_ = false;
  float max_height_ = 0, max_depth_ = 0, max_half_ = 0;  // over all scratches (mm)
  float min_half_ = 1e30f;  // the narrowest scratch's half extent at its largest scale (uv)
  int strata_x_ = 1, strata_y_ = 1;  // a pixel's strata (grooveStrata): a camera hit's footprint is one
  float tan_light_max_ = 6.0f;  // cap on the shadow reach toward grazing lights (Bosch §4.2.1)
  std::vector<std::vector<int>> blockers_;  // findBlockers()
  int sub_count_ = 1;   // light-sample subsets at deeper groove levels (shadeLevel)
};

thread_local Tracer::GrooveCounts Tracer::counts_;

DiffRay cameraRay(const RayGenerator& gen, float px, float py) {
  DiffRay r;
  gen.generate(px, py, r.o, r.d, r.dddx, r.dddy);
  r.dodx = r.dody = Vec3f(0.0f);
  return r;
}

}  // namespace

std::vector<Material> layerMaterials(const Material& part, const LayerStack& stack) {
  std::vector<Material> out;
  for (size_t i = 0; i < stack.layers.size(); ++i) {
    if (i == 0) {
      out.push_back(part);
      continue;
    }
    const std::string& name = stack.layers[i].name;
    Material m;
    if (name == "steel") {
      const MetalIor* ior = findMetal("steel");
      m.kind = MaterialKind::Conductor;
      m.eta = ior->eta;
      m.k = ior->k;
      m.roughness = 0.3f;
    } else if (name == "base_coat") {
      m.kind = MaterialKind::RoughDiffuse;
      m.base_color = part.base_color;
      m.sigma = 0.3f;
    } else {  // primer and anything else: a grey rough diffuse layer
      m.kind = MaterialKind::RoughDiffuse;
      m.base_color = Rgb(0.32f, 0.32f, 0.30f);
      m.sigma = 0.4f;
    }
    out.push_back(m);
  }
  return out;
}

RenderFrame render(const RenderScene& scene, const RenderSettings& st) {
  const int W = scene.camera.K.width, H = scene.camera.K.height;
  RenderFrame out;
  if (st.want_rgb) out.rgb = ImageF(W, H, 3);
  if (st.want_depth) out.depth = ImageF(W, H, 1);
  if (st.want_normals) out.normal = ImageF(W, H, 3);
  const bool coverage = st.want_coverage && scene.defects && !scene.defects->empty();
  if (st.want_coverage) {
    out.dominant = Image<uint16_t>(W, H, 1);
    out.coverage = ImageF(W, H, 1);
  }
  RayGenerator gen(scene.camera);
  Tracer tracer(scene, st);
  const int tile = tileSize(W, H);
  const int tx = (W + tile - 1) / tile, ty = (H + tile - 1) / tile;
  std::atomic<uint64_t> rays{0}, g_sections{0}, g_polygons{0}, g_trimmed{0}, g_fallbacks{0}, g_shared{0};
  std::atomic<bool> part_in_view{false};
  const int K = std::max(1, st.coverage_grid);
  const int ninst = scene.defects ? int(scene.defects->size()) : 0;
  int sx = 1, sy = 1;
  grooveStrata(st.spp, sx, sy);
  const int spp_g = latticeGenerator(st.spp);
  // Groove shading: the pixel's camera samples share one lattice per light (PixelPattern::light).
  const int light_g = tracer.grooves_ && st.spp > 1 && st.groove_light_samples > 1
                          ? latticeGenerator(st.groove_light_samples * st.spp, st.groove_light_samples,
                                             latticeGenerator(st.groove_light_samples))
                          : 0;
  // Camera hits off the grooves take fewer from 16 spp on (Tracer::cameraHitLights): a lattice
  // of their own.
  const int cam_nl = tracer.grooves_ ? tracer.cameraHitLights() : 1;
  const int cam_light_g = light_g > 0 && cam_nl > 1 && cam_nl != st.groove_light_samples
                              ? latticeGenerator(cam_nl * st.spp, cam_nl, latticeGenerator(cam_nl))
                              : 0;
  // And their split BSDF directions off the grooves (PixelPattern::direction; a glass hit that
  // takes fewer draws its own lattice).
  const int split = tracer.grooves_ ? tracer.cameraHitSplit() : 1;
  const int split_g = st.spp > 1 && split > 1 ? latticeGenerator(split * st.spp, split, latticeGenerator(split)) : 0;

  parallelFor(size_t(tx) * ty, [&](size_t t) {
    int x0 = int(t % tx) * tile, y0 = int(t / tx) * tile;
    int x1 = std::min(W, x0 + tile), y1 = std::min(H, y0 + tile);
    uint64_t local_rays = 0;
    bool tile_sees_part = false;
    Tracer::takeCounts();  // start this tile's groove counts from zero
    Tracer::forgetSharedArea();  // and no polygon surface to share (Tracer::SharedArea)
    std::vector<uint16_t> counts(size_t(ninst) + 1);
    PixelPattern pads;
    std::vector<float> scov(size_t(ninst) + 1);
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) {
        uint64_t pixel = uint64_t(y) * W + x;
        if (st.want_rgb) {
          Rgb sum(0.0f);
          if (st.spp > 1) {
            Rng prng(hashKey(st.seed, uint64_t(Stream::PixelPattern), st.sample_index, pixel));
            pads.reset(st.spp, spp_g, tracer.padDimensions(), prng);
            if (light_g > 0) pads.resetLights(tracer.padDimensions() - 2, st.groove_light_samples, light_g, prng);
            if (cam_light_g > 0) pads.resetLights(tracer.padDimensions() - 2, cam_nl, cam_light_g, prng);
            if (split_g > 0) pads.resetDirections(split, split_g, prng);
          }
          for (int s = 0; s < st.spp; ++s) {
            Rng rng(hashKey(st.seed, uint64_t(Stream::Pixel), st.sample_index, pixel * 65536u + s));
            // Pixel (x, y) covers [x - 0.5, x + 0.5] in OpenCV's convention; box filter.
            const float ux = rng.uniform(), uy = rng.uniform();
            float jx = ux, jy = uy;
            if (st.spp > 1) {
              const Vec2f j = pads.at(tracer.padDimensions() - 1, s, false);
              jx = j.x;
              jy = j.y;
            }
            DiffRay r, plate;
            if (tracer.grooves_) {
              // Groove rendering integrates each stratum's footprint analytically: samples sit at
              // the centres of sx x sy strata with a footprint of one stratum.
              // Away from the grooves the sample is traced through a uniform point of its stratum
              // (Tracer::trace's `plate`) with the footprint of the whole pixel, as the path
              // tracer's samples are: what filters by the footprint (the paint's flakes and orange
              // peel, bumps) then looks the same at every spp and in both renderers.
              int i = s % sx, j = s / sx;
              r = cameraRay(gen, x - 0.5f + (i + 0.5f) / sx, y - 0.5f + (j + 0.5f) / sy);
              r.dddx = r.dddx / float(sx);
              r.dddy = r.dddy / float(sy);
              plate = cameraRay(gen, x - 0.5f + (i + ux) / sx, y - 0.5f + (j + uy) / sy);
            } else {
              r = cameraRay(gen, x - 0.5f + jx, y - 0.5f + jy);
            }
            Rgb c = tracer.trace(r, rng, local_rays, st.spp > 1 ? &pads : nullptr, s,
                                 tracer.grooves_ ? &plate : nullptr);
            if (isFinite(c)) sum += c;
          }
          float* o = out.rgb.at(x, y);
          o[0] = sum.x / st.spp;
          o[1] = sum.y / st.spp;
          o[2] = sum.z / st.spp;
        }
        if (st.want_depth || st.want_normals) {
          DiffRay r = cameraRay(gen, float(x), float(y));
          Hit h = intersect(scene.part->scene(), r.o, r.d, 0.0f, kInf);
          ++local_rays;
          if (h.hit) {
            SurfacePoint sp = tracer.surface(h, r, tracer.has_defects_);
            if (st.want_depth) {
              Vec3d pc = scene.camera.world_to_camera.apply(Vec3d(sp.p));
              out.depth(x, y) = float(pc.z);
            }
            if (st.want_normals) {
              tracer.applyDefects(sp, -r.d, h);
              float* o = out.normal.at(x, y);
              o[0] = sp.ns.x;
              o[1] = sp.ns.y;
              o[2] = sp.ns.z;
            }
          }
        }
        if (coverage) {
          // The footprint's visible surface, sampled on a K x K grid of primary rays: the
          // fraction of those points inside each defect's labelled region is its coverage.
          std::fill(counts.begin(), counts.end(), 0);
          std::fill(scov.begin(), scov.end(), 0.0f);
          if (tracer.has_scratches_) {
            // Scratches: the analytic coverage of their visible facets in the pixel footprint.
            DiffRay r = cameraRay(gen, float(x), float(y));
            Hit h = intersect(scene.part->scene(), r.o, r.d, 0.0f, kInf);
            ++local_rays;
            if (h.hit) {
              SurfacePoint sp = tracer.surface(h, r, true);
              if (sp.uv_ok) tracer.scratchCoverage(sp, h, -r.d, scov);
            }
          }
          // The other defects' masks, sampled on a K x K grid of primary rays. Where every defect
          // is a scratch the grid finds nothing and is skipped, except to learn whether the tile
          // sees the part at all (as far as one of its rays meets it); on the wash swirls at 1 spp
          // it was a tenth of the render's time.
          for (int j = 0; j < K && (tracer.has_other_defects_ || !tile_sees_part); ++j)
            for (int i = 0; i < K && (tracer.has_other_defects_ || !tile_sees_part); ++i) {
              float px = x - 0.5f + (i + 0.5f) / K, py = y - 0.5f + (j + 0.5f) / K;
              DiffRay r = cameraRay(gen, px, py);
              Hit h = intersect(scene.part->scene(), r.o, r.d, 0.0f, kInf);
              ++local_rays;
              tile_sees_part = tile_sees_part || h.hit;
              if (!h.hit || h.shell) continue;
              const uint32_t* f = &scene.part->mesh().indices[3 * h.prim];
              const auto& uvs = scene.part->mesh().uvs;
              if (uvs.empty()) continue;
              DefectQuery q;
              q.uv = uvs[f[0]] * (1 - h.b1 - h.b2) + uvs[f[1]] * h.b1 + uvs[f[2]] * h.b2;
              if (tracer.needs_cavity_) q.cavity = scene.part->occlusionAt(h.prim, h.b1, h.b2);
              scene.defect_index.forEach(q.uv, 0.0f, [&](const Defect& d) {
                if (d.cls() != DefectClass::Scratch && d.inMask(q)) ++counts[d.instanceId()];
              });
            }
          uint16_t best = 0;
          float best_cov = 0;
          for (int id = 1; id <= ninst; ++id) {
            float c = std::max(float(counts[id]) / float(K * K), scov[id]);
            if (c > best_cov) {
              best_cov = c;
              best = uint16_t(id);
            }
          }
          out.dominant(x, y) = best;
          out.coverage(x, y) = best_cov;
        } else if (!tile_sees_part) {
          // Without the mask pass, one ray through each pixel centre until one meets the part.
          DiffRay r = cameraRay(gen, float(x), float(y));
          ++local_rays;
          tile_sees_part = intersect(scene.part->scene(), r.o, r.d, 0.0f, kInf).hit;
        }
      }
    rays += local_rays;
    if (tile_sees_part) part_in_view = true;
    auto gc = Tracer::takeCounts();
    g_sections += gc.sections;
    g_polygons += gc.polygons;
    g_trimmed += gc.trimmed;
    g_shared += gc.shared;
    g_fallbacks += gc.fallbacks;
  });
  out.stats.rays = rays.load();
  out.stats.part_in_view = part_in_view.load();
  out.stats.groove_sections = g_sections.load();
  out.stats.groove_polygons = g_polygons.load();
  out.stats.groove_trimmed = g_trimmed.load();
  out.stats.groove_shared = g_shared.load();
  out.stats.groove_fallbacks = g_fallbacks.load();
  return out;
}

uint64_t primaryPass(const RenderScene& scene, const RayGenerator& gen) {
  const int W = scene.camera.K.width, H = scene.camera.K.height;
  const int tile = tileSize(W, H);
  const int tx = (W + tile - 1) / tile, ty = (H + tile - 1) / tile;
  std::atomic<uint64_t> hits{0};
  RTCScene rs = scene.part->scene();
  parallelFor(size_t(tx) * ty, [&](size_t t) {
    int x0 = int(t % tx) * tile, y0 = int(t / tx) * tile;
    int x1 = std::min(W, x0 + tile), y1 = std::min(H, y0 + tile);
    uint64_t n = 0;
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) {
        DiffRay r = cameraRay(gen, float(x), float(y));
        n += intersect(rs, r.o, r.d, 0.0f, kInf).hit;
      }
    hits += n;
  });
  return hits.load();
}

}  // namespace dg
