// Perceptual colour-difference maps between two registered images of the same size:
//   - plain CIELAB: Delta E per pixel of the unfiltered images;
//   - S-CIELAB (Zhang and Wandell, SID 1996 digest pp. 731-734; J. SID 5(1), 1997): XYZ -> opponent
//     space, one sum-of-Gaussians kernel per opponent channel, back to XYZ, then CIELAB;
//   - YCxCz/Lab (Kolpatzik and Bouman, J. Electronic Imaging 1(3), 1992; Flohr et al., SPIE 1913,
//     1993): XYZ -> linearised CIELAB (YCxCz), one contrast-sensitivity filter per channel in the
//     frequency domain, back to XYZ, then CIELAB.
// The spatial filters are sized by the viewing geometry in samples (pixels) per degree of visual
// angle. See docs/compare.md and shared/reference/scielab.md.
#pragma once
#include <array>
#include <functional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "labels/colorimetry.h"

namespace dg {

enum class SpatialMetric { Cielab, Scielab, Ycxcz };

// Which published form of the S-CIELAB filters to use.
//   Paper:   Zhang and Wandell (1996) table: Gaussians exp(-x^2/s^2) with spreads s in degrees,
//            weights renormalised to sum 1.
//   Isetcam: the numbers of the S-CIELAB "distribution" code (0.05, 0.225, 7.0 / 0.0685, 0.826 /
//            0.092, 0.6451 degrees) read as half widths at half maximum, as ISETCam's current
//            scGaussianParameters + gauss2 do; its Gaussians are about twice as wide as the paper's.
enum class ScielabFilters { Paper, Isetcam };

// One Gaussian of an S-CIELAB channel filter.
struct ScielabGaussian {
  double weight = 0;          // share in the channel filter; the weights of a channel sum to 1
  double spreadDeg = 0;       // the published number (s of exp(-x^2/s^2), or the half width at half max)
  double sigmaSamples = 0;    // the Gaussian is exp(-x^2 / sigmaSamples^2), x in samples
  double halfMaxSamples = 0;  // where exp(-x^2 / sigma^2) = 1/2, in samples
  int radius = 0;             // taps cover [-radius, radius]; taps below 1e-10 of the peak are dropped
  std::vector<double> taps;   // 2 radius + 1 values, sum 1: a 1-D factor of the 2-D Gaussian
  double profile(double xSamples) const;  // exp(-x^2 / sigma^2), 1 at the centre
};

struct ScielabChannelFilter {
  std::vector<ScielabGaussian> terms;
  int support = 1;  // odd width of the channel's 2-D kernel, about one degree
};

struct ScielabFilterBank {
  double samplesPerDegree = 0;
  ScielabFilters convention = ScielabFilters::Paper;
  int support = 1;  // ceil(spd / 2) * 2 - 1 samples, as in the S-CIELAB code (about one degree)
  std::array<ScielabChannelFilter, 3> channel;  // O1 luminance, O2 red-green, O3 blue-yellow
};

ScielabFilterBank makeScielabFilters(double samplesPerDegree, ScielabFilters convention);

// The channel's 2-D kernel, support x support, CV_64F: K = sum_i w_i g_i g_i^T (each Gaussian is
// separable, their weighted sum is not). Sums to 1.
cv::Mat scielabKernel2D(const ScielabChannelFilter& f);

// Filters one CV_32F plane with the channel kernel as a sum of separable passes (one row and one
// column pass per Gaussian), reflected edges (cv::BORDER_REFLECT, "cba|abc"). out is CV_32F.
// When plane is a region of a larger matrix, rows and columns of the larger matrix outside the
// region are used as the neighbourhood (OpenCV's ROI rule); only its outer edges are reflected.
void applyScielabChannel(const cv::Mat& plane, const ScielabChannelFilter& f, cv::Mat& out);

// YCxCz/Lab contrast-sensitivity filters as frequency responses, frequencies in cycles/degree,
// normalised to gain 1 at zero frequency (only the shape matters once each channel keeps its mean).
//   Luminance (Yy): Nasanen's exponential model as used by Kolpatzik and Bouman (1992),
//     W(rho, phi) = K(L) exp(-alpha(L) rho / s(phi)),  K(L) = a L^b,  alpha(L) = 1 / (c ln L + d),
//     a = 131.6, b = 0.3188, c = 0.525, d = 3.91, mean luminance L = 11 cd/m^2, and the angular
//     factor of Sullivan, Ray and Miller (IEEE SMC 21(1), 1991)
//     s(phi) = (1 - w)/2 cos(4 phi) + (1 + w)/2, w = 0.7 (sensitivity lowest along the diagonals).
//   Chrominance (Cx, Cz): W(rho) = A exp(-0.419 rho), A = 100 (Kolpatzik and Bouman, after Mullen 1985).
struct YcxczModel {
  static constexpr double kLuminanceA = 131.6, kLuminanceB = 0.3188;
  static constexpr double kLuminanceC = 0.525, kLuminanceD = 3.91;
  static constexpr double kMeanLuminance = 11.0;  // cd/m^2
  static constexpr double kOmega = 0.7;
  static constexpr double kChromaAlpha = 0.419;  // degrees per cycle
  static constexpr double kChromaA = 100.0;
  static double luminanceAlpha();  // 1 / (c ln L + d) = 0.19346 degrees per cycle
};
double ycxczLuminanceResponse(double fxCpd, double fyCpd);
double ycxczChrominanceResponse(double fxCpd, double fyCpd);

// Filters a CV_32F plane with a zero-phase response given in cycles/degree. The response is applied
// to the DCT-II coefficients, which is exactly convolution with the filter over the image extended
// by reflection (the same edge rule as applyScielabChannel); coefficient (ky, kx) of an H x W plane
// has frequency (kx / 2W, ky / 2H) cycles per sample. Odd sizes are padded by one reflected
// row/column (cv::dct needs even sizes) and cropped after.
void applyFrequencyResponse(const cv::Mat& plane, double samplesPerDegree,
                            const std::function<double(double, double)>& response, cv::Mat& out);

struct MetricOptions {
  SpatialMetric metric = SpatialMetric::Scielab;
  color::DeltaE deltaE = color::DeltaE::CIE76;
  double samplesPerDegree = 60;
  ScielabFilters filters = ScielabFilters::Paper;
  color::Observer observer = color::Observer::Deg2;  // S-CIELAB opponent matrix only
};

// Delta E per pixel (CV_32F) between two images of the same size, each 3-channel in R, G, B order:
// CV_8UC3 or CV_16UC3 holding sRGB-encoded values, or CV_32FC3 holding linear values (1 = white).
// CIELAB is taken relative to the sRGB white. Results do not depend on the number of threads.
cv::Mat deltaEMap(const cv::Mat& reference, const cv::Mat& test, const MetricOptions& opt);

// Per-pixel CIELAB of one such image (CV_32FC3, L*, a*, b*); the image after the metric's spatial
// filtering when opt.metric is Scielab or Ycxcz. For inspection and tests.
cv::Mat labImage(const cv::Mat& image, const MetricOptions& opt);

const char* metricName(SpatialMetric m);         // "cielab", "scielab", "ycxcz"
const char* filtersName(ScielabFilters f);       // "paper", "isetcam"
const char* deltaEName(color::DeltaE d);         // "1976", "94", "2000"

}  // namespace dg
