#include "labels/scielab.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace dg {

namespace {

using color::Vec3;

// ---------------------------------------------------------------------------------------------
// S-CIELAB filter parameters.

struct PublishedGaussian {
  double spreadDeg, weight;
};

// Zhang and Wandell (1996), table of the three channel filters: (spread s in degrees, weight) of
// w exp(-(x^2 + y^2) / s^2). The weights of a channel do not sum to 1 in the table (0.918, 0.861,
// 0.859); they are renormalised below, which gives the weights of the distribution code to 3 or 4
// digits (0.921 / 0.918 = 1.00327).
const std::vector<PublishedGaussian> kPaperTable[3] = {
    {{0.0283, 0.921}, {0.133, 0.105}, {4.336, -0.108}},
    {{0.0392, 0.531}, {0.494, 0.330}},
    {{0.0536, 0.488}, {0.386, 0.371}}};

// The S-CIELAB distribution code (separableFilters.m), also tabulated by Johnson and Fairchild:
// (width in degrees, weight), weights summing to 1. ISETCam (scGaussianParameters 'distribution',
// then gauss2 / ieHwhm2SD) reads the widths as half widths at half maximum.
const std::vector<PublishedGaussian> kDistributionTable[3] = {
    {{0.05, 1.00327}, {0.225, 0.114416}, {7.0, -0.117686}},
    {{0.0685, 0.616725}, {0.826, 0.383275}},
    {{0.0920, 0.567885}, {0.6451, 0.432115}}};

const double kSqrtLn2 = std::sqrt(std::log(2.0));
// Taps below 1e-10 of the peak are dropped: exp(-r^2/sigma^2) < 1e-10 for r > sigma sqrt(ln 1e10).
const double kTailCut = std::sqrt(std::log(1e10));

// DCT work buffers get a row stride that is not a multiple of 1 KiB: with power-of-two strides
// (4096-wide images) the column transforms thrash the cache (measured 3x slower). Only for local
// buffers: a padded region would count as image content for filters that read outside an ROI.
cv::Mat allocPlane(int rows, int cols) {
  int stride = cols + 16;
  if ((stride * 4) % 1024 == 0) stride += 16;
  cv::Mat buf(rows, stride, CV_32F);
  return buf.colRange(0, cols);
}

// ---------------------------------------------------------------------------------------------
// Decoding to linear RGB.

const double* srgb8Table() {
  static const std::vector<double> t = [] {
    std::vector<double> v(256);
    for (int i = 0; i < 256; ++i) v[i] = color::srgbDecode(i / 255.0);
    return v;
  }();
  return t.data();
}

const double* srgb16Table() {
  static const std::vector<double> t = [] {
    std::vector<double> v(65536);
    for (int i = 0; i < 65536; ++i) v[i] = color::srgbDecode(i / 65535.0);
    return v;
  }();
  return t.data();
}

void checkImage(const cv::Mat& m, const char* what) {
  if (m.empty() || m.channels() != 3 ||
      (m.depth() != CV_8U && m.depth() != CV_16U && m.depth() != CV_32F))
    throw std::invalid_argument(std::string("deltaEMap: ") + what +
                                " must be a non-empty CV_8UC3, CV_16UC3 or CV_32FC3 image");
}

// Linear RGB of row y, 3 doubles per pixel.
void decodeRow(const cv::Mat& img, int y, double* out) {
  const int n = img.cols * 3;
  switch (img.depth()) {
    case CV_8U: {
      const double* t = srgb8Table();
      const uint8_t* p = img.ptr<uint8_t>(y);
      for (int i = 0; i < n; ++i) out[i] = t[p[i]];
      break;
    }
    case CV_16U: {
      const double* t = srgb16Table();
      const uint16_t* p = img.ptr<uint16_t>(y);
      for (int i = 0; i < n; ++i) out[i] = t[p[i]];
      break;
    }
    default: {
      const float* p = img.ptr<float>(y);
      for (int i = 0; i < n; ++i) out[i] = p[i];
    }
  }
}

// Mean linear RGB; per-row sums in parallel, added in row order (independent of thread count).
Vec3 meanLinearRgb(const cv::Mat& img) {
  std::vector<Vec3> rows(img.rows);
  cv::parallel_for_(cv::Range(0, img.rows), [&](const cv::Range& r) {
    std::vector<double> buf(size_t(img.cols) * 3);
    for (int y = r.start; y < r.end; ++y) {
      decodeRow(img, y, buf.data());
      Vec3 s(0, 0, 0);
      for (int x = 0; x < img.cols; ++x) s += Vec3(buf[3 * x], buf[3 * x + 1], buf[3 * x + 2]);
      rows[y] = s;
    }
  });
  Vec3 s(0, 0, 0);
  for (const Vec3& v : rows) s += v;
  return s * (1.0 / (double(img.rows) * img.cols));
}

// ---------------------------------------------------------------------------------------------
// Opponent / YCxCz planes.

struct Basis {
  cv::Matx33d fromRgb;  // linear RGB -> channel values
  cv::Matx33d toXyz;    // channel values -> XYZ
};

Basis basisFor(const MetricOptions& opt) {
  const cv::Matx33d& toXyz = color::linearSrgbToXyz();
  if (opt.metric == SpatialMetric::Ycxcz) {
    cv::Matx33d a = color::xyzToYcxczLinear(color::srgbWhiteXyz());
    return {a * toXyz, a.inv()};
  }
  const cv::Matx33d& o = color::xyzToOpponent(opt.observer);
  return {o * toXyz, o.inv()};
}

// The three channels of an image as CV_32F planes, each holding its value minus the channel's
// image mean ("offset", kept in double). Filtering is linear with gain 1 at zero frequency, so
// filtering the deviation and adding the mean back is the same operation; storing the deviation
// makes a flat region come back exactly (its deviation is 0 or nearly) instead of carrying the
// float rounding of the full value.
struct Planes {
  std::array<cv::Mat, 3> p;
  Vec3 offset;
};

// Rows [rows.start, rows.end) of img into dst[c] (CV_32F, rows.size() x img.cols): channel value
// minus offset c.
void convertRows(const cv::Mat& img, cv::Range rows, const cv::Matx33d& m, const Vec3& c, double* buf,
                 std::array<cv::Mat, 3>& dst) {
  for (auto& d : dst) d.create(rows.size(), img.cols, CV_32F);
  for (int y = rows.start; y < rows.end; ++y) {
    decodeRow(img, y, buf);
    float* p0 = dst[0].ptr<float>(y - rows.start);
    float* p1 = dst[1].ptr<float>(y - rows.start);
    float* p2 = dst[2].ptr<float>(y - rows.start);
    for (int x = 0; x < img.cols; ++x) {
      const double R = buf[3 * x], G = buf[3 * x + 1], B = buf[3 * x + 2];
      p0[x] = float(m(0, 0) * R + m(0, 1) * G + m(0, 2) * B - c[0]);
      p1[x] = float(m(1, 0) * R + m(1, 1) * G + m(1, 2) * B - c[1]);
      p2[x] = float(m(2, 0) * R + m(2, 1) * G + m(2, 2) * B - c[2]);
    }
  }
}

// Makes an H x W image region even-sized for cv::dct: full is (H + H%2) x (W + W%2) and its extra
// column / row repeat the last ones (reflection about the image edge, as cv::BORDER_REFLECT).
void fillEvenPadding(cv::Mat& full, int H, int W) {
  if (full.cols > W) full(cv::Rect(W - 1, 0, 1, H)).copyTo(full(cv::Rect(W, 0, 1, H)));
  if (full.rows > H) full.row(H - 1).copyTo(full.row(H));
}

// The whole image as planes. With evenPadded, the planes are allocated for the DCT: even size
// (see fillEvenPadding) and a row stride off powers of two.
Planes toPlanes(const cv::Mat& img, const Basis& b, bool evenPadded = false) {
  Planes out;
  out.offset = b.fromRgb * meanLinearRgb(img);
  const int H = img.rows, W = img.cols;
  for (auto& p : out.p) {
    if (evenPadded)
      p = allocPlane(H + (H & 1), W + (W & 1));
    else
      p.create(H, W, CV_32F);
  }
  cv::parallel_for_(cv::Range(0, H), [&](const cv::Range& r) {
    std::vector<double> buf(size_t(W) * 3);
    std::array<cv::Mat, 3> dst;
    for (int c = 0; c < 3; ++c) dst[c] = out.p[c](cv::Rect(0, r.start, W, r.size()));
    convertRows(img, r, b.fromRgb, out.offset, buf.data(), dst);
  });
  if (evenPadded)
    for (auto& p : out.p) fillEvenPadding(p, H, W);
  return out;
}

// ---------------------------------------------------------------------------------------------
// Per-row CIELAB and Delta E.

inline void xyzToLabInline(double X, double Y, double Z, const Vec3& w, double* lab) {
  double fx = color::labF(X / w[0]), fy = color::labF(Y / w[1]), fz = color::labF(Z / w[2]);
  lab[0] = 116.0 * fy - 16.0;
  lab[1] = 500.0 * (fx - fy);
  lab[2] = 200.0 * (fy - fz);
}

// Lab of row `row` of three filtered planes (values minus offset).
void labRowFromPlanes(const cv::Mat& q0, const cv::Mat& q1, const cv::Mat& q2, int row, const Vec3& c,
                      const cv::Matx33d& toXyz, const Vec3& white, double* lab) {
  const float* a = q0.ptr<float>(row);
  const float* b = q1.ptr<float>(row);
  const float* d = q2.ptr<float>(row);
  const cv::Matx33d& m = toXyz;
  for (int x = 0; x < q0.cols; ++x) {
    const double v0 = a[x] + c[0], v1 = b[x] + c[1], v2 = d[x] + c[2];
    xyzToLabInline(m(0, 0) * v0 + m(0, 1) * v1 + m(0, 2) * v2, m(1, 0) * v0 + m(1, 1) * v1 + m(1, 2) * v2,
                   m(2, 0) * v0 + m(2, 1) * v1 + m(2, 2) * v2, white, lab + 3 * x);
  }
}

void labRowFromImage(const cv::Mat& img, int y, const Vec3& white, double* rgbBuf, double* lab) {
  decodeRow(img, y, rgbBuf);
  const cv::Matx33d& m = color::linearSrgbToXyz();
  for (int x = 0; x < img.cols; ++x) {
    const double R = rgbBuf[3 * x], G = rgbBuf[3 * x + 1], B = rgbBuf[3 * x + 2];
    xyzToLabInline(m(0, 0) * R + m(0, 1) * G + m(0, 2) * B, m(1, 0) * R + m(1, 1) * G + m(1, 2) * B,
                   m(2, 0) * R + m(2, 1) * G + m(2, 2) * B, white, lab + 3 * x);
  }
}

void deltaERow(const double* lab1, const double* lab2, int n, color::DeltaE f, float* out) {
  if (f == color::DeltaE::CIE76) {
    for (int x = 0; x < n; ++x) {
      const double dl = lab1[3 * x] - lab2[3 * x], da = lab1[3 * x + 1] - lab2[3 * x + 1],
                   db = lab1[3 * x + 2] - lab2[3 * x + 2];
      out[x] = float(std::sqrt(dl * dl + da * da + db * db));
    }
    return;
  }
  for (int x = 0; x < n; ++x) {
    Vec3 a(lab1[3 * x], lab1[3 * x + 1], lab1[3 * x + 2]), b(lab2[3 * x], lab2[3 * x + 1], lab2[3 * x + 2]);
    out[x] = float(color::deltaE(f, a, b));
  }
}

// Row bands of about 384 rows for the per-pixel passes: fixed by the image height, not by the
// thread count, so that every band is computed the same way whatever the parallelism.
int bandCount(int rows) { return std::clamp((rows + 383) / 384, 1, 64); }
cv::Range band(int i, int n, int rows) { return {int(int64_t(i) * rows / n), int(int64_t(i + 1) * rows / n)}; }

// ---------------------------------------------------------------------------------------------
// Frequency-domain filtering.

// Response sampled at the DCT-II frequencies of an H x W plane (H, W even), CV_32F.
template <class Response>
cv::Mat responseGrid(int rows, int cols, double spd, const Response& response) {
  cv::Mat g(rows, cols, CV_32F);
  std::vector<double> fx(cols);
  for (int k = 0; k < cols; ++k) fx[k] = k * spd / (2.0 * cols);
  cv::parallel_for_(cv::Range(0, rows), [&](const cv::Range& r) {
    for (int ky = r.start; ky < r.end; ++ky) {
      const double fy = ky * spd / (2.0 * rows);
      float* p = g.ptr<float>(ky);
      for (int kx = 0; kx < cols; ++kx) p[kx] = float(response(fx[kx], fy));
    }
  });
  return g;
}

// Filters even-sized planes in place: DCT-II, times the grid, inverse DCT. Independent jobs, each
// thread reusing one coefficient buffer.
void filterPlanesDct(const std::vector<cv::Mat*>& planes, const std::vector<const cv::Mat*>& grids) {
  const int jobs = int(planes.size());
  const int chunks = std::max(1, std::min(jobs, cv::getNumThreads()));
  cv::parallel_for_(cv::Range(0, jobs), [&](const cv::Range& r) {
    cv::Mat coef = allocPlane(planes[r.start]->rows, planes[r.start]->cols);
    for (int j = r.start; j < r.end; ++j) {
      cv::Mat& p = *planes[j];
      cv::dct(p, coef);
      cv::multiply(coef, *grids[j], coef);
      cv::dct(coef, p, cv::DCT_INVERSE);
    }
  }, chunks);
}

}  // namespace

