// Area sampling of grooves with polygons, for the footprints that 1-D line sampling cannot
// integrate: crossings and ends (Bosch 2007 §4.2.4; shared/reference/bosch-grooves.md §2.2.4).
// Pure geometry in doubles, no renderer types, like render/groove.h.
//
// Coordinates are footprint-centred: x along the first groove's T, y along its B, z along the
// surface normal W (mm). Near one footprint every groove is straight (its tangent line, digest
// §1.7), its cross-section scales linearly along it (the force fade) and it may end. The composite
// surface (the lower surface where a groove cuts below the base, else the highest pile-up: the
// rule of the explicit-geometry reference) is then piecewise planar: `Surface` cuts a convex
// region into convex pieces, each lying on one facet of one groove (or on the base plane).
//
// On those pieces Bosch's per-facet steps become clipping of convex polygons:
//  - the footprint projected onto a piece along the view, clipped to the piece (step 1);
//  - the removal of what intersecting grooves cut away is already in the pieces (step 2);
//  - masking and shadowing (step 3): a point of piece P is hidden along a direction d when the
//    ray towards d enters the solid, i.e. crosses a piece Q facing away from d (N_Q.d < 0) on the
//    d-side of P's plane. So the hidden part is the union of those Q's projections along d onto
//    P's plane, each a convex polygon, subtracted from the portion;
//  - the reflected share (step 4) is the remaining area's share of the footprint;
//  - inter-reflection (§4.3): the rays leaving a portion along d hit the facing pieces in order of
//    distance; each claims the part of the portion under its projection, mapped onto itself.
// Differences of convex polygons are kept as lists of convex fragments. The number of fragments
// of one portion is capped (kMaxFragments); past it the smallest are dropped (`overflow` counts
// it), so the cost per footprint stays bounded.
#pragma once
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <vector>

#include "core/math.h"

