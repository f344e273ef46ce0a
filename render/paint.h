// Natural variation of metallic car paint (not defects, never labelled): orange peel of the clear
// coat, resolved metallic flakes ("sparkles") that fade with the pixel footprint, passive flakes
// that modulate the flake lobe's specular colour, and a slight variation of the base colour.
// Methods after J. Nilsson, "Procedural Generation of Natural Variations in Materials and
// Surfaces", Chalmers 2008, §4.3 (digest: shared/reference/nilsson-variations.md §3, §9, §10),
// re-expressed for a path tracer working in the part's UV chart (mm) with ray-differential
// footprints. Every quantity is a pure function of (params, uv, footprint, u_rand): no state, no
// allocation; an instance is immutable and may be shared between threads.
//
// Orange peel (thesis §4.3.2, digest §3.3). A height field of the clear coat,
//   h(uv) = A_rms * fbm2(uv; 3 octaves, lacunarity 2, gain 0.5, base frequency 1/wavelength) / kPeelRms
// in mm. A_rms = orange_peel_amplitude_um / 1000 is the RMS height (Rq) of the unfiltered field
// (kPeelRms is the measured RMS of that fBm, checked in the tests). The wavelength is the lattice
// spacing of the coarsest octave; the two finer octaves (wavelength/2, /4) keep slope per octave
// equal (gain * lacunarity = 1, digest §2.4), which spans roughly one wave-scan band (digest §3.3:
// long-wave 1.2-12 mm, short-wave 0.3-1.2 mm). The thesis uses one octave; three octaves give the
// broad-band waviness that wave-scan instruments measure. Defaults (2 um, 3 mm) give an RMS slope of
// about 6.8e-3 (0.39 deg): reflections are visibly distorted, the surface never looks "rocky". The
// gradient is analytic (chain rule through fbm2) and octaves finer than the footprint fade to 0
// (digest §2.5), so the filtered height and its gradient stay consistent.
//
// Base colour (thesis §4.5.2-like "small variation", digest §6.2, corrected: multiplicative, mean 1).
// LUMINANCE-ONLY: the same scale for R, G and B,
//   s = clamp(1 + color_variation * fbm2(uv; 2 octaves, base frequency 1/color_variation_size_mm)
//             / kColorRms,  max(0, 1 - 3 cv), 1 + 3 cv),
// so color_variation is the standard deviation of the scale. Film-thickness and flake-density
// variation change mostly lightness; one noise evaluation instead of three.
//
// Sparkling flakes (thesis §4.3.3-4.3.4, digest §3.5, path-tracer option (b)): a hash grid in UV mm
// with square cells of edge  cell = 2 * flake_size_mm  (independent of density; see below). Each
// cell (ix, iy) holds at most one flake, decided by hashes of (seed, ix, iy) (core/rng.h hashKey /
// mix64; the flake identity is the cell, never its normal, digest §10.8):
//  - presence with probability flake_density (the fraction of cells holding a flake);
//  - a round flake of diameter flake_size_mm whose centre is uniform over the positions where the
//    disk stays inside its cell (a jitter of one full flake diameter), so a lookup tests one cell
//    and flakes never overlap;
//  - a normal tilted from the macro normal: the tilt vector (theta cos phi, theta sin phi) is an
//    isotropic 2-D Gaussian with per-axis standard deviation flake_tilt_deg, i.e. the tilt angle
//    seen along ANY tangent direction has std flake_tilt_deg; theta itself is Rayleigh distributed
//    (RMS sqrt(2) * flake_tilt_deg) and truncated at kMaxFlakeTiltRad so a flake never leaves the
//    hemisphere (digest §10.9). (The thesis's uniform cube perturbation, §3.5 step 7, is not a
//    physical distribution; a Gaussian matches a Beckmann lobe, see smoothFlakeAlpha().)
// Hence flake_coverage = flake_density * pi * (flake_size/2)^2 / cell^2 = flake_density * pi / 16
// (at most 0.196). The brief suggested cell ~ flake_size / sqrt(density); that couples the flake
// spacing to the presence probability (density 1 would give touching flakes on a regular grid), so
// the cell is tied to the flake size only and density only thins the flakes out.
// Flakes keep their PHYSICAL size at every distance (unlike the thesis's pixel-sized sparkles, §3.5
// step 1, which changes the covered area with distance and so is not energy-consistent); the path
// tracer's sub-pixel jitter averages sub-pixel flakes.
//
// Sparkle fade (thesis §4.1.6 / §4.3.4 step 8, digest §2.5; average value 0 as §10.6 requires):
//   sparkle_fade = (1 - smoothstep(kSparkleFadeStart, kSparkleFadeEnd, footprint / cell))
//                  * clamp(sparkle_intensity, 0, 1)
// It is 1 while a pixel's footprint spans at most one cell (about one flake in three pixels at the
// default density) and 0 once it spans 4 cells (~5 flakes per pixel): from there on the flakes'
// average is the BSDF's smooth flake lobe. sparkle_weight = sparkle_fade on a flake, 0 elsewhere, so
// E_uv[sparkle_weight] = flake_coverage * sparkle_fade <= flake_coverage: resolved sparkles only
// REDISTRIBUTE the flake lobe's energy (see residualFlakeAmount()), they never add to it.
// sparkle_intensity is a probability, so values above 1 are clamped (a brighter-than-physical boost,
// thesis "Flake Sparkle Boost", belongs in the flake lobe's tint and is deliberately not offered).
// u_rand in [0, 1) (one per path vertex) resolves the blend stochastically: use_flake_lobe =
// on_flake && u_rand < sparkle_fade, so E[use_flake_lobe] = sparkle_weight and the integrator needs
// only one base BSDF per sample.
//
// Passive flakes (thesis §4.3.5, digest §3.6): the unresolved flakes' local density/orientation
// varies, which the thesis renders as a specular-colour modulation with fBm of amplitude multiplier
// 2.7 and frequency multiplier 2.4 (fine octaves dominate up close and fade with the footprint, so
// the modulation shrinks with distance):
//   flake_specular_scale = clamp(1 + passive_strength * fbm2(uv; 3 octaves, lac 2.4, gain 2.7,
//                          base frequency 1/passive_size_mm) / kPassiveRms, max(0, 1 - 3 ps), 1 + 3 ps)
// (mean 1, std passive_strength at zero footprint). Use: multiply the smooth flake lobe's tint (its
// Schlick F0) by it; leave the clear coat's Fresnel alone (a dielectric coat has no colour).
#pragma once
#include <cstdint>

