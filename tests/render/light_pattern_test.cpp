#include "render/light_pattern.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <utility>
#include <numeric>
#include <vector>

#include "core/rng.h"

namespace dg {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Zaremba's index of the lattice of generator g, by brute force over a box of frequencies: the
// smallest max(1, |h1|) max(1, |h2|) over nonzero (h1, h2) with h1 + g h2 = 0 (mod n).
int64_t zaremba(int n, int g) {
  int64_t best = n;
  for (int h1 = -n; h1 <= n; ++h1)
    for (int h2 = -n; h2 <= n; ++h2)
      if ((h1 != 0 || h2 != 0) && ((h1 + int64_t(g) * h2) % n + n) % n == 0)
        best = std::min<int64_t>(best, int64_t(std::max(1, std::abs(h1))) * std::max(1, std::abs(h2)));
  return best;
}

// The chosen generator makes a Latin square (every row and every column of the n x n grid holds
// one point: g is prime to n) and has the largest Zaremba index of all such generators; for
// Fibonacci numbers that is the Fibonacci lattice (generator the previous Fibonacci number, or its
// mirror image n - g), the best 2-D lattice there is.
TEST(LightPattern, GeneratorIsTheBestLatticeAndALatinSquare) {
  for (int n = 1; n <= 40; ++n) {
    SCOPED_TRACE(n);
    const int g = latticeGenerator(n);
    ASSERT_GE(g, 1);
    ASSERT_LT(g, std::max(2, n));
    EXPECT_EQ(std::gcd(g, n), 1);
    std::vector<bool> row(size_t(n), false);
    for (int k = 0; k < n; ++k) row[size_t((int64_t(k) * g) % n)] = true;
    EXPECT_EQ(std::count(row.begin(), row.end(), true), n);
    int64_t best = 0;
    for (int h = 1; h < n; ++h)
      if (std::gcd(h, n) == 1) best = std::max(best, zaremba(n, h));
    if (n > 3) {
      EXPECT_EQ(zaremba(n, g), best);
    }
  }
  for (auto [n, f] : {std::pair{13, 8}, {21, 13}, {34, 21}, {55, 34}}) {
    const int g = latticeGenerator(n);
    EXPECT_TRUE(g == f || g == n - f) << n << " points: generator " << g;
  }
}

// Every point is uniform on [0, 1)^2 (the shift, folded by the tent map where asked): the
// histogram of point k over many shifts is flat, for each k, periodic second coordinate or not.
TEST(LightPattern, EachPointIsUniform) {
  const int n = 16, g = latticeGenerator(n), bins = 8, draws = 40000;
  Rng rng(7);
  for (bool periodic : {false, true})
    for (int k : {0, 5, 15}) {
      std::vector<int> hist(bins * bins, 0);
      for (int i = 0; i < draws; ++i) {
        Vec2f u = LightPattern(n, g, rng).at(k, periodic);
        ASSERT_GE(u.x, 0.0f);
        ASSERT_LT(u.x, 1.0f);
        ASSERT_GE(u.y, 0.0f);
        ASSERT_LT(u.y, 1.0f);
        ++hist[int(u.y * bins) * bins + int(u.x * bins)];
      }
      const double expect = double(draws) / (bins * bins);
      double chi2 = 0;
      for (int c : hist) chi2 += (c - expect) * (c - expect) / expect;
      // 63 degrees of freedom: the 99.9% point is about 104.
      EXPECT_LT(chi2, 104) << "k " << k << (periodic ? " periodic" : "");
    }
}

// On smooth integrands the pattern's error is far below independent samples' and below the
// jittered q x q grid it replaced (n strata along x when n is not a square), and its mean over
// shifts is the integral. (Printed: at 16 points, the renderer's count, 1.8 and 6 times below the
// grid's error; 10 to 30 times at the Fibonacci counts 13 and 21.) The integrands: a
// smooth bump in both coordinates (a rectangle light's glossy highlight) and, with the second
// coordinate periodic, the annulus's case (a glossy lobe that sees one side of the ring brighter
// than the other: 1 + 0.6 cos(2 pi y), falling off across the ring as 1 / (1 + x)^4).
TEST(LightPattern, SmoothIntegrandsConvergeFasterThanJitteredStrata) {
  struct Case {
    bool periodic;
    double (*f)(double, double);
    double exact;
  };
  const Case cases[] = {
      {false, [](double x, double y) { return std::exp(-3 * ((x - 0.3) * (x - 0.3) + (y - 0.6) * (y - 0.6))); },
       // the integral of exp(-3 t^2) over [-0.3, 0.7] times over [-0.6, 0.4]
       0.0},
      {true, [](double x, double y) { return (1 + 0.6 * std::cos(2 * kPi * (y + 0.1))) / std::pow(1 + x, 4); },
       (1 - 1 / 8.0) / 3},
  };
  for (const Case& c : cases) {
    double exact = c.exact;
    if (exact == 0) {  // the bump: a fine midpoint rule
      const int m = 2000;
      for (int i = 0; i < m; ++i)
        for (int j = 0; j < m; ++j) exact += c.f((i + 0.5) / m, (j + 0.5) / m);
      exact /= double(m) * m;
    }
    for (int n : {8, 13, 16, 21, 32}) {
      SCOPED_TRACE(testing::Message() << "n " << n << (c.periodic ? " periodic" : ""));
      const int g = latticeGenerator(n), runs = 4000;
      Rng rng(11);
      double mean = 0, err2 = 0, err2_grid = 0, var1 = 0;
      const int q = n == 16 ? 4 : 0;  // the only square count here
      for (int r = 0; r < runs; ++r) {
        LightPattern pat(n, g, rng);
        double est = 0, grid = 0;
        for (int k = 0; k < n; ++k) {
          Vec2f u = pat.at(k, c.periodic);
          est += c.f(u.x, u.y) / n;
          // The old sampler: a jittered q x q grid for square n, else n strata along x.
          double gx = q ? (k % q + rng.uniformD()) / q : (k + rng.uniformD()) / n;
          double gy = q ? (k / q + rng.uniformD()) / q : rng.uniformD();
          grid += c.f(gx, gy) / n;
          double v = c.f(rng.uniformD(), rng.uniformD()) - exact;
          var1 += v * v / runs;
        }
        mean += est / runs;
        err2 += (est - exact) * (est - exact) / runs;
        err2_grid += (grid - exact) * (grid - exact) / runs;
      }
      var1 /= n;  // per sample
      const double rms = std::sqrt(err2), rms_grid = std::sqrt(err2_grid), rms_mc = std::sqrt(var1 / n);
      EXPECT_NEAR(mean, exact, 4 * rms / std::sqrt(double(runs)) + 1e-12);
      printf("%2d points, %s: rms error %.3g (jittered grid %.3g, independent %.3g)\n", n,
             c.periodic ? "ring" : "bump", rms, rms_grid, rms_mc);
      EXPECT_LT(rms, rms_mc / 4);
      EXPECT_LT(rms, rms_grid / 1.5);
      // Fibonacci counts give the best 2-D lattices.
      if (n == 13 || n == 21) {
        EXPECT_LT(rms, rms_grid / 5);
      }
    }
  }
}


// Generators restricted to g = r (mod m): the lattice of n = m p points splits into p sub-lattices
// {k p + s : k < m}, each the m-point lattice of generator r (a camera sample's light samples
// within its pixel's lattice), and the whole is still a good lattice: its Zaremba index is at
// least 40% of the best unrestricted one's (printed).
TEST(LightPattern, EmbeddedLatticesSplitIntoGoodParts) {
  const int m = 16, r = latticeGenerator(16);
  for (int p : {2, 3, 4, 8, 16}) {
    const int n = m * p, g = latticeGenerator(n, m, r);
    SCOPED_TRACE(testing::Message() << n << " points, generator " << g);
    EXPECT_EQ(g % m, r);
    EXPECT_EQ(std::gcd(g, n), 1);
    for (int s = 0; s < p; ++s)
      for (int k = 0; k + 1 < m; ++k) {
        // Consecutive points of a part step by 1/m along x and by r/m (mod 1) along y.
        const int64_t y0 = (int64_t(k * p + s) * g) % n, y1 = (int64_t((k + 1) * p + s) * g) % n;
        EXPECT_EQ(((y1 - y0) % n + n) % n, (int64_t(r) * p) % n);
      }
    int64_t best = 0;
    for (int h = 1; h < n; ++h)
      if (std::gcd(h, n) == 1) best = std::max(best, zaremba(n, h));
    printf("%3d points: Zaremba index %lld (best unrestricted %lld)\n", n, (long long)zaremba(n, g), (long long)best);
    EXPECT_GE(zaremba(n, g), 0.4 * double(best));
  }
}

// A pixel's pattern: every (dimension, sample) point is uniform; within one dimension the
// pixel's samples integrate a smooth function far better than independent samples; and two
// dimensions do not move in step (the mean |correlation| of their points over a pixel's samples
// is about 1 / sqrt(n); the same lattice unpermuted, differing only in its shift, gives about 0.6).
TEST(PixelPattern, UniformEvenAndDecorrelated) {
  const int n = 64, g = latticeGenerator(n), dims = 3, runs = 3000;
  Rng rng(5);
  PixelPattern pp;
  std::vector<int> hist(64, 0);
  double err2 = 0, corr = 0;
  auto f = [](Vec2f u) { return std::exp(-2.0 * ((u.x - 0.4) * (u.x - 0.4) + (u.y - 0.7) * (u.y - 0.7))); };
  const int m = 1000;
  double exact = 0;
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < m; ++j) exact += f(Vec2f((i + 0.5f) / m, (j + 0.5f) / m)) / (double(m) * m);
  double var1 = 0;
  for (int r = 0; r < runs; ++r) {
    pp.reset(n, g, dims, rng);
    Vec2f u = pp.at(1, r % n, true);
    ++hist[int(u.y * 8) * 8 + int(u.x * 8)];
    double est = 0, sxy = 0, sx = 0, sy = 0, sxx = 0, syy = 0;
    for (int s = 0; s < n; ++s) {
      est += f(pp.at(0, s, false)) / n;
      const double a = pp.at(0, s, false).x, b = pp.at(2, s, false).x;
      sx += a / n;
      sy += b / n;
      sxy += a * b / n;
      sxx += a * a / n;
      syy += b * b / n;
      const double v = f(Vec2f(rng.uniform(), rng.uniform())) - exact;
      var1 += v * v / (double(runs) * n);
    }
    err2 += (est - exact) * (est - exact) / runs;
    corr += std::fabs(sxy - sx * sy) / std::sqrt((sxx - sx * sx) * (syy - sy * sy)) / runs;
  }
  double chi2 = 0;
  for (int c : hist) chi2 += (c - runs / 64.0) * (c - runs / 64.0) / (runs / 64.0);
  EXPECT_LT(chi2, 104);  // 63 degrees of freedom, 99.9%
  const double rms = std::sqrt(err2), rms_mc = std::sqrt(var1 / n);
  printf("64 samples: rms error %.3g (independent %.3g); mean |correlation| of two dimensions %.3f\n", rms, rms_mc,
         corr);
  EXPECT_LT(rms, rms_mc / 20);
  EXPECT_LT(corr, 0.2);
}

