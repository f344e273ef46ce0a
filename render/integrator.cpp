#include "render/integrator.h"

#include <atomic>
#include <cmath>
#include <limits>

#include "core/parallel.h"
#include "core/rng.h"

namespace dg {

namespace {

constexpr int kTile = 32;
constexpr float kInf = std::numeric_limits<float>::infinity();

// A ray with its two auxiliary rays (Igehy 1999, "Tracing ray differentials"), stored as the
// offsets of their origins and directions from the main ray for a one-pixel step in x and y.
struct DiffRay {
  Vec3f o, d;
  Vec3f dodx, dody, dddx, dddy;
};

struct Hit {
  bool hit = false;
  float t = kInf;
  unsigned prim = 0;
  float b1 = 0, b2 = 0;  // barycentrics of vertices 1 and 2
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

// Everything the integrator needs to know about a surface point.
struct SurfacePoint {
  Vec3f p, ng, ns;  // ng and ns face the incoming ray
  Vec2f uv;
  Vec3f dpdu, dpdv;
  bool uv_ok;
  float mm_per_uv;
  Vec3f dpdx, dpdy;
  Vec2f duvdx, duvdy;
};

// Offset for spawning rays off the surface, scaled with the magnitude of the coordinates.
float rayEpsilon(Vec3f p) { return 1e-4f * std::max(1.0f, maxComponent(Vec3f(std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)))); }

class Tracer {
 public:
  Tracer(const RenderScene& s, const RenderSettings& st)
      : s_(s), st_(st), mesh_(s.part->mesh()), has_defects_(s.defects && !s.defects->empty()) {
    if (has_defects_)
      for (auto& d : *s.defects) needs_cavity_ |= d->needsCavity();
    has_paint_ = s.paint != nullptr && s.material.kind == MaterialKind::CarPaint;
  }

