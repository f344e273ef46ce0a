// Footprint integration over grooves in cross-section space (Bosch 2007 §4.2.3, "1-D line
// sampling"; shared/reference/bosch-grooves.md §2.2.3 and §2.3). Pure 2-D geometry in doubles,
// no renderer types: the integrator turns its pixel footprint, view and light directions into the
// groove's local frame (T along the path, B = W x T across it, W the surface normal) and asks
// this module which facet portions are seen, lit, and what a reflection off a portion meets.
//
// Inside one footprint the grooves are prisms along T (digest §1.7), so projecting along a 3-D
// direction d = (d_t, d_b, d_w) equals projecting in the BW plane along (d_b, d_w): a point
// (b, w) lands on the base line at x = b - w * d_b / d_w.
#pragma once
#include <vector>

#include "core/math.h"

namespace dg::groove {

// The tangent that a facet of normal N takes from the part's chart: the surface's tangent t (its
// dpdu) carried up onto the facet's plane along the surface normal W. The explicit geometry's cut
// triangles have their UVs from the part at the point below, so this is their dpdu's direction; the
// orthogonal projection of t onto the plane is not, wherever the groove runs oblique to t (the
// groove renderer's facets then turned a resolved flake's tilt about their normal). t itself where
// the facet stands (nearly) upright.
inline Vec3f facetTangent(Vec3f t, Vec3f W, Vec3f N) {
  const float wn = dot(W, N);
  return std::fabs(wn) > 1e-4f ? t - W * (dot(t, N) / wn) : t;
}

// A merged cross-section in footprint-centred coordinates: points (b, w), b non-decreasing,
// starting and ending on w = 0; facet k joins pts[k] and pts[k+1] and shows material layer
// layer[k] (0 = the part's own top layer). The flat base surface between and around grooves is
// made of ordinary facets with w = 0.
struct Section {
  std::vector<Vec2d> pts;
  std::vector<int> layer;
  // Per facet (empty: all 0), the slope of the facet along the path that a force fade gives it:
  // its 3-D normal is (tilt, normal(k)) in (t, b, w), normalised. A profile scaled by r(t) =
  // 1 + rho t about its centre line (b = offset, w = 0) moves each facet line by rho times its
  // distance from that centre per unit of t, so tilt = -rho (P - (offset, 0)).normal(k) for any
  // point P of the facet (as the polygons' planes of render/groove_area.h have it). A groove turned
  // from t by an angle of tangent `turn` (PlacedProfile::turn) adds -turn normal(k).x: its height
  // g(b cos a - t sin a) has the slope -g' sin a along t.
  std::vector<double> tilt;
  size_t facets() const { return pts.size() < 2 ? 0 : pts.size() - 1; }
  // Unit outward normal of facet k in (b, w): the facet direction turned +90 degrees,
  // (-dw, db) / len, so flat facets have (0, 1).
  Vec2d normal(size_t k) const;
  double tiltOf(size_t k) const { return tilt.empty() ? 0.0 : tilt[k]; }
};

// One groove's profile placed in the footprint: its points are at b + offset (offset = B.(P - F):
// the path's position relative to the footprint centre F), mirrored (b -> -b, order reversed)
// first when `mirrored` (a parallel path running the other way).
struct PlacedProfile {
  const std::vector<Vec2d>* pts = nullptr;
  const std::vector<int>* layer = nullptr;
  double offset = 0;
  bool mirrored = false;
  // The force fade: the profile's relative change of scale per unit of the section's t (per mm;
  // along the section's direction, so negated for a path that runs the other way). Gives its
  // facets their Section::tilt.
  double rho = 0;
  // tan of the angle from the section's t to the groove's own direction (turned towards +b; the
  // direction taken the section's way): grooves within the merging tolerance of parallel are
  // placed as if parallel, but each facet keeps its own groove's normal, whose slope along t is
  // -turn times its b component (Section::tilt). Under a bar light a wall turned by 2 degrees moves
  // its mirror image of the bar by nearly 3 (docs/grooves.md, "Nearly parallel grooves").
  double turn = 0;
};

// Concatenates the placed profiles in order of b and adds flat facets (layer 0) from -extent to
// the first and from the last to +extent, and between profiles. Profiles that overlap in b (which
// Bosch excludes) are merged as the explicit geometry composes them (scratchHeight): at every b the
// lowest height where one is below the base (what any groove removes stays removed), else the
// highest (every pile-up stays), with vertical steps where a groove's edge cuts through a pile-up.
// extent must be at least the farthest projected footprint coordinate the caller will use.
Section merge(const std::vector<PlacedProfile>& grooves, double extent);

// The footprint's weighting along the base line (footprint-centred): the pixel footprint is a
// parallelogram spanned by a1, a2; its projection onto B weights x by the convolution of two boxes
// of widths w1 = |a1.B| and w2 = |a2.B| (a trapezoid of total width w1 + w2, unit area), exactly
// the pixel's box filter restricted to one axis. Either width may be 0 (a single box); both 0 is a
// point footprint at x = 0 (weight is then all-or-nothing).
struct Footprint {
  double w1 = 0, w2 = 0;
  double halfWidth() const { return 0.5 * (w1 + w2); }
  // Integral of the weight over [x0, x1] (in [0, 1]; x0 <= x1).
  double weight(double x0, double x1) const;
};

// A portion of facet `facet`: parameter t in [t0, t1] of [0, 1] from pts[k] to pts[k+1], with
// the footprint weight it carries (fraction of the pixel). x0 and x1 are the footprint
// coordinates (on the base line, where the footprint weight lives) that the portion's ends come
// from, affine in t in between: for a directly seen portion its view projection; for a portion hit
// after scatter() the footprint coordinates of the points the rays started from. So the weight of
// any sub-range [ta, tb] of the portion is fp.weight over the mapped x range.
struct Portion {
  int facet = -1;
  double t0 = 0, t1 = 1;
  double x0 = 0, x1 = 0;
  double weight = 0;
  double xAt(double t) const { return t1 > t0 ? x0 + (x1 - x0) * (t - t0) / (t1 - t0) : x0; }
};

// The facet portions visible from direction e (pointing from the surface towards the viewer;
// e.w > 0; only e.b / e.w matters) inside the footprint: masking by ordered projection (running
// maximum or minimum, digest §2.2.3 (3)), clipped to the footprint, weighted by fp. The weights
// of all returned portions sum to 1 (within rounding) because the profile starts and ends on the
// base line and the flat ends reach past the footprint. Portions of zero weight are dropped.
// Grazing e.w is clamped to 1e-6 (finite results).
std::vector<Portion> visible(const Section& s, Vec2d e_bw, const Footprint& fp);

// The lit part of portion p for light direction l (towards the light, in the BW plane; l.w may
// be <= 0: then only facets facing it can be lit and nothing on the base line is): the fraction
// of the portion's weight whose points see the light unoccluded by the section (shadowing by
// ordered projection along l, intersected with the portion in the facet parameter t), and 0 when
// the facet faces away from l. Weighting inside the portion is the footprint weight through
// Portion::xAt (so the result is exact for the trapezoid filter).
double litFraction(const Section& s, const Portion& p, const Footprint& fp, Vec2d l_bw);

// The same shadowing for every portion of one section under one light direction, built once:
// every vertex is projected along l onto the base line, x_i = b_i - w_i l_b / l_w (the ordered
// projection of Bosch 2007 §4.2.3.3). With light from +b a point of facet k is lit when its
// projection is at most the smallest projection of the vertices after it; from -b, at least the
// largest of the vertices before it; straight up, always. So the lit part of a facet is one
// interval of its parameter, found in O(1) after an O(V) set-up, instead of a 2-D ray per piece.
// Gives litFraction(s, p, fp, l) (tested against it); the section must outlive it.
class Shadowing {
 public:
  Shadowing() = default;
  Shadowing(const Section& s, Vec2d l_bw);
  // Rebuilds it for another section or direction, keeping its storage.
  void reset(const Section& s, Vec2d l_bw);
  double litFraction(const Portion& p, const Footprint& fp) const;

