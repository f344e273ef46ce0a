// Tests of the image comparison: colorimetry (CIEDE2000 against Sharma, Wu and Dalal 2005), the
// S-CIELAB and YCxCz/Lab filters, the Delta E maps, registration, statistics, outputs and errors.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <unistd.h>

#include <OpenImageIO/imageio.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "labels/colorimetry.h"
#include "labels/compare.h"
#include "labels/registration.h"
#include "labels/scielab.h"

namespace fs = std::filesystem;
using namespace dg;
using color::Vec3;

namespace {

const std::string kShared = DG_SHARED_DIR;
const std::string kHats = kShared + "/data/scielab/hats_decoded.png";
const std::string kHatsC = kShared + "/data/scielab/hatsC_decoded.png";
const std::string kPhoto = kShared + "/data/photos/polyhaven/rusty_metal_02_diff_1k.jpg";

// Tests on the shared photographs: skipped with a visible reason when CMake found no shared data.
#define DG_NEED_SHARED()                                                                       \
  do {                                                                                         \
    if (kShared.empty()) GTEST_SKIP() << "shared data not found (configure with -DDG_SHARED_DIR)"; \
  } while (0)

cv::Mat readRgb(const std::string& path) {
  cv::Mat bgr = cv::imread(path, cv::IMREAD_COLOR);
  EXPECT_FALSE(bgr.empty()) << path;
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  return rgb;
}

double maxAbs(const cv::Mat& a, const cv::Mat& b) { return cv::norm(a, b, cv::NORM_INF); }

// A scratch folder removed at the end of the test.
struct TempDir {
  fs::path path;
  explicit TempDir(const std::string& name) {
    path = fs::temp_directory_path() / ("dg_compare_" + name + "_" + std::to_string(::getpid()));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

// Restores OpenCV's thread count.
struct ThreadCount {
  int saved = cv::getNumThreads();
  ~ThreadCount() { cv::setNumThreads(saved); }
};

}  // namespace

// ----------------------------------------------------------------------------------------------
// Colorimetry.

TEST(Colorimetry, Ciede2000MatchesSharmaWuDalal2005) {
  // Sharma, Wu, Dalal, "The CIEDE2000 color-difference formula: implementation notes, supplementary
  // test data, and mathematical observations", Color Res. Appl. 30(1), 2005, Table 1: all 34 pairs.
  struct Row {
    double L1, a1, b1, L2, a2, b2, dE;
  };
  const Row rows[34] = {
      {50.0000, 2.6772, -79.7751, 50.0000, 0.0000, -82.7485, 2.0425},
      {50.0000, 3.1571, -77.2803, 50.0000, 0.0000, -82.7485, 2.8615},
      {50.0000, 2.8361, -74.0200, 50.0000, 0.0000, -82.7485, 3.4412},
      {50.0000, -1.3802, -84.2814, 50.0000, 0.0000, -82.7485, 1.0000},
      {50.0000, -1.1848, -84.8006, 50.0000, 0.0000, -82.7485, 1.0000},
      {50.0000, -0.9009, -85.5211, 50.0000, 0.0000, -82.7485, 1.0000},
      {50.0000, 0.0000, 0.0000, 50.0000, -1.0000, 2.0000, 2.3669},
      {50.0000, -1.0000, 2.0000, 50.0000, 0.0000, 0.0000, 2.3669},
      {50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0009, 7.1792},
      {50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0010, 7.1792},
      {50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0011, 7.2195},
      {50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0012, 7.2195},
      {50.0000, -0.0010, 2.4900, 50.0000, 0.0009, -2.4900, 4.8045},
      {50.0000, -0.0010, 2.4900, 50.0000, 0.0010, -2.4900, 4.8045},
      {50.0000, -0.0010, 2.4900, 50.0000, 0.0011, -2.4900, 4.7461},
      {50.0000, 2.5000, 0.0000, 50.0000, 0.0000, -2.5000, 4.3065},
      {50.0000, 2.5000, 0.0000, 73.0000, 25.0000, -18.0000, 27.1492},
      {50.0000, 2.5000, 0.0000, 61.0000, -5.0000, 29.0000, 22.8977},
      {50.0000, 2.5000, 0.0000, 56.0000, -27.0000, -3.0000, 31.9030},
      {50.0000, 2.5000, 0.0000, 58.0000, 24.0000, 15.0000, 19.4535},
      {50.0000, 2.5000, 0.0000, 50.0000, 3.1736, 0.5854, 1.0000},
      {50.0000, 2.5000, 0.0000, 50.0000, 3.2972, 0.0000, 1.0000},
      {50.0000, 2.5000, 0.0000, 50.0000, 1.8634, 0.5757, 1.0000},
      {50.0000, 2.5000, 0.0000, 50.0000, 3.2592, 0.3350, 1.0000},
      {60.2574, -34.0099, 36.2677, 60.4626, -34.1751, 39.4387, 1.2644},
      {63.0109, -31.0961, -5.8663, 62.8187, -29.7946, -4.0864, 1.2630},
      {61.2901, 3.7196, -5.3901, 61.4292, 2.2480, -4.9620, 1.8731},
      {35.0831, -44.1164, 3.7933, 35.0232, -40.0716, 1.5901, 1.8645},
      {22.7233, 20.0904, -46.6940, 23.0331, 14.9730, -42.5619, 2.0373},
      {36.4612, 47.8580, 18.3852, 36.2715, 50.5065, 21.2231, 1.4146},
      {90.8027, -2.0831, 1.4410, 91.1528, -1.6435, 0.0447, 1.4441},
      {90.9257, -0.5406, -0.9208, 88.6381, -0.8985, -0.7239, 1.5381},
      {6.7747, -0.2908, -2.4247, 5.8714, -0.0985, -2.2286, 0.6377},
      {2.0776, 0.0795, -1.1350, 0.9033, -0.0636, -0.5514, 0.9082},
  };
  for (int i = 0; i < 34; ++i) {
    const Row& r = rows[i];
    Vec3 a(r.L1, r.a1, r.b1), b(r.L2, r.a2, r.b2);
    EXPECT_NEAR(color::deltaE2000(a, b), r.dE, 5e-5) << "pair " << i + 1;
    EXPECT_NEAR(color::deltaE2000(b, a), r.dE, 5e-5) << "pair " << i + 1 << " swapped";
  }
}

TEST(Colorimetry, Cie76And94ByDefinition) {
  Vec3 a(50, 20, -10), b(55, 23, -6);
  EXPECT_NEAR(color::deltaE76(a, b), std::sqrt(25.0 + 9 + 16), 1e-12);
  // Pure lightness difference: S_L = 1.
  EXPECT_NEAR(color::deltaE94(Vec3(40, 30, 40), Vec3(43, 30, 40)), 3.0, 1e-12);
  // Pure chroma difference along the hue line of the reference (C1 = 50): dC / (1 + 0.045 C1).
  EXPECT_NEAR(color::deltaE94(Vec3(60, 30, 40), Vec3(60, 36, 48)), 10.0 / (1 + 0.045 * 50), 1e-12);
  // Pure hue difference at equal chroma (C = 50, 90 degrees apart): dH / (1 + 0.015 C1).
  double dH = 2 * 50 * std::sin(M_PI / 4);
  EXPECT_NEAR(color::deltaE94(Vec3(60, 50, 0), Vec3(60, 0, 50)), dH / (1 + 0.015 * 50), 1e-9);
}

TEST(Colorimetry, SrgbCurveXyzAndLab) {
  // IEC 61966-2-1 break points and round trip.
  EXPECT_NEAR(color::srgbDecode(0.04045), 0.04045 / 12.92, 1e-15);
  EXPECT_NEAR(color::srgbDecode(0.5), std::pow((0.5 + 0.055) / 1.055, 2.4), 1e-15);
  for (double v = 0; v <= 1.0; v += 0.01) EXPECT_NEAR(color::srgbEncode(color::srgbDecode(v)), v, 1e-12);
  // White: Y = 100, Lab (100, 0, 0) against its own white.
  Vec3 w = color::srgbWhiteXyz();
  EXPECT_NEAR(w[1], 100.0, 1e-12);
  EXPECT_NEAR(w[0], 95.05, 1e-9);
  EXPECT_NEAR(w[2], 108.90, 1e-9);
  Vec3 lw = color::xyzToLab(w, w);
  EXPECT_NEAR(lw[0], 100, 1e-12);
  EXPECT_NEAR(lw[1], 0, 1e-12);
  EXPECT_NEAR(lw[2], 0, 1e-12);
  // sRGB primary red: tabulated CIELAB (D65) about (53.24, 80.09, 67.20).
  Vec3 red = color::xyzToLab(color::linearSrgbToXyz() * Vec3(1, 0, 0), w);
  EXPECT_NEAR(red[0], 53.24, 0.02);
  EXPECT_NEAR(red[1], 80.09, 0.05);
  EXPECT_NEAR(red[2], 67.20, 0.05);
  // Lab <-> XYZ round trip on both branches of f.
  for (Vec3 xyz : {Vec3(20, 30, 40), Vec3(0.2, 0.5, 0.1), Vec3(90, 95, 100)}) {
    Vec3 back = color::labToXyz(color::xyzToLab(xyz, w), w);
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(back[i], xyz[i], 1e-10);
  }
  // The fast cube root.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-12, 3);
  for (int i = 0; i < 10000; ++i) {
    double t = std::pow(10.0, u(rng));
    EXPECT_NEAR(color::fastCbrt(t), std::cbrt(t), 1e-14 * std::cbrt(t));
  }
  EXPECT_EQ(color::fastCbrt(0.0), 0.0);
  EXPECT_NEAR(color::fastCbrt(-8.0), -2.0, 1e-14);
}

TEST(Colorimetry, OpponentAndYcxczSpaces) {
  for (auto obs : {color::Observer::Deg2, color::Observer::Deg10}) {
    cv::Matx33d id = color::opponentToXyz(obs) * color::xyzToOpponent(obs);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(id(r, c), r == c ? 1.0 : 0.0, 1e-12);
  }
  // Zhang and Wandell's published first entries.
  EXPECT_DOUBLE_EQ(color::xyzToOpponent(color::Observer::Deg2)(0, 0), 0.2787336);
  EXPECT_DOUBLE_EQ(color::xyzToOpponent(color::Observer::Deg10)(2, 2), 0.4814746);
  // YCxCz of the white is (100, 0, 0); the round trip is exact.
  Vec3 w = color::srgbWhiteXyz();
  Vec3 y = color::xyzToYcxcz(w, w);
  EXPECT_NEAR(y[0], 100, 1e-12);
  EXPECT_NEAR(y[1], 0, 1e-12);
  EXPECT_NEAR(y[2], 0, 1e-12);
  Vec3 x(30, 40, 50), back = color::ycxczToXyz(color::xyzToYcxcz(x, w), w);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(back[i], x[i], 1e-12);
  // Definition: Cx = 500 (X/Xn - Y/Yn), Cz = 200 (Y/Yn - Z/Zn).
  Vec3 c = color::xyzToYcxcz(x, w);
  EXPECT_NEAR(c[0], 116 * 0.4 - 16, 1e-12);
  EXPECT_NEAR(c[1], 500 * (30 / w[0] - 0.4), 1e-12);
  EXPECT_NEAR(c[2], 200 * (0.4 - 50 / w[2]), 1e-12);
}

// ----------------------------------------------------------------------------------------------
// S-CIELAB filters.

namespace {

// Position where a sampled Gaussian falls to half its centre value: exact for a Gaussian, because
// ln(tap_k / tap_0) = -k^2 / sigma^2 is linear in k^2.
double halfMaxFromTaps(const ScielabGaussian& g) {
  const int r = g.radius;
  const double t0 = g.taps[r];
  for (int k = 1; k <= r; ++k) {
    double lo = std::log(g.taps[r + k - 1] / t0), hi = std::log(g.taps[r + k] / t0);
    if (hi <= std::log(0.5)) {
      double k2 = (k - 1.0) * (k - 1.0) + (std::log(0.5) - lo) / (hi - lo) * (2.0 * k - 1.0);
      return std::sqrt(k2);
    }
  }
  return -1;  // beyond the support
}

}  // namespace

TEST(ScielabFilters, SupportKernelSumsAndHalfMaxima) {
  for (double spd : {23.0, 22.62, 60.0, 101.3}) {
    for (auto conv : {ScielabFilters::Paper, ScielabFilters::Isetcam}) {
      ScielabFilterBank b = makeScielabFilters(spd, conv);
      EXPECT_EQ(b.support, int(std::ceil(spd / 2)) * 2 - 1);
      for (int c = 0; c < 3; ++c) {
        const auto& f = b.channel[c];
        EXPECT_NEAR(cv::sum(scielabKernel2D(f))[0], 1.0, 1e-12) << "spd " << spd << " channel " << c;
        double wsum = 0;
        for (const auto& g : f.terms) {
          wsum += g.weight;
          double s = 0;
          for (double t : g.taps) s += t;
          EXPECT_NEAR(s, 1.0, 1e-12);
          const double expected = conv == ScielabFilters::Paper ? g.spreadDeg * spd * std::sqrt(std::log(2.0))
                                                                : g.spreadDeg * spd;
          EXPECT_NEAR(g.halfMaxSamples, expected, 1e-12);
          EXPECT_NEAR(g.profile(g.halfMaxSamples), 0.5, 1e-12);
          double measured = halfMaxFromTaps(g);
          if (expected < g.radius) {
            EXPECT_NEAR(measured, expected, 1e-6) << "spd " << spd << " channel " << c << " spread " << g.spreadDeg;
          }
        }
        EXPECT_NEAR(wsum, 1.0, 1e-12);
      }
    }
  }
  // Numbers by hand at 60 samples/degree. Paper, O1 narrowest: s = 0.0283 deg = 1.698 samples,
  // half maximum at 1.698 sqrt(ln 2) = 1.4137 samples. ISETCam: half width 0.05 deg = 3 samples.
  ScielabFilterBank p = makeScielabFilters(60, ScielabFilters::Paper);
  ScielabFilterBank i = makeScielabFilters(60, ScielabFilters::Isetcam);
  EXPECT_NEAR(halfMaxFromTaps(p.channel[0].terms[0]), 1.41370, 1e-4);
  EXPECT_NEAR(halfMaxFromTaps(i.channel[0].terms[0]), 3.0, 1e-9);
  EXPECT_NEAR(halfMaxFromTaps(i.channel[1].terms[0]), 0.0685 * 60, 1e-9);
  // Paper weights renormalised: 0.921 / (0.921 + 0.105 - 0.108).
  EXPECT_NEAR(p.channel[0].terms[0].weight, 0.921 / 0.918, 1e-12);
  EXPECT_NEAR(p.channel[0].terms[2].weight, -0.108 / 0.918, 1e-12);
  EXPECT_THROW(makeScielabFilters(0, ScielabFilters::Paper), InputError);
}

TEST(ScielabFilters, TwoDimensionalFilteringEqualsSeparable) {
  // 1000 columns: the separable filter works in column tiles of about 900 pixels, so this also
  // checks that the tiles join without a seam.
  cv::Mat plane(97, 1000, CV_32F);
  cv::RNG rng(3);
  rng.fill(plane, cv::RNG::UNIFORM, -50, 50);
  for (auto conv : {ScielabFilters::Paper, ScielabFilters::Isetcam}) {
    ScielabFilterBank b = makeScielabFilters(30, conv);
    for (int c = 0; c < 3; ++c) {
      cv::Mat sep, full, plane64, full64;
      applyScielabChannel(plane, b.channel[c], sep);
      plane.convertTo(plane64, CV_64F);
      cv::filter2D(plane64, full64, CV_64F, scielabKernel2D(b.channel[c]), cv::Point(-1, -1), 0, cv::BORDER_REFLECT);
      full64.convertTo(full, CV_32F);
      EXPECT_LT(maxAbs(sep, full), 5e-5) << "channel " << c;
      // And the filter really does something.
      EXPECT_GT(maxAbs(sep, plane), 1.0);
    }
  }
}

// ----------------------------------------------------------------------------------------------
// YCxCz/Lab filters.

TEST(YcxczFilters, UnitDcGainMonotoneFallOffAndConstants) {
  EXPECT_NEAR(YcxczModel::luminanceAlpha(), 1.0 / (0.525 * std::log(11.0) + 3.91), 1e-15);
  EXPECT_NEAR(YcxczModel::luminanceAlpha(), 0.19346, 1e-5);
  EXPECT_EQ(ycxczLuminanceResponse(0, 0), 1.0);
  EXPECT_EQ(ycxczChrominanceResponse(0, 0), 1.0);
  for (double angle : {0.0, 10.0, 30.0, 45.0, 80.0}) {
    double prevL = 1, prevC = 1;
    for (double rho = 0.25; rho <= 60; rho += 0.25) {
      double fx = rho * std::cos(angle * M_PI / 180), fy = rho * std::sin(angle * M_PI / 180);
      double l = ycxczLuminanceResponse(fx, fy), c = ycxczChrominanceResponse(fx, fy);
      EXPECT_LT(l, prevL);
      EXPECT_LT(c, prevC);
      EXPECT_GT(l, 0);
      prevL = l, prevC = c;
    }
  }
  // Along the axes s(phi) = 1: exp(-alpha rho). On the diagonal s = w = 0.7: exp(-alpha rho / 0.7).
  const double a = YcxczModel::luminanceAlpha();
  EXPECT_NEAR(ycxczLuminanceResponse(10, 0), std::exp(-a * 10), 1e-12);
  EXPECT_NEAR(ycxczLuminanceResponse(0, 10), std::exp(-a * 10), 1e-12);
  EXPECT_NEAR(ycxczLuminanceResponse(10 / std::sqrt(2.0), 10 / std::sqrt(2.0)), std::exp(-a * 10 / 0.7), 1e-12);
  EXPECT_NEAR(ycxczChrominanceResponse(3, 4), std::exp(-0.419 * 5), 1e-12);
}

TEST(YcxczFilters, DctFilteringScalesEachCosineByTheResponse) {
  // A DCT-II basis image is an eigenvector of the filter: it comes back scaled by H(f).
  const int W = 64, H = 48;
  const double spd = 40;
  for (auto [kx, ky] : {std::pair<int, int>{5, 0}, {0, 7}, {9, 4}}) {
    cv::Mat plane(H, W, CV_32F);
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x)
        plane.at<float>(y, x) = float(10 * std::cos(M_PI * kx * (x + 0.5) / W) * std::cos(M_PI * ky * (y + 0.5) / H));
    cv::Mat out;
    applyFrequencyResponse(plane, spd, ycxczLuminanceResponse, out);
    double g = ycxczLuminanceResponse(kx * spd / (2.0 * W), ky * spd / (2.0 * H));
    EXPECT_LT(maxAbs(out, plane * g), 2e-5) << kx << "," << ky << " gain " << g;
    EXPECT_LT(g, 0.95);
  }
  // Odd sizes work too (padded by one reflected row/column) and keep a constant plane.
  cv::Mat flat(33, 21, CV_32F, cv::Scalar(4.25f)), out;
  applyFrequencyResponse(flat, 30, ycxczChrominanceResponse, out);
  EXPECT_EQ(out.size(), flat.size());
  EXPECT_LT(maxAbs(out, flat), 1e-5);
}

// ----------------------------------------------------------------------------------------------
// Delta E maps.

TEST(DeltaEMap, IdenticalImagesGiveZero) {
  DG_NEED_SHARED();
  cv::Mat hats = readRgb(kHats);
  for (auto m : {SpatialMetric::Cielab, SpatialMetric::Scielab, SpatialMetric::Ycxcz})
    for (auto d : {color::DeltaE::CIE76, color::DeltaE::CIE94, color::DeltaE::CIEDE2000}) {
      MetricOptions o;
      o.metric = m;
      o.deltaE = d;
      o.samplesPerDegree = 40;
      cv::Mat dE = deltaEMap(hats, hats.clone(), o);
      EXPECT_EQ(cv::countNonZero(dE), 0) << metricName(m) << " " << deltaEName(d);
    }
}

TEST(DeltaEMap, UniformImagesGivePlainCielab) {
  const cv::Vec3b colours[][2] = {{{120, 64, 200}, {118, 70, 190}},
                                  {{30, 30, 30}, {34, 29, 27}},
                                  {{250, 240, 10}, {245, 244, 30}},
                                  {{5, 2, 0}, {9, 0, 3}}};
  for (const auto& c : colours) {
    cv::Mat a(45, 67, CV_8UC3, cv::Scalar(c[0][0], c[0][1], c[0][2]));
    cv::Mat b(45, 67, CV_8UC3, cv::Scalar(c[1][0], c[1][1], c[1][2]));
    // The colorimetry functions in double.
    auto lab = [](cv::Vec3b v) {
      Vec3 rgb(color::srgbDecode(v[0] / 255.0), color::srgbDecode(v[1] / 255.0), color::srgbDecode(v[2] / 255.0));
      return color::xyzToLab(color::linearSrgbToXyz() * rgb, color::srgbWhiteXyz());
    };
    for (auto d : {color::DeltaE::CIE76, color::DeltaE::CIE94, color::DeltaE::CIEDE2000}) {
      const double expected = color::deltaE(d, lab(c[0]), lab(c[1]));
      for (auto m : {SpatialMetric::Cielab, SpatialMetric::Scielab, SpatialMetric::Ycxcz})
        for (auto f : {ScielabFilters::Paper, ScielabFilters::Isetcam}) {
          MetricOptions o;
          o.metric = m;
          o.deltaE = d;
          o.filters = f;
          o.samplesPerDegree = 60;
          cv::Mat dE = deltaEMap(a, b, o);
          double lo, hi;
          cv::minMaxLoc(dE, &lo, &hi);
          EXPECT_NEAR(lo, expected, 1e-6 + 1e-7 * expected) << metricName(m) << " dE" << deltaEName(d);
          EXPECT_NEAR(hi, expected, 1e-6 + 1e-7 * expected) << metricName(m) << " dE" << deltaEName(d);
        }
    }
  }
}

TEST(DeltaEMap, SpatialMetricsForgiveFineDetailOnTheHatsPair) {
  DG_NEED_SHARED();
  cv::Mat a = readRgb(kHats), b = readRgb(kHatsC);
  MetricOptions o;
  o.samplesPerDegree = 60;
  o.metric = SpatialMetric::Cielab;
  const double plain = cv::mean(deltaEMap(a, b, o))[0];
  o.metric = SpatialMetric::Scielab;
  const double sc = cv::mean(deltaEMap(a, b, o))[0];
  o.filters = ScielabFilters::Isetcam;
  const double sci = cv::mean(deltaEMap(a, b, o))[0];
  o.metric = SpatialMetric::Ycxcz;
  const double yc = cv::mean(deltaEMap(a, b, o))[0];
  // JPEG errors are high-frequency: blurring both images first lowers the mean difference, more so
  // with the wider ISETCam filters. (Plain CIELAB mean on this pair: 4.31.)
  EXPECT_NEAR(plain, 4.313, 0.01);
  EXPECT_LT(sc, plain);
  EXPECT_LT(sci, sc);
  EXPECT_LT(yc, plain);
  // A different image gives a much larger difference than its JPEG copy.
  cv::Mat flipped;
  cv::flip(a, flipped, 1);
  o.metric = SpatialMetric::Scielab;
  o.filters = ScielabFilters::Paper;
  EXPECT_GT(cv::mean(deltaEMap(a, flipped, o))[0], 3 * sc);
}

TEST(DeltaEMap, ResultsDoNotDependOnTheThreadCount) {
  DG_NEED_SHARED();
  ThreadCount restore;
  cv::Mat a = readRgb(kPhoto), b;
  cv::resize(a, a, cv::Size(1850, 420), 0, 0, cv::INTER_AREA);  // 2 row bands, 3 column tiles
  cv::GaussianBlur(a, b, cv::Size(0, 0), 1.2);
  b.at<cv::Vec3b>(300, 900) = cv::Vec3b(255, 0, 255);
  for (auto m : {SpatialMetric::Cielab, SpatialMetric::Scielab, SpatialMetric::Ycxcz}) {
    MetricOptions o;
    o.metric = m;
    o.samplesPerDegree = 60;
    cv::setNumThreads(1);
    cv::Mat one = deltaEMap(a, b, o);
    cv::setNumThreads(2);
    cv::Mat two = deltaEMap(a, b, o);
    EXPECT_EQ(maxAbs(one, two), 0.0) << metricName(m);
    EXPECT_GT(cv::mean(one)[0], 0.1);
  }
  // Registration as well.
  cv::Mat small;
  cv::resize(a, small, cv::Size(320, 300), 0, 0, cv::INTER_AREA);
  cv::Matx33d H(1.02, 0.03, 4, -0.02, 0.99, -3, 1e-5, 0, 1);
  cv::Mat test;
  cv::warpPerspective(small, test, cv::Mat(H), cv::Size(280, 260), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                      cv::BORDER_REFLECT);
  RegistrationOptions ro;
  ro.mode = RegistrationMode::Auto;
  cv::setNumThreads(1);
  RegistrationResult r1 = registerImages(small, test, ro);
  cv::setNumThreads(2);
  RegistrationResult r2 = registerImages(small, test, ro);
  for (int i = 0; i < 9; ++i) EXPECT_EQ(r1.homography.val[i], r2.homography.val[i]);
  EXPECT_EQ(maxAbs(r1.warpedTest, r2.warpedTest), 0.0);
}

// ----------------------------------------------------------------------------------------------
// Registration.

TEST(Registration, RecoversAKnownHomographyOnAPhotograph) {
  DG_NEED_SHARED();
  // A real photograph (Poly Haven, CC0) as reference; the test image is a view of it through a
  // known homography (rotation 4 deg, scale 1.05, shift, mild perspective).
  cv::Mat ref = readRgb(kPhoto);
  ASSERT_EQ(ref.cols, 1024);
  const double a = 4 * M_PI / 180, s = 1.05;
  cv::Matx33d Htrue(s * std::cos(a), -s * std::sin(a), 150, s * std::sin(a), s * std::cos(a), 80, 2e-5, -1e-5, 1);
  cv::Size ts(720, 700);
  cv::Mat test;  // test(x) = ref(Htrue x): Htrue maps test pixels to reference pixels
  cv::warpPerspective(ref, test, cv::Mat(Htrue), ts, cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_REFLECT);
  RegistrationOptions o;
  o.mode = RegistrationMode::Auto;
  RegistrationResult r = registerImages(ref, test, o);
  const double err = meanCornerError(r.homography, Htrue, ts);
  EXPECT_LT(err, 0.5);
  EXPECT_GT(r.inliers, 50);
  EXPECT_LT(r.residualPx, 1.5);
  EXPECT_TRUE(r.eccAccepted) << r.eccNote;
  EXPECT_GT(r.eccCorrelation, 0.95);
  // The valid region is where the test image lands: the quadrilateral Htrue makes of the test's
  // pixel-centre rectangle.
  std::vector<cv::Point2f> quad;
  for (cv::Point2d c : {cv::Point2d(0, 0), cv::Point2d(ts.width - 1, 0), cv::Point2d(ts.width - 1, ts.height - 1),
                        cv::Point2d(0, ts.height - 1)}) {
    cv::Vec3d q = Htrue * cv::Vec3d(c.x, c.y, 1);
    quad.push_back(cv::Point2f(float(q[0] / q[2]), float(q[1] / q[2])));
  }
  EXPECT_NEAR(cv::countNonZero(r.valid), cv::contourArea(quad), 0.003 * cv::contourArea(quad));
  // Inside it, the registered test reproduces the reference (bilinear twice: small differences).
  MetricOptions m;
  m.metric = SpatialMetric::Cielab;
  cv::Mat dE = deltaEMap(ref, r.warpedTest, m);
  cv::Mat inner;
  cv::erode(r.valid, inner, cv::Mat(), cv::Point(-1, -1), 3);
  EXPECT_LT(cv::mean(dE, inner)[0], 2.0);
}

TEST(Registration, PointPairsGiveTheExactHomography) {
  TempDir tmp("points");
  cv::Matx33d H(0.98, 0.05, 12.5, -0.04, 1.01, -7.25, 2e-5, -3e-5, 1);
  const fs::path file = tmp.path / "pairs.txt";
  {
    std::ofstream f(file);
    f << "# x_ref y_ref x_test y_test\n\n";
    for (cv::Point2d p : {cv::Point2d(10, 12), cv::Point2d(300, 20), cv::Point2d(280, 190), cv::Point2d(15, 200),
                          cv::Point2d(150, 100)}) {
      cv::Vec3d q = H * cv::Vec3d(p.x, p.y, 1);
      f.precision(12);
      f << q[0] / q[2] << ", " << q[1] / q[2] << "  " << p.x << " " << p.y << "   # pair\n";
    }
  }
  auto pairs = readPointPairs(file.string());
  ASSERT_EQ(pairs.size(), 5u);
  cv::Mat ref(220, 320, CV_8UC3, cv::Scalar(90, 100, 110)), test(230, 330, CV_8UC3, cv::Scalar(90, 100, 110));
  RegistrationOptions o;
  o.mode = RegistrationMode::Points;
  o.pointsFile = file.string();
  RegistrationResult r = registerImages(ref, test, o);
  EXPECT_LT(meanCornerError(r.homography, H, test.size()), 1e-4);
  EXPECT_LT(r.residualPx, 1e-4);
  EXPECT_EQ(r.inliers, 5);
}

TEST(Registration, BadInputIsAnInputError) {
  TempDir tmp("regerr");
  cv::Mat a(100, 120, CV_8UC3, cv::Scalar(128, 128, 128)), b(90, 120, CV_8UC3, cv::Scalar(128, 128, 128));
  RegistrationOptions none;
  EXPECT_THROW(registerImages(a, b, none), InputError);  // sizes differ without registration
  // Featureless images cannot be registered.
  RegistrationOptions autoReg;
  autoReg.mode = RegistrationMode::Auto;
  EXPECT_THROW(registerImages(a, b, autoReg), InputError);
  // Unrelated noise: matches do not agree on a homography.
  cv::Mat n1(300, 300, CV_8UC3), n2(300, 300, CV_8UC3);
  cv::RNG rng(11);
  rng.fill(n1, cv::RNG::UNIFORM, 0, 256);
  rng.fill(n2, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(n1, n1, cv::Size(0, 0), 2);
  cv::GaussianBlur(n2, n2, cv::Size(0, 0), 2);
  try {
    registerImages(n1, n2, autoReg);
    ADD_FAILURE() << "registration of unrelated noise succeeded";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("registration failed"), std::string::npos) << e.what();
  }
  // Point files: fewer than 4 pairs, malformed lines, missing file.
  const fs::path three = tmp.path / "three.txt", bad = tmp.path / "bad.txt";
  std::ofstream(three) << "1 2 3 4\n5 6 7 8\n9 10 11 12\n";
  std::ofstream(bad) << "1 2 3 4\n5 6 7 8\n9 10 x 12\n13 14 15 16\n";
  try {
    readPointPairs(three.string());
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("at least 4"), std::string::npos) << e.what();
  }
  try {
    readPointPairs(bad.string());
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 3);
    EXPECT_EQ(e.column(), 6);
  }
  EXPECT_THROW(readPointPairs((tmp.path / "missing.txt").string()), InputError);
  // A folder was read as an empty file: "at least 4 pairs".
  try {
    readPointPairs(tmp.path.string());
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("is a folder, expected a file"), std::string::npos) << e.what();
  }
  // Collinear points do not determine a homography.
  const fs::path line = tmp.path / "line.txt";
  std::ofstream(line) << "0 0 0 0\n1 1 1 1\n2 2 2 2\n3 3 3 3\n4 4 4 4\n";
  RegistrationOptions pts;
  pts.mode = RegistrationMode::Points;
  pts.pointsFile = line.string();
  EXPECT_THROW(registerImages(a, a, pts), InputError);
}

