// Loading part meshes: OBJ (own parser, for vt/vn and line numbers), PLY / STL / OFF (CGAL 5.5
// polygon-soup readers), glTF 2.0 (assimp). Every format is first read into a RawMesh in file
// units; one shared path then validates, scales, cleans, adds normals and, when the file has no
// UVs, computes a least-squares conformal chart with CGAL's surface mesh parameterization (after
// checking on a CGAL::Surface_mesh that the surface is a disk). This is the only translation unit
// that includes CGAL (and, through it, Eigen), to keep their template cost in one place.
#include "render/mesh_io.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numeric>
#include <optional>
#include <sstream>
#include <string_view>
#include <type_traits>
#include <unordered_map>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/IO/OFF.h>
#include <CGAL/IO/PLY.h>
#include <CGAL/IO/STL.h>
#include <CGAL/Surface_mesh.h>
// CGAL's LSCM falls back to OpenNL without Eigen, and in CGAL 5.5 that fallback does not compile
// for a Surface_mesh; dg_render links CGAL::Eigen3_support, which defines this macro.
#if !defined(CGAL_EIGEN3_ENABLED)
#error "render/mesh_io.cpp needs Eigen 3: link CGAL::Eigen3_support (it defines CGAL_EIGEN3_ENABLED)"
#endif
#include <CGAL/Eigen_solver_traits.h>
#include <CGAL/Surface_mesh_parameterization/Error_code.h>
#include <CGAL/Surface_mesh_parameterization/LSCM_parameterizer_3.h>
#include <CGAL/Surface_mesh_parameterization/Two_vertices_parameterizer_3.h>

#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include "core/error.h"
#include "core/fsutil.h"
#include "render/mesh_text.h"

