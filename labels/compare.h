// `defectgen compare`: compares a test image (photograph or render) with a reference image after
// optional registration, per pixel in CIELAB, S-CIELAB or YCxCz/Lab, and writes the Delta E map
// (EXR), a false-colour picture with legend, the pixels with Delta E >= 10 over the reference, a
// histogram and report.json. Bosch (2007), appendix A; method notes in docs/compare.md.
#pragma once
#include <cstdint>
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "labels/registration.h"
#include "labels/scielab.h"

namespace dg {

// An input image: 3 channels in R, G, B order. CV_8UC3 / CV_16UC3 hold sRGB-encoded values (PNG,
// JPEG, TIFF), CV_32FC3 linear values (EXR). Grey inputs are expanded to 3 channels, alpha dropped.
struct ColorImage {
  cv::Mat rgb;
  std::string path;
  std::string encoding;  // "sRGB 8-bit", "sRGB 16-bit", "linear float"
};

// Reads PNG, JPEG, TIFF (8 or 16 bit, sRGB) or EXR (half/float, linear; channels R, G, B or Y).
// Throws InputError naming the file when it cannot be read or has an unsupported format.
ColorImage readColorImage(const std::string& path);

// A ColorImage's pixels as 8-bit sRGB-encoded RGB, for display: 8-bit kept, 16-bit scaled, linear
// float encoded (NaN as 0, clamped to [0, 1]).
cv::Mat toDisplay8(const cv::Mat& rgb);

// Reads a mask (any image; a pixel is inside where any channel is non-zero). Throws InputError
// when unreadable or not of the expected size. Returns CV_8U, 255 inside, 0 outside.
cv::Mat readMaskImage(const std::string& path, cv::Size expected);

// Viewing geometry -> samples (pixels) per degree of visual angle:
//   spd = 1 / degrees(atan(pitch / distance)), pitch = 25.4 mm / dpi for a display.
double samplesPerDegreeFromPitch(double pitchMm, double distanceMm);
struct ViewingGeometry {
  double samplesPerDegree = 0;
  std::string description;  // how it was given, for the report
};
// Exactly one of: spd; dpi with distance; pitch with distance. Unset values are NaN. All unset:
// Bosch's 72 dpi at 18 inches (457.2 mm), 22.6 samples/degree. Throws InputError on a conflict,
// a missing partner value or a value out of range (spd must end up in [2, 600]).
ViewingGeometry resolveViewingGeometry(double samplesPerDegree, double dpi, double pitchMm, double distanceMm);

struct DeltaEStats {
  int64_t pixels = 0;  // pixels counted; the other fields are 0 when there are none
  double mean = 0, median = 0, p95 = 0, p99 = 0, max = 0;
  double pctGe2 = 0, pctGe5 = 0, pctGe10 = 0;  // percentage of counted pixels with Delta E >= 2, 5, 10
};
// Statistics of deltaE (CV_32F) over the pixels where include (CV_8U) is non-zero. Percentiles
// interpolate linearly between order statistics (the q-quantile sits at rank q (n - 1)).
DeltaEStats computeStats(const cv::Mat& deltaE, const cv::Mat& include);
nlohmann::ordered_json statsJson(const DeltaEStats& s);

struct CompareOptions {
  MetricOptions metric;       // metric.samplesPerDegree is set from viewing
  ViewingGeometry viewing;
  RegistrationOptions registration;
};

struct CompareResult {
  cv::Mat deltaE;  // CV_32F on the reference grid; 0 outside the valid region
  cv::Mat valid;   // CV_8U, 255 where the registered test image is defined
  cv::Mat mask;    // CV_8U user mask (255 inside), empty when none
  RegistrationResult registration;
  DeltaEStats all, inside, outside;  // inside/outside: valid pixels inside / outside the mask
  double metricSeconds = 0, registrationSeconds = 0;
};

// Registers test onto reference (per opt.registration) and computes the Delta E map and its
// statistics. mask, when given, must have the reference's size. Throws InputError on bad input.
CompareResult compareImages(const ColorImage& reference, const ColorImage& test, const CompareOptions& opt,
                            const cv::Mat& mask = cv::Mat());

// Pictures (8-bit BGR, for cv::imwrite).
// False-colour scale, fixed: Delta E 0 blue (0, 0, 255) -> 10 green (0, 255, 0) -> 20 and above red
// (255, 0, 0), linear in between (RGB). Outside the valid region: black. Maps under 240 pixels high
// are enlarged by an integer factor (nearest neighbour) for the legend's sake.
cv::Vec3b falseColorRgb(double deltaE);
cv::Mat falseColorImage(const cv::Mat& deltaE, const cv::Mat& valid, const std::string& label);
// The reference in grey at 60% brightness, pixels with Delta E >= threshold in red, outside the
// valid region darkened to 25%, mask outline (if any) in yellow.
cv::Mat overlayImage(const cv::Mat& referenceRgb, const cv::Mat& deltaE, const cv::Mat& valid, const cv::Mat& mask,
                     double threshold);
// Histogram of Delta E over the valid region in bins of 0.5 from 0 to 20 plus one bin for >= 20,
// as percentages of the valid pixels; with a mask, the inside-mask distribution as a white line.
cv::Mat histogramImage(const CompareResult& r, const std::string& label);

// Everything the command needs. reference/test are paths; with pairsCsv set, batch mode.
struct CompareRequest {
  std::string reference, test;
  std::string outDir = "compare_out";
  std::string maskPath;
  std::string pairsCsv;
  CompareOptions options;
};

// The JSON record of the request (inputs, metric, geometry, registration) stored in report.json
// under "request"; a batch run skips a pair whose report.json holds the same record.
nlohmann::ordered_json requestJson(const CompareRequest& req);

// Compares one pair and writes outDir/{delta_e.exr, delta_e_false_color.png,
// delta_e_ge10_overlay.png, delta_e_histogram.png, registered_test.png (when registered),
// report.json}. Files are staged in a temporary folder inside outDir and moved into place when all
// are written; on error nothing is left behind. Returns the report. Progress goes to stderr.
nlohmann::ordered_json runCompare(const CompareRequest& req);

// Batch: req.pairsCsv is a CSV with a header naming the columns reference, test and optionally
// mask, points, name (paths relative to the CSV's folder). Each pair is written to
// outDir/<name or pair_NNN>/ as by runCompare, and outDir/summary.csv gets one row per pair.
// Pairs already complete with the same request are not recomputed.
void runComparePairs(const CompareRequest& req);

}  // namespace dg