// ----------------------------------------------------------------------------------------------
// Statistics, inputs and the whole command.

TEST(CompareStats, PercentilesMeansAndShares) {
  cv::Mat d(1, 11, CV_32F), inc(1, 11, CV_8U, cv::Scalar(255));
  for (int i = 0; i <= 10; ++i) d.at<float>(0, i) = float(2 * i);  // 0, 2, ..., 20
  inc.at<uint8_t>(0, 10) = 0;                                     // drop the 20
  DeltaEStats s = computeStats(d, inc);
  EXPECT_EQ(s.pixels, 10);
  EXPECT_DOUBLE_EQ(s.mean, 9.0);
  EXPECT_DOUBLE_EQ(s.median, 9.0);            // rank 4.5 between 8 and 10
  EXPECT_NEAR(s.p95, 16 + 0.55 * 2, 1e-9);    // rank 8.55
  EXPECT_NEAR(s.p99, 16 + 0.91 * 2, 1e-9);    // rank 8.91
  EXPECT_DOUBLE_EQ(s.max, 18.0);
  EXPECT_DOUBLE_EQ(s.pctGe2, 90.0);
  EXPECT_DOUBLE_EQ(s.pctGe5, 70.0);
  EXPECT_DOUBLE_EQ(s.pctGe10, 50.0);
  EXPECT_EQ(computeStats(d, cv::Mat::zeros(1, 11, CV_8U)).pixels, 0);
}