// Two dimensions of one pixel's pattern jointly: where a pixel's value depends on a sum of two of
// its sample dimensions (a shadow edge that moves with both the camera sample's position and the
// light sample's, the path tracer's case at a pile-up's shadow line), the share of the pixel's
// samples below a line u_a + c u_b = t has to follow the area below it. Dimensions paired by an
// affine permutation of the same lattice form a 2-D lattice again, for some pixels one whose
// points lie on two or four lines; such a pixel's shadow edge then took 0, 1/2 or 1 of its
// samples whatever the edge's place (a reference pixel at 256 spp read 0.49 or 0.02 where the
// exact value ramps from 0.02 to 0.24). Over 300 pixels the largest deviation stays near the
// Kolmogorov bound of n independent pairs (1.63 / sqrt(n) at 99%).
TEST(PixelPattern, TwoDimensionsTogetherFollowTheAreaBelowALine) {
  const int n = 256, g = latticeGenerator(n), runs = 300;
  Rng rng(17);
  PixelPattern pp;
  std::vector<double> v(size_t(n), 0.0);
  double worst = 0;
  for (int r = 0; r < runs; ++r) {
    pp.reset(n, g, 3, rng);
    for (const double c : {0.37, 1.0, 2.9}) {
      // The camera dimension's y against a light dimension's y and x.
      for (int pair = 0; pair < 2; ++pair) {
        for (int s = 0; s < n; ++s) {
          const Vec2f a = pp.at(2, s, false), b = pp.at(0, s, false);
          v[size_t(s)] = a.y + c * (pair == 0 ? b.y : b.x);
        }
        std::sort(v.begin(), v.end());
        // The area of {x + c y < t} over the unit square: the distribution of the sum of
        // uniforms on [0, 1] and [0, c].
        auto area = [c](double t) {
          const double lo = std::min(1.0, c), hi = std::max(1.0, c);
          if (t <= 0) return 0.0;
          if (t >= lo + hi) return 1.0;
          if (t <= lo) return t * t / (2 * lo * hi);
          if (t <= hi) return (t - lo / 2) / hi;
          const double u = lo + hi - t;
          return 1.0 - u * u / (2 * lo * hi);
        };
        for (int k = 0; k < n; ++k) {
          const double f = area(v[size_t(k)]);
          worst = std::max({worst, std::fabs(f - double(k) / n), std::fabs(f - double(k + 1) / n)});
        }
      }
    }
  }
  printf("%d samples, %d pixels: largest deviation below a line %.3f (bound %.3f)\n", n, runs, worst,
         1.63 / std::sqrt(double(n)));
  EXPECT_LT(worst, 1.63 / std::sqrt(double(n)));
}