namespace dg::groove::area {

// A convex polygon in the plane, counter-clockwise, with at most kMaxVertices vertices.
struct Poly {
  static constexpr int kMaxVertices = 40;
  // The vertices v[0 .. n-1]; the rest is left uninitialised (a union member), and copies take
  // the n vertices only: the clipping makes and copies polygons at every step (most have 3 to 8
  // vertices), and zeroing and copying whole 640-byte arrays was most of its time.
  union {
    Vec2d v[kMaxVertices];
  };
  int n = 0;
  Poly() {}
  Poly(const Poly& o) : n(o.n) { std::memcpy(v, o.v, sizeof(Vec2d) * size_t(o.n)); }
  Poly& operator=(const Poly& o) {
    if (this != &o) std::memcpy(v, o.v, sizeof(Vec2d) * size_t(o.n));
    n = o.n;
    return *this;
  }
  bool empty() const { return n < 3; }
  double area() const;  // signed (> 0 counter-clockwise)
  // Grows the box [lo, hi] to hold every vertex.
  void extend(Vec2d& lo, Vec2d& hi) const;
  void push(Vec2d p) {
    if (n < kMaxVertices) v[size_t(n++)] = p;
  }
};

// The part of p where a.x * x + a.y * y + c <= 0. A (near-)zero a keeps all or nothing by the
// sign of c (with `strict`, c == 0 keeps nothing: used to break ties between identical planes).
Poly clip(const Poly& p, Vec2d a, double c, bool strict = false);
// The part of p inside the convex polygon q.
Poly intersect(const Poly& p, const Poly& q);

// z = z0 + g.(x, y).
struct Plane {
  double z0 = 0;
  Vec2d g{0, 0};
  double at(Vec2d p) const { return z0 + g.x * p.x + g.y * p.y; }
  Vec3d normal() const;  // unit, z > 0
};

// The half-plane a.p + c <= 0.
struct HalfPlane {
  Vec2d a{0, 0};
  double c = 0;
  bool holds(Vec2d p) const { return a.x * p.x + a.y * p.y + c <= 0; }
};

// One groove near the footprint. The groove's own coordinates of a point p: b(p) = b0 + p.bdir
// across (b > 0: the profile's +b side), t(p) = t0 + p.tdir along. The profile (points (b, w),
// one layer per facet) holds at t = 0; along t it is scaled by r(t) = 1 + rho t (the force fade)
// where r > 0, and the groove exists only for t in [t_lo, t_hi] (its ends).
struct Groove {
  Vec2d tdir{1, 0}, bdir{0, 1};
  double t0 = 0, b0 = 0;
  double rho = 0;
  double t_lo = -1e30, t_hi = 1e30;
  const std::vector<Vec2d>* pts = nullptr;
  const std::vector<int>* layer = nullptr;
  // Depths (mm, top first) of the interfaces between its coating layers: the bands of the walls
  // that it cuts below the base plane. Null: a wall below the base shows its foot's layer.
  const std::vector<double>* interfaces = nullptr;
  int id = 0;  // caller's index
  // A groove whose path turns a corner near the footprint is made of parts (cornerParts,
  // chainParts, passParts): each part a groove as above that holds only where its `dom`
  // half-planes hold, their domains tiling the plane (chainParts: the region it was given). Such a
  // groove counts as one (one plane per cell, one id); its own fields other than `parts` and `id`
  // are not used. A part's own `parts` is null.
  //
  // A cell keeps every line that passes within rounding of two of its vertices, and the clipping
  // can leave a vertex as a cluster of points a rounding apart. At a corner's vertex, where the
  // edges of all its fan's sectors meet, a leg's cell that reaches the vertex then keeps all of
  // them, though only two bound it along an edge. Up to kMaxDom they are kept (they cut nothing
  // off the cell); past it chainParts drops those that the cell's other lines imply. (10 until
  // 2026-12-01, with nothing dropped: a leg's cell at c47_4's corner of 163 degrees, with a
  // straight pass across its legs, kept 12 lines, and c45_6's knot of four corners 17 to 21;
  // chainParts refused both chains. GrooveArea.ACornerAndAPassAcrossItsLegsAreOnePartition,
  // GrooveArea.AChainsCellsDropTheLinesTheirOthersImply.)
  static constexpr int kMaxDom = 16;
  const std::vector<Groove>* parts = nullptr;
  HalfPlane dom[kMaxDom];
  int n_dom = 0;
  // A line (split.a . p + split.c = 0) across which the surface may step anywhere along it: the
  // first leg's line beyond a half turn, where the cap takes the profile's two sides (appendFan).
  // Surface::build looks for walls along every piece edge on it, as on an abrupt end's line.
  bool has_split = false;
  HalfPlane split;
};

// Whether part q's domain (its `dom` half-planes; none for a plain groove) holds p.
bool inDomain(const Groove& q, Vec2d p);

// The parts of a groove that turns a corner at the point where `in` ends and `out` starts: `in`
// along the path before the corner, with t = 0 at the vertex (t_hi = 0), `out` after it (t_lo =
// 0, t = 0 at the vertex), each with its own frame, the same profile (the one at the vertex: r = 1
// there) and id. The surface is the one the explicit geometry cuts (Scratch::height): each point
// takes the cross-section at its closest point on the path, so the two legs meet along the
// bisector of the corner on its inner side (each leg holds on its side of it), and around the
// vertex on the outer side, where the vertex itself is the closest point, the profile's outer
// half turns about the vertex. That cap is a fan of sectors no wider than `max_sector` (rad), each
// a straight groove through the vertex clipped to its wedge, with its profile stretched by 1 /
// cos(half the sector) so that neighbouring sectors and the legs meet without a step (the cap
// lies within 1 - cos(max_sector / 2) of the round one in its radii). Appends the parts to `out_parts`
// (cleared first). False (nothing appended) for a turn of less than 1e-6 rad.
//
// Past kMaxCornerTurn the legs' bisector degenerates: its normal, the sum of the legs' directions,
// is 2 cos(turn / 2) long, 1.7e-3 at 179.9 degrees, so that the legs' directions, rounded to float
// in the integrator's frames, turn it by up to about 1e-4 rad (on the inner side, where both legs
// give nearly the same height), and at a half turn it has no direction. There the path is taken
// to go back along itself, the cap being the half disc beyond the vertex. Where the legs lie on
// one line (within kOneLineTurn of a half turn) `in` holds up to the vertex on both sides of its
// line, as the explicit geometry gives the tie to the earlier segment, and the cap takes on each
// side of that line the profile's half on that side; short of that, `in` holds on its outer side
// and `out` on the inner, split along `in`'s line (the bisector lies within 0.05 degrees of it),
// and the cap takes the profile's outer half, as the closest point's tangent there, the legs'
// mean, is across `in`. (The two differ where the profile's sides do: a tilted tool's.) (175
// degrees until 2026-11-29: a
// path doubling back by 176 to 179 degrees ran straight past its vertex, its tip 0.3-0.4% of
// pixels >= 10 against geometry at 512 spp where now under 0.1%; past 179.9 degrees, a path
// going exactly back over itself, until 2026-11-30: docs/grooves.md, "Corners".)
constexpr double kMaxCornerTurn = 179.9 * 3.14159265358979323846 / 180.0;
// A half turn, and how near a turn must come to it for its legs to be one line (the explicit
// geometry's test, ScratchPath::closest, in float: their directions' cross product within 1e-6).
constexpr double kPiTurn = 3.14159265358979323846;
constexpr double kOneLineTurn = 1e-6;
bool cornerParts(const Groove& in, const Groove& out, double max_sector, std::vector<Groove>& out_parts);

// The parts of a groove whose path turns at several corners near the footprint (a hook, a U-turn
// made of two corners, a zigzag): legs[0..n] (n >= 1) its straight legs in path order, leg k + 1
// starting at corner k, each in its own frame as for cornerParts. Leg 0 has t = 0 at corner 0 (its
// end, t_hi = 0); every later leg has t = 0 at its start corner (t_lo = 0), and each but the last
// ends at the next corner (t_hi: that corner's t along it). Every leg's profile is the one at its
// t = 0 (so the fan of corner k takes leg k + 1's); its rho carries it to the next corner's.
//
// The surface is again the explicit geometry's, each point taking the cross-section at its closest
// point on the path, but the corners' legs and round outer sides now meet each other too: the
// two legs of a U-turn side by side, a hook's last leg beside its first. The plane is partitioned
// by nearness: each leg is a candidate over its strip (between its corners' normals; the first
// and last leg unbounded beyond their far ends, where the groove's own ends hold), each sector of
// a corner's fan (as in cornerParts) over its wedge, and every point goes to the candidate with
// the smallest |b| there (for two candidates a and b the cut runs along b_a - b_b = 0 and b_a + b_b
// = 0, as in passParts). A corner that turns by more than kMaxCornerTurn is a half turn, as in
// cornerParts: its fan is the half disc beyond the vertex; where two candidates lie on one line
// (1e-6 in direction and 1e-6 mm in place), the earlier keeps what they share. Each cell of the partition is a part,
// its domain the half-planes that bound it within `bound` (the largest region the caller will
// build), so the parts tile `bound`; a cell with more than Groove::kMaxDom of them keeps only
// those that its others do not imply (within kThinCut). Appends the parts to `out_parts`
// (cleared first). False (nothing appended) where the partition needs more than kMaxChainCells
// cells or a cell more than Groove::kMaxDom half-planes that its others do not imply.
// (400 until the fifty-ninth session. A cubic that curls twice within 0.2 mm, seen on one curl's
// wall, took 14 bends whose partition has about 430 cells; at 400 the window fell back to 8
// bends, which drew the other curl as one corner whose chord ran 18 um inside the path, and
// another scratch's pile-up stood up as a wall there that sent a glint into the bar (the passes
// fuzzer's p76_0; docs/grooves.md, "Bends").)
constexpr size_t kMaxChainCells = 1000;
// No cell of the partition is narrower than kThinCut (mm) across one of its cuts: a line that
// passes within it of a cell's far side leaves the cell whole. A tenth of a nanometre, far below
// anything a footprint resolves; the strips that lines computed in different frames left between
// them over the regions of the accuracy and fuzzer scenes were up to about that wide.
constexpr double kThinCut = 1e-7;
//
// run_starts: the legs (in increasing order) where another pass of the path starts, with no
// corner between it and the leg before it (a loop whose passes near the footprint are apart along
// the path, each with its bends): each run's first and last legs are unbounded beyond their far
// ends, a run of one leg everywhere, and all runs' candidates share the partition, as passParts
// does for two straight passes.
bool chainParts(const std::vector<Groove>& legs, double max_sector, const Poly& bound, std::vector<Groove>& out_parts,
                const std::vector<size_t>& run_starts = {});

// The parts of a path that passes near the footprint twice (a hairpin's two legs, a loop that
// crosses itself), `a` and `b` each straight along its pass, with the same id: the explicit
// geometry takes each point's cross-section at the path's closest point (Scratch::height), so each
// pass holds where it is the nearer, |b_a(p)| <= |b_b(p)|, and not the composite of the two that
// two scratches make. The bisectors of the two lines, b_a - b_b = 0 and b_a + b_b = 0, cut the
// plane into four wedges, two for each pass (parallel passes: one half-plane each, the other
// bisector being at infinity). Appends the parts to `out_parts` (cleared first). False (nothing
// appended) where the two lie on one line (within 1e-12 mm): the same groove twice, whose
// composite is either.
bool passParts(const Groove& a, const Groove& b, std::vector<Groove>& out_parts);

// The same where each pass is in pieces along its line (a[0..na), b[0..nb), in any order: the
// integrator's scaleSegments, where a cross-section's scale is far from linear over the region,
// each piece with its own t0, rho, profile and t range on the one line of its pass). Within its
// pass's two wedges each piece holds over its own stretch of the line, between the midpoints of
// the gaps to its neighbours' t ranges (the first and last unbounded beyond them), so a point
// takes the piece of the nearer pass at its closest point, as Scratch::height does. With one
// piece each it gives passParts' parts, in the same order. False (nothing appended) as there,
// or where a pass has no pieces or a piece's line is not its pass's first piece's.
bool passPieces(const Groove* a, size_t na, const Groove* b, size_t nb, std::vector<Groove>& out_parts);

// One groove in pieces along its line (g[0..n), in any order, n >= 1: scaleSegments' pieces of a
// single pass) as one groove of parts: each piece holds over its stretch of the line, as in
// passPieces, the first and last unbounded beyond their far ends, so the parts tile the plane.
// The surface is the pieces' composite, but the groove counts as one against
// Surface::kMaxGrooves and takes one plane in each cell, as the whole groove does. (Entered as
// separate grooves, six scratches each in three pieces passed that cap where the whole grooves
// did not, and the surface was built with the whole grooves instead: the fuzzer's c56_1.) False
// (nothing appended) where n is 0, a piece is itself of parts, or a piece's line is not the first
// piece's.
bool pieceParts(const Groove* g, size_t n, std::vector<Groove>& out_parts);

// Whether the centre lines of grooves a and b (each its line b = 0 over [t_lo, t_hi]; not parts)
// come within w of each other inside the disc of radius r about the origin: where two passes of one
// path, each of half-width w / 2 at most, do not, their grooves do not overlap there, and their
// composite is the surface that chainParts' partition by nearness would give.
bool centreLinesWithin(const Groove& a, const Groove& b, double r, double w);

// A planar convex piece of the composite surface.
struct Piece {
  Poly poly;    // in (x, y)
  Plane plane;  // its height
  int groove = -1;  // Groove::id, -1 for the base plane
  int layer = 0;    // material layer (0: the top coat)
  Vec2d lo{0, 0}, hi{0, 0};  // bounding box of poly
  double zmax = 0;            // highest point
  bool wall = false;          // one of the two steep pieces that stand for a wall (Surface::Wall)
  // No groove cuts below the base here (the composite is the highest groove's height, or the
  // base's): where every groove's height is continuous, the composite cannot step up beyond it.
  bool raised = false;
};

// A portion: a region of one piece (convex fragments in (x, y)) with the footprint weight per unit
// of (x, y) area that it carries.
struct Portion {
  int piece = -1;
  std::vector<Poly> frags;
  double density = 0;
  double weight = 0;  // density * area, kept up to date by the functions below
};

struct Hits {
  std::vector<Portion> hits;  // weights: shares of the portion's weight
  double escaped = 0;         // the share that leaves the surface
  // Where the escaped share leaves the portion: the centroid of its fragments. A direction that
  // does not rise (d.z <= 0) leaves the region sideways (Surface::leaving); one that rises low may
  // meet a pile-up beyond it (the integrator's pileUpAhead).
  Vec2d escaped_at{0, 0};
};

class Surface {
 public:
  static constexpr size_t kMaxFragments = 48;
  // 1,200 since 2026-11-26 (600 before): on the fuzzer's densest clusters (docs/grooves.md,
  // "Fuzzing") it took the pixels >= 10 from 2.95% to 1.35% (c1_2) and 0.56% to 0.17% (c3_13), for
  // 20-65% more time there. Of the accuracy scenes only `star` and `dense` reach 600; no footprint
  // of the bench's scenes or of the example configs does.
  static constexpr size_t kMaxPieces = 1200;
  // The renderer's cap in close views (since 2026-11-30; the integrator's buildArea says when):
  // enough for a loop of bends crossed by a polyline seen at 1 degree (about 3,800 pieces at the
  // full reach), whose light from beyond a quarter of the reach was lost at the ordinary cap.
  // 16,000 since 2026-12-02 (4,000 before): twelve deep scratches crossing in a cluster seen at
  // 2 degrees (the clusters fuzzer's c56_1) need 8,000 to 16,000 at the full reach, and at half
  // of it lost the light their walls pass between them: 2.60% of pixels >= 10, now 0.17%, in half
  // the time (a refused build costs about as much as a finished one). docs/grooves.md, "Close
  // views".
  static constexpr size_t kMaxPiecesClose = 16000;
  // At most this many grooves per surface (the callers keep the nearest past it). 16 since
  // 2026-11-30 (8 before; docs/grooves.md, "Sixteen grooves").
  static constexpr size_t kMaxGrooves = 16;
  // Surfaces of up to this many grooves are cut with cells that hold this many planes.
  static constexpr size_t kSmallGrooves = 8;
  // A groove of at least this many parts (a chain of bends) has them found through a grid of their
  // boxes (below); fewer are tried in turn, which costs less than the grid.
  static constexpr size_t kPartsIndexed = 32;

