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

}  // namespace dg