// The lobe choices of a pixel's camera samples (lobeAt) and of their split directions (lobe): one
// number in each of the pixel's strata, whatever the jitter, and the strata in a random order.
TEST(PixelPattern, LobeChoicesAreLatinStrataOverThePixel) {
  const int spp = 16, nd = 4;
  Rng rng(3);
  PixelPattern pp;
  pp.reset(spp, latticeGenerator(spp), 3, rng);
  pp.resetDirections(nd, latticeGenerator(nd * spp, nd, latticeGenerator(nd)), rng);
  std::vector<int> one(spp, 0), split(nd * spp, 0);
  int in_order = 0;
  for (int s = 0; s < spp; ++s) {
    const float u = pp.lobeAt(s, rng.uniform());
    ASSERT_GE(u, 0.0f);
    ASSERT_LT(u, 1.0f);
    ++one[size_t(u * spp)];
    in_order += int(u * spp) == s;
    for (int j = 0; j < nd; ++j) {
      const float v = pp.lobe(j, s, rng.uniform());
      ASSERT_GE(v, 0.0f);
      ASSERT_LT(v, 1.0f);
      ++split[size_t(v * nd * spp)];
    }
  }
  for (int c : one) EXPECT_EQ(c, 1);
  for (int c : split) EXPECT_EQ(c, 1);
  EXPECT_LT(in_order, spp / 2);
  EXPECT_LT(pp.lobeAt(0, 0.9999999f), 1.0f);
}