TEST(CompareInputs, ReadsPng8Png16ExrAndRejectsBadFiles) {
  DG_NEED_SHARED();
  TempDir tmp("inputs");
  ColorImage p8 = readColorImage(kHats);
  EXPECT_EQ(p8.rgb.type(), CV_8UC3);
  EXPECT_EQ(p8.rgb.size(), cv::Size(192, 128));
  EXPECT_EQ(maxAbs(p8.rgb, readRgb(kHats)), 0.0);  // R, G, B order
  // 16-bit PNG and linear EXR of the same pixels give (nearly) the same Lab.
  cv::Mat rgb16, bgr16;
  p8.rgb.convertTo(rgb16, CV_16U, 257.0);
  cv::cvtColor(rgb16, bgr16, cv::COLOR_RGB2BGR);
  ASSERT_TRUE(cv::imwrite((tmp.path / "h16.png").string(), bgr16));
  cv::Mat lin(p8.rgb.size(), CV_32FC3);
  for (int y = 0; y < lin.rows; ++y)
    for (int x = 0; x < lin.cols; ++x)
      for (int c = 0; c < 3; ++c)
        lin.at<cv::Vec3f>(y, x)[c] = float(color::srgbDecode(p8.rgb.at<cv::Vec3b>(y, x)[c] / 255.0));
  {
    auto out = OIIO::ImageOutput::create((tmp.path / "h.exr").string());
    OIIO::ImageSpec spec(lin.cols, lin.rows, 3, OIIO::TypeDesc::FLOAT);
    ASSERT_TRUE(out->open((tmp.path / "h.exr").string(), spec));
    ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, lin.data));
    out->close();
  }
  ColorImage p16 = readColorImage((tmp.path / "h16.png").string());
  ColorImage exr = readColorImage((tmp.path / "h.exr").string());
  EXPECT_EQ(p16.rgb.type(), CV_16UC3);
  EXPECT_EQ(exr.rgb.type(), CV_32FC3);
  EXPECT_EQ(exr.encoding, "linear float");
  MetricOptions o;
  o.metric = SpatialMetric::Scielab;
  double mx;
  cv::minMaxLoc(deltaEMap(p8.rgb, p16.rgb, o), nullptr, &mx);
  EXPECT_LT(mx, 1e-4);
  cv::minMaxLoc(deltaEMap(p8.rgb, exr.rgb, o), nullptr, &mx);
  EXPECT_LT(mx, 1e-3);
  // Bad files.
  EXPECT_THROW(readColorImage((tmp.path / "missing.png").string()), InputError);
  std::ofstream(tmp.path / "garbage.png") << "this is not a PNG";
  EXPECT_THROW(readColorImage((tmp.path / "garbage.png").string()), InputError);
  // A JPEG cut short: libjpeg fills the rest with grey and only warns; that is refused.
  {
    std::ifstream in(kShared + "/data/scielab/hats.jpg", std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    ASSERT_GT(bytes.size(), 1000u);
    std::ofstream((tmp.path / "whole.jpg").string(), std::ios::binary) << bytes;
    std::ofstream((tmp.path / "half.jpg").string(), std::ios::binary) << bytes.substr(0, bytes.size() / 2);
    EXPECT_EQ(readColorImage((tmp.path / "whole.jpg").string()).rgb.size(), cv::Size(192, 128));
    try {
      readColorImage((tmp.path / "half.jpg").string());
      ADD_FAILURE() << "a truncated JPEG was read";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("half.jpg: the JPEG is damaged (JPEG error: Premature end of JPEG file"),
                std::string::npos)
          << e.what();
    }
  }
  EXPECT_THROW(readMaskImage(kHats, cv::Size(100, 100)), InputError);  // wrong size
  cv::Mat m = readMaskImage(kHats, cv::Size(192, 128));
  EXPECT_EQ(m.type(), CV_8U);
}

