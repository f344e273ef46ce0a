#include "labels/registration.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "core/error.h"
#include "core/fsutil.h"
#include "labels/colorimetry.h"

namespace dg {

namespace {

// 8-bit grey version of an image (sRGB-encoded grey for linear float input).
cv::Mat toGray8(const cv::Mat& img) {
  cv::Mat g;
  if (img.channels() == 3)
    cv::cvtColor(img, g, cv::COLOR_RGB2GRAY);
  else if (img.channels() == 1)
    g = img;
  else
    throw std::invalid_argument("registration: images must have 1 or 3 channels");
  cv::Mat out;
  switch (g.depth()) {
    case CV_8U: out = g.clone(); break;
    case CV_16U: g.convertTo(out, CV_8U, 1.0 / 257.0); break;
    case CV_32F: {
      out.create(g.size(), CV_8U);
      for (int y = 0; y < g.rows; ++y) {
        const float* p = g.ptr<float>(y);
        uint8_t* o = out.ptr<uint8_t>(y);
        for (int x = 0; x < g.cols; ++x) {
          double v = color::srgbEncode(std::clamp(double(p[x]), 0.0, 1.0));
          o[x] = uint8_t(std::lround(v * 255.0));
        }
      }
      break;
    }
    default: throw std::invalid_argument("registration: unsupported image depth");
  }
  return out;
}

// Scaling of pixel coordinates by s about the pixel-centre convention of cv::resize:
// x_scaled = s (x + 0.5) - 0.5.
cv::Matx33d scaling(double s) { return {s, 0, 0.5 * s - 0.5, 0, s, 0.5 * s - 0.5, 0, 0, 1}; }

cv::Mat downscale(const cv::Mat& g, double s) {
  if (s >= 1.0) return g;
  cv::Mat out;
  cv::resize(g, out, cv::Size(std::max(1, int(std::lround(g.cols * s))), std::max(1, int(std::lround(g.rows * s)))), 0,
             0, cv::INTER_AREA);
  return out;
}

cv::Point2d apply(const cv::Matx33d& H, const cv::Point2d& p) {
  cv::Vec3d q = H * cv::Vec3d(p.x, p.y, 1.0);
  return {q[0] / q[2], q[1] / q[2]};
}

// AKAZE keypoints and descriptors, keypoints in a canonical order (strongest first, ties by
// position) so that matching does not depend on the order in which threads found them.
void features(const cv::Mat& g, std::vector<cv::KeyPoint>& kps, cv::Mat& desc) {
  kps.clear();
  desc.release();
  // AKAZE's scale space needs some room (it asserts on tiny images); such images have no features.
  if (std::min(g.cols, g.rows) < 32) return;
  auto akaze = cv::AKAZE::create();
  akaze->detect(g, kps);
  if (kps.size() < 200) {  // low-contrast image: lower the detector threshold (default 0.001)
    akaze->setThreshold(1e-4);
    kps.clear();
    akaze->detect(g, kps);
  }
  std::sort(kps.begin(), kps.end(), [](const cv::KeyPoint& a, const cv::KeyPoint& b) {
    if (a.response != b.response) return a.response > b.response;
    if (a.pt.y != b.pt.y) return a.pt.y < b.pt.y;
    if (a.pt.x != b.pt.x) return a.pt.x < b.pt.x;
    if (a.size != b.size) return a.size < b.size;
    return a.class_id < b.class_id;
  });
  if (kps.size() > 5000) kps.resize(5000);
  akaze->compute(g, kps, desc);
}

void checkHomography(const cv::Matx33d& H, cv::Size testSize, const std::string& what) {
  bool ok = true;
  for (int i = 0; i < 9; ++i) ok = ok && std::isfinite(H.val[i]);
  const double det = H(0, 0) * H(1, 1) - H(0, 1) * H(1, 0);
  ok = ok && std::fabs(det) > 1e-4 && std::fabs(det) < 1e4;
  // Every test corner must map to a finite point in front of the camera (w > 0).
  const double w = testSize.width - 1.0, h = testSize.height - 1.0;
  for (cv::Point2d c : {cv::Point2d(0, 0), cv::Point2d(w, 0), cv::Point2d(w, h), cv::Point2d(0, h)}) {
    cv::Vec3d q = H * cv::Vec3d(c.x, c.y, 1.0);
    ok = ok && q[2] > 1e-8 * (std::fabs(q[0]) + std::fabs(q[1]) + 1.0);
  }
  if (!ok) throw InputError(what, "registration failed: the transform found is degenerate (folds or collapses the image)");
}

// Zero-mean normalised correlation of ref and test warped by H (test -> ref) over the overlap.
double correlation(const cv::Mat& refF, const cv::Mat& testF, const cv::Matx33d& H) {
  cv::Mat warped, valid;
  warpToReference(testF, H, refF.size(), warped, valid);
  cv::Scalar ma, sa, mb, sb;
  cv::meanStdDev(refF, ma, sa, valid);
  cv::meanStdDev(warped, mb, sb, valid);
  const int n = cv::countNonZero(valid);
  if (n < 16 || sa[0] == 0 || sb[0] == 0) return 0;
  cv::Mat a, b;
  cv::subtract(refF, ma, a, valid, CV_64F);
  cv::subtract(warped, mb, b, valid, CV_64F);
  a.setTo(0, valid == 0);
  b.setTo(0, valid == 0);
  return a.dot(b) / (double(n) * sa[0] * sb[0]);
}

void residuals(const cv::Matx33d& H, const std::vector<cv::Point2d>& test, const std::vector<cv::Point2d>& ref,
               const std::vector<uint8_t>& use, RegistrationResult& r) {
  double s2 = 0, mx = 0;
  int n = 0;
  for (size_t i = 0; i < test.size(); ++i) {
    if (!use.empty() && !use[i]) continue;
    cv::Point2d d = apply(H, test[i]) - ref[i];
    double e = std::hypot(d.x, d.y);
    s2 += e * e;
    mx = std::max(mx, e);
    ++n;
  }
  r.residualPx = n ? std::sqrt(s2 / n) : 0;
  r.maxResidualPx = mx;
}

std::string trim(const std::string& s) {
  size_t a = s.find_first_not_of(" \t\r"), b = s.find_last_not_of(" \t\r");
  return a == std::string::npos ? std::string() : s.substr(a, b - a + 1);
}

}  // namespace

std::vector<PointPair> readPointPairs(const std::string& path) {
  std::istringstream f(readTextFile(path));  // names a missing file or a folder
  std::vector<PointPair> pairs;
  std::string line;
  int lineNo = 0;
  while (std::getline(f, line)) {
    ++lineNo;
    std::string content = line.substr(0, line.find('#'));
    if (trim(content).empty()) continue;
    double v[4];
    int count = 0;
    size_t i = 0;
    while (i < content.size()) {
      while (i < content.size() && (content[i] == ' ' || content[i] == '\t' || content[i] == ',' || content[i] == '\r')) ++i;
      if (i >= content.size()) break;
      size_t start = i;
      while (i < content.size() && !(content[i] == ' ' || content[i] == '\t' || content[i] == ',' || content[i] == '\r')) ++i;
      std::string tok = content.substr(start, i - start);
      if (count == 4)
        throw InputError(path, lineNo, int(start) + 1, "expected 4 numbers 'x_ref y_ref x_test y_test', found more");
      char* end = nullptr;
      double d = std::strtod(tok.c_str(), &end);
      if (end != tok.c_str() + tok.size() || !std::isfinite(d))
        throw InputError(path, lineNo, int(start) + 1, "expected a number, got '" + tok + "'");
      v[count++] = d;
    }
    if (count != 4)
      throw InputError(path, lineNo, 1,
                       "expected 4 numbers 'x_ref y_ref x_test y_test', got " + std::to_string(count));
    pairs.push_back({{v[0], v[1]}, {v[2], v[3]}});
  }
  if (pairs.size() < 4)
    throw InputError(path, "a homography needs at least 4 point pairs, the file has " + std::to_string(pairs.size()));
  return pairs;
}

void warpToReference(const cv::Mat& test, const cv::Matx33d& H, cv::Size refSize, cv::Mat& warped, cv::Mat& valid) {
  cv::warpPerspective(test, warped, cv::Mat(H), refSize, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  valid.create(refSize, CV_8U);
  const cv::Matx33d Hi = H.inv();
  const double w = test.cols - 1.0, h = test.rows - 1.0;
  cv::parallel_for_(cv::Range(0, refSize.height), [&](const cv::Range& r) {
    for (int y = r.start; y < r.end; ++y) {
      uint8_t* v = valid.ptr<uint8_t>(y);
      for (int x = 0; x < refSize.width; ++x) {
        const double qz = Hi(2, 0) * x + Hi(2, 1) * y + Hi(2, 2);
        const double qx = (Hi(0, 0) * x + Hi(0, 1) * y + Hi(0, 2)) / qz;
        const double qy = (Hi(1, 0) * x + Hi(1, 1) * y + Hi(1, 2)) / qz;
        // A hair of tolerance so that an identity-like transform keeps the last row and column.
        v[x] = (qz > 0 && qx >= -1e-7 && qx <= w + 1e-7 && qy >= -1e-7 && qy <= h + 1e-7) ? 255 : 0;
      }
    }
  });
}

double meanCornerError(const cv::Matx33d& a, const cv::Matx33d& b, cv::Size s) {
  const double w = s.width - 1.0, h = s.height - 1.0;
  double sum = 0;
  for (cv::Point2d c : {cv::Point2d(0, 0), cv::Point2d(w, 0), cv::Point2d(w, h), cv::Point2d(0, h)}) {
    cv::Point2d d = apply(a, c) - apply(b, c);
    sum += std::hypot(d.x, d.y);
  }
  return sum / 4.0;
}

RegistrationResult registerImages(const cv::Mat& reference, const cv::Mat& test, const RegistrationOptions& opt) {
  RegistrationResult r;
  r.mode = opt.mode;
  const cv::Size refSize = reference.size(), testSize = test.size();

  if (opt.mode == RegistrationMode::None) {
    if (refSize != testSize)
      throw InputError("", "the images differ in size (reference " + std::to_string(refSize.width) + "x" +
                               std::to_string(refSize.height) + ", test " + std::to_string(testSize.width) + "x" +
                               std::to_string(testSize.height) +
                               "); register them with --register auto or --register points FILE");
    r.warpedTest = test;
    r.valid = cv::Mat(refSize, CV_8U, cv::Scalar(255));
    return r;
  }

  if (opt.mode == RegistrationMode::Points) {
    std::vector<PointPair> pairs = readPointPairs(opt.pointsFile);
    std::vector<cv::Point2d> tp, rp;
    for (const auto& p : pairs) {
      tp.push_back(p.test);
      rp.push_back(p.reference);
    }
    cv::Mat H = cv::findHomography(tp, rp, 0);  // least squares over all pairs
    if (H.empty())
      throw InputError(opt.pointsFile, "the point pairs do not determine a homography (are 3 of them collinear?)");
    r.homography = cv::Matx33d(H);
    checkHomography(r.homography, testSize, opt.pointsFile);
    r.matches = r.inliers = int(pairs.size());
    residuals(r.homography, tp, rp, {}, r);
  } else {
    const cv::Mat gRef = toGray8(reference), gTest = toGray8(test);
    const double sRef = std::min(1.0, double(opt.maxFeatureSide) / std::max(refSize.width, refSize.height));
    const double sTest = std::min(1.0, double(opt.maxFeatureSide) / std::max(testSize.width, testSize.height));
    std::vector<cv::KeyPoint> kRef, kTest;
    cv::Mat dRef, dTest;
    features(downscale(gRef, sRef), kRef, dRef);
    features(downscale(gTest, sTest), kTest, dTest);
    r.features[0] = int(kRef.size());
    r.features[1] = int(kTest.size());
    std::vector<cv::Point2d> tp, rp;
    if (!dRef.empty() && !dTest.empty() && kRef.size() >= 2 && kTest.size() >= 2) {
      // Lowe's ratio test (0.8) plus a mutual-best check.
      cv::BFMatcher matcher(cv::NORM_HAMMING);
      std::vector<std::vector<cv::DMatch>> fwd;
      std::vector<cv::DMatch> back;
      matcher.knnMatch(dTest, dRef, fwd, 2);
      matcher.match(dRef, dTest, back);
      std::vector<int> bestForRef(kRef.size(), -1);
      for (const auto& m : back) bestForRef[m.queryIdx] = m.trainIdx;
      const cv::Matx33d toFullRef = scaling(sRef).inv(), toFullTest = scaling(sTest).inv();
      for (const auto& m : fwd) {
        if (m.size() < 2 || m[0].distance >= 0.8f * m[1].distance) continue;
        if (bestForRef[m[0].trainIdx] != m[0].queryIdx) continue;
        const cv::Point2f& pt = kTest[m[0].queryIdx].pt;
        const cv::Point2f& pr = kRef[m[0].trainIdx].pt;
        tp.push_back(apply(toFullTest, cv::Point2d(pt.x, pt.y)));
        rp.push_back(apply(toFullRef, cv::Point2d(pr.x, pr.y)));
      }
    }
    r.matches = int(tp.size());
    if (r.matches < 4)
      throw InputError("", "registration failed: only " + std::to_string(r.matches) +
                               " feature matches between the images (" + std::to_string(r.features[0]) + " and " +
                               std::to_string(r.features[1]) +
                               " AKAZE features); give point pairs with --register points FILE");
    std::vector<uint8_t> inl;
    cv::Mat H = cv::findHomography(tp, rp, cv::RANSAC, opt.ransacThresholdPx, inl, 5000, 0.999);
    r.inliers = H.empty() ? 0 : int(std::count(inl.begin(), inl.end(), uint8_t(1)));
    if (H.empty() || r.inliers < opt.minInliers)
      throw InputError("", "registration failed: " + std::to_string(r.inliers) + " of " + std::to_string(r.matches) +
                               " feature matches agree on one homography (at least " +
                               std::to_string(opt.minInliers) +
                               " needed); the images may not show the same scene, or give point pairs with "
                               "--register points FILE");
    r.homography = cv::Matx33d(H);
    checkHomography(r.homography, testSize, "");

    if (opt.refineEcc) {
      // ECC (Evangelidis and Psarakis, IEEE PAMI 30(10), 2008) on downscaled grey images; its warp
      // maps template (reference) coordinates to input (test) coordinates.
      r.eccRun = true;
      const double e = std::min(1.0, double(opt.eccMaxSide) / std::max({refSize.width, refSize.height,
                                                                           testSize.width, testSize.height}));
      cv::Mat refF, testF;
      downscale(gRef, e).convertTo(refF, CV_32F, 1.0 / 255.0);
      downscale(gTest, e).convertTo(testF, CV_32F, 1.0 / 255.0);
      const cv::Matx33d S = scaling(e);
      const cv::Matx33d Hs = S * r.homography * S.inv();
      cv::Matx33d W = Hs.inv();
      W *= 1.0 / W(2, 2);
      cv::Mat Wf;
      cv::Mat(W).convertTo(Wf, CV_32F);
      const double before = correlation(refF, testF, Hs);
      try {
        r.eccCorrelation = cv::findTransformECC(
            refF, testF, Wf, cv::MOTION_HOMOGRAPHY,
            cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, opt.eccIterations, opt.eccEpsilon),
            cv::noArray(), 5);
        cv::Mat W64;
        Wf.convertTo(W64, CV_64F);
        const cv::Matx33d Wd(W64.ptr<double>());
        const cv::Matx33d Hecc = S.inv() * Wd.inv() * S;
        const double shift = meanCornerError(Hecc, r.homography, testSize);
        const double after = correlation(refF, testF, S * Hecc * S.inv());
        bool finite = true;
        for (int i = 0; i < 9; ++i) finite = finite && std::isfinite(Hecc.val[i]);
        if (!finite) {
          r.eccNote = "ECC result not finite; kept the RANSAC homography";
        } else if (shift > 4.0 * opt.ransacThresholdPx) {
          r.eccNote = "ECC moved the corners by " + std::to_string(shift) + " px; kept the RANSAC homography";
        } else if (after < before) {
          r.eccNote = "ECC lowered the correlation; kept the RANSAC homography";
        } else {
          r.homography = Hecc;
          r.eccAccepted = true;
        }
      } catch (const cv::Exception& ex) {
        r.eccNote = std::string("ECC did not converge (") + ex.err + "); kept the RANSAC homography";
      }
      checkHomography(r.homography, testSize, "");
    }
    residuals(r.homography, tp, rp, inl, r);
  }

  warpToReference(test, r.homography, refSize, r.warpedTest, r.valid);
  const int covered = cv::countNonZero(r.valid);
  r.validFraction = double(covered) / (double(refSize.width) * refSize.height);
  if (covered == 0)
    throw InputError(opt.mode == RegistrationMode::Points ? opt.pointsFile : std::string(),
                     "registration failed: the registered test image does not overlap the reference");
  return r;
}

}  // namespace dg
