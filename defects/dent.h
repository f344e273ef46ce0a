// A round dent rendered by bump mapping (Blinn 1978; shared/reference/blinn-bump.md).
//
// Height profile (the digest's §8.5 polynomial bowl, C1 at centre and rim):
//   F(r) = -d (1 - (r/R)^2)^2 for r < R, 0 outside,   F'(r) = 4 d r / R^2 (1 - (r/R)^2),
// with r the distance in the part's UV chart (mm) from the centre. The maximum slope is
// 8d/(3 sqrt(3) R) ~ 1.5396 d/R at r = R/sqrt(3).
// Label: the points where the depth is at least mask_threshold * d, i.e.
//   r <= R sqrt(1 - sqrt(mask_threshold)).
#pragma once
#include <cmath>

#include "defects/defect.h"

namespace dg {

struct DentParams {
  Vec2f center_uv;          // mm
  float radius_mm = 10;
  float depth_mm = 0.5;     // positive = inward
  float mask_threshold = 0.1f;
};

class Dent final : public Defect {
 public:
  explicit Dent(const DentParams& p);
  DefectClass cls() const override { return DefectClass::Dent; }
  const char* kind() const override { return "dent"; }
  Box2 support() const override;
  Box2 maskBox() const override;
  void shade(const DefectQuery& q, DefectShading& s) const override;
  bool inMask(Vec2f p) const override;
  float height(Vec2f p) const override {
    double du = double(p.x) - p_.center_uv.x, dv = double(p.y) - p_.center_uv.y;
    return float(height(std::sqrt(du * du + dv * dv)));
  }
  nlohmann::json attributes() const override;

  // Profile and its radial derivative (exposed for tests).
  double height(double r) const;
  double slope(double r) const;
  double maskRadius() const { return mask_radius_; }
  const DentParams& params() const { return p_; }

 private:
  DentParams p_;
  double mask_radius_;
};

}  // namespace dg
