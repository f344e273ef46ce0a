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
  // The point of the sample domain [0, 1)^2 that samplePoint maps to q (a point on the emitter).
  Vec2f domainPoint(Vec3f q) const;
  // The coordinate of the sample domain along which the light is long: an annulus's angle (y), a
  // rectangle's longer side.
  int majorAxis() const { return shape == Shape::Disk || half_v > half_u ? 1 : 0; }
};

// A density over an area light's sample domain shaped like one shading point's view of the
// light, for its light samples: piecewise constant, a product of kMajor bins along the light's
// major axis and kMinor along the other, each mixed with the uniform density (share `floor`) so
// that no part of the light goes unsampled. A warp of the uniform domain point keeps the light
// pattern's stratification (render/light_pattern.h), since it is monotone in each coordinate.
// Under a ring light round the lens, a glossy plate sees the ring through the tail of its lobe,
// brightest on the side nearest the mirror direction; uniform samples spread over the whole ring.
struct LightGuide {
  static constexpr int kMajor = 32, kMinor = 16;
  int major = 1;               // the coordinate with kMajor bins (AreaLight::majorAxis)
  bool on = false;             // the bins below are set only when on
  float p_major[kMajor];       // bin probabilities, summing to 1
  float c_major[kMajor + 1];   // their running sums
  float p_minor[kMinor];
  float c_minor[kMinor + 1];

  // From non-negative weights per bin (what the shading point gets from the bin's centre per unit
  // area): off (uniform) where every weight of either axis is 0 or one is not finite.
  void build(const float* w_major, const float* w_minor, float floor);
  // The guided point for a uniform point u, and its density relative to uniform.
  Vec2f warp(Vec2f u, float& rel) const;
  // The density relative to uniform at a domain point.
  float relDensity(Vec2f u) const;
};

struct LightSet {
  std::vector<AreaLight> area;
  std::shared_ptr<const EnvironmentMap> env;  // null = black background
  bool empty() const { return area.empty() && !env; }
};

}  // namespace dg