// ---------------------------------------------------------------------------------------------

double ScielabGaussian::profile(double x) const { return std::exp(-(x * x) / (sigmaSamples * sigmaSamples)); }

ScielabFilterBank makeScielabFilters(double spd, ScielabFilters convention) {
  if (!(spd > 0) || !std::isfinite(spd))
    throw InputError("samples per degree", "must be a positive finite number, got " + std::to_string(spd));
  ScielabFilterBank bank;
  bank.samplesPerDegree = spd;
  bank.convention = convention;
  // S-CIELAB code: width = ceil(sampPerDeg / 2) * 2 - 1 (odd, about one degree).
  bank.support = std::max(1, int(std::ceil(spd / 2.0)) * 2 - 1);
  const int R = (bank.support - 1) / 2;
  for (int c = 0; c < 3; ++c) {
    const auto& table = convention == ScielabFilters::Paper ? kPaperTable[c] : kDistributionTable[c];
    double wsum = 0;
    for (const auto& g : table) wsum += g.weight;
    ScielabChannelFilter& f = bank.channel[c];
    f.support = bank.support;
    for (const auto& g : table) {
      ScielabGaussian t;
      t.weight = g.weight / wsum;
      t.spreadDeg = g.spreadDeg;
      if (convention == ScielabFilters::Paper) {
        t.sigmaSamples = g.spreadDeg * spd;  // exp(-x^2/s^2), s in samples
      } else {
        // Half width at half maximum h: exp(-ln2 x^2 / h^2) = exp(-x^2 / (h / sqrt(ln 2))^2).
        t.sigmaSamples = g.spreadDeg * spd / kSqrtLn2;
      }
      t.halfMaxSamples = t.sigmaSamples * kSqrtLn2;
      t.radius = std::min(R, int(std::ceil(t.sigmaSamples * kTailCut)));
      t.taps.resize(2 * size_t(t.radius) + 1);
      double s = 0;
      for (int k = -t.radius; k <= t.radius; ++k) s += t.taps[k + t.radius] = t.profile(k);
      for (double& v : t.taps) v /= s;
      f.terms.push_back(std::move(t));
    }
  }
  return bank;
}

