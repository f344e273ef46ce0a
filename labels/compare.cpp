#include "labels/compare.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <exception>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <unistd.h>

#include <OpenImageIO/imageio.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/fsutil.h"
#include "core/version.h"
#include "labels/image_io.h"

namespace dg {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

namespace {

double seconds(std::chrono::steady_clock::time_point a, std::chrono::steady_clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

std::string fmt(double v, int digits = 3) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(digits);
  s << v;
  return s.str();
}

// ---------------------------------------------------------------------------------------------
// Reading.

struct RawImage {
  int width = 0, height = 0, channels = 0;
  std::string format;  // OIIO format name
  OIIO::TypeDesc type;
  std::vector<std::string> names;
  std::vector<uint8_t> data;  // interleaved, in `type`
};

RawImage readRaw(const std::string& path, bool asFloat) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(path, "file not found");
  if (fs::is_directory(path, ec)) throw InputError(path, "is a folder, expected an image file");
  QuietStderr quiet;  // libpng's own complaint: the error below says it
  auto in = OIIO::ImageInput::open(path);
  if (!in) {
    std::string err = oneLineError(OIIO::geterror());
    throw InputError(path, "cannot read image" + (err.empty() ? std::string() : ": " + err));
  }
  const OIIO::ImageSpec& spec = in->spec();
  RawImage r;
  r.width = spec.width;
  r.height = spec.height;
  r.channels = spec.nchannels;
  r.format = in->format_name();
  r.names = spec.channelnames;
  if (r.width <= 0 || r.height <= 0 || r.channels <= 0) throw InputError(path, "image has no pixels");
  if (int64_t(r.width) * r.height > int64_t(20000) * 20000)
    throw InputError(path, "image is too large (" + std::to_string(r.width) + "x" + std::to_string(r.height) + ")");
  r.type = asFloat ? OIIO::TypeDesc(OIIO::TypeDesc::FLOAT) : spec.format;
  r.data.resize(size_t(r.width) * r.height * r.channels * r.type.size());
  if (!in->read_image(0, 0, 0, r.channels, r.type, r.data.data())) {
    std::string err = oneLineError(in->geterror());
    throw InputError(path, "cannot decode image" + (err.empty() ? std::string() : ": " + err));
  }
  // Else the comparison would be of a grey lower part.
  refuseDamagedJpeg(path, r.format, in->geterror(), "the JPEG", "export it again from its source");
  in->close();
  return r;
}

// Copies channels idx (3, or 1 repeated) of an interleaved raw buffer into an RGB cv::Mat.
template <class T>
cv::Mat gatherRgb(const RawImage& r, const int idx[3], int cvDepth) {
  cv::Mat m(r.height, r.width, CV_MAKETYPE(cvDepth, 3));
  const T* src = reinterpret_cast<const T*>(r.data.data());
  for (int y = 0; y < r.height; ++y) {
    T* d = m.ptr<T>(y);
    const T* s = src + size_t(y) * r.width * r.channels;
    for (int x = 0; x < r.width; ++x)
      for (int c = 0; c < 3; ++c) d[3 * x + c] = s[size_t(x) * r.channels + idx[c]];
  }
  return m;
}

// ---------------------------------------------------------------------------------------------
// Drawing helpers (8-bit BGR canvases; Hershey fonts have no Greek letters, hence "dE").

cv::Scalar bgr(const cv::Vec3b& rgb) { return cv::Scalar(rgb[2], rgb[1], rgb[0]); }

void text(cv::Mat& img, const std::string& s, cv::Point org, double scale, cv::Scalar color, int thick = 1) {
  cv::putText(img, s, org, cv::FONT_HERSHEY_SIMPLEX, scale, color, thick, cv::LINE_AA);
}

double fitScale(const std::string& s, double scale, int maxWidth, int thick) {
  int base = 0;
  while (scale > 0.2 && cv::getTextSize(s, cv::FONT_HERSHEY_SIMPLEX, scale, thick, &base).width > maxWidth) scale *= 0.9;
  return scale;
}

std::string metricLabel(const MetricOptions& m) {
  std::string name = m.metric == SpatialMetric::Cielab ? "CIELAB" : m.metric == SpatialMetric::Scielab ? "S-CIELAB" : "YCxCz/Lab";
  std::string de = m.deltaE == color::DeltaE::CIE76 ? "dE76" : m.deltaE == color::DeltaE::CIE94 ? "dE94" : "dE00";
  return name + " " + de;
}

// ---------------------------------------------------------------------------------------------
// Output staging: all files of one comparison are written into a hidden folder inside the output
// folder, then moved into place (report.json last, as the completion mark).

using Writer = std::function<void(const fs::path&)>;

// `stale`: outputs of an earlier run that this run does not write (removed with the old report).
void writeStaged(const fs::path& outDir, const std::vector<std::pair<std::string, Writer>>& files,
                 const std::vector<std::string>& stale) {
  std::error_code ec;
  bool created = false;
  if (!fs::exists(outDir, ec)) {
    fs::create_directories(outDir, ec);
    if (ec) throw InputError(outDir.string(), "cannot create the output folder: " + ec.message());
    created = true;
  } else if (!fs::is_directory(outDir, ec)) {
    throw InputError(outDir.string(), "exists and is not a folder");
  }
  const fs::path stage = outDir / (".compare-tmp-" + std::to_string(::getpid()));
  auto cleanup = [&] {
    std::error_code e2;
    fs::remove_all(stage, e2);
    if (created && fs::is_empty(outDir, e2)) fs::remove(outDir, e2);
  };
  try {
    fs::remove_all(stage, ec);
    fs::create_directories(stage);
    // All but the last file (report.json) are independent: encode them concurrently. An exception
    // in any of them is rethrown here (the first in list order).
    const int n = int(files.size());
    // A writer's I/O failure names the file it was to be.
    auto writeOne = [&](int i) {
      try {
        files[i].second(stage / files[i].first);
      } catch (const InputError&) {
        throw;
      } catch (const std::runtime_error& e) {
        throwWriteError(outDir / files[i].first, e.what());
      }
    };
    std::vector<std::exception_ptr> errors(n);
    cv::parallel_for_(cv::Range(0, n - 1), [&](const cv::Range& r) {
      for (int i = r.start; i < r.end; ++i) {
        try {
          writeOne(i);
        } catch (...) {
          errors[i] = std::current_exception();
        }
      }
    }, n - 1);
    for (const auto& e : errors)
      if (e) std::rethrow_exception(e);
    writeOne(n - 1);
    // The old completion mark goes first, so that a reader never pairs it with new files.
    fs::remove(outDir / "report.json", ec);
    for (const std::string& name : stale) fs::remove(outDir / name, ec);
    for (const auto& [name, write] : files) fs::rename(stage / name, outDir / name);
    fs::remove_all(stage);
  } catch (const InputError&) {
    cleanup();
    throw;
  } catch (const std::runtime_error& e) {  // a file that could not be written, a full disk
    cleanup();
    throwWriteError(outDir, e.what());
  } catch (...) {
    cleanup();
    throw;
  }
}

void writePng(const fs::path& p, const cv::Mat& bgr8) {
  if (bgr8.type() != CV_8UC3) throw std::logic_error("compare's writePng: expected an 8-bit BGR image");
  writePngBgr8(p.string(), bgr8.ptr<uint8_t>(0), bgr8.cols, bgr8.rows, bgr8.step);
}

void writeDeltaEExr(const fs::path& p, const cv::Mat& dE, const cv::Mat& valid, const json& meta) {
  const int W = dE.cols, H = dE.rows;
  std::vector<float> px(size_t(W) * H * 2);
  for (int y = 0; y < H; ++y) {
    const float* d = dE.ptr<float>(y);
    const uint8_t* v = valid.ptr<uint8_t>(y);
    for (int x = 0; x < W; ++x) {
      px[(size_t(y) * W + x) * 2] = v[x] ? d[x] : 0.f;
      px[(size_t(y) * W + x) * 2 + 1] = v[x] ? 1.f : 0.f;
    }
  }
  OIIO::ImageSpec spec(W, H, 2, OIIO::TypeDesc::FLOAT);
  spec.channelnames = {"Y", "A"};
  spec.alpha_channel = 1;
  spec.attribute("compression", "zip");
  spec.attribute("Software", std::string("defectgen ") + DEFECTGEN_VERSION);
  spec.attribute("ImageDescription", meta.dump());
  auto out = OIIO::ImageOutput::create(p.string());
  if (!out || !out->open(p.string(), spec)) throw std::runtime_error("cannot write " + p.string() + ": " + OIIO::geterror());
  if (!out->write_image(OIIO::TypeDesc::FLOAT, px.data()))
    throw std::runtime_error("cannot write " + p.string() + ": " + out->geterror());
  out->close();
}

json homographyJson(const cv::Matx33d& H) {
  json j = json::array();
  for (int r = 0; r < 3; ++r) j.push_back({H(r, 0), H(r, 1), H(r, 2)});
  return j;
}

std::string absPath(const std::string& p) {
  if (p.empty()) return p;
  std::error_code ec;
  fs::path a = fs::absolute(p, ec);
  return (ec ? fs::path(p) : a).lexically_normal().string();
}

const char* modeName(RegistrationMode m) {
  return m == RegistrationMode::None ? "none" : m == RegistrationMode::Auto ? "auto" : "points";
}

// ---------------------------------------------------------------------------------------------
// CSV for batch mode.

std::vector<std::string> splitCsv(const std::string& line, const std::string& file, int lineNo) {
  std::vector<std::string> out;
  std::string cur;
  for (size_t i = 0; i <= line.size(); ++i) {
    if (i == line.size() || line[i] == ',') {
      size_t a = cur.find_first_not_of(" \t\r"), b = cur.find_last_not_of(" \t\r");
      out.push_back(a == std::string::npos ? std::string() : cur.substr(a, b - a + 1));
      cur.clear();
    } else if (line[i] == '"') {
      throw InputError(file, lineNo, int(i) + 1, "quoted fields are not supported; paths must not contain commas");
    } else {
      cur += line[i];
    }
  }
  return out;
}

std::string csvField(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

}  // namespace

// ---------------------------------------------------------------------------------------------

cv::Mat toDisplay8(const cv::Mat& rgb) {
  cv::Mat out;
  if (rgb.depth() == CV_8U) return rgb.clone();
  if (rgb.depth() == CV_16U) {
    rgb.convertTo(out, CV_8U, 1.0 / 257.0);
    return out;
  }
  static const std::vector<uint8_t> lut = [] {
    std::vector<uint8_t> t(65536);
    for (int i = 0; i < 65536; ++i) t[i] = uint8_t(std::lround(color::srgbEncode(i / 65535.0) * 255.0));
    return t;
  }();
  out.create(rgb.size(), CV_MAKETYPE(CV_8U, rgb.channels()));
  for (int y = 0; y < rgb.rows; ++y) {
    const float* p = rgb.ptr<float>(y);
    uint8_t* o = out.ptr<uint8_t>(y);
    for (int i = 0; i < rgb.cols * rgb.channels(); ++i) {
      float v = std::isnan(p[i]) ? 0.f : std::clamp(p[i], 0.f, 1.f);
      o[i] = lut[size_t(std::lround(v * 65535.0f))];
    }
  }
  return out;
}

ColorImage readColorImage(const std::string& path) {
  // Peek at the format first to decide between integer (sRGB) and float (linear) reading.
  std::string format;
  {
    std::error_code ec;
    if (!fs::exists(path, ec)) throw InputError(path, "file not found");
    QuietStderr quiet;
    auto in = OIIO::ImageInput::open(path);
    if (!in) {
      std::string err = oneLineError(OIIO::geterror());
      throw InputError(path, "cannot read image" + (err.empty() ? std::string() : ": " + err));
    }
    format = in->format_name();
  }
  static const std::set<std::string> known = {"png", "jpeg", "tiff", "openexr"};
  if (!known.count(format))
    throw InputError(path, "unsupported image format '" + format + "'; expected PNG, JPEG, TIFF or EXR");
  const bool exr = format == "openexr";
  RawImage r = readRaw(path, exr);
  ColorImage img;
  img.path = path;
  int idx[3] = {0, 1, 2};
  if (exr) {
    auto find = [&](const std::string& n) {
      auto it = std::find(r.names.begin(), r.names.end(), n);
      return it == r.names.end() ? -1 : int(it - r.names.begin());
    };
    int R = find("R"), G = find("G"), B = find("B"), Y = find("Y");
    if (R >= 0 && G >= 0 && B >= 0) {
      idx[0] = R, idx[1] = G, idx[2] = B;
    } else if (Y >= 0) {
      idx[0] = idx[1] = idx[2] = Y;
    } else if (r.channels == 1) {
      idx[0] = idx[1] = idx[2] = 0;
    } else {
      std::string names;
      for (auto& n : r.names) names += (names.empty() ? "" : ", ") + n;
      throw InputError(path, "EXR has no R, G, B or Y channels (it has " + names + ")");
    }
    img.rgb = gatherRgb<float>(r, idx, CV_32F);
    img.encoding = "linear float";
    // Non-finite samples would poison the filters; reject them with the first location.
    for (int y = 0; y < img.rgb.rows; ++y) {
      const float* p = img.rgb.ptr<float>(y);
      for (int x = 0; x < img.rgb.cols * 3; ++x)
        if (!std::isfinite(p[x]))
          throw InputError(path, "EXR has a non-finite value at pixel (" + std::to_string(x / 3) + ", " +
                                     std::to_string(y) + ")");
    }
    return img;
  }
  if (r.channels == 1 || r.channels == 2) {
    idx[0] = idx[1] = idx[2] = 0;
  } else if (r.channels > 4) {
    throw InputError(path, "expected 1 to 4 channels (grey, grey+alpha, RGB, RGBA), got " + std::to_string(r.channels));
  }
  if (r.type == OIIO::TypeDesc::UINT8) {
    img.rgb = gatherRgb<uint8_t>(r, idx, CV_8U);
    img.encoding = "sRGB 8-bit";
  } else if (r.type == OIIO::TypeDesc::UINT16) {
    img.rgb = gatherRgb<uint16_t>(r, idx, CV_16U);
    img.encoding = "sRGB 16-bit";
  } else {
    throw InputError(path, std::string("unsupported sample type '") + r.type.c_str() +
                               "'; PNG, JPEG and TIFF inputs must be 8 or 16 bit sRGB (use EXR for linear float)");
  }
  return img;
}

cv::Mat readMaskImage(const std::string& path, cv::Size expected) {
  RawImage r = readRaw(path, true);
  if (r.width != expected.width || r.height != expected.height)
    throw InputError(path, "mask is " + std::to_string(r.width) + "x" + std::to_string(r.height) +
                               ", the reference image is " + std::to_string(expected.width) + "x" +
                               std::to_string(expected.height));
  cv::Mat m(r.height, r.width, CV_8U);
  const float* p = reinterpret_cast<const float*>(r.data.data());
  for (int y = 0; y < r.height; ++y)
    for (int x = 0; x < r.width; ++x) {
      bool on = false;
      for (int c = 0; c < r.channels; ++c) on = on || p[(size_t(y) * r.width + x) * r.channels + c] != 0.f;
      m.at<uint8_t>(y, x) = on ? 255 : 0;
    }
  return m;
}

double samplesPerDegreeFromPitch(double pitchMm, double distanceMm) {
  const double deg = std::atan(pitchMm / distanceMm) * 180.0 / 3.14159265358979323846;
  return 1.0 / deg;
}

ViewingGeometry resolveViewingGeometry(double spd, double dpi, double pitch, double dist) {
  auto given = [](double v) { return !std::isnan(v); };
  auto positive = [](const char* name, double v) {
    if (!(v > 0) || !std::isfinite(v)) {
      std::ostringstream s;
      s << v;  // as the user wrote it ("0", "-3"), not in fixed notation
      throw InputError(name, "must be a positive number, got " + s.str());
    }
  };
  const int forms = int(given(spd)) + int(given(dpi)) + int(given(pitch));
  if (forms > 1)
    throw InputError("--samples-per-degree/--dpi/--pixel-pitch-mm", "give only one of them");
  ViewingGeometry g;
  if (given(spd)) {
    if (given(dist)) throw InputError("--distance-mm", "goes with --dpi or --pixel-pitch-mm, not --samples-per-degree");
    positive("--samples-per-degree", spd);
    g.samplesPerDegree = spd;
    g.description = fmt(spd, 3) + " samples/degree (given)";
  } else if (given(dpi) || given(pitch)) {
    if (!given(dist))
      throw InputError(given(dpi) ? "--dpi" : "--pixel-pitch-mm", "needs --distance-mm (the viewing distance)");
    positive("--distance-mm", dist);
    if (given(dpi)) {
      positive("--dpi", dpi);
      g.samplesPerDegree = samplesPerDegreeFromPitch(25.4 / dpi, dist);
      g.description = fmt(dpi, 2) + " dpi at " + fmt(dist, 1) + " mm";
    } else {
      positive("--pixel-pitch-mm", pitch);
      g.samplesPerDegree = samplesPerDegreeFromPitch(pitch, dist);
      g.description = "pixel pitch " + fmt(pitch, 5) + " mm at " + fmt(dist, 1) + " mm";
    }
  } else {
    if (given(dist)) throw InputError("--distance-mm", "needs --dpi or --pixel-pitch-mm");
    g.samplesPerDegree = samplesPerDegreeFromPitch(25.4 / 72.0, 18 * 25.4);
    g.description = "72 dpi at 18 in (457.2 mm), the default (Bosch 2007, appendix A)";
  }
  if (g.samplesPerDegree < 2 || g.samplesPerDegree > 600)
    throw InputError("viewing geometry", g.description + " gives " + fmt(g.samplesPerDegree, 2) +
                                             " samples/degree; supported range is 2 to 600");
  return g;
}

DeltaEStats computeStats(const cv::Mat& dE, const cv::Mat& include) {
  CV_Assert(dE.type() == CV_32F && include.type() == CV_8U && dE.size() == include.size());
  // Exact order statistics without sorting 10^7 values: Delta E >= 0, so the bit patterns of the
  // floats order like the values. Pass 1 counts the values per top-16-bit bucket (and the sums);
  // pass 2 collects only the buckets holding the ranks asked for and sorts those. Per-band partial
  // results are merged in band order, so the numbers do not depend on the thread count.
  constexpr int kBuckets = 1 << 16;
  const int rows = dE.rows;
  const int nb = std::clamp((rows + 127) / 128, 1, 256);
  struct Part {
    std::vector<uint32_t> hist;
    double sum = 0, max = 0;
    int64_t n = 0, n2 = 0, n5 = 0, n10 = 0;
  };
  std::vector<Part> parts(nb);
  auto key = [](float f) {
    uint32_t u;
    std::memcpy(&u, &f, 4);
    return u;
  };
  cv::parallel_for_(cv::Range(0, nb), [&](const cv::Range& r) {
    for (int b = r.start; b < r.end; ++b) {
      Part& p = parts[b];
      p.hist.assign(kBuckets, 0);
      const int y0 = int(int64_t(b) * rows / nb), y1 = int(int64_t(b + 1) * rows / nb);
      for (int y = y0; y < y1; ++y) {
        const float* d = dE.ptr<float>(y);
        const uint8_t* m = include.ptr<uint8_t>(y);
        for (int x = 0; x < dE.cols; ++x) {
          if (!m[x]) continue;
          const float v = std::max(d[x], 0.0f);
          p.sum += v;
          p.max = std::max(p.max, double(v));
          ++p.n;
          p.n2 += v >= 2.f;
          p.n5 += v >= 5.f;
          p.n10 += v >= 10.f;
          ++p.hist[key(v) >> 16];
        }
      }
    }
  });
  DeltaEStats s;
  std::vector<int64_t> hist(kBuckets, 0);
  double sum = 0;
  int64_t n2 = 0, n5 = 0, n10 = 0;
  for (const Part& p : parts) {
    s.pixels += p.n;
    sum += p.sum;
    s.max = std::max(s.max, p.max);
    n2 += p.n2, n5 += p.n5, n10 += p.n10;
    for (int i = 0; i < kBuckets; ++i) hist[i] += p.hist[i];
  }
  if (s.pixels == 0) return s;
  const double n = double(s.pixels);
  s.mean = sum / n;
  s.pctGe2 = 100.0 * n2 / n;
  s.pctGe5 = 100.0 * n5 / n;
  s.pctGe10 = 100.0 * n10 / n;
  // Ranks needed: floor(q (n - 1)) and the next one, for q = 0.5, 0.95, 0.99.
  const double qs[3] = {0.5, 0.95, 0.99};
  std::vector<int64_t> ranks;
  for (double q : qs) {
    const int64_t lo = int64_t(std::floor(q * (n - 1)));
    ranks.push_back(lo);
    ranks.push_back(std::min<int64_t>(lo + 1, s.pixels - 1));
  }
  std::vector<int64_t> start(kBuckets + 1, 0);
  for (int i = 0; i < kBuckets; ++i) start[i + 1] = start[i] + hist[i];
  std::map<int, std::vector<float>> wanted;  // bucket -> its values
  for (int64_t k : ranks) wanted[int(std::upper_bound(start.begin(), start.end(), k) - start.begin()) - 1];
  for (int y = 0; y < rows; ++y) {
    const float* d = dE.ptr<float>(y);
    const uint8_t* m = include.ptr<uint8_t>(y);
    for (int x = 0; x < dE.cols; ++x) {
      if (!m[x]) continue;
      const float v = std::max(d[x], 0.0f);
      auto it = wanted.find(int(key(v) >> 16));
      if (it != wanted.end()) it->second.push_back(v);
    }
  }
  for (auto& [bucket, vals] : wanted) std::sort(vals.begin(), vals.end());
  auto order = [&](int64_t k) {
    const int bucket = int(std::upper_bound(start.begin(), start.end(), k) - start.begin()) - 1;
    return double(wanted[bucket][size_t(k - start[bucket])]);
  };
  double q[3];
  for (int i = 0; i < 3; ++i) {
    const double pos = qs[i] * (n - 1);
    const double a = order(ranks[2 * i]), b = order(ranks[2 * i + 1]);
    q[i] = a + (pos - std::floor(pos)) * (b - a);
  }
  s.median = q[0];
  s.p95 = q[1];
  s.p99 = q[2];
  return s;
}

json statsJson(const DeltaEStats& s) {
  return {{"pixels", s.pixels}, {"mean", s.mean},       {"median", s.median},     {"p95", s.p95},
          {"p99", s.p99},       {"max", s.max},         {"pct_ge_2", s.pctGe2}, {"pct_ge_5", s.pctGe5},
          {"pct_ge_10", s.pctGe10}};
}

CompareResult compareImages(const ColorImage& ref, const ColorImage& test, const CompareOptions& opt,
                            const cv::Mat& mask) {
  if (!mask.empty() && mask.size() != ref.rgb.size())
    throw InputError("mask", "mask size differs from the reference image");
  CompareResult r;
  auto t0 = std::chrono::steady_clock::now();
  try {
    r.registration = registerImages(ref.rgb, test.rgb, opt.registration);
  } catch (const InputError& e) {
    if (!e.file().empty()) throw;
    throw InputError(test.path, std::string(e.what()) + " (reference " + ref.path + ")");
  }
  auto t1 = std::chrono::steady_clock::now();
  MetricOptions m = opt.metric;
  m.samplesPerDegree = opt.viewing.samplesPerDegree > 0 ? opt.viewing.samplesPerDegree : m.samplesPerDegree;
  r.deltaE = deltaEMap(ref.rgb, r.registration.warpedTest, m);
  auto t2 = std::chrono::steady_clock::now();
  r.valid = r.registration.valid;
  r.deltaE.setTo(0, r.valid == 0);
  r.all = computeStats(r.deltaE, r.valid);
  if (!mask.empty()) {
    r.mask = mask;
    cv::Mat in, out;
    cv::bitwise_and(r.valid, mask, in);
    cv::bitwise_and(r.valid, ~mask, out);
    r.inside = computeStats(r.deltaE, in);
    r.outside = computeStats(r.deltaE, out);
  }
  r.registrationSeconds = seconds(t0, t1);
  r.metricSeconds = seconds(t1, t2);
  return r;
}

cv::Vec3b falseColorRgb(double dE) {
  const double t = std::clamp(std::isnan(dE) ? 0.0 : dE / 20.0, 0.0, 1.0);
  auto u8 = [](double v) { return uint8_t(std::lround(std::clamp(v, 0.0, 255.0))); };
  if (t <= 0.5) return {0, u8(510 * t), u8(255 * (1 - 2 * t))};
  return {u8(255 * (2 * t - 1)), u8(255 * (2 - 2 * t)), 0};
}

cv::Mat falseColorImage(const cv::Mat& dE, const cv::Mat& valid, const std::string& label) {
  // Maps under 240 pixels high are enlarged by an integer factor (nearest neighbour) so that the
  // legend stays legible; the EXR keeps the data at the reference's resolution.
  const int k = dE.rows >= 240 ? 1 : (240 + dE.rows - 1) / dE.rows;
  const int H = dE.rows * k, W = dE.cols * k;
  const int canvasH = std::max(H, 240);
  const int panelW = std::clamp(canvasH / 4, 100, 420);
  cv::Mat canvas(canvasH, W + panelW, CV_8UC3, cv::Scalar(0, 0, 0));
  // The map: a 256-entry table over [0, 20].
  cv::Vec3b table[257];
  for (int i = 0; i <= 256; ++i) {
    cv::Vec3b c = falseColorRgb(20.0 * i / 256.0);
    table[i] = {c[2], c[1], c[0]};
  }
  cv::Mat map(dE.size(), CV_8UC3, cv::Scalar(0, 0, 0));
  for (int y = 0; y < dE.rows; ++y) {
    const float* d = dE.ptr<float>(y);
    const uint8_t* v = valid.ptr<uint8_t>(y);
    cv::Vec3b* o = map.ptr<cv::Vec3b>(y);
    for (int x = 0; x < dE.cols; ++x)
      if (v[x]) o[x] = table[int(std::lround(std::clamp(double(d[x]), 0.0, 20.0) / 20.0 * 256.0))];
  }
  if (k > 1)
    cv::resize(map, canvas(cv::Rect(0, 0, W, H)), cv::Size(W, H), 0, 0, cv::INTER_NEAREST);
  else
    map.copyTo(canvas(cv::Rect(0, 0, W, H)));
  // Legend panel.
  cv::Mat panel = canvas(cv::Rect(W, 0, panelW, canvasH));
  panel.setTo(cv::Scalar(48, 48, 48));
  const double fs = std::clamp(canvasH / 600.0, 0.35, 2.0);
  const int th = std::max(1, int(std::lround(fs * 1.6)));
  const int top = int(canvasH * 0.20), bottom = int(canvasH * 0.95);
  const int barX0 = int(panelW * 0.10), barX1 = int(panelW * 0.34);
  for (int y = top; y <= bottom; ++y) {
    double v = 20.0 * (bottom - y) / double(bottom - top);
    cv::line(panel, {barX0, y}, {barX1, y}, bgr(falseColorRgb(v)), 1);
  }
  cv::rectangle(panel, {barX0, top}, {barX1, bottom}, cv::Scalar(220, 220, 220), 1);
  for (int tick : {0, 5, 10, 15, 20}) {
    int y = bottom - int(std::lround((bottom - top) * tick / 20.0));
    cv::line(panel, {barX1, y}, {barX1 + int(panelW * 0.06), y}, cv::Scalar(220, 220, 220), th);
    std::string s = tick == 20 ? ">=20" : std::to_string(tick);
    double sc = fitScale(s, fs, panelW - barX1 - int(panelW * 0.10), th);
    text(panel, s, {barX1 + int(panelW * 0.09), y + int(8 * sc)}, sc, cv::Scalar(235, 235, 235), th);
  }
  // Title: metric on two lines ("S-CIELAB", "dE76").
  size_t sp = label.rfind(' ');
  std::string l1 = sp == std::string::npos ? label : label.substr(0, sp);
  std::string l2 = sp == std::string::npos ? std::string() : label.substr(sp + 1);
  double s1 = fitScale(l1, fs, panelW - 8, th), s2 = fitScale(l2, fs, panelW - 8, th);
  text(panel, l1, {4, int(canvasH * 0.04) + int(22 * s1)}, s1, cv::Scalar(255, 255, 255), th);
  if (!l2.empty()) text(panel, l2, {4, int(canvasH * 0.04) + int(52 * s2)}, s2, cv::Scalar(255, 255, 255), th);
  return canvas;
}

cv::Mat overlayImage(const cv::Mat& refRgb, const cv::Mat& dE, const cv::Mat& valid, const cv::Mat& mask,
                     double threshold) {
  cv::Mat disp = toDisplay8(refRgb), grey;
  cv::cvtColor(disp, grey, cv::COLOR_RGB2GRAY);
  cv::Mat out(dE.size(), CV_8UC3);
  for (int y = 0; y < dE.rows; ++y) {
    const float* d = dE.ptr<float>(y);
    const uint8_t* v = valid.ptr<uint8_t>(y);
    const uint8_t* g = grey.ptr<uint8_t>(y);
    cv::Vec3b* o = out.ptr<cv::Vec3b>(y);
    for (int x = 0; x < dE.cols; ++x) {
      if (!v[x]) {
        uint8_t c = uint8_t(g[x] / 4);
        o[x] = {c, c, c};
      } else if (d[x] >= threshold) {
        o[x] = {0, 0, 255};
      } else {
        uint8_t c = uint8_t(g[x] * 3 / 5);
        o[x] = {c, c, c};
      }
    }
  }
  if (!mask.empty()) {
    std::vector<std::vector<cv::Point>> contours;
    cv::findContours(mask.clone(), contours, cv::RETR_LIST, cv::CHAIN_APPROX_NONE);
    cv::drawContours(out, contours, -1, cv::Scalar(0, 230, 255), std::max(1, dE.rows / 600));
  }
  return out;
}

cv::Mat histogramImage(const CompareResult& r, const std::string& label) {
  const int W = 960, H = 540, ml = 80, mr = 30, mt = 70, mb = 70;
  cv::Mat img(H, W, CV_8UC3, cv::Scalar(32, 32, 32));
  constexpr int kBins = 41;  // 40 bins of 0.5 on [0, 20), one for >= 20
  auto histogram = [&](const cv::Mat& include, int64_t& n) {
    std::vector<double> h(kBins, 0.0);
    n = 0;
    for (int y = 0; y < r.deltaE.rows; ++y) {
      const float* d = r.deltaE.ptr<float>(y);
      const uint8_t* m = include.ptr<uint8_t>(y);
      for (int x = 0; x < r.deltaE.cols; ++x)
        if (m[x]) {
          int b = d[x] >= 20.f ? kBins - 1 : std::max(0, int(d[x] * 2.f));
          h[b] += 1;
          ++n;
        }
    }
    for (double& v : h) v = n ? 100.0 * v / n : 0.0;
    return h;
  };
  int64_t nAll = 0, nIn = 0;
  std::vector<double> hAll = histogram(r.valid, nAll), hIn;
  if (!r.mask.empty()) {
    cv::Mat in;
    cv::bitwise_and(r.valid, r.mask, in);
    hIn = histogram(in, nIn);
  }
  double peak = 0;
  for (double v : hAll) peak = std::max(peak, v);
  for (double v : hIn) peak = std::max(peak, v);
  // A "nice" top of the y axis: 1, 2 or 5 times a power of ten.
  double top = 1;
  if (peak > 0) {
    double p10 = std::pow(10.0, std::floor(std::log10(peak)));
    top = peak <= p10 ? p10 : peak <= 2 * p10 ? 2 * p10 : peak <= 5 * p10 ? 5 * p10 : 10 * p10;
  }
  const int px0 = ml, px1 = W - mr, py0 = mt, py1 = H - mb;
  const double bw = double(px1 - px0) / kBins;
  auto xAt = [&](double dEv) { return px0 + int(std::lround(dEv * 2 * bw)); };
  auto yAt = [&](double pct) { return py1 - int(std::lround((py1 - py0) * pct / top)); };
  // Grid and y labels.
  for (int i = 0; i <= 4; ++i) {
    double pct = top * i / 4;
    int y = yAt(pct);
    cv::line(img, {px0, y}, {px1, y}, cv::Scalar(70, 70, 70), 1);
    std::ostringstream s;
    s << pct << "%";
    text(img, s.str(), {8, y + 5}, 0.45, cv::Scalar(220, 220, 220));
  }
  for (int b = 0; b < kBins; ++b) {
    int x0 = px0 + int(std::lround(b * bw)) + 1, x1 = px0 + int(std::lround((b + 1) * bw)) - 1;
    double centre = b == kBins - 1 ? 20.0 : 0.25 + 0.5 * b;
    cv::rectangle(img, {x0, yAt(hAll[b])}, {x1, py1}, bgr(falseColorRgb(centre)), cv::FILLED);
  }
  if (!hIn.empty()) {
    std::vector<cv::Point> pts;
    for (int b = 0; b < kBins; ++b) pts.push_back({px0 + int(std::lround((b + 0.5) * bw)), yAt(hIn[b])});
    cv::polylines(img, pts, false, cv::Scalar(255, 255, 255), 2, cv::LINE_AA);
  }
  // Thresholds 2, 5, 10 as dashed lines with the share of pixels at or above them.
  const double pct[3] = {r.all.pctGe2, r.all.pctGe5, r.all.pctGe10};
  const int thr[3] = {2, 5, 10};
  for (int i = 0; i < 3; ++i) {
    int x = xAt(thr[i]);
    for (int y = py0; y < py1; y += 10) cv::line(img, {x, y}, {x, std::min(py1, y + 5)}, cv::Scalar(200, 200, 200), 1);
    text(img, ">=" + std::to_string(thr[i]) + ": " + fmt(pct[i], 2) + "%", {x + 4, py0 + 16 + 18 * i}, 0.45,
         cv::Scalar(230, 230, 230));
  }
  cv::line(img, {px0, py1}, {px1, py1}, cv::Scalar(220, 220, 220), 1);
  for (int t : {0, 2, 5, 10, 15, 20}) {
    int x = xAt(t);
    cv::line(img, {x, py1}, {x, py1 + 6}, cv::Scalar(220, 220, 220), 1);
    text(img, t == 20 ? ">=20" : std::to_string(t), {x - 6, py1 + 24}, 0.5, cv::Scalar(220, 220, 220));
  }
  text(img, label + " per pixel", {px0 + (px1 - px0) / 2 - 90, H - 14}, 0.55, cv::Scalar(230, 230, 230));
  std::string title = label + ": " + std::to_string(nAll) + " valid px, mean " + fmt(r.all.mean, 2) + ", median " +
                      fmt(r.all.median, 2) + ", p95 " + fmt(r.all.p95, 2);
  text(img, title, {10, 26}, fitScale(title, 0.6, W - 20, 1), cv::Scalar(255, 255, 255));
  std::string sub = "bars: % of valid pixels per 0.5 bin";
  if (!hIn.empty()) sub += "; white line: inside the mask (" + std::to_string(nIn) + " px)";
  text(img, sub, {10, 50}, 0.45, cv::Scalar(200, 200, 200));
  return img;
}

json requestJson(const CompareRequest& req) {
  const auto& o = req.options;
  const bool spatial = o.metric.metric != SpatialMetric::Cielab;
  json j = {{"reference", absPath(req.reference)},
            {"test", absPath(req.test)},
            {"mask", req.maskPath.empty() ? json(nullptr) : json(absPath(req.maskPath))},
            {"metric", metricName(o.metric.metric)},
            {"delta_e", deltaEName(o.metric.deltaE)},
            {"samples_per_degree", spatial ? json(o.viewing.samplesPerDegree) : json(nullptr)},
            {"filters", o.metric.metric == SpatialMetric::Scielab ? json(filtersName(o.metric.filters)) : json(nullptr)},
            {"observer", o.metric.metric == SpatialMetric::Scielab ? json(int(o.metric.observer)) : json(nullptr)},
            {"register", modeName(o.registration.mode)},
            {"points", o.registration.mode == RegistrationMode::Points ? json(absPath(o.registration.pointsFile))
                                                                       : json(nullptr)}};
  return j;
}

json runCompare(const CompareRequest& req) {
  auto t0 = std::chrono::steady_clock::now();
  const auto& o = req.options;
  if (o.registration.mode == RegistrationMode::Points && o.registration.pointsFile.empty())
    throw InputError("--register", "points needs a FILE of point pairs");
  std::cerr << "compare: " << req.reference << " (reference) vs " << req.test << "\n";
  ColorImage ref = readColorImage(req.reference);
  ColorImage test = readColorImage(req.test);
  cv::Mat mask;
  if (!req.maskPath.empty()) mask = readMaskImage(req.maskPath, ref.rgb.size());
  std::cerr << "compare: reference " << ref.rgb.cols << "x" << ref.rgb.rows << " " << ref.encoding << ", test "
            << test.rgb.cols << "x" << test.rgb.rows << " " << test.encoding << "\n";
  CompareResult r = compareImages(ref, test, o, mask);
  const RegistrationResult& g = r.registration;
  if (g.mode != RegistrationMode::None) {
    std::cerr << "compare: registration (" << modeName(g.mode) << "): " << g.inliers << " of " << g.matches
              << (g.mode == RegistrationMode::Auto ? " matches" : " point pairs") << ", residual " << fmt(g.residualPx)
              << " px RMS, " << fmt(100 * g.validFraction, 1) << "% of the reference covered";
    if (g.eccRun) std::cerr << ", ECC " << (g.eccAccepted ? "refined (correlation " + fmt(g.eccCorrelation, 4) + ")" : g.eccNote);
    std::cerr << " [" << fmt(r.registrationSeconds, 2) << " s]\n";
    if (g.validFraction < 0.25)
      std::cerr << "compare: warning: the registered test image covers only " << fmt(100 * g.validFraction, 1)
                << "% of the reference\n";
  }
  const std::string label = metricLabel(o.metric);
  std::cerr << "compare: " << label;
  if (o.metric.metric != SpatialMetric::Cielab)
    std::cerr << " at " << fmt(o.viewing.samplesPerDegree, 2) << " samples/degree (" << o.viewing.description << ")";
  std::cerr << " [" << fmt(r.metricSeconds, 2) << " s]\n";

  json report;
  report["tool"] = std::string("defectgen ") + DEFECTGEN_VERSION + " compare";
  report["request"] = requestJson(req);
  auto imgJson = [](const ColorImage& c) {
    return json{{"path", c.path}, {"width", c.rgb.cols}, {"height", c.rgb.rows}, {"encoding", c.encoding}};
  };
  report["reference"] = imgJson(ref);
  report["test"] = imgJson(test);
  const bool spatial = o.metric.metric != SpatialMetric::Cielab;
  report["metric"] = {
      {"name", metricName(o.metric.metric)},
      {"delta_e", deltaEName(o.metric.deltaE)},
      {"samples_per_degree", spatial ? json(o.viewing.samplesPerDegree) : json(nullptr)},
      {"viewing", spatial ? json(o.viewing.description) : json(nullptr)},
      {"filters", o.metric.metric == SpatialMetric::Scielab ? json(filtersName(o.metric.filters)) : json(nullptr)},
      {"observer", o.metric.metric == SpatialMetric::Scielab ? json(int(o.metric.observer)) : json(nullptr)},
      {"white_xyz", {color::srgbWhiteXyz()[0], color::srgbWhiteXyz()[1], color::srgbWhiteXyz()[2]}},
      {"false_color_clamp", 20}};
  json reg = {{"mode", modeName(g.mode)},
              {"homography_test_to_reference", homographyJson(g.homography)},
              {"valid_fraction", g.validFraction}};
  if (g.mode == RegistrationMode::Auto) {
    reg["features"] = {g.features[0], g.features[1]};
    reg["matches"] = g.matches;
    reg["inliers"] = g.inliers;
    reg["ecc"] = {{"run", g.eccRun}, {"accepted", g.eccAccepted}, {"correlation", g.eccRun ? json(g.eccCorrelation) : json(nullptr)},
                  {"note", g.eccNote}};
  }
  if (g.mode == RegistrationMode::Points) reg["point_pairs"] = g.matches;
  if (g.mode != RegistrationMode::None) {
    reg["residual_rms_px"] = g.residualPx;
    reg["residual_max_px"] = g.maxResidualPx;
  }
  report["registration"] = reg;
  report["stats"] = {{"valid", statsJson(r.all)},
                     {"inside_mask", r.mask.empty() ? json(nullptr) : statsJson(r.inside)},
                     {"outside_mask", r.mask.empty() ? json(nullptr) : statsJson(r.outside)}};
  report["outputs"] = {{"delta_e", "delta_e.exr"},
                       {"false_color", "delta_e_false_color.png"},
                       {"overlay_ge10", "delta_e_ge10_overlay.png"},
                       {"histogram", "delta_e_histogram.png"},
                       {"registered_test", g.mode == RegistrationMode::None ? json(nullptr) : json("registered_test.png")}};

  std::vector<std::pair<std::string, Writer>> files;
  json exrMeta = {{"metric", report["metric"]}, {"channels", "Y = Delta E, A = 1 inside the valid region"}};
  files.push_back({"delta_e.exr", [&](const fs::path& p) { writeDeltaEExr(p, r.deltaE, r.valid, exrMeta); }});
  files.push_back({"delta_e_false_color.png", [&](const fs::path& p) { writePng(p, falseColorImage(r.deltaE, r.valid, label)); }});
  files.push_back({"delta_e_ge10_overlay.png",
                   [&](const fs::path& p) { writePng(p, overlayImage(ref.rgb, r.deltaE, r.valid, r.mask, 10.0)); }});
  files.push_back({"delta_e_histogram.png", [&](const fs::path& p) { writePng(p, histogramImage(r, label)); }});
  if (g.mode != RegistrationMode::None)
    files.push_back({"registered_test.png", [&](const fs::path& p) {
                       cv::Mat d = toDisplay8(g.warpedTest), bgrImg;
                       d.setTo(cv::Scalar::all(0), g.valid == 0);
                       cv::cvtColor(d, bgrImg, cv::COLOR_RGB2BGR);
                       writePng(p, bgrImg);
                     }});
  report["timing_s"] = {{"registration", r.registrationSeconds}, {"metric", r.metricSeconds}};
  files.push_back({"report.json", [&](const fs::path& p) {
                     report["timing_s"]["total"] = seconds(t0, std::chrono::steady_clock::now());
                     std::ofstream f(p);
                     f << report.dump(2) << "\n";
                     f.close();
                     if (!f) throw std::runtime_error("cannot write " + p.string());
                   }});
  std::vector<std::string> stale;
  if (g.mode == RegistrationMode::None) stale.push_back("registered_test.png");
  writeStaged(req.outDir, files, stale);
  std::cerr << "compare: mean " << fmt(r.all.mean, 2) << ", median " << fmt(r.all.median, 2) << ", p95 "
            << fmt(r.all.p95, 2) << ", max " << fmt(r.all.max, 2) << ", " << fmt(r.all.pctGe10, 2)
            << "% of " << r.all.pixels << " valid pixels >= 10";
  if (!r.mask.empty())
    std::cerr << "; inside the mask mean " << fmt(r.inside.mean, 2) << ", outside " << fmt(r.outside.mean, 2);
  std::cerr << "\ncompare: wrote " << req.outDir << "/ [" << fmt(seconds(t0, std::chrono::steady_clock::now()), 2)
            << " s]\n";
  return report;
}

void runComparePairs(const CompareRequest& req) {
  const std::string& csv = req.pairsCsv;
  if (!req.reference.empty() || !req.test.empty())
    throw InputError("--pairs", "give either REFERENCE TEST or --pairs CSV, not both");
  if (!req.maskPath.empty())
    throw InputError("--mask", "applies to one pair; with --pairs give masks in the CSV's mask column");
  if (req.options.registration.mode == RegistrationMode::Points)
    throw InputError("--register", "points FILE applies to one pair; with --pairs give point files in the CSV's points column");
  std::istringstream f(readTextFile(csv));  // names a missing file or a folder
  const fs::path base = fs::path(csv).parent_path();
  auto resolve = [&](const std::string& p) { return fs::path(p).is_absolute() || base.empty() ? p : (base / p).string(); };

  struct Pair {
    int line;
    std::string name, reference, test, mask, points;
  };
  std::vector<Pair> pairs;
  std::map<std::string, int> col;
  std::string line;
  int lineNo = 0;
  std::set<std::string> names;
  while (std::getline(f, line)) {
    ++lineNo;
    std::string t = line;
    if (t.find_first_not_of(" \t\r") == std::string::npos || t[t.find_first_not_of(" \t\r")] == '#') continue;
    std::vector<std::string> fields = splitCsv(line, csv, lineNo);
    if (col.empty()) {
      for (size_t i = 0; i < fields.size(); ++i) {
        static const std::set<std::string> known = {"reference", "test", "mask", "points", "name"};
        if (!known.count(fields[i]))
          throw InputError(csv, lineNo, 0,
                           "unknown column '" + fields[i] + "' in the header; expected reference, test, mask, points, name");
        if (col.count(fields[i])) throw InputError(csv, lineNo, 0, "column '" + fields[i] + "' appears twice");
        col[fields[i]] = int(i);
      }
      if (!col.count("reference") || !col.count("test"))
        throw InputError(csv, lineNo, 0, "the header must name the columns reference and test");
      continue;
    }
    if (fields.size() != col.size())
      throw InputError(csv, lineNo, 0,
                       "expected " + std::to_string(col.size()) + " fields, got " + std::to_string(fields.size()));
    auto get = [&](const char* c) { return col.count(c) ? fields[col[c]] : std::string(); };
    Pair p{lineNo, get("name"), get("reference"), get("test"), get("mask"), get("points")};
    if (p.reference.empty() || p.test.empty()) throw InputError(csv, lineNo, 0, "reference and test must not be empty");
    if (p.name.empty()) {
      std::ostringstream s;
      s << "pair_" << std::setw(3) << std::setfill('0') << (pairs.size() + 1);
      p.name = s.str();
    }
    for (char c : p.name)
      if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.'))
        throw InputError(csv, lineNo, 0, "name '" + p.name + "' may only use letters, digits, '_', '-' and '.'");
    if (p.name == "." || p.name == "..") throw InputError(csv, lineNo, 0, "name '" + p.name + "' is not allowed");
    if (!names.insert(p.name).second) throw InputError(csv, lineNo, 0, "name '" + p.name + "' is used twice");
    p.reference = resolve(p.reference);
    p.test = resolve(p.test);
    if (!p.mask.empty()) p.mask = resolve(p.mask);
    if (!p.points.empty()) p.points = resolve(p.points);
    for (const std::string* file : {&p.reference, &p.test, &p.mask, &p.points}) {
      std::error_code ec;
      if (!file->empty() && !fs::is_regular_file(*file, ec))
        throw InputError(csv, lineNo, 0, "file not found: " + *file);
    }
    pairs.push_back(p);
  }
  if (pairs.empty()) throw InputError(csv, "no pairs (a header line and at least one pair are needed)");

  std::ostringstream summary;
  summary << "name,reference,test,metric,delta_e,samples_per_degree,valid_pixels,mean,median,p95,p99,max,"
             "pct_ge_2,pct_ge_5,pct_ge_10,inside_mean,inside_pct_ge_10,outside_mean,outside_pct_ge_10,"
             "registration_residual_px\n";
  summary.precision(6);
  int done = 0;
  for (const Pair& p : pairs) {
    CompareRequest pr = req;
    pr.pairsCsv.clear();
    pr.reference = p.reference;
    pr.test = p.test;
    pr.maskPath = p.mask;
    pr.outDir = (fs::path(req.outDir) / p.name).string();
    if (!p.points.empty()) {
      pr.options.registration.mode = RegistrationMode::Points;
      pr.options.registration.pointsFile = p.points;
    }
    json report;
    const fs::path existing = fs::path(pr.outDir) / "report.json";
    std::error_code ec;
    if (fs::exists(existing, ec)) {
      try {
        json old = json::parse(readTextFile(existing));
        if (old.value("request", json()) == requestJson(pr)) report = old;
      } catch (const std::exception&) {
      }
    }
    std::cerr << "compare: pair " << (++done) << "/" << pairs.size() << " '" << p.name << "'"
              << (report.is_null() ? "" : " already complete, skipped") << "\n";
    if (report.is_null()) {
      try {
        report = runCompare(pr);
      } catch (const InputError& e) {
        throw InputError(csv, p.line, 0, "pair '" + p.name + "': " + e.what());
      }
    }
    const json& st = report["stats"];
    auto num = [](const json& j, const char* k) {
      std::ostringstream s;
      s.precision(6);
      if (j.is_null() || !j.contains(k) || j[k].is_null()) return std::string();
      s << j[k].get<double>();
      return s.str();
    };
    summary << csvField(p.name) << "," << csvField(p.reference) << "," << csvField(p.test) << ","
            << report["metric"]["name"].get<std::string>() << "," << report["metric"]["delta_e"].get<std::string>()
            << "," << num(report["metric"], "samples_per_degree") << "," << st["valid"]["pixels"].get<int64_t>() << ","
            << num(st["valid"], "mean") << "," << num(st["valid"], "median") << "," << num(st["valid"], "p95") << ","
            << num(st["valid"], "p99") << "," << num(st["valid"], "max") << "," << num(st["valid"], "pct_ge_2") << ","
            << num(st["valid"], "pct_ge_5") << "," << num(st["valid"], "pct_ge_10") << ","
            << num(st["inside_mask"], "mean") << "," << num(st["inside_mask"], "pct_ge_10") << ","
            << num(st["outside_mask"], "mean") << "," << num(st["outside_mask"], "pct_ge_10") << ","
            << num(report["registration"], "residual_rms_px") << "\n";
  }
  writeTextAtomically(fs::path(req.outDir) / "summary.csv", summary.str());
  std::cerr << "compare: wrote " << (fs::path(req.outDir) / "summary.csv").string() << " (" << pairs.size()
            << " pairs)\n";
}

}  // namespace dg
