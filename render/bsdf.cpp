// BSDFs of the five material kinds (see bsdf.h). Everything below evalBsdf/pdfBsdf/sampleBsdf runs
// once or more per path vertex, so it is plain float arithmetic: no allocation, no virtual calls,
// no std::complex.
//
// Conventions: local shading frame, normal = +z, wo and wi point away from the surface, wo.z > 0
// (otherwise f = 0, pdf = 0 and nothing is sampled). Every kind but Glass is reflection only (wi.z
// <= 0 gives f = 0 and pdf = 0); Glass also transmits, into wi.z < 0. Microfacet alpha =
// roughness^2.
#include "render/bsdf.h"

#include <cctype>
#include <cmath>
#include <limits>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace dg {

// ------------------------------------------------------------------------------------------------
// Metal table
// ------------------------------------------------------------------------------------------------

namespace {

const char* kLabPbr =
    "LabPBR hardcoded metals (rre36/lab-pbr wiki), as listed in "
    "shared/reference/mihaylov-metals.md §2.3; RGB rendering constants, not a measured spectrum";

}  // namespace

const std::vector<MetalIor>& metalTable() {
  static const std::vector<MetalIor> table = {
      {"steel", Rgb{2.4401f, 2.0440f, 1.6778f}, Rgb{4.1820f, 3.6732f, 3.1170f},
       "Austenitic stainless steel (Avesta 832 MV, similar to AISI 316): Karlsson & Ribbing 1982, "
       "J. Appl. Phys. 53, 6340, as tabulated on refractiveindex.info (values read from a figure "
       "by "
       "the database); linearly interpolated by us at 650/550/450 nm. Not iron's values; for plain "
       "carbon steel use 'iron'"},
      {"iron", Rgb{2.9114f, 2.9497f, 2.5845f}, Rgb{3.0893f, 2.9318f, 2.7670f}, kLabPbr},
      {"aluminium", Rgb{1.3456f, 0.96521f, 0.61722f}, Rgb{7.4746f, 6.3995f, 5.3031f}, kLabPbr},
      {"chrome", Rgb{3.1071f, 3.1812f, 2.3230f}, Rgb{3.3314f, 3.3291f, 3.1350f}, kLabPbr},
      {"copper", Rgb{0.27105f, 0.67693f, 1.3164f}, Rgb{3.6092f, 2.6248f, 2.2921f}, kLabPbr},
      {"brass", Rgb{0.444f, 0.527f, 1.094f}, Rgb{3.695f, 2.765f, 1.829f},
       "Brass 70% Cu / 30% Zn: M. R. Querry, Optical constants, CRDC-CR-85034 (1985), as tabulated "
       "on refractiveindex.info (Cu-Zn/Querry-Cu70Zn30); table entries at 650/550/450 nm"},
      {"titanium", Rgb{2.7407f, 2.5418f, 2.2670f}, Rgb{3.8143f, 3.4345f, 3.0385f},
       "Titanium: Johnson & Christy 1974, Phys. Rev. B 9, 5056, as tabulated on "
       "refractiveindex.info "
       "(Ti/Johnson); linearly interpolated by us at 650/550/450 nm"},
      {"gold", Rgb{0.18299f, 0.42108f, 1.3734f}, Rgb{3.4242f, 2.3459f, 1.7704f}, kLabPbr},
      {"silver", Rgb{0.15943f, 0.14512f, 0.13547f}, Rgb{3.9291f, 3.1900f, 2.3808f}, kLabPbr},
  };
  return table;
}

const MetalIor* findMetal(const std::string& name) {
  std::string key;
  key.reserve(name.size());
  for (char c : name) key.push_back(char(std::tolower(static_cast<unsigned char>(c))));
  if (key == "aluminum") key = "aluminium";
  for (const MetalIor& m : metalTable())
    if (m.name == key) return &m;
  return nullptr;
}

// ------------------------------------------------------------------------------------------------
// Fresnel
// ------------------------------------------------------------------------------------------------

