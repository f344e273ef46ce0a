// Simplex noise and octave sums; see noise.h for the method, its sources and the choices made.
#include "defects/noise.h"

#include "core/rng.h"

namespace dg {
namespace {

// Gustavson (2005): the 12 midpoints of the cube's edges. 2-D uses their (x, y) parts with the
// same index, which gives (±1,±1) four times and (±1,0), (0,±1) twice each.
constexpr float kGrad3[12][3] = {{1, 1, 0}, {-1, 1, 0}, {1, -1, 0}, {-1, -1, 0},
                                 {1, 0, 1}, {-1, 0, 1}, {1, 0, -1}, {-1, 0, -1},
                                 {0, 1, 1}, {0, -1, 1}, {0, 1, -1}, {0, -1, -1}};

// Gustavson (2005): the 32 vectors with one zero and three ±1 entries. Block b (8 entries) has its
// zero at position b; within a block the signs of the other three count in binary (+ = 0, - = 1).
struct Grad4Table {
  float g[32][4];
  constexpr Grad4Table() : g() {
    for (int b = 0; b < 4; ++b)
      for (int s = 0; s < 8; ++s) {
        int bit = 2;
        for (int c = 0; c < 4; ++c) {
          if (c == b) {
            g[8 * b + s][c] = 0.0f;
          } else {
            g[8 * b + s][c] = ((s >> bit) & 1) ? -1.0f : 1.0f;
            --bit;
          }
        }
      }
  }
};
constexpr Grad4Table kGrad4;

// Skew / unskew factors F_n = (sqrt(n+1) - 1)/n, G_n = (1 - 1/sqrt(n+1))/n (digest §2.2).
constexpr double kF2 = 0.36602540378443864676;
constexpr double kG2 = 0.21132486540518711775;
constexpr double kF3 = 1.0 / 3.0;
constexpr double kG3 = 1.0 / 6.0;
constexpr double kF4 = 0.30901699437494742410;
constexpr double kG4 = 0.13819660112501051518;

// floor that is exact at integers (including 0 and negative integers).
inline int floorInt(double v) {
  int i = int(v);
  return i - (v < double(i) ? 1 : 0);
}

// One corner's kernel, accumulated into value and (optionally) gradient:
//   t = r^2 - |d|^2;  n = t^4 (g.d);  dn/dd = -8 t^3 (g.d) d + t^4 g.
template <int N>
inline void corner(const float* d, const float* g, float& value, float* grad) {
  float r2 = 0.0f;
  for (int c = 0; c < N; ++c) r2 += d[c] * d[c];
  // Clamped rather than branched on: whether a corner is in range is unpredictable.
  const float t = std::max(SimplexNoise::kRadius2 - r2, 0.0f);
  float gd = 0.0f;
  for (int c = 0; c < N; ++c) gd += g[c] * d[c];
  const float t2 = t * t;
  const float t4 = t2 * t2;
  value += t4 * gd;
  if (grad) {
    float a = -8.0f * t2 * t * gd;
    for (int c = 0; c < N; ++c) grad[c] += a * d[c] + t4 * g[c];
  }
}

float smoothstep(float a, float b, float x) {
  float t = clampf((x - a) / (b - a), 0.0f, 1.0f);
  return t * t * (3.0f - 2.0f * t);
}

// Shared octave loop. D = 2 or 3; Turb selects sum of |n| with mean kMeanAbs.
template <int D, bool Turb>
float octaveSum(const SimplexNoise& noise, const float* p, const FbmParams& fp, float footprint,
                float* grad) {
  const int octaves = std::min(std::max(fp.octaves, 1), kMaxOctaves);
  const float mean = Turb ? (D == 2 ? kMeanAbs2 : kMeanAbs3) : 0.0f;
  float g[3] = {0.0f, 0.0f, 0.0f};
  float sum = 0.0f;     // sum_k a_k w_k (n_k - mean)   (n_k -> |n_k| for turbulence)
  float ampSum = 0.0f;  // A = sum over all octaves of a_k (faded ones included)
  float a = 1.0f, f = fp.base_frequency;
  for (int k = 0; k < octaves; ++k, a *= fp.gain, f *= fp.lacunarity) {
    ampSum += a;
    const float w = octaveWeight(footprint, f);
    if (w <= 0.0f) continue;  // fully faded: the octave sits at its mean, nothing to evaluate
    float q[3], ng[3] = {0.0f, 0.0f, 0.0f};
    for (int c = 0; c < D; ++c) q[c] = f * p[c] + float(k) * kOctaveShift[c];
    float v;
    if constexpr (D == 2) {
      Vec2f g2;
      v = noise.noise2(Vec2f(q[0], q[1]), grad ? &g2 : nullptr);
      ng[0] = g2.x;
      ng[1] = g2.y;
    } else {
      Vec3f g3;
      v = noise.noise3(Vec3f(q[0], q[1], q[2]), grad ? &g3 : nullptr);
      ng[0] = g3.x;
      ng[1] = g3.y;
      ng[2] = g3.z;
    }
    float s = 1.0f;
    if (Turb && v < 0.0f) {  // |n|, and the sign that goes with its gradient
      v = -v;
      s = -1.0f;
    }
    const float aw = a * w;
    sum += aw * (v - mean);
    if (grad) {
      const float scale = aw * f * s;
      for (int c = 0; c < D; ++c) g[c] += scale * ng[c];
    }
  }
  const float inv = 1.0f / ampSum;
  if (grad)
    for (int c = 0; c < D; ++c) grad[c] = g[c] * inv;
  return mean + sum * inv;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Construction

SimplexNoise::SimplexNoise(uint64_t seed) {
  // Fisher-Yates shuffle of 0..255 driven by a counter-based generator keyed by the seed (the
  // constant separates this use of the seed from every other stream derived from it). The
  // modulo bias of next64() % m is below 2^-56.
  uint8_t p[256];
  for (int i = 0; i < 256; ++i) p[i] = uint8_t(i);
  Rng rng(hashKey(seed, 0x6e6f697365ull /* "noise" */));
  for (int i = 255; i > 0; --i) {
    int j = int(rng.next64() % uint64_t(i + 1));
    uint8_t t = p[i];
    p[i] = p[j];
    p[j] = t;
  }
  fillTables(p);
}

SimplexNoise SimplexNoise::fromPermutation(const uint8_t (&perm)[256]) {
  SimplexNoise n;
  n.fillTables(perm);
  return n;
}

void SimplexNoise::fillTables(const uint8_t* p256) {
  for (int i = 0; i < 512; ++i) {
    perm_[i] = p256[i & 255];
    mod12_[i] = uint8_t(perm_[i] % 12);
  }
}

Vec2f SimplexNoise::latticeGradient2(int i, int j) const {
  const float* g = kGrad3[mod12_[(i & 255) + perm_[j & 255]]];
  return {g[0], g[1]};
}

Vec3f SimplexNoise::latticeGradient3(int i, int j, int k) const {
  const float* g = kGrad3[mod12_[(i & 255) + perm_[(j & 255) + perm_[k & 255]]]];
  return {g[0], g[1], g[2]};
}

void SimplexNoise::latticeGradient4(int i, int j, int k, int l, float g[4]) const {
  const float* s =
      kGrad4.g[perm_[(i & 255) + perm_[(j & 255) + perm_[(k & 255) + perm_[l & 255]]]] & 31];
  for (int c = 0; c < 4; ++c) g[c] = s[c];
}

// ---------------------------------------------------------------------------------------------
// 2-D

float SimplexNoise::noise2(Vec2f p, Vec2f* grad) const {
  // Skew to find the cell, unskew its origin: the first corner offset (double: see noise.h).
  const double x = p.x, y = p.y;
  const double s = (x + y) * kF2;
  const int i = floorInt(x + s), j = floorInt(y + s);
  const double t = double(i + j) * kG2;
  const float d0[2] = {float(x - (double(i) - t)), float(y - (double(j) - t))};
  // The triangle: step along x first if the x offset is the larger one.
  const int i1 = d0[0] > d0[1] ? 1 : 0, j1 = 1 - i1;
  const float g2 = float(kG2);
  const float d1[2] = {d0[0] - float(i1) + g2, d0[1] - float(j1) + g2};
  const float d2[2] = {d0[0] - 1.0f + 2.0f * g2, d0[1] - 1.0f + 2.0f * g2};
  const int ii = i & 255, jj = j & 255;
  const float* gr0 = kGrad3[mod12_[ii + perm_[jj]]];
  const float* gr1 = kGrad3[mod12_[ii + i1 + perm_[jj + j1]]];
  const float* gr2 = kGrad3[mod12_[ii + 1 + perm_[jj + 1]]];
  float v = 0.0f, gsum[2] = {0.0f, 0.0f};
  float* gp = grad ? gsum : nullptr;
  corner<2>(d0, gr0, v, gp);
  corner<2>(d1, gr1, v, gp);
  corner<2>(d2, gr2, v, gp);
  if (grad) *grad = {kScale2 * gsum[0], kScale2 * gsum[1]};
  return kScale2 * v;
}

// ---------------------------------------------------------------------------------------------
// 3-D

float SimplexNoise::noise3(Vec3f p, Vec3f* grad) const {
  const double x = p.x, y = p.y, z = p.z;
  const double s = (x + y + z) * kF3;
  const int i = floorInt(x + s), j = floorInt(y + s), k = floorInt(z + s);
  const double t = double(i + j + k) * kG3;
  const float d0[3] = {float(x - (double(i) - t)), float(y - (double(j) - t)),
                       float(z - (double(k) - t))};
  // The tetrahedron: the coordinates step from 0 to 1 in decreasing order of the offsets. Rank
  // each offset by the pairwise comparisons it wins (ties go to the earlier axis, so the ranks
  // are a permutation of 0, 1, 2); the second corner steps along rank 2, the third along ranks
  // 2 and 1. Same simplices as Gustavson's six-case table, without branches.
  const int rx = (d0[0] >= d0[1]) + (d0[0] >= d0[2]);
  const int ry = (d0[1] > d0[0]) + (d0[1] >= d0[2]);
  const int rz = (d0[2] > d0[0]) + (d0[2] > d0[1]);
  const int i1 = rx >= 2, j1 = ry >= 2, k1 = rz >= 2;
  const int i2 = rx >= 1, j2 = ry >= 1, k2 = rz >= 1;
  const float g3 = float(kG3);
  const float d1[3] = {d0[0] - float(i1) + g3, d0[1] - float(j1) + g3, d0[2] - float(k1) + g3};
  const float d2[3] = {d0[0] - float(i2) + 2.0f * g3, d0[1] - float(j2) + 2.0f * g3,
                       d0[2] - float(k2) + 2.0f * g3};
  const float d3[3] = {d0[0] - 1.0f + 3.0f * g3, d0[1] - 1.0f + 3.0f * g3,
                       d0[2] - 1.0f + 3.0f * g3};
  const int ii = i & 255, jj = j & 255, kk = k & 255;
  const float* gr0 = kGrad3[mod12_[ii + perm_[jj + perm_[kk]]]];
  const float* gr1 = kGrad3[mod12_[ii + i1 + perm_[jj + j1 + perm_[kk + k1]]]];
  const float* gr2 = kGrad3[mod12_[ii + i2 + perm_[jj + j2 + perm_[kk + k2]]]];
  const float* gr3 = kGrad3[mod12_[ii + 1 + perm_[jj + 1 + perm_[kk + 1]]]];
  float v = 0.0f, gsum[3] = {0.0f, 0.0f, 0.0f};
  float* gp = grad ? gsum : nullptr;
  corner<3>(d0, gr0, v, gp);
  corner<3>(d1, gr1, v, gp);
  corner<3>(d2, gr2, v, gp);
  corner<3>(d3, gr3, v, gp);
  if (grad) *grad = {kScale3 * gsum[0], kScale3 * gsum[1], kScale3 * gsum[2]};
  return kScale3 * v;
}

// ---------------------------------------------------------------------------------------------
// 4-D

float SimplexNoise::noise4(float x, float y, float z, float w, float grad[4]) const {
  const double pd[4] = {x, y, z, w};
  const double s = (pd[0] + pd[1] + pd[2] + pd[3]) * kF4;
  int cell[4];
  for (int c = 0; c < 4; ++c) cell[c] = floorInt(pd[c] + s);
  const double t = double(cell[0] + cell[1] + cell[2] + cell[3]) * kG4;
  float d[5][4];
  for (int c = 0; c < 4; ++c) d[0][c] = float(pd[c] - (double(cell[c]) - t));
  // Rank each offset by how many of the others it exceeds; corner k (k = 1..3) has stepped
  // along the axes whose rank is >= 4 - k (digest §2.2 step 3, rank method).
  int rank[4] = {0, 0, 0, 0};
  for (int a = 0; a < 4; ++a)
    for (int b = a + 1; b < 4; ++b) {
      const int aWins = d[0][a] > d[0][b];  // branch-free: the order is unpredictable
      rank[a] += aWins;
      rank[b] += 1 - aWins;
    }
  int o[5][4];
  for (int c = 0; c < 4; ++c) {
    o[0][c] = 0;
    o[1][c] = rank[c] >= 3;
    o[2][c] = rank[c] >= 2;
    o[3][c] = rank[c] >= 1;
    o[4][c] = 1;
  }
  const float g4 = float(kG4);
  for (int k = 1; k < 5; ++k)
    for (int c = 0; c < 4; ++c) d[k][c] = d[0][c] - float(o[k][c]) + float(k) * g4;
  const int ii = cell[0] & 255, jj = cell[1] & 255, kk = cell[2] & 255, ll = cell[3] & 255;
  float v = 0.0f, gsum[4] = {0.0f, 0.0f, 0.0f, 0.0f};
  float* gp = grad ? gsum : nullptr;
  for (int k = 0; k < 5; ++k) {
    const int h =
        perm_[ii + o[k][0] + perm_[jj + o[k][1] + perm_[kk + o[k][2] + perm_[ll + o[k][3]]]]];
    corner<4>(d[k], kGrad4.g[h & 31], v, gp);
  }
  if (grad)
    for (int c = 0; c < 4; ++c) grad[c] = kScale4 * gsum[c];
  return kScale4 * v;
}

// ---------------------------------------------------------------------------------------------
// Octave sums

float octaveWeight(float footprint, float frequency) {
  return 1.0f - smoothstep(kFadeStart, kFadeEnd, footprint * frequency);
}

float fbm2(const SimplexNoise& n, Vec2f p, const FbmParams& fp, float footprint, Vec2f* grad) {
  const float pp[2] = {p.x, p.y};
  float g[3];
  float v = octaveSum<2, false>(n, pp, fp, footprint, grad ? g : nullptr);
  if (grad) *grad = {g[0], g[1]};
  return v;
}

float fbm3(const SimplexNoise& n, Vec3f p, const FbmParams& fp, float footprint, Vec3f* grad) {
  const float pp[3] = {p.x, p.y, p.z};
  float g[3];
  float v = octaveSum<3, false>(n, pp, fp, footprint, grad ? g : nullptr);
  if (grad) *grad = {g[0], g[1], g[2]};
  return v;
}

float turbulence2(const SimplexNoise& n, Vec2f p, const FbmParams& fp, float footprint,
                  Vec2f* grad) {
  const float pp[2] = {p.x, p.y};
  float g[3];
  float v = octaveSum<2, true>(n, pp, fp, footprint, grad ? g : nullptr);
  if (grad) *grad = {g[0], g[1]};
  return v;
}

float turbulence3(const SimplexNoise& n, Vec3f p, const FbmParams& fp, float footprint,
                  Vec3f* grad) {
  const float pp[3] = {p.x, p.y, p.z};
  float g[3];
  float v = octaveSum<3, true>(n, pp, fp, footprint, grad ? g : nullptr);
  if (grad) *grad = {g[0], g[1], g[2]};
  return v;
}

}  // namespace dg
