// Tests of the paint variation (render/paint.h; Nilsson 2008 §4.3, shared/reference/
// nilsson-variations.md §3 and §12): exact zero-strength identities, the orange-peel gradient
// against central differences, the RMS normalisations, determinism by seed, the base-colour scale's
// statistics, flake coverage and tilt spread, bounded and monotonically fading sparkle energy, the
// energy bookkeeping with the smooth flake lobe, and robustness to degenerate footprints.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

#include "core/rng.h"
#include "render/paint.h"

namespace dg {
namespace {

// A uniform point in a square of half-width R (mm): wide enough that samples land in distinct
// flake cells and far apart compared with every noise wavelength.
Vec2f randomUv(Rng& rng, float R) {
  return {(2.0f * rng.uniform() - 1.0f) * R, (2.0f * rng.uniform() - 1.0f) * R};
}

bool sameSample(const PaintSample& a, const PaintSample& b) {
  return a.coat_height_grad.x == b.coat_height_grad.x &&
         a.coat_height_grad.y == b.coat_height_grad.y && a.base_color_scale == b.base_color_scale &&
         a.sparkle_weight == b.sparkle_weight && a.flake_normal_local == b.flake_normal_local &&
         a.flake_coverage == b.flake_coverage && a.on_flake == b.on_flake &&
         a.use_flake_lobe == b.use_flake_lobe && a.sparkle_fade == b.sparkle_fade &&
         a.flake_specular_scale == b.flake_specular_scale && a.flake_id == b.flake_id;
}

bool allFinite(const PaintSample& s) {
  return std::isfinite(s.coat_height_grad.x) && std::isfinite(s.coat_height_grad.y) &&
         isFinite(s.base_color_scale) && std::isfinite(s.sparkle_weight) &&
         isFinite(s.flake_normal_local) && std::isfinite(s.flake_coverage) &&
         std::isfinite(s.sparkle_fade) && std::isfinite(s.flake_specular_scale);
}

TEST(PaintVariation, ZeroStrengthsAreExactIdentities) {
  PaintVariationParams p;
  p.orange_peel_amplitude_um = 0;
  p.color_variation = 0;
  p.passive_strength = 0;
  p.flake_tilt_deg = 0;
  PaintVariation pv(p);
  Rng rng(3, Stream::Test);
  int on = 0;
  for (int i = 0; i < 20000; ++i) {
    const float fp = i % 2 ? 0.0f : 0.01f * rng.uniform();
    const PaintSample s = pv.evaluate(randomUv(rng, 500.0f), fp, rng.uniform());
    ASSERT_EQ(s.coat_height_grad.x, 0.0f);
    ASSERT_EQ(s.coat_height_grad.y, 0.0f);
    ASSERT_EQ(s.base_color_scale, Rgb(1.0f));
    ASSERT_EQ(s.flake_specular_scale, 1.0f);
    ASSERT_EQ(s.flake_normal_local, Vec3f(0.0f, 0.0f, 1.0f));  // zero tilt: macro normal
    on += s.on_flake;
  }
  EXPECT_GT(on, 0);  // flakes are still there, just untilted
  EXPECT_EQ(pv.coatHeight({1.0f, 2.0f}), 0.0f);

  // Density 0: no flake anywhere, no sparkle, coverage 0.
  p.flake_density = 0;
  PaintVariation none(p);
  EXPECT_EQ(none.flakeCoverage(), 0.0f);
  for (int i = 0; i < 20000; ++i) {
    const PaintSample s = none.evaluate(randomUv(rng, 500.0f), 0.0f, 0.0f);
    ASSERT_FALSE(s.on_flake);
    ASSERT_EQ(s.sparkle_weight, 0.0f);
    ASSERT_FALSE(s.use_flake_lobe);
  }
}

TEST(PaintVariation, OrangePeelGradientMatchesCentralDifferences) {
  for (float amp_um : {2.0f, 50.0f}) {
    PaintVariationParams p;
    p.orange_peel_amplitude_um = amp_um;
    PaintVariation pv(p);
    // RMS slope of the unfiltered field: A_rms / kPeelRms * rms|grad fbm| / wavelength, where the
    // unit fBm's rms |gradient| is 2.95 per lattice cell (measured).
    const double slope_rms = amp_um * 1e-3 / PaintVariation::kPeelRms * 2.953 / 3.0;
    const float h = 2e-3f;  // mm; the finest octave has a 0.75 mm lattice
    Rng rng(5, Stream::Test);
    double max_err = 0;
    for (float fp : {0.0f, 0.5f, 1.2f}) {  // filtering keeps height and gradient consistent
      for (int i = 0; i < 2000; ++i) {
        // Near the origin a float uv (and the octaves' float lattice coordinates) resolve 1e-7 mm,
        // so the differences below are not dominated by rounding; the actual (rounded) step is the
        // denominator. (Far from the origin the analytic gradient stays exact, the height does not.)
        const Vec2f uv = randomUv(rng, 4.0f);
        const PaintSample s = pv.evaluate(uv, fp, 0.5f);
        const float xp = uv.x + h, xm = uv.x - h, yp = uv.y + h, ym = uv.y - h;
        const double gx = (double(pv.coatHeight({xp, uv.y}, fp)) -
                           double(pv.coatHeight({xm, uv.y}, fp))) / (double(xp) - double(xm));
        const double gy = (double(pv.coatHeight({uv.x, yp}, fp)) -
                           double(pv.coatHeight({uv.x, ym}, fp))) / (double(yp) - double(ym));
        max_err = std::max(max_err, std::max(std::fabs(gx - s.coat_height_grad.x),
                                             std::fabs(gy - s.coat_height_grad.y)));
      }
    }
    EXPECT_LT(max_err, 5e-4 * slope_rms) << "amplitude " << amp_um << " um";
  }
}

TEST(PaintVariation, OrangePeelRmsHeightAndSlopeMatchParameters) {
  PaintVariationParams p;  // 2 um RMS, 3 mm
  Rng rng(7, Stream::Test);
  double h2 = 0, g2 = 0;
  const int n = 60000;
  for (int seed = 1; seed <= 3; ++seed) {
    p.seed = seed;
    PaintVariation pv(p);
    for (int i = 0; i < n; ++i) {
      const Vec2f uv = randomUv(rng, 3000.0f);
      const float hh = pv.coatHeight(uv);
      const Vec2f g = pv.evaluate(uv, 0.0f, 0.5f).coat_height_grad;
      h2 += double(hh) * hh;
      g2 += double(g.x) * g.x + double(g.y) * g.y;
    }
  }
  const double rms_h_um = std::sqrt(h2 / (3.0 * n)) * 1e3;
  const double rms_slope = std::sqrt(g2 / (3.0 * n));
  EXPECT_NEAR(rms_h_um, 2.0, 0.06);          // Rq = amplitude (3%)
  EXPECT_NEAR(rms_slope, 6.8e-3, 0.4e-3);    // 0.39 degrees: distorts reflections, not rocky
  // A footprint far wider than the coarsest octave leaves the mean: flat coat, exactly.
  PaintVariation pv(p);
  const PaintSample s = pv.evaluate({12.3f, -4.5f}, 100.0f, 0.5f);
  EXPECT_EQ(s.coat_height_grad.x, 0.0f);
  EXPECT_EQ(s.coat_height_grad.y, 0.0f);
  EXPECT_EQ(s.base_color_scale, Rgb(1.0f));  // 40 mm colour noise faded too (2 footprints/cell)
  EXPECT_EQ(s.flake_specular_scale, 1.0f);
}

TEST(PaintVariation, DeterministicBySeedAndDifferentAcrossSeeds) {
  PaintVariationParams p;
  p.seed = 42;
  PaintVariation a(p), b(p);
  p.seed = 43;
  PaintVariation c(p);
  Rng rng(11, Stream::Test);
  int grad_diff = 0, flake_diff = 0, n_on = 0;
  double sab = 0, saa = 0, sbb = 0;
  for (int i = 0; i < 20000; ++i) {
    const Vec2f uv = randomUv(rng, 200.0f);
    const float fp = 0.002f * rng.uniform(), u = rng.uniform();
    const PaintSample sa = a.evaluate(uv, fp, u), sb = b.evaluate(uv, fp, u);
    ASSERT_TRUE(sameSample(sa, sb));
    const PaintSample sc = c.evaluate(uv, fp, u);
    grad_diff += sa.coat_height_grad.x != sc.coat_height_grad.x;
    if (sa.on_flake || sc.on_flake) {
      ++n_on;
      flake_diff += sa.flake_id != sc.flake_id;
    }
    const double ha = a.coatHeight(uv), hc = c.coatHeight(uv);
    sab += ha * hc;
    saa += ha * ha;
    sbb += hc * hc;
  }
  EXPECT_EQ(grad_diff, 20000);
  EXPECT_EQ(flake_diff, n_on);
  EXPECT_LT(std::fabs(sab / std::sqrt(saa * sbb)), 0.05);  // decorrelated height fields
}

TEST(PaintVariation, BaseColorScaleHasMeanOneAndConfiguredSpread) {
  PaintVariationParams p;  // color_variation 0.03 (std), 40 mm
  const float cv = p.color_variation;
  Rng rng(13, Stream::Test);
  double sum = 0, sum2 = 0;
  const int n = 3 * 40000;
  for (int seed = 1; seed <= 3; ++seed) {
    p.seed = seed;
    PaintVariation pv(p);
    for (int i = 0; i < n / 3; ++i) {
      const Rgb c = pv.evaluate(randomUv(rng, 40000.0f), 0.0f, 0.5f).base_color_scale;
      ASSERT_EQ(c.x, c.y);  // luminance-only
      ASSERT_EQ(c.x, c.z);
      ASSERT_GE(c.x, 1.0f - 3.0f * cv);
      ASSERT_LE(c.x, 1.0f + 3.0f * cv);
      sum += c.x;
      sum2 += double(c.x) * c.x;
    }
  }
  const double mean = sum / n, sd = std::sqrt(std::max(0.0, sum2 / n - mean * mean));
  EXPECT_NEAR(mean, 1.0, 4.0 * cv / std::sqrt(double(n)) + 1e-4);
  EXPECT_NEAR(sd, cv, 0.05 * cv);
}

TEST(PaintVariation, PassiveFlakeScaleHasMeanOneAndFadesWithFootprint) {
  PaintVariationParams p;  // passive_strength 0.1, 0.5 mm
  PaintVariation pv(p);
  Rng rng(17, Stream::Test);
  auto stats = [&](float fp, double& mean, double& sd) {
    double s = 0, s2 = 0;
    const int n = 40000;
    for (int i = 0; i < n; ++i) {
      const float v = pv.evaluate(randomUv(rng, 2000.0f), fp, 0.5f).flake_specular_scale;
      s += v;
      s2 += double(v) * v;
    }
    mean = s / n;
    sd = std::sqrt(std::max(0.0, s2 / n - mean * mean));
  };
  double m0, sd0, m1, sd1, m2, sd2;
  stats(0.0f, m0, sd0);
  stats(0.05f, m1, sd1);  // the finest octave (0.087 mm) is gone
  stats(1.0f, m2, sd2);   // all octaves gone
  EXPECT_NEAR(m0, 1.0, 0.003);
  EXPECT_NEAR(sd0, 0.1, 0.006);
  EXPECT_NEAR(m1, 1.0, 0.003);
  EXPECT_LT(sd1, 0.6 * sd0);  // the thesis's 2.7 gain: fine octaves carry most of the variation
  EXPECT_EQ(sd2, 0.0);
  EXPECT_EQ(m2, 1.0);
}

TEST(PaintVariation, FlakeCoverageAndTiltSpread) {
  for (float density : {0.3f, 1.0f}) {
    PaintVariationParams p;
    p.flake_density = density;
    PaintVariation pv(p);
    EXPECT_FLOAT_EQ(pv.flakeCoverage(), density * kPiF / 16.0f);
    EXPECT_FLOAT_EQ(pv.cellSize(), 0.06f);
    Rng rng(19, Stream::Test);
    const int n = 200000;
    int on = 0;
    double sx = 0, sx2 = 0, sy = 0, sy2 = 0, st = 0;
    int nt = 0;
    for (int i = 0; i < n; ++i) {
      const PaintSample s = pv.evaluate(randomUv(rng, 5000.0f), 0.0f, 0.5f);
      ASSERT_NEAR(length(s.flake_normal_local), 1.0f, 1e-5f);
      ASSERT_GT(s.flake_normal_local.z, 0.0f);
      ASSERT_EQ(s.flake_coverage, pv.flakeCoverage());
      if (!s.on_flake) {
        ASSERT_EQ(s.flake_normal_local, Vec3f(0.0f, 0.0f, 1.0f));
        continue;
      }
      ++on;
      // Tilt vector (theta cos phi, theta sin phi) from the normal.
      const Vec3f fn = s.flake_normal_local;
      const double theta = std::acos(std::min(1.0, double(fn.z)));
      const double r = std::hypot(double(fn.x), double(fn.y));
      if (r > 0) {
        const double tx = theta * fn.x / r, ty = theta * fn.y / r;
        sx += tx;
        sx2 += tx * tx;
        sy += ty;
        sy2 += ty * ty;
      }
      st += theta;
      ++nt;
    }
    const double c = pv.flakeCoverage();
    const double sigma_binom = std::sqrt(c * (1 - c) / n);
    EXPECT_NEAR(double(on) / n, c, 4 * sigma_binom) << "density " << density;
    const double sigma = 12.0 * kPi / 180.0;
    const double sdx = std::sqrt(sx2 / nt - sqr(float(sx / nt)));
    const double sdy = std::sqrt(sy2 / nt - sqr(float(sy / nt)));
    EXPECT_NEAR(sdx, sigma, 0.1 * sigma);  // brief: std within 10%
    EXPECT_NEAR(sdy, sigma, 0.1 * sigma);
    EXPECT_NEAR(sdx, sigma, 0.03 * sigma);  // and, in fact, within statistical error
    EXPECT_NEAR(st / nt, sigma * std::sqrt(kPi / 2), 0.03 * sigma);  // Rayleigh mean
  }
}

TEST(PaintVariation, PointsOfOneFlakeShareItsIdentityAndNormal) {
  PaintVariationParams p;
  PaintVariation pv(p);
  Rng rng(23, Stream::Test);
  int flakes = 0;
  while (flakes < 200) {
    const Vec2f uv = randomUv(rng, 1000.0f);
    const PaintSample s = pv.evaluate(uv, 0.0f, 0.5f);
    if (!s.on_flake) continue;
    ++flakes;
    // Probe a small neighbourhood: every probe on a flake with this id has the same normal, and
    // probes of the same cell without the flake are off it (one flake per cell, disk shaped).
    int same = 0;
    for (int k = 0; k < 16; ++k) {
      const Vec2f q{uv.x + 0.004f * (rng.uniform() - 0.5f), uv.y + 0.004f * (rng.uniform() - 0.5f)};
      const PaintSample t = pv.evaluate(q, 0.0f, 0.5f);
      if (t.on_flake && t.flake_id == s.flake_id) {
        ++same;
        ASSERT_EQ(t.flake_normal_local, s.flake_normal_local);
      }
    }
    EXPECT_GT(same, 0);
  }
}

TEST(PaintVariation, SparkleEnergyBoundedAndFadesMonotonically) {
  PaintVariationParams p;
  p.sparkle_intensity = 5.0f;  // clamped to 1: a probability cannot exceed 1
  PaintVariation pv(p);
  const float cell = pv.cellSize(), c = pv.flakeCoverage();
  // A fixed point on a flake, for a per-point monotonicity check.
  Rng rng(29, Stream::Test);
  Vec2f on_uv;
  for (;;) {
    on_uv = randomUv(rng, 100.0f);
    if (pv.evaluate(on_uv, 0.0f, 0.5f).on_flake) break;
  }
  float prev_fade = 2.0f, prev_point = 2.0f, prev_mean = 2.0f;
  const int steps = 41, n = 20000;
  for (int k = 0; k < steps; ++k) {
    const float fp = cell * 0.1f * std::pow(100.0f, float(k) / (steps - 1));  // 0.1 .. 10 cells
    double sum_w = 0;
    int on = 0;
    Rng r2(31, Stream::Test);  // same points for every footprint
    for (int i = 0; i < n; ++i) {
      const PaintSample s = pv.evaluate(randomUv(r2, 3000.0f), fp, r2.uniform());
      ASSERT_LE(s.sparkle_weight, 1.0f);
      ASSERT_GE(s.sparkle_weight, 0.0f);
      if (!s.on_flake) {
        ASSERT_EQ(s.sparkle_weight, 0.0f);
      }
      sum_w += s.sparkle_weight * (s.on_flake ? 1.0 : 0.0);
      on += s.on_flake;
    }
    const double mean_w = sum_w / n;
    EXPECT_LE(mean_w, c + 4.0 * std::sqrt(c * (1 - c) / n)) << "footprint " << fp;
    EXPECT_LE(mean_w, double(on) / n + 1e-12);
    const PaintSample s = pv.evaluate(on_uv, fp, 0.5f);
    EXPECT_LE(s.sparkle_fade, prev_fade);
    EXPECT_LE(s.sparkle_weight, prev_point);
    EXPECT_LE(mean_w, prev_mean + 1e-12);
    prev_fade = s.sparkle_fade;
    prev_point = s.sparkle_weight;
    prev_mean = float(mean_w);
    if (k == 0) {
      EXPECT_EQ(s.sparkle_weight, 1.0f);  // 0.1 cell: fully resolved
      EXPECT_NEAR(mean_w, c, 4.0 * std::sqrt(c * (1 - c) / n));
    }
    if (k == steps - 1) {
      EXPECT_EQ(s.sparkle_weight, 0.0f);  // 10 cells: only the smooth lobe
      EXPECT_EQ(mean_w, 0.0);
    }
  }
  EXPECT_FLOAT_EQ(pv.evaluate(on_uv, 2.5f * cell, 0.5f).sparkle_fade, 0.5f);  // mid of [1, 4]
}

TEST(PaintVariation, StochasticFlakeLobeKeepsFlakeEnergy) {
  // Over area and u_rand: P(use_flake_lobe) = coverage * fade, and with the residual smooth share
  // elsewhere, the mean flake share equals the material's flake_amount.
  PaintVariationParams p;
  PaintVariation pv(p);
  const float fa = 0.5f;
  for (float cells : {0.5f, 2.0f, 3.0f, 8.0f}) {
    const float fp = cells * pv.cellSize();
    Rng rng(37, Stream::Test);
    const int n = 200000;
    double share = 0;
    int use = 0;
    float fade = 0;
    for (int i = 0; i < n; ++i) {
      const PaintSample s = pv.evaluate(randomUv(rng, 5000.0f), fp, rng.uniform());
      fade = s.sparkle_fade;
      if (s.use_flake_lobe) {
        ASSERT_TRUE(s.on_flake);
        ++use;
        share += 1.0;
      } else {
        share += PaintVariation::residualFlakeAmount(fa, s);
      }
    }
    const double pc = pv.flakeCoverage() * fade;
    EXPECT_NEAR(double(use) / n, pc, 4 * std::sqrt(pc * (1 - pc) / n) + 1e-9) << cells;
    EXPECT_NEAR(share / n, fa, 4 * std::sqrt(pc * (1 - pc) / n) * (1 - fa) + 1e-5) << cells;
  }
}

TEST(PaintVariation, SmoothFlakeAlphaMatchesTiltSpread) {
  PaintVariationParams p;
  PaintVariation pv(p);
  EXPECT_NEAR(pv.smoothFlakeAlpha(), std::sqrt(2.0) * std::tan(12.0 * kPi / 180.0), 1e-5);
  p.flake_tilt_deg = 0;
  EXPECT_EQ(PaintVariation(p).smoothFlakeAlpha(), 0.0f);
}

TEST(PaintVariation, NoNanForDegenerateFootprintsOrInputs) {
  PaintVariationParams p;
  PaintVariation pv(p);
  const float inf = std::numeric_limits<float>::infinity();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  Rng rng(41, Stream::Test);
  for (float fp : {0.0f, 1e-30f, 1e3f, 1e30f, inf, nan, -1.0f}) {
    for (int i = 0; i < 2000; ++i) {
      const PaintSample s = pv.evaluate(randomUv(rng, 1e4f), fp, rng.uniform());
      ASSERT_TRUE(allFinite(s)) << fp;
      if (fp >= 1e3f) {  // huge: everything at its mean
        ASSERT_EQ(s.coat_height_grad.x, 0.0f);
        ASSERT_EQ(s.sparkle_weight, 0.0f);
        ASSERT_EQ(s.base_color_scale, Rgb(1.0f));
      }
    }
  }
  // Negative uv and exact cell boundaries.
  for (float x : {-0.06f, -1e-7f, 0.0f, 0.06f, -12345.678f})
    EXPECT_TRUE(allFinite(pv.evaluate({x, x}, 0.0f, 0.0f)));
  // Non-finite uv: the neutral sample.
  const PaintSample s = pv.evaluate({nan, 1.0f}, 0.0f, 0.5f);
  EXPECT_TRUE(allFinite(s));
  EXPECT_FALSE(s.on_flake);
  EXPECT_EQ(s.base_color_scale, Rgb(1.0f));
  // Degenerate parameters.
  PaintVariationParams bad;
  bad.orange_peel_wavelength_mm = 0;
  bad.flake_size_mm = nan;
  bad.color_variation = -1;
  bad.flake_tilt_deg = 1e9f;
  PaintVariation pb(bad);
  for (int i = 0; i < 1000; ++i) {
    const PaintSample t = pb.evaluate(randomUv(rng, 100.0f), 0.0f, 0.5f);
    ASSERT_TRUE(allFinite(t));
    ASSERT_FALSE(t.on_flake);
    ASSERT_EQ(t.coat_height_grad.x, 0.0f);
  }
}

TEST(PaintVariation, FbmRmsConstantsAreMeasuredValues) {
  // The normalising constants of paint.h, re-measured on fresh seeds (3%).
  struct Case {
    int octaves;
    float lac, gain, rms;
  } cases[] = {{3, 2.0f, 0.5f, PaintVariation::kPeelRms},
               {2, 2.0f, 0.5f, PaintVariation::kColorRms},
               {3, 2.4f, 2.7f, PaintVariation::kPassiveRms}};
  for (const Case& c : cases) {
    double s2 = 0;
    int n = 0;
    Rng rng(43, Stream::Test);
    for (int seed = 100; seed < 104; ++seed) {
      SimplexNoise noise(seed);
      FbmParams fp;
      fp.octaves = c.octaves;
      fp.lacunarity = c.lac;
      fp.gain = c.gain;
      for (int i = 0; i < 25000; ++i, ++n) s2 += sqr(fbm2(noise, randomUv(rng, 1000.0f), fp));
    }
    EXPECT_NEAR(std::sqrt(s2 / n), c.rms, 0.03 * c.rms);
  }
}

}  // namespace
}  // namespace dg