 private:
  const Section* s_ = nullptr;
  Vec2d l_;
  int from_ = 0;              // +1: light from +b, -1: from -b, 0: straight up, 2: not above (l_w <= 0)
  std::vector<double> x_;     // projection of each vertex
  std::vector<double> bound_; // per facet: suffix minimum from k+1 (from +b) or prefix maximum to k
};

// Where rays leaving portion p in direction d (BW plane, pointing away from facet p.facet, i.e.
// dot(d, normal) > 0) go: sub-portions of other facets they hit first (each with the share of
// p.weight that lands there, facet parameters of the hit points, and x0/x1 carried over from p),
// and the share that leaves the groove unobstructed (`escaped`). Shares sum to p.weight. Section §4.3 of Bosch: the
// recursion on visible facet portions. Directions with dot(d, normal) <= 0 return nothing hit
// and escaped = 0.
struct Scatter {
  std::vector<Portion> hits;  // .weight = share of p.weight
  double escaped = 0;
};
Scatter scatter(const Section& s, const Portion& p, const Footprint& fp, Vec2d d_bw);

// The same for rays that leave portion p into the solid below the section (a glass part's
// refraction, dot(d, normal) < 0): the facets they meet again from inside (hits, on the facets'
// solid side) and the share that goes on down into the solid without meeting one (`escaped`).
// The solid seen upside down is the open side of the section mirrored in w (w -> -w: the order
// of the points, the facets' indices and parameters stay), so this is scatter() there.
Scatter scatterInside(const Section& s, const Portion& p, const Footprint& fp, Vec2d d_bw);

// The point of facet k at parameter t.
Vec2d pointOn(const Section& s, int k, double t);

// Where the ray from point P along d (BW plane) first meets the front of a facet: its index and the
// parameter t of the hit on it. False when it meets none (a ray that rises away). P is meant to lie
// in the open space above the section; from inside the solid the backs of the facets are passed
// through. The area sampling hands rays that leave its region down a groove to that groove's
// section this way (the integrator's beyondRegion). `ray_s` (where given) gets the ray's
// parameter there: the hit is P + ray_s d.
bool castInto(const Section& s, Vec2d P, Vec2d d, int& facet, double& t, double* ray_s = nullptr);

}  // namespace dg::groove
