// Loading part meshes from files: OBJ, PLY, STL, OFF (CGAL's I/O) and glTF 2.0 (assimp).
// UVs come from the file where it has them (OBJ vt, glTF TEXCOORD_0); otherwise they are computed
// with CGAL's surface mesh parameterization and scaled to mm. Every problem with the file is an
// InputError naming the file and what was wrong: unreadable, unsupported extension, NaN or infinite
// coordinates, no non-degenerate triangle, a mesh that cannot be parameterized.
#pragma once
#include <string>

#include "render/mesh.h"

namespace dg {

struct MeshLoadOptions {
  double unit_scale_to_mm = 1.0;  // multiply file coordinates by this to get mm
  bool compute_uvs_if_missing = true;
};

TriangleMesh loadMesh(const std::string& path, const MeshLoadOptions& opts = {});

}  // namespace dg