  // Cuts `region` (convex, counter-clockwise) into pieces. False when there are more than
  // kMaxGrooves grooves, or the pieces of the surface, or those of its walls, would exceed
  // `max_pieces` (the caller then tries a smaller region, then fewer grooves, and past that falls
  // back to the blend).
  bool build(const Poly& region, const std::vector<Groove>& grooves, size_t max_pieces = kMaxPieces);
  const std::vector<Piece>& pieces() const { return pieces_; }

  // The portions of the pieces seen through the footprint `fp` (a convex polygon on the base
  // plane z = 0: the pixel's parallelogram) from direction e (towards the viewer, e.z > 0), each
  // with its share of the footprint; the shares sum to 1 up to what lies outside the region.
  std::vector<Portion> visible(const Poly& fp, Vec3d e) const;
  // The share of portion p that sees direction l (towards a light) unoccluded by the surface.
  double litFraction(const Portion& p, Vec3d l) const;
  // The same for light direction number `key` (< keys, as set by cacheLights): the shadow
  // polygons on each piece are computed once per direction and kept until the next build.
  void cacheLights(size_t keys) const;
  double litFraction(const Portion& p, Vec3d l, size_t key) const;
  // Where rays leaving portion p in direction d go (d on p's front side).
  Hits scatter(const Portion& p, Vec3d d) const;
  // Where rays leaving portion p into the solid go (d on p's back side: a ray refracted into a
  // glass part): the pieces they meet again from inside (a pile-up's far side, a wall under it,
  // the walls of a crossing groove), with the shares of p's weight mapped onto them, and the share
  // that meets none within the region (`escaped`). Seen upside down this is scatter(): mirrored
  // in z the solid lies above the surface and d points up out of the mirrored pieces, so it is
  // scatter() on the mirrored surface (built at the first call after build(), then kept).
  Hits scatterInside(const Portion& p, Vec3d d) const;
  // Fragments dropped at the cap so far (diagnostics and tests).
  mutable size_t overflow = 0;
  // Where the ray from o along d leaves the region (its box) sideways: the crossing with the
  // box's boundary (`at`, with its height on the ray), and the groove whose centre line is nearest
  // there among those that exist at that point (for a groove of parts, the part whose domain holds
  // it), whose channel the ray runs on in. Null where no groove exists there, or d has no
  // horizontal part. A ray that meets no piece and does not rise leaves this way: the explicit
  // geometry's meets the groove farther along (the integrator hands it to that groove's section).
  const Groove* leaving(Vec3d o, Vec3d d, Vec3d& at) const;
  // Only the crossing: where the ray from o (inside the region's box) along d leaves the box,
  // with its height on the ray. False where d has no horizontal part.
  bool exitPoint(Vec3d o, Vec3d d, Vec3d& at) const;

