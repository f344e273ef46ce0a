// What a defect is, independent of any renderer: a support region in the part's UV chart (mm), the
// way it changes shading there, the region it labels, and its physical parameters.
//
// The integrator asks a defect only through this interface, so scratches, rust and patina slot in
// beside the dent without touching it. A defect may
//  - add a height-field gradient (bump, Blinn 1978), summed over defects before the normal is
//    perturbed (shared/reference/blinn-bump.md §8.3: surface gradients add);
//  - replace the surface's appearance (a different material, e.g. rust or exposed primer) with a
//    weight, for defects that change what the surface is made of.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/defect_class.h"
#include "core/math.h"

namespace dg {

struct Box2 {
  Vec2f lo{1e30f, 1e30f}, hi{-1e30f, -1e30f};
  bool overlaps(const Box2& o) const {
    return lo.x <= o.hi.x && o.lo.x <= hi.x && lo.y <= o.hi.y && o.lo.y <= hi.y;
  }
  bool contains(Vec2f p) const { return p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y; }
};

// The shading point as a defect sees it: UV in mm, and the pixel footprint in UV (mm per pixel
// step in x and y, from ray differentials).
struct DefectQuery {
  Vec2f uv;
  Vec2f duv_dx{0, 0}, duv_dy{0, 0};
  float mm_per_uv = 1.0f;  // local chart stretch of the triangle (1 for isometric charts)
  float cavity = 0.0f;     // ambient occlusion of the part at the point, 0 (open) .. 1 (cavity);
                           // computed only when a defect asks for it (needsCavity())
  // A path vertex past the camera hit while the groove renderer draws scratches: scratches give
  // the slope of their cross-section at the point (a point sample of the grooves, as
  // render.scratches: normal_map does everywhere), so that a ray meeting the surface again, a ray
  // leaving a glass part through a scratch for instance, sees the scratch's facets.
  bool point_grooves = false;
  // The footprint's largest extent in UV mm (for filtering procedural detail).
  float footprint() const {
    return std::max(std::max(std::fabs(duv_dx.x), std::fabs(duv_dx.y)),
                    std::max(std::fabs(duv_dy.x), std::fabs(duv_dy.y)));
  }
};

// What a weathering defect turns the surface into. The renderer maps it onto a BSDF; defects
// stay free of renderer types.
struct SurfaceAppearance {
  Rgb albedo{0.5f};
  float sigma_rad = 0.5f;  // Oren-Nayar roughness (Oren and Nayar 1994)
};

// What the defects do to one shading point. Accumulated over all defects that apply.
struct DefectShading {
  Vec2f height_grad{0, 0};  // d(height)/du, d(height)/dv in mm per mm of UV (outward positive)
  // Fraction of the shading point's surface replaced by `appearance` (rust, patina); where several
  // defects overlap, the covers combine as 1 - prod(1 - c) and the strongest one's look is kept.
  float cover = 0.0f;
  SurfaceAppearance appearance;
  void addCover(float c, const SurfaceAppearance& a) {
    if (c <= 0) return;
    if (c > strongest_) {
      strongest_ = c;
      appearance = a;
    }
    cover = 1.0f - (1.0f - cover) * (1.0f - c);
  }
  // A scratch point-sampled where the groove renderer does not integrate (DefectQuery::
  // point_grooves): its height h (mm) and height gradient under the point. Scratches compose as
  // the explicit geometry cuts them (scratchHeight in render/scratch_geometry.cpp): the lowest
  // where one is below the base, else the highest, so where they overlap the surface takes one
  // groove's slope, not the sum of them all. grooveGrad() is the slope of the one that holds.
  void addGroove(float h, Vec2f grad) {
    if (h < low_) low_ = h, low_grad_ = grad;
    if (h > high_) high_ = h, high_grad_ = grad;
  }
  Vec2f grooveGrad() const { return low_ < 0 ? low_grad_ : high_ > 0 ? high_grad_ : Vec2f{0, 0}; }

 private:
  float strongest_ = 0.0f;
  float low_ = 0, high_ = 0;
  Vec2f low_grad_{0, 0}, high_grad_{0, 0};
};

class Defect {
 public:
  virtual ~Defect() = default;
  virtual DefectClass cls() const = 0;
  virtual const char* kind() const = 0;  // "dent", ...
  uint16_t instanceId() const { return instance_id_; }
  void setInstanceId(uint16_t id) { instance_id_ = id; }
  // UV box (mm) outside which the defect changes nothing.
  virtual Box2 support() const = 0;
  // UV box (mm) of the labelled region; inside support().
  virtual Box2 maskBox() const { return support(); }
  virtual void shade(const DefectQuery& q, DefectShading& s) const = 0;
  // The defect's height field at UV point p (mm, outward positive), for true displacement of the
  // geometry; 0 for defects that only change appearance.
  virtual float height(Vec2f p) const { return 0.0f; }
  // Whether the geometry should be displaced for this defect (deep dents, dents near outlines).
  virtual bool wantsDisplacement() const { return false; }
  // Whether UV point p (mm) lies in the labelled region. The pixel's coverage is the fraction of
  // its footprint's visible surface for which this holds.
  virtual bool inMask(Vec2f p) const = 0;
  // The same with the whole query (defects whose label depends on more than UV, e.g. cavities).
  virtual bool inMask(const DefectQuery& q) const { return inMask(q.uv); }
  // Whether shade()/inMask() read DefectQuery::cavity (the part's occlusion is then computed).
  virtual bool needsCavity() const { return false; }
  // Physical parameters, in the units of the config (mm, degrees), for the COCO annotation.
  virtual nlohmann::json attributes() const = 0;

 private:
  uint16_t instance_id_ = 0;
};

using DefectList = std::vector<std::unique_ptr<Defect>>;

}  // namespace dg
