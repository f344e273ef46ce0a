// Registration of a test image (photograph or render) onto a reference image: a projective
// transform (homography) found automatically from AKAZE features (RANSAC) and refined by ECC, or
// fitted to point pairs given in a file. The test image is resampled onto the reference pixel
// grid, and a mask marks where it is defined (Bosch 2007, appendix A.1: warp, then drop the border
// the warp leaves undefined).
#pragma once
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace dg {

enum class RegistrationMode { None, Auto, Points };

struct RegistrationOptions {
  RegistrationMode mode = RegistrationMode::None;
  std::string pointsFile;      // for Points
  int maxFeatureSide = 1024;   // images are downscaled to this longest side for feature detection
  double ransacThresholdPx = 3.0;  // RANSAC inlier threshold, reference pixels
  int minInliers = 12;         // fewer RANSAC inliers than this: registration fails
  bool refineEcc = true;       // ECC refinement after RANSAC (Auto only)
  int eccMaxSide = 2048;       // ECC runs on grey images downscaled to at most this longest side
  int eccIterations = 50;      // ECC stops after this many iterations...
  double eccEpsilon = 1e-5;    // ...or when the correlation changes by less than this
};

// One correspondence: the same scene point in the reference and in the test image, in pixels
// (x right, y down, origin at the centre of the top-left pixel).
struct PointPair {
  cv::Point2d reference, test;
};

struct RegistrationResult {
  RegistrationMode mode = RegistrationMode::None;
  cv::Matx33d homography = cv::Matx33d::eye();  // test pixel -> reference pixel
  cv::Mat warpedTest;  // test resampled on the reference grid (same depth as the test image)
  cv::Mat valid;       // CV_8U, 255 where warpedTest is defined, 0 elsewhere
  int features[2] = {0, 0};  // keypoints found in reference, test (Auto)
  int matches = 0;           // tentative matches (Auto) or point pairs (Points)
  int inliers = 0;           // RANSAC inliers (Auto) or point pairs (Points)
  double residualPx = 0;     // RMS distance, in reference pixels, between H(test point) and its
                             // reference point over the inliers / point pairs
  double maxResidualPx = 0;
  bool eccRun = false, eccAccepted = false;
  double eccCorrelation = 0;  // ECC's enhanced correlation coefficient at the end (1 = perfect)
  std::string eccNote;        // why ECC was not accepted, if it was not
  double validFraction = 1;   // share of reference pixels covered
};

// Reads point pairs: one pair per line, "x_ref y_ref x_test y_test" separated by blanks or commas;
// '#' starts a comment; blank lines are skipped. Throws InputError (file, line, column) on a
// malformed line and when fewer than 4 pairs are given.
std::vector<PointPair> readPointPairs(const std::string& path);

// Registers test onto reference. Images: 1 or 3 channels, CV_8U, CV_16U (sRGB encoded) or CV_32F
// (linear); any sizes. Mode None requires equal sizes. Throws InputError when registration fails
// (too few features or inliers, degenerate transform, no overlap) or sizes differ without it.
RegistrationResult registerImages(const cv::Mat& reference, const cv::Mat& test, const RegistrationOptions& opt);

// Resamples test onto a grid of refSize with the homography H (test -> reference), bilinear,
// edge pixels replicated beyond the test image; valid (CV_8U) marks reference pixels whose
// bilinear footprint lies entirely inside the test image.
void warpToReference(const cv::Mat& test, const cv::Matx33d& H, cv::Size refSize, cv::Mat& warped, cv::Mat& valid);

// Mean distance between where H_a and H_b send the four corners of a w x h image (test -> reference).
double meanCornerError(const cv::Matx33d& a, const cv::Matx33d& b, cv::Size testSize);

}  // namespace dg
