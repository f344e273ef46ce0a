// The geometric model of a scratch (Bosch 2007, chapter 3; shared/reference/bosch-grooves.md §1):
// a path in the part's UV chart (mm), a piecewise-linear cross-section in the plane across the
// path, a scale of that cross-section along the path, and a material layer per facet. Pure
// geometry: no renderer types. The groove renderer (issue 5, Bosch chapter 4) reads it through
// Scratch::path(), Scratch::profileAt() and Scratch::scaleAt().
//
// Conventions (digest §5.2):
//  - T is the path tangent (direction of increasing arc length s), W the outward normal of the
//    UV plane, B = W x T, i.e. T turned 90 degrees counter-clockwise in (u, v). A cross-section
//    point is (b, w): b the signed offset along B (b > 0: left of the path), w the height
//    (w > 0 above the base surface, w < 0 below it). "Depth" values are positive numbers (-min w).
//  - Lengths in mm, angles in radians inside (degrees only in attributes()), forces in kg
//    (kilogram-force), hardness in Vickers kg/mm^2, as in Bosch §3.2.
#pragma once
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "core/math.h"
#include "core/rng.h"
#include "defects/defect.h"

namespace dg {

// ------------------------------------------------------------------------------------------------
// Paths
// ------------------------------------------------------------------------------------------------

// Result of a closest-point query. Floats: this is the per-shading-point query.
struct PathPoint {
  bool found = false;     // false when nothing lies within the query's max distance
  float distance = 0;     // Euclidean distance from the query point to the path (mm)
  float s = 0;            // arc position of the closest point (mm from the start)
  Vec2f point{0, 0};      // the closest point on the path
  Vec2f tangent{1, 0};    // unit T there (at an interior vertex: the normalised mean of both sides)
  float offset = 0;       // signed offset along B = W x T (> 0: left of the path)
  float beyond = 0;       // distance past the nearest end along the end tangent (0 between ends)
  int side() const { return offset >= 0 ? +1 : -1; }
  int seg = -1;           // the path's segment it lies on (at a vertex: the one it was found on)
};

// A scratch path: a polyline with arc-length parameterisation. Cubic Bezier chains and circular
// arcs are flattened into it with a bounded chord error (Bosch §3.1 allows lines and cubic
// curves; the renderer replaces the path by its tangent line inside a pixel anyway, digest §1.7).
class ScratchPath {
 public:
  ScratchPath() = default;
  // At least two distinct points; repeated consecutive points are dropped. Throws
  // std::invalid_argument otherwise.
  // A vertex that goes back along the line the path came on and ends within kRetraceSnap (mm)
  // of it is put on that line (snapRetraces).
  static ScratchPath polyline(std::vector<Vec2d> pts);
  static constexpr double kRetraceSnap = 1e-4;
  // A chain of cubic Bezier segments given by 3k+1 control points (k >= 1). Flattened by
  // recursive de Casteljau halving until both inner control points lie within max_chord_error
  // of the chord segment; by the convex-hull property every curve point is then within
  // max_chord_error of the polyline.
  static ScratchPath bezier(const std::vector<Vec2d>& ctrl, double max_chord_error_mm = 1e-3);
  // A circular arc from angle start_rad sweeping sweep_rad (> 0 counter-clockwise), with
  // sagitta <= max_chord_error_mm per segment.
  static ScratchPath arc(Vec2d centre, double radius, double start_rad, double sweep_rad,
                         double max_chord_error_mm = 1e-3);

  double length() const { return arc_.empty() ? 0.0 : arc_.back(); }
  const std::vector<Vec2d>& points() const { return pts_; }
  const std::vector<double>& arcLengths() const { return arc_; }  // cumulative, arc_[0] = 0
  Vec2d pointAt(double s) const;    // s clamped to [0, length]
  Vec2d tangentAt(double s) const;  // unit tangent of the segment containing s
  // The part of the path between arc positions s0 < s1 (clamped to [0, length]) as a new path.
  // Throws std::invalid_argument when the clamped interval is empty.
  ScratchPath sub(double s0, double s1) const;
  Box2 bounds() const { return box_; }
  // Whether segments i and j lie on one line, in the double coordinates: parallel or opposite
  // within 1e-9 rad, and j's start on i's line within 1e-9 of the coordinates' magnitude. A path
  // that goes exactly back over itself (or was put back on its line by snapRetraces) passes; the
  // float segments of a short leg on a slanted line are a few 1e-6 rad off their line.
  bool segmentsOnOneLine(size_t i, size_t j) const;