// A pixel holds the light lattices of two counts (groove footprints' 16 per camera sample, camera
// hits' fewer): each count reads its own, the first is what it is without the second, and the
// second's points over the pixel's samples fill its whole lattice, one in every row and column
// of its grid (the Latin property of a lattice whose generator is prime to its size).
TEST(PixelPattern, HoldsTheLightLatticesOfTwoCounts) {
  const int spp = 16, lights = 2;
  const int g16 = latticeGenerator(16 * spp, 16, latticeGenerator(16));
  const int g4 = latticeGenerator(4 * spp, 4, latticeGenerator(4));
  PixelPattern one, two;
  Rng r1(9), r2(9);
  one.reset(spp, latticeGenerator(spp), 3, r1);
  one.resetLights(lights, 16, g16, r1);
  two.reset(spp, latticeGenerator(spp), 3, r2);
  two.resetLights(lights, 16, g16, r2);
  two.resetLights(lights, 4, g4, r2);
  EXPECT_TRUE(two.hasLights(16));
  EXPECT_TRUE(two.hasLights(4));
  EXPECT_FALSE(two.hasLights(8));
  EXPECT_FALSE(one.hasLights(4));
  for (int li = 0; li < lights; ++li)
    for (int s = 0; s < spp; ++s)
      for (int k = 0; k < 16; ++k) {
        EXPECT_EQ(one.light(16, li, k, s, true).x, two.light(16, li, k, s, true).x);
        EXPECT_EQ(one.light(16, li, k, s, true).y, two.light(16, li, k, s, true).y);
      }
  const int n = 4 * spp;
  for (int li = 0; li < lights; ++li) {
    std::vector<int> rows(size_t(n), 0), cols(size_t(n), 0);
    for (int s = 0; s < spp; ++s)
      for (int k = 0; k < 4; ++k) {
        // Both coordinates periodic here would be the lattice itself; x is tent-folded, which
        // maps the n columns two to one, so count x in n / 2 bins and y (periodic) in n.
        const Vec2f u = two.light(4, li, k, s, true);
        ++cols[size_t(u.x * float(n / 2))];
        ++rows[size_t(u.y * float(n))];
      }
    for (int i = 0; i < n / 2; ++i) EXPECT_EQ(cols[size_t(i)], 2) << "light " << li << ", column " << i;
    for (int i = 0; i < n; ++i) EXPECT_EQ(rows[size_t(i)], 1) << "light " << li << ", row " << i;
  }
}

}  // namespace
}  // namespace dg