cv::Mat scielabKernel2D(const ScielabChannelFilter& f) {
  cv::Mat k = cv::Mat::zeros(f.support, f.support, CV_64F);
  const int R = (f.support - 1) / 2;
  for (const auto& t : f.terms) {
    for (int y = -t.radius; y <= t.radius; ++y)
      for (int x = -t.radius; x <= t.radius; ++x)
        k.at<double>(R + y, R + x) += t.weight * t.taps[y + t.radius] * t.taps[x + t.radius];
  }
  return k;
}

void applyScielabChannel(const cv::Mat& plane, const ScielabChannelFilter& f, cv::Mat& out) {
  CV_Assert(plane.type() == CV_32F);
  out.create(plane.size(), CV_32F);
  std::vector<cv::Mat> kernels;
  for (const auto& t : f.terms) {
    cv::Mat k(1, int(t.taps.size()), CV_32F);
    for (size_t j = 0; j < t.taps.size(); ++j) k.at<float>(0, int(j)) = float(t.taps[j]);
    kernels.push_back(k);
  }
  // Column tiles of about 900 pixels: OpenCV's filter engine slows down by half on rows of 4096
  // floats (cache-set conflicts in its ring buffer), and tiles avoid that. Each tile reads its
  // neighbourhood from the full plane (ROI rule), so the result is the same bit for bit as one
  // whole-plane pass.
  const int W = plane.cols;
  const int nt = std::max(1, (W + 899) / 900);
  cv::Mat tmp;
  for (int t = 0; t < nt; ++t) {
    const cv::Range cols(int(int64_t(t) * W / nt), int(int64_t(t + 1) * W / nt));
    const cv::Mat src = plane.colRange(cols);
    cv::Mat dst = out.colRange(cols);
    for (size_t i = 0; i < f.terms.size(); ++i) {
      cv::sepFilter2D(src, tmp, CV_32F, kernels[i], kernels[i], cv::Point(-1, -1), 0, cv::BORDER_REFLECT);
      if (i == 0)
        tmp.convertTo(dst, CV_32F, f.terms[i].weight);
      else
        cv::scaleAdd(tmp, f.terms[i].weight, dst, dst);
    }
  }
}