  // Closest point of the path to p. With a finite max_dist the path's segment grid is used
  // (Bosch §4 / digest §1.5.1: a uniform grid, here per path) and found = false when the path is
  // farther than max_dist; with the default it is an exhaustive scan.
  PathPoint closest(Vec2f p, float max_dist = std::numeric_limits<float>::infinity()) const;
  // The closest point of each branch of the path near p: a branch is a run of consecutive
  // segments that each come within max_dist of p, so a path that leaves that disc and comes back
  // into it (a hairpin, a loop, a path that crosses itself) has one branch for each pass. out[0]
  // is closest(p, max_dist), the others follow in path order; empty when nothing is that near.
  // A run is also cut where the path goes away from p by `rise` beyond its nearest point so far
  // and comes back by as much (a hairpin whose turn lies within max_dist of p, as it does when the
  // reach is long, still has its two legs). With runs, also each branch's segments (first and
  // last index), in the order of out.
  void closestBranches(Vec2f p, float max_dist, std::vector<PathPoint>& out,
                       float rise = std::numeric_limits<float>::infinity(),
                       std::vector<std::pair<size_t, size_t>>* runs = nullptr) const;
  // The closest point to p of segments first to last alone (as closest, which it equals where the
  // path's closest point lies on them).
  PathPoint closestOnSegments(Vec2f p, float max_dist, size_t first, size_t last) const;

  // An interior vertex where the path turns by at least kCornerTurn (rad): a polyline's corner, or
  // a kink between two cubic curves. A flattened curve's own turns stay below it where its radius
  // is above about 0.26 mm (at the 1 um chord error, turns of sqrt(8 e / r)); on a tighter curve
  // some of its vertices pass it, and the bends around them (bendsAround) carry the curve. The
  // groove renderer gives such a vertex its two legs and the round outer side the explicit
  // geometry has there (render/groove_area.h, cornerParts). turn > 0: to the left.
  struct Corner {
    size_t vertex = 0;
    double s = 0;  // arc position
    Vec2d p{0, 0}, t_in{1, 0}, t_out{1, 0};
    double turn = 0;
  };
  static constexpr double kCornerTurn = 10.0 * 3.14159265358979323846 / 180.0;
  const std::vector<Corner>& corners() const { return corners_; }
  // The corner nearest p within max_dist, or null.
  const Corner* nearestCorner(Vec2d p, double max_dist) const;
  // Of the two corners around arc position s (the last at or before it and the first at or after
  // it, so that the segment at s is one of the corner's legs), the nearer to p within max_dist, or
  // null.
  const Corner* cornerAround(double s, Vec2d p, double max_dist) const;
  // The arc positions where corner c's legs end: the corners before and after it, or the path's
  // ends.
  std::pair<double, double> legSpan(const Corner& c) const;
  // The arc positions of the corners around arc position s (the last before it and the first
  // after it), or the path's ends: the straight run of the path that holds s.
  std::pair<double, double> spanAt(double s) const;

  // Bends: where a curve turns tightly near a point (a small loop or U-turn of a cubic, flattened
  // into many vertices, some past kCornerTurn and most below it), neither its tangent at the
  // closest point nor the straight legs between its corners stand for it. The window of arc
  // position s runs from s's segment out to the first vertex on each side farther than `reach`
  // from p. Simplified (Douglas-Peucker) so that each dropped vertex lies within tol + growth * (its
  // distance from p) of the kept polyline, its kept interior vertices are the bends, as corners
  // (vertex, s, p, the simplified legs' directions and the turn between them; a polyline's corners
  // are kept as such where their legs are straight), and `span` the window's arc range. Where the
  // kept leg over s's own segment turns from that segment by more than max_dev (radians), the
  // segment's two ends are kept too, so that the leg at p has the path's own direction: a wall's
  // glint moves along a curve with its direction. With near > 0 the same holds for every segment
  // within near of p beyond s's own segment's distance (the segments that are the closest to
  // some point of a footprint of radius near / 2 about p): inside a tight curve the borders
  // between the legs' walls (their angle bisectors) then stand where the path's own do, as long
  // as that keeps no more than max_near bends, or max_bends where that is more (else only s's
  // segment is held so). Where the simplification alone keeps more than max_bends, growth is
  // doubled (tol where growth is 0), up to 16 times, so that the path stays as close near p.
  // False (out cleared) where no vertex is kept, or past that.
  bool bendsAround(double s, Vec2d p, double reach, double tol, double growth, double min_stray, size_t max_bends,
                   double max_dev, std::vector<Corner>& out, std::pair<double, double>& span,
                   double near = 0, size_t max_near = 0) const;