TEST(CompareInputs, ViewingGeometry) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // Bosch's 72 dpi at 18 in: 1 / degrees(atan(0.35278 / 457.2)) = 22.62 samples/degree.
  ViewingGeometry d = resolveViewingGeometry(nan, nan, nan, nan);
  EXPECT_NEAR(d.samplesPerDegree, 22.62, 0.01);
  EXPECT_NEAR(resolveViewingGeometry(nan, 72, nan, 457.2).samplesPerDegree, d.samplesPerDegree, 1e-12);
  EXPECT_NEAR(resolveViewingGeometry(nan, nan, 0.05, 300).samplesPerDegree,
              1.0 / (std::atan(0.05 / 300) * 180 / M_PI), 1e-9);
  EXPECT_EQ(resolveViewingGeometry(60, nan, nan, nan).samplesPerDegree, 60);
  EXPECT_THROW(resolveViewingGeometry(60, 72, nan, 457), InputError);    // two forms
  EXPECT_THROW(resolveViewingGeometry(nan, 72, nan, nan), InputError);   // no distance
  EXPECT_THROW(resolveViewingGeometry(60, nan, nan, 400), InputError);   // distance without dpi/pitch
  EXPECT_THROW(resolveViewingGeometry(-3, nan, nan, nan), InputError);   // not positive
  EXPECT_THROW(resolveViewingGeometry(5000, nan, nan, nan), InputError); // out of range
}