namespace dg {

namespace {

namespace fs = std::filesystem;
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using CgalPoint = Kernel::Point_3;
using CgalMesh = CGAL::Surface_mesh<CgalPoint>;

const char* const kSupported = ".obj .ply .stl .off .gltf .glb";
const char* const kAddUvsHint = "; add UVs to the file (OBJ vt or glTF TEXCOORD_0)";

// A mesh as read from a file, before any cleaning; coordinates in file units.
struct RawMesh {
  std::vector<Vec3d> pos;
  std::vector<Vec3d> nrm;  // empty, or one per position
  std::vector<Vec2d> uv;   // empty, or one per position
  std::vector<std::array<uint32_t, 3>> tris;
  std::vector<int> posLine;  // OBJ: the line each position was defined on (for messages)
};

std::string fmt(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

using meshtext::parseDouble;
using meshtext::parseLong;
using meshtext::Token;
using meshtext::tokenize;

// ---------------------------------------------------------------------------------------------
// OBJ. CGAL's OBJ reader ignores vt and vn, so OBJ is parsed here: v, vt, vn and f (v, v/vt,
// v//vn, v/vt/vn; negative indices count back from the latest element). Other statements (o, g,
// s, usemtl, mtllib, l, p, ...) do not change the surface and are skipped. One output vertex is
// made per distinct (v, vt, vn) triple, so UV seams and hard edges are kept.

struct CornerKey {
  long v, t, n;
  bool operator==(const CornerKey& o) const { return v == o.v && t == o.t && n == o.n; }
};
struct CornerHash {
  size_t operator()(const CornerKey& k) const {
    size_t h = std::hash<long>()(k.v);
    h ^= std::hash<long>()(k.t) + 0x9e3779b97f4a7c15ULL + (h << 6) + (h >> 2);
    h ^= std::hash<long>()(k.n) + 0x9e3779b97f4a7c15ULL + (h << 6) + (h >> 2);
    return h;
  }
};

RawMesh readObj(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::vector<Vec3d> v, vn;
  std::vector<Vec2d> vt;
  std::vector<int> vLine;
  struct Face {
    std::vector<CornerKey> corners;  // 0-based, -1 = absent
    int line;
  };
  std::vector<Face> faces;

  std::string s;
  int lineNo = 0;
  auto fail = [&](int col, const std::string& what) { throw InputError(path, lineNo, col, what); };
  while (std::getline(in, s)) {
    ++lineNo;
    if (!s.empty() && s.back() == '\r') s.pop_back();
    std::string_view line(s);
    if (lineNo == 1 && line.substr(0, 3) == "\xEF\xBB\xBF") line.remove_prefix(3);  // UTF-8 BOM
    const size_t hash = line.find('#');
    if (hash != std::string_view::npos) line = line.substr(0, hash);
    const std::vector<Token> tok = tokenize(line);
    if (tok.empty()) continue;
    const std::string_view kw = tok[0].text;

    auto numbers = [&](size_t count, const char* what, double* out) {
      if (tok.size() < count + 1)
        fail(tok[0].column, "expected " + std::to_string(count) + " numbers after '" +
                                std::string(kw) + "' (" + what + ")");
      for (size_t k = 0; k < count; ++k)
        if (!parseDouble(tok[k + 1].text, out[k]))
          fail(tok[k + 1].column, "expected a number in the " + std::string(what) + ", got '" +
                                      std::string(tok[k + 1].text) + "'");
      for (size_t k = 0; k < count; ++k)
        if (!std::isfinite(out[k]))
          fail(tok[k + 1].column, std::string(what) + " has a non-finite coordinate (" +
                                      std::string(tok[k + 1].text) + ")");
    };

    if (kw == "v") {
      double c[3];
      numbers(3, ("vertex " + std::to_string(v.size() + 1)).c_str(), c);  // OBJ counts from 1
      v.push_back({c[0], c[1], c[2]});
      vLine.push_back(lineNo);
    } else if (kw == "vt") {
      double c[2];
      numbers(2, ("texture coordinate " + std::to_string(vt.size() + 1)).c_str(), c);
      vt.push_back({c[0], c[1]});
    } else if (kw == "vn") {
      double c[3];
      numbers(3, ("normal " + std::to_string(vn.size() + 1)).c_str(), c);
      vn.push_back({c[0], c[1], c[2]});
    } else if (kw == "f") {
      Face f{{}, lineNo};
      for (size_t k = 1; k < tok.size(); ++k) {
        std::string_view c = tok[k].text;
        long idx[3] = {-1, -1, -1};
        const size_t counts[3] = {v.size(), vt.size(), vn.size()};
        const char* names[3] = {"vertex", "texture coordinate", "normal"};
        for (int part = 0; part < 3; ++part) {
          const size_t slash = c.find('/');
          const std::string_view p = c.substr(0, slash);
          if (!p.empty()) {
            long i;
            if (!parseLong(p, i) || i == 0)
              fail(tok[k].column, "bad face corner '" + std::string(tok[k].text) +
                                      "' (expected v, v/vt, v//vn or v/vt/vn with indices from 1)");
            // Negative: relative to the latest element defined so far. Positive indices are
            // checked once the whole file is read (a file may define them later).
            idx[part] = i < 0 ? long(counts[part]) + i : i - 1;
            if (idx[part] < 0)
              fail(tok[k].column, "face refers to " + std::string(names[part]) + " " +
                                      std::to_string(i) + " but only " +
                                      std::to_string(counts[part]) + " are defined before it");
          } else if (part == 0) {
            fail(tok[k].column, "face corner '" + std::string(tok[k].text) + "' has no vertex index");
          }
          if (slash == std::string_view::npos) break;
          c.remove_prefix(slash + 1);
        }
        f.corners.push_back({idx[0], idx[1], idx[2]});
      }
      faces.push_back(std::move(f));
    }
  }
  if (in.bad()) throw InputError(path, "read error while reading the OBJ file");

  RawMesh raw;
  std::unordered_map<CornerKey, uint32_t, CornerHash> corner;
  bool anyUv = false, allUv = true, allN = true;
  int firstNoUvLine = 0;
  for (const Face& f : faces)
    for (const CornerKey& k : f.corners) {
      anyUv |= k.t >= 0;
      if (k.t < 0 && allUv) firstNoUvLine = f.line;
      allUv &= k.t >= 0;
      allN &= k.n >= 0;
    }
  if (anyUv && !allUv)
    throw InputError(path, firstNoUvLine, 0,
                     "face has no texture coordinates while other faces have them (all faces "
                     "need vt indices, or none)");
  for (const Face& f : faces) {
    std::vector<uint32_t> ids;
    for (const CornerKey& k : f.corners) {
      if (size_t(k.v) >= v.size() || (k.t >= 0 && size_t(k.t) >= vt.size()) ||
          (k.n >= 0 && size_t(k.n) >= vn.size()))
        throw InputError(path, f.line, 0,
                         "face index out of range (the file has " + std::to_string(v.size()) +
                             " vertices, " + std::to_string(vt.size()) + " texture coordinates, " +
                             std::to_string(vn.size()) + " normals)");
      auto [it, added] = corner.emplace(k, uint32_t(raw.pos.size()));
      if (added) {
        raw.pos.push_back(v[size_t(k.v)]);
        raw.posLine.push_back(vLine[size_t(k.v)]);
        if (anyUv) raw.uv.push_back(vt[size_t(k.t)]);
        if (allN) raw.nrm.push_back(vn[size_t(k.n)]);
      }
      ids.push_back(it->second);
    }
    for (size_t k = 1; k + 1 < ids.size(); ++k) raw.tris.push_back({ids[0], ids[k], ids[k + 1]});
  }
  return raw;
}

// ---------------------------------------------------------------------------------------------
// PLY, STL, OFF through CGAL's polygon-soup readers. Polygons with more than three corners are
// split into a fan from their first corner (exact for convex polygons, which is what these
// formats hold in practice).

// A polygon as a fan of triangles around its first corner.
template <class Polygon>
void addFan(const Polygon& poly, RawMesh& raw) {
  for (size_t k = 1; k + 1 < poly.size(); ++k)
    raw.tris.push_back({uint32_t(poly[0]), uint32_t(poly[k]), uint32_t(poly[k + 1])});
}

void soupToRaw(const std::string& path, const std::vector<CgalPoint>& pts,
               const std::vector<std::vector<std::size_t>>& polys, RawMesh& raw) {
  raw.pos.reserve(pts.size());
  for (const CgalPoint& p : pts) raw.pos.push_back({p.x(), p.y(), p.z()});
  for (size_t f = 0; f < polys.size(); ++f) {
    const auto& poly = polys[f];
    // CGAL reads a face of one or two corners (a point, an edge) without complaint; it has no
    // surface, and was dropped silently before.
    if (poly.size() < 3)
      throw InputError(path, "face " + std::to_string(f) + " (counting from 0) has " + std::to_string(poly.size()) +
                                 " corners; a face needs at least 3");
    for (std::size_t i : poly)
      if (i >= pts.size())
        throw InputError(path, "face " + std::to_string(f) + " refers to vertex " + std::to_string(i) +
                                   " but the file has only " + std::to_string(pts.size()) + " vertices");
    addFan(poly, raw);
  }
}

// A binary OFF file, read by meshtext::readBinaryOff (CGAL misreads it), as a RawMesh.
RawMesh binaryOffToRaw(const std::string& path, const meshtext::BinaryOff& bin) {
  if (bin.problem) throw InputError(path, bin.problem->line, bin.problem->column, bin.problem->what);
  RawMesh raw;
  for (const auto& p : bin.mesh.pos) raw.pos.push_back({p[0], p[1], p[2]});
  for (const auto& n : bin.mesh.nrm) raw.nrm.push_back({n[0], n[1], n[2]});
  for (const auto& t : bin.mesh.uv) raw.uv.push_back({t[0], t[1]});
  for (const auto& face : bin.mesh.faces) addFan(face, raw);
  return raw;
}

// Guards CGAL's PLY reader, which adds each 'property' line to the last element declared before
// it: a property before any 'element' line (a damaged header) crashed it (found by
// scripts/fuzz-meshes, seed 13). The header is text even in a binary file; it is read up to
// 'end_header' or the first 64 KiB, as CGAL reads it: line by line, the first word the keyword.
void checkPlyHeader(const std::string& path) {
  std::istringstream lines(readFileHead(path, 65536));
  std::string line;
  bool element = false;
  for (int number = 1; std::getline(lines, line); ++number) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (number <= 2) continue;  // "ply" and the format: CGAL refuses those itself
    const std::vector<Token> tok = tokenize(line);
    if (tok.empty()) continue;
    if (tok[0].text == "end_header") return;
    if (tok[0].text == "element") element = true;
    if (tok[0].text == "property" && !element)
      throw InputError(path, number, tok[0].column, "a property before any 'element'");
  }
}

// A binary STL whose vertices are NaN would be silently merged by CGAL's reader (it indexes
// points with an ordered map, and NaN compares equal to everything), so binary STL coordinates
// are checked here first. The file is binary if its size is exactly 84 + 50 * (facet count).
void checkBinaryStl(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char header[84];
  if (!in.read(header, 84)) return;
  uint32_t n;
  std::memcpy(&n, header + 80, 4);
  if (fs::file_size(path) != 84 + 50 * uintmax_t(n)) return;  // ASCII (or broken): CGAL decides
  char rec[50];
  for (uint32_t f = 0; f < n && in.read(rec, 50); ++f)
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < 3; ++k) {
        float x;
        std::memcpy(&x, rec + 12 + 12 * c + 4 * k, 4);
        if (!std::isfinite(x))
          throw InputError(path, "non-finite coordinate (" + fmt(x) + ") in facet " + std::to_string(f) +
                                     ", corner " + std::to_string(c));
      }
}

RawMesh readWithCgal(const std::string& path, const std::string& ext) {
  std::vector<CgalPoint> pts;
  std::vector<std::vector<std::size_t>> polys;
  std::vector<Kernel::Vector_3> normals;
  std::vector<Kernel::Point_2> texcoords;
  bool ok = false;
  const std::string format = ext == ".ply" ? "PLY" : ext == ".stl" ? "STL" : "OFF";
  if (ext == ".off") {
    const meshtext::BinaryOff bin = meshtext::readBinaryOff(path);
    if (bin.binary) return binaryOffToRaw(path, bin);
  }
  if (ext == ".ply") checkPlyHeader(path);
  // A face or list longer than the file can hold: CGAL would allocate it first (mesh_text.h).
  if (std::optional<meshtext::FileProblem> p = ext == ".off"   ? meshtext::oversizedOff(path)
                                               : ext == ".ply" ? meshtext::oversizedPlyList(path)
                                                               : std::nullopt)
    throw InputError(path, p->line, p->column, p->what);
  if (ext == ".stl") checkBinaryStl(path);
  try {
    if (ext == ".ply") {
      ok = CGAL::IO::read_PLY(path, pts, polys, CGAL::parameters::verbose(false));
    } else if (ext == ".stl") {
      ok = CGAL::IO::read_STL(path, pts, polys, CGAL::parameters::verbose(false));
    } else {
      ok = CGAL::IO::read_OFF(path, pts, polys,
                              CGAL::parameters::vertex_normal_output_iterator(std::back_inserter(normals))
                                  .vertex_texture_output_iterator(std::back_inserter(texcoords))
                                  .verbose(false));
    }
  } catch (const std::exception&) {  // CGAL assertions throw; so does a failed allocation
    ok = false;
  }
  // CGAL says only that it failed, or it reads what it can (a face index past the vertices, a
  // misspelt PLY type that leaves no faces): find where and why (render/mesh_text.h).
  auto diagnose = [&] {
    std::optional<meshtext::FileProblem> p = meshtext::findNonFinite(path);
    if (!p) p = ext == ".ply" ? meshtext::diagnosePly(path) : ext == ".stl" ? meshtext::diagnoseStl(path) : meshtext::diagnoseOff(path);
    if (p) throw InputError(path, p->line, p->column, p->what);
  };
  if (!ok) {
    diagnose();
    throw InputError(path, "cannot parse the " + format + " file (malformed or truncated)");
  }
  RawMesh raw;
  try {
    soupToRaw(path, pts, polys, raw);
  } catch (const InputError&) {
    diagnose();
    throw;
  }
  if (raw.tris.empty()) diagnose();
  if (normals.size() == pts.size() && !pts.empty())
    for (const auto& n : normals) raw.nrm.push_back({n.x(), n.y(), n.z()});
  if (texcoords.size() == pts.size() && !pts.empty())
    for (const auto& t : texcoords) raw.uv.push_back({t.x(), t.y()});
  return raw;
}

// ---------------------------------------------------------------------------------------------
// glTF 2.0 (.gltf, .glb) through assimp: every triangle mesh of every node, in world space (node
// transforms applied; normals by the inverse transpose; winding swapped under a mirroring
// transform so that it still matches the normals). UVs from TEXCOORD_0 (assimp's channel 0).

void collectNode(const aiScene* scene, const aiNode* node, const aiMatrix4x4& parent, RawMesh& raw,
                 bool& uvMissing, bool& nMissing) {
  const aiMatrix4x4 m = parent * node->mTransformation;
  aiMatrix3x3 nm(m);
  const double det = nm.Determinant();
  nm.Inverse().Transpose();
  for (unsigned k = 0; k < node->mNumMeshes; ++k) {
    const aiMesh* mesh = scene->mMeshes[node->mMeshes[k]];
    if (!(mesh->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) continue;  // points and lines
    const uint32_t base = uint32_t(raw.pos.size());
    uvMissing |= !mesh->HasTextureCoords(0);
    nMissing |= !mesh->HasNormals();
    for (unsigned i = 0; i < mesh->mNumVertices; ++i) {
      const aiVector3D p = m * mesh->mVertices[i];
      raw.pos.push_back({p.x, p.y, p.z});
      if (mesh->HasNormals()) {
        const aiVector3D n = nm * mesh->mNormals[i];
        raw.nrm.push_back({n.x, n.y, n.z});
      } else {
        raw.nrm.push_back({0, 0, 0});  // replaced by computed normals below
      }
      if (mesh->HasTextureCoords(0))
        raw.uv.push_back({mesh->mTextureCoords[0][i].x, mesh->mTextureCoords[0][i].y});
      else
        raw.uv.push_back({0, 0});
    }
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices != 3) continue;
      std::array<uint32_t, 3> t{base + face.mIndices[0], base + face.mIndices[1], base + face.mIndices[2]};
      for (uint32_t i : t)
        if (i >= raw.pos.size()) throw std::runtime_error("index out of range");
      if (det < 0) std::swap(t[1], t[2]);
      raw.tris.push_back(t);
    }
  }
  for (unsigned c = 0; c < node->mNumChildren; ++c)
    collectNode(scene, node->mChildren[c], m, raw, uvMissing, nMissing);
}

