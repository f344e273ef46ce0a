// Rust and patina: weathering that grows with age (Mihaylov 2013, as corrected in
// shared/reference/mihaylov-metals.md §4 and §5; the time model is stated in docs/weathering.md).
//
// Both follow the digest's "fixed field, moving threshold" rule (§5.5): a field phi(p) that does
// not depend on age is compared against a threshold that moves monotonically with age, so for one
// seed the covered region only grows as the part ages (the regions are nested).
#pragma once
#include <memory>
#include <optional>
#include <vector>

#include "defects/defect.h"
#include "defects/noise.h"
#include "defects/scratch.h"

namespace dg {

// ---------------------------------------------------------------------------------------------
// Rust: a spot that starts at a pit (or at the part's edge), or a band that starts along the
// stretch of a scratch that bares the steel, and spreads with age.
//
//   phi(p) = d(p) / R + roughness * fbm(p)           (fbm in [-1, 1], wavelength ~ R / 2)
//   d(p)   = |p - c| for a point origin c, the distance to the origin path for a scratch
//   g(age) = 1 - exp(-age / growth_years)             (front position, increasing in age)
//   rusted  <=>  phi(p) < g(age)
// The local rust age s = (g - phi) / g in (0, 1] is 1 at the origin (oldest, deepest, darkest) and
// 0 at the front (fresh, orange-red): the colour ramp and the pit depth follow it (digest §4.1:
// older layers are darker and deeper). Around the front, in g <= phi < g + ring_width / R, the
// paint lifts in bubbles (a bump, not labelled). The rusted surface is Oren-Nayar.
struct RustParams {
  Vec2f origin_uv;            // mm
  float radius_mm = 20;       // R: extent of the fully grown spot
  float age_years = 2;
  float growth_years = 3;     // time constant of the front
  float roughness = 0.35f;    // raggedness of the front (fbm amplitude in units of R)
  float pit_depth_mm = 0.15f; // depth of the oldest rust
  float blister_width_mm = 3; // width of the bubbled ring of lifted paint
  float blister_height_mm = 0.08f;
  float sigma_rad = 0.5f;     // Oren-Nayar roughness of rust
  Rgb fresh{0.35f, 0.12f, 0.04f}, old{0.06f, 0.03f, 0.015f}, accent{0.45f, 0.28f, 0.08f};  // digest §4.4
  uint64_t seed = 1;
  const char* origin = "pit";  // "pit", "edge" or "scratch" (the caller places the origin)
  // With origin "scratch": the bared stretch of the scratch's path (UV mm, at least two points);
  // the rust then grows from this line instead of from origin_uv. Empty for a point origin.
  std::vector<Vec2d> origin_path;
  int origin_scratch = 0;      // the scratch's instance id (attributes only)
};

class Rust final : public Defect {
 public:
  explicit Rust(const RustParams& p);
  DefectClass cls() const override { return DefectClass::Rust; }
  const char* kind() const override { return "rust"; }
  Box2 support() const override;
  Box2 maskBox() const override;
  void shade(const DefectQuery& q, DefectShading& s) const override;
  bool inMask(Vec2f p) const override;
  nlohmann::json attributes() const override;
  // The field and the front, exposed for tests.
  float phi(Vec2f p, float footprint = 0.0f, Vec2f* grad = nullptr) const;
  float front() const { return g_; }

 private:
  float originDistance(Vec2f p, Vec2f* dir) const;
  float extent() const;  // farthest distance from the origin that can be rusty or blistered
  Box2 originBox(float ext) const;
  RustParams p_;
  float g_;
  std::optional<ScratchPath> path_;
  SimplexNoise front_noise_, color_noise_, detail_noise_;
  FbmParams front_fbm_, color_fbm_, detail_fbm_;
};

// ---------------------------------------------------------------------------------------------
// Patina on copper alloys and bare steel (digest §5.3 and the time model of §5.5):
//   a(t)   = clamp(log(1 + k t / t0) / log(1 + T_full / t0), 0, 1),  t0 = 1 month, T_full = 25 years
//   value  = (1 - lambda) * n(p) + lambda * cavity(p),  n = (fbm + 1) / 2 in [0, 1]
//   patina <=> value > 1 - a(t)        (a fixed field against a threshold falling with age)
// inside a disc of radius R around the centre (or the whole part when R is 0). The colour comes
// from a five-colour ramp (dark-brown tarnish, red-brown, brown-green, green, blue-green) at the
// band of the age, shifted per point by a second noise so older bands stay visible in places.
struct PatinaParams {
  Vec2f center_uv;
  float radius_mm = 0;        // 0 = the whole part
  float age_years = 5;
  float environment = 1;      // k: speed-up of the environment (2-4 near the sea)
  float cavity_weight = 0;    // lambda: how much cavities (occlusion) attract patina
  float scale_mm = 15;        // wavelength of the coverage noise
  float bump_mm = 0.03f;
  float sigma_rad = 0.6f;
  Rgb ramp[5] = {{0.10f, 0.05f, 0.03f}, {0.22f, 0.08f, 0.04f}, {0.15f, 0.16f, 0.07f},
                 {0.10f, 0.30f, 0.17f}, {0.12f, 0.38f, 0.33f}};
  uint64_t seed = 1;
  Box2 part_uv;               // the part's UV extent (support when radius_mm = 0)
};

class Patina final : public Defect {
 public:
  explicit Patina(const PatinaParams& p);
  DefectClass cls() const override { return DefectClass::Patina; }
  const char* kind() const override { return "patina"; }
  Box2 support() const override;
  void shade(const DefectQuery& q, DefectShading& s) const override;
  bool inMask(Vec2f p) const override;
  bool inMask(const DefectQuery& q) const override;
  bool needsCavity() const override { return p_.cavity_weight > 0; }
  nlohmann::json attributes() const override;
  static float normalizedAge(float years, float environment);
  float threshold() const { return 1.0f - a_; }

 private:
  float value(Vec2f p, float cavity, float footprint, Vec2f* grad) const;
  bool inDisc(Vec2f p) const;
  PatinaParams p_;
  float a_;
  SimplexNoise cover_noise_, band_noise_;
  FbmParams cover_fbm_, band_fbm_;
};

}  // namespace dg