TEST(CompareCommand, WritesAllOutputsAndNothingOnError) {
  DG_NEED_SHARED();
  TempDir tmp("cmd");
  CompareRequest req;
  req.reference = kHats;
  req.test = kHatsC;
  req.outDir = (tmp.path / "out").string();
  req.options.viewing = resolveViewingGeometry(40, NAN, NAN, NAN);
  // A mask over the left half.
  cv::Mat mask(128, 192, CV_8U, cv::Scalar(0));
  mask.colRange(0, 96).setTo(255);
  ASSERT_TRUE(cv::imwrite((tmp.path / "mask.png").string(), mask));
  req.maskPath = (tmp.path / "mask.png").string();
  auto report = runCompare(req);
  for (const char* f : {"delta_e.exr", "delta_e_false_color.png", "delta_e_ge10_overlay.png", "delta_e_histogram.png",
                        "report.json"})
    EXPECT_TRUE(fs::is_regular_file(tmp.path / "out" / f)) << f;
  int entries = 0;
  for (auto& e : fs::directory_iterator(tmp.path / "out")) entries += e.path().filename().string()[0] == '.';
  EXPECT_EQ(entries, 0) << "staging folder left behind";
  // The EXR holds the same numbers as a direct computation; the report the same statistics.
  ColorImage a = readColorImage(kHats), b = readColorImage(kHatsC);
  CompareOptions co = req.options;
  CompareResult direct = compareImages(a, b, co, mask);
  auto in = OIIO::ImageInput::open((tmp.path / "out" / "delta_e.exr").string());
  ASSERT_TRUE(in);
  ASSERT_EQ(in->spec().nchannels, 2);
  std::vector<float> px(192 * 128 * 2);
  ASSERT_TRUE(in->read_image(0, 0, 0, 2, OIIO::TypeDesc::FLOAT, px.data()));
  double worst = 0;
  for (int i = 0; i < 192 * 128; ++i) worst = std::max(worst, double(std::fabs(px[2 * i] - direct.deltaE.at<float>(i / 192, i % 192))));
  EXPECT_EQ(worst, 0.0);
  auto j = nlohmann::ordered_json::parse(std::ifstream(tmp.path / "out" / "report.json"));
  EXPECT_NEAR(j["stats"]["valid"]["mean"].get<double>(), direct.all.mean, 1e-9);
  EXPECT_NEAR(j["stats"]["inside_mask"]["p95"].get<double>(), direct.inside.p95, 1e-9);
  EXPECT_EQ(j["stats"]["inside_mask"]["pixels"].get<int64_t>() + j["stats"]["outside_mask"]["pixels"].get<int64_t>(),
            192 * 128);
  EXPECT_EQ(j["metric"]["name"], "scielab");
  EXPECT_EQ(j["registration"]["mode"], "none");
  // Pictures have the documented sizes: the map (enlarged 2x below 240 rows) plus a legend panel.
  cv::Mat fc = cv::imread((tmp.path / "out" / "delta_e_false_color.png").string());
  EXPECT_EQ(fc.rows, 256);
  EXPECT_GT(fc.cols, 384);
  cv::Mat ov = cv::imread((tmp.path / "out" / "delta_e_ge10_overlay.png").string());
  EXPECT_EQ(ov.size(), cv::Size(192, 128));

  // Errors leave nothing behind: a mask of the wrong size, a test image of another size.
  CompareRequest bad = req;
  bad.outDir = (tmp.path / "bad1").string();
  cv::imwrite((tmp.path / "small.png").string(), cv::Mat(10, 10, CV_8U, cv::Scalar(255)));
  bad.maskPath = (tmp.path / "small.png").string();
  EXPECT_THROW(runCompare(bad), InputError);
  EXPECT_FALSE(fs::exists(bad.outDir));
  bad.maskPath.clear();
  bad.test = (tmp.path / "small.png").string();
  EXPECT_THROW(runCompare(bad), InputError);
  EXPECT_FALSE(fs::exists(bad.outDir));
  bad.options.registration.mode = RegistrationMode::Points;
  bad.options.registration.pointsFile = (tmp.path / "none.txt").string();
  EXPECT_THROW(runCompare(bad), InputError);
  EXPECT_FALSE(fs::exists(bad.outDir));
}

