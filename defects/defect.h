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
};

// What the defects do to one shading point. Accumulated over all defects that apply.
struct DefectShading {
  Vec2f height_grad{0, 0};  // d(height)/du, d(height)/dv in mm per mm of UV (outward positive)
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
  // Whether UV point p (mm) lies in the labelled region. The pixel's coverage is the fraction of
  // its footprint's visible surface for which this holds.
  virtual bool inMask(Vec2f p) const = 0;
  // Physical parameters, in the units of the config (mm, degrees), for the COCO annotation.
  virtual nlohmann::json attributes() const = 0;

 private:
  uint16_t instance_id_ = 0;
};

using DefectList = std::vector<std::unique_ptr<Defect>>;

}  // namespace dg
