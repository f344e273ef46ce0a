// Where the n light samples that a shading point takes on one light fall in the light's 2-D
// sample domain [0, 1)^2: a randomly shifted rank-1 lattice (a Korobov lattice), folded by the
// tent map in the coordinates that are not periodic.
//
// Point k of n is frac((k / n, k g / n) + s) for a generator g chosen per n and one uniform shift
// s per shading point and light (Cranley & Patterson 1976). Each point alone is uniform, so every
// sample, and every subset of them, is an unbiased light sample, as before. Together they spread
// evenly in both coordinates for any n: the q x q jittered grid they replace did that only for
// square n (8 samples fell into 8 strata along one axis, which on the accuracy test's ring light
// left the noise of random angles: 2.5 times the error of 16). For a smooth integrand a shifted
// lattice's error falls faster than a jittered grid's, and the tent map u -> 1 - |2u - 1| (it
// keeps the uniform distribution) makes a non-periodic coordinate look periodic to the lattice,
// which is what that needs (Hickernell 2002, "Obtaining O(N^-2+e) convergence for lattice
// quadrature rules"; Dick, Nuyens & Pillichshammer 2014). Where a shadow edge crosses the light
// the integrand is not smooth, and the lattice does about as well as the grid.
#pragma once
#include <algorithm>
#include <vector>

#include "core/math.h"
#include "core/rng.h"

namespace dg {

// The generator g in [1, n), prime to n, of the best lattice {(k / n, frac(k g / n))}: the
// largest Zaremba index, then the largest smallest distance between two points on the unit torus
// (the first such g); 1 for n <= 3. Prime to n, every row and every column of the n x n grid
// holds one point (a Latin square), so a light that varies along one coordinate only is sampled
// in n strata. O(n^2) up to 1024 points (up to 64 without m and r, from a table built once); past
// that only generators near n / 1.618 are tried.
// With m > 1, only generators g = r (mod m) are considered: the lattice of n = m p points then
// splits into p sub-lattices {k p + s : k < m} (s < p), each the m-point lattice of generator r,
// so with r = latticeGenerator(m) every part is a good lattice too (PixelPattern::light).
int latticeGenerator(int n, int m = 1, int r = 0);

class LightPattern {
 public:
  // n points for generator g (latticeGenerator(n)); the shift takes two numbers from rng.
  LightPattern(int n, int g, Rng& rng);
  // Point k (0 <= k < n), with u.y left periodic when `periodic_y` (an angle); the tent map folds
  // u.x always and u.y otherwise. Both in [0, 1).
  Vec2f at(int k, bool periodic_y) const;
  int size() const { return n_; }

 private:
  int n_, g_;
  double sx_, sy_;
};

// The first bounce's sample dimensions of one pixel's spp camera samples, spread over those
// samples: dimension d (a light, the BSDF direction, the position in the pixel) of camera sample s
// is point pi_d(s) of its own shifted lattice of spp points, pi_d a random permutation per
// dimension and pixel that keeps the dimensions from moving in step ("padding", Kollig & Keller
// 2002, "Efficient multidimensional sampling"). Each point alone is uniform, so every camera sample
// stays an unbiased estimate; together the pixel's samples cover each light and the BSDF's
// directions evenly. The permutations were affine, (a_d s + b_d) mod spp, until 2026-11-28: two
// dimensions paired so are again a 2-D lattice, for some pixels one with all its points on a few
// lines, and a pixel whose value follows a sum of two dimensions (a shadow edge that moves with
// the position in the pixel and on the light) then took 0, 1/2 or 1 of its samples wherever the
// edge lay (PixelPattern.TwoDimensionsTogetherFollowTheAreaBelowALine).
class PixelPattern {
 public:
  // spp points (generator g = latticeGenerator(spp)) in `dims` dimensions; draws from rng.
  void reset(int spp, int g, int dims, Rng& rng);
  Vec2f at(int d, int s, bool periodic_y) const;
  // A number in [0, 1) for camera sample s's lobe choice: the pixel's spp samples take Latin
  // strata (a random permutation), `jitter` placing sample s in its stratum.
  float lobeAt(int s, float jitter) const { return stratum(lobe1_, size_t(s), jitter); }
  // Where every camera sample takes nl samples per light (groove shading's camera hits and
  // footprints): one lattice of nl * spp points per light for the pixel, generator g =
  // latticeGenerator(nl * spp, nl, latticeGenerator(nl)); camera sample s takes its points
  // k spp + s, k < nl, themselves an nl-point lattice of the usual generator. Call after reset(),
  // once per count: a pixel holds the lattices of at most two counts (a footprint's and, where it
  // takes fewer, a camera hit's; Tracer::cameraHitLights).
  void resetLights(int lights, int nl, int g, Rng& rng);
  // Whether the pixel has lattices of nl points per camera sample.
  bool hasLights(int nl) const { return nl > 0 && (sets_[0].nl == nl || sets_[1].nl == nl); }
  Vec2f light(int nl, int li, int k, int s, bool periodic_y) const {
    const LightSet& set = sets_[0].nl == nl ? sets_[0] : sets_[1];
    return set.lights[size_t(li)].at(k * n_ + s, periodic_y);
  }
  // Where every camera sample splits into nd BSDF directions (groove shading's camera hits off
  // the grooves), the same for their 2-D direction samples: one lattice of nd * spp points,
  // generator g = latticeGenerator(nd * spp, nd, latticeGenerator(nd)); camera sample s takes
  // points j spp + s, j < nd (both coordinates tent-folded). Without it the pixel's samples drew
  // their directions independently, and off the grooves the noise rose with spp where the split
  // count fell as spp rose (camera_hit_bsdf_per_pixel). Call after reset().
  void resetDirections(int nd, int g, Rng& rng);
  int directionCount() const { return nd_; }  // nd, or 0 without resetDirections
  Vec2f direction(int j, int s) const { return dirs_.front().at(j * n_ + s, false); }
  // And their lobe choice: the nd * spp directions' numbers in [0, 1) are Latin strata over the
  // pixel (a random permutation), `jitter` placing direction j of camera sample s in its stratum.
  float lobe(int j, int s, float jitter) const { return stratum(lobes_, size_t(j * n_ + s), jitter); }

 private:
  // Point i of Latin strata p (a permutation of the strata): its stratum, `jitter` within it.
  static float stratum(const std::vector<int>& p, size_t i, float jitter) {
    return std::min((float(p[i]) + jitter) / float(p.size()), kOneMinusEps);
  }
  struct LightSet {
    int nl = 0;  // light samples per camera sample; 0: unused
    std::vector<LightPattern> lights;
  };
  int n_ = 1, nd_ = 0;
  std::vector<LightPattern> dims_;  // one lattice per dimension
  std::vector<int> perm_;           // dimension d's order: perm_[d * n_ + s] for camera sample s
  LightSet sets_[2];
  std::vector<LightPattern> dirs_;  // one pattern after resetDirections
  std::vector<int> lobes_;          // the lobe strata of the pixel's directions
  std::vector<int> lobe1_;          // the lobe strata of the pixel's samples
};

}  // namespace dg
