#include "defects/dent.h"

#include <cmath>
#include <stdexcept>

namespace dg {

Dent::Dent(const DentParams& p) : p_(p) {
  if (!(p.radius_mm > 0) || !(p.depth_mm >= 0) || !(p.mask_threshold > 0 && p.mask_threshold < 1))
    throw std::invalid_argument("Dent: radius > 0, depth >= 0, 0 < mask_threshold < 1 required");
  mask_radius_ = p.radius_mm * std::sqrt(1.0 - std::sqrt(double(p.mask_threshold)));
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

Box2 Dent::support() const {
  Box2 b;
  b.lo = {p_.center_uv.x - p_.radius_mm, p_.center_uv.y - p_.radius_mm};
  b.hi = {p_.center_uv.x + p_.radius_mm, p_.center_uv.y + p_.radius_mm};
  return b;
}

Box2 Dent::maskBox() const {
  float m = float(mask_radius_);
  Box2 b;
  b.lo = {p_.center_uv.x - m, p_.center_uv.y - m};
  b.hi = {p_.center_uv.x + m, p_.center_uv.y + m};
  return b;
}

void Dent::shade(const DefectQuery& q, DefectShading& s) const {
  // Distances in the chart are in UV mm; the chart's local stretch converts them to surface mm.
  double du = (double(q.uv.x) - p_.center_uv.x) * q.mm_per_uv;
  double dv = (double(q.uv.y) - p_.center_uv.y) * q.mm_per_uv;
  double r = std::sqrt(du * du + dv * dv);
  if (r >= p_.radius_mm || r <= 0.0) return;  // r = 0: the gradient is 0 (digest §8.5)
  // dF/du = F'(r) * (du/r) * d(du)/du; d(du)/du = mm_per_uv.
  double g = slope(r) / r * q.mm_per_uv;
  s.height_grad.x += float(g * du);
  s.height_grad.y += float(g * dv);
}

bool Dent::inMask(Vec2f p) const {
  double du = double(p.x) - p_.center_uv.x, dv = double(p.y) - p_.center_uv.y;
  return du * du + dv * dv <= mask_radius_ * mask_radius_;
}

nlohmann::json Dent::attributes() const {
  return {{"kind", "dent"},
          {"center_uv_mm", {p_.center_uv.x, p_.center_uv.y}},
          {"radius_mm", p_.radius_mm},
          {"depth_mm", p_.depth_mm},
          {"profile", "poly_bowl"},
          {"mask_threshold", p_.mask_threshold},
          {"mask_radius_mm", mask_radius_}};
}

}  // namespace dg
