// Materials and their BSDFs, evaluated in a local shading frame where the normal is +z. All
// directions point away from the surface. eval() returns f(wo, wi) without the cosine. wo must lie
// above the surface (wo.z > 0; the caller turns the frame toward the viewer), else f = 0, pdf = 0
// and nothing is sampled. Only Glass transmits (wi.z < 0); every other kind is zero for wi.z <= 0.
//
// Kinds:
//  - Conductor: microfacet (GGX or Beckmann) with Smith masking-shadowing (height-correlated) and
//    the exact Fresnel equations for a complex index of refraction n + ik per RGB channel.
//  - Plastic: a dielectric microfacet coat (IOR) over a Lambertian base colour.
//  - CarPaint: a clear coat (dielectric microfacet, coat roughness, coat IOR) layered over a base
//    that mixes Lambertian base colour with a metallic-flake glossy lobe (flake amount in [0,1]).
//  - RoughDiffuse: rough diffuse body reflection for rust and patina, the full Oren-Nayar (1994)
//    model (direct term with C1, C2, C3 plus the interreflection term) with albedo base_color and
//    facet-slope deviation sigma; sigma = 0 is exactly Lambert. Sampled cosine-weighted. See the
//    comment above orenNayar() in bsdf.cpp for the formula, its energy balance and its guards.
//  - Glass: a clear rough dielectric interface that reflects and refracts (Walter et al. 2007),
//    GGX or Beckmann, roughness, and ior = eta = n(far side) / n(side of wo), a RELATIVE index (1.5
//    for a ray arriving from air, 1/1.5 for one arriving from inside). wi.z > 0 is reflection,
//    wi.z < 0 transmission. The BTDF is the one for RADIANCE (camera paths): its smooth limit
//    carries (1 - F) / eta^2 of the radiance, not (1 - F), so entering and leaving a smooth slab
//    cancel the eta^2 factors; it obeys f(wi', wo'; 1/eta) = eta^2 f(wo, wi; eta) for the pair
//    seen from the other side. Sampling picks reflection with probability F (using u0: one lobe).
//    See the comment above glassEval() in bsdf.cpp. base_color is not used.
// Roughness r is perceptual: the microfacet alpha is r^2.
#pragma once
#include <optional>
#include <string>
#include <vector>

#include "core/math.h"

