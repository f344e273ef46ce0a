#include "render/lights.h"

#include <algorithm>
#include <cmath>

namespace dg {

float AreaLight::area() const {
  if (shape == Shape::Rect) return 4.0f * half_u * half_v;
  return kPiF * (radius * radius - inner_radius * inner_radius);
}

Vec3f AreaLight::samplePoint(Vec2f u) const {
  if (shape == Shape::Rect)
    return center + axis_u * ((2 * u.x - 1) * half_u) + axis_v * ((2 * u.y - 1) * half_v);
  // Uniform on the annulus: r^2 uniform between inner^2 and outer^2.
  float r = std::sqrt(inner_radius * inner_radius + u.x * (radius * radius - inner_radius * inner_radius));
  float phi = 2 * kPiF * u.y;
  return center + axis_u * (r * std::cos(phi)) + axis_v * (r * std::sin(phi));
}

bool AreaLight::intersect(Vec3f o, Vec3f d, float tmin, float tmax, float& t) const {
  float dn = dot(d, normal);
  if (dn >= 0) return false;  // arriving from behind or parallel: one-sided emitter
  float tt = dot(center - o, normal) / dn;
  if (!(tt > tmin && tt < tmax)) return false;
  Vec3f q = o + d * tt - center;
  float a = dot(q, axis_u), b = dot(q, axis_v);
  if (shape == Shape::Rect) {
    if (std::fabs(a) > half_u || std::fabs(b) > half_v) return false;
  } else {
    float r2 = a * a + b * b;
    if (r2 > radius * radius || r2 < inner_radius * inner_radius) return false;
  }
  t = tt;
  return true;
}

float AreaLight::pdfSolidAngle(Vec3f p, Vec3f q) const {
  Vec3f w = q - p;
  float d2 = dot(w, w);
  float cosl = -dot(w, normal) / std::sqrt(d2);
  if (cosl <= 0) return 0.0f;
  return d2 / (cosl * area());
}

Vec2f AreaLight::domainPoint(Vec3f q) const {
  const Vec3f d = q - center;
  const float a = dot(d, axis_u), b = dot(d, axis_v);
  if (shape == Shape::Rect)
    return Vec2f(std::clamp(0.5f * (a / half_u + 1), 0.0f, kOneMinusEps),
                 std::clamp(0.5f * (b / half_v + 1), 0.0f, kOneMinusEps));
  const float span = radius * radius - inner_radius * inner_radius;
  const float x = span > 0 ? (a * a + b * b - inner_radius * inner_radius) / span : 0.5f;
  float y = std::atan2(b, a) / (2 * kPiF);
  if (y < 0) y += 1;
  return Vec2f(std::clamp(x, 0.0f, kOneMinusEps), std::clamp(y, 0.0f, kOneMinusEps));
}

namespace {

// Normalises n weights into probabilities mixed with the uniform (share `floor`) and their
// running sums; false when they sum to 0 or are not finite.
bool binsFrom(const float* w, int n, float floor, float* p, float* c) {
  double sum = 0;
  for (int i = 0; i < n; ++i) sum += w[i];
  if (!(sum > 0) || !std::isfinite(sum)) return false;
  c[0] = 0;
  for (int i = 0; i < n; ++i) {
    p[i] = float((1 - floor) * w[i] / sum + floor / n);
    c[i + 1] = c[i] + p[i];
  }
  return true;
}

// The bin of t in [0, 1) under running sums c (n bins), and t's place in the domain.
float warpOne(float t, const float* p, const float* c, int n, float& rel) {
  int j = 0;
  while (j + 1 < n && t >= c[j + 1]) ++j;
  rel *= float(n) * p[j];
  const float f = std::clamp((t - c[j]) / p[j], 0.0f, kOneMinusEps);
  return std::min((float(j) + f) / float(n), kOneMinusEps);
}

}  // namespace

void LightGuide::build(const float* w_major, const float* w_minor, float floor) {
  on = binsFrom(w_major, kMajor, floor, p_major, c_major) && binsFrom(w_minor, kMinor, floor, p_minor, c_minor);
}

Vec2f LightGuide::warp(Vec2f u, float& rel) const {
  rel = 1.0f;
  if (!on) return u;
  float a = major == 0 ? u.x : u.y, b = major == 0 ? u.y : u.x;
  a = warpOne(a, p_major, c_major, kMajor, rel);
  b = warpOne(b, p_minor, c_minor, kMinor, rel);
  return major == 0 ? Vec2f(a, b) : Vec2f(b, a);
}

float LightGuide::relDensity(Vec2f u) const {
  if (!on) return 1.0f;
  const float a = major == 0 ? u.x : u.y, b = major == 0 ? u.y : u.x;
  const int i = std::min(int(a * kMajor), kMajor - 1), j = std::min(int(b * kMinor), kMinor - 1);
  return float(kMajor) * p_major[i] * float(kMinor) * p_minor[j];
}

}  // namespace dg