RawMesh readGltf(const std::string& path, const std::string& ext) {
  Assimp::Importer importer;
  const aiScene* scene = nullptr;
  try {
    scene = importer.ReadFile(path, aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
                                        aiProcess_SortByPType | aiProcess_ValidateDataStructure);
  } catch (const std::exception& e) {
    throw InputError(path, std::string("cannot parse the glTF file: ") + e.what());
  }
  if (!scene || !scene->mRootNode || (scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE)) {
    if (ext == ".glb")
      if (auto p = meshtext::diagnoseGlb(path)) throw InputError(path, p->what);
    if (auto p = meshtext::diagnoseGltfJson(path)) throw InputError(path, p->line, p->column, p->what);
    const std::string why = importer.GetErrorString();
    throw InputError(path, "cannot parse the glTF file: " + (why.empty() ? std::string("malformed or truncated") : why));
  }
  RawMesh raw;
  bool uvMissing = false, nMissing = false;
  try {
    collectNode(scene, scene->mRootNode, aiMatrix4x4(), raw, uvMissing, nMissing);
  } catch (const std::runtime_error&) {
    throw InputError(path, "a glTF primitive has a vertex index out of range");
  }
  // A chart must cover the whole part: UVs on only some primitives are treated like none.
  if (uvMissing) raw.uv.clear();
  if (nMissing) raw.nrm.clear();
  return raw;
}