 private:
  void finish();  // arc lengths, box, float copy, segment grid
  // bendsAround's kept vertices (indices in [a, b], the window's ends implied) made the same on
  // both passes of each stretch where the path goes exactly back over its own points.
  void keepRetracesAlike(size_t a, size_t b, std::vector<char>& keep) const;
  // Puts a vertex that comes back within kRetraceSnap of its own line exactly on it.
  void snapRetraces();
  void closestOnSegment(size_t i, Vec2f p, float& best_d2, size_t& best_i, float& best_t) const;
  // The corner of [b, e) nearest p within max_dist (the later on a tie), or null.
  static const Corner* nearestOf(const Corner* b, const Corner* e, Vec2d p, double max_dist);
  // Calls visit(i) for each segment in the grid cells within max_dist of p (some more than once);
  // false, having called nothing, where the path has no grid, max_dist is infinite or a scan of
  // every segment is cheaper.
  template <class Visit>
  bool forSegmentsNear(Vec2f p, float max_dist, Visit&& visit) const;
  // The PathPoint of the point at parameter t of segment i, d2 its squared distance from p (not
  // found past max_dist).
  PathPoint pointOn(Vec2f p, size_t i, float t, float d2, float max_dist) const;
  std::vector<Vec2d> pts_;
  std::vector<double> arc_;
  std::vector<Vec2f> ptsf_;
  std::vector<float> arcf_;
  Box2 box_;
  // Segment grid: gx_ x gy_ cells over box_, cell lists in CSR form.
  int gx_ = 0, gy_ = 0;
  float cell_w_ = 1, cell_h_ = 1;
  std::vector<uint32_t> cell_start_, cell_seg_;
  std::vector<Corner> corners_;
};

// ------------------------------------------------------------------------------------------------
// Cross-sections
// ------------------------------------------------------------------------------------------------

// The coating over the part, top first (e.g. clear coat, base coat, primer, then the substrate).
// The last layer is the substrate; its thickness is ignored (infinite).
struct CoatingLayer {
  std::string name;
  double thickness_mm = 0;
};
struct LayerStack {
  std::vector<CoatingLayer> layers{{"metal", 0.0}};
  // Index of the layer exposed at depth d >= 0 below the original surface (0 = top layer).
  int layerAtDepth(double depth_mm) const;
  // Depths (mm, > 0) of the interfaces between layers, top first.
  std::vector<double> interfaces() const;
};

// A cross-section polyline in the BW plane (mm): points (b, w) with b non-decreasing (monotone
// profiles, digest §5.3; vertical facets allowed), starting and ending on the base surface
// (w = 0). Facet k joins pts[k] and pts[k+1] and shows material layer layer[k].
struct Profile {
  std::vector<Vec2d> pts;
  std::vector<int> layer;  // per facet; index into a LayerStack

  // Validates (>= 2 points, finite, b non-decreasing, ends at w = 0 within 1e-12 mm, which are
  // then set to exactly 0), drops zero-length facets, sets every facet to layer 0. Throws
  // std::invalid_argument.
  static Profile fromPolyline(std::vector<Vec2d> pts);