  // A vertical wall where the composite steps: a groove cutting below the base next to another's
  // pile-up, or a groove that ends before its cross-section has faded out. The quad over the
  // segment a-b from the low side's heights (za0, zb0) up to the high side's (za1, zb1); `out` is
  // the horizontal unit normal towards the low side. A wall is split where the piece beyond
  // changes, so that its top is straight.
  //
  // A vertical plane has no height function over (x, y), so each wall enters pieces() as two
  // triangles leaning back by kWallLean (their top edge moved by kWallLean times the wall's height
  // towards the high side, under its rim): steep pieces like any other, so they are seen, lit,
  // block, and take part in inter-reflection (the corner between a groove's floor and a cut
  // pile-up sends light back as a corner reflector does). The strip under the rim that they lean
  // into is then counted twice: up to 1e-4 of a footprint in the tests. Views within 1e-5 rad of
  // the base plane do not see walls (visible()).
  static constexpr double kWallLean = 1e-3;
  struct Wall {
    Vec2d a, b;
    double za0 = 0, zb0 = 0, za1 = 0, zb1 = 0;
    Vec2d out;
  };
  // The composite height at p, from the grooves' definitions.
  double heightAt(Vec2d p) const;
  // Whether heightAt(p) > z, stopping at the first groove that settles it (the wall search asks
  // this of every piece's edges: most of a close view's build time went to heightAt).
  bool above(Vec2d p, double z) const;
  const std::vector<Wall>& walls() const { return walls_; }

