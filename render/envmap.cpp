// Environment light from a latitude-longitude map. Importance sampling follows the usual
// piecewise-constant 2-D scheme (Pharr, Jakob, Humphreys, "Physically Based Rendering", 3rd ed.,
// sections 13.6.7 and 14.2.4): a marginal distribution over rows and a conditional one over the
// pixels of each row, with weights f(i, j) = luminance(i, j) * sin(theta_j) at the row centre.
// A uniform point (u, v) in [0,1]^2 maps to theta = pi v, phi = 2 pi u, whose Jacobian is
// d(omega) = 2 pi^2 sin(theta) du dv, so the solid-angle density is p(u, v) / (2 pi^2 sin theta).
#include "render/envmap.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <new>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "core/error.h"
#include "core/fsutil.h"

namespace dg {

namespace {

constexpr float kInv4Pi = 0.07957747154594767f;
constexpr double kTwoPiSqr = 2.0 * kPi * kPi;

// sRGB electro-optical transfer function (IEC 61966-2-1): encoded value in [0,1] to linear.
float srgbToLinear(float c) {
  return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

// Builds a normalized CDF of `n` non-negative weights into cdf[0..n]; returns their sum. A row
// whose weights are all zero gets a uniform CDF (it is never chosen by the marginal anyway).
double buildCdf(const double* w, int n, float* cdf) {
  double sum = 0.0;
  for (int i = 0; i < n; ++i) sum += w[i];
  double acc = 0.0;
  cdf[0] = 0.0f;
  for (int i = 0; i < n; ++i) {
    acc += w[i];
    cdf[i + 1] = sum > 0.0 ? float(acc / sum) : float(i + 1) / float(n);
  }
  cdf[n] = 1.0f;
  return sum;
}

// Finds the interval k of a CDF of n intervals with cdf[k] <= u < cdf[k+1] and returns the
// position of u inside it in [0,1). Zero-width intervals are never returned for u < 1.
int sampleCdf(const float* cdf, int n, float u, float& frac) {
  int k = int(std::upper_bound(cdf, cdf + n + 1, u) - cdf) - 1;
  k = std::min(std::max(k, 0), n - 1);
  const float width = cdf[k + 1] - cdf[k];
  frac = width > 0.0f ? std::min((u - cdf[k]) / width, 0x1.fffffep-1f) : 0.5f;
  return k;
}

}  // namespace

EnvironmentMap EnvironmentMap::constant(Rgb radiance) {
  if (!isFinite(radiance) || radiance.x < 0 || radiance.y < 0 || radiance.z < 0)
    throw std::invalid_argument("EnvironmentMap::constant: radiance must be finite and >= 0");
  EnvironmentMap m;
  m.constant_ = radiance;
  return m;
}

EnvironmentMap EnvironmentMap::load(const std::string& path, float scale, float rotation_deg) {
  if (!std::isfinite(scale) || scale < 0.0f || !std::isfinite(rotation_deg))
    throw std::invalid_argument("EnvironmentMap::load: scale must be finite and >= 0, rotation "
                                "finite");
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw InputError(path, "environment map not found (expected a lat-long image: EXR, HDR, PNG, "
                           "... readable by OpenImageIO)");
  std::optional<QuietStderr> quiet(std::in_place);  // libpng's own complaint: the error below says it
  auto in = OIIO::ImageInput::open(path);
  if (!in) {
    std::string why = oneLineError(OIIO::geterror());
    throw InputError(path, "cannot read environment map as an image" +
                               (why.empty() ? std::string() : ": " + why));
  }
  const OIIO::ImageSpec spec = in->spec();
  const int w = spec.width, h = spec.height, nc = spec.nchannels;
  if (w < 2 || h < 1 || nc < 1 || spec.depth > 1)
    throw InputError(path, "environment map is " + std::to_string(w) + "x" + std::to_string(h) +
                               " with " + std::to_string(nc) +
                               " channels; expected a 2-D lat-long image at least 2 pixels wide");
  // A header can declare any size; a lat-long map past 32768 x 16384 is refused, not allocated.
  if (int64_t(w) * h > int64_t(32768) * 16384)
    throw InputError(path, "environment map is " + std::to_string(w) + "x" + std::to_string(h) +
                               "; the largest taken is 32768x16384 pixels");
  std::vector<float> buf;
  try {
    buf.resize(size_t(w) * h * nc);
  } catch (const std::bad_alloc&) {
    throw InputError(path, "environment map is " + std::to_string(w) + "x" + std::to_string(h) + " with " +
                               std::to_string(nc) + " channels, more than this machine's memory holds as floats");
  }
  if (!in->read_image(0, 0, 0, nc, OIIO::TypeDesc::FLOAT, buf.data())) {
    std::string why = oneLineError(in->geterror());
    throw InputError(path, "cannot read the pixels of the environment map" +
                               (why.empty() ? std::string() : ": " + why));
  }
  refuseDamagedJpeg(path, in->format_name(), in->geterror(), "the environment map's JPEG", "export it again");
  in->close();
  quiet.reset();

  // Integer formats store display-encoded (sRGB) values unless the file says it is linear;
  // floating-point formats (EXR, HDR, float TIFF) hold linear radiance.
  std::string cs = spec.get_string_attribute("oiio:ColorSpace");
  std::transform(cs.begin(), cs.end(), cs.begin(), [](unsigned char c) { return std::tolower(c); });
  const bool linear = spec.format.is_floating_point() || cs == "linear" || cs == "scene_linear";

  EnvironmentMap m;
  m.w_ = w;
  m.h_ = h;
  m.scale_ = scale;
  m.rotation_ = rotation_deg / 360.0f - std::floor(rotation_deg / 360.0f);
  if (m.rotation_ >= 1.0f) m.rotation_ = 0.0f;
  m.pixels_.resize(size_t(w) * h);
  for (int j = 0; j < h; ++j) {
    for (int i = 0; i < w; ++i) {
      const float* p = &buf[(size_t(j) * w + i) * nc];
      // 1 or 2 channels (grey, grey + alpha): replicate grey; 3 or more: RGB, alpha ignored.
      Rgb c = nc >= 3 ? Rgb{p[0], p[1], p[2]} : Rgb{p[0]};
      if (!isFinite(c)) {
        std::ostringstream s;
        s << "environment map pixel (" << i << ", " << j << ") is not finite; expected finite "
          << "radiance values";
        throw InputError(path, s.str());
      }
      if (c.x < 0 || c.y < 0 || c.z < 0) {
        std::ostringstream s;
        s << "environment map pixel (" << i << ", " << j << ") is negative (" << c.x << ", "
          << c.y << ", " << c.z << "); expected radiance >= 0";
        throw InputError(path, s.str());
      }
      if (!linear) c = {srgbToLinear(c.x), srgbToLinear(c.y), srgbToLinear(c.z)};
      m.pixels_[size_t(j) * w + i] = c * scale;
    }
  }

  // Sampling distribution. Weights in double so that large maps keep their small entries.
  m.conditional_cdf_.resize(size_t(h) * (w + 1));
  m.row_integral_.resize(h);
  std::vector<double> weights(w), rowSums(h);
  double total = 0.0;
  for (int j = 0; j < h; ++j) {
    const double sinTheta = std::sin(kPi * (j + 0.5) / h);  // > 0 at every row centre
    for (int i = 0; i < w; ++i) weights[i] = luminance(m.pixels_[size_t(j) * w + i]) * sinTheta;
    rowSums[j] = buildCdf(weights.data(), w, &m.conditional_cdf_[size_t(j) * (w + 1)]);
    m.row_integral_[j] = float(rowSums[j] / w);
    total += rowSums[j];
  }
  m.marginal_cdf_.resize(h + 1);
  buildCdf(rowSums.data(), h, m.marginal_cdf_.data());
  m.total_ = float(total);
  if (!std::isfinite(m.total_))
    throw InputError(path, "environment map radiance times scale overflows single precision");
  return m;
}

namespace {

// Lat-long coordinates of a direction (need not be unit length): u in [0,1) after the rotation,
// v in [0,1], and sin(theta).
void dirToUv(Vec3f d, float rotation, float& u, float& v, float& sinTheta) {
  const float rxy = std::sqrt(d.x * d.x + d.y * d.y);
  const float theta = std::atan2(rxy, d.z);  // robust near the poles, unlike acos(z)
  const float len = std::sqrt(rxy * rxy + d.z * d.z);
  sinTheta = len > 0.0f ? rxy / len : 0.0f;
  v = theta * kInvPiF;
  // A rotation by +rot (counterclockwise about +z) moves the feature at column u to phi = 2 pi
  // (u + rot), so the column seen in direction phi is phi / 2 pi - rot.
  u = std::atan2(d.y, d.x) * (0.5f * kInvPiF) - rotation;
  u -= std::floor(u);
}

}  // namespace

Rgb EnvironmentMap::eval(Vec3f dir) const {
  if (isConstant()) return constant_;
  float u, v, s;
  dirToUv(dir, rotation_, u, v, s);
  // Nearest pixel, i.e. the cell of the piecewise-constant sampling density.
  const int i = std::min(int(u * w_), w_ - 1), j = std::min(int(v * h_), h_ - 1);
  return pixels_[size_t(j) * w_ + i];
}

float EnvironmentMap::pdf(Vec3f dir) const {
  if (isConstant()) return kInv4Pi;
  if (!(total_ > 0.0f)) return 0.0f;
  float u, v, sinTheta;
  dirToUv(dir, rotation_, u, v, sinTheta);
  if (!(sinTheta > 0.0f)) return 0.0f;  // the poles have zero measure
  const int i = std::min(int(u * w_), w_ - 1), j = std::min(int(v * h_), h_ - 1);
  const float sinRow = std::sin(kPiF * (j + 0.5f) / h_);
  // p(u, v) = f(i, j) / (total / (w h)) on the unit square.
  const double puv = double(luminance(pixels_[size_t(j) * w_ + i])) * sinRow * w_ * h_ / total_;
  return float(puv / (kTwoPiSqr * sinTheta));
}

Vec3f EnvironmentMap::sample(Vec2f u, Rgb& radiance, float& pdf) const {
  const float u0 = clampf(u.x, 0.0f, 0x1.fffffep-1f), u1 = clampf(u.y, 0.0f, 0x1.fffffep-1f);
  if (isConstant()) {
    // Uniform sphere: z uniform in [-1, 1] (Archimedes), phi uniform.
    const float z = 1.0f - 2.0f * u1;
    const float r = safeSqrt(1.0f - z * z);
    const float phi = 2.0f * kPiF * u0;
    radiance = constant_;
    pdf = kInv4Pi;
    return {r * std::cos(phi), r * std::sin(phi), z};
  }
  if (!(total_ > 0.0f)) {  // an all-black map emits nothing and cannot be sampled
    radiance = Rgb(0.0f);
    pdf = 0.0f;
    return {0.0f, 0.0f, 1.0f};
  }
  float dv, du;
  const int j = sampleCdf(marginal_cdf_.data(), h_, u1, dv);
  const int i = sampleCdf(&conditional_cdf_[size_t(j) * (w_ + 1)], w_, u0, du);
  const float theta = kPiF * (float(j) + dv) / float(h_);
  const float phi = 2.0f * kPiF * ((float(i) + du) / float(w_) + rotation_);
  const float sinTheta = std::sin(theta);
  const Vec3f dir{sinTheta * std::cos(phi), sinTheta * std::sin(phi), std::cos(theta)};
  radiance = pixels_[size_t(j) * w_ + i];
  if (!(sinTheta > 0.0f)) {
    pdf = 0.0f;
    return dir;
  }
  const float sinRow = std::sin(kPiF * (j + 0.5f) / h_);
  const double puv = double(luminance(radiance)) * sinRow * w_ * h_ / total_;
  pdf = float(puv / (kTwoPiSqr * sinTheta));
  return dir;
}

}  // namespace dg
