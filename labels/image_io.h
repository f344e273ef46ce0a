// Writing images: PNG 8/16-bit (sRGB transfer curve applied to linear RGB), single-channel label
// PNGs, and multi-layer EXR (linear, float) through OpenImageIO.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "core/image.h"

namespace dg {

float linearToSrgb(float v);  // IEC 61966-2-1 transfer curve, input clamped to [0, 1]
float srgbToLinear(float v);

// 8-bit sRGB. Without `dither_key` each value is rounded to the nearest code, so a smooth region
// whose value lies between two codes comes out flat at one of them (off by up to half a code:
// banding on gradients, a uniform colour offset on flat areas). With a key, code floor(v + u) is
// written, u uniform in [0, 1) from a hash of the key, the pixel and the channel: the code's mean
// over a region is v itself, and values on a code (0 and 255 among them) are kept exactly. Same
// key, same bytes.
void writePngRgb8(const std::string& path, const ImageF& linear_rgb, const uint64_t* dither_key = nullptr);
void writePngRgb16(const std::string& path, const ImageF& linear_rgb);
void writePngGray8(const std::string& path, const Image<uint8_t>& img);
void writePngGray16(const std::string& path, const Image<uint16_t>& img);
// 8-bit colour as it is, channels in OpenCV's order (blue, green, red), rows `row_bytes` apart
// (a cv::Mat's data and step): the contact sheet and compare's pictures.
void writePngBgr8(const std::string& path, const uint8_t* bgr, int width, int height, size_t row_bytes);

// One named layer of an EXR: channel names are "<layer>.<suffix>" (e.g. "normal.X"); the layer
// named "" gives plain "R", "G", "B".
struct ExrLayer {
  std::string name;
  std::vector<std::string> channel_suffixes;  // e.g. {"R","G","B"} or {"Z"}
  const ImageF* image;                        // channels must match channel_suffixes.size()
};
void writeExr(const std::string& path, int width, int height, const std::vector<ExrLayer>& layers);

}  // namespace dg
