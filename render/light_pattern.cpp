#include "render/light_pattern.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <numeric>

namespace dg {

namespace {

// Distance of x to the nearest integer.
double wrap(double x) { return std::fabs(x - std::round(x)); }

double tent(double u) { return 1.0 - std::fabs(2.0 * u - 1.0); }

// In [0, 1) also after rounding to float.
float below1(double u) { return std::min(float(u), 0x1.fffffep-1f); }

// p[0..n) = 0, 1, ..., n - 1 in a random order (Fisher-Yates, one draw per position from the top).
void shuffledRange(int* p, size_t n, Rng& rng) {
  for (size_t i = 0; i < n; ++i) p[i] = int(i);
  for (size_t i = n; i-- > 1;) std::swap(p[i], p[rng.next32() % uint32_t(i + 1)]);
}
void shuffledRange(std::vector<int>& p, size_t n, Rng& rng) {
  p.resize(n);
  shuffledRange(p.data(), n, rng);
}

// latticeGenerator's search (its contract in light_pattern.h).
int searchGenerator(int n, int m, int r) {
  m = std::max(1, m);
  if (n <= 3 && m == 1) return 1;
  int best_g = m == 1 ? 1 : r;
  int64_t best_rho = -1;
  double best_d = -1;
  // The candidates g = r + j m. Past 1024 of them only those near n / golden ratio are tried (the
  // Fibonacci lattices' neighbourhood, where the good 2-D lattices are), so that the search
  // stays O(n).
  const int count = (n - r + m - 1) / m;
  const int centre = int(n * 0.6180339887 - r) / m;
  const int lo = count <= 1024 ? 0 : std::max(0, centre - 32);
  const int hi = count <= 1024 ? count - 1 : std::min(count - 1, centre + 32);
  for (int j = lo; j <= hi; ++j) {
    const int g = r + j * m;
    if (g < 1 || std::gcd(g, n) != 1) continue;  // else the points share rows of the n x n grid
    // Zaremba's index: the smallest max(1, |h1|) max(1, |h2|) over the nonzero integer
    // frequencies (h1, h2), |h| <= n / 2, with h1 + g h2 = 0 (mod n). Those are the Fourier modes
    // the rule cannot tell from a constant; the larger the index, the smaller the error on a
    // smooth periodic integrand (Niederreiter 1992, ch. 5). h2 = 0 gives h1 = n.
    int64_t rho = n;
    for (int h2 = 1; h2 <= n / 2; ++h2) {
      int64_t h1 = (int64_t(n) - (int64_t(g) * h2) % n) % n;
      if (h1 > n / 2) h1 -= n;
      rho = std::min<int64_t>(rho, std::max<int64_t>(1, std::llabs(h1)) * h2);
    }
    // Ties: the largest smallest distance between two points on the unit torus (the lattice is a
    // group, so it is the smallest distance of a point k >= 1 from point 0).
    double dmin = 1e9;
    for (int k = 1; k < n; ++k) {
      const double dx = wrap(double(k) / n), dy = wrap(double((int64_t(k) * g) % n) / n);
      dmin = std::min(dmin, dx * dx + dy * dy);
    }
    if (rho > best_rho || (rho == best_rho && dmin > best_d + 1e-15)) {
      best_rho = rho;
      best_d = dmin;
      best_g = g;
    }
  }
  return best_g;
}

}  // namespace

int latticeGenerator(int n, int m, int r) {
  // Small unconstrained counts (every count of light samples and split directions the settings
  // give) come from a table built once per process (0.5 ms): the search is O(n^2), and found
  // anew at every camera hit for the 8 light samples per light of groove shading at 16 spp it
  // took 4% of configs/scratch_rust.yaml's time.
  constexpr int kTable = 65;
  static const std::array<int, kTable> table = [] {
    std::array<int, kTable> t{};
    for (int k = 1; k < kTable; ++k) t[size_t(k)] = searchGenerator(k, 1, 0);
    return t;
  }();
  if (m <= 1 && r == 0 && n > 0 && n < kTable) return table[size_t(n)];
  return searchGenerator(n, m, r);
}

LightPattern::LightPattern(int n, int g, Rng& rng)
    : n_(std::max(1, n)), g_(g), sx_(rng.uniformD()), sy_(rng.uniformD()) {}

Vec2f LightPattern::at(int k, bool periodic_y) const {
  const double x = double(k) / n_ + sx_;
  const double y = double((int64_t(k) * g_) % n_) / n_ + sy_;
  const double ux = x - std::floor(x), uy = y - std::floor(y);
  return {below1(tent(ux)), below1(periodic_y ? uy : tent(uy))};
}

void PixelPattern::reset(int spp, int g, int dims, Rng& rng) {
  n_ = std::max(1, spp);
  sets_[0].nl = sets_[1].nl = 0;
  nd_ = 0;
  dims_.clear();
  perm_.resize(size_t(dims) * size_t(n_));
  for (int d = 0; d < dims; ++d) {
    dims_.emplace_back(n_, g, rng);
    shuffledRange(perm_.data() + size_t(d) * size_t(n_), size_t(n_), rng);
  }
  shuffledRange(lobe1_, size_t(n_), rng);
}

Vec2f PixelPattern::at(int d, int s, bool periodic_y) const {
  return dims_[size_t(d)].at(perm_[size_t(d) * size_t(n_) + size_t(s)], periodic_y);
}

void PixelPattern::resetLights(int lights, int nl, int g, Rng& rng) {
  LightSet& set = sets_[sets_[0].nl == 0 || sets_[0].nl == nl ? 0 : 1];
  set.nl = nl;
  set.lights.clear();
  for (int i = 0; i < lights; ++i) set.lights.emplace_back(nl * n_, g, rng);
}

void PixelPattern::resetDirections(int nd, int g, Rng& rng) {
  nd_ = nd;
  dirs_.clear();
  dirs_.emplace_back(nd * n_, g, rng);
  shuffledRange(lobes_, size_t(nd * n_), rng);
}

}  // namespace dg