TEST(CompareCommand, BatchWritesOneRowPerPairAndResumes) {
  DG_NEED_SHARED();
  TempDir tmp("batch");
  const fs::path csv = tmp.path / "pairs.csv";
  std::ofstream(csv) << "name,reference,test\n# comment\njpeg," << kHats << "," << kHatsC << "\nsame," << kHats << ","
                     << kHats << "\n";
  CompareRequest req;
  req.pairsCsv = csv.string();
  req.outDir = (tmp.path / "out").string();
  req.options.metric.metric = SpatialMetric::Ycxcz;
  req.options.viewing = resolveViewingGeometry(40, NAN, NAN, NAN);
  runComparePairs(req);
  std::ifstream s(tmp.path / "out" / "summary.csv");
  std::string header, r1, r2, extra;
  std::getline(s, header);
  std::getline(s, r1);
  std::getline(s, r2);
  EXPECT_FALSE(std::getline(s, extra));
  EXPECT_EQ(header.rfind("name,reference,test,metric", 0), 0u);
  EXPECT_EQ(r1.rfind("jpeg,", 0), 0u);
  EXPECT_NE(r1.find(",ycxcz,1976,40,"), std::string::npos) << r1;
  EXPECT_EQ(r2.rfind("same,", 0), 0u);
  EXPECT_NE(r2.find(",24576,0,0,0,0,0,0,0,0,"), std::string::npos) << r2;  // identical pair: all zero
  // A second run finds both pairs complete and leaves their files untouched.
  auto stamp = fs::last_write_time(tmp.path / "out" / "jpeg" / "delta_e.exr");
  runComparePairs(req);
  EXPECT_EQ(fs::last_write_time(tmp.path / "out" / "jpeg" / "delta_e.exr"), stamp);
  // Bad CSVs.
  std::ofstream(tmp.path / "bad.csv") << "reference,test\n" << kHats << "\n";
  req.pairsCsv = (tmp.path / "bad.csv").string();
  EXPECT_THROW(runComparePairs(req), InputError);
  std::ofstream(tmp.path / "missing.csv") << "reference,test\n" << kHats << ",nope.png\n";
  req.pairsCsv = (tmp.path / "missing.csv").string();
  EXPECT_THROW(runComparePairs(req), InputError);
}