// Exact reflectance of a plane wave hitting a medium of complex index n + ik from vacuum. Real form
// of the Fresnel equations (Born & Wolf, Principles of Optics, §14.2, reflection at a metal
// surface), with s^2 = sin^2(theta), c = cos(theta):
//   A = n^2 - k^2 - s^2,   a^2 + b^2 = sqrt(A^2 + 4 n^2 k^2),   a^2 - b^2 = A,
//   Rs = ((a - c)^2 + b^2) / ((a + c)^2 + b^2),
//   Rp = Rs * ((a c - s^2)^2 + b^2 c^2) / ((a c + s^2)^2 + b^2 c^2).
// (a + ib is sqrt(n_complex^2 - s^2) = n_complex cos(theta_t).) The Rp factor is the textbook
// (a^2+b^2 - 2 a s tan + s^2 tan^2)/(... + ...) multiplied through by c^2 so that it stays finite
// at grazing incidence; writing numerators and denominators as sums of squares avoids cancellation.
// a^2 and b^2 are each taken from whichever of the two equivalent expressions does not subtract
// nearly equal numbers (0.5 (t + A) = 2 n^2 k^2 / (t - A)). With k = 0 and n < 1 past the critical
// angle this gives a = 0 and Rs = Rp = 1, i.e. total internal reflection comes out by itself.
namespace {
// fresnelConductor with its angle-independent terms given: a0 = n^2 - k^2 - 1 (as (n - 1)(n + 1) -
// k^2) and nk2 = n^2 k^2 (BsdfAt computes them once per shading point).
inline float conductorFresnel(float cos_i, float a0, float nk2) {
  const float c = clampf(cos_i, 0.0f, 1.0f);
  const float c2 = c * c;
  const float s2 = 1.0f - c2;
  // A = n^2 - k^2 - s^2 with s^2 = 1 - c^2, grouped so that n -> 1 loses no precision.
  const float A = a0 + c2;
  const float t = std::sqrt(A * A + 4.0f * nk2);  // a^2 + b^2
  const float a2 = A >= 0.0f ? 0.5f * (t + A) : 2.0f * nk2 / (t - A);
  const float b2 = A <= 0.0f ? 0.5f * (t - A) : 2.0f * nk2 / (t + A);
  const float a = std::sqrt(a2);
  const float rs_den = (a + c) * (a + c) + b2;
  if (!(rs_den > 0.0f)) return 1.0f;  // n = 1, k = 0 at exact grazing: the limit is 1
  const float rs = ((a - c) * (a - c) + b2) / rs_den;
  const float p_num = (a * c - s2) * (a * c - s2) + b2 * c2;
  const float p_den = (a * c + s2) * (a * c + s2) + b2 * c2;
  const float rp = p_den > 0.0f ? rs * (p_num / p_den) : rs;  // p_den = 0 only when s = 0 and a = 0
  return 0.5f * (rs + rp);
}
// The same for the three colour channels at once: each SSE2 lane does the scalar function's
// operations in its order (both branches of the a^2 / b^2 choice, then a select), and packed
// sqrt, division and arithmetic round as the scalar ones do, so the result is the scalar one to
// the bit. It halves the square roots and divisions of a conductor's evaluation, which were most
// of its cost (the wash-swirl scene spent a third of its render time in the BSDF).
inline Rgb conductorFresnelRgb(float cos_i, Rgb a0, Rgb nk2) {
#if defined(__SSE2__)
  const float c = clampf(cos_i, 0.0f, 1.0f);
  const float c2s = c * c;
  const __m128 cv = _mm_set1_ps(c), c2 = _mm_set1_ps(c2s), s2 = _mm_set1_ps(1.0f - c2s);
  const __m128 zero = _mm_setzero_ps(), half = _mm_set1_ps(0.5f);
  const __m128 nk = _mm_set_ps(0.0f, nk2.z, nk2.y, nk2.x);
  const __m128 A = _mm_add_ps(_mm_set_ps(0.0f, a0.z, a0.y, a0.x), c2);
  const __m128 t = _mm_sqrt_ps(_mm_add_ps(_mm_mul_ps(A, A), _mm_mul_ps(_mm_set1_ps(4.0f), nk)));
  const __m128 two_nk = _mm_mul_ps(_mm_set1_ps(2.0f), nk);
  const __m128 t_plus = _mm_add_ps(t, A), t_minus = _mm_sub_ps(t, A);
  auto select = [](__m128 mask, __m128 yes, __m128 no) {
    return _mm_or_ps(_mm_and_ps(mask, yes), _mm_andnot_ps(mask, no));
  };
  const __m128 a2 = select(_mm_cmpge_ps(A, zero), _mm_mul_ps(half, t_plus), _mm_div_ps(two_nk, t_minus));
  const __m128 b2 = select(_mm_cmple_ps(A, zero), _mm_mul_ps(half, t_minus), _mm_div_ps(two_nk, t_plus));
  const __m128 a = _mm_sqrt_ps(a2);
  const __m128 apc = _mm_add_ps(a, cv), amc = _mm_sub_ps(a, cv);
  const __m128 rs_den = _mm_add_ps(_mm_mul_ps(apc, apc), b2);
  const __m128 rs = _mm_div_ps(_mm_add_ps(_mm_mul_ps(amc, amc), b2), rs_den);
  const __m128 ac = _mm_mul_ps(a, cv), b2c2 = _mm_mul_ps(b2, c2);
  const __m128 ac_m = _mm_sub_ps(ac, s2), ac_p = _mm_add_ps(ac, s2);
  const __m128 p_num = _mm_add_ps(_mm_mul_ps(ac_m, ac_m), b2c2);
  const __m128 p_den = _mm_add_ps(_mm_mul_ps(ac_p, ac_p), b2c2);
  const __m128 rp = select(_mm_cmpgt_ps(p_den, zero), _mm_mul_ps(rs, _mm_div_ps(p_num, p_den)), rs);
  // rs_den > 0 fails only for n = 1, k = 0 at exact grazing, where the limit is 1.
  const __m128 f = select(_mm_cmpgt_ps(rs_den, zero), _mm_mul_ps(half, _mm_add_ps(rs, rp)), _mm_set1_ps(1.0f));
  alignas(16) float out[4];
  _mm_store_ps(out, f);
  return Rgb(out[0], out[1], out[2]);
#else
  return Rgb(conductorFresnel(cos_i, a0.x, nk2.x), conductorFresnel(cos_i, a0.y, nk2.y),
             conductorFresnel(cos_i, a0.z, nk2.z));
#endif
}
inline float conductorA0(float eta, float k) { return (eta - 1.0f) * (eta + 1.0f) - k * k; }
inline float conductorNk2(float eta, float k) { return eta * eta * k * k; }
}  // namespace

float fresnelConductor(float cos_i, float eta, float k) {
  return conductorFresnel(cos_i, conductorA0(eta, k), conductorNk2(eta, k));
}

Rgb fresnelConductor(float cos_i, Rgb eta, Rgb k) {
  return conductorFresnelRgb(cos_i, Rgb(conductorA0(eta.x, k.x), conductorA0(eta.y, k.y), conductorA0(eta.z, k.z)),
                             Rgb(conductorNk2(eta.x, k.x), conductorNk2(eta.y, k.y), conductorNk2(eta.z, k.z)));
}

// Fresnel equations for a real relative index eta = n_t / n_i (Born & Wolf §1.5.2):
//   rs = (cos_i - eta cos_t) / (cos_i + eta cos_t),
//   rp = (eta cos_i - cos_t) / (eta cos_i + cos_t),
// cos_t from Snell's law; sin^2(theta_t) >= 1 is total internal reflection.
float fresnelDielectric(float cos_i, float eta) {
  const float c = clampf(cos_i, 0.0f, 1.0f);
  if (!(eta > 0.0f)) return 1.0f;
  // cos^2(theta_t) = 1 - (1 - c^2) / eta^2, grouped so that eta -> 1 loses no precision.
  const float cos_t2 = (c * c + (eta - 1.0f) * (eta + 1.0f)) / (eta * eta);
  if (cos_t2 <= 0.0f) return 1.0f;
  const float cos_t = std::sqrt(cos_t2);
  const float rs = (c - eta * cos_t) / (c + eta * cos_t);
  const float rp = (eta * c - cos_t) / (eta * c + cos_t);
  return 0.5f * (rs * rs + rp * rp);
}

// ------------------------------------------------------------------------------------------------
// Microfacet distributions (isotropic), Smith masking-shadowing, sampling
// ------------------------------------------------------------------------------------------------