  SurfacePoint surface(const Hit& h, const DiffRay& r, bool need_footprint) const {
    SurfacePoint sp;
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
    // Two-sided: the normals face the side the ray came from.
    if (dot(sp.ng, r.d) > 0) {
      sp.ng = -sp.ng;
      sp.ns = -sp.ns;
    }
    if (dot(sp.ns, sp.ng) <= 0) sp.ns = sp.ng;
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

  // Applies the defects at a surface point: their height gradients perturb the shading normal
  // (Blinn 1978 in surface-gradient form: n' = normalize(n - grad_s F), shared/reference/
  // blinn-bump.md §3b and §8.3), and weathering may replace the surface's look (returned cover and
  // appearance).
  // `extra_grad` is a height gradient from the surface itself (the clear coat's orange peel).
  DefectShading applyDefects(SurfacePoint& sp, Vec3f wo_world, const Hit& h, Vec2f extra_grad = {0, 0}) const {
    DefectShading ds;
    if (!sp.uv_ok) return ds;
    ds.height_grad = extra_grad;
    if (has_defects_) {
      DefectQuery q;
      q.uv = sp.uv;
      q.duv_dx = sp.duvdx;
      q.duv_dy = sp.duvdy;
      q.mm_per_uv = sp.mm_per_uv;
      if (needs_cavity_) q.cavity = s_.part->occlusionAt(h.prim, h.b1, h.b2);
      s_.defect_index.forEach(sp.uv, q.footprint(), [&](const Defect& d) { d.shade(q, ds); });
    }
    if (ds.height_grad.x == 0 && ds.height_grad.y == 0) return ds;
    Vec3f N = cross(sp.dpdu, sp.dpdv);
    float n2 = dot(N, N);
    Vec3f pu = cross(sp.dpdv, N) / n2, pv = cross(N, sp.dpdu) / n2;  // dual basis
    Vec3f grad = pu * ds.height_grad.x + pv * ds.height_grad.y;
    // The height is measured along the outward shading normal; a ray from behind sees the sheet's
    // back, where the same displacement reads as the opposite (digest §8.3).
    grad = grad - sp.ns * dot(grad, sp.ns);
    Vec3f n = normalize(sp.ns - grad);
    // Keep the perturbed normal in the hemisphere of the viewer (digest §8.3, hemisphere safety).
    float c = dot(n, wo_world);
    if (c < 0.02f) n = normalize(n + wo_world * (0.02f - c));
    sp.ns = n;
    return ds;
  }

  static float footprintOf(const SurfacePoint& sp) {
    return std::max(std::max(std::fabs(sp.duvdx.x), std::fabs(sp.duvdx.y)),
                    std::max(std::fabs(sp.duvdy.x), std::fabs(sp.duvdy.y)));
  }

  // Car paint's variation at this point (Nilsson 2008 §4.3): base colour scaled, passive flakes
  // tint the flake lobe, and where a resolved flake is picked (probability = its sparkle weight)
  // the flake lobe becomes a near-mirror around that flake's normal; elsewhere the smooth flake
  // lobe keeps the rest of the flake energy, so the mean matches flake_amount.
  static void applyPaint(Material& m, const PaintSample& ps) {
    m.base_color *= ps.base_color_scale;
    m.flake_tint_scale = ps.flake_specular_scale;
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

  Rgb trace(DiffRay ray, Rng& rng, uint64_t& nrays) const {
    Rgb L(0.0f), beta(1.0f);
    float prev_pdf = 0;
    bool prev_specular = true;  // camera rays count as "specular": no MIS on directly seen lights
    Vec3f prev_p;
    RTCScene scene = s_.part->scene();
    for (int depth = 0;; ++depth) {
      Hit h = intersect(scene, ray.o, ray.d, 0.0f, kInf);
      ++nrays;
      // Emitters are not in the BVH; test them analytically against the part's hit distance.
      int light_hit = -1;
      float tl = h.t;
      for (size_t i = 0; i < s_.lights.area.size(); ++i) {
        const AreaLight& al = s_.lights.area[i];
        if (depth == 0 && !al.visible_to_camera) continue;
        float t;
        if (al.intersect(ray.o, ray.d, 0.0f, tl, t)) {
          tl = t;
          light_hit = int(i);
        }
      }
      if (light_hit >= 0) {
        const AreaLight& al = s_.lights.area[light_hit];
        float w = 1.0f;
        if (!prev_specular) w = powerHeuristic(prev_pdf, al.pdfSolidAngle(prev_p, ray.o + ray.d * tl));
        L += beta * al.radiance * w;
        break;
      }
      if (!h.hit) {
        if (s_.lights.env) {
          float w = prev_specular ? 1.0f : powerHeuristic(prev_pdf, s_.lights.env->pdf(ray.d));
          L += beta * s_.lights.env->eval(ray.d) * w;
        }
        break;
      }
      if (depth >= st_.max_bounces) break;
      SurfacePoint sp = surface(h, ray, has_defects_ || has_paint_);
      Vec3f wo_w = -ray.d;
      Material m = s_.material;
      Vec2f peel(0.0f, 0.0f);
      if (has_paint_ && sp.uv_ok) {
        PaintSample ps = s_.paint->evaluate(sp.uv, footprintOf(sp), rng.uniform());
        peel = ps.coat_height_grad;
        applyPaint(m, ps);
      }
      DefectShading ds = applyDefects(sp, wo_w, h, peel);
      Frame fr = Frame::fromNormalTangent(sp.ns, sp.dpdu);
      Vec3f wo = fr.toLocal(wo_w);
      if (wo.z <= 0) break;
      if (ds.cover > 0) m = weathered(m, ds, rng.uniform());
      float eps = rayEpsilon(sp.p);
      Vec3f origin = sp.p + sp.ng * eps;

      // Next-event estimation: one sample on every light, MIS against the BSDF's sampling.
      for (const AreaLight& al : s_.lights.area) {
        Vec2f u{rng.uniform(), rng.uniform()};
        Vec3f q = al.samplePoint(u);
        Vec3f wl = q - origin;
        float dist = length(wl);
        if (!(dist > 0)) continue;
        wl = wl / dist;
        if (dot(wl, sp.ng) <= 0 || -dot(wl, al.normal) <= 0) continue;
        float pl = al.pdfSolidAngle(origin, q);
        Vec3f wi = fr.toLocal(wl);
        if (wi.z <= 0 || !(pl > 0)) continue;
        Rgb f = evalBsdf(m, wo, wi);
        if (maxComponent(f) <= 0) continue;
        ++nrays;
        if (occluded(scene, origin, wl, 0.0f, dist * (1 - 1e-4f))) continue;
        float w = powerHeuristic(pl, pdfBsdf(m, wo, wi));
        L += beta * f * al.radiance * (wi.z * w / pl);
      }
      if (s_.lights.env) {
        Vec2f u{rng.uniform(), rng.uniform()};
        Rgb Le;
        float pe;
        Vec3f wl = s_.lights.env->sample(u, Le, pe);
        Vec3f wi = fr.toLocal(wl);
        if (pe > 0 && wi.z > 0 && dot(wl, sp.ng) > 0 && maxComponent(Le) > 0) {
          Rgb f = evalBsdf(m, wo, wi);
          if (maxComponent(f) > 0 && (++nrays, !occluded(scene, origin, wl, 0.0f, kInf))) {
            float w = powerHeuristic(pe, pdfBsdf(m, wo, wi));
            L += beta * f * Le * (wi.z * w / pe);
          }
        }
      }

      // Continue the path by sampling the BSDF.
      BsdfSample bs;
      float ul = rng.uniform();
      Vec2f ud{rng.uniform(), rng.uniform()};
      if (!sampleBsdf(m, wo, ul, ud, bs) || !(bs.pdf > 0) || bs.wi.z <= 0) break;
      Vec3f wi_w = fr.toWorld(bs.wi);
      if (dot(wi_w, sp.ng) <= 0) break;  // below the geometric surface
      beta *= bs.f * (bs.wi.z / bs.pdf);
      if (!isFinite(beta) || maxComponent(beta) <= 0) break;
      prev_pdf = bs.pdf;
      prev_specular = false;
      prev_p = origin;
      // Auxiliary rays follow the mirror transfer about the shading normal (the surface's
      // curvature is neglected); after a rough bounce this underestimates the footprint.
      DiffRay nr;
      nr.o = origin;
      nr.d = wi_w;
      nr.dodx = sp.dpdx;
      nr.dody = sp.dpdy;
      Vec3f rx = reflect(ray.d + ray.dddx, sp.ns), ry = reflect(ray.d + ray.dddy, sp.ns);
      Vec3f r0 = reflect(ray.d, sp.ns);
      nr.dddx = rx - r0;
      nr.dddy = ry - r0;
      ray = nr;
      // Russian roulette after three bounces; the survival test uses the path's own random stream.
      if (depth >= 3) {
        float q = std::max(0.05f, 1.0f - maxComponent(beta));
        if (rng.uniform() < q) break;
        beta = beta / (1.0f - q);
      }
    }
    return L;
  }

  const RenderScene& s_;
  const RenderSettings& st_;
  const TriangleMesh& mesh_;
  bool has_defects_;
  bool needs_cavity_ = false;
  bool has_paint_ = false;
};

DiffRay cameraRay(const RayGenerator& gen, float px, float py) {
  DiffRay r;
  gen.generate(px, py, r.o, r.d, r.dddx, r.dddy);
  r.dodx = r.dody = Vec3f(0.0f);
  return r;
}

}  // namespace

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
  const int tx = (W + kTile - 1) / kTile, ty = (H + kTile - 1) / kTile;
  std::atomic<uint64_t> rays{0};
  const int K = std::max(1, st.coverage_grid);
  const int ninst = scene.defects ? int(scene.defects->size()) : 0;

