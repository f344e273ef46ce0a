// Emitters: one-sided planar area lights (rectangle, disk, annulus) and the environment. The
// inspection set-ups users know (dome, ring, bar, coaxial) are built from these in the generator;
// see docs/config.md.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "core/math.h"
#include "render/envmap.h"

namespace dg {

struct AreaLight {
  enum class Shape { Rect, Disk };
  Shape shape = Shape::Rect;
  Vec3f center;
  Vec3f normal{0, 0, -1};  // emitting side
  Vec3f axis_u{1, 0, 0};   // unit, in the plane; rect half-extent along it is half_u
  Vec3f axis_v{0, 1, 0};
  float half_u = 50, half_v = 50;         // rectangle half extents (mm)
  float radius = 50, inner_radius = 0;    // disk / annulus (mm)
  Rgb radiance{1.0f};
  bool visible_to_camera = true;
  std::string name;

  float area() const;
  // Uniform point on the emitter; returns the point.
  Vec3f samplePoint(Vec2f u) const;
  // Ray (o, d) against the emitter: distance t in (tmin, tmax) if hit on the emitting side.
  bool intersect(Vec3f o, Vec3f d, float tmin, float tmax, float& t) const;
  // Solid-angle pdf at shading point p of reaching point q on the light by uniform area sampling.
  float pdfSolidAngle(Vec3f p, Vec3f q) const;
};

struct LightSet {
  std::vector<AreaLight> area;
  std::shared_ptr<const EnvironmentMap> env;  // null = black background
  bool empty() const { return area.empty() && !env; }
};

}  // namespace dg
