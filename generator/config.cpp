#include "generator/config.h"

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <map>
#include <set>
#include <sstream>

#include "core/error.h"
#include "core/fsutil.h"
#include "defects/scratch.h"
#include "render/bsdf.h"

namespace dg {

using nlohmann::json;

// ---------------------------------------------------------------------------------------------
// Schema
// ---------------------------------------------------------------------------------------------

namespace {

Field num(std::string key, std::string unit, json def, double lo, double hi, std::string doc,
          bool random_ok = true, bool lo_excl = false) {
  Field f;
  f.key = std::move(key);
  f.type = FieldType::Number;
  f.unit = std::move(unit);
  f.default_value = std::move(def);
  f.required = f.default_value.is_null();
  f.min = lo;
  f.max = hi;
  f.min_exclusive = lo_excl;
  f.doc = std::move(doc);
  f.random_ok = random_ok;
  return f;
}
Field integer(std::string key, std::string unit, json def, double lo, double hi, std::string doc,
              bool random_ok = false) {
  Field f = num(std::move(key), std::move(unit), std::move(def), lo, hi, std::move(doc), random_ok);
  f.type = FieldType::Integer;
  return f;
}
Field flag(std::string key, bool def, std::string doc) {
  Field f;
  f.key = std::move(key);
  f.type = FieldType::Bool;
  f.default_value = def;
  f.doc = std::move(doc);
  return f;
}
Field enumeration(std::string key, std::vector<std::string> values, json def, std::string doc,
                  bool random_ok = false) {
  Field f;
  f.key = std::move(key);
  f.type = FieldType::Enum;
  f.enum_values = std::move(values);
  f.default_value = std::move(def);
  f.required = f.default_value.is_null();
  f.doc = std::move(doc);
  f.random_ok = random_ok;
  return f;
}
Field path(std::string key, std::string doc, bool required) {
  Field f;
  f.key = std::move(key);
  f.type = FieldType::Path;
  f.required = required;
  f.doc = std::move(doc);
  return f;
}
Field vec(std::string key, int n, std::string unit, json def, double lo, double hi, std::string doc,
          bool random_ok = true, FieldType elem = FieldType::Number) {
  Field f = num(std::move(key), std::move(unit), std::move(def), lo, hi, std::move(doc), random_ok);
  f.type = FieldType::Vector;
  f.vector_size = n;
  f.element_type = elem;
  return f;
}
Field optional(Field f) {
  f.required = false;
  return f;
}
Field rgb(std::string key, json def, double hi, std::string doc) {
  return vec(std::move(key), 3, "linear RGB", std::move(def), 0, hi, std::move(doc));
}

std::vector<std::string> metalNames() {
  std::vector<std::string> v;
  for (auto& m : metalTable()) v.push_back(m.name);
  return v;
}

Field buildSchema() {
  Field root;
  root.key = "";
  root.type = FieldType::Object;
  root.fields.push_back(integer("seed", "", 0, 0, 1e15,
                                "Master seed. Every random value of sample i is drawn from a "
                                "counter-based stream keyed by (seed, i). `--seed` overrides it."));
  root.fields.push_back(integer("count", "samples", 10, 1, 1e7,
                                "Number of samples (images) in the dataset. `--count` overrides it."));

  // part
  Field part;
  part.key = "part";
  part.type = FieldType::Object;
  part.required = true;
  part.doc = "The car part. It is the same for every sample of a dataset, so its BVH is built once.";
  Field tess = num("tessellation_mm", "mm", 10, 0.5, 200,
                   "Largest edge length of the built-in part's triangles.", false);
  part.variants["plate"] = {num("width_mm", "mm", 300, 10, 5000, "Width (u direction).", false),
                            num("height_mm", "mm", 200, 10, 5000, "Height (v direction).", false), tess};
  part.variant_docs["plate"] = "Flat test plate in the z = 0 plane, outside facing +z.";
  part.variants["door_panel"] = {
      num("width_mm", "mm", 1000, 100, 3000, "Width along the car.", false),
      num("height_mm", "mm", 600, 100, 2000, "Height, measured along the bow.", false),
      num("curvature_radius_mm", "mm", 1500, 200, 100000, "Radius of the bow across the height.", false),
      num("character_line_height", "fraction", 0.6, 0.05, 0.95,
          "Position of the character line, as a fraction of the height.", false),
      num("character_line_depth_mm", "mm", 4, 0, 50, "Height of the character-line ridge.", false),
      num("character_line_width_mm", "mm", 20, 1, 200, "Width of the character-line ridge.", false),
      tess};
  part.variant_docs["door_panel"] = "Door skin curved across its height, with a character line.";
  part.variants["hood"] = {num("width_mm", "mm", 1400, 200, 3000, "Width across the car.", false),
                           num("length_mm", "mm", 1100, 200, 3000, "Length along the car.", false),
                           num("crown_mm", "mm", 40, 0, 300, "Height of the crown in the middle.", false),
                           tess};
  part.variant_docs["hood"] = "Doubly curved hood, crowned in the middle.";
  part.variants["fender"] = {
      num("length_mm", "mm", 900, 200, 3000, "Length along the car.", false),
      num("height_mm", "mm", 600, 200, 2000, "Height.", false),
      num("arch_radius_mm", "mm", 330, 50, 800, "Radius of the wheel-arch cut-out.", false),
      num("curvature_radius_mm", "mm", 1200, 200, 100000, "Radius of the curve in plan view.", false),
      tess};
  part.variant_docs["fender"] = "Front fender: side panel curved in plan, with a wheel-arch cut-out.";
  part.variants["mesh"] = {
      path("path", "Mesh file: OBJ, PLY, STL, OFF (ASCII or binary) or glTF 2.0 (.gltf/.glb), relative to the config.", true),
      num("unit_scale_to_mm", "", 1.0, 0, 1e6, "", false, true)};
  part.variants["mesh"][1].doc =
      "Factor from the file's units to mm. Default 1, except 1000 for glTF (whose unit is the metre).";
  part.variant_docs["mesh"] =
      "A mesh from a file. UVs come from the file (OBJ vt, glTF TEXCOORD_0); without them they are "
      "computed by CGAL's LSCM parameterization (the mesh must then be one disk-like patch).";
  root.fields.push_back(part);

  // material
  Field mat;
  mat.key = "material";
  mat.type = FieldType::Object;
  mat.doc = "What the part's surface is made of. Microfacet roughness r is perceptual: alpha = r^2.";
  mat.default_value = json::object({{"type", "car_paint"}});
  Field micro = enumeration("microfacet", {"ggx", "beckmann"}, "ggx",
                            "Microfacet distribution (Smith height-correlated masking-shadowing).");
  mat.variants["car_paint"] = {
      rgb("base_color", {0.55, 0.03, 0.03}, 1, "Base coat colour."),
      num("flake_amount", "", 0.3, 0, 1, "Share of metallic flakes in the base coat (0 = solid paint)."),
      num("flake_roughness", "", 0.35, 0.02, 1, "Roughness of the flakes' glossy lobe."),
      num("clear_coat_roughness", "", 0.05, 0.02, 1, "Roughness of the clear coat."),
      num("clear_coat_ior", "", 1.5, 1.0, 3.0, "Index of refraction of the clear coat.", true, true),
      micro,
      num("orange_peel_um", "um", 2, 0, 50, "RMS height of the clear coat's orange peel (Nilsson 2008 §4.3.2)."),
      num("orange_peel_wavelength_mm", "mm", 3, 0.2, 50, "Wavelength of the orange peel's coarsest octave."),
      num("flake_size_mm", "mm", 0.03, 0.005, 1, "Size of a metallic flake."),
      num("flake_density", "", 0.3, 0, 1, "Fraction of flake-grid cells holding a flake."),
      num("flake_tilt_deg", "deg", 12, 0, 45, "Spread of the flakes' normals (sparkle directions)."),
      num("sparkle", "", 1, 0, 1, "Strength of resolved flakes' sparkles (0 = smooth flake lobe only); "
          "sparkles fade as the pixel footprint covers many flakes."),
      num("color_variation", "", 0.03, 0, 0.3, "Standard deviation of the slow variation of the base colour.")};
  mat.variant_docs["car_paint"] = "Clear coat over a base coat of colour and metallic flakes.";
  mat.variants["metal"] = {enumeration("metal", metalNames(), "steel",
                                       "Bare metal, by name; complex IOR per RGB channel (see Metals below).",
                                       true),
                           num("roughness", "", 0.2, 0.02, 1, "Surface roughness."), micro};
  mat.variant_docs["metal"] = "Bare conductor with the exact Fresnel equations for its complex IOR.";
  mat.variants["plastic"] = {rgb("base_color", {0.05, 0.05, 0.05}, 1, "Diffuse colour."),
                             num("roughness", "", 0.4, 0.02, 1, "Surface roughness."),
                             num("ior", "", 1.5, 1.0, 3.0, "Index of refraction.", true, true), micro};
  mat.variant_docs["plastic"] = "Dielectric gloss over a diffuse base.";
  mat.variants["glass"] = {
      num("ior", "", 1.5, 1.0, 3.0, "Index of refraction (glass 1.5, polycarbonate 1.59, PMMA 1.49).", true, true),
      num("roughness", "", 0.02, 0.02, 1, "Surface roughness (0.02 = polished, as a mirror to the path tracer)."),
      num("thickness_mm", "mm", 4, 0, 1000,
          "Thickness of the solid made from an open part surface (its back is the surface moved "
          "this far against its normals, joined by a rim); a closed mesh is a solid already and "
          "ignores it. Not a distribution: every sample shares the part.",
          false, true),
      micro};
  mat.variant_docs["glass"] =
      "Clear solid dielectric (a lamp lens, a window): rough-dielectric reflection and refraction "
      "(Walter et al. 2007) at every surface of the solid; scratches refract light into it.";
  root.fields.push_back(mat);

  // lights
  Field light;
  light.key = "lights";
  light.type = FieldType::List;
  light.required = true;
  light.doc = "Light sources; at least one. Radiance is in relative units (1 = a white dome that "
              "makes a white diffuse surface render white).";
  Field radiance = rgb("radiance", {1, 1, 1}, 1e6, "Emitted radiance.");
  Field target = vec("target", 3, "mm", {0, 0, 0}, -1e5, 1e5, "Point the light faces.");
  light.variants["environment"] = {
      radiance, path("map", "Latitude-longitude HDR/EXR map (any format OpenImageIO reads); "
                     "replaces `radiance` when given. At most 32768 x 16384 pixels; a damaged JPEG "
                     "(one that decodes only with a warning) is refused.", false),
      num("scale", "", 1, 0, 1e6, "Multiplier on the map."),
      num("rotation_deg", "deg", 0, -360, 360, "Rotation of the map about +z.")};
  light.variant_docs["environment"] = "Light from every direction: constant radiance or an HDR map (+z up).";
  light.variants["dome"] = {radiance};
  light.variant_docs["dome"] = "Diffuse dome: uniform radiance from every direction (bright, shadowless).";
  light.variants["rect"] = {vec("position", 3, "mm", nullptr, -1e5, 1e5, "Centre of the rectangle."),
                            target, vec("size_mm", 2, "mm", nullptr, 0.1, 1e5,
                                "[along u, along v]: u is world +x projected into the light's plane "
                                "(+y if the light faces along x), v completes the frame."),
                            radiance};
  light.variant_docs["rect"] = "One-sided rectangular area light facing `target`.";
  light.variants["disk"] = {vec("position", 3, "mm", nullptr, -1e5, 1e5, "Centre of the disk."), target,
                            num("radius_mm", "mm", 100, 0.1, 1e5, "Radius."), radiance};
  light.variant_docs["disk"] = "One-sided disk area light facing `target`.";
  light.variants["ring"] = {num("radius_mm", "mm", 60, 1, 1e4, "Outer radius of the ring."),
                            num("inner_radius_mm", "mm", 45, 0, 1e4, "Inner radius."),
                            rgb("radiance", {20, 20, 20}, 1e6, "Emitted radiance.")};
  light.variant_docs["ring"] = "Ring light around the lens: an annulus in the camera's plane facing "
                               "along the optical axis.";
  light.variants["bar"] = {num("length_mm", "mm", 600, 1, 1e5, "Length of the bar."),
                           num("width_mm", "mm", 30, 1, 1e4, "Width of the emitting face."),
                           num("distance_mm", "mm", 700, 10, 1e5, "Distance from `target`."),
                           num("elevation_deg", "deg", 10, 0.5, 89.5, "Angle above the part's plane (low = dark field)."),
                           num("azimuth_deg", "deg", 0, -360, 360, "Direction around +z, from +x."),
                           target, rgb("radiance", {30, 30, 30}, 1e6, "Emitted radiance.")};
  light.variant_docs["bar"] = "Low-angle bar light (dark field): a long rectangle at a grazing "
                              "elevation facing `target`; scratches and dents catch its light.";
  light.variants["coaxial"] = {num("radius_mm", "mm", 80, 1, 1e4, "Radius of the emitting disk."),
                               rgb("radiance", {2, 2, 2}, 1e6, "Emitted radiance.")};
  light.variant_docs["coaxial"] = "Coaxial light (bright field): a disk at the camera, facing along "
                                  "the optical axis, seen by the camera only in reflections.";
  root.fields.push_back(light);

  // camera
  Field cam;
  cam.key = "camera";
  cam.type = FieldType::Object;
  cam.required = true;
  cam.doc = "Pinhole camera with OpenCV's model (x right, y down, z forward). Give exactly one of "
            "`fov_deg`, `intrinsics` or `calibration`.";
  cam.fields = {
      num("fov_deg", "deg", nullptr, 1, 170, "Horizontal field of view; principal point at the centre."),
      vec("intrinsics", 4, "px", nullptr, -1e7, 1e7, "[fx, fy, cx, cy] at the render resolution."),
      path("calibration", "cv::FileStorage file (camera_matrix, distortion_coefficients, image_width, "
                          "image_height); K is scaled to the render resolution.", false),
      vec("distortion", 5, "", {0, 0, 0, 0, 0}, -10, 10, "[k1, k2, p1, p2, k3] (ignored with `calibration`)."),
      vec("position", 3, "mm", nullptr, -1e5, 1e5, "Camera centre."),
      vec("target", 3, "mm", {0, 0, 0}, -1e5, 1e5, "Point the optical axis passes through."),
      vec("up", 3, "", {0, 1, 0}, -1, 1, "World direction that appears up in the image.")};
  cam.fields[0].required = false;  // exactly one of fov_deg, intrinsics, calibration (cross-checked)
  cam.fields[1].required = false;
  root.fields.push_back(cam);

  // render
  Field ren;
  ren.key = "render";
  ren.type = FieldType::Object;
  ren.default_value = json::object();
  ren.doc = "Image size, sampling and which outputs are written. Nothing that is not asked for is computed.";
  ren.fields = {
      vec("resolution", 2, "px", {512, 512}, 8, 16384, "[width, height]. Refused when the frame and its outputs cannot fit in the memory the process may use (docs/output.md, \"Memory\").", false, FieldType::Integer),
      integer("spp", "samples/pixel", 16, 1, 65536, "Path samples per pixel."),
      integer("max_bounces", "", 4, 1, 64, "Maximum path length in surface bounces."),
      integer("noise_seed", "", 0, 0, 2147483647,
              "Seed of the pixel sampling only: the same scene (every placement and sampled value comes "
              "from `seed`) rendered with independent noise, e.g. for a converged reference or noisy/clean "
              "pairs. 0 = derived from `seed`."),
      num("exposure_stops", "EV", 0, -20, 20, "Exposure applied before the sRGB curve (PNG only)."),
      enumeration("png", {"8", "16", "none"}, "8", "PNG bit depth, or none."),
      flag("dither", true,
           "8-bit PNG: each value goes to the code below or above it at random (in proportion to how "
           "near it is; from the noise seed, so the same bytes on every run), so that smooth shading "
           "keeps its mean instead of banding into flat steps. false: rounded to the nearest code."),
      flag("exr", false, "Write images/NNNNNN.exr: linear RGB plus the requested AOVs as layers."),
      flag("depth", false, "Depth AOV (camera z in mm) in the EXR."),
      flag("normals", false, "World shading-normal AOV (after bump) in the EXR."),
      flag("masks", true, "Semantic and instance masks and COCO annotations."),
      integer("mask_subsamples", "per axis", 4, 1, 16,
              "The pixel footprint is sampled on an n x n grid to measure defect coverage."),
      enumeration("scratches", {"groove", "geometry", "normal_map"}, "groove",
                  "How scratches are rendered: groove = the footprint integrated over their cross-"
                  "sections (Bosch 2007; exact masking, shadowing and inter-reflection, few samples "
                  "needed); geometry = the explicit-geometry reference (the part re-meshed with the "
                  "cross-sections cut in, on any part; needs many samples, and memory: the door of "
                  "configs/scratched_door.yaml becomes 21 million triangles); normal_map = the "
                  "slopes as a bump map without occlusion (the baseline of texture-based tools)."),
      num("geometry_cell_mm", "mm", 0, 0, 1,
          "scratches: geometry only: the largest edge of the cut mesh's finest cells (the part's UV "
          "chart is halved until they are no larger). 0 = automatic, the narrowest scratch's width / "
          "16 (at least 0.0005 mm). Straight kinks are cut exactly at "
          "any size; finer cells follow the curved ones (a corner's or a half turn's round cap) and "
          "the change along a path more closely, for views of a few micrometres per pixel. The "
          "mesh grows with the inverse square of the cell.",
          false)};
  root.fields.push_back(ren);

  // defects
  Field def;
  def.key = "defects";
  def.type = FieldType::List;
  def.default_value = json::array();
  def.doc = "Defect groups. Each group places `count` defects of one type at random UV positions.";
  def.variants["dent"] = {
      integer("count", "", 1, 0, 1000, "Number of dents in the group.", true),
      num("radius_mm", "mm", 15, 0.5, 500, "Radius of the dent."),
      num("depth_mm", "mm", 0.5, 0, 50, "Depth at the centre (0 leaves the surface unchanged)."),
      num("mask_threshold", "fraction", 0.1, 0.0, 0.99,
          "Labelled where the depth is at least this fraction of the centre depth.", false, true),
      vec("region", 4, "fraction", {0, 0, 1, 1}, 0, 1,
          "[u0, v0, u1, v1]: where centres may fall, as fractions of the part's UV extent. Centres "
          "are drawn uniformly by area on the part's surface within it.", false),
      optional(vec("center", 2, "fraction", nullptr, 0, 1,
                   "[u, v]: a fixed centre, as fractions of the part's UV extent (instead of `region`)."))};
  def.variant_docs["dent"] = "Round dent or crease, rendered by bump mapping (Blinn 1978) with a C1 "
                             "polynomial bowl profile across its centre point or line.";
  Field region = def.variants["dent"][4], center = def.variants["dent"][5];
  Field disp = enumeration("displacement", {"auto", "bump", "geometry"}, "auto",
                           "How the dent is rendered: bump mapping only, true geometry (the part is "
                           "refined and displaced for this sample, so silhouettes change), or auto: "
                           "geometry when the steepest tilt exceeds 15 degrees or the dent reaches the "
                           "part's outline, bump otherwise.");
  Field disp_edge = num("displacement_edge_mm", "mm", 1.0, 0.05, 20,
                        "Largest triangle edge inside a displaced dent.", false);
  def.variants["dent"].push_back(disp);
  def.variants["dent"].push_back(disp_edge);
  def.variants["dent"].push_back(num("length_mm", "mm", 0, 0, 2000,
                                     "Length of the crease line through the centre; 0 = a round dent."));
  def.variants["dent"].push_back(num("angle_deg", "deg", 0, -360, 360,
                                     "Direction of a crease in the UV chart, from +u toward +v."));
  def.variants["hail"] = {
      integer("count", "", 1, 0, 100, "Number of hail clusters.", true),
      integer("dents_per_cluster", "", 12, 1, 500, "Dents in each cluster.", true),
      num("cluster_radius_mm", "mm", 80, 1, 2000, "Radius of the area a cluster's dents fall in."),
      num("radius_mm", "mm", 6, 0.5, 100, "Radius of each dent."),
      num("depth_mm", "mm", 0.4, 0, 10, "Depth of each dent."),
      def.variants["dent"][3], region, center, disp, disp_edge};
  def.variant_docs["hail"] = "A hail cluster: many small round dents scattered in a disc; each dent "
                             "is its own instance of class dent.";
  def.variants["rust"] = {
      integer("count", "", 1, 0, 1000, "Number of rust spots in the group.", true),
      enumeration("origin", {"pit", "edge", "scratch"}, "pit",
                  "Where the rust starts: a pit in the surface, the part's edge (the centre is moved "
                  "to the nearest edge of the UV chart), or a scratch that cuts through the paint: the "
                  "rust then grows along the stretch of the scratch that bares the steel (chosen at "
                  "random, by length, among the sample's scratches; none is placed when no scratch "
                  "reaches the steel, and the sample's metadata says so). `scratch` needs a scratch "
                  "group in `defects`.", true),
      num("radius_mm", "mm", 20, 1, 1000, "Extent of the fully grown spot."),
      num("age_years", "years", 2, 0, 100, "Age; for one seed the rusted area only grows with it."),
      num("growth_years", "years", 3, 0.01, 100, "Time constant of the front: g = 1 - exp(-age/growth).",
          true, true),
      num("roughness", "", 0.35, 0, 1, "Raggedness of the front (noise amplitude, in units of the radius)."),
      num("pit_depth_mm", "mm", 0.15, 0, 5, "Depth of the oldest rust (bump)."),
      num("blister_width_mm", "mm", 3, 0, 50, "Width of the ring of bubbled paint around the front."),
      num("blister_height_mm", "mm", 0.08, 0, 2, "Height of the paint bubbles."),
      num("sigma_deg", "deg", 30, 0, 90, "Oren-Nayar roughness of the rust."),
      rgb("fresh_color", {0.35, 0.12, 0.04}, 1, "Colour of fresh rust at the front (orange-red)."),
      rgb("old_color", {0.06, 0.03, 0.015}, 1, "Colour of the oldest, deepest rust (dark brown)."),
      region, center};
  def.variant_docs["rust"] = "Rust spot after Mihaylov (2013) with the digest's corrections: a noise-"
                             "ragged front that advances with age, colour from orange-red (fresh) to dark "
                             "brown (old), Oren-Nayar reflectance, pitted bump, bubbled paint at the "
                             "front. See docs/weathering.md.";
  def.variants["patina"] = {
      integer("count", "", 1, 0, 1000, "Number of patina regions in the group.", true),
      num("radius_mm", "mm", 0, 0, 5000, "Radius of the region; 0 = the whole part."),
      num("age_years", "years", 5, 0, 300, "Age; coverage only grows with it."),
      num("environment", "", 1, 0.1, 10, "Speed-up of the environment (2-4 near the sea)."),
      num("cavity_weight", "", 0, 0, 1, "How much cavities (ambient occlusion of the part) attract "
          "patina; > 0 computes the part's occlusion once per dataset."),
      num("scale_mm", "mm", 15, 0.5, 1000, "Wavelength of the coverage noise."),
      num("bump_mm", "mm", 0.03, 0, 1, "Height of the patina crust (bump)."),
      num("sigma_deg", "deg", 35, 0, 90, "Oren-Nayar roughness of the patina."),
      region, center};
  def.variant_docs["patina"] = "Patina on copper, brass, bronze or bare steel (Mihaylov 2013 §5): a five-"
                               "colour ramp from dark-brown tarnish to blue-green, coverage growing "
                               "monotonically with age. See docs/weathering.md.";
  def.variants["scratch"] = {
      integer("count", "", 1, 0, 1000,
              "Number of scratches in the group (pattern swirl: arcs in the swirl set).", true),
      enumeration("pattern", {"random", "key", "swirl", "path"}, "random",
                  "random: independent scratches of `length_mm`, `orientation_deg`, `curvature_per_mm`; "
                  "key: long gently curved scratches across the region (cubic curves); swirl: wash "
                  "swirls, concentric arcs about one centre; path: the path given by `path_mm` and "
                  "`curve`, placed at each scratch's centre."),
      num("length_mm", "mm", 20, 0.5, 5000, "Length of a random scratch."),
      optional(num("orientation_deg", "deg", nullptr, -360, 360,
                   "Direction of a random scratch in the UV chart, from +u toward +v; absent = uniform. "
                   "With pattern path: the turn of `path_mm` about the centre; absent = as given.")),
      optional(vec("path_mm", -4, "mm", nullptr, -5000, 5000,
                   "Pattern path only: the path's points [u0, v0, u1, v1, ...] in the UV chart, in mm "
                   "from the scratch's centre (`center`, or drawn in `region`); see `curve`.",
                   false)),
      enumeration("curve", {"polyline", "bezier"}, "polyline",
                  "How `path_mm` makes the path: polyline = straight segments through the points (at "
                  "least two distinct; a point that goes back along the line the path came on and ends "
                  "within 0.1 um of it is put exactly on it, so a path typed back over itself with "
                  "rounded numbers retraces its way); bezier = a chain of cubic Bezier curves, 3k + 1 "
                  "control points (k >= 1), each curve starting where the last ended."),
      num("curvature_per_mm", "1/mm", 0, 0, 1, "Curvature of a random scratch (its sign is random)."),
      num("force_kg", "kg", 1, 0, 1000, "Normal force on the tool, F_N (Bosch 2007 §3.2)."),
      num("hardness_hv", "kg/mm^2", 20, 0.1, 5000,
          "Vickers hardness of the scratched surface, H_V (clear coat ~10-30, steel ~150-250)."),
      enumeration("tool", {"cone", "pyramid"}, "cone", "Tool shape: a cone with a rounded tip, or a "
                  "Vickers-like pyramid."),
      num("tool_apex_deg", "deg", 100, 10, 170, "Full apex angle of the tool (pyramid: face to face)."),
      num("tool_tip_radius_mm", "mm", 0.002, 0, 5, "Tip radius of a cone tool."),
      num("tool_tilt_deg", "deg", 0, 0, 80,
          "Tilt of the tool axis from the surface normal (theta_t); at most 89 deg minus the steepest half-angle of the "
          "tool (a cone's apex/2, a pyramid's edge), so that its tip stays its lowest point."),
      num("tool_tilt_azimuth_deg", "deg", 0, -360, 360,
          "Direction of the tilt from the scratch direction toward its left (phi_t)."),
      num("pileup", "fraction", 0.6, 0, 1, "Share of the groove's volume piled up beside it (1 = "
          "Bosch's conservation of volume; less for cutting tools and paint)."),
      optional(vec("profile_mm", -4, "mm", nullptr, -50, 50,
                   "Explicit cross-section [b0, w0, b1, w1, ...] across the path (b left of the path, "
                   "w up), from w = 0 to w = 0 with b non-decreasing; replaces the process model.",
                   false)),
      num("fade_mm", "mm", 2, 0, 1000, "The force ramps up from 0 over this length at each end."),
      num("perturbation", "fraction", 0.15, 0, 0.95, "Random variation of the depth along the path."),
      vec("coating_mm", 3, "mm", {0.04, 0.015, 0.03}, 0, 5,
          "[clear coat, base coat, primer] thicknesses of car paint over the metal; a facet deeper "
          "than the clear coat shows the base coat, then primer, then bare steel. Other materials "
          "are one solid layer.", false),
      region, center};
  def.variant_docs["scratch"] = "Scratches rendered as grooves (Bosch 2007): a path in the UV chart and "
                                "a cross-section derived from the tool, force and hardness; one instance "
                                "of class scratch per path. See docs/grooves.md.";
  root.fields.push_back(def);
  return root;
}

}  // namespace

const Field& configSchema() {
  static const Field schema = buildSchema();
  return schema;
}

// ---------------------------------------------------------------------------------------------
// Parsing and validation
// ---------------------------------------------------------------------------------------------

size_t editDistance(const std::string& a, const std::string& b) {
  std::vector<size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (size_t j = 1; j <= b.size(); ++j)
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

namespace {

std::string closest(const std::string& key, const std::vector<std::string>& options) {
  std::string best;
  size_t bd = std::string::npos;
  for (auto& o : options) {
    size_t d = editDistance(key, o);
    if (d < bd) {
      bd = d;
      best = o;
    }
  }
  if (bd <= std::max<size_t>(2, key.size() / 3)) return best;
  return "";
}

std::string joinList(const std::vector<std::string>& v) {
  std::string s;
  for (size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + v[i];
  return s;
}

std::string fmt(double v) {
  std::ostringstream s;
  s << std::setprecision(10) << v;
  return s.str();
}

class Parser {
 public:
  Parser(std::string file, std::vector<InputError>* collect = nullptr) : file_(std::move(file)), collect_(collect) {}

  // In collecting mode (validate), an error in one field is recorded and parsing goes on with the
  // next field, so that every error is reported at once.
  template <class Fn>
  bool attempt(Fn&& fn) const {
    if (!collect_) {
      fn();
      return true;
    }
    try {
      fn();
      return true;
    } catch (const InputError& e) {
      collect_->push_back(e);
      return false;
    }
  }

  [[noreturn]] void fail(const YAML::Node& n, const std::string& msg) const {
    if (n.IsDefined() && n.Mark().line >= 0) throw InputError(file_, n.Mark().line + 1, n.Mark().column + 1, msg);
    throw InputError(file_, msg);
  }
  [[noreturn]] void failAt(int line, int col, const std::string& msg) const {
    throw InputError(file_, line, col, msg);
  }

  static std::string where(const std::string& path) { return path.empty() ? "the top level" : "'" + path + "'"; }

  double toNumber(const YAML::Node& n, const std::string& path, bool integer) const {
    if (!n.IsScalar()) fail(n, where(path) + ": expected a number" + std::string(integer ? " (integer)" : ""));
    const std::string& s = n.Scalar();
    char* end = nullptr;
    double v = std::strtod(s.c_str(), &end);
    if (s.empty() || end != s.c_str() + s.size() || !std::isfinite(v))
      fail(n, where(path) + ": expected a number, got '" + s + "'");
    if (integer && v != std::floor(v)) fail(n, where(path) + ": expected an integer, got " + s);
    return v;
  }

  void checkRange(const YAML::Node& n, const Field& f, const std::string& path, double v) const {
    bool lo_bad = f.min && (f.min_exclusive ? !(v > *f.min) : !(v >= *f.min));
    bool hi_bad = f.max && !(v <= *f.max);
    if (lo_bad || hi_bad) {
      std::string range = std::string(f.min_exclusive ? "(" : "[") + (f.min ? fmt(*f.min) : "-inf") + ", " +
                          (f.max ? fmt(*f.max) : "inf") + "]";
      fail(n, where(path) + ": " + fmt(v) + " is out of range; expected a value in " + range +
                  (f.unit.empty() ? "" : " " + f.unit));
    }
  }

  // A scalar number, or a distribution over numbers.
  Dist numberOrDist(const YAML::Node& n, const Field& f, const std::string& path, bool integer) const {
    Dist d;
    if (n.IsMap()) {
      if (!f.random_ok)
        fail(n, where(path) + ": must be a constant here, not a distribution" +
                    (f.key == "tessellation_mm" || path.rfind("part.", 0) == 0
                         ? " (the part is fixed for a dataset so that its BVH is built once)"
                         : ""));
      std::vector<std::string> kinds = {"uniform", "loguniform", "normal", "choice"};
      std::string kind;
      for (auto it = n.begin(); it != n.end(); ++it) {
        std::string k = it->first.Scalar();
        if (k == "weights") continue;
        if (std::find(kinds.begin(), kinds.end(), k) == kinds.end()) {
          std::string s = closest(k, kinds);
          fail(it->first, where(path) + ": unknown distribution '" + k + "'" +
                              (s.empty() ? "" : "; did you mean '" + s + "'?") + " Expected one of: " +
                              joinList(kinds));
        }
        if (!kind.empty()) fail(it->first, where(path) + ": a distribution has exactly one kind");
        kind = k;
      }
      if (kind.empty()) fail(n, where(path) + ": empty distribution; expected one of " + joinList(kinds));
      const YAML::Node& a = n[kind];
      if (kind == "uniform" || kind == "loguniform") {
        if (!a.IsSequence() || a.size() != 2) fail(a, where(path) + ": " + kind + " expects [min, max]");
        d.kind = kind == "uniform" ? Dist::Kind::Uniform : Dist::Kind::LogUniform;
        d.a = toNumber(a[0], path, integer);
        d.b = toNumber(a[1], path, integer);
        if (!(d.a <= d.b)) fail(a, where(path) + ": " + kind + " needs min <= max");
        if (d.kind == Dist::Kind::LogUniform && !(d.a > 0)) fail(a, where(path) + ": loguniform needs min > 0");
        checkRange(a[0], f, path, d.a);
        checkRange(a[1], f, path, d.b);
      } else if (kind == "normal") {
        if (!a.IsMap()) fail(a, where(path) + ": normal expects {mean: m, std: s, min: lo, max: hi}");
        for (auto it = a.begin(); it != a.end(); ++it) {
          std::string k = it->first.Scalar();
          if (k != "mean" && k != "std" && k != "min" && k != "max") {
            std::string s = closest(k, {"mean", "std", "min", "max"});
            fail(it->first, where(path) + ": unknown key '" + k + "' in normal" +
                                (s.empty() ? "" : "; did you mean '" + s + "'?"));
          }
        }
        if (!a["mean"] || !a["std"]) fail(a, where(path) + ": normal needs 'mean' and 'std'");
        d.kind = Dist::Kind::Normal;
        d.a = toNumber(a["mean"], path, false);
        d.b = toNumber(a["std"], path, false);
        if (!(d.b >= 0)) fail(a["std"], where(path) + ": std must be >= 0");
        // Samples are clamped to [min, max]; without them, to the field's documented range.
        d.lo = a["min"] ? toNumber(a["min"], path, false) : (f.min ? *f.min : -1e300);
        d.hi = a["max"] ? toNumber(a["max"], path, false) : (f.max ? *f.max : 1e300);
        if (a["min"]) checkRange(a["min"], f, path, d.lo);
        if (a["max"]) checkRange(a["max"], f, path, d.hi);
        if (!(d.lo <= d.hi)) fail(a, where(path) + ": normal needs min <= max");
        if (f.min_exclusive && f.min && d.lo <= *f.min)
          fail(a, where(path) + ": give normal a 'min' above " + fmt(*f.min));
      } else {  // choice
        if (!a.IsSequence() || a.size() == 0) fail(a, where(path) + ": choice expects a non-empty list");
        d.kind = Dist::Kind::Choice;
        for (size_t i = 0; i < a.size(); ++i) {
          double v = toNumber(a[i], path, integer);
          checkRange(a[i], f, path, v);
          d.choices.push_back(v);
        }
        weights(n, d, path);
      }
      return d;
    }
    double v = toNumber(n, path, integer);
    checkRange(n, f, path, v);
    d.constant = integer ? json(int64_t(v)) : json(v);
    return d;
  }

  void weights(const YAML::Node& n, Dist& d, const std::string& path) const {
    if (!n["weights"]) {
      d.weights.assign(d.choices.size(), 1.0);
      return;
    }
    const YAML::Node& w = n["weights"];
    if (!w.IsSequence() || w.size() != d.choices.size())
      fail(w, where(path) + ": weights must be a list as long as the choices (" +
                  std::to_string(d.choices.size()) + ")");
    double sum = 0;
    for (size_t i = 0; i < w.size(); ++i) {
      double x = toNumber(w[i], path + ".weights", false);
      if (x < 0) fail(w[i], where(path) + ": weights must be >= 0");
      d.weights.push_back(x);
      sum += x;
    }
    if (!(sum > 0)) fail(w, where(path) + ": weights must not all be 0");
  }

  Dist enumOrChoice(const YAML::Node& n, const Field& f, const std::string& path) const {
    auto check = [&](const YAML::Node& s) {
      if (!s.IsScalar()) fail(s, where(path) + ": expected one of: " + joinList(f.enum_values));
      std::string v = s.Scalar();
      if (std::find(f.enum_values.begin(), f.enum_values.end(), v) == f.enum_values.end()) {
        std::string c = closest(v, f.enum_values);
        fail(s, where(path) + ": '" + v + "' is not valid" + (c.empty() ? "" : "; did you mean '" + c + "'?") +
                    " Expected one of: " + joinList(f.enum_values));
      }
      return v;
    };
    Dist d;
    if (n.IsMap()) {
      if (!f.random_ok) fail(n, where(path) + ": must be a constant here, not a distribution");
      if (!n["choice"]) fail(n, where(path) + ": the only distribution for a name is {choice: [...], weights: [...]}");
      const YAML::Node& a = n["choice"];
      if (!a.IsSequence() || a.size() == 0) fail(a, where(path) + ": choice expects a non-empty list");
      d.kind = Dist::Kind::Choice;
      for (size_t i = 0; i < a.size(); ++i) d.choices.push_back(check(a[i]));
      weights(n, d, path);
      return d;
    }
    d.constant = check(n);
    return d;
  }

  Value parseScalar(const YAML::Node& n, const Field& f, const std::string& path) const {
    Value v;
    v.field = &f;
    v.path = path;
    v.line = n.Mark().line + 1;
    v.column = n.Mark().column + 1;
    switch (f.type) {
      case FieldType::Number:
        v.dist = numberOrDist(n, f, path, false);
        break;
      case FieldType::Integer:
        v.dist = numberOrDist(n, f, path, true);
        break;
      case FieldType::Bool: {
        bool b;
        if (!n.IsScalar() || !YAML::convert<bool>::decode(n, b))
          fail(n, where(path) + ": expected true or false");
        v.dist.constant = b;
        break;
      }
      case FieldType::String:
      case FieldType::Path:
        if (!n.IsScalar() || n.Scalar().empty()) fail(n, where(path) + ": expected a " +
                                                                (f.type == FieldType::Path ? "file path" : "string"));
        v.dist.constant = n.Scalar();
        if (f.type == FieldType::Path) {
          std::filesystem::path p(n.Scalar());
          if (p.is_relative()) p = std::filesystem::path(file_).parent_path() / p;
          std::error_code ec;
          if (!std::filesystem::is_regular_file(p, ec)) {
            const bool missing = !std::filesystem::exists(p, ec);
            // A shell would have expanded these; a config is not read by one.
            const std::string& given = n.Scalar();
            const bool shellish = !given.empty() && (given[0] == '~' || given.find('$') != std::string::npos);
            fail(n, where(path) + (std::filesystem::is_directory(p, ec) ? ": is a folder, expected a file: "
                                   : !missing                           ? ": is not a regular file: "
                                                                        : ": file not found: ") +
                        p.string() +
                        (missing && shellish ? " (a config does not expand '~' or $VARIABLES: give the path in "
                                               "full, or relative to the config file)"
                                             : ""));
          }
          v.dist.constant = p.lexically_normal().string();
        }
        break;
      case FieldType::Enum:
        v.dist = enumOrChoice(n, f, path);
        break;
      case FieldType::Vector: {
        // vector_size < 0: a list of at least -vector_size numbers.
        bool ok = n.IsSequence() && (f.vector_size > 0 ? int(n.size()) == f.vector_size
                                                       : int(n.size()) >= -f.vector_size);
        if (!ok)
          fail(n, where(path) + ": expected a list of " + (f.vector_size < 0 ? "at least " : "") +
                      std::to_string(std::abs(f.vector_size)) + " numbers" +
                      (f.unit.empty() ? "" : " (" + f.unit + ")"));
        Field ef = f;
        ef.type = f.element_type;
        for (int i = 0; i < int(n.size()); ++i) {
          Value e;
          e.field = &f;
          e.path = path + "[" + std::to_string(i) + "]";
          e.line = n[i].Mark().line + 1;
          e.column = n[i].Mark().column + 1;
          e.dist = numberOrDist(n[i], ef, e.path, f.element_type == FieldType::Integer);
          v.items.push_back(std::move(e));
        }
        break;
      }
      default:
        break;
    }
    return v;
  }

  Value defaultValue(const Field& f, const std::string& path, int line, int col) const {
    // Defaults are given in the schema as JSON; parse them through YAML so they take the same path.
    YAML::Node n = YAML::Load(f.default_value.dump());
    Value v = parse(n, f, path);
    auto mark = [&](Value& x, auto& self) -> void {
      x.defaulted = true;
      x.line = line;
      x.column = col;
      for (auto& i : x.items) self(i, self);
      for (auto& m : x.members) self(m.second, self);
    };
    mark(v, mark);
    return v;
  }

  Value parseObject(const YAML::Node& n, const Field& f, const std::string& path) const {
    if (!n.IsMap()) fail(n, where(path) + ": expected a mapping of keys to values");
    Value v;
    v.field = &f;
    v.path = path;
    v.line = n.Mark().line + 1;
    v.column = n.Mark().column + 1;
    std::vector<const Field*> fields;
    for (auto& c : f.fields) fields.push_back(&c);
    if (!f.variants.empty()) {
      std::vector<std::string> types;
      for (auto& kv : f.variants) types.push_back(kv.first);
      const YAML::Node& t = n["type"];
      if (!t) fail(n, where(path) + ": missing 'type'; expected one of: " + joinList(types));
      if (!t.IsScalar() || !f.variants.count(t.Scalar())) {
        std::string c = t.IsScalar() ? closest(t.Scalar(), types) : "";
        fail(t, where(path + ".type") + ": '" + (t.IsScalar() ? t.Scalar() : std::string("?")) +
                    "' is not a known type" + (c.empty() ? "" : "; did you mean '" + c + "'?") +
                    " Expected one of: " + joinList(types));
      }
      static const Field type_field = [] {
        Field tf;
        tf.key = "type";
        tf.type = FieldType::String;
        return tf;
      }();
      Value tv;
      tv.field = &type_field;
      tv.path = path + ".type";
      tv.dist.constant = t.Scalar();
      tv.line = t.Mark().line + 1;
      tv.column = t.Mark().column + 1;
      v.members["type"] = tv;
      v.member_order.push_back("type");
      for (auto& c : f.variants.at(t.Scalar())) fields.push_back(&c);
    }
    std::vector<std::string> keys;
    for (auto* c : fields) keys.push_back(c->key);
    if (!f.variants.empty()) keys.push_back("type");
    for (auto it = n.begin(); it != n.end(); ++it) {
      if (!it->first.IsScalar()) fail(it->first, where(path) + ": keys must be plain names");
      std::string k = it->first.Scalar();
      if (std::find(keys.begin(), keys.end(), k) == keys.end()) {
        std::string c = closest(k, keys);
        attempt([&] {
          fail(it->first, "unknown key '" + k + "' in " + where(path) +
                              (c.empty() ? "" : "; did you mean '" + c + "'?") + " Valid keys: " + joinList(keys));
        });
      }
    }
    for (auto* c : fields) {
      std::string p = path.empty() ? c->key : path + "." + c->key;
      const YAML::Node& m = n[c->key];
      if (m && !m.IsNull()) {
        if (!attempt([&] { v.members[c->key] = parse(m, *c, p); })) continue;
      } else if (!c->default_value.is_null()) {
        v.members[c->key] = defaultValue(*c, p, v.line, v.column);
      } else if (c->required) {
        attempt([&] { fail(n, where(path) + ": missing required key '" + c->key + "' (" + c->doc + ")"); });
        continue;
      } else {
        continue;
      }
      v.member_order.push_back(c->key);
    }
    return v;
  }

  Value parse(const YAML::Node& n, const Field& f, const std::string& path) const {
    if (f.type == FieldType::Object) return parseObject(n, f, path);
    if (f.type == FieldType::List) {
      if (!n.IsSequence()) fail(n, where(path) + ": expected a list");
      Value v;
      v.field = &f;
      v.path = path;
      v.line = n.Mark().line + 1;
      v.column = n.Mark().column + 1;
      for (size_t i = 0; i < n.size(); ++i)
        attempt([&] { v.items.push_back(parseObject(n[i], f, path + "[" + std::to_string(i) + "]")); });
      return v;
    }
    return parseScalar(n, f, path);
  }

  std::string file_;
  std::vector<InputError>* collect_;
};

// The largest value a number (constant or distribution) can take.
double largest(const Dist& d) {
  switch (d.kind) {
    case Dist::Kind::Const: return d.constant.get<double>();
    case Dist::Kind::Uniform:
    case Dist::Kind::LogUniform: return d.b;
    case Dist::Kind::Normal: return d.hi;
    case Dist::Kind::Choice: {
      double m = -1e300;
      for (const auto& c : d.choices) m = std::max(m, c.get<double>());
      return m;
    }
  }
  return 0;
}

// A scratch group's tool tilt must keep the tip the tool's lowest point (defects/scratch.h,
// maxToolTilt) for every tilt and apex its distributions can draw: the widest apex with the
// largest tilt.
void checkToolTilt(const Parser& p, const Value& d) {
  const Value& tilt = d["tool_tilt_deg"];
  const bool pyramid = d["tool"].str() == "pyramid";
  ToolSpec t;
  t.shape = pyramid ? ToolSpec::Shape::Pyramid : ToolSpec::Shape::Cone;
  const double apex = largest(d["tool_apex_deg"].dist);
  t.apex_angle_rad = apex * kPi / 180.0;
  const double most = largest(tilt.dist), limit = std::max(0.0, maxToolTilt(t) * 180.0 / kPi);
  if (most <= limit + 1e-9) return;
  std::ostringstream m;
  m << std::setprecision(4) << "'" << tilt.path << "': " << (tilt.isConstant() ? "a tilt of " : "tilts up to ") << most
    << " deg would put the " << (pyramid ? "pyramid's edges" : "cone's flank") << " below its tip (tool_apex_deg "
    << (d["tool_apex_deg"].isConstant() ? "" : "up to ") << apex
    << "); expected at most " << limit << " deg (90 - 1 - the steepest half-angle of the tool)";
  p.failAt(tilt.line, tilt.column, m.str());
}

// pattern: path needs path_mm, and path_mm is read by nothing else; its points must make a path.
void checkScratchPattern(const Parser& p, const Value& d) {
  const Value& pattern = d["pattern"];
  const std::string pat = pattern.str();
  const bool is_path = pat == "path";
  // A field the group's pattern does not read is a mistake, not something to ignore: key draws its
  // scratches across `region` (no centre, length, curvature or direction of the user's), swirl
  // makes its own arcs about the centre.
  const struct {
    const char* key;
    std::vector<std::string> readers;
  } read_by[] = {{"length_mm", {"random"}},          {"curvature_per_mm", {"random"}},
                 {"orientation_deg", {"random", "path"}}, {"path_mm", {"path"}},
                 {"curve", {"path"}},                {"center", {"random", "swirl", "path"}}};
  for (const auto& r : read_by) {
    if (!d.has(r.key) || d[r.key].defaulted) continue;
    if (std::find(r.readers.begin(), r.readers.end(), pat) != r.readers.end()) continue;
    std::string who = r.readers.size() == 1 ? "pattern " + r.readers[0] : "patterns ";
    for (size_t i = 0; r.readers.size() > 1 && i < r.readers.size(); ++i)
      who += (i == 0 ? "" : i + 1 == r.readers.size() ? " and " : ", ") + r.readers[i];
    const Value& v = d[r.key];
    p.failAt(v.line, v.column,
             "'" + v.path + "': only " + who + " read" + (r.readers.size() == 1 ? "s " : " ") + r.key +
                 " (the pattern is " + pat + ")");
  }
  if (!d.has("path_mm")) {
    if (is_path) p.failAt(pattern.line, pattern.column, "'" + pattern.path + "': pattern path needs 'path_mm'");
    return;
  }
  const Value& pm = d["path_mm"];
  if (pm.items.size() % 2 != 0)
    p.failAt(pm.line, pm.column, "'" + pm.path + "': expected pairs [u, v]: an even count of numbers");
  const size_t n = pm.items.size() / 2;
  const bool bezier = d["curve"].str() == "bezier";
  if (bezier && (n < 4 || (n - 1) % 3 != 0))
    p.failAt(pm.line, pm.column,
             "'" + pm.path + "': curve bezier expected 3k + 1 control points (4, 7, 10, ...), found " +
                 std::to_string(n));
  bool distinct = false;
  for (size_t i = 1; i < n; ++i)
    distinct = distinct || pm.items[2 * i].num() != pm.items[0].num() || pm.items[2 * i + 1].num() != pm.items[1].num();
  if (!distinct) p.failAt(pm.line, pm.column, "'" + pm.path + "': expected at least two distinct points");
}

// Rules that involve several fields.
void crossChecks(const Value& root, const Parser& p) {
  const Value& cam = root["camera"];
  int given = int(cam.has("fov_deg")) + int(cam.has("intrinsics")) + int(cam.has("calibration"));
  if (given != 1)
    p.failAt(cam.line, cam.column,
             "'camera': give exactly one of 'fov_deg', 'intrinsics' or 'calibration' (found " +
                 std::to_string(given) + ")");
  if (root["lights"].items.empty())
    p.failAt(root["lights"].line, root["lights"].column, "'lights': at least one light is needed");
  int envs = 0;
  for (const Value& l : root["lights"].items) {
    std::string t = l["type"].str();
    if ((t == "environment" || t == "dome") && ++envs > 1)
      p.failAt(l.line, l.column, "'" + l.path + "': only one environment or dome light per config");
    if (l["type"].str() == "ring" && l["inner_radius_mm"].isConstant() && l["radius_mm"].isConstant() &&
        !(l["inner_radius_mm"].num() < l["radius_mm"].num()))
      p.failAt(l["inner_radius_mm"].line, l["inner_radius_mm"].column,
               "'" + l.path + ".inner_radius_mm' must be smaller than radius_mm");
  }
  const Value& ren = root["render"];
  if (!ren["geometry_cell_mm"].defaulted) {  // (defaults are filled in by now)
    const Value& gc = ren["geometry_cell_mm"];
    if (ren["scratches"].str() != "geometry")
      p.failAt(gc.line, gc.column,
               "'render.geometry_cell_mm': only scratches: geometry reads geometry_cell_mm (render.scratches is " +
                   ren["scratches"].str() + ")");
    if (gc.num() != 0 && gc.num() < 0.0005)
      p.failAt(gc.line, gc.column,
               "'render.geometry_cell_mm': expected 0 (automatic) or at least 0.0005 mm, found " + gc.str());
  }
  bool has_scratches = false;
  for (const Value& d : root["defects"].items) has_scratches = has_scratches || d["type"].str() == "scratch";
  for (const Value& d : root["defects"].items) {
    if (d["type"].str() == "rust" && !has_scratches) {
      const Value& o = d["origin"];
      bool may_scratch = o.dist.kind == Dist::Kind::Const ? o.str() == "scratch" : false;
      for (const auto& ch : o.dist.choices) may_scratch = may_scratch || ch == "scratch";
      if (may_scratch)
        p.failAt(o.line, o.column, "'" + o.path + "': origin 'scratch' needs a group of type scratch in 'defects'");
    }
    if (d["type"].str() == "scratch" && !d.has("profile_mm")) checkToolTilt(p, d);
    if (d["type"].str() == "scratch") checkScratchPattern(p, d);
    const Value& r = d["region"];
    if (!(r.items[0].num() < r.items[2].num() && r.items[1].num() < r.items[3].num()))
      p.failAt(r.line, r.column, "'" + r.path + "': expected [u0, v0, u1, v1] with u0 < u1 and v0 < v1");
  }
}

}  // namespace

const Value& Value::operator[](const std::string& k) const {
  auto it = members.find(k);
  if (it == members.end()) throw std::logic_error("config: no member '" + k + "' in '" + path + "'");
  return it->second;
}

double Value::num() const {
  if (dist.kind != Dist::Kind::Const) throw std::logic_error("config: '" + path + "' is a distribution");
  return dist.constant.get<double>();
}
std::string Value::str() const {
  if (dist.kind != Dist::Kind::Const) throw std::logic_error("config: '" + path + "' is a distribution");
  return dist.constant.is_string() ? dist.constant.get<std::string>() : dist.constant.dump();
}
bool Value::flag() const { return dist.constant.get<bool>(); }

Config parseConfig(const std::string& text, const std::string& file) { return parseConfig(text, file, nullptr); }

namespace {
// A key given twice in one mapping: YAML forbids it, and yaml-cpp keeps both and answers with the
// first, so the second value (often the one the user meant, added later at the end of the file)
// would be silently ignored.
void refuseDuplicateKeys(const YAML::Node& n, const std::string& file, int depth = 0) {
  if (depth > 256) return;  // yaml-cpp refuses far shallower documents
  if (n.IsSequence()) {
    for (const YAML::Node& c : n) refuseDuplicateKeys(c, file, depth + 1);
  } else if (n.IsMap()) {
    std::map<std::string, YAML::Mark> seen;
    for (auto it = n.begin(); it != n.end(); ++it) {
      if (it->first.IsScalar()) {
        const auto [at, fresh] = seen.emplace(it->first.Scalar(), it->first.Mark());
        if (!fresh)
          throw InputError(file, it->first.Mark().line + 1, it->first.Mark().column + 1,
                           "'" + it->first.Scalar() + "' is given twice in one mapping (first at line " +
                               std::to_string(at->second.line + 1) + "); keep one");
      }
      refuseDuplicateKeys(it->second, file, depth + 1);
    }
  }
}
// YAML 1.1's merge key, which yaml-cpp leaves as an ordinary key "<<": `<<: *name` or
// `<<: [*a, *b]` adds the keys of those mappings to the mapping that holds it, where it does not
// give them itself (of a list, the first mapping wins). The merged keys and values keep their place
// in the file, so an error in one points at the anchor's text.
void expandMergeKeys(YAML::Node n, const std::string& file, int depth = 0) {
  if (depth > 256) return;
  if (n.IsSequence()) {
    for (YAML::Node c : n) expandMergeKeys(c, file, depth + 1);
    return;
  }
  if (!n.IsMap()) return;
  YAML::Node merge;
  bool has_merge = false;
  for (auto it = n.begin(); it != n.end(); ++it)
    if (it->first.IsScalar() && it->first.Tag() == "?" && it->first.Scalar() == "<<") {
      merge = it->second;
      has_merge = true;
    }
  if (has_merge) {
    const char* expected = "'<<' (merge key): expected a mapping, such as an alias *name, or a list of them";
    std::vector<YAML::Node> sources;
    if (merge.IsMap()) {
      sources.push_back(merge);
    } else if (merge.IsSequence()) {
      for (YAML::Node m : merge) {
        if (!m.IsMap()) throw InputError(file, m.Mark().line + 1, m.Mark().column + 1, expected);
        sources.push_back(m);
      }
    } else {
      throw InputError(file, merge.Mark().line + 1, merge.Mark().column + 1, expected);
    }
    n.remove("<<");
    const YAML::Node& held = n;  // lookups on a const node insert nothing
    for (YAML::Node& src : sources) {
      expandMergeKeys(src, file, depth + 1);
      for (auto it = src.begin(); it != src.end(); ++it)
        if (it->first.IsScalar() && !held[it->first.Scalar()]) n.force_insert(it->first, it->second);
    }
  }
  for (auto it = n.begin(); it != n.end(); ++it) expandMergeKeys(it->second, file, depth + 1);
}

// Explicit tags ('!!str 5', '!include part.yaml', '!ENV ...') were dropped without a word: each
// value is read by its field's type, so '!!str 20' became the number 20 and a '!include' its bare
// file name. A tag is refused where it stands. yaml-cpp gives "?" to an untagged node and "!" to a
// quoted scalar.
void refuseTags(const YAML::Node& n, const std::string& file, int depth = 0) {
  if (depth > 256) return;  // aliases can make the tree deeper than the text, never wider
  const std::string& tag = n.Tag();
  if (!tag.empty() && tag != "?" && tag != "!") {
    const std::string core = "tag:yaml.org,2002:";
    const std::string shown = tag.rfind(core, 0) == 0 ? "!!" + tag.substr(core.size()) : tag;
    throw InputError(file, n.Mark().line + 1, n.Mark().column + 1,
                     "YAML tag '" + shown + "' is not supported: each value is read as its field's type, "
                     "so write it without the tag (an include or environment tag has no meaning here)");
  }
  if (n.IsSequence())
    for (const YAML::Node& c : n) refuseTags(c, file, depth + 1);
  else if (n.IsMap())
    for (auto it = n.begin(); it != n.end(); ++it) {
      refuseTags(it->first, file, depth + 1);
      refuseTags(it->second, file, depth + 1);
    }
}

// yaml-cpp 0.7 (Debian's) loops for ever where a document should begin with a token that no
// node can begin with, a stray ',' above all: its parser gives an empty document without taking
// the token, LoadAll asks for the next document, which begins at the same token, and so on, a new
// node each time, until the machine's memory runs out (a fuzzed config took 24 GB before the
// kernel killed it; upstream jbeder/yaml-cpp#1040, fixed after 0.8 by #1319). So the documents
// are first walked with the event parser, which stops at a document that begins where the one
// before it began.
struct DocumentStarts : YAML::EventHandler {
  YAML::Mark start;
  void OnDocumentStart(const YAML::Mark& mark) override { start = mark; }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
  void OnAlias(const YAML::Mark&, YAML::anchor_t) override {}
  void OnScalar(const YAML::Mark&, const std::string&, YAML::anchor_t, const std::string&) override {}
  void OnSequenceStart(const YAML::Mark&, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {}
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark&, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {}
  void OnMapEnd() override {}
};

void refuseStuckDocuments(const std::string& text, const std::string& file) {
  std::istringstream in(text);
  YAML::Parser parser(in);
  DocumentStarts starts;
  int before = -1;
  while (parser.HandleNextDocument(starts)) {
    const YAML::Mark& m = starts.start;
    if (m.pos == before) {
      const char c = m.pos >= 0 && size_t(m.pos) < text.size() ? text[size_t(m.pos)] : '?';
      throw InputError(file, m.line + 1, m.column + 1,
                       std::string("malformed YAML: a value cannot begin with '") + c +
                           "' (a ',' separates the items of a [...] or {...} list)");
    }
    before = m.pos;
  }
}

}  // namespace

Config parseConfig(const std::string& text, const std::string& file, std::vector<InputError>* all_errors) {
  Parser p(file, all_errors);
  YAML::Node doc;
  try {
    // All the documents: YAML::Load would read the first and drop the rest without a word (a
    // second config appended after `---`). An empty one (a '---' at the end) is let pass.
    refuseStuckDocuments(text, file);
    std::vector<YAML::Node> docs = YAML::LoadAll(text);
    for (size_t k = 1; k < docs.size(); ++k)
      if (!docs[k].IsNull())
        throw InputError(file, docs[k].Mark().line + 1, docs[k].Mark().column + 1,
                       "a second YAML document begins here; a config is one document (remove the '---' "
                       "and what follows, or make it a config file of its own)");
    if (!docs.empty()) doc = docs.front();
  } catch (const YAML::ParserException& e) {
    throw InputError(file, e.mark.line + 1, e.mark.column + 1, "malformed YAML: " + e.msg);
  }
  if (!doc.IsMap()) throw InputError(file, 1, 1, "expected a YAML mapping at the top level (part, camera, lights, ...)");
  refuseTags(doc, file);
  refuseDuplicateKeys(doc, file);
  expandMergeKeys(doc, file);
  Config c;
  c.file = file;
  c.text = text;
  c.root = p.parse(doc, configSchema(), "");
  if (all_errors && !all_errors->empty()) return c;  // cross-field rules need every field
  crossChecks(c.root, p);
  // glTF 2.0 defines its unit as the metre, so its default scale to mm is 1000.
  Value& part = c.root.members.at("part");
  if (part["type"].str() == "mesh" && part["unit_scale_to_mm"].defaulted) {
    const std::string ext = lowerExtension(part["path"].str());
    if (ext == ".gltf" || ext == ".glb") part.members.at("unit_scale_to_mm").dist.constant = 1000.0;
  }
  return c;
}

namespace {

void requireConfigFile(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_regular_file(path, ec)) return;
  if (std::filesystem::is_directory(path, ec)) throw InputError(path, "is a folder, expected a YAML config file");
  if (std::filesystem::exists(path, ec)) throw InputError(path, "is not a regular file, expected a YAML config file");
  throw InputError(path, "config file not found");
}

}  // namespace

Config loadConfig(const std::string& path) {
  requireConfigFile(path);
  return parseConfig(readTextFile(path), path);
}

Config loadConfigAllErrors(const std::string& path, std::vector<InputError>& errors) {
  requireConfigFile(path);
  Config c = parseConfig(readTextFile(path), path, &errors);
  return c;
}

// ---------------------------------------------------------------------------------------------
// Sampling
// ---------------------------------------------------------------------------------------------

json sampleValue(const Value& v, Rng& rng, json& record) {
  const Dist& d = v.dist;
  json out;
  bool integer = v.field && (v.field->type == FieldType::Integer ||
                             (v.field->type == FieldType::Vector && v.field->element_type == FieldType::Integer));
  switch (d.kind) {
    case Dist::Kind::Const:
      return d.constant;
    case Dist::Kind::Uniform: {
      double u = rng.uniformD();
      if (integer) {
        double x = std::floor(d.a + u * (d.b - d.a + 1));
        out = int64_t(std::min(x, d.b));
      } else {
        out = d.a + u * (d.b - d.a);
      }
      break;
    }
    case Dist::Kind::LogUniform: {
      double x = std::exp(std::log(d.a) + rng.uniformD() * (std::log(d.b) - std::log(d.a)));
      out = integer ? json(int64_t(std::llround(x))) : json(x);
      break;
    }
    case Dist::Kind::Normal: {
      // Box-Muller with two draws from the counter-based stream.
      double u1 = std::max(rng.uniformD(), 1e-300), u2 = rng.uniformD();
      double z = std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
      double x = std::clamp(d.a + d.b * z, d.lo, d.hi);
      out = integer ? json(int64_t(std::llround(x))) : json(x);
      break;
    }
    case Dist::Kind::Choice: {
      double total = 0;
      for (double w : d.weights) total += w;
      double u = rng.uniformD() * total;
      size_t i = 0;
      for (; i + 1 < d.choices.size(); ++i) {
        if (u < d.weights[i]) break;
        u -= d.weights[i];
      }
      out = d.choices[i];
      if (integer && out.is_number()) out = int64_t(out.get<double>());
      break;
    }
  }
  record[v.path] = out;
  return out;
}

double sampleNumber(const Value& v, Rng& rng, json& record) { return sampleValue(v, rng, record).get<double>(); }

// ---------------------------------------------------------------------------------------------
// Descriptions
// ---------------------------------------------------------------------------------------------

namespace {

std::string distText(const Value& v) {
  const Dist& d = v.dist;
  auto n = [](double x) { return fmt(x); };
  switch (d.kind) {
    case Dist::Kind::Const:
      return d.constant.is_string() ? d.constant.get<std::string>() : d.constant.dump();
    case Dist::Kind::Uniform:
      return "{uniform: [" + n(d.a) + ", " + n(d.b) + "]}";
    case Dist::Kind::LogUniform:
      return "{loguniform: [" + n(d.a) + ", " + n(d.b) + "]}";
    case Dist::Kind::Normal:
      return "{normal: {mean: " + n(d.a) + ", std: " + n(d.b) + ", min: " + n(d.lo) + ", max: " + n(d.hi) + "}}";
    case Dist::Kind::Choice: {
      std::string s = "{choice: [";
      for (size_t i = 0; i < d.choices.size(); ++i)
        s += (i ? ", " : "") + (d.choices[i].is_string() ? d.choices[i].get<std::string>() : d.choices[i].dump());
      s += "], weights: [";
      for (size_t i = 0; i < d.weights.size(); ++i) s += (i ? ", " : "") + n(d.weights[i]);
      return s + "]}";
    }
  }
  return "";
}

void describe(const Value& v, int indent, std::ostringstream& o) {
  std::string pad(size_t(indent) * 2, ' ');
  for (const std::string& k : v.member_order) {
    const Value& m = v.members.at(k);
    const Field* f = m.field;
    if (f && f->type == FieldType::Object) {
      o << pad << k << ":" << (m.defaulted ? "  # default" : "") << "\n";
      describe(m, indent + 1, o);
      continue;
    }
    if (f && f->type == FieldType::List) {
      o << pad << k << ":" << (m.items.empty() ? " []" : "") << (m.defaulted ? "  # default" : "") << "\n";
      for (const Value& it : m.items) {
        o << pad << "  -\n";
        describe(it, indent + 2, o);
      }
      continue;
    }
    std::string val;
    if (f && f->type == FieldType::Vector) {
      val = "[";
      for (size_t i = 0; i < m.items.size(); ++i) val += (i ? ", " : "") + distText(m.items[i]);
      val += "]";
    } else {
      val = distText(m);
    }
    std::string line = pad + k + ": " + val;
    std::string note;
    if (f && !f->unit.empty()) note += f->unit;
    if (m.defaulted) note += std::string(note.empty() ? "" : ", ") + "default";
    if (!note.empty()) line += std::string(line.size() < 48 ? 48 - line.size() : 1, ' ') + "# " + note;
    o << line << "\n";
  }
}

std::string rangeText(const Field& f) {
  if (f.type == FieldType::Enum) return joinList(f.enum_values);
  if (f.type == FieldType::Bool) return "true, false";
  if (!f.min && !f.max) return "";
  return std::string(f.min_exclusive ? "(" : "[") + fmt(*f.min) + ", " + fmt(*f.max) + "]";
}

std::string typeText(const Field& f) {
  switch (f.type) {
    case FieldType::Number: return "number";
    case FieldType::Integer: return "integer";
    case FieldType::Bool: return "bool";
    case FieldType::String: return "string";
    case FieldType::Enum: return "name";
    case FieldType::Path: return "file path";
    case FieldType::Vector:
      return "list of " + std::string(f.vector_size < 0 ? "at least " : "") + std::to_string(std::abs(f.vector_size)) +
             (f.element_type == FieldType::Integer ? " integers" : " numbers");
    case FieldType::Object: return "mapping";
    case FieldType::List: return "list";
  }
  return "";
}

void fieldTable(const std::vector<Field>& fields, const std::string& prefix, std::ostringstream& o) {
  o << "| key | type | unit | default | range | random | meaning |\n|---|---|---|---|---|---|---|\n";
  for (const Field& f : fields) {
    if (f.type == FieldType::Object || f.type == FieldType::List) continue;
    std::string def = f.default_value.is_null() ? (f.required ? "required" : "—") : f.default_value.dump();
    if (f.default_value.is_string()) def = f.default_value.get<std::string>();
    o << "| `" << prefix << f.key << "` | " << typeText(f) << " | " << (f.unit.empty() ? "" : f.unit) << " | "
      << def << " | " << rangeText(f) << " | " << (f.random_ok ? "yes" : "no") << " | " << f.doc << " |\n";
  }
  o << "\n";
}

void sectionDoc(const Field& f, std::ostringstream& o) {
  o << "## `" << f.key << "`" << (f.type == FieldType::List ? " (list)" : "") << "\n\n" << f.doc << "\n\n";
  if (f.required) o << "Required.\n\n";
  if (!f.fields.empty()) fieldTable(f.fields, "", o);
  for (auto& kv : f.variants) {
    o << "### `" << f.key << "` of `type: " << kv.first << "`\n\n";
    auto d = f.variant_docs.find(kv.first);
    if (d != f.variant_docs.end()) o << d->second << "\n\n";
    fieldTable(kv.second, "", o);
  }
}

}  // namespace

std::string describeConfig(const Config& c) {
  std::ostringstream o;
  o << "# resolved config of " << c.file << " (hash " << c.hash() << ")\n";
  describe(c.root, 0, o);
  return o.str();
}

namespace {
// FNV-1a 64 over the resolved description (not the raw bytes, so comments and key order do not
// matter but every value, including defaults, does).
std::string hashOf(const Value& root) {
  std::ostringstream o;
  describe(root, 0, o);
  std::string s = o.str();
  uint64_t h = 0xcbf29ce484222325ull;
  for (unsigned char ch : s) {
    h ^= ch;
    h *= 0x100000001b3ull;
  }
  std::ostringstream hx;
  hx << std::hex << std::setw(16) << std::setfill('0') << h;
  return hx.str();
}
}  // namespace

std::string Config::hash() const { return hashOf(root); }

std::string Config::sceneHash() const {
  Value r = root;
  r.members.erase("count");
  r.member_order.erase(std::remove(r.member_order.begin(), r.member_order.end(), "count"), r.member_order.end());
  return hashOf(r);
}

std::string configReferenceMarkdown() {
  std::ostringstream o;
  o << "# Config reference\n\n"
       "<!-- Generated by `defectgen config-reference`; tests/generator checks it is up to date. -->\n\n"
       "A config is a YAML file. Units are part of the key names (`_mm`, `_deg`); angles are degrees, "
       "lengths millimetres, colours linear Rec.709 RGB. `defectgen validate CONFIG` prints the "
       "resolved config with every default and unit. An unknown key, a value out of its range and a key "
       "given twice in one mapping are refused with their line and column, as is a second YAML "
       "document after `---` (a config is one) and a YAML tag such as `!!str` or `!include` (each "
       "value is read as its field's type). Settings shared by "
       "several lights or defects can be written once with an anchor and merged with YAML's merge "
       "key: after `- &dent {type: dent, radius_mm: 20}`, an entry `- <<: *dent` followed by "
       "`depth_mm: 2` is that dent with its own depth (the entry's own keys win; `<<: [*a, *b]` "
       "merges several, the first winning); an error in a merged value points at the anchor's "
       "text.\n\n"
       "Any field marked *random: yes* may be a distribution instead of a constant, sampled anew for "
       "every image; each sampled value is recorded in `samples/NNNNNN.json` under its config path:\n\n"
       "| form | meaning |\n|---|---|\n"
       "| `{uniform: [a, b]}` | uniform in [a, b] (integers: each of a..b equally likely) |\n"
       "| `{loguniform: [a, b]}` | log-uniform in [a, b], a > 0 |\n"
       "| `{normal: {mean: m, std: s, min: lo, max: hi}}` | normal, clamped to [lo, hi] (default: the field's range) |\n"
       "| `{choice: [x, y, z], weights: [1, 2, 1]}` | one of the values, with the given weights (default equal) |\n\n"
       "Elements of a list of numbers (positions, colours) may each be a distribution.\n\n"
       "Errors name the file, line and column, and what was expected; unknown keys get the closest "
       "valid key as a suggestion.\n\n";
  const Field& r = configSchema();
  o << "## Top level\n\n";
  fieldTable(r.fields, "", o);
  for (const Field& f : r.fields)
    if (f.type == FieldType::Object || f.type == FieldType::List) sectionDoc(f, o);
  o << "## Metals\n\nComplex index of refraction n + ik at the R, G, B channels, used with the exact "
       "conductor Fresnel equations.\n\n| name | n (R, G, B) | k (R, G, B) | source |\n|---|---|---|---|\n";
  auto f5 = [](float v) {
    std::ostringstream s;
    s << std::setprecision(5) << v;
    return s.str();
  };
  for (const MetalIor& m : metalTable())
    o << "| `" << m.name << "` | " << f5(m.eta.x) << ", " << f5(m.eta.y) << ", " << f5(m.eta.z) << " | "
      << f5(m.k.x) << ", " << f5(m.k.y) << ", " << f5(m.k.z) << " | " << m.source << " |\n";
  return o.str();
}

}  // namespace dg