#include "core/math.h"
#include "defects/noise.h"

namespace dg {

struct PaintVariationParams {
  float orange_peel_amplitude_um = 2;   // RMS height (Rq) of the coat's orange peel; 0 = off
  float orange_peel_wavelength_mm = 3;  // lattice spacing of the coarsest octave (0.3-12 mm)
  float flake_density = 0.3f;           // fraction of cells holding a flake, [0, 1]; 0 = no flakes
  float flake_size_mm = 0.03f;          // flake diameter; the cell edge is twice this
  float flake_tilt_deg = 12;            // per-axis std of the flake normal's tilt angle
  float sparkle_intensity = 1;          // [0, 1] (clamped): probability a flake shows as a sparkle
  float color_variation = 0.03f;        // std of the base colour's (luminance) scale; 0 = off
  uint64_t seed = 1;
  // Additions to the brief's list (defaults chosen for car panels):
  float color_variation_size_mm = 40;  // lattice spacing of the colour noise's coarse octave
  float passive_strength = 0.1f;       // std of flake_specular_scale; 0 = off
  float passive_size_mm = 0.5f;        // lattice spacing of the passive-flake fBm's coarse octave
};

struct PaintSample {
  // d height / d(u, v) of the clear coat (orange peel), mm per mm, u and v in UV mm. Add to the
  // defects' height gradient (same convention as DefectShading::height_grad).
  Vec2f coat_height_grad{0.0f, 0.0f};
  Rgb base_color_scale{1.0f, 1.0f, 1.0f};  // multiplies the base colour; mean 1, R = G = B
  // Weight of the resolved-flake (mirror) lobe at this point: sparkle_fade on a flake, else 0.
  float sparkle_weight = 0.0f;
  // The normal of the flake under uv in the (t, b, n) tangent frame (+z = macro normal); (0, 0, 1)
  // where there is no flake.
  Vec3f flake_normal_local{0.0f, 0.0f, 1.0f};
  float flake_coverage = 0.0f;  // expected fraction of area covered by flakes (a constant)
  // Additions:
  bool on_flake = false;          // uv lies on a flake
  bool use_flake_lobe = false;    // on_flake && u_rand < sparkle_fade (stochastic blend)
  float sparkle_fade = 0.0f;      // footprint fade in [0, 1], the same on and off flakes
  float flake_specular_scale = 1.0f;  // passive flakes: multiplies the smooth flake lobe's tint
  uint64_t flake_id = 0;          // hash of the flake's cell (nonzero on a flake), for per-flake use
};

class PaintVariation {
 public:
  // Measured RMS of the unit fBm fields used (16 seeds x 4e5 points; tests check them to 3%).
  static constexpr float kPeelRms = 0.2897f;     // 3 octaves, lacunarity 2, gain 0.5
  static constexpr float kColorRms = 0.3299f;    // 2 octaves, lacunarity 2, gain 0.5
  static constexpr float kPassiveRms = 0.3156f;  // 3 octaves, lacunarity 2.4, gain 2.7
  // Sparkle fade edges, in cells per footprint.
  static constexpr float kSparkleFadeStart = 1.0f;
  static constexpr float kSparkleFadeEnd = 4.0f;
  static constexpr float kMaxFlakeTiltRad = 1.3962634f;  // 80 deg: Gaussian tilt truncated here
  static constexpr float kCellPerFlake = 2.0f;           // cell edge / flake diameter