namespace dg {

enum class MicrofacetModel { GGX, Beckmann };
enum class MaterialKind { Conductor, Plastic, CarPaint, RoughDiffuse, Glass };

struct Material {
  MaterialKind kind = MaterialKind::Plastic;
  MicrofacetModel model = MicrofacetModel::GGX;
  Rgb base_color{0.5f, 0.5f, 0.5f};  // linear; Plastic and CarPaint base, RoughDiffuse albedo
  float roughness = 0.3f;            // Conductor, Plastic and Glass surface roughness
  Rgb eta{1.5f}, k{0.0f};            // Conductor complex IOR per channel
  float ior = 1.5f;                  // Plastic coat IOR; Glass: n(far side) / n(side of wo)
  // CarPaint
  float flake_amount = 0.0f;      // 0 = solid paint, 1 = fully metallic base
  float flake_roughness = 0.35f;  // glossiness of the flake lobe
  float coat_roughness = 0.05f;
  float coat_ior = 1.5f;
  // CarPaint flake lobe: the normal of the flake under the shading point, in the local shading
  // frame ((0, 0, 1) = the smooth lobe of the flake population), and a scale on its tint (passive
  // flakes, Nilsson 2008 §4.3.5). Set per shading point by the paint variation.
  Vec3f flake_normal{0.0f, 0.0f, 1.0f};
  float flake_tint_scale = 1.0f;
  // RoughDiffuse: Oren-Nayar roughness, the standard deviation of the facet slope angle in
  // RADIANS (not the perceptual roughness above). 0 = Lambert; the digest's rust/patina range is
  // 0..1. Values are clamped to [0, pi/2]; NaN counts as 0.
  float sigma = 0.3f;
  // Glass: the least probability with which sampling picks reflection over refraction. 0 (the
  // default) picks it with the facet's Fresnel reflectance F; a value s in (0, 1) with max(s, F)
  // (the pdf follows, so every estimate stays unbiased; total internal reflection still always
  // reflects). The integrator uses 1/2 where it splits a path in two at glass (one reflection, one
  // refraction) and 1/4 at camera hits on glass: the few percent that glass reflects
  // are often the brightest thing in view (a light's highlight), and F alone spends ~95% of the
  // directions on refraction (1/4 against 1/2 and F on the glass accuracy scenes: ends/ring 0.011%
  // of pixels >= 10 against 0.83% and 0.92%; backlight mean dE 0.45 against 0.62 and 0.43).
  float reflect_share = 0.0f;
};

// A named metal with its complex IOR (n, k) for the R, G, B channels and where the values come from.
struct MetalIor {
  std::string name;
  Rgb eta, k;
  std::string source;
};
const std::vector<MetalIor>& metalTable();       // steel, aluminium, chrome, copper, brass, titanium, ...
const MetalIor* findMetal(const std::string& name);  // nullptr if unknown

// Exact Fresnel reflectance of an unpolarised wave at a conductor (or dielectric when k = 0)
// interface from a medium of index 1, for cos(theta_i) in [0, 1].
float fresnelConductor(float cos_i, float eta, float k);
Rgb fresnelConductor(float cos_i, Rgb eta, Rgb k);
// Exact dielectric Fresnel (k = 0), handles total internal reflection when eta < 1.
float fresnelDielectric(float cos_i, float eta);

struct BsdfSample {
  Vec3f wi;      // local, sampled incoming direction
  Rgb f;         // BSDF value for (wo, wi)
  float pdf = 0; // solid-angle density of wi
};

Rgb evalBsdf(const Material& m, Vec3f wo, Vec3f wi);
float pdfBsdf(const Material& m, Vec3f wo, Vec3f wi);

// GGX visible-normal sampling's terms that depend on wo alone (bsdf.cpp).
struct VisibleNormalFrame {
  VisibleNormalFrame(float alpha, Vec3f wo);
  Vec3f v, t1, t2;
  float blend;
};

// The BSDF at one shading point seen from a fixed outgoing direction wo: what depends on wo alone
// (the lobe-selection probabilities, the coat's transmission toward wo, the specular lobe's alpha
// and Smith Lambda(wo), a conductor's Fresnel terms that do not depend on the angle) is computed
// once, so that many incident directions (light samples) cost less. evalBsdf(), pdfBsdf() and
// sampleBsdf() are built on it, and evalPdf() shares the half vector and the distribution's value
// between the two, so the values are the same to the bit whichever route computes them. The
// material must outlive it.
class BsdfAt {
 public:
  BsdfAt(const Material& m, Vec3f wo);
  Rgb eval(Vec3f wi) const;
  float pdf(Vec3f wi) const;
  Rgb evalPdf(Vec3f wi, float& pdf) const;  // eval(wi), with pdf(wi) into `pdf`
  // u0 chooses a lobe (glass: reflection or refraction), u the direction; as sampleBsdf().
  bool sample(float u0, Vec2f u, BsdfSample& out) const;

 private:
  // eval and pdf at once; `pdf` may be null (eval alone).
  Rgb evalImpl(Vec3f wi, float* pdf) const;
  // d_flake: the untilted flake lobe's D(h), or < 0 where it is to be found here.
  float pdfImpl(Vec3f wi, Vec3f h, float d_spec, float d_flake = -1.0f) const;
  const Material& m_;
  Vec3f wo_;
  float lobe_[3] = {0.0f, 0.0f, 0.0f};  // probabilities of the specular, diffuse and flake lobes
  float through_wo_ = 0.0f;             // 1 - Fresnel of the coat toward wo (plastic, car paint)
  float alpha_ = 0.0f;                  // the specular lobe's (coat's) alpha
  float lambda_wo_ = 0.0f;              // its Smith Lambda(wo)
  Rgb fa_{0.0f}, fnk2_{0.0f};           // conductor: n^2 - k^2 - 1 and n^2 k^2 per channel
  float flake_alpha_ = 0.0f;            // car paint: the flake lobe's alpha
  float flake_lambda_wo_ = 0.0f;        // and its Smith Lambda(wo) (untilted flakes)
  mutable std::optional<VisibleNormalFrame> vn_;  // the specular lobe's, from the first sample on
};
// u0 chooses a lobe (Glass: reflection or refraction), u chooses the direction. Returns false if no
// direction was produced.
bool sampleBsdf(const Material& m, Vec3f wo, float u0, Vec2f u, BsdfSample& out);

// A roughness so low that the lobe is treated as a mirror by the path tracer's MIS (still finite).
constexpr float kMinRoughness = 0.02f;

}  // namespace dg