double YcxczModel::luminanceAlpha() { return 1.0 / (kLuminanceC * std::log(kMeanLuminance) + kLuminanceD); }

double ycxczLuminanceResponse(double fx, double fy) {
  const double rho2 = fx * fx + fy * fy;
  if (rho2 == 0) return 1.0;
  const double rho = std::sqrt(rho2);
  // cos(4 phi) = 1 - 8 sin^2(phi) cos^2(phi) = 1 - 8 fx^2 fy^2 / rho^4.
  const double cos4 = 1.0 - 8.0 * fx * fx * fy * fy / (rho2 * rho2);
  const double w = YcxczModel::kOmega;
  const double s = 0.5 * (1.0 - w) * cos4 + 0.5 * (1.0 + w);
  // K(L) exp(-alpha rho / s) / K(L): gain 1 at rho = 0.
  return std::exp(-YcxczModel::luminanceAlpha() * rho / s);
}

double ycxczChrominanceResponse(double fx, double fy) {
  return std::exp(-YcxczModel::kChromaAlpha * std::sqrt(fx * fx + fy * fy));
}

void applyFrequencyResponse(const cv::Mat& plane, double spd, const std::function<double(double, double)>& response,
                            cv::Mat& out) {
  CV_Assert(plane.type() == CV_32F);
  const int H = plane.rows, W = plane.cols;
  cv::Mat work = allocPlane(H + (H & 1), W + (W & 1));
  plane.copyTo(work(cv::Rect(0, 0, W, H)));
  fillEvenPadding(work, H, W);
  const cv::Mat grid = responseGrid(work.rows, work.cols, spd, response);
  filterPlanesDct({&work}, {&grid});
  work(cv::Rect(0, 0, W, H)).copyTo(out);
}

