// A round dent rendered by bump mapping (Blinn 1978; shared/reference/blinn-bump.md).
//
// Height profile (the digest's §8.5 polynomial bowl, C1 at centre and rim):
//   F(r) = -d (1 - (r/R)^2)^2 for r < R, 0 outside,   F'(r) = 4 d r / R^2 (1 - (r/R)^2),
// with r the distance in the part's UV chart (mm) from the centre. The maximum slope is
// 8d/(3 sqrt(3) R) ~ 1.5396 d/R at r = R/sqrt(3).
// Label: the points where the depth is at least mask_threshold * d, i.e.
//   r <= R sqrt(1 - sqrt(mask_threshold)).
// A crease is the same profile across a line segment: r is the distance to the segment (from
// center_uv to end_uv), so the crease has round ends; a round dent is a crease of length 0.
#pragma once
#include <cmath>
#include <limits>

#include "defects/defect.h"

namespace dg {

struct DentParams {
  Vec2f center_uv;          // mm; for a crease, one end of its line
  // The other end of a crease's line; NaN (the default) or equal to center_uv for a round dent.
  Vec2f end_uv{std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::quiet_NaN()};
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
    double du, dv;
    offset(p, 1.0, du, dv);
    return float(height(std::sqrt(du * du + dv * dv)));
  }
  bool isCrease() const { return is_crease_; }
  // A displaced dent is in the geometry: it keeps its label but adds no bump on top.
  void setDisplaced(bool d) { displaced_ = d; }
  bool wantsDisplacement() const override { return displaced_; }
  // The default rule for `displacement: auto` (blinn-bump.md §8.4): true geometry when the steepest
  // tilt exceeds 15 degrees (bump mapping's small-slope assumption fails), or when the dent comes
  // within its radius of the chart's outline (so the silhouette changes there).
  bool needsGeometry(const Box2& chart) const;
  nlohmann::json attributes() const override;

  // Profile and its radial derivative (exposed for tests).
  double height(double r) const;
  double slope(double r) const;
  double maskRadius() const { return mask_radius_; }
  const DentParams& params() const { return p_; }

 private:
  // Offset (surface mm) from the closest point of the dent's centre line to p.
  void offset(Vec2f p, double mm_per_uv, double& du, double& dv) const;
  DentParams p_;
  double mask_radius_;
  bool is_crease_ = false;
  bool displaced_ = false;
};

}  // namespace dg