  size_t facets() const { return pts.size() < 2 ? 0 : pts.size() - 1; }
  double bMin() const { return pts.front().x; }
  double bMax() const { return pts.back().x; }
  double width() const { return bMax() - bMin(); }  // visible width, peaks included
  double halfExtent() const { return std::max(-bMin(), bMax()); }  // farthest |b|
  double depth() const;       // -min w (>= 0)
  double peakHeight() const;  // max w (>= 0)
  double grooveArea() const;  // area between the polyline and w = 0 where w < 0 (mm^2)
  double peakArea() const;    // area between the polyline and w = 0 where w > 0 (mm^2)
  // Height at offset b (0 outside [bMin, bMax]; at a vertical facet the lower end's left value).
  double heightAt(double b) const;
  // Uniformly scaled copy (b and w by k, k >= 0); layers are kept (re-run withLayers after a
  // scale when the depth matters).
  Profile scaled(double k) const;
  // Copy with facets split where they cross a layer interface, each facet assigned the layer at
  // its mid-depth; facets above the base surface (pile-up) show the top layer.
  Profile withLayers(const LayerStack& stack) const;
  // Keeps the part on one side of b = bc (b <= bc with `below`, else b >= bc), closed by a
  // vertical facet to the base at bc of the layer of the facet cut there; no points left where
  // nothing is on that side. (Where two passes of one path overlap, the renderer's sections keep
  // each on its side of their midline: the nearer pass, as Scratch::height takes it.)
  void keepSide(double bc, bool below);
};

// Process model, Bosch §3.2 (digest §1.4.2), equation by equation.
// Penetration depth p = 0.182 sqrt(F_N/H_V + 0.0055) - 0.014 [mm], clamped at 0 (the fit is
// negative for F_N/H_V < 4.17e-4, digest §5.3).
double scratchDepthMm(double force_kg, double hardness_hv);
// Outer peak slope from the inner one: tan(beta) = -0.56 + 2.54 tan(alpha), unclamped.
double peakTanBetaRaw(double tan_alpha);
// The same clamped to beta >= kMinPeakBetaRad (the fit gives beta <= 0 for alpha <= 12.43 deg;
// digest §5.3 asks for a small positive minimum, our choice is 3 degrees).
constexpr double kMinPeakBetaRad = 3.0 * kPi / 180.0;
double peakBeta(double alpha_rad);
// Cap on the inner peak slope used for the peaks (the groove wall itself may be steeper, up to
// vertical for an overhanging tilted tool): at alpha -> 90 deg the beta fit diverges and a peak
// would have zero width. Our choice; the thesis measured blunt tools only.
constexpr double kMaxPeakAlphaRad = 80.0 * kPi / 180.0;
// Height of a triangular peak with inner/outer slopes alpha, beta holding area `peak_area`:
// area = h^2 (cot a + cot b) / 2. With peak_area = A/2 per side this is Bosch's
// h = sqrt(A / (cot a + cot b)) (conservation of volume, §3.2.2).
double peakHeight(double peak_area, double alpha_rad, double beta_rad);

// The tool: a cone with a spherical tip (Rockwell diamond: 120 deg, 0.2 mm; a nail: ~40 deg) or a
// regular pyramid (Vickers: 4 faces, 136 deg between opposite faces), tilted by (theta_t, phi_t):
// theta_t from the surface normal, phi_t from the scratch direction T towards B (phi_t = +-90 deg
// tilts across the scratch, as in Bosch's nail tests). Validated: 10 <= apex <= 170 deg, and the
// tilt must keep the tip the lowest point (theta_t < 90 deg - 1 deg - the half-angle of the
// steepest generator: apex/2 for a cone, the edge's for a pyramid). A tilt beyond apex/2 makes the
// far flank overhang: the groove then gets a vertical wall on that side.
struct ToolSpec {
  enum class Shape { Cone, Pyramid } shape = Shape::Cone;
  double apex_angle_rad = 120.0 * kPi / 180.0;  // cone: full apex angle; pyramid: face to face
  double tip_radius_mm = 0.0;                   // cone only
  int pyramid_faces = 4;
  double roll_rad = 0.0;                        // pyramid: rotation about its own axis
  double theta_rad = 0.0, phi_rad = 0.0;        // orientation (theta_t, phi_t)
};

struct ScratchProcess {
  ToolSpec tool;
  double force_kg = 1.0;
  double hardness_hv = 100.0;
  // Fraction of the groove's volume piled up into the two peaks: 1 = Bosch's no-loss assumption
  // (metals, tool not too sharp); less for cutting tools or coatings that do not pile up (the
  // thesis does not model non-metals, digest §1.4.5).
  double pileup = 1.0;
};

// Everything the derivation produced (digest §1.4.3): left side = b < 0.
struct ProcessCrossSection {
  Profile profile;  // layers all 0; apply Profile::withLayers
  double depth = 0;                     // p (mm)
  double groove_area = 0;               // A (mm^2)
  double b_left = 0, b_right = 0;       // where the groove crosses w = 0
  // [0] left, [1] right (radians). alpha is the groove wall's angle at w = 0; the peak uses
  // min(alpha, kMaxPeakAlphaRad), so w_inner = h cot(min(alpha, cap)).
  double alpha[2] = {0, 0}, beta[2] = {0, 0};
  double h[2] = {0, 0}, w_inner[2] = {0, 0}, w_outer[2] = {0, 0};
};

// The largest tilt theta_t (radians) that keeps the tool's tip its lowest point: 90 deg - 1 deg -
// the half-angle of its steepest generator (apex/2 for a cone; for a pyramid its edge's,
// atan(tan(apex/2) / cos(pi / faces)), which is steeper than its faces'). Negative when no tilt
// is allowed (an apex so wide that even the upright tool is within 1 degree of lying flat).
double maxToolTilt(const ToolSpec& tool);

// The groove the moving tool leaves: the lower envelope of the tilted tool projected along T
// onto the BW plane (for an upright axisymmetric tool this is the axial slice the digest names),
// with its lowest point at w = -depth, clipped to w <= 0. Points from b_left to b_right.
std::vector<Vec2d> toolGroove(const ToolSpec& tool, double depth_mm);
// Depth from the force, groove from the tool, peaks per side from alpha, beta and A/2 each,
// assembled outer foot -> apex -> groove -> apex -> outer foot. Throws std::invalid_argument
// for an invalid tool. depth 0 gives a flat two-point profile of zero width.
ProcessCrossSection deriveCrossSection(const ScratchProcess& proc);
// The same for a given depth (the force law bypassed).
ProcessCrossSection deriveCrossSectionForDepth(const ToolSpec& tool, double depth_mm,
                                               double pileup = 1.0);

// ------------------------------------------------------------------------------------------------
// Variation along the path
// ------------------------------------------------------------------------------------------------

// The cross-section at arc position s is the reference cross-section scaled uniformly by
// scale(s) (Bosch §3.1: "usually ... simply scale the cross-section"), stored like Bosch's
// perturbation function as a piecewise-linear table.
//
// Fade law: the normal force ramps up from 0 at each end over fade_length_mm with the smoothstep
// g(u) = 3u^2 - 2u^3, u = min(s, L - s) / fade_length (a tool landing and lifting; C1, monotone,
// g(0) = 0). For process scratches the depth follows the force through the p(F_N, H_V) law and
// scale(s) = p(F(s) g(s)) / p(F_ref); it reaches 0 slightly before the end, where F/H_V falls below
// 4.17e-4. For explicit profiles scale(s) = g(s). fade_length 0 gives blunt ends.
// force_keys: optional (fraction of the length in [0, 1], force kg) pairs, linearly interpolated
// (Bosch §3.2.3), for process scratches; F_ref is then the largest key.
// Random perturbation: scale *= 1 + noise_amplitude * n(s), n a smooth value noise in [-1, 1]
// with knots every noise_wavelength_mm, seeded by noise_seed.
struct ScratchPerturbation {
  double fade_length_mm = 0.0;
  std::vector<std::pair<double, double>> force_keys;
  double noise_amplitude = 0.0;  // in [0, 1)
  double noise_wavelength_mm = 2.0;
  uint64_t noise_seed = 0;
};

// Smoothstep fade factor used above, for u = distance to the nearer end / fade length.
double scratchFade(double s, double length, double fade_length);

// ------------------------------------------------------------------------------------------------
// The defect
// ------------------------------------------------------------------------------------------------

class Scratch final : public Defect {
 public:
  // A process scratch: the reference profile from proc (with F_ref as above).
  static Scratch fromProcess(ScratchPath path, const ScratchProcess& proc,
                             const ScratchPerturbation& pert = {}, LayerStack layers = {});
  // An explicit cross-section (digest §6.2 `cross_section`).
  static Scratch fromProfile(ScratchPath path, Profile profile,
                             const ScratchPerturbation& pert = {}, LayerStack layers = {});