namespace {

constexpr float kInvSqrtPi = 0.56418958354775628695f;
constexpr float kMinAlpha = kMinRoughness * kMinRoughness;

inline float alphaOf(float roughness) {
  const float r =
      clampf(roughness, kMinRoughness, 1.0f);  // NaN roughness also ends at kMinRoughness
  return std::max(r * r, kMinAlpha);
}

// Normal distribution D(h), normalised so that the projected microfacet area integrates to one:
// integral of D(h) h.z over the hemisphere = 1.
//  GGX / Trowbridge-Reitz (Walter et al. 2007, eq. 33):
//    D = alpha^2 / (pi (sin^2 + alpha^2 cos^2)^2)
//    (the same as 1 / (pi alpha^2 cos^4 (1 + tan^2/alpha^2)^2), written without tan).
//  Beckmann (Walter et al. 2007, eq. 25): D = exp(-tan^2/alpha^2) / (pi alpha^2 cos^4).
inline float ndf(MicrofacetModel model, float alpha, Vec3f h) {
  if (h.z <= 0.0f) return 0.0f;
  const float sin2 = h.x * h.x + h.y * h.y;
  const float cos2 = h.z * h.z;
  const float a2 = alpha * alpha;
  if (model == MicrofacetModel::GGX) {
    const float d = sin2 + a2 * cos2;
    return a2 / (kPiF * d * d);
  }
  const float e = sin2 / (cos2 * a2);  // tan^2 / alpha^2
  if (!(e < 80.0f)) return 0.0f;       // exp(-80) ~ 2e-35: below anything that matters, avoids 0/0
  return std::exp(-e) / (kPiF * a2 * cos2 * cos2);
}

// Smith Lambda for direction w (Heitz 2014, "Understanding the Masking-Shadowing Function in
// Microfacet-Based BRDFs", JCGT 3(2)):
//  GGX (eq. 72): Lambda = (-1 + sqrt(1 + alpha^2 tan^2)) / 2
//  Beckmann (the Beckmann case in the same paper; 1 / (1 + Lambda) is the exact Smith-Beckmann G1
//  of Walter et al. 2007): Lambda = (erf(a) - 1)/2 + exp(-a^2) / (2 a sqrt(pi)), a = 1/(alpha tan)
inline float smithLambda(MicrofacetModel model, float alpha, Vec3f w) {
  const float sin2 = w.x * w.x + w.y * w.y;
  const float cos2 = w.z * w.z;
  if (sin2 <= 0.0f) return 0.0f;  // along the normal nothing is masked
  if (!(cos2 > 0.0f)) return std::numeric_limits<float>::infinity();
  if (model == MicrofacetModel::GGX) {
    const float x = alpha * alpha * sin2 / cos2;  // alpha^2 tan^2
    const float r = std::sqrt(1.0f + x);
    // For small x use x / (2 (1 + r)), the same value without the cancellation of r - 1.
    return x > 1.0f ? 0.5f * (r - 1.0f) : x / (2.0f * (1.0f + r));
  }
  const float a = std::sqrt(cos2 / sin2) / alpha;  // 1 / (alpha tan)
  if (a > 9.0f) return 0.0f;  // Lambda < 1e-37 there; the formula would only return rounding noise
  // erf(a) - 1 = -erfc(a), which keeps the precision for large a.
  const float v = 0.5f * (std::exp(-a * a) * kInvSqrtPi / a - std::erfc(a));
  return std::max(v, 0.0f);
}

inline float smithG1(MicrofacetModel model, float alpha, Vec3f w) {
  return 1.0f / (1.0f + smithLambda(model, alpha, w));
}

// Height-correlated masking-shadowing (Heitz 2014, eq. 99): G2 = 1 / (1 + Lambda(wo) + Lambda(wi)),
// from the two Lambdas.
inline float smithG2FromLambdas(float lambda_o, float lambda_i) {
  // Lambda sum first: a + b == b + a exactly in IEEE arithmetic, so G2(wo, wi) == G2(wi, wo)
  // bitwise.
  return 1.0f / (1.0f + (lambda_o + lambda_i));
}
inline float smithG2(MicrofacetModel model, float alpha, Vec3f wo, Vec3f wi) {
  return smithG2FromLambdas(smithLambda(model, alpha, wo), smithLambda(model, alpha, wi));
}

// D G2 / (4 cos_o cos_i): the microfacet reflection BRDF without its Fresnel factor
// (Walter et al. 2007, eq. 20). Symmetric in wo and wi. From D(h) and the two Lambdas (BsdfAt
// keeps Lambda(wo)), and from the model.
inline float microfacetReflectionFromD(float d, float lambda_o, float lambda_i, Vec3f wo, Vec3f wi) {
  const float den = 4.0f * wo.z * wi.z;
  if (!(den > 0.0f)) return 0.0f;
  return d * smithG2FromLambdas(lambda_o, lambda_i) / den;
}
inline float microfacetReflection(MicrofacetModel model, float alpha, Vec3f wo, Vec3f wi, Vec3f h) {
  return microfacetReflectionFromD(ndf(model, alpha, h), smithLambda(model, alpha, wo), smithLambda(model, alpha, wi),
                                   wo, wi);
}

inline Vec3f reflectAbout(Vec3f wo, Vec3f h) { return h * (2.0f * dot(wo, h)) - wo; }

}  // namespace

// The part of GGX visible-normal sampling that depends on wo alone: the stretched direction v, two
// tangents around it and the blend that squashes the hidden half of the disk. A BsdfAt computes it
// at its first sample and keeps it for the others (a groove footprint or a camera hit draws tens
// of directions for one wo).
VisibleNormalFrame::VisibleNormalFrame(float alpha, Vec3f wo) {
  v = normalize(Vec3f(alpha * wo.x, alpha * wo.y, wo.z));
  const float len2 = v.x * v.x + v.y * v.y;
  t1 = len2 > 0.0f ? Vec3f(-v.y, v.x, 0.0f) / std::sqrt(len2) : Vec3f(1.0f, 0.0f, 0.0f);
  t2 = cross(v, t1);
  blend = 0.5f * (1.0f + v.z);
}

