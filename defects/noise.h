// Procedural noise for rust, patina and paint variation: seeded simplex noise in 2-D, 3-D and 4-D
// with analytic gradients, and fBm / turbulence sums with a pixel-footprint filter.
//
// Simplex noise follows the construction in S. Gustavson, "Simplex noise demystified" (2005),
// as summarised in shared/reference/nilsson-variations.md §2.2: skew the point onto the integer
// lattice, pick the simplex by ordering the fractional coordinates, and sum over the n+1 corners
// the radial kernel  max(0, r^2 - |d|^2)^4 * (g . d)  (d = offset from the corner, g = its
// hashed gradient). Departures from the classic code, all deliberate:
//  - Kernel radius r^2 = 0.5 in every dimension, not 0.6. 0.5 is the squared height of the
//    simplex (digest §2.3; re-derived here for n = 2, 3, 4: every vertex-to-opposite-facet height
//    squared is exactly 1/2), so a corner's kernel vanishes before it leaves the simplices that
//    contain the corner. The sum over the n+1 simplex corners therefore equals the sum over all
//    lattice points and the noise is smooth everywhere. With 0.6 the 3-D value jumps by up to 5e-3
//    and the gradient by 0.2 at simplex faces (digest §2.3, §10.1, erratum 13.2).
//  - Output scales (kScale2/3/4) are chosen so that |noise| <= 1 for EVERY seed: they are just
//    below 1/B_n, where B_n = max over points in a simplex of sum_k t_k^4 max_g (g . d_k), i.e.
//    the largest value any hash could produce (measured by dense sampling plus local search:
//    1/B_2 = 70.148, 1/B_3 = 76.881, 1/B_4 = 62.778). 1/B_2 reproduces Gustavson's 70 (digest
//    max 0.99789 with x70); 1/B_3 matches the digest's 32/0.41623 ~ 76.9 for r^2 = 0.5.
//  - The hash is a per-instance permutation of 0..255, shuffled (Fisher-Yates) by a counter-based
//    generator keyed with the 64-bit seed. fromPermutation() accepts Ken Perlin's table for the
//    digest's golden values (§2.2). The gradient sets and hash chains are Gustavson's (12 cube-edge
//    midpoints in 3-D, their xy parts in 2-D, 32 vectors (0,±1,±1,±1) and permutations in 4-D).
//  - The gradient is the analytic derivative of the kernel sum, per corner
//    d/dd [t^4 (g.d)] = -8 t^3 (g.d) d + t^4 g,  t = r^2 - |d|^2  (digest §2.1 erratum: the
//    thesis's printed formula has wrong signs in g.d and misses the factor d).
//  - floor() is exact at integers (the classic fastfloor is not, digest §2.3). The skew and the
//    first corner offset are computed in double, so only the float input limits precision; the
//    kernels are evaluated in float. Simplex choice and kernel clamping are branch-free.
// Properties (measured; tests/defects/noise_test.cpp): |noise| <= 1 (hill-climbed maxima reach
// 0.9999); mean 0; RMS 0.442 (2-D), 0.392 (3-D), 0.253 (4-D); E|noise| 0.378, 0.314, 0.176; C^3
// (the kernel's first three derivatives vanish at its rim); 0 at every lattice point; period
// 256 cells in SKEWED space only (noise3 repeats under a shift of (128,128,128), not (256,0,0);
// offset each part by a seeded translation if repetition could show). Inputs must be finite with
// |p| < ~1e6 (beyond that a float input is coarser than 1/16 cell anyway: recentre on the part).
// An instance is immutable after construction and safe to share between threads.
#pragma once
#include <cstdint>

#include "core/math.h"

namespace dg {

class SimplexNoise {
 public:
  static constexpr float kRadius2 = 0.5f;  // squared kernel radius (all dimensions)
  static constexpr float kScale2 = 70.14f;
  static constexpr float kScale3 = 76.87f;
  static constexpr float kScale4 = 62.77f;

  explicit SimplexNoise(uint64_t seed);
  // A noise with a given permutation of 0..255 (e.g. Ken Perlin's reference table, to compare
  // with published values). Entries need not be a permutation, but then the hash is biased.
  static SimplexNoise fromPermutation(const uint8_t (&perm)[256]);

  // Value in [-1, 1]; *grad (if not null) receives d noise / d p.
  float noise2(Vec2f p, Vec2f* grad = nullptr) const;
  float noise3(Vec3f p, Vec3f* grad = nullptr) const;
  float noise4(float x, float y, float z, float w, float grad[4] = nullptr) const;

  // The gradient that the hash attaches to a lattice point, given in skewed (integer) coordinates.
  // For checks that sum kernels over all lattice points; not needed for shading.
  Vec2f latticeGradient2(int i, int j) const;
  Vec3f latticeGradient3(int i, int j, int k) const;
  void latticeGradient4(int i, int j, int k, int l, float g[4]) const;

