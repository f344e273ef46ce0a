// True displacement of a part's mesh by the defects' height fields, for dents that must change the
// silhouette or are too deep for bump mapping (shared/reference/blinn-bump.md §8.4).
//
// Method: the triangles whose UV box meets a defect's support are refined by longest-edge bisection
// with propagation along the longest-edge propagation path (Rivara, "New longest-edge algorithms for
// the refinement and/or improvement of unstructured triangulations", IJNME 40, 1997): a triangle is
// split only across its longest edge, and only once every triangle sharing that edge has it as its
// own longest edge, so the result stays conforming (no hanging vertices) and the smallest angle stays
// bounded below by half the smallest angle of the input. Then every vertex is moved along its normal
// by the sum of the defects' height(uv).
//
// Shading normals: a vertex that was moved gets its (interpolated) input normal rotated by the tilt
// of the area-weighted geometric normal, i.e. the rotation that takes the area-weighted normal of its
// undisplaced fan to that of its displaced fan. On a flat part that is the displaced surface's
// area-weighted normal; on a curved, smooth-shaded part the refined patch keeps the smooth shading of
// the input where nothing moved, instead of showing the input's flat facets. Vertices that did not
// move keep their input normal (new vertices: the normalized average of the edge's end normals).
//
// Chart scale: a child triangle inherits its input triangle's mmPerUv (the stretch of the chart on
// the undisplaced surface, which is what defect sizes in mm refer to; it equals the value recomputed
// from the undisplaced child up to rounding).
#pragma once
#include <cstddef>
#include <vector>

#include "defects/defect.h"
#include "render/mesh.h"

namespace dg {

struct DisplacementOptions {
  // Largest 3-D edge length (mm) of the refined triangles, measured both before and after the move.
  float max_edge_mm = 1.0f;
  // Largest triangle count of the result; beyond it displaceMesh throws std::runtime_error.
  int max_triangles = 4'000'000;
};

// What displaceMesh did (for logs, manifests and tests).
struct DisplacementStats {
  size_t triangles_split = 0;    // bisections (each adds one triangle)
  size_t vertices_added = 0;     // new vertices (edge midpoints)
  size_t vertices_moved = 0;     // vertices with a non-zero height
  size_t triangles_in_support = 0;  // output triangles whose UV box meets a support
};

// Returns a copy of `base` refined (conforming) where the triangles' UV boxes overlap any defect's
// support until their 3-D edges are at most o.max_edge_mm, with every vertex inside a support moved
// along its normal by the sum of the defects' heights there. Triangles away from the supports keep
// their index, vertices and attributes; new triangles are appended after the input's. Boundary edges
// stay boundary edges and interior (two-sided) edges stay two-sided with the input's orientation;
// edges shared by more than two triangles are split in all of them. Output is deterministic (the
// algorithm is sequential and uses no hashing).
//
// Needs a UV chart (uvs.size() == positions.size()); the input's normals are used as displacement
// directions (area-weighted face normals when it has none; the result then has none either).
// Throws std::invalid_argument for max_edge_mm <= 0 or a mesh without UVs (when there are defects),
// std::runtime_error when the result would have more than o.max_triangles triangles.
// An empty defect list returns `base` unchanged.
// Limitation: UV seams are separate vertices with separate UVs; a defect across a seam moves the two
// sides by the heights at their own UVs, so where those differ the seam opens.
TriangleMesh displaceMesh(const TriangleMesh& base, const std::vector<const Defect*>& defects,
                          const DisplacementOptions& o, DisplacementStats* stats = nullptr);

}  // namespace dg
