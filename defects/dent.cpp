#include "defects/dent.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace dg {

Dent::Dent(const DentParams& p) : p_(p) {
  if (!(p.radius_mm > 0) || !(p.depth_mm >= 0) || !(p.mask_threshold > 0 && p.mask_threshold < 1))
    throw std::invalid_argument("Dent: radius > 0, depth >= 0, 0 < mask_threshold < 1 required");
  mask_radius_ = p.radius_mm * std::sqrt(1.0 - std::sqrt(double(p.mask_threshold)));
  is_crease_ = std::isfinite(p.end_uv.x) && std::isfinite(p.end_uv.y) &&
               (p.end_uv.x != p.center_uv.x || p.end_uv.y != p.center_uv.y);
  if (!is_crease_) p_.end_uv = p_.center_uv;
}

void Dent::offset(Vec2f p, double k, double& du, double& dv) const {
  double ax = p_.center_uv.x, ay = p_.center_uv.y;
  double px = p.x - ax, py = p.y - ay;
  if (is_crease_) {
    double bx = p_.end_uv.x - ax, by = p_.end_uv.y - ay;
    double t = std::clamp((px * bx + py * by) / (bx * bx + by * by), 0.0, 1.0);
    px -= t * bx;
    py -= t * by;
  }
  du = px * k;
  dv = py * k;
}

double Dent::height(double r) const {
  double R = p_.radius_mm;
  if (r >= R) return 0.0;
  double s = 1.0 - (r * r) / (R * R);
  return -p_.depth_mm * s * s;
}

double Dent::slope(double r) const {
  double R = p_.radius_mm;
  if (r >= R) return 0.0;
  return 4.0 * p_.depth_mm * r / (R * R) * (1.0 - (r * r) / (R * R));
}

namespace {
Box2 segmentBox(Vec2f a, Vec2f b, float r) {
  Box2 x;
  x.lo = {std::min(a.x, b.x) - r, std::min(a.y, b.y) - r};
  x.hi = {std::max(a.x, b.x) + r, std::max(a.y, b.y) + r};
  return x;
}
}  // namespace

Box2 Dent::support() const { return segmentBox(p_.center_uv, p_.end_uv, p_.radius_mm); }

Box2 Dent::maskBox() const { return segmentBox(p_.center_uv, p_.end_uv, float(mask_radius_)); }

bool Dent::needsGeometry(const Box2& chart) const {
  const double max_slope = 8.0 * p_.depth_mm / (3.0 * std::sqrt(3.0) * p_.radius_mm);
  if (max_slope > std::tan(15.0 * kPi / 180.0)) return true;
  Box2 b = support();
  return b.lo.x < chart.lo.x || b.lo.y < chart.lo.y || b.hi.x > chart.hi.x || b.hi.y > chart.hi.y;
}

void Dent::shade(const DefectQuery& q, DefectShading& s) const {
  if (displaced_) return;
  // Distances in the chart are in UV mm; the chart's local stretch converts them to surface mm.
  double du, dv;
  offset(q.uv, q.mm_per_uv, du, dv);
  double r = std::sqrt(du * du + dv * dv);
  if (r >= p_.radius_mm || r <= 0.0) return;  // r = 0: the gradient is 0 (digest §8.5)
  // dF/du = F'(r) * (du/r) * d(du)/du; d(du)/du = mm_per_uv.
  double g = slope(r) / r * q.mm_per_uv;
  s.height_grad.x += float(g * du);
  s.height_grad.y += float(g * dv);
}

bool Dent::inMask(Vec2f p) const {
  double du, dv;
  offset(p, 1.0, du, dv);
  return du * du + dv * dv <= mask_radius_ * mask_radius_;
}

nlohmann::json Dent::attributes() const {
  nlohmann::json j = {{"kind", is_crease_ ? "crease" : "dent"},
          {"center_uv_mm", {p_.center_uv.x, p_.center_uv.y}},
          {"radius_mm", p_.radius_mm},
          {"depth_mm", p_.depth_mm},
          {"profile", "poly_bowl"},
          {"mask_threshold", p_.mask_threshold},
          {"mask_radius_mm", mask_radius_}};
  if (is_crease_) {
    j["end_uv_mm"] = {p_.end_uv.x, p_.end_uv.y};
    j["length_mm"] = std::hypot(p_.end_uv.x - p_.center_uv.x, p_.end_uv.y - p_.center_uv.y);
  }
  return j;
}

}  // namespace dg
