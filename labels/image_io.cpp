// Image writers: sRGB-encoded PNGs through OpenCV's PNG codec, linear float EXRs through
// OpenImageIO. Identical input gives byte-identical files: OpenCV's PNG encoder writes no tIME
// chunk, and for EXR we pin the capture date (see kExrFixedDateTime) because OpenImageIO's EXR
// writer otherwise stamps the current local time into the header.
#include "labels/image_io.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string>

#include <OpenImageIO/imageio.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/rng.h"

namespace dg {

namespace {

// OpenImageIO's OpenEXR writer fills "DateTime" (EXR attribute capDate) with the wall-clock time
// when the spec lacks one, so two runs would differ. An empty value still writes an (ill-formed)
// empty capDate, so we write a fixed, well-formed placeholder instead: the Unix epoch, in EXR's
// "YYYY:MM:DD hh:mm:ss" form. It marks "no capture date", not a real one.
constexpr const char* kExrFixedDateTime = "1970:01:01 00:00:00";

// Clamps to [0, 1]; NaN goes to 0 so that a stray NaN radiance writes black, not garbage.
double clamp01(double v) {
  if (!(v > 0.0)) return 0.0;
  return v < 1.0 ? v : 1.0;
}

}  // namespace

// IEC 61966-2-1:1999 (sRGB), section 5.2: linear segment of slope 12.92 below 0.0031308,
// otherwise 1.055 * L^(1/2.4) - 0.055. Evaluated in double, so the 8- and 16-bit quantisation
// below does not inherit float pow error.
float linearToSrgb(float v) {
  double l = clamp01(v);
  double s = l <= 0.0031308 ? 12.92 * l : 1.055 * std::pow(l, 1.0 / 2.4) - 0.055;
  return float(s);
}

// Inverse of the above (same standard): V / 12.92 below 0.04045, else ((V + 0.055) / 1.055)^2.4.
float srgbToLinear(float v) {
  double s = clamp01(v);
  double l = s <= 0.04045 ? s / 12.92 : std::pow((s + 0.055) / 1.055, 2.4);
  return float(l);
}

namespace {

void requireRgb(const ImageF& img, const char* who) {
  if (img.channels != 3 || img.width <= 0 || img.height <= 0 ||
      img.data.size() != size_t(img.width) * img.height * 3)
    throw std::logic_error(std::string(who) + ": expected a non-empty 3-channel linear RGB image, got " +
                           std::to_string(img.width) + "x" + std::to_string(img.height) + "x" +
                           std::to_string(img.channels));
}

template <class T>
void requireGray(const Image<T>& img, const char* who) {
  if (img.channels != 1 || img.width <= 0 || img.height <= 0 ||
      img.data.size() != size_t(img.width) * img.height)
    throw std::logic_error(std::string(who) + ": expected a non-empty single-channel image, got " +
                           std::to_string(img.width) + "x" + std::to_string(img.height) + "x" +
                           std::to_string(img.channels));
}

// Encodes as PNG in memory and writes the bytes ourselves: the format then does not depend on the
// file name's extension (callers write to temporary names), and write errors are reported with
// the OS reason.
void writePng(const std::string& path, const cv::Mat& m) {
  std::vector<uchar> bytes;
  // Fixed zlib level so output bytes do not depend on OpenCV's default; 3 trades little size for
  // much speed on the large, smooth renders and the mostly-empty masks.
  const std::vector<int> params = {cv::IMWRITE_PNG_COMPRESSION, 3};
  bool ok = false;
  try {
    ok = cv::imencode(".png", m, bytes, params);
  } catch (const cv::Exception& e) {
    throw std::runtime_error("cannot encode PNG for " + path + ": " + e.what());
  }
  if (!ok) throw std::runtime_error("cannot encode PNG for " + path);
  // The path is the caller's to name (writeAtomically names the final one, not this temporary).
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  if (!f) throw std::runtime_error(std::string("cannot open it for writing: ") + std::strerror(errno));
  f.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  f.close();
  if (!f) throw std::runtime_error(std::strerror(errno));
}

// Linear RGB (float) -> sRGB-encoded BGR (OpenCV's channel order), rounded to nearest, or with
// `dither_key` dithered (writePngRgb8).
template <class T>
cv::Mat toSrgbBgr(const ImageF& img, int cv_type, double scale, const uint64_t* dither_key = nullptr) {
  cv::Mat m(img.height, img.width, cv_type);
  for (int y = 0; y < img.height; ++y) {
    T* row = m.ptr<T>(y);
    for (int x = 0; x < img.width; ++x) {
      const float* p = img.at(x, y);
      for (int c = 0; c < 3; ++c) {
        const double u = dither_key ? double(hashKey(*dither_key, uint64_t(y), uint64_t(x), uint64_t(c)) >> 11) * 0x1p-53
                                    : 0.5;
        double q = std::min(std::floor(double(linearToSrgb(p[c])) * scale + u), scale);
        row[3 * x + (2 - c)] = T(q);  // R,G,B -> B,G,R
      }
    }
  }
  return m;
}

}  // namespace

void writePngRgb8(const std::string& path, const ImageF& linear_rgb, const uint64_t* dither_key) {
  requireRgb(linear_rgb, "writePngRgb8");
  writePng(path, toSrgbBgr<uint8_t>(linear_rgb, CV_8UC3, 255.0, dither_key));
}

void writePngRgb16(const std::string& path, const ImageF& linear_rgb) {
  requireRgb(linear_rgb, "writePngRgb16");
  writePng(path, toSrgbBgr<uint16_t>(linear_rgb, CV_16UC3, 65535.0));
}

void writePngGray8(const std::string& path, const Image<uint8_t>& img) {
  requireGray(img, "writePngGray8");
  // The Mat header only wraps the buffer; imencode reads it, never writes.
  cv::Mat m(img.height, img.width, CV_8UC1, const_cast<uint8_t*>(img.data.data()));
  writePng(path, m);
}

void writePngBgr8(const std::string& path, const uint8_t* bgr, int width, int height, size_t row_bytes) {
  if (!bgr || width <= 0 || height <= 0 || row_bytes < size_t(width) * 3)
    throw std::logic_error("writePngBgr8: expected a non-empty 8-bit BGR image");
  // The Mat header only wraps the buffer; imencode reads it, never writes.
  writePng(path, cv::Mat(height, width, CV_8UC3, const_cast<uint8_t*>(bgr), row_bytes));
}

void writePngGray16(const std::string& path, const Image<uint16_t>& img) {
  requireGray(img, "writePngGray16");
  cv::Mat m(img.height, img.width, CV_16UC1, const_cast<uint16_t*>(img.data.data()));
  writePng(path, m);
}

void writeExr(const std::string& path, int width, int height, const std::vector<ExrLayer>& layers) {
  if (width <= 0 || height <= 0)
    throw std::logic_error("writeExr: non-positive size " + std::to_string(width) + "x" +
                           std::to_string(height));
  std::vector<std::string> names;
  for (const ExrLayer& l : layers) {
    if (!l.image) throw std::logic_error("writeExr: layer '" + l.name + "' has no image");
    if (l.channel_suffixes.empty() || l.image->channels != int(l.channel_suffixes.size()) ||
        l.image->width != width || l.image->height != height ||
        l.image->data.size() != size_t(width) * height * l.image->channels)
      throw std::logic_error("writeExr: layer '" + l.name + "' is " + std::to_string(l.image->width) +
                             "x" + std::to_string(l.image->height) + "x" +
                             std::to_string(l.image->channels) + ", expected " +
                             std::to_string(width) + "x" + std::to_string(height) + "x" +
                             std::to_string(l.channel_suffixes.size()));
    for (const std::string& s : l.channel_suffixes) {
      std::string n = l.name.empty() ? s : l.name + "." + s;
      for (const std::string& o : names)
        if (o == n) throw std::logic_error("writeExr: channel '" + n + "' appears twice");
      names.push_back(n);
    }
  }
  if (names.empty()) throw std::logic_error("writeExr: no layers");

  // All layers interleaved into one scanline part, a band of rows at a time: a copy of the whole
  // image would add 4 bytes per pixel and channel to the peak of a large frame (docs/output.md,
  // "Memory"). 64 rows: a multiple of the 16 that zip compresses together.
  const size_t nch = names.size();
  OIIO::ImageSpec spec(width, height, int(nch), OIIO::TypeDesc::FLOAT);
  spec.channelnames = names;
  spec.alpha_channel = -1;
  spec.z_channel = -1;
  spec.attribute("compression", "zip");
  spec.attribute("DateTime", kExrFixedDateTime);
  // Chosen by format name, not by the file's extension, so temporary names work.
  auto out = OIIO::ImageOutput::create("openexr");
  if (!out) throw std::runtime_error("cannot create EXR writer for " + path + ": " + OIIO::geterror());
  if (!out->open(path, spec))
    throw std::runtime_error("cannot open " + path + " for writing: " + out->geterror());
  constexpr int kBand = 64;
  std::vector<float> buf(size_t(width) * size_t(std::min(kBand, height)) * nch);
  bool ok = true;
  for (int y0 = 0; y0 < height && ok; y0 += kBand) {
    const int y1 = std::min(height, y0 + kBand);
    const size_t first = size_t(y0) * size_t(width), n = size_t(y1 - y0) * size_t(width);
    size_t base = 0;
    for (const ExrLayer& l : layers) {
      const size_t lc = l.channel_suffixes.size();
      const float* src = l.image->data.data() + first * lc;
      for (size_t p = 0; p < n; ++p)
        for (size_t c = 0; c < lc; ++c) buf[p * nch + base + c] = src[p * lc + c];
      base += lc;
    }
    ok = out->write_scanlines(y0, y1, 0, OIIO::TypeDesc::FLOAT, buf.data());
  }
  std::string err = ok ? std::string() : out->geterror();
  if (!out->close() && ok) {
    ok = false;
    err = out->geterror();
  }
  if (!ok) throw std::runtime_error("cannot write " + path + ": " + err);
}

}  // namespace dg