// ---------------------------------------------------------------------------------------------
// Parameterization of a mesh without UVs: least squares conformal maps (LSCM; Levy, Petitjean,
// Ray, Maillot 2002, "Least squares conformal maps for automatic texture atlas generation"),
// computed by CGAL's Surface_mesh_parameterization::LSCM_parameterizer_3 with its Eigen solver
// (CGAL_EIGEN3_ENABLED: the normal equations are factored by Eigen::SimplicialLDLT). LSCM needs a
// disk: one connected component, one boundary loop, manifold. parameterize() below checks that
// first, so that each failure gets its own message rather than CGAL's generic error codes.
//
// What CGAL minimizes: for each triangle with corners z0, z1, z2 in an orthonormal frame of its
// plane (complex numbers) and unknown chart positions U0, U1, U2 (u + iv), the residual
//   (z1 - z0)(U2 - U0) - (z2 - z0)(U1 - U0),
// real and imaginary parts as two rows of a least-squares system. It vanishes exactly when the
// triangle maps by a similarity that keeps its orientation (the discrete Cauchy-Riemann equations
// of Levy et al. 2002, multiplied through by the triangle's edge vectors, so no division
// by the area). Two vertices are pinned to remove the similarity freedom; any developable patch
// then unrolls isometrically up to scale, which the caller removes by scaling to mm.
//
// Pins: two nearly farthest-apart vertices of the border loop (a double sweep), handed to CGAL's
// Two_vertices_parameterizer_3, which places them at (0, 0.5) and (1, 0.5).
//
// Cost (one core, grid patches): about 0.7-1 s for 23k vertices, 5-10 s for 100k, 11 s for 160k;
// half of it is Eigen's factorization, the rest CGAL assembling the normal equations. Peak memory
// is about 0.5 GB at 100k vertices and 0.8 GB at 160k; very large meshes should come with UVs.