  parallelFor(size_t(tx) * ty, [&](size_t tile) {
    int x0 = int(tile % tx) * kTile, y0 = int(tile / tx) * kTile;
    int x1 = std::min(W, x0 + kTile), y1 = std::min(H, y0 + kTile);
    uint64_t local_rays = 0;
    std::vector<uint16_t> counts(size_t(ninst) + 1);
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) {
        uint64_t pixel = uint64_t(y) * W + x;
        if (st.want_rgb) {
          Rgb sum(0.0f);
          for (int s = 0; s < st.spp; ++s) {
            Rng rng(hashKey(st.seed, uint64_t(Stream::Pixel), st.sample_index, pixel * 65536u + s));
            // Pixel (x, y) covers [x - 0.5, x + 0.5] in OpenCV's convention; box filter.
            float px = x - 0.5f + rng.uniform(), py = y - 0.5f + rng.uniform();
            Rgb c = tracer.trace(cameraRay(gen, px, py), rng, local_rays);
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
          for (int j = 0; j < K; ++j)
            for (int i = 0; i < K; ++i) {
              float px = x - 0.5f + (i + 0.5f) / K, py = y - 0.5f + (j + 0.5f) / K;
              DiffRay r = cameraRay(gen, px, py);
              Hit h = intersect(scene.part->scene(), r.o, r.d, 0.0f, kInf);
              ++local_rays;
              if (!h.hit) continue;
              const uint32_t* f = &scene.part->mesh().indices[3 * h.prim];
              const auto& uvs = scene.part->mesh().uvs;
              if (uvs.empty()) continue;
              DefectQuery q;
              q.uv = uvs[f[0]] * (1 - h.b1 - h.b2) + uvs[f[1]] * h.b1 + uvs[f[2]] * h.b2;
              if (tracer.needs_cavity_) q.cavity = scene.part->occlusionAt(h.prim, h.b1, h.b2);
              scene.defect_index.forEach(q.uv, 0.0f, [&](const Defect& d) {
                if (d.inMask(q)) ++counts[d.instanceId()];
              });
            }
          uint16_t best = 0;
          for (int id = 1; id <= ninst; ++id)
            if (counts[id] > counts[best] || (best == 0 && counts[id] > 0)) best = uint16_t(id);
          out.dominant(x, y) = best;
          out.coverage(x, y) = best ? float(counts[best]) / float(K * K) : 0.0f;
        }
      }
    rays += local_rays;
  });
  out.stats.rays = rays.load();
  return out;
}

uint64_t primaryPass(const RenderScene& scene, const RayGenerator& gen) {
  const int W = scene.camera.K.width, H = scene.camera.K.height;
  const int tx = (W + kTile - 1) / kTile, ty = (H + kTile - 1) / kTile;
  std::atomic<uint64_t> hits{0};
  RTCScene rs = scene.part->scene();
  parallelFor(size_t(tx) * ty, [&](size_t tile) {
    int x0 = int(tile % tx) * kTile, y0 = int(tile / tx) * kTile;
    int x1 = std::min(W, x0 + kTile), y1 = std::min(H, y0 + kTile);
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
