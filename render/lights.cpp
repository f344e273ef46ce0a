#include "render/lights.h"

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

}  // namespace dg