 private:
  // The hidden part of piece `pi` along d as convex polygons in (x, y) (projections of the pieces
  // facing away from d that lie on its d-side), with each one's distance along d at its centroid.
  // Only occluders whose projection can reach the box [lo, hi] (the receiving portion's) are
  // projected.
  void shadowsOn(size_t pi, Vec3d d, Vec2d lo, Vec2d hi, std::vector<Poly>& out, std::vector<double>* dist,
                 std::vector<size_t>* owner) const;
  std::vector<Piece> pieces_;
  // Which pieces can block a direction: shadowsOn is asked for every portion, light sample and
  // continued direction, and of the pieces it tests against a box only 0.5% (the accuracy scenes'
  // crossings) to 2.5% (a dense cluster) can reach the receiving portion. The region's box is cut
  // into kBins columns and kBins rows; bit i of a column's (row's) word set says that piece i's
  // box reaches into it. A query ORs the columns and the rows under its box and tests only the
  // pieces in both, in their order, so that the result is the same as testing them all. A shadow
  // query (candidates()) takes, for each column, only the rows its strip crosses there.
  static constexpr int kBins = 16;
  Vec2d bin_lo_{0, 0}, bin_size_{1, 1};
  double zmax_all_ = 0;  // the highest point of any piece
  size_t words_ = 0;     // 64-bit words per set
  std::vector<uint64_t> col_bits_, row_bits_;
  // What shadowsOn's tests read of each candidate before it clips one, one cache line per piece
  // (a Piece holds its polygon's 40 vertices, 728 bytes): in the close view of the accuracy
  // scene `spot` a surface has about 4,100 pieces, the bins gave about 1,250 candidates per call
  // and 75 of them passed the tests of the time.
  struct alignas(64) Cull {
    double gx, gy, z0;        // the plane
    double lox, loy, hix, hiy;  // the box
    double zmax;
  };
  std::vector<Cull> cull_;
  // The union of rows r0..r1 (r0 <= r1) for every such pair, at rowRange(r0, r1) * words_.
  std::vector<uint64_t> rows_or_;
  static size_t rowRange(int r0, int r1) { return size_t(r0 * kBins - r0 * (r0 - 1) / 2 + (r1 - r0)); }
  void binPieces();
  int binOf(double v, int axis) const;
  // The pieces, in order, whose bins meet the strip where an occluder of P's portion in [lo, hi]
  // along d (den: P's N.d, > 0) can lie (the box swept along d_xy, column by column): a superset
  // of those that can shadow it.
  void candidates(const Plane& P, double den, Vec3d d, Vec2d lo, Vec2d hi, std::vector<size_t>& out) const;
  // Appends the pieces, in order, that are in one of the columns c0..c1 and one of the rows r0..r1.
  void inBins(int c0, int c1, int r0, int r1, std::vector<size_t>& out) const;
  std::vector<Wall> walls_;
  std::vector<Groove> grooves_;
  Vec2d region_lo_{0, 0}, region_hi_{0, 0};  // the box of the region build() was given
  // The parts of a groove made of parts (a chain of bends holds hundreds) that can hold a point
  // of the region: each part's domain, its lines moved out by kPartMargin, clipped to the region
  // grown by it, as a box grown by it too, and a kPartBins x kPartBins grid over the grown region
  // listing, in order, the parts whose boxes reach each bin. build() skips the parts whose box
  // misses a cell's, and heightAt() (three calls per piece edge) looks at its bin's parts only;
  // both give what testing every part gives, since a part's domain within the grown region lies
  // in its box.
  static constexpr int kPartBins = 16;
  static constexpr double kPartMargin = 1e-6;  // mm
  struct PartIndex {
    Vec2d lo{0, 0}, hi{0, 0}, inv{0, 0};         // the grown region's box; bins per mm
    std::vector<Vec2d> box_lo, box_hi;           // per part (lo.x > hi.x: it misses the region)
    std::vector<uint32_t> start, list;           // bin b's parts: list[start[b] .. start[b + 1])
  };
  // Per groove of grooves_; no boxes for a plain groove or one of fewer than kPartsIndexed parts.
  std::vector<PartIndex> part_index_;
  bool parts_indexed_ = false;  // part_index_ is for grooves_ (build() may stop before it)
  void indexParts(const Poly& region);
  template <size_t N>
  bool cutPieces(const Poly& region, const std::vector<Groove>& grooves, size_t max_pieces);
  static int partBin(const PartIndex& ix, double v, int axis);
  const Groove* partOf(size_t gi, Vec2d p) const;
  // Groove gi's height at p (a groove of parts: the part that holds p); false where no part does.
  bool heightOf(size_t gi, Vec2d p, double& h) const;
  // Shadow polygons per (piece, light key): [begin, end) in cache_polys_, begin < 0 if not yet.
  mutable size_t cache_keys_ = 0;
  mutable std::vector<std::pair<int, int>> cache_range_;
  mutable std::vector<Poly> cache_polys_;
  // The surface mirrored in z (scatterInside); its buffers are kept from one build to the next.
  mutable std::unique_ptr<Surface> mirror_;
  mutable bool mirror_built_ = false;
  const Surface& mirrored() const;
  double litWith(const Portion& p, const Poly* shadows, size_t n) const;
};

// Area of a fragment list.
double area(const std::vector<Poly>& frags);
// Its centroid (c), false (c untouched) where its area is not positive.
bool centroid(const std::vector<Poly>& frags, Vec2d& c);
// frags minus the convex polygon s (in place); at most `cap` fragments are kept (the smallest
// dropped, counted in `dropped`).
void subtract(std::vector<Poly>& frags, const Poly& s, size_t cap, size_t& dropped);

}  // namespace dg::groove::area
