// The explicit-geometry reference for scratches (issue 5's "reference mode"): the part re-meshed
// with every scratch's cross-section cut into it, to be rendered by the ordinary path tracer with
// many samples. Ground truth for the groove renderer (render/groove.h).
//
// Supported parts are flat with an affine UV chart (the built-in plate; any planar mesh whose UVs
// are an affine image of its positions and whose chart fills its UV rectangle). The rectangle is
// re-meshed by a quadtree: cells are split down to `cell_mm` wherever a scratch's cross-section
// can reach into them, and stay coarse elsewhere. A cell that is not split contains no point of any
// cross-section, so its edges are flat and the finer neighbours' vertices on them lie in the
// plane: the T-junctions are coplanar and leave no cracks.
//
// Heights of overlapping scratches combine as the removed material's union: the lowest groove
// where any groove is below the surface, else the highest pile-up.
#pragma once
#include <vector>

#include "defects/scratch.h"
#include "render/mesh.h"

namespace dg {

struct ScratchGeometryOptions {
  // Edge of the finest cells (mm); 0 = automatic: the narrowest scratch's width / 16, at least
  // 0.5 micrometre. Cells are cut along the kinks, so the size only bounds how well the variation
  // along the path is followed (the cross-sections themselves are exact at any size).
  double cell_mm = 0;
  size_t max_triangles = 40'000'000;  // refuse rather than exhaust memory
};
struct ScratchGeometryStats {
  size_t triangles = 0;
  double cell_mm = 0;
};

// Composite height (mm, along the outward normal) of the scratches at UV point p.
float scratchHeight(const std::vector<const Scratch*>& scratches, Vec2f p);

// Throws std::runtime_error when the part is not flat with an affine, rectangle-filling chart, or
// the mesh would exceed max_triangles.
TriangleMesh scratchedPlanarMesh(const TriangleMesh& part, const std::vector<const Scratch*>& scratches,
                                 const ScratchGeometryOptions& opt = {}, ScratchGeometryStats* stats = nullptr);

}  // namespace dg