  DefectClass cls() const override { return DefectClass::Scratch; }
  const char* kind() const override { return "scratch"; }
  // Path box dilated by the largest half-extent of the cross-section along the path.
  Box2 support() const override { return support_; }
  Box2 maskBox() const override { return support_; }
  // With the groove renderer (render/groove_shading.cpp, Bosch §4.2) the footprint is integrated
  // over the cross-section's facets and a scratch adds nothing through the bump interface. In
  // normal-map mode (setBumpShading(true), the comparison baseline of scripts/bench-grooves) it
  // adds the slope of the facet under the point as a height gradient: point-sampled, no masking,
  // no shadowing, no inter-reflection — what texture-based tools do.
  void shade(const DefectQuery& q, DefectShading& s) const override;
  void setBumpShading(bool on) { bump_shading_ = on; }
  bool bumpShading() const { return bump_shading_; }
  // The cross-section's height at p (mm): for the explicit-geometry reference mode.
  float height(Vec2f p) const override;
  // p lies within the cross-section's footprint [scale*bMin, scale*bMax] at its arc position,
  // and not past an end.
  bool inMask(Vec2f p) const override;
  nlohmann::json attributes() const override;

  const ScratchPath& path() const { return path_; }
  const Profile& referenceProfile() const { return ref_; }
  const LayerStack& layers() const { return layers_; }
  // layers().interfaces(), computed once.
  const std::vector<double>& interfaces() const { return interfaces_; }
  float scaleAt(float s) const;  // piecewise-linear table lookup
  float maxScale() const { return max_scale_; }
  // The cross-section at s: reference scaled by scaleAt(s), facets split and assigned layers.
  Profile profileAt(double s) const;
  bool isProcess() const { return is_process_; }
  // Where the groove cuts through the whole coating and bares the substrate (the stack's last
  // layer, e.g. the steel under clear coat, base coat and primer): the arc intervals [s0, s1] (mm)
  // on which depth(s) = scale(s) * reference depth exceeds the coating's total thickness. Ends are
  // placed by linear interpolation of the scale table. A one-layer stack (bare metal) is bared
  // wherever the groove has any depth. Rust that starts at scratches grows from these runs.
  std::vector<std::pair<double, double>> exposedRuns() const;
  const ProcessCrossSection& process() const { return proc_cs_; }

