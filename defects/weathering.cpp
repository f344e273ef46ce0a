#include "defects/weathering.h"

#include <cmath>
#include <stdexcept>

#include "core/rng.h"

namespace dg {

namespace {

Rgb lerp(Rgb a, Rgb b, float t) { return a * (1 - t) + b * t; }
float smoothstep(float e0, float e1, float x) {
  float t = clampf((x - e0) / (e1 - e0), 0.0f, 1.0f);
  return t * t * (3 - 2 * t);
}
nlohmann::json rgbJson(Rgb c) { return {c.x, c.y, c.z}; }

}  // namespace

// ---------------------------------------------------------------------------------------------
// Rust
// ---------------------------------------------------------------------------------------------

Rust::Rust(const RustParams& p)
    : p_(p),
      front_noise_(hashKey(p.seed, 1)),
      color_noise_(hashKey(p.seed, 2)),
      detail_noise_(hashKey(p.seed, 3)) {
  if (!(p.radius_mm > 0) || !(p.age_years >= 0) || !(p.growth_years > 0))
    throw std::invalid_argument("Rust: radius > 0, age >= 0, growth_years > 0 required");
  g_ = 1.0f - std::exp(-p.age_years / p.growth_years);
  front_fbm_.octaves = 5;
  front_fbm_.base_frequency = 2.0f / p.radius_mm;
  color_fbm_.octaves = 4;
  color_fbm_.base_frequency = 6.0f / p.radius_mm;
  detail_fbm_.octaves = 4;
  detail_fbm_.base_frequency = 1.0f;  // ~1 mm grains of rust
  if (!p.origin_path.empty()) path_ = ScratchPath::polyline(p.origin_path);
}

float Rust::extent() const { return p_.radius_mm * (g_ + p_.roughness) + p_.blister_width_mm; }

// Distance from p to the origin (point or path) and the unit direction away from it.
float Rust::originDistance(Vec2f p, Vec2f* dir) const {
  Vec2f d;
  if (path_) {
    // Farther than extent() nothing is rusty or blistered whatever the noise (phi >= g + ring
    // there), so the query stops at that distance and reports it.
    float ext = extent();
    PathPoint q = path_->closest(p, ext);
    if (!q.found) {
      if (dir) *dir = Vec2f(0, 0);
      return ext;
    }
    d = p - q.point;
  } else {
    d = p - p_.origin_uv;
  }
  float r = std::sqrt(d.x * d.x + d.y * d.y);
  if (dir) *dir = r > 0 ? d / r : Vec2f(0, 0);
  return r;
}

float Rust::phi(Vec2f p, float footprint, Vec2f* grad) const {
  Vec2f dir;
  float r = originDistance(p, grad ? &dir : nullptr);
  Vec2f gn;
  float n = fbm2(front_noise_, p, front_fbm_, footprint, grad ? &gn : nullptr);
  if (grad) *grad = dir * (1.0f / p_.radius_mm) + gn * p_.roughness;
  return r / p_.radius_mm + p_.roughness * n;
}

// The origin (point or path) grown by `ext` on every side.
Box2 Rust::originBox(float ext) const {
  Box2 o = path_ ? path_->bounds() : Box2{p_.origin_uv, p_.origin_uv};
  Box2 b;
  b.lo = o.lo - Vec2f(ext, ext);
  b.hi = o.hi + Vec2f(ext, ext);
  return b;
}

Box2 Rust::support() const { return originBox(extent()); }

Box2 Rust::maskBox() const { return originBox(p_.radius_mm * (g_ + p_.roughness)); }

bool Rust::inMask(Vec2f p) const { return g_ > 0 && phi(p) < g_; }

void Rust::shade(const DefectQuery& q, DefectShading& s) const {
  if (g_ <= 0) return;
  float fp = q.footprint();
  Vec2f gphi;
  float ph = phi(q.uv, fp, &gphi);
  float ring = p_.blister_width_mm / p_.radius_mm;
  if (ph >= g_ + ring) return;
  float k = q.mm_per_uv > 0 ? 1.0f / q.mm_per_uv : 1.0f;  // d/d(uv) of quantities in surface mm
  if (ph >= g_) {
    // Lifted paint around the front: bubbles (positive part of a ~1.5 mm noise, squared),
    // strongest at the front and fading over the ring.
    Vec2f gb;
    float n = front_noise_.noise2(q.uv * (1.0f / 1.5f), &gb);
    if (n <= 0) return;
    float w = 1.0f - (ph - g_) / ring;
    float b = n * n;
    Vec2f grad_b = gb * (2 * n / 1.5f);
    Vec2f grad = (grad_b * w + gphi * (-b / ring)) * p_.blister_height_mm;
    s.height_grad += grad * k;
    return;
  }
  // Inside the rust: local age s in (0, 1], 1 at the origin.
  float age = (g_ - ph) / g_;
  Vec2f gc;
  float c = color_noise_.noise2(q.uv * color_fbm_.base_frequency, &gc);
  float t = clampf(age + 0.15f * c, 0.0f, 1.0f);
  Rgb col = lerp(p_.fresh, p_.old, t);
  // Yellowish accents on young rust (digest §4.2 step 5: per-layer variation).
  float acc = fbm2(color_noise_, q.uv + Vec2f(37.1f, 11.3f), color_fbm_, fp);
  col = lerp(col, p_.accent, smoothstep(0.35f, 0.7f, acc) * (1 - t) * 0.6f);
  SurfaceAppearance a;
  a.albedo = col;
  a.sigma_rad = p_.sigma_rad;
  s.addCover(1.0f, a);
  // Height: pitted by age (deeper where older) plus fine grains.
  Vec2f gd;
  fbm2(detail_noise_, q.uv, detail_fbm_, fp, &gd);
  Vec2f grad_age = gphi * (-1.0f / g_);
  Vec2f grad = grad_age * (-p_.pit_depth_mm) + gd * (0.3f * p_.pit_depth_mm);
  s.height_grad += grad * k;
}

nlohmann::json Rust::attributes() const {
  nlohmann::json j = {{"kind", "rust"},
          {"origin", p_.origin},
          {"origin_uv_mm", {p_.origin_uv.x, p_.origin_uv.y}},
          {"radius_mm", p_.radius_mm},
          {"age_years", p_.age_years},
          {"growth_years", p_.growth_years},
          {"front", g_},
          {"roughness", p_.roughness},
          {"pit_depth_mm", p_.pit_depth_mm},
          {"blister_width_mm", p_.blister_width_mm},
          {"fresh_color", rgbJson(p_.fresh)},
          {"old_color", rgbJson(p_.old)},
          {"seed", p_.seed}};
  if (path_) {
    j["origin_scratch"] = p_.origin_scratch;
    j["origin_length_mm"] = path_->length();
  }
  return j;
}

// ---------------------------------------------------------------------------------------------
// Patina
// ---------------------------------------------------------------------------------------------

float Patina::normalizedAge(float years, float environment) {
  const float t0 = 1.0f / 12.0f, full = 25.0f;  // one month; full coverage at ~25 years (digest §5.1)
  float t = std::max(0.0f, years * environment);
  return clampf(std::log1p(t / t0) / std::log1p(full / t0), 0.0f, 1.0f);
}

Patina::Patina(const PatinaParams& p)
    : p_(p), cover_noise_(hashKey(p.seed, 11)), band_noise_(hashKey(p.seed, 12)) {
  if (!(p.radius_mm >= 0) || !(p.age_years >= 0) || !(p.scale_mm > 0))
    throw std::invalid_argument("Patina: radius >= 0, age >= 0, scale > 0 required");
  a_ = normalizedAge(p.age_years, p.environment);
  cover_fbm_.octaves = 5;
  cover_fbm_.base_frequency = 1.0f / p.scale_mm;
  band_fbm_.octaves = 3;
  band_fbm_.base_frequency = 2.0f / p.scale_mm;
}

bool Patina::inDisc(Vec2f p) const {
  if (p_.radius_mm <= 0) return p_.part_uv.contains(p);
  Vec2f d = p - p_.center_uv;
  return d.x * d.x + d.y * d.y <= p_.radius_mm * p_.radius_mm;
}

Box2 Patina::support() const {
  if (p_.radius_mm <= 0) return p_.part_uv;
  Box2 b;
  b.lo = p_.center_uv - Vec2f(p_.radius_mm, p_.radius_mm);
  b.hi = p_.center_uv + Vec2f(p_.radius_mm, p_.radius_mm);
  return b;
}

float Patina::value(Vec2f p, float cavity, float footprint, Vec2f* grad) const {
  float n = 0.5f * (fbm2(cover_noise_, p, cover_fbm_, footprint, grad) + 1.0f);
  float lam = p_.cavity_weight;
  if (grad) *grad = *grad * (0.5f * (1 - lam));
  return (1 - lam) * n + lam * cavity;
}

bool Patina::inMask(Vec2f p) const { return inDisc(p) && a_ > 0 && value(p, 0.0f, 0.0f, nullptr) > 1.0f - a_; }

bool Patina::inMask(const DefectQuery& q) const {
  return inDisc(q.uv) && a_ > 0 && value(q.uv, q.cavity, 0.0f, nullptr) > 1.0f - a_;
}

void Patina::shade(const DefectQuery& q, DefectShading& s) const {
  if (a_ <= 0 || !inDisc(q.uv)) return;
  float fp = q.footprint();
  Vec2f gv;
  float v = value(q.uv, q.cavity, fp, &gv);
  float tau = 1.0f - a_;
  if (v <= tau) return;
  // Colour band: the age picks the band, a second noise shifts it so that older bands show
  // through in places (layering, digest §5.5); within a band the shade varies with the value.
  float shift = fbm2(band_noise_, q.uv, band_fbm_, fp);
  float pos = clampf(a_ * 4.0f + 0.8f * shift - 0.6f * (1.0f - (v - tau) / std::max(1e-3f, 1.0f - tau)), 0.0f, 4.0f);
  int i = std::min(3, int(pos));
  Rgb col = lerp(p_.ramp[i], p_.ramp[i + 1], pos - float(i));
  SurfaceAppearance ap;
  ap.albedo = col;
  ap.sigma_rad = p_.sigma_rad;
  s.addCover(1.0f, ap);
  float k = q.mm_per_uv > 0 ? 1.0f / q.mm_per_uv : 1.0f;
  // The same grey-level field drives the bump (digest §5.3 step 4): patina crust is thicker
  // where it is older.
  s.height_grad += gv * (p_.bump_mm * k);
}

nlohmann::json Patina::attributes() const {
  return {{"kind", "patina"},
          {"center_uv_mm", {p_.center_uv.x, p_.center_uv.y}},
          {"radius_mm", p_.radius_mm},
          {"age_years", p_.age_years},
          {"environment", p_.environment},
          {"normalized_age", a_},
          {"cavity_weight", p_.cavity_weight},
          {"scale_mm", p_.scale_mm},
          {"seed", p_.seed}};
}

}  // namespace dg
