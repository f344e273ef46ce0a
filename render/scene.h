// The Embree side: one device per process, one BVH per part built once and shared by every sample
// that renders that part.
#pragma once
#include <memory>
#include <vector>

#include <embree3/rtcore.h>

#include "core/rng.h"
#include "defects/defect.h"
#include "render/mesh.h"

namespace dg {

RTCDevice embreeDevice();  // created on first use, lives for the process

class PartGeometry {
 public:
  // `shell`, when not empty, closes the part into a solid (solidShell(): the back and the rim of a
  // glass sheet). It is Embree geometry 1, carries no UVs and so no defects and no paint.
  explicit PartGeometry(TriangleMesh mesh, TriangleMesh shell = {});
  ~PartGeometry();
  PartGeometry(const PartGeometry&) = delete;
  PartGeometry& operator=(const PartGeometry&) = delete;

  RTCScene scene() const { return scene_; }
  const TriangleMesh& mesh() const { return mesh_; }
  const TriangleMesh& shell() const { return shell_; }
  static constexpr unsigned kShellGeometry = 1;
  // From this many triangles on, the BVH is built compact (render/scene.cpp).
  static constexpr size_t kCompactBvhTriangles = 1000000;
  // Unit geometric normal (from the winding, out of the solid) of shell triangle `prim`.
  Vec3f shellNormal(unsigned prim) const { return shell_ng_[prim]; }

  // Per triangle: the exact derivatives of position with respect to the UV chart (mm per UV mm),
  // the unit geometric normal (from the winding), and whether the UV triangle is usable. For a
  // degenerate UV triangle uv_ok is false and dpdu/dpdv are an arbitrary orthonormal tangent pair.
  struct TriFrame {
    Vec3f dpdu, dpdv, ng;
    bool uv_ok;
  };
  const TriFrame& frame(unsigned prim) const { return frames_[prim]; }
  size_t degenerateUvCount() const { return degenerate_uv_; }
  Box2 uvBounds() const { return uv_bounds_; }
  float boundingRadius() const { return radius_; }
  // A point drawn uniformly by area on the surface, returned as its UV (mm); u0 picks the
  // triangle, (u1, u2) the point in it.
  Vec2f sampleSurfaceUv(double u0, double u1, double u2) const;
  // A point drawn uniformly by area on the surface whose UV lies in `box` (mm): each triangle's UV
  // triangle is clipped to the box and weighted by the surface area it keeps, so a region of any
  // size is found in one draw wherever the chart covers it; false where it covers none of it.
  // Deterministic in rng.
  bool sampleSurfaceUvIn(const Box2& box, Rng& rng, Vec2f& out) const;
  // Ambient occlusion per vertex (0 open .. 1 enclosed), for defects that gather in cavities:
  // the fraction of cosine-distributed rays from the vertex that hit the part within max_distance.
  // Computed once per dataset, only when asked for; deterministic (counter-based rays).
  void computeOcclusion(int rays_per_vertex = 64, float max_distance_mm = 100.0f);
  bool hasOcclusion() const { return !occlusion_.empty(); }
  float occlusionAt(unsigned prim, float b1, float b2) const;
  Vec3f boundingCenter() const { return center_; }

 private:
  // The UV of a point of triangle t, drawn uniformly by area from (u1, u2) in [0, 1)^2.
  Vec2f uvInTriangle(size_t t, double u1, double u2) const;

  TriangleMesh mesh_, shell_;
  std::vector<Vec3f> shell_ng_;
  RTCScene scene_ = nullptr;
  std::vector<TriFrame> frames_;
  std::vector<double> area_cdf_;
  std::vector<float> occlusion_;  // cumulative triangle areas, normalised to end at 1
  size_t degenerate_uv_ = 0;
  Box2 uv_bounds_;
  Vec3f center_;
  float radius_ = 0;
};

}  // namespace dg