namespace {

// The rest of it, for one u: a point on the disk seen from v, lifted onto the hemisphere and
// unstretched.
inline bool sampleVisibleNormal(const VisibleNormalFrame& f, float alpha, Vec2f u, Vec3f& h) {
  const float phi = 2.0f * kPiF * u.y;
  const float r = std::sqrt(u.x);
  const float p1 = r * std::cos(phi);
  float p2 = r * std::sin(phi);
  p2 = (1.0f - f.blend) * safeSqrt(1.0f - p1 * p1) + f.blend * p2;
  const Vec3f n = f.t1 * p1 + f.t2 * p2 + f.v * safeSqrt(1.0f - p1 * p1 - p2 * p2);
  h = normalize(Vec3f(alpha * n.x, alpha * n.y, std::max(0.0f, n.z)));
  return h.z > 0.0f;
}

// Samples a microfacet normal h for the given wo.
//  GGX: the distribution of visible normals D_wo(h) = G1(wo) max(0, wo.h) D(h) / wo.z, sampled
//       exactly with Heitz 2018 ("Sampling the GGX Distribution of Visible Normals", JCGT 7(4)):
//       stretch wo to the alpha = 1 configuration, pick a point uniformly on the disk seen from the
//       stretched direction, squash the half of the disk that is hidden behind the hemisphere onto
//       the visible half, lift it onto the hemisphere and unstretch the resulting normal.
//  Beckmann: D(h) cos(theta_h) by inverting its CDF (Walter et al. 2007, eqs. 28-29):
//       tan^2(theta_h) = -alpha^2 ln(1 - u1), phi_h = 2 pi u2.
// Returns false when the sample cannot give a reflection into the upper hemisphere.
inline bool sampleMicrofacetNormal(MicrofacetModel model, float alpha, Vec3f wo, Vec2f u,
                                   Vec3f& h) {
  if (model == MicrofacetModel::GGX) return sampleVisibleNormal(VisibleNormalFrame(alpha, wo), alpha, u, h);
  const float phi = 2.0f * kPiF * u.y;
  const float tan2 = -alpha * alpha * std::log1p(-u.x);
  const float cos_t = 1.0f / std::sqrt(1.0f + tan2);
  const float sin_t = std::sqrt(tan2) * cos_t;
  h = Vec3f(sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t);
  return dot(wo, h) > 0.0f;
}

// Solid-angle density of wi = reflect(wo, h) under sampleMicrofacetNormal. Both use
// dwi/dh = 1 / (4 |wo.h|) (Walter et al. 2007, eq. 14).
//  GGX VNDF: G1(wo) (wo.h) D(h) / wo.z / (4 wo.h) = G1(wo) D(h) / (4 wo.z)  (Heitz 2018).
//  Beckmann: D(h) h.z / (4 wo.h).
// From D(h) and Lambda(wo) (GGX's G1(wo) = 1 / (1 + Lambda(wo)); Beckmann does not use it), and
// from the model.
inline float microfacetPdfFromD(MicrofacetModel model, float d, float lambda_o, Vec3f wo, Vec3f h) {
  if (model == MicrofacetModel::GGX) return d * (1.0f / (1.0f + lambda_o)) / (4.0f * wo.z);
  const float oh = dot(wo, h);
  return oh > 0.0f ? d * h.z / (4.0f * oh) : 0.0f;
}
inline float microfacetPdf(MicrofacetModel model, float alpha, Vec3f wo, Vec3f h) {
  const float lambda_o = model == MicrofacetModel::GGX ? smithLambda(model, alpha, wo) : 0.0f;
  return microfacetPdfFromD(model, ndf(model, alpha, h), lambda_o, wo, h);
}

// Fresnel-Schlick with a coloured F0 (Schlick 1994, "An Inexpensive BRDF Model for
// Physically-based Rendering"): F0 + (1 - F0)(1 - cos)^5.
inline Rgb schlick(float cos_t, Rgb f0) {
  const float m = clampf(1.0f - cos_t, 0.0f, 1.0f);
  const float m5 = (m * m) * (m * m) * m;
  return f0 + (Rgb(1.0f) - f0) * m5;
}

inline Rgb clamp01(Rgb c) {
  return {clampf(c.x, 0.0f, 1.0f), clampf(c.y, 0.0f, 1.0f), clampf(c.z, 0.0f, 1.0f)};
}

// ------------------------------------------------------------------------------------------------
// Rough diffuse (Oren-Nayar)
// ------------------------------------------------------------------------------------------------
//
// Oren & Nayar 1994 ("Generalization of Lambert's Reflectance Model", SIGGRAPH '94, pp. 239-246)
// model a rough body-reflecting surface as V-cavities of Lambertian facets whose slope angles are
// Gaussian with standard deviation sigma (radians), with masking, shadowing, foreshortening and
// interreflection between the two faces of a cavity. We use their full functional approximation,
// radiance L_r = L_r1 (direct) + L_r2 (interreflection), divided by the irradiance E0 cos(theta_i)
// so that it becomes a BRDF:
//   f = rho/pi   [C1 + g C2 tan(beta) + (1 - |g|) C3 tan((alpha + beta) / 2)]            (L_r1)
//     + rho^2/pi 0.17 sigma^2 / (sigma^2 + 0.13) [1 - g (2 beta / pi)^2]                  (L_r2)
//   alpha = max(theta_i, theta_o),  beta = min(theta_i, theta_o),  g = cos(phi_i - phi_o),
//   C1 = 1 - 0.5 sigma^2 / (sigma^2 + 0.33),
//   C2 = 0.45 sigma^2 / (sigma^2 + 0.09) sin(alpha)                         if g >= 0,
//        0.45 sigma^2 / (sigma^2 + 0.09) (sin(alpha) - (2 beta / pi)^3)     if g <  0,
//   C3 = 0.125 sigma^2 / (sigma^2 + 0.09) (4 alpha beta / pi^2)^2,
// as given in shared/reference/mihaylov-metals.md §1.7 [X], which recommends this full model. The
// rho^2 of the interreflection term is per channel (two bounces off facets of the same colour).
// Not taken from the thesis's version (digest §8, items 6-8): g is the cosine of the azimuth
// difference (both projected directions normalised), not their unnormalised dot product; the g < 0
// branch multiplies (sin(alpha) - (2 beta/pi)^3) into C2 instead of replacing C2; the
// interreflection term and the 1/pi are present. sigma = 0 gives C1 = 1, C2 = C3 = 0 and no
// interreflection: exactly Lambert, rho/pi.
//
// f depends on wo and wi only through alpha, beta and g, all symmetric, so it is reciprocal; below,
// every quantity is a min, max, sum or product of per-direction values taken in a symmetric way,
// so f(wo, wi) == f(wi, wo) bitwise.
//
// Energy balance (rho = 1, by quadrature in double; checked in tests/render/oren_nayar_test.cpp).
// The model neither conserves nor only loses energy: with one bounce of interreflection it loses
// energy at normal view (directional albedo 0.96 at sigma = 0.3, 0.77 at sigma = 1), and toward
// grazing view it gains some (max 1.051 at sigma ~ 0.3 and theta_o -> 90 deg; the direct term
// alone reaches 1.0035 at sigma ~ 0.15). It never exceeds 1 when every channel of base_color is
// <= 0.95, which covers rust and patina by a wide margin. We keep the published model unscaled.
//
// Guards (none of them matter away from the horizon):
//  - at sigma >~ 0.7 the g < 0 branch of C2 overshoots C1 when both directions lie within a few
//    degrees of the horizon (the direct bracket tends to C1 - (6/pi) 0.45 sigma^2/(sigma^2 + 0.09)
//    for alpha = beta -> 90 deg, forward scattering): the direct bracket is clamped at 0;
//  - tan(beta) = sin(beta)/cos(beta) and tan((alpha+beta)/2) = (sin(alpha) + sin(beta)) /
//    (cos(alpha) + cos(beta)) (a sum-to-product identity, no angle needed) take cos(beta) >= 1e-6,
//    so f stays finite for directions within 1e-6 rad of the horizon;
//  - when either direction is along the normal, g is undefined; beta = 0 then removes every term
//    that depends on g, and g = 0 is used.
// The polar angles themselves (needed for (2 beta/pi)^3, C3 and L_r2) come from atan2(sin, cos),
// which, unlike acos(z), keeps full precision near the normal and cannot see |z| > 1.

constexpr float kMaxSigma = 1.57079632679489661923f;  // pi/2: slope-angle deviation beyond 90 deg
constexpr float kTwoOverPi = 0.63661977236758134308f;
constexpr float kMinCosTan = 1e-6f;

inline Rgb orenNayar(Rgb rho, float sigma, Vec3f wo, Vec3f wi) {
  const float s = clampf(sigma, 0.0f, kMaxSigma);  // NaN ends at 0
  if (!(s > 0.0f)) return rho * kInvPiF;           // Lambert (the general path gives the same)
  const float s2 = s * s;
  const float c1 = 1.0f - 0.5f * s2 / (s2 + 0.33f);
  const float k = s2 / (s2 + 0.09f);

  const float sin_o = std::sqrt(wo.x * wo.x + wo.y * wo.y);
  const float sin_i = std::sqrt(wi.x * wi.x + wi.y * wi.y);
  // alpha is the polar angle further from the normal, beta the nearer one.
  const float sin_a = std::max(sin_o, sin_i), sin_b = std::min(sin_o, sin_i);
  const float cos_a = std::min(wo.z, wi.z), cos_b = std::max(wo.z, wi.z);
  const float th_o = std::atan2(sin_o, wo.z), th_i = std::atan2(sin_i, wi.z);
  const float a = kTwoOverPi * std::max(th_o, th_i);  // 2 alpha / pi, in [0, 1]
  const float b = kTwoOverPi * std::min(th_o, th_i);  // 2 beta / pi, in [0, 1]

  const float sin_prod = sin_o * sin_i;
  const float g =
      sin_prod > 0.0f ? clampf((wo.x * wi.x + wo.y * wi.y) / sin_prod, -1.0f, 1.0f) : 0.0f;

  const float cb = std::max(cos_b, kMinCosTan);
  const float tan_b = sin_b / cb;
  const float tan_half = (sin_a + sin_b) / (std::max(cos_a, 0.0f) + cb);

  // sin(alpha) >= sin(beta) >= 2 beta/pi >= (2 beta/pi)^3 (Jordan's inequality), so C2 >= 0.
  const float c2 = 0.45f * k * (g >= 0.0f ? sin_a : sin_a - b * b * b);
  const float ab = a * b;  // 4 alpha beta / pi^2
  const float c3 = 0.125f * k * (ab * ab);
  const float direct = std::max(0.0f, c1 + g * c2 * tan_b + (1.0f - std::abs(g)) * c3 * tan_half);
  const float inter = 0.17f * s2 / (s2 + 0.13f) * (1.0f - g * (b * b));
  return rho * (direct * kInvPiF) + (rho * rho) * (inter * kInvPiF);
}

// ------------------------------------------------------------------------------------------------
// Lobes
// ------------------------------------------------------------------------------------------------
//
// Conductor: one lobe, F_conductor(wo.h) D G2 / (4 cos_o cos_i).
//
// Plastic: a dielectric microfacet coat (white, F_dielectric(wo.h; ior) D G2 / (4 cos_o cos_i))
// over
//   a Lambertian base seen through the coat:
//     f_base = base_color / pi * (1 - F(cos_i)) (1 - F(cos_o)),   F = F_dielectric(.; ior).
//   (1 - F(cos_i)) is the part of the light that gets through the coat on the way in, (1 -
//   F(cos_o)) on the way out; the product is symmetric, so f stays reciprocal. We deliberately use
//   no normalising factor: the albedo is then at most F(cos_o) + (1 - F(cos_o)) (1 - Fbar) base,
//   Fbar = cosine-weighted hemispherical average of F (0.092 for ior 1.5), so it never exceeds 1
//   whatever the coat roughness. The price is that the inter-reflections between base and coat are
//   not returned (a layered model, e.g. Weidlich & Wilkie 2007, would add them), making the diffuse
//   part about (1 - Fbar) darker than base_color/pi at normal incidence (~9% for ior 1.5); choose
//   base_color with that in mind. For ior -> 1 it reduces exactly to Lambert.
//
// CarPaint: clear coat (coat_roughness, coat_ior; same as the plastic coat) over a base layer, with
//   the same (1 - F(cos_i)) (1 - F(cos_o)) weighting of the base:
//     base = (1 - flake_amount) base_color / pi
//          + flake_amount * Schlick(wo.h; F0 = base_color) D G2 / (4 cos_o cos_i) [flake_roughness]
//   The flake lobe is an appearance model of metallic paint flakes, not a bare metal: its colour is
//   a tint, so Fresnel-Schlick with F0 = base_color is an acceptable choice there (bare metals use
//   the exact conductor Fresnel above). The base lobes are evaluated with the outside directions
//   (no refraction through the coat): a simplification that keeps the model reciprocal and
//   energy-conserving (the base albedo is a convex mix of two lobes each <= 1).

enum Lobe { kSpec = 0, kDiffuse = 1, kFlake = 2 };

// Probabilities with which sampleBsdf picks each lobe at wo, from cheap estimates of each lobe's
// albedo: the coat reflects about F(cos_o); the rest, (1 - F(cos_o)), reaches the base, split by
// flake_amount and weighted by the luminance of base colour / flake tint. A floor (10% spread over
// the lobes that exist) keeps every lobe reachable so that MIS never divides by a tiny probability.
struct LobeProbs {
  float p[3] = {0.0f, 0.0f, 0.0f};
};

inline LobeProbs lobeProbs(const Material& m, Vec3f wo) {
  LobeProbs lp;
  float w[3] = {0.0f, 0.0f, 0.0f};
  switch (m.kind) {
    case MaterialKind::Conductor:
      lp.p[kSpec] = 1.0f;
      return lp;
    case MaterialKind::RoughDiffuse:
      lp.p[kDiffuse] = 1.0f;
      return lp;
    case MaterialKind::Glass:  // one lobe: the choice between reflection and refraction is inside
      lp.p[kSpec] = 1.0f;
      return lp;
    case MaterialKind::Plastic: {
      const float f = fresnelDielectric(wo.z, m.ior);
      w[kSpec] = f;
      w[kDiffuse] = (1.0f - f) * std::max(0.0f, luminance(clamp01(m.base_color)));
      break;
    }
    case MaterialKind::CarPaint: {
      const float f = fresnelDielectric(wo.z, m.coat_ior);
      const float fa = clampf(m.flake_amount, 0.0f, 1.0f);
      const Rgb base = clamp01(m.base_color);
      w[kSpec] = f;
      w[kDiffuse] = (1.0f - f) * (1.0f - fa) * luminance(base);
      w[kFlake] = (1.0f - f) * fa * luminance(schlick(wo.z, base));
      break;
    }
  }
  float sum = 0.0f;
  int n = 0;
  for (float x : w) {
    sum += x;
    n += x > 0.0f ? 1 : 0;
  }
  if (!(sum > 0.0f)) {  // nothing reflects (e.g. ior = 1 and black base): sample the coat anyway
    lp.p[kSpec] = 1.0f;
    return lp;
  }
  for (int i = 0; i < 3; ++i) lp.p[i] = w[i] > 0.0f ? 0.9f * (w[i] / sum) + 0.1f / float(n) : 0.0f;
  return lp;
}

// ------------------------------------------------------------------------------------------------
// Glass: a rough dielectric interface that reflects and refracts
// ------------------------------------------------------------------------------------------------
//
// Walter, Marschner, Li & Torrance 2007 ("Microfacet Models for Refraction through Rough
// Surfaces", EGSR). wo lies on the +z side, in a medium of index n_o; the far side (-z) has index
// n_t, and eta = m.ior = n_t / n_o is the RELATIVE index (the integrator passes 1.5 for a ray
// arriving from air, 1/1.5 for one arriving from inside the glass). wi.z > 0 is reflection,
// wi.z < 0 transmission. Clear glass: the value is grey and base_color is not used.
//
// Reflection: the dielectric microfacet lobe of the plastic coat,
//   f_r = F(wo.h; eta) D(h) G2(wo, wi) / (4 cos_o cos_i),   h = normalize(wo + wi),
// where for eta < 1 the exact Fresnel term is 1 beyond the critical angle (total internal
// reflection), so everything is reflected there.
//
// Transmission: wi is reached from wo by refraction through the microfacet whose normal is the
// generalised half vector h = +-normalize(wo + eta wi) (Walter eq. 16), the sign chosen so that
// h.z > 0. Because wo + eta wi is parallel to h, the tangential parts satisfy sin(theta_o) = eta
// sin(theta_i) about h: Snell's law holds by construction. A pair is admissible only when wo is in
// front of that facet and wi behind it, wo.h > 0 and wi.h < 0; otherwise f = 0.
//   Walter's eq. 21 is written for his incident direction i and outgoing o. Read with i = wo (the
//   direction the path arrives from) it is the FLUX (importance) form
//     f_t^flux = |wo.h| |wi.h| / (|wo.z| |wi.z|) eta^2 (1 - F) D(h) G2 / (wo.h + eta wi.h)^2,
//   whose smooth limit integrates (with |cos_i|) to 1 - F, the transmitted share of the energy.
//   Radiance is not conserved through an interface, L / n^2 is (Veach 1997, thesis §5.2): radiance
//   arriving from the far side leaves toward wo as (n_o / n_t)^2 (1 - F) L = (1 - F) L / eta^2, the
//   solid angle widening as it leaves the denser medium. Camera paths carry radiance, so eval()
//   returns the RADIANCE form (Walter's eq. 21 read with i = wi, the direction light comes from):
//     f_t = f_t^flux / eta^2
//         = |wo.h| |wi.h| / (|wo.z| |wi.z|) (1 - F) D(h) G2 / (wo.h + eta wi.h)^2.
//   Its smooth limit carries (1 - F) / eta^2 of the radiance. A camera ray that enters glass (eta =
//   1.5) and leaves it again (eta = 1/1.5) picks up 1/1.5^2 and then 1.5^2: through a smooth slab
//   the factors cancel and only the two Fresnel losses remain. This BTDF obeys the generalised
//   reciprocity of Veach 1997 (eq. 5.14), f(wi -> wo) / n_o^2 = f(wo -> wi) / n_t^2. Evaluated
//   from wi's side, as the integrator does for a ray arriving from there (the frame turned over,
//   z -> -z, so that wi' = wi lies above and wo' = wo below, relative index 1/eta):
//     f_t(wi', wo'; 1/eta) = eta^2 f_t(wo, wi; eta),
//   since both pairs have the same half vector (turned over) and (wi'.h' + wo'.h' / eta)^2 =
//   (wo.h + eta wi.h)^2 / eta^2. The flux form obeys the reverse relation, f_t^flux(wi', wo';
//   1/eta) = f_t^flux(wo, wi; eta) / eta^2.
//   (wo.h + eta wi.h)^2 is computed as |wo + eta wi|^2, the same number since h is parallel to
//   wo + eta wi. G2 is the height-correlated Smith form used for reflection, 1 / (1 + Lambda(wo) +
//   Lambda(wi)); Lambda depends on z^2 only, so it needs no special case below the surface. (For
//   transmission the two directions see the microsurface from opposite sides, so height
//   correlation works the other way: a facet high enough to be seen from above is less likely to
//   be seen from below, and a height-correlated transmission G2 would be smaller than this one;
//   Heitz 2014 discusses that case. The form used here never exceeds G1(wo), so it cannot create
//   energy; it is the usual choice for rough glass.) The Fresnel factor of
//   the pair is taken on the side of the lower index, F(cos_i; eta) = F(cos_t; 1/eta): seen from
//   the denser side F has a square-root singularity at the critical angle, seen from the other it
//   has none, and the pair and its reverse then get the same F to rounding.
//
// Sampling: h from sampleMicrofacetNormal (GGX visible normals or Beckmann D cos), then reflection
// with probability F(wo.h; eta) (decided by u0, free since Glass has a single lobe), else
// refraction by Snell's law about h. The density of wi is
//   reflection:    F pdf_h(h) / (4 wo.h)                                 (Walter eq. 14)
//   transmission:  (1 - F) pdf_h(h) eta^2 |wi.h| / (wo.h + eta wi.h)^2    (Walter eq. 17),
// pdf_h = G1(wo) max(0, wo.h) D(h) / wo.z (GGX visible normals) or D(h) h.z (Beckmann). With GGX
// the sample weights f |cos_i| / pdf are G2 / G1(wo) for reflection and G2 / (G1(wo) eta^2) for
// transmission: at most 1 and 1 / eta^2.
//
// Guards. At eta = 1 the interface vanishes: the transmission becomes a delta along -wo, which no
// density represents, and wo + eta wi cancels down to rounding noise. eta is therefore kept at
// least kEtaGap from 1 (1 + kEtaGap above, 1 / (1 + kEtaGap) below; NaN, infinite or non-positive
// ior counts as 1): there the generalised half vector is still known to ~1e-4 rad, and the sample
// weight does not depend on it anyway, so index-matched glass comes out (nearly) invisible. eta is
// also clamped to [1/kMaxEta, kMaxEta], which keeps eta^2 finite.

constexpr float kEtaGap = 1e-3f;
constexpr float kMaxEta = 100.0f;

// The probability of picking reflection at a facet of Fresnel reflectance f: f itself, or at least
// Material::reflect_share (so total internal reflection, f = 1, still always reflects).
inline float reflectChoice(const Material& m, float f) {
  return m.reflect_share > 0.0f && m.reflect_share < 1.0f ? std::max(m.reflect_share, f) : f;
}

inline float glassEta(float ior) {
  const float eta = (ior > 0.0f && ior < std::numeric_limits<float>::infinity())
                        ? clampf(ior, 1.0f / kMaxEta, kMaxEta)
                        : 1.0f;
  return eta >= 1.0f ? std::max(eta, 1.0f + kEtaGap) : std::min(eta, 1.0f / (1.0f + kEtaGap));
}

// Density with which sampleMicrofacetNormal draws the microfacet normal h for wo (per solid angle
// of h): G1(wo) max(0, wo.h) D(h) / wo.z for GGX visible normals, D(h) h.z for Beckmann.
inline float normalPdf(MicrofacetModel model, float alpha, Vec3f wo, Vec3f h) {
  const float d = ndf(model, alpha, h);
  if (model == MicrofacetModel::GGX) {
    const float oh = dot(wo, h);
    return oh > 0.0f ? smithG1(model, alpha, wo) * oh * d / wo.z : 0.0f;
  }
  return d * h.z;
}

// The refraction geometry of a pair wo (above) / wi (below): the generalised half vector, both
// cosines with it, |wo + eta wi|^2 = (wo.h + eta wi.h)^2 and the Fresnel reflectance of the facet.
// False when no microfacet refracts wo into wi (wrong side of the facet, or a degenerate h).
struct Refraction {
  Vec3f h;
  float cos_o = 0.0f;  // wo.h > 0
  float cos_i = 0.0f;  // |wi.h|
  float len2 = 0.0f;
  float fresnel = 1.0f;
};

inline bool refractionOf(Vec3f wo, Vec3f wi, float eta, Refraction& r) {
  // s, parallel to h, is (n_dense w_dense + n_rare w_rare) / n_rare: the pair seen from the other
  // side (frame turned over, 1/eta) then gives the same vector, turned over, to the bit.
  const Vec3f s = eta >= 1.0f ? wo + wi * eta : wo * (1.0f / eta) + wi;
  const float s2 = dot(s, s);
  if (!(s2 > 0.0f)) return false;
  r.len2 = eta >= 1.0f ? s2 : s2 * (eta * eta);  // s = (wo + eta wi) / eta when eta < 1
  r.h = s / std::sqrt(s2);
  if (r.h.z < 0.0f) r.h = -r.h;
  r.cos_o = dot(wo, r.h);
  const float ih = dot(wi, r.h);
  if (!(r.h.z > 0.0f) || !(r.cos_o > 0.0f) || !(ih < 0.0f)) return false;
  r.cos_i = -ih;
  // The same reflectance from either side; taken where it has no singularity (see above).
  r.fresnel =
      eta >= 1.0f ? fresnelDielectric(r.cos_o, eta) : fresnelDielectric(r.cos_i, 1.0f / eta);
  return true;
}

// The half vector of a reflected pair and wo.h. |wo + wi| = 2 cos(theta_h) with wo.h = wi.h =
// cos(theta_h); taking the Fresnel cosine from the length instead of from dot(wo, h) keeps f(wo, wi)
// and f(wi, wo) bitwise equal (the two dot products differ by rounding, which matters for Fresnel
// near grazing). Every reflection lobe uses it.
inline bool reflectionHalf(Vec3f wo, Vec3f wi, Vec3f& h, float& cos_oh) {
  const Vec3f sum = wo + wi;
  const float len = length(sum);
  if (!(len > 0.0f)) return false;
  h = sum / len;
  cos_oh = clampf(0.5f * len, 0.0f, 1.0f);
  return true;
}

inline float glassEval(const Material& m, Vec3f wo, Vec3f wi) {
  if (!(wo.z > 0.0f)) return 0.0f;
  const float eta = glassEta(m.ior);
  const float alpha = alphaOf(m.roughness);
  if (wi.z > 0.0f) {
    Vec3f h;
    float cos_oh;
    if (!reflectionHalf(wo, wi, h, cos_oh)) return 0.0f;
    return fresnelDielectric(cos_oh, eta) * microfacetReflection(m.model, alpha, wo, wi, h);
  }
  if (!(wi.z < 0.0f)) return 0.0f;
  Refraction r;
  if (!refractionOf(wo, wi, eta, r)) return 0.0f;
  // Numerator and denominator apart: a direction within ~1e-19 of the horizon has G2 = 0 and a
  // denominator that may be subnormal, and 0 / den stays 0 where (1 / den) * 0 would not.
  const float num = r.cos_o * r.cos_i * (1.0f - r.fresnel) * ndf(m.model, alpha, r.h) *
                    smithG2(m.model, alpha, wo, wi);
  const float den = wo.z * -wi.z * r.len2;
  return den > 0.0f ? num / den : 0.0f;
}

inline float glassPdf(const Material& m, Vec3f wo, Vec3f wi) {
  if (!(wo.z > 0.0f)) return 0.0f;
  const float eta = glassEta(m.ior);
  const float alpha = alphaOf(m.roughness);
  if (wi.z > 0.0f) {
    Vec3f h;
    float cos_oh;
    if (!reflectionHalf(wo, wi, h, cos_oh)) return 0.0f;
    return reflectChoice(m, fresnelDielectric(cos_oh, eta)) * microfacetPdf(m.model, alpha, wo, h);
  }
  if (!(wi.z < 0.0f)) return 0.0f;
  Refraction r;
  if (!refractionOf(wo, wi, eta, r)) return 0.0f;
  return (1.0f - reflectChoice(m, r.fresnel)) * normalPdf(m.model, alpha, wo, r.h) * (eta * eta) * r.cos_i / r.len2;
}

// Draws h, then reflects with probability F(wo.h) (or Material::reflect_share) or refracts; returns wi (not yet checked against
// the pdf). False when the direction ends up on the wrong side of the macro surface.
inline bool sampleGlassDirection(const Material& m, Vec3f wo, float u0, Vec2f u, Vec3f& wi) {
  const float eta = glassEta(m.ior);
  Vec3f h;
  if (!sampleMicrofacetNormal(m.model, alphaOf(m.roughness), wo, u, h)) return false;
  const float oh = dot(wo, h);
  if (!(oh > 0.0f)) return false;
  if (u0 < reflectChoice(m, fresnelDielectric(oh, eta))) {
    wi = reflectAbout(wo, h);
    return wi.z > 0.0f;
  }
  // Snell about h: cos^2(theta_t) = 1 - (1 - oh^2) / eta^2 (grouped as in fresnelDielectric), and
  // wi = -wo / eta + (oh / eta - cos_t) h, a unit vector with wi.h = -cos_t.
  const float cos_t2 = (oh * oh + (eta - 1.0f) * (eta + 1.0f)) / (eta * eta);
  if (!(cos_t2 > 0.0f)) return false;  // total internal reflection (F = 1 there, so rounding only)
  const float cos_t = std::sqrt(cos_t2);
  wi = normalize(h * (oh / eta - cos_t) - wo / eta);
  return wi.z < 0.0f;
}

}  // namespace

