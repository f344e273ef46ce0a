// A part's surface: a triangle mesh in millimetres with a UV chart in millimetres.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "core/math.h"

namespace dg {

struct TriangleMesh {
  std::vector<Vec3f> positions;   // mm, world space
  std::vector<Vec3f> normals;     // per vertex, unit length; empty means flat shading
  std::vector<Vec2f> uvs;         // per vertex, in mm of surface (defects are sized in mm)
  std::vector<uint32_t> indices;  // three per triangle, counter-clockwise seen from the outside
  // Per triangle: sqrt(3-D area / UV area). 1 for an isometric chart; parameterized meshes keep
  // their local stretch here so that a defect sized in mm can be corrected where the chart is not
  // isometric.
  std::vector<float> mmPerUv;
  // Optional, per vertex: the height (mm) along the normal above the part's own surface, where it
  // was moved (the scratch reference's cut mesh, so that a hit knows which coating layer it is in).
  std::vector<float> heights;
  std::string source;  // "builtin:plate" or the file it was loaded from

  size_t triangleCount() const { return indices.size() / 3; }
  void bounds(Vec3f& lo, Vec3f& hi) const;
  double surfaceAreaMm2() const;
  // Recomputes mmPerUv from positions and uvs (0 where the UV triangle is degenerate).
  void computeMmPerUv();
};

// Edges used by exactly one triangle (an open sheet has them along its outline; a closed solid
// has none).
size_t boundaryEdgeCount(const TriangleMesh& m);

// The rest of a solid whose front is the open sheet `front`: its back, the front moved by
// thickness_mm against the vertex normals (front.heights, where present, are taken off first, so a
// cut-in groove does not reach the back), and a rim joining the two along the sheet's outline.
// Wound so that every normal points out of the solid, no UVs, flat rim, smooth back. Empty when the
// front is closed. Throws std::invalid_argument for thickness_mm <= 0 or a front with an edge
// shared by more than two triangles.
TriangleMesh solidShell(const TriangleMesh& front, float thickness_mm);

}  // namespace dg