cv::Mat deltaEMap(const cv::Mat& reference, const cv::Mat& test, const MetricOptions& opt) {
  checkImage(reference, "reference");
  checkImage(test, "test");
  if (reference.size() != test.size()) throw std::invalid_argument("deltaEMap: images differ in size");
  const int H = reference.rows, W = reference.cols;
  const Vec3 white = color::srgbWhiteXyz();
  cv::Mat out(H, W, CV_32F);
  const int nb = bandCount(H);

  if (opt.metric == SpatialMetric::Cielab) {
    cv::parallel_for_(cv::Range(0, nb), [&](const cv::Range& r) {
      std::vector<double> rgb(size_t(W) * 3), lab1(size_t(W) * 3), lab2(size_t(W) * 3);
      for (int b = r.start; b < r.end; ++b) {
        cv::Range rows = band(b, nb, H);
        for (int y = rows.start; y < rows.end; ++y) {
          labRowFromImage(reference, y, white, rgb.data(), lab1.data());
          labRowFromImage(test, y, white, rgb.data(), lab2.data());
          deltaERow(lab1.data(), lab2.data(), W, opt.deltaE, out.ptr<float>(y));
        }
      }
    }, nb);
    return out;
  }

  const Basis basis = basisFor(opt);

  if (opt.metric == SpatialMetric::Scielab) {
    const ScielabFilterBank bank = makeScielabFilters(opt.samplesPerDegree, opt.filters);
    const int R = (bank.support - 1) / 2;
    const cv::Mat* img[2] = {&reference, &test};
    const Vec3 offset[2] = {basis.fromRgb * meanLinearRgb(reference), basis.fromRgb * meanLinearRgb(test)};
    // Each band converts its rows plus R rows above and below (the kernels' reach) into band-local
    // planes, filters its own rows (reading the extra rows as neighbours, reflecting only at the
    // image's edges), and converts the result to Delta E at once. No full-size plane is kept, and
    // the result equals whole-plane filtering bit for bit. Each thread takes a run of whole bands.
    const int chunks = std::max(1, std::min(nb, cv::getNumThreads()));
    cv::parallel_for_(cv::Range(0, nb), [&](const cv::Range& r) {
      std::vector<double> buf(size_t(W) * 3), lab1(size_t(W) * 3), lab2(size_t(W) * 3);
      std::array<cv::Mat, 3> in[2], f[2];
      for (int b = r.start; b < r.end; ++b) {
        const cv::Range rows = band(b, nb, H);
        const cv::Range ext(std::max(0, rows.start - R), std::min(H, rows.end + R));
        const cv::Range own(rows.start - ext.start, rows.end - ext.start);
        for (int i = 0; i < 2; ++i) {
          convertRows(*img[i], ext, basis.fromRgb, offset[i], buf.data(), in[i]);
          for (int c = 0; c < 3; ++c) applyScielabChannel(in[i][c].rowRange(own), bank.channel[c], f[i][c]);
        }
        for (int y = rows.start; y < rows.end; ++y) {
          const int yy = y - rows.start;
          labRowFromPlanes(f[0][0], f[0][1], f[0][2], yy, offset[0], basis.toXyz, white, lab1.data());
          labRowFromPlanes(f[1][0], f[1][1], f[1][2], yy, offset[1], basis.toXyz, white, lab2.data());
          deltaERow(lab1.data(), lab2.data(), W, opt.deltaE, out.ptr<float>(y));
        }
      }
    }, chunks);
    return out;
  }

  // YCxCz/Lab: whole-plane DCT filtering of six planes.
  Planes planes[2] = {toPlanes(reference, basis, true), toPlanes(test, basis, true)};
  const int He = planes[0].p[0].rows, We = planes[0].p[0].cols;
  const cv::Mat lumGrid = responseGrid(He, We, opt.samplesPerDegree, ycxczLuminanceResponse);
  const cv::Mat chromaGrid = responseGrid(He, We, opt.samplesPerDegree, ycxczChrominanceResponse);
  std::vector<cv::Mat*> jobs;
  std::vector<const cv::Mat*> grids;
  for (int i = 0; i < 2; ++i)
    for (int c = 0; c < 3; ++c) {
      jobs.push_back(&planes[i].p[c]);
      grids.push_back(c == 0 ? &lumGrid : &chromaGrid);
    }
  filterPlanesDct(jobs, grids);
  cv::Mat q[2][3];
  for (int i = 0; i < 2; ++i)
    for (int c = 0; c < 3; ++c) q[i][c] = planes[i].p[c](cv::Rect(0, 0, W, H));
  cv::parallel_for_(cv::Range(0, nb), [&](const cv::Range& r) {
    std::vector<double> lab1(size_t(W) * 3), lab2(size_t(W) * 3);
    for (int b = r.start; b < r.end; ++b) {
      cv::Range rows = band(b, nb, H);
      for (int y = rows.start; y < rows.end; ++y) {
        labRowFromPlanes(q[0][0], q[0][1], q[0][2], y, planes[0].offset, basis.toXyz, white, lab1.data());
        labRowFromPlanes(q[1][0], q[1][1], q[1][2], y, planes[1].offset, basis.toXyz, white, lab2.data());
        deltaERow(lab1.data(), lab2.data(), W, opt.deltaE, out.ptr<float>(y));
      }
    }
  }, nb);
  return out;
}