BsdfAt::BsdfAt(const Material& m, Vec3f wo) : m_(m), wo_(wo) {
  if (!(wo.z > 0.0f)) return;
  const LobeProbs lp = lobeProbs(m, wo);
  for (int i = 0; i < 3; ++i) lobe_[i] = lp.p[i];
  switch (m.kind) {
    case MaterialKind::Conductor:
      fa_ = Rgb(conductorA0(m.eta.x, m.k.x), conductorA0(m.eta.y, m.k.y), conductorA0(m.eta.z, m.k.z));
      fnk2_ = Rgb(conductorNk2(m.eta.x, m.k.x), conductorNk2(m.eta.y, m.k.y), conductorNk2(m.eta.z, m.k.z));
      alpha_ = alphaOf(m.roughness);
      break;
    case MaterialKind::Plastic:
      through_wo_ = 1.0f - fresnelDielectric(wo.z, m.ior);
      alpha_ = alphaOf(m.roughness);
      break;
    case MaterialKind::CarPaint:
      through_wo_ = 1.0f - fresnelDielectric(wo.z, m.coat_ior);
      alpha_ = alphaOf(m.coat_roughness);
      flake_alpha_ = alphaOf(m.flake_roughness);
      if (!(m.flake_normal.z < 1.0f)) flake_lambda_wo_ = smithLambda(m.model, flake_alpha_, wo);
      break;
    case MaterialKind::RoughDiffuse:
    case MaterialKind::Glass:
      return;
  }
  lambda_wo_ = smithLambda(m.model, alpha_, wo);
}