  explicit PaintVariation(const PaintVariationParams& p);

  // uv_mm: the part's UV in mm; footprint_mm: the pixel footprint's largest extent in UV mm
  // (DefectQuery::footprint(); 0 = unfiltered; NaN/negative count as 0, +inf is allowed);
  // u_rand in [0, 1): a per-sample uniform number, only used for use_flake_lobe.
  // A non-finite uv gives the neutral sample (no perturbation, scales 1, no flake).
  PaintSample evaluate(Vec2f uv_mm, float footprint_mm, float u_rand) const;

  // The orange-peel height (mm) whose gradient evaluate() reports (for tests, AOVs, debugging).
  float coatHeight(Vec2f uv_mm, float footprint_mm = 0.0f) const;
  // Its gradient alone, as evaluate() reports it (coat_height_grad): the groove renderer's flat
  // facets beside a scratch take it at their own place in the footprint.
  Vec2f coatHeightGrad(Vec2f uv_mm, float footprint_mm) const;

  bool hasPeel() const { return peel_scale_ != 0.0f; }  // orange peel on
  float cellSize() const { return cell_; }       // mm; 0 when there are no flakes
  float flakeCoverage() const { return coverage_; }
  const PaintVariationParams& params() const { return p_; }

  // Microfacet alpha of a Beckmann lobe whose slope distribution matches the flakes' tilts
  // (per-axis slope std tan(sigma) = alpha / sqrt(2)): set the smooth flake lobe to this roughness
  // (perceptual roughness = sqrt(alpha)) and the far (faded) look agrees with the near (resolved)
  // one. With GGX it is an approximation (same RMS slope near the peak, longer tails).
  float smoothFlakeAlpha() const;

  // The smooth flake lobe's share where the resolved lobe is NOT used, so that the area average of
  // the flake energy stays flake_amount:  (fa - c w) / (1 - c w), c = flake_coverage,
  // w = s.sparkle_fade, clamped to [0, 1]. (If fa < c w the sparkles carry more than fa; keep
  // flake_coverage <= flake_amount.)
  static float residualFlakeAmount(float flake_amount, const PaintSample& s);

 private:
  Vec2f peelGrad(Vec2f uv, float fp) const;  // uv finite, fp >= 0

  PaintVariationParams p_;
  SimplexNoise peel_noise_, color_noise_, passive_noise_;
  FbmParams peel_fbm_, color_fbm_, passive_fbm_;
  float peel_scale_ = 0;     // mm per unit fBm (0 = off)
  float color_scale_ = 0;    // per unit fBm
  float passive_scale_ = 0;  // per unit fBm
  float color_lo_ = 1, color_hi_ = 1, passive_lo_ = 1, passive_hi_ = 1;
  float cell_ = 0, inv_cell_ = 0;
  float density_ = 0;
  float flake_radius_cells_ = 0;  // flake radius in cell units
  float tilt_sigma_ = 0;          // radians
  float intensity_ = 0;
  float coverage_ = 0;
  uint64_t flake_key_ = 0;
};

}  // namespace dg
