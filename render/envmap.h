// Environment light: a constant radiance or a latitude-longitude (equirectangular) HDR map read
// with OpenImageIO (EXR, HDR, ...), importance-sampled by a piecewise-constant 2-D distribution
// weighted by luminance and sin(theta).
// World convention: +z is up. Direction (theta, phi) with theta from +z and phi = atan2(y, x);
// image column u = phi / 2pi - rotation (wrapped to [0,1)), row v = theta / pi: a positive
// rotation_deg turns the environment counterclockwise about +z (a feature at phi moves to
// phi + rotation). Row 0 is the top of the image (+z). Lookups pick the nearest pixel, matching the
// piecewise-constant sampling density exactly.
// Integer images (PNG, 8/16-bit TIFF) are taken as sRGB-encoded unless OIIO reports a linear colour
// space; float images as linear. 1 channel is replicated to RGB; alpha is ignored.
#pragma once
#include <string>
#include <vector>

#include "core/math.h"

namespace dg {

class EnvironmentMap {
 public:
  static EnvironmentMap constant(Rgb radiance);
  // Throws InputError naming the file when it cannot be read or is not 2:1-ish lat-long (any size
  // with width >= 2 and height >= 1 is accepted; non-finite or negative pixels are an error).
  // An all-black map loads; it emits nothing and sample() then returns pdf 0.
  static EnvironmentMap load(const std::string& path, float scale = 1.0f, float rotation_deg = 0.0f);

  bool isConstant() const { return w_ == 0; }
  Rgb eval(Vec3f dir) const;                          // radiance arriving from direction dir
  // pdf in solid angle; 0 for a sample exactly at a pole (discard it).
  Vec3f sample(Vec2f u, Rgb& radiance, float& pdf) const;
  float pdf(Vec3f dir) const;

 private:
  Rgb constant_{0.0f};
  int w_ = 0, h_ = 0;
  float scale_ = 1.0f, rotation_ = 0.0f;  // rotation in [0,1) of a turn
  std::vector<Rgb> pixels_;
  std::vector<float> marginal_cdf_;       // over rows, size h+1
  std::vector<float> conditional_cdf_;    // per row, size h*(w+1)
  std::vector<float> row_integral_;       // per row: mean weight over the row
  float total_ = 0.0f;
};

}  // namespace dg