Rgb BsdfAt::eval(Vec3f wi) const { return evalImpl(wi, nullptr); }

float BsdfAt::pdf(Vec3f wi) const {
  const Material& m = m_;
  const Vec3f wo = wo_;
  if (m.kind == MaterialKind::Glass) return glassPdf(m, wo, wi);
  if (!(wo.z > 0.0f) || !(wi.z > 0.0f)) return 0.0f;
  if (m.kind == MaterialKind::RoughDiffuse) return wi.z * kInvPiF;  // cosine-weighted only
  const Vec3f h = normalize(wo + wi);
  return pdfImpl(wi, h, lobe_[kSpec] > 0.0f ? ndf(m.model, alpha_, h) : 0.0f);
}

Rgb BsdfAt::evalPdf(Vec3f wi, float& pdf) const { return evalImpl(wi, &pdf); }

// The lobes' mixture density of wi, with h = normalize(wo + wi) and the specular lobe's D(h) given.
float BsdfAt::pdfImpl(Vec3f wi, Vec3f h, float d_spec, float d_flake) const {
  const Material& m = m_;
  const Vec3f wo = wo_;
  float pdf = 0.0f;
  if (lobe_[kSpec] > 0.0f) pdf += lobe_[kSpec] * microfacetPdfFromD(m.model, d_spec, lambda_wo_, wo, h);
  if (lobe_[kDiffuse] > 0.0f) pdf += lobe_[kDiffuse] * wi.z * kInvPiF;
  if (lobe_[kFlake] > 0.0f) {
    if (m.flake_normal.z < 1.0f) {
      const Frame ff = Frame::fromNormal(m.flake_normal);
      const Vec3f o = ff.toLocal(wo), i = ff.toLocal(wi);
      if (o.z > 0.0f && i.z > 0.0f)
        pdf += lobe_[kFlake] * microfacetPdf(m.model, flake_alpha_, o, normalize(o + i));
    } else {
      // As microfacetPdf(model, flake alpha, wo, h), with the cached Lambda(wo) (GGX only).
      if (d_flake < 0.0f) d_flake = ndf(m.model, flake_alpha_, h);
      pdf += lobe_[kFlake] *
             microfacetPdfFromD(m.model, d_flake, m.model == MicrofacetModel::GGX ? flake_lambda_wo_ : 0.0f, wo, h);
    }
  }
  return pdf;
}