 private:
  SimplexNoise() = default;
  void fillTables(const uint8_t* p256);
  uint8_t perm_[512];   // the permutation stored twice, so chained lookups need no masking
  uint8_t mod12_[512];  // perm_[i] % 12 (2-D and 3-D gradient index)
};

// Octave sums (Perlin's fractal sum; Nilsson 2008 §4.1.4, digest §2.4), normalised by the
// amplitude sum so that the result keeps noise's range:
//   fbm(p)        = sum_k a_k w_k n_k / A,                 in [-1, 1], mean 0,
//   turbulence(p) = mu + sum_k a_k w_k (|n_k| - mu) / A,   in [0, 1],  mean mu = kMeanAbs{2,3},
// with n_k = noise(f_k p + k c) (c: a fixed irrational shift per octave that keeps the octaves'
// lattices, and their zeros, from lining up at the origin), f_k = base_frequency * lacunarity^k,
// a_k = gain^k, A = sum_{k<octaves} a_k, and w_k the footprint fade below. "Plasma" is
// 1 - turbulence. The gradient is the chain rule per octave: sum_k a_k w_k f_k grad n_k / A
// (sign(n_k) grad n_k for turbulence, discontinuous on the zero set: use turbulence for colour
// rather than bump). Slopes grow like (gain * lacunarity)^k: keep gain * lacunarity <= 1 for bump.
struct FbmParams {
  int octaves = 6;              // 1..kMaxOctaves (clamped)
  float lacunarity = 2.0f;      // frequency ratio between octaves (> 1)
  float gain = 0.5f;            // amplitude ratio between octaves (> 0)
  float base_frequency = 1.0f;  // octave 0 is noise(base_frequency * p); wavelength ~ 1/f
};
constexpr int kMaxOctaves = 16;
// The shift c between octaves (fractional parts of sqrt 2, the golden ratio and sqrt 3).
constexpr float kOctaveShift[3] = {0.41421356f, 0.61803399f, 0.73205081f};

// Footprint filter ("frequency clamping", Tatarchuk 2007 as used by Nilsson 2008 §4.1.6; digest
// §2.5). W is the footprint: the largest extent of the pixel's footprint on the surface, in the
// units of p (e.g. the largest component of |dp/dx| and |dp/dy| from ray differentials). An
// octave of frequency f keeps the weight
//   w = 1 - smoothstep(kFadeStart, kFadeEnd, W f)
// and the rest of it is replaced by the octave's mean; its gradient is scaled by w too (W is
// taken as locally constant). The edges span exactly one octave: an octave is untouched while
// its wavelength 1/f spans >= 4 footprints and gone at <= 2 (the sampling Nyquist limit).
// Measured along lines, noise of frequency 1 holds 16-20 % of its power above 1 cycle per unit,
// 2 % above 1.5 and 0.06 % above 2, so what is kept aliases little: for a 6-octave fbm of gain
// 0.7 the energy above Nyquist drops from 4-6 % to 0.01-0.14 % while 87-92 % of the energy below
// it is kept (noise_test.cpp). Tatarchuk's edges 0.2 / 0.6 (1.6 octaves) measure about the same.
// Fully faded octaves are not evaluated, so surfaces seen from far away (wide footprints) also
// cost less.
constexpr float kFadeStart = 0.25f;
constexpr float kFadeEnd = 0.5f;
float octaveWeight(float footprint, float frequency);

// E|noise|, the mean of every turbulence octave and the value a faded one takes: measured over
// 16 seeds x 2e5 points (seed-to-seed spread 3e-4; noise_test.cpp checks it to 0.004). The
// digest's turbulence mean for the classic r^2 = 0.6, x32 3-D noise is 0.354 (§2.4 [V]); ours
// is lower because the kernel is narrower (the RMS drops likewise, 0.428 -> 0.392).
constexpr float kMeanAbs2 = 0.3782f;
constexpr float kMeanAbs3 = 0.3139f;

float fbm2(const SimplexNoise& n, Vec2f p, const FbmParams& fp, float footprint = 0.0f,
           Vec2f* grad = nullptr);
float fbm3(const SimplexNoise& n, Vec3f p, const FbmParams& fp, float footprint = 0.0f,
           Vec3f* grad = nullptr);
float turbulence2(const SimplexNoise& n, Vec2f p, const FbmParams& fp, float footprint = 0.0f,
                  Vec2f* grad = nullptr);
float turbulence3(const SimplexNoise& n, Vec3f p, const FbmParams& fp, float footprint = 0.0f,
                  Vec3f* grad = nullptr);

}  // namespace dg