namespace smp = CGAL::Surface_mesh_parameterization;

// CGAL 5.5's get_error_message() table has one entry fewer than the enum (the text for
// ERROR_NO_TOPOLOGICAL_BALL is missing, so every later code gets its neighbour's text and the
// last one a null pointer), hence this own list.
std::string lscmErrorText(smp::Error_code code) {
  switch (code) {
    case smp::OK: return "success";
    case smp::ERROR_EMPTY_MESH: return "CGAL found an empty mesh";
    case smp::ERROR_NON_TRIANGULAR_MESH: return "CGAL found a face that is not a triangle";
    case smp::ERROR_NO_TOPOLOGICAL_DISC: return "CGAL found that the surface is not a topological disk";
    case smp::ERROR_NO_TOPOLOGICAL_BALL: return "CGAL found that the surface is not a topological ball";
    case smp::ERROR_BORDER_TOO_SHORT: return "the boundary is too short for the pinned vertices";
    case smp::ERROR_NON_CONVEX_BORDER: return "the pinned vertices are not in the same connected component";
    case smp::ERROR_CANNOT_SOLVE_LINEAR_SYSTEM:
      return "the LSCM linear system is singular (Eigen's LDLT factorization failed; degenerate or "
             "nearly degenerate triangles?)";
    case smp::ERROR_NO_1_TO_1_MAPPING: return "the chart is not one-to-one";
    case smp::ERROR_WRONG_PARAMETER: return "CGAL received an unexpected parameter";
  }
  return "CGAL returned error code " + std::to_string(int(code));
}