Rgb BsdfAt::evalImpl(Vec3f wi, float* pdf) const {
  const Material& m = m_;
  const Vec3f wo = wo_;
  if (m.kind == MaterialKind::Glass) {
    if (pdf) *pdf = glassPdf(m, wo, wi);
    return Rgb(glassEval(m, wo, wi));
  }
  if (!(wo.z > 0.0f) || !(wi.z > 0.0f)) {
    if (pdf) *pdf = 0.0f;
    return Rgb(0.0f);
  }
  if (m.kind == MaterialKind::RoughDiffuse) {  // needs no half vector
    if (pdf) *pdf = wi.z * kInvPiF;
    return orenNayar(clamp01(m.base_color), m.sigma, wo, wi);
  }
  Vec3f h;
  float cos_oh;
  if (!reflectionHalf(wo, wi, h, cos_oh)) {
    if (pdf) *pdf = this->pdf(wi);
    return Rgb(0.0f);
  }
  // The specular lobe's D(h), shared with its density (h is normalize(wo + wi) to the bit, so
  // pdf() would find the same D), and its reflection with the cached Lambda(wo).
  const float d = ndf(m.model, alpha_, h);
  // The untilted flake lobe's D(h) likewise, where the value or the density needs it.
  const bool flat_flakes = m.kind == MaterialKind::CarPaint && !(m.flake_normal.z < 1.0f);
  const float d_flake = flat_flakes && (lobe_[kFlake] > 0.0f || m.flake_amount > 0.0f)
                            ? ndf(m.model, flake_alpha_, h)
                            : -1.0f;
  if (pdf) *pdf = pdfImpl(wi, h, d, d_flake);
  const float spec_mf = microfacetReflectionFromD(d, lambda_wo_, smithLambda(m.model, alpha_, wi), wo, wi);
  switch (m.kind) {
    case MaterialKind::Conductor:
      return conductorFresnelRgb(cos_oh, fa_, fnk2_) * spec_mf;
    case MaterialKind::Plastic: {
      const float spec = fresnelDielectric(cos_oh, m.ior) * spec_mf;
      const float through = (1.0f - fresnelDielectric(wi.z, m.ior)) * through_wo_;
      return clamp01(m.base_color) * (through * kInvPiF) + Rgb(spec);
    }
    case MaterialKind::CarPaint: {
      const float spec = fresnelDielectric(cos_oh, m.coat_ior) * spec_mf;
      const float through = (1.0f - fresnelDielectric(wi.z, m.coat_ior)) * through_wo_;
      const float fa = clampf(m.flake_amount, 0.0f, 1.0f);
      const Rgb base = clamp01(m.base_color);
      Rgb layer = base * ((1.0f - fa) * kInvPiF);
      if (fa > 0.0f) {
        float mf;
        if (m.flake_normal.z < 1.0f) {
          // A tilted flake: its microfacet lobe lives in the flake's own frame.
          const Frame ff = Frame::fromNormal(m.flake_normal);
          const Vec3f o = ff.toLocal(wo), i = ff.toLocal(wi);
          mf = (o.z > 0.0f && i.z > 0.0f) ? microfacetReflection(m.model, flake_alpha_, o, i, normalize(o + i))
                                          : 0.0f;
        } else {
          mf = microfacetReflectionFromD(d_flake, flake_lambda_wo_, smithLambda(m.model, flake_alpha_, wi), wo, wi);
        }
        layer += schlick(cos_oh, base) * (fa * mf * m.flake_tint_scale);
      }
      return layer * through + Rgb(spec);
    }
    case MaterialKind::RoughDiffuse:  // returned above
    case MaterialKind::Glass:
      break;
  }
  return Rgb(0.0f);
}