 private:
  Scratch() = default;
  void build(const ScratchPerturbation& pert);
  ScratchPath path_;
  Profile ref_;
  LayerStack layers_;
  std::vector<double> interfaces_;
  bool is_process_ = false;
  ScratchProcess proc_;
  ProcessCrossSection proc_cs_;
  double f_ref_ = 0, p_ref_ = 0;
  ScratchPerturbation pert_;
  std::vector<float> scale_;  // samples at s = i * ds
  float ds_ = 1, max_scale_ = 1;
  Box2 support_;
  bool bump_shading_ = false;
};

// ------------------------------------------------------------------------------------------------
// Random placement (pure functions of the Rng state; deterministic by seed)
// ------------------------------------------------------------------------------------------------

struct UniformRange {
  double lo = 0, hi = 0;
  double sample(Rng& r) const { return lo + (hi - lo) * r.uniformD(); }
};

// A circular-arc scratch of given length, mid-point, direction at the mid-point and signed
// curvature (1/mm, > 0 bends left); curvature 0 gives a segment.
ScratchPath arcScratch(Vec2d mid, double length, double orientation_rad, double curvature,
                       double max_chord_error_mm = 1e-3);

// One long "key" scratch: a cubic Bezier of length ~length_frac * region diagonal whose inner
// control points deviate sideways by at most bend_frac * chord (gentle curvature), inside region.
struct KeyScratchOptions {
  UniformRange length_frac{0.5, 0.8};
  double bend_frac = 0.12;
};
ScratchPath randomKeyScratch(Rng& rng, const Box2& region, const KeyScratchOptions& o = {});

// Wash swirls: `count` arcs concentric about one centre (in region, or `centre` if given), radii
// r0 + i * spacing (+- jitter), each with its own start angle and sweep, clipped to region
// (longest run inside; runs shorter than min_length_mm are dropped).
struct SwirlOptions {
  int count = 8;
  UniformRange radius0_mm{40, 120};
  UniformRange spacing_mm{0.8, 2.5};
  double spacing_jitter = 0.2;  // fraction of the spacing
  UniformRange sweep_rad{0.3, 1.2};
  double min_length_mm = 3.0;
  bool fixed_centre = false;
  Vec2d centre{0, 0};
};
struct SwirlSet {
  Vec2d centre;
  std::vector<double> radii;  // per kept arc
  std::vector<ScratchPath> arcs;
};
SwirlSet randomWashSwirls(Rng& rng, const Box2& region, const SwirlOptions& o = {});

// A generic scratch: length, orientation and curvature drawn uniformly from the ranges (curvature
// sign random), mid-point uniform in region shrunk so the scratch fits (fewer than 32 tries, then
// the length is halved).
struct GenericScratchOptions {
  UniformRange length_mm{5, 40};
  UniformRange orientation_rad{0, kPi};
  UniformRange curvature{0, 0.02};  // |1/mm|
};
ScratchPath randomScratch(Rng& rng, const Box2& region, const GenericScratchOptions& o = {});

}  // namespace dg
