// Paint variation: see render/paint.h for the model, its sources and its parameters.
#include "render/paint.h"

#include <cmath>

#include "core/rng.h"

namespace dg {
namespace {

// Purposes of the seeded sub-streams, so the noises and the flake hash never share a key.
enum : uint64_t { kPeelKey = 0x9ee1, kColorKey = 0xc010, kPassiveKey = 0x9a55, kFlakeKey = 0xf1a4e };

inline float smoothstepF(float a, float b, float x) {
  const float t = clampf((x - a) / (b - a), 0.0f, 1.0f);
  return t * t * (3.0f - 2.0f * t);
}

// 24 high bits of a hash as a uniform number in [0, 1).
inline float unitFloat(uint64_t h) { return float(h >> 40) * (1.0f / 16777216.0f); }

inline float nonNegative(float v) { return v > 0.0f ? v : 0.0f; }  // NaN -> 0

}  // namespace

PaintVariation::PaintVariation(const PaintVariationParams& p)
    : p_(p),
      peel_noise_(hashKey(p.seed, kPeelKey)),
      color_noise_(hashKey(p.seed, kColorKey)),
      passive_noise_(hashKey(p.seed, kPassiveKey)) {
  // Orange peel: RMS height in mm, coarsest lattice spacing = wavelength (paint.h).
  const float amp_mm = nonNegative(p.orange_peel_amplitude_um) * 1e-3f;
  const float wl = nonNegative(p.orange_peel_wavelength_mm);
  peel_fbm_.octaves = 3;
  peel_fbm_.lacunarity = 2.0f;
  peel_fbm_.gain = 0.5f;
  if (amp_mm > 0.0f && wl > 0.0f && std::isfinite(wl)) {
    peel_fbm_.base_frequency = 1.0f / wl;
    peel_scale_ = amp_mm / kPeelRms;
  }

  const float cv = nonNegative(p.color_variation);
  const float cs = nonNegative(p.color_variation_size_mm);
  color_fbm_.octaves = 2;
  color_fbm_.lacunarity = 2.0f;
  color_fbm_.gain = 0.5f;
  if (cv > 0.0f && cs > 0.0f && std::isfinite(cs)) {
    color_fbm_.base_frequency = 1.0f / cs;
    color_scale_ = cv / kColorRms;
    color_lo_ = std::max(0.0f, 1.0f - 3.0f * cv);
    color_hi_ = 1.0f + 3.0f * cv;
  }

  // Passive flakes: the thesis's multipliers (amplitude 2.7, frequency 2.4; digest §3.6).
  const float ps = nonNegative(p.passive_strength);
  const float psz = nonNegative(p.passive_size_mm);
  passive_fbm_.octaves = 3;
  passive_fbm_.lacunarity = 2.4f;
  passive_fbm_.gain = 2.7f;
  if (ps > 0.0f && psz > 0.0f && std::isfinite(psz)) {
    passive_fbm_.base_frequency = 1.0f / psz;
    passive_scale_ = ps / kPassiveRms;
    passive_lo_ = std::max(0.0f, 1.0f - 3.0f * ps);
    passive_hi_ = 1.0f + 3.0f * ps;
  }

  // Flakes.
  density_ = clampf(nonNegative(p.flake_density), 0.0f, 1.0f);
  const float size = nonNegative(p.flake_size_mm);
  if (density_ > 0.0f && size > 0.0f && std::isfinite(size)) {
    cell_ = kCellPerFlake * size;
    inv_cell_ = 1.0f / cell_;
    flake_radius_cells_ = 0.5f / kCellPerFlake;
    // A disk of radius r (cell units) inside the unit cell: coverage = density * pi r^2.
    coverage_ = density_ * kPiF * flake_radius_cells_ * flake_radius_cells_;
  }
  tilt_sigma_ = degToRad(std::min(nonNegative(p.flake_tilt_deg), 90.0f));
  intensity_ = clampf(nonNegative(p.sparkle_intensity), 0.0f, 1.0f);
  flake_key_ = hashKey(p.seed, kFlakeKey);
}

float PaintVariation::coatHeight(Vec2f uv, float footprint) const {
  if (peel_scale_ == 0.0f) return 0.0f;
  return peel_scale_ * fbm2(peel_noise_, uv, peel_fbm_, nonNegative(footprint));
}

float PaintVariation::smoothFlakeAlpha() const {
  // Per-axis slope std of the flake normals ~ tan(sigma); Beckmann: slope std = alpha / sqrt(2).
  return std::sqrt(2.0f) * std::tan(std::min(tilt_sigma_, 1.2f));
}

float PaintVariation::residualFlakeAmount(float flake_amount, const PaintSample& s) {
  const float fa = clampf(nonNegative(flake_amount), 0.0f, 1.0f);
  const float cw = s.flake_coverage * s.sparkle_fade;
  if (!(cw > 0.0f)) return fa;
  if (cw >= 1.0f) return 0.0f;
  return clampf((fa - cw) / (1.0f - cw), 0.0f, 1.0f);
}

Vec2f PaintVariation::peelGrad(Vec2f uv, float fp) const {
  if (peel_scale_ == 0.0f) return Vec2f(0.0f, 0.0f);
  Vec2f g;
  fbm2(peel_noise_, uv, peel_fbm_, fp, &g);
  return g * peel_scale_;
}

Vec2f PaintVariation::coatHeightGrad(Vec2f uv, float footprint) const {
  if (!std::isfinite(uv.x) || !std::isfinite(uv.y)) return Vec2f(0.0f, 0.0f);
  return peelGrad(uv, nonNegative(footprint));
}

PaintSample PaintVariation::evaluate(Vec2f uv, float footprint, float u_rand) const {
  PaintSample s;
  s.flake_coverage = coverage_;
  if (!std::isfinite(uv.x) || !std::isfinite(uv.y)) return s;
  // NaN / negative -> 0; +inf stays (every fade below saturates cleanly at +inf).
  const float fp = nonNegative(footprint);

  // 1. Orange peel (digest §9 step 2): the gradient of the footprint-filtered height field.
  s.coat_height_grad = peelGrad(uv, fp);

  // 2. Base colour (luminance only).
  if (color_scale_ != 0.0f) {
    const float v = fbm2(color_noise_, uv, color_fbm_, fp);
    const float c = clampf(1.0f + color_scale_ * v, color_lo_, color_hi_);
    s.base_color_scale = Rgb(c, c, c);
  }

  // 3. Passive flakes (digest §9 step 3).
  if (passive_scale_ != 0.0f) {
    const float v = fbm2(passive_noise_, uv, passive_fbm_, fp);
    s.flake_specular_scale = clampf(1.0f + passive_scale_ * v, passive_lo_, passive_hi_);
  }

  // 4. Sparkling flakes (digest §9 step 4, §3.5).
  if (cell_ > 0.0f) {
    s.sparkle_fade =
        intensity_ * (1.0f - smoothstepF(kSparkleFadeStart, kSparkleFadeEnd, fp * inv_cell_));
    // Cell coordinates in double: the float input limits precision, not the division.
    const double cx = double(uv.x) * double(inv_cell_), cy = double(uv.y) * double(inv_cell_);
    const double fx = std::floor(cx), fy = std::floor(cy);
    const int64_t ix = int64_t(fx), iy = int64_t(fy);
    const float lx = float(cx - fx), ly = float(cy - fy);
    const uint64_t h = hashKey(flake_key_, uint64_t(ix), uint64_t(iy));
    if (unitFloat(mix64(h ^ 0x1ull)) < density_) {
      // Centre uniform over the positions that keep the disk inside the cell.
      const float r = flake_radius_cells_, span = 1.0f - 2.0f * r;
      const float ox = r + span * unitFloat(mix64(h ^ 0x2ull)) - lx;
      const float oy = r + span * unitFloat(mix64(h ^ 0x3ull)) - ly;
      if (ox * ox + oy * oy < r * r) {
        s.on_flake = true;
        s.flake_id = h | 1ull;
        s.sparkle_weight = s.sparkle_fade;
        s.use_flake_lobe = u_rand < s.sparkle_fade;
        if (tilt_sigma_ > 0.0f) {
          // Box-Muller: an isotropic 2-D Gaussian tilt vector; theta = |vector| is Rayleigh.
          const float u1 = 1.0f - unitFloat(mix64(h ^ 0x4ull));  // (0, 1]
          const float u2 = unitFloat(mix64(h ^ 0x5ull));
          const float theta = std::min(tilt_sigma_ * std::sqrt(-2.0f * std::log(u1)),
                                       kMaxFlakeTiltRad);
          const float phi = 2.0f * kPiF * u2;
          const float st = std::sin(theta);
          s.flake_normal_local = Vec3f(st * std::cos(phi), st * std::sin(phi), std::cos(theta));
        }
      }
    }
  }
  return s;
}

}  // namespace dg