// Returns one chart position per vertex of sm (indexed like sm's vertices), in CGAL's units
// (pins 1 apart); sm must be a disk and `border` a border halfedge of it.
template <class Fail>
std::vector<Vec2d> solveLscm(CgalMesh& sm, CgalMesh::Halfedge_index border, Fail& fail) {
  std::vector<CgalMesh::Vertex_index> loop;
  for (CgalMesh::Halfedge_index g = border;;) {
    loop.push_back(sm.source(g));
    g = sm.next(g);
    if (g == border) break;
  }
  auto farthestFrom = [&](CgalMesh::Vertex_index from) {
    CgalMesh::Vertex_index best = from;
    double bestD = -1;
    for (CgalMesh::Vertex_index v : loop) {
      const double d = CGAL::squared_distance(sm.point(v), sm.point(from));
      if (d > bestD) bestD = d, best = v;
    }
    return best;
  };
  const CgalMesh::Vertex_index pinB = farthestFrom(loop.front()), pinA = farthestFrom(pinB);
  if (!(CGAL::squared_distance(sm.point(pinA), sm.point(pinB)) > 0)) fail("its boundary has zero length");

  using UvMap = CgalMesh::Property_map<CgalMesh::Vertex_index, Kernel::Point_2>;
  using PinMap = CgalMesh::Property_map<CgalMesh::Vertex_index, bool>;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  UvMap uvmap = sm.add_property_map<CgalMesh::Vertex_index, Kernel::Point_2>("v:dg_uv", Kernel::Point_2(nan, nan)).first;
  PinMap pinmap = sm.add_property_map<CgalMesh::Vertex_index, bool>("v:dg_pinned", false).first;

  using Border = smp::Two_vertices_parameterizer_3<CgalMesh>;
  using Lscm = smp::LSCM_parameterizer_3<CgalMesh, Border>;
  static_assert(std::is_same<Lscm::Solver_traits,
                             CGAL::Eigen_solver_traits<Eigen::SimplicialLDLT<
                                 CGAL::Eigen_sparse_symmetric_matrix<double>::EigenType>>>::value,
                "CGAL's LSCM should use its Eigen solver: compile with CGAL_EIGEN3_ENABLED");
  Lscm lscm{Border(pinA, pinB)};
  smp::Error_code status = smp::OK;
  try {
    // The vertex indices of a Surface_mesh without removed elements are 0..n-1, as CGAL needs.
    status = lscm.parameterize(sm, border, uvmap, get(CGAL::vertex_index, sm), pinmap);
  } catch (const std::bad_alloc&) {
    fail("out of memory in CGAL's LSCM solve (" + std::to_string(sm.number_of_vertices()) + " vertices)");
  } catch (const std::exception& e) {  // CGAL's failed assertions throw
    fail(std::string("CGAL's LSCM parameterization failed: ") + e.what());
  }
  if (status != smp::OK) fail(lscmErrorText(status));

  std::vector<Vec2d> uv(sm.number_of_vertices());
  for (CgalMesh::Vertex_index v : sm.vertices()) {
    const Kernel::Point_2& q = uvmap[v];
    if (!std::isfinite(q.x()) || !std::isfinite(q.y()))
      fail("CGAL's LSCM left a vertex without a finite chart position");
    uv[size_t(v)] = {q.x(), q.y()};
  }
  sm.remove_property_map(uvmap);
  sm.remove_property_map(pinmap);
  return uv;
}

struct UnionFind {
  std::vector<uint32_t> parent;
  explicit UnionFind(size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }
  uint32_t find(uint32_t a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  }
  void unite(uint32_t a, uint32_t b) { parent[find(a)] = find(b); }
};

