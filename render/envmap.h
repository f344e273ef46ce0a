// Environment light: a constant radiance or a latitude-longitude (equirectangular) HDR map read
// with OpenImageIO (EXR, HDR, ...), importance-sampled by a piecewise-constant 2-D distribution
// weighted by luminance and sin(theta).
// World convention: +z is up. Direction (theta, phi) with theta from +z and phi = atan2(y, x);
// image column u = phi / 2pi (wrapped to [0,1), then rotated by rotation_deg), row v = theta / pi.
#pragma once
#include <string>
#include <vector>

#include "core/math.h"

namespace dg {

class EnvironmentMap {
 public:
  static EnvironmentMap constant(Rgb radiance);
  // Throws InputError naming the file when it cannot be read or is not 2:1-ish lat-long (any size
  // with width >= 2 and height >= 1 is accepted; non-finite pixels are an error).
  static EnvironmentMap load(const std::string& path, float scale = 1.0f, float rotation_deg = 0.0f);

  bool isConstant() const { return w_ == 0; }
  Rgb eval(Vec3f dir) const;                          // radiance arriving from direction dir
  Vec3f sample(Vec2f u, Rgb& radiance, float& pdf) const;  // pdf in solid angle
  float pdf(Vec3f dir) const;

 private:
  Rgb constant_{0.0f};
  int w_ = 0, h_ = 0;
  float scale_ = 1.0f, rotation_ = 0.0f;  // rotation in [0,1) of a turn
  std::vector<Rgb> pixels_;
  std::vector<float> marginal_cdf_;       // over rows, size h+1
  std::vector<float> conditional_cdf_;    // per row, size h*(w+1)
  std::vector<float> row_integral_;
  float total_ = 0.0f;
};

}  // namespace dg
