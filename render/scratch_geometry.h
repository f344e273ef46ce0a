// The explicit-geometry reference for scratches (issue 5's "reference mode"): the part re-meshed
// with every scratch's cross-section cut into it, to be rendered by the ordinary path tracer with
// many samples. Ground truth for the groove renderer (render/groove.h).
//
// Any part with a UV chart: flat or curved, built in or loaded, its chart filling a rectangle or
// not. The chart's bounding rectangle is divided by a quadtree whose cells are split down to
// `cell_mm` wherever a scratch's cross-section can reach into them and stay coarse elsewhere.
// Part triangles that no cross-section reaches are kept as they are; the others are cut into the
// quadtree's cells (each cell clipped to the triangle in UV) and every piece is mapped back through
// the triangle: its position and normal interpolated, then moved along that normal by the
// scratches' height. A cell that is not split contains no point of any cross-section, so its
// pieces are undisplaced and the finer neighbours' vertices on their edges lie on them: the
// T-junctions leave no cracks. Points on a part triangle's edge are mapped along that edge alone,
// so the two triangles sharing it place them alike.
//
// Heights of overlapping scratches combine as the removed material's union: the lowest groove
// where any groove is below the surface, else the highest pile-up.
#pragma once
#include <vector>

#include "defects/scratch.h"
#include "render/mesh.h"

namespace dg {

struct ScratchGeometryOptions {
  // Largest edge of the finest cells (mm; render.geometry_cell_mm); 0 = automatic: the narrowest
  // scratch's width / 16, at least 0.5 micrometre. Cells are cut along the kinks, so the size only
  // bounds how well the variation along the path and the curved kinks of a corner's round cap
  // are followed (straight kinks are exact at any size).
  double cell_mm = 0;
  size_t max_triangles = 40'000'000;  // refuse rather than exhaust memory
  // The memory the mesh may take at its peak, once it is rendered: its arrays, the renderer's
  // per-triangle frames and Embree's BVH (bytes; 0 = no limit). A mesh whose estimate is larger is
  // refused as soon as its size is known, before it is copied out and given a BVH, rather than
  // left to std::bad_alloc or, under Linux's overcommit, to the kernel's OOM killer.
  uint64_t max_bytes = 0;
  // A finest cell (within one part triangle) is cut along the kinks until it holds this many
  // pieces, then left as it is: a bound on the work and the triangles of one cell whatever the
  // scratches. The scenes of the accuracy tests and the bench need at most 91.
  size_t max_pieces_per_cell = 4096;
  // Only cut and count: the mesh returned is empty, stats get the figures the full mesh would
  // have, and the same errors are thrown (generate's check of every sample before it writes).
  bool count_only = false;
};
struct ScratchGeometryStats {
  size_t triangles = 0;
  size_t part_triangles_cut = 0;  // part triangles that a cross-section reaches (re-meshed)
  size_t cells_capped = 0;        // cells left at max_pieces_per_cell (0 on every scene we know)
  double cell_mm = 0;
};

// Composite height (mm, along the outward normal) of the scratches at UV point p: the lowest cut,
// else the highest pile-up. `which` (optional) gets the scratch whose height that is, null where
// none has a height there.
float scratchHeight(const std::vector<const Scratch*>& scratches, Vec2f p, const Scratch** which = nullptr);

// Where a ray over the part first goes below the scratches' composite height (scratchHeight): the
// ray at height z0 + slope x over the UV line a + du x, for x from 0 to len (du: UV per unit of x),
// sampled every `step` of x from x = step on. Below means by more than tol. Between the last sample
// above and the first below it is refined by bisection to step / 1024. A feature narrower than a
// step can be passed over. The groove renderer's rays that rise low out of a footprint's polygons
// (docs/grooves.md, "Rising over the pile-ups beyond") and that leave them downwards ("Past the end
// of a groove's leg"). False where it stays above, and (without `plain`) where it meets the
// plain part, where no scratch has a height; with `plain` that meeting counts, out.scratch null.
// With `from_below` the ray starts under the surface (inside a solid part) and the meeting is where
// it first goes above the height by more than tol; `from` is then its last sample below.
struct HeightMeet {
  double from = 0;  // the last sample above (x)
  double at = 0;    // where the ray goes below (x)
  const Scratch* scratch = nullptr;  // whose height that is there (scratchHeight's `which`)
};
bool meetScratchHeight(const std::vector<const Scratch*>& scratches, Vec2d a, Vec2d du, double z0, double slope,
                       double len, double step, double tol, HeightMeet& out, bool plain = false,
                       bool from_below = false);

// The part with the scratches cut in. Facet normals are exact: a piece's normal is its facet's in
// the part triangle's plane, turned with the part's interpolated normal at each vertex (so that,
// as in the groove renderer, a cross-section's slopes are measured from the shading normal).
// Throws std::runtime_error when the part has no usable UV chart, or the mesh would exceed
// max_triangles.
TriangleMesh scratchedMesh(const TriangleMesh& part, const std::vector<const Scratch*>& scratches,
                           const ScratchGeometryOptions& opt = {}, ScratchGeometryStats* stats = nullptr);

}  // namespace dg