void parameterize(const std::string& path, TriangleMesh& m) {
  auto fail = [&](const std::string& reason) {
    throw InputError(path, "mesh has no UVs and cannot be parameterized: " + reason + kAddUvsHint);
  };
  // Weld vertices at identical positions (files split them at normal seams or per face, as STL
  // and OBJ-with-vn do), so that the topology is the surface's and not the file's.
  struct Bits {
    size_t operator()(const std::array<uint32_t, 3>& k) const {
      return (size_t(k[0]) * 73856093u) ^ (size_t(k[1]) * 19349663u) ^ (size_t(k[2]) * 83492791u);
    }
  };
  std::unordered_map<std::array<uint32_t, 3>, uint32_t, Bits> weldMap;
  std::vector<uint32_t> weld(m.positions.size());
  std::vector<Vec3f> wpos;
  for (size_t i = 0; i < m.positions.size(); ++i) {
    std::array<uint32_t, 3> key;
    for (int k = 0; k < 3; ++k) {
      const float c = m.positions[i][k] + 0.0f;  // -0 and +0 weld together
      std::memcpy(&key[size_t(k)], &c, 4);
    }
    auto [it, added] = weldMap.emplace(key, uint32_t(wpos.size()));
    if (added) wpos.push_back(m.positions[i]);
    weld[i] = it->second;
  }

  const size_t nt = m.triangleCount();
  UnionFind uf(wpos.size());
  for (size_t t = 0; t < nt; ++t) {
    uf.unite(weld[m.indices[3 * t]], weld[m.indices[3 * t + 1]]);
    uf.unite(weld[m.indices[3 * t]], weld[m.indices[3 * t + 2]]);
  }
  size_t components = 0;
  for (uint32_t i = 0; i < wpos.size(); ++i) components += uf.find(i) == i;
  if (components > 1) fail(std::to_string(components) + " connected components (a chart needs one)");

  CgalMesh sm;
  std::vector<CgalMesh::Vertex_index> vid;
  vid.reserve(wpos.size());
  for (const Vec3f& p : wpos) vid.push_back(sm.add_vertex(CgalPoint(p.x, p.y, p.z)));
  size_t rejected = 0;
  for (size_t t = 0; t < nt; ++t) {
    const auto a = vid[weld[m.indices[3 * t]]], b = vid[weld[m.indices[3 * t + 1]]],
               c = vid[weld[m.indices[3 * t + 2]]];
    if (a == b || b == c || a == c || sm.add_face(a, b, c) == CgalMesh::null_face()) ++rejected;
  }
  if (rejected > 0)
    fail("not manifold or not consistently oriented (" + std::to_string(rejected) +
         " triangle(s) share an edge with two others, repeat a triangle, or have a neighbour with "
         "opposite winding)");

  // Border loops; a vertex on two of them (or twice on one) is a non-manifold pinch point.
  std::vector<char> seen(sm.number_of_halfedges(), 0);
  std::vector<int> borderOut(sm.number_of_vertices(), 0);
  size_t loops = 0;
  CgalMesh::Halfedge_index border;
  for (CgalMesh::Halfedge_index h : sm.halfedges()) {
    if (!sm.is_border(h)) continue;
    if (++borderOut[sm.source(h)] > 1) fail("not manifold (triangle fans touching at a single vertex)");
    if (seen[h]) continue;
    ++loops;
    border = h;
    CgalMesh::Halfedge_index g = h;
    do {
      seen[g] = 1;
      g = sm.next(g);
    } while (g != h);
  }
  if (loops == 0) fail("closed mesh with no boundary (a chart needs a disk-like surface; cut it open)");
  if (loops > 1) fail(std::to_string(loops) + " boundary loops (the surface has holes; a chart needs exactly one)");

  std::vector<Vec2d> uv = solveLscm(sm, border, fail);
  // LSCM preserves orientation, so counter-clockwise triangles have positive UV area; mirror the
  // chart if not (a safeguard), then reject fold-overs: a defect placed in UV would appear twice.
  auto signedArea = [&](size_t t) {
    const Vec2d a = uv[weld[m.indices[3 * t]]], b = uv[weld[m.indices[3 * t + 1]]],
                c = uv[weld[m.indices[3 * t + 2]]];
    return 0.5 * ((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x));
  };
  double total = 0;
  for (size_t t = 0; t < nt; ++t) total += signedArea(t);
  if (total < 0) {
    for (Vec2d& q : uv) q.x = -q.x;
    total = -total;
  }
  if (!(total > 0)) fail("the LSCM chart has zero area");
  size_t flipped = 0;
  for (size_t t = 0; t < nt; ++t) flipped += signedArea(t) < -1e-9 * total;
  if (flipped > 0)
    fail("the LSCM chart folds over (" + std::to_string(flipped) + " of " + std::to_string(nt) +
         " triangles flipped)");

  // Scale to mm: total UV area equals the surface area; per-triangle stretch stays in mmPerUv.
  const double s = std::sqrt(m.surfaceAreaMm2() / total);
  double umin = std::numeric_limits<double>::max(), vmin = umin;
  for (const Vec2d& q : uv) {
    umin = std::min(umin, q.x * s);
    vmin = std::min(vmin, q.y * s);
  }
  m.uvs.resize(m.positions.size());
  for (size_t i = 0; i < m.positions.size(); ++i) {
    const Vec2d& q = uv[weld[i]];
    m.uvs[i] = Vec2f(float(q.x * s - umin), float(q.y * s - vmin));
  }
}

// ---------------------------------------------------------------------------------------------
// Shared validation and cleaning.