cv::Mat labImage(const cv::Mat& image, const MetricOptions& opt) {
  checkImage(image, "image");
  const int H = image.rows, W = image.cols;
  const Vec3 white = color::srgbWhiteXyz();
  cv::Mat out(H, W, CV_32FC3);
  std::vector<double> rgb(size_t(W) * 3), lab(size_t(W) * 3);
  auto store = [&](int y) {
    float* o = out.ptr<float>(y);
    for (int i = 0; i < 3 * W; ++i) o[i] = float(lab[i]);
  };
  if (opt.metric == SpatialMetric::Cielab) {
    for (int y = 0; y < H; ++y) {
      labRowFromImage(image, y, white, rgb.data(), lab.data());
      store(y);
    }
    return out;
  }
  const Basis basis = basisFor(opt);
  const bool ycc = opt.metric == SpatialMetric::Ycxcz;
  Planes p = toPlanes(image, basis, ycc);
  if (!ycc) {
    const ScielabFilterBank bank = makeScielabFilters(opt.samplesPerDegree, opt.filters);
    for (int c = 0; c < 3; ++c) {
      cv::Mat f;
      applyScielabChannel(p.p[c], bank.channel[c], f);
      p.p[c] = f;
    }
  } else {
    const cv::Mat lum = responseGrid(p.p[0].rows, p.p[0].cols, opt.samplesPerDegree, ycxczLuminanceResponse);
    const cv::Mat chroma = responseGrid(p.p[0].rows, p.p[0].cols, opt.samplesPerDegree, ycxczChrominanceResponse);
    filterPlanesDct({&p.p[0], &p.p[1], &p.p[2]}, {&lum, &chroma, &chroma});
    for (auto& plane : p.p) plane = plane(cv::Rect(0, 0, W, H));
  }
  for (int y = 0; y < H; ++y) {
    labRowFromPlanes(p.p[0], p.p[1], p.p[2], y, p.offset, basis.toXyz, white, lab.data());
    store(y);
  }
  return out;
}

const char* metricName(SpatialMetric m) {
  switch (m) {
    case SpatialMetric::Cielab: return "cielab";
    case SpatialMetric::Scielab: return "scielab";
    case SpatialMetric::Ycxcz: return "ycxcz";
  }
  return "?";
}

const char* filtersName(ScielabFilters f) { return f == ScielabFilters::Paper ? "paper" : "isetcam"; }

const char* deltaEName(color::DeltaE d) {
  switch (d) {
    case color::DeltaE::CIE76: return "1976";
    case color::DeltaE::CIE94: return "94";
    case color::DeltaE::CIEDE2000: return "2000";
  }
  return "?";
}

}  // namespace dg