Rgb evalBsdf(const Material& m, Vec3f wo, Vec3f wi) { return BsdfAt(m, wo).eval(wi); }

float pdfBsdf(const Material& m, Vec3f wo, Vec3f wi) { return BsdfAt(m, wo).pdf(wi); }

bool sampleBsdf(const Material& m, Vec3f wo, float u0, Vec2f u, BsdfSample& out) {
  return BsdfAt(m, wo).sample(u0, u, out);
}

bool BsdfAt::sample(float u0, Vec2f u, BsdfSample& out) const {
  const Material& m = m_;
  const Vec3f wo = wo_;
  if (!(wo.z > 0.0f)) return false;
  if (m.kind == MaterialKind::Glass) {
    Vec3f wi;
    if (!sampleGlassDirection(m, wo, u0, u, wi)) return false;
    // f and pdf as eval() and pdf() give them for this wi, so that both routes agree to the bit.
    out.wi = wi;
    out.pdf = glassPdf(m, wo, wi);
    if (!(out.pdf > 0.0f) || !std::isfinite(out.pdf)) return false;
    out.f = Rgb(glassEval(m, wo, wi));
    return true;
  }
  // Pick the first lobe whose cumulative probability exceeds u0; rounding leftovers go to the last
  // lobe that can be picked at all.
  int lobe = -1;
  float cdf = 0.0f;
  for (int i = 0; i < 3; ++i) {
    if (lobe_[i] <= 0.0f) continue;
    lobe = i;
    cdf += lobe_[i];
    if (u0 < cdf) break;
  }
  if (lobe < 0) return false;

  Vec3f wi;
  if (lobe == kDiffuse) {
    // Cosine-weighted hemisphere (Malley's method): uniform point on the unit disk lifted up.
    const float r = std::sqrt(u.x);
    const float phi = 2.0f * kPiF * u.y;
    wi = Vec3f(r * std::cos(phi), r * std::sin(phi), safeSqrt(1.0f - u.x));
  } else {
    const float alpha = lobe == kFlake ? flake_alpha_ : alpha_;
    Vec3f h;
    if (lobe == kFlake && m.flake_normal.z < 1.0f) {
      const Frame ff = Frame::fromNormal(m.flake_normal);
      const Vec3f o = ff.toLocal(wo);
      if (!(o.z > 0.0f) || !sampleMicrofacetNormal(m.model, alpha, o, u, h)) return false;
      wi = ff.toWorld(reflectAbout(o, h));
    } else if (lobe == kSpec && m.model == MicrofacetModel::GGX) {
      if (!vn_) vn_.emplace(alpha, wo);
      if (!sampleVisibleNormal(*vn_, alpha, u, h)) return false;
      wi = reflectAbout(wo, h);
    } else {
      if (!sampleMicrofacetNormal(m.model, alpha, wo, u, h)) return false;
      wi = reflectAbout(wo, h);
    }
  }
  if (!(wi.z > 0.0f)) return false;
  out.wi = wi;
  out.f = evalPdf(wi, out.pdf);
  return out.pdf > 0.0f && std::isfinite(out.pdf);
}

}  // namespace dg