TriangleMesh finish(const std::string& path, RawMesh& raw, const MeshLoadOptions& opts) {
  for (size_t i = 0; i < raw.pos.size(); ++i)
    if (!isFinite(raw.pos[i])) {
      const Vec3d& p = raw.pos[i];
      throw InputError(path, raw.posLine.empty() ? 0 : raw.posLine[i], 0,
                       "vertex " + std::to_string(i) + " (counting from 0) has a non-finite coordinate (" + fmt(p.x) +
                           " " + fmt(p.y) + " " + fmt(p.z) + ")");
    }
  if (raw.tris.empty()) throw InputError(path, "the mesh has no triangles (no faces with 3 or more vertices)");

  // Scale to mm, in float as the mesh is stored; a coordinate can overflow float.
  const double scale = opts.unit_scale_to_mm;
  std::vector<Vec3f> pos(raw.pos.size());
  for (size_t i = 0; i < raw.pos.size(); ++i) {
    pos[i] = Vec3f(raw.pos[i] * scale);
    if (!isFinite(pos[i]))
      throw InputError(path, raw.posLine.empty() ? 0 : raw.posLine[i], 0,
                       "vertex " + std::to_string(i) + " (counting from 0) is too large after scaling to mm (x" +
                           fmt(scale) + ")");
  }

  // Drop degenerate triangles: repeated corners, or an area that vanishes against the squared
  // longest edge (collinear corners).
  std::vector<std::array<uint32_t, 3>> kept;
  for (const auto& t : raw.tris) {
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;
    const Vec3d a(pos[t[0]]), b(pos[t[1]]), c(pos[t[2]]);
    const double twice = length(cross(b - a, c - a));
    const double longest2 = std::max({dot(b - a, b - a), dot(c - a, c - a), dot(c - b, c - b)});
    if (twice > 1e-12 * longest2) kept.push_back(t);
  }
  if (kept.empty())
    throw InputError(path, "only degenerate (zero-area) triangles: all " + std::to_string(raw.tris.size()) +
                               " triangles have zero area");

  // Keep only the vertices the remaining triangles use.
  TriangleMesh m;
  std::vector<int64_t> remap(pos.size(), -1);
  std::vector<size_t> origin;
  for (auto& t : kept)
    for (uint32_t& i : t) {
      if (remap[i] < 0) {
        remap[i] = int64_t(m.positions.size());
        m.positions.push_back(pos[i]);
        origin.push_back(i);
      }
      m.indices.push_back(uint32_t(remap[i]));
    }
  const size_t nv = m.positions.size(), nt = m.triangleCount();

  // Normals: the file's where it gave a usable one, else area-weighted face normals (the sum of
  // the unnormalized cross products weights each face by twice its area).
  std::vector<Vec3d> acc(nv, Vec3d(0.0));
  for (size_t t = 0; t < nt; ++t) {
    const uint32_t i0 = m.indices[3 * t], i1 = m.indices[3 * t + 1], i2 = m.indices[3 * t + 2];
    const Vec3d n = cross(Vec3d(m.positions[i1]) - Vec3d(m.positions[i0]),
                          Vec3d(m.positions[i2]) - Vec3d(m.positions[i0]));
    acc[i0] += n;
    acc[i1] += n;
    acc[i2] += n;
  }
  m.normals.resize(nv);
  for (size_t i = 0; i < nv; ++i) {
    Vec3d n = raw.nrm.empty() ? Vec3d(0.0) : raw.nrm[origin[i]];
    if (!(isFinite(n) && length(n) > 1e-12)) n = acc[i];
    if (!(length(n) > 0)) n = {0, 0, 1};  // faces cancel exactly at a pinch; any unit vector will do
    m.normals[i] = Vec3f(normalize(n));
  }

  if (!raw.uv.empty()) {
    // File UVs are usually in texture units (0..1): scale them uniformly to mm so that the total UV
    // area equals the surface area, and move their minimum to 0. The chart's shape is kept.
    std::vector<Vec2d> uv(nv);
    for (size_t i = 0; i < nv; ++i) {
      uv[i] = raw.uv[origin[i]];
      if (!std::isfinite(uv[i].x) || !std::isfinite(uv[i].y))
        throw InputError(path, "texture coordinate of vertex " + std::to_string(origin[i]) + " is not finite");
    }
    double auv = 0;
    for (size_t t = 0; t < nt; ++t) {
      const Vec2d a = uv[m.indices[3 * t]], b = uv[m.indices[3 * t + 1]], c = uv[m.indices[3 * t + 2]];
      auv += 0.5 * std::abs((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x));
    }
    if (!(auv > 0))
      throw InputError(path, "the texture coordinates in the file have zero total area (all UVs "
                             "coincide or are collinear); fix them or remove them to have UVs computed");
    const double s = std::sqrt(m.surfaceAreaMm2() / auv);
    double umin = std::numeric_limits<double>::max(), vmin = umin;
    for (const Vec2d& q : uv) {
      umin = std::min(umin, q.x);
      vmin = std::min(vmin, q.y);
    }
    m.uvs.resize(nv);
    for (size_t i = 0; i < nv; ++i) m.uvs[i] = Vec2f(float((uv[i].x - umin) * s), float((uv[i].y - vmin) * s));
  } else if (opts.compute_uvs_if_missing) {
    parameterize(path, m);
  }
  m.computeMmPerUv();
  m.source = path;
  return m;
}

}  // namespace

TriangleMesh loadMesh(const std::string& path, const MeshLoadOptions& opts) {
  const std::string ext = lowerExtension(path);
  if (ext != ".obj" && ext != ".ply" && ext != ".stl" && ext != ".off" && ext != ".gltf" && ext != ".glb")
    throw InputError(path, "unsupported mesh file extension '" + fs::path(path).extension().string() +
                               "'; supported: " + kSupported);
  if (!(std::isfinite(opts.unit_scale_to_mm) && opts.unit_scale_to_mm > 0))
    throw InputError(path, "unit_scale_to_mm must be a positive finite number, got " + fmt(opts.unit_scale_to_mm));
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(path, "cannot open the mesh file: it does not exist");
  if (!fs::is_regular_file(path, ec)) throw InputError(path, "cannot open the mesh file: not a regular file");
  if (!std::ifstream(path, std::ios::binary).good())
    throw InputError(path, "cannot open the mesh file: permission denied or unreadable");

  RawMesh raw;
  if (ext == ".obj")
    raw = readObj(path);
  else if (ext == ".gltf" || ext == ".glb")
    raw = readGltf(path, ext);
  else
    raw = readWithCgal(path, ext);
  return finish(path, raw, opts);
}

}  // namespace dg
