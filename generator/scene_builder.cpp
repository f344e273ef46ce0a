#include "generator/scene_builder.h"

#include <cmath>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "core/error.h"
#include "core/memory.h"
#include "defects/dent.h"
#include "defects/scratch.h"
#include "defects/weathering.h"
#include "render/displacement.h"
#include "render/scratch_geometry.h"
#include "render/mesh_io.h"
#include "render/parts.h"

namespace dg {

using nlohmann::json;

namespace {

TriangleMesh buildPart(const Config& c) {
  const Value& p = c.root["part"];
  std::string type = p["type"].str();
  auto n = [&](const char* k) { return p[k].num(); };
  try {
    if (type == "plate") return makePlate({n("width_mm"), n("height_mm")}, n("tessellation_mm"));
    if (type == "door_panel") {
      DoorPanelParams d;
      d.width_mm = n("width_mm");
      d.height_mm = n("height_mm");
      d.curvature_radius_mm = n("curvature_radius_mm");
      d.character_line_height = n("character_line_height");
      d.character_line_depth_mm = n("character_line_depth_mm");
      d.character_line_width_mm = n("character_line_width_mm");
      return makeDoorPanel(d, n("tessellation_mm"));
    }
    if (type == "hood") return makeHood({n("width_mm"), n("length_mm"), n("crown_mm")}, n("tessellation_mm"));
    if (type == "fender") {
      FenderParams f;
      f.length_mm = n("length_mm");
      f.height_mm = n("height_mm");
      f.arch_radius_mm = n("arch_radius_mm");
      f.curvature_radius_mm = n("curvature_radius_mm");
      return makeFender(f, n("tessellation_mm"));
    }
  } catch (const std::invalid_argument& e) {
    throw InputError(c.file, p.line, p.column, "'part': " + std::string(e.what()));
  }
  MeshLoadOptions o;
  o.unit_scale_to_mm = n("unit_scale_to_mm");
  return loadMesh(p["path"].str(), o);
}

// A glass part made from an open surface is closed into a solid (solidShell); every other part
// is rendered as the two-sided sheet it is.
TriangleMesh partShell(const Config& c, const TriangleMesh& front) {
  const Value& mv = c.root["material"];
  if (mv["type"].str() != "glass") return {};
  try {
    return solidShell(front, float(mv["thickness_mm"].num()));
  } catch (const std::invalid_argument& e) {
    throw InputError(c.file, mv["thickness_mm"].line, mv["thickness_mm"].column,
                     "'material.thickness_mm': cannot make the glass part a solid: " + std::string(e.what()));
  }
}

Vec3d sampleVec3(const Value& v, Rng& rng, json& rec) {
  return {sampleNumber(v.items[0], rng, rec), sampleNumber(v.items[1], rng, rec), sampleNumber(v.items[2], rng, rec)};
}
Rgb sampleRgb(const Value& v, Rng& rng, json& rec) { return Rgb(sampleVec3(v, rng, rec)); }

json toJson(Vec3f v) { return {v.x, v.y, v.z}; }
json toJson(Vec3d v) { return {v.x, v.y, v.z}; }

// An orthonormal pair spanning the plane with normal n (for placing area lights): u is world +x
// projected into the plane (world +y when the plane faces along x), v = n x u.
void planeAxes(Vec3f n, Vec3f& u, Vec3f& v) {
  Vec3f x(1, 0, 0);
  u = x - n * dot(n, x);
  if (length(u) < 1e-3f) u = Vec3f(0, 1, 0) - n * n.y;
  u = normalize(u);
  v = cross(n, u);
}

}  // namespace

Dataset prepareDataset(Config config) {
  Dataset ds;
  TriangleMesh front = buildPart(config);
  TriangleMesh shell = partShell(config, front);
  auto part = std::make_shared<PartGeometry>(std::move(front), std::move(shell));
  // Occlusion is computed once, and only when a patina group is drawn to cavities.
  bool cavities = false;
  for (const Value& d : config.root["defects"].items)
    if (d["type"].str() == "patina") {
      const Value& w = d["cavity_weight"];
      cavities |= !w.isConstant() || w.num() > 0;
    }
  if (cavities) part->computeOcclusion();
  ds.part = part;
  const Value& lights = config.root["lights"];
  ds.env_maps.resize(lights.items.size());
  for (size_t i = 0; i < lights.items.size(); ++i) {
    const Value& l = lights.items[i];
    // A map with constant scale and rotation is loaded once; a random one is loaded per sample.
    if (l["type"].str() == "environment" && l.has("map") && l["scale"].isConstant() &&
        l["rotation_deg"].isConstant())
      ds.env_maps[i] = std::make_shared<EnvironmentMap>(
          EnvironmentMap::load(l["map"].str(), float(l["scale"].num()), float(l["rotation_deg"].num())));
  }
  const Value& cam = config.root["camera"];
  if (cam.has("calibration")) {
    ds.has_calibration = true;
    ds.calibration = loadCalibration(cam["calibration"].str());
  }
  ds.config = std::move(config);
  return ds;
}

namespace {

// makeSample, or with check_only its check: the same draws and errors, but a mesh of its own (for
// displaced dents or the scratch reference) is made without its BVH, the scratch reference is only
// counted, and the defect index is left out.
Sample buildSample(const Dataset& ds, uint64_t seed, uint64_t index, bool check_only) {
  const Config& c = ds.config;
  const Value& root = c.root;
  Sample s;
  s.index = index;
  Rng rng(seed, Stream::Scene, index);
  json rec = json::object();
  json meta;
  meta["index"] = index;
  meta["seed"] = seed;

  // Render settings.
  const Value& r = root["render"];
  int W = int(r["resolution"].items[0].num()), H = int(r["resolution"].items[1].num());
  s.settings.spp = int(r["spp"].num());
  s.settings.max_bounces = int(r["max_bounces"].num());
  const uint64_t noise_seed = uint64_t(r["noise_seed"].num());
  s.settings.seed = noise_seed == 0 ? seed : hashKey(seed, 0x6e6f697365ull, noise_seed);
  s.settings.sample_index = index;
  setFrameOutputs(r, s.settings);
  s.settings.coverage_grid = int(r["mask_subsamples"].num());

  // Camera.
  const Value& cv = root["camera"];
  CameraIntrinsics K;
  if (cv.has("fov_deg")) {
    K = intrinsicsFromFov(W, H, sampleNumber(cv["fov_deg"], rng, rec));
  } else if (cv.has("intrinsics")) {
    K.width = W;
    K.height = H;
    K.fx = sampleNumber(cv["intrinsics"].items[0], rng, rec);
    K.fy = sampleNumber(cv["intrinsics"].items[1], rng, rec);
    K.cx = sampleNumber(cv["intrinsics"].items[2], rng, rec);
    K.cy = sampleNumber(cv["intrinsics"].items[3], rng, rec);
    if (!(K.fx > 0 && K.fy > 0))
      throw InputError(c.file, cv["intrinsics"].line, cv["intrinsics"].column,
                       "'camera.intrinsics': fx and fy must be > 0");
  } else {
    K = scaleIntrinsics(ds.calibration, W, H);
  }
  if (!cv.has("calibration")) {
    double dist[5];
    for (int i = 0; i < 5; ++i) dist[i] = sampleNumber(cv["distortion"].items[i], rng, rec);
    K.k1 = dist[0];
    K.k2 = dist[1];
    K.p1 = dist[2];
    K.p2 = dist[3];
    K.k3 = dist[4];
  }
  Vec3d eye = sampleVec3(cv["position"], rng, rec), target = sampleVec3(cv["target"], rng, rec),
        up = sampleVec3(cv["up"], rng, rec);
  try {
    s.scene.camera = cameraLookAt(K, eye, target, up);
  } catch (const std::invalid_argument& e) {
    throw InputError(c.file, cv.line, cv.column,
                     "'camera': cannot aim the camera (position, target and up must not be degenerate): " +
                         std::string(e.what()));
  }
  if (K.hasDistortion()) {
    try {
      RayGenerator probe(s.scene.camera);  // solves the inverse distortion over the image
    } catch (const std::invalid_argument& e) {
      throw InputError(c.file, cv.line, cv.column, "'camera': the distortion cannot be inverted over the image: " +
                                                       std::string(e.what()));
    }
  }
  const Camera& cam = s.scene.camera;
  const Pose& P = cam.world_to_camera;
  meta["camera"] = {{"width", W},
                    {"height", H},
                    {"K", {{K.fx, 0.0, K.cx}, {0.0, K.fy, K.cy}, {0.0, 0.0, 1.0}}},
                    {"distortion", {K.k1, K.k2, K.p1, K.p2, K.k3}},
                    {"R_world_to_camera", {{P.R[0], P.R[1], P.R[2]}, {P.R[3], P.R[4], P.R[5]}, {P.R[6], P.R[7], P.R[8]}}},
                    {"t_world_to_camera", toJson(P.t)},
                    {"position_mm", toJson(cam.position())},
                    {"target_mm", toJson(target)}};

  // Material.
  const Value& mv = root["material"];
  Material& m = s.scene.material;
  std::string mt = mv["type"].str();
  m.model = mv["microfacet"].str() == "beckmann" ? MicrofacetModel::Beckmann : MicrofacetModel::GGX;
  json mj = {{"type", mt}, {"microfacet", mv["microfacet"].str()}};
  if (mt == "car_paint") {
    m.kind = MaterialKind::CarPaint;
    m.base_color = sampleRgb(mv["base_color"], rng, rec);
    m.flake_amount = float(sampleNumber(mv["flake_amount"], rng, rec));
    m.flake_roughness = float(sampleNumber(mv["flake_roughness"], rng, rec));
    m.coat_roughness = float(sampleNumber(mv["clear_coat_roughness"], rng, rec));
    m.coat_ior = float(sampleNumber(mv["clear_coat_ior"], rng, rec));
    PaintVariationParams pv;
    pv.orange_peel_amplitude_um = float(sampleNumber(mv["orange_peel_um"], rng, rec));
    pv.orange_peel_wavelength_mm = float(sampleNumber(mv["orange_peel_wavelength_mm"], rng, rec));
    pv.flake_size_mm = float(sampleNumber(mv["flake_size_mm"], rng, rec));
    pv.flake_density = float(sampleNumber(mv["flake_density"], rng, rec));
    pv.flake_tilt_deg = float(sampleNumber(mv["flake_tilt_deg"], rng, rec));
    pv.sparkle_intensity = float(sampleNumber(mv["sparkle"], rng, rec));
    pv.color_variation = float(sampleNumber(mv["color_variation"], rng, rec));
    pv.seed = hashKey(seed, index, 0x9a17);
    // Nothing to vary: no per-point work at all.
    if (pv.orange_peel_amplitude_um > 0 || (pv.sparkle_intensity > 0 && pv.flake_density > 0) ||
        pv.color_variation > 0)
      s.scene.paint = std::make_shared<PaintVariation>(pv);
    mj["paint_variation"] = {{"orange_peel_um", pv.orange_peel_amplitude_um},
                             {"orange_peel_wavelength_mm", pv.orange_peel_wavelength_mm},
                             {"flake_size_mm", pv.flake_size_mm},
                             {"flake_density", pv.flake_density},
                             {"flake_tilt_deg", pv.flake_tilt_deg},
                             {"sparkle", pv.sparkle_intensity},
                             {"color_variation", pv.color_variation},
                             {"seed", pv.seed}};
    mj.update({{"base_color", toJson(m.base_color)},
               {"flake_amount", m.flake_amount},
               {"flake_roughness", m.flake_roughness},
               {"clear_coat_roughness", m.coat_roughness},
               {"clear_coat_ior", m.coat_ior}});
  } else if (mt == "metal") {
    m.kind = MaterialKind::Conductor;
    std::string name = sampleValue(mv["metal"], rng, rec).get<std::string>();
    const MetalIor* ior = findMetal(name);
    if (!ior) throw std::logic_error("metal table lacks " + name);
    m.eta = ior->eta;
    m.k = ior->k;
    m.roughness = float(sampleNumber(mv["roughness"], rng, rec));
    mj.update({{"metal", name}, {"eta", toJson(m.eta)}, {"k", toJson(m.k)}, {"roughness", m.roughness},
               {"ior_source", ior->source}});
  } else if (mt == "glass") {
    m.kind = MaterialKind::Glass;
    m.roughness = float(sampleNumber(mv["roughness"], rng, rec));
    m.ior = float(sampleNumber(mv["ior"], rng, rec));
    mj.update({{"roughness", m.roughness}, {"ior", m.ior}, {"thickness_mm", mv["thickness_mm"].num()},
               {"solid", ds.part->shell().triangleCount() > 0 ? "made from the open surface" : "the closed mesh"}});
  } else {
    m.kind = MaterialKind::Plastic;
    m.base_color = sampleRgb(mv["base_color"], rng, rec);
    m.roughness = float(sampleNumber(mv["roughness"], rng, rec));
    m.ior = float(sampleNumber(mv["ior"], rng, rec));
    mj.update({{"base_color", toJson(m.base_color)}, {"roughness", m.roughness}, {"ior", m.ior}});
  }
  meta["material"] = mj;

  // Lights.
  json lj = json::array();
  const Value& lights = root["lights"];
  Vec3f cam_pos(cam.position()), cam_fwd(cam.forward());
  for (size_t i = 0; i < lights.items.size(); ++i) {
    const Value& l = lights.items[i];
    std::string type = l["type"].str();
    json one = {{"type", type}};
    if (type == "environment" || type == "dome") {
      Rgb rad = sampleRgb(l["radiance"], rng, rec);
      if (type == "environment" && l.has("map")) {
        float scale = float(sampleNumber(l["scale"], rng, rec));
        float rot = float(sampleNumber(l["rotation_deg"], rng, rec));
        s.scene.lights.env = ds.env_maps[i] ? ds.env_maps[i]
                                            : std::make_shared<EnvironmentMap>(
                                                  EnvironmentMap::load(l["map"].str(), scale, rot));
        one.update({{"map", l["map"].str()}, {"scale", scale}, {"rotation_deg", rot}});
      } else {
        s.scene.lights.env = std::make_shared<EnvironmentMap>(EnvironmentMap::constant(rad));
        one["radiance"] = toJson(rad);
      }
      lj.push_back(one);
      continue;
    }
    AreaLight al;
    al.name = type;
    if (type == "rect" || type == "disk") {
      Vec3f pos(sampleVec3(l["position"], rng, rec)), tgt(sampleVec3(l["target"], rng, rec));
      if (!(length(tgt - pos) > 0))
        throw InputError(c.file, l.line, l.column, "'" + l.path + "': position and target must differ");
      al.center = pos;
      al.normal = normalize(tgt - pos);
      planeAxes(al.normal, al.axis_u, al.axis_v);
      if (type == "rect") {
        al.shape = AreaLight::Shape::Rect;
        al.half_u = float(sampleNumber(l["size_mm"].items[0], rng, rec)) * 0.5f;
        al.half_v = float(sampleNumber(l["size_mm"].items[1], rng, rec)) * 0.5f;
      } else {
        al.shape = AreaLight::Shape::Disk;
        al.radius = float(sampleNumber(l["radius_mm"], rng, rec));
      }
    } else if (type == "ring" || type == "coaxial") {
      al.shape = AreaLight::Shape::Disk;
      al.center = cam_pos;
      al.normal = cam_fwd;
      planeAxes(al.normal, al.axis_u, al.axis_v);
      al.radius = float(sampleNumber(l["radius_mm"], rng, rec));
      if (type == "ring") {
        al.inner_radius = float(sampleNumber(l["inner_radius_mm"], rng, rec));
        if (!(al.inner_radius < al.radius))
          throw InputError(c.file, l.line, l.column, "'" + l.path + "': sampled inner_radius_mm >= radius_mm");
      }
      al.visible_to_camera = false;  // it sits in the lens plane, behind the entrance pupil
    } else if (type == "bar") {
      float len = float(sampleNumber(l["length_mm"], rng, rec)), wid = float(sampleNumber(l["width_mm"], rng, rec));
      float dist = float(sampleNumber(l["distance_mm"], rng, rec));
      float el = degToRad(float(sampleNumber(l["elevation_deg"], rng, rec)));
      float az = degToRad(float(sampleNumber(l["azimuth_deg"], rng, rec)));
      Vec3f tgt(sampleVec3(l["target"], rng, rec));
      Vec3f dir(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
      al.shape = AreaLight::Shape::Rect;
      al.center = tgt + dir * dist;
      al.normal = -dir;
      al.axis_u = Vec3f(-std::sin(az), std::cos(az), 0.0f);  // the bar runs horizontally
      al.axis_v = cross(al.normal, al.axis_u);
      al.half_u = len * 0.5f;
      al.half_v = wid * 0.5f;
    }
    al.radiance = sampleRgb(l["radiance"], rng, rec);
    one.update({{"center_mm", toJson(al.center)},
                {"normal", toJson(al.normal)},
                {"shape", al.shape == AreaLight::Shape::Rect ? "rect" : "disk"},
                {"radiance", toJson(al.radiance)}});
    if (al.shape == AreaLight::Shape::Rect)
      one["size_mm"] = {2 * al.half_u, 2 * al.half_v};
    else
      one.update({{"radius_mm", al.radius}, {"inner_radius_mm", al.inner_radius}});
    s.scene.lights.area.push_back(al);
    lj.push_back(one);
  }
  meta["lights"] = lj;

  // Defects, placed at sampled positions in the part's UV chart.
  s.defects = std::make_unique<DefectList>();
  Box2 uvb = ds.part->uvBounds();
  json dj = json::array();
  const Value& groups = root["defects"];
  float displace_edge = 1e30f;
  // Registers a placed defect: its instance id, its COCO attributes (physical parameters, the
  // group, and `extra`) and its entry in the sample's metadata.
  auto addInstance = [&](std::unique_ptr<Defect> defect, size_t g, const json& extra) {
    // Instance ids are 16-bit (the instance mask); 0 means none.
    if (s.defects->size() >= 65535)
      throw InputError(c.file, groups.line, groups.column, "more than 65535 defects in one sample");
    uint16_t id = uint16_t(s.defects->size() + 1);
    defect->setInstanceId(id);
    InstanceInfo info;
    info.id = id;
    info.cls = defect->cls();
    info.attributes = defect->attributes();
    info.attributes["group"] = g;
    info.attributes.update(extra);
    s.instances.push_back(info);
    dj.push_back({{"instance_id", id}, {"class", defect->kind()}, {"group", g}, {"attributes", info.attributes}});
    s.defects->push_back(std::move(defect));
  };
  const std::string scratch_mode = r["scratches"].str();
  struct RustAtScratch {
    size_t group;
    int index;
    RustParams rp;
  };
  std::vector<RustAtScratch> rust_at_scratch;
  for (size_t g = 0; g < groups.items.size(); ++g) {
    const Value& d = groups.items[g];
    int count = int(sampleNumber(d["count"], rng, rec));
    std::string type = d["type"].str();
    for (int k = 0; k < count; ++k) {
      json local = json::object();
      const Value& reg = d["region"];
      double u0 = reg.items[0].num(), v0 = reg.items[1].num(), u1 = reg.items[2].num(), v1 = reg.items[3].num();
      // The region in the chart's mm.
      Box2 rbox;
      rbox.lo = {float(uvb.lo.x + u0 * (uvb.hi.x - uvb.lo.x)), float(uvb.lo.y + v0 * (uvb.hi.y - uvb.lo.y))};
      rbox.hi = {float(uvb.lo.x + u1 * (uvb.hi.x - uvb.lo.x)), float(uvb.lo.y + v1 * (uvb.hi.y - uvb.lo.y))};
      // Centres are drawn uniformly by area on the part's surface, kept if they fall in the
      // region (fractions of the UV extent), so a defect never lands off the part.
      Vec2f center;
      bool placed = false;
      if (d.has("center")) {
        double fu = sampleNumber(d["center"].items[0], rng, local), fv = sampleNumber(d["center"].items[1], rng, local);
        center = {float(uvb.lo.x + fu * (uvb.hi.x - uvb.lo.x)), float(uvb.lo.y + fv * (uvb.hi.y - uvb.lo.y))};
        placed = true;
      }
      for (int attempt = 0; attempt < 10000 && !placed; ++attempt) {
        double a = rng.uniformD(), b = rng.uniformD(), e = rng.uniformD();
        Vec2f uv = ds.part->sampleSurfaceUv(a, b, e);
        double fu = (uv.x - uvb.lo.x) / std::max(1e-9f, uvb.hi.x - uvb.lo.x);
        double fv = (uv.y - uvb.lo.y) / std::max(1e-9f, uvb.hi.y - uvb.lo.y);
        if (fu >= u0 && fu <= u1 && fv >= v0 && fv <= v1) {
          center = uv;
          placed = true;
        }
      }
      // A region that is a small share of a large part can miss all of those draws (the crossing
      // scratches' 3.2 x 0.8 mm bands on a 100 mm door: 2.6 expected hits in 10,000): then draw from
      // the surface under the region, each triangle clipped to it, which finds a region of any size
      // in one draw. (Only then, so that placements that were found stay the same.)
      if (!placed) placed = ds.part->sampleSurfaceUvIn(rbox, rng, center);
      if (!placed)
        throw InputError(c.file, reg.line, reg.column,
                         "'" + reg.path + "': no part surface found in this region of the UV chart");
      uint64_t instance_seed = hashKey(seed, index, g, uint64_t(k));
      std::unique_ptr<Defect> defect;
      if (type == "hail") {
        // A cluster of small dents, uniform in a disc around the centre; each is an instance.
        int n = int(sampleNumber(d["dents_per_cluster"], rng, local));
        float cr = float(sampleNumber(d["cluster_radius_mm"], rng, local));
        for (int j = 0; j < n; ++j) {
          DentParams dp;
          float rr = cr * std::sqrt(float(rng.uniformD())), ph = float(2 * kPi * rng.uniformD());
          dp.center_uv = center + Vec2f(rr * std::cos(ph), rr * std::sin(ph));
          dp.end_uv = dp.center_uv;
          json one = json::object();
          dp.radius_mm = float(sampleNumber(d["radius_mm"], rng, one));
          dp.depth_mm = float(sampleNumber(d["depth_mm"], rng, one));
          dp.mask_threshold = float(d["mask_threshold"].num());
          for (auto& kv : one.items()) local[kv.key() + "#" + std::to_string(j)] = kv.value();
          auto dent = std::make_unique<Dent>(dp);
          std::string mode = d["displacement"].str();
          dent->setDisplaced(mode == "geometry" || (mode == "auto" && dent->needsGeometry(uvb)));
          if (dent->wantsDisplacement()) displace_edge = std::min(displace_edge, float(d["displacement_edge_mm"].num()));
          addInstance(std::move(dent), g, {{"cluster", k}});
        }
      } else if (type == "scratch") {
        // Scratches: paths in the UV chart (mm), cross-sections from the process (Bosch 2007 §3.2)
        // or an explicit profile; each path is an instance of class scratch.
        std::string pattern = d["pattern"].str();
        std::vector<ScratchPath> paths;
        try {
          if (pattern == "swirl") {
            if (k > 0) continue;  // the whole swirl set is made at k == 0
            SwirlOptions so;
            so.count = count;
            so.fixed_centre = true;
            so.centre = Vec2d(center.x, center.y);
            so.radius0_mm = {0.15 * (rbox.hi.x - rbox.lo.x), 0.4 * (rbox.hi.x - rbox.lo.x)};
            SwirlSet set = randomWashSwirls(rng, rbox, so);
            paths = std::move(set.arcs);
            local["swirl_centre_mm"] = {set.centre.x, set.centre.y};
          } else if (pattern == "key") {
            KeyScratchOptions ko;
            paths.push_back(randomKeyScratch(rng, rbox, ko));
          } else if (pattern == "path") {
            // The given points, turned by orientation_deg (if any) about the centre and moved to it.
            const Value& pm = d["path_mm"];
            const double turn = d.has("orientation_deg") ? degToRad(sampleNumber(d["orientation_deg"], rng, local)) : 0.0;
            const double cs = std::cos(turn), sn = std::sin(turn);
            std::vector<Vec2d> pts;
            for (size_t i = 0; i + 1 < pm.items.size(); i += 2) {
              const double u = pm.items[i].num(), v = pm.items[i + 1].num();
              pts.push_back({center.x + cs * u - sn * v, center.y + sn * u + cs * v});
            }
            paths.push_back(d["curve"].str() == "bezier" ? ScratchPath::bezier(pts) : ScratchPath::polyline(pts));
          } else {
            double len = sampleNumber(d["length_mm"], rng, local);
            double ori = d.has("orientation_deg") ? degToRad(sampleNumber(d["orientation_deg"], rng, local))
                                                  : kPi * rng.uniformD();
            double curv = sampleNumber(d["curvature_per_mm"], rng, local) * (rng.uniformD() < 0.5 ? -1 : 1);
            paths.push_back(arcScratch(Vec2d(center.x, center.y), len, ori, curv));
          }
        } catch (const std::invalid_argument& e) {
          throw InputError(c.file, d.line, d.column, "'" + d.path + "': cannot place the scratch: " + e.what());
        }
        LayerStack stack;
        if (s.scene.material.kind == MaterialKind::CarPaint) {
          stack.layers = {{"clear_coat", d["coating_mm"].items[0].num()},
                          {"base_coat", d["coating_mm"].items[1].num()},
                          {"primer", d["coating_mm"].items[2].num()},
                          {"steel", 0.0}};
        } else {
          stack.layers = {{"surface", 0.0}};
        }
        for (size_t j = 0; j < paths.size(); ++j) {
          json one = json::object();
          ScratchProcess proc;
          proc.force_kg = sampleNumber(d["force_kg"], rng, one);
          proc.hardness_hv = sampleNumber(d["hardness_hv"], rng, one);
          proc.pileup = sampleNumber(d["pileup"], rng, one);
          proc.tool.shape = sampleValue(d["tool"], rng, one).get<std::string>() == "pyramid" ? ToolSpec::Shape::Pyramid
                                                                                          : ToolSpec::Shape::Cone;
          proc.tool.apex_angle_rad = degToRad(sampleNumber(d["tool_apex_deg"], rng, one));
          proc.tool.tip_radius_mm = sampleNumber(d["tool_tip_radius_mm"], rng, one);
          proc.tool.theta_rad = degToRad(sampleNumber(d["tool_tilt_deg"], rng, one));
          proc.tool.phi_rad = degToRad(sampleNumber(d["tool_tilt_azimuth_deg"], rng, one));
          ScratchPerturbation pert;
          pert.fade_length_mm = sampleNumber(d["fade_mm"], rng, one);
          pert.noise_amplitude = sampleNumber(d["perturbation"], rng, one);
          pert.noise_wavelength_mm = 3.0;
          pert.noise_seed = hashKey(instance_seed, j);
          std::unique_ptr<Scratch> sc;
          try {
            if (d.has("profile_mm")) {
              const Value& pv = d["profile_mm"];
              if (pv.items.size() % 2 != 0)
                throw InputError(c.file, pv.line, pv.column,
                                 "'" + pv.path + "': expected pairs [b, w]: an even count of numbers");
              std::vector<Vec2d> pts;
              for (size_t i = 0; i < pv.items.size(); i += 2) pts.push_back({pv.items[i].num(), pv.items[i + 1].num()});
              Profile prof;
              try {
                prof = Profile::fromPolyline(pts);
              } catch (const std::invalid_argument& e) {
                throw InputError(c.file, pv.line, pv.column, "'" + pv.path + "': " + e.what());
              }
              sc = std::make_unique<Scratch>(Scratch::fromProfile(paths[j], prof, pert, stack));
            } else {
              sc = std::make_unique<Scratch>(Scratch::fromProcess(paths[j], proc, pert, stack));
            }
          } catch (const std::invalid_argument& e) {
            throw InputError(c.file, d.line, d.column, "'" + d.path + "': invalid scratch: " + e.what());
          }
          // A glass part made from an open surface is a slab thickness_mm thick: a groove as deep
          // as that would cut it through, which no cross-section describes.
          if (s.scene.material.kind == MaterialKind::Glass && ds.part->shell().triangleCount() > 0) {
            const double deepest = sc->referenceProfile().depth() * sc->maxScale();
            const double slab = mv["thickness_mm"].num();
            if (!(deepest < slab)) {
              std::ostringstream m;
              m << std::setprecision(4) << "'" << d.path << "': a scratch " << deepest << " mm deep (force_kg "
                << proc.force_kg << ", hardness_hv " << proc.hardness_hv << ") would cut through the glass, " << slab
                << " mm thick (material.thickness_mm); expected a shallower scratch or a thicker part";
              throw InputError(c.file, d.line, d.column, m.str());
            }
          }
          sc->setBumpShading(scratch_mode == "normal_map");
          std::string suffix = paths.size() > 1 ? "#" + std::to_string(j) : "";
          for (auto& kv : one.items()) local[kv.key() + suffix] = kv.value();
          addInstance(std::move(sc), g, {{"pattern", pattern}});
        }
      } else if (type == "dent") {
        DentParams dp;
        dp.center_uv = center;
        dp.radius_mm = float(sampleNumber(d["radius_mm"], rng, local));
        dp.depth_mm = float(sampleNumber(d["depth_mm"], rng, local));
        dp.mask_threshold = float(d["mask_threshold"].num());
        float len = float(sampleNumber(d["length_mm"], rng, local));
        float ang = degToRad(float(sampleNumber(d["angle_deg"], rng, local)));
        // The crease line is centred on the sampled point.
        Vec2f half(0.5f * len * std::cos(ang), 0.5f * len * std::sin(ang));
        dp.center_uv = center - half;
        dp.end_uv = center + half;
        auto dent = std::make_unique<Dent>(dp);
        std::string mode = d["displacement"].str();
        dent->setDisplaced(mode == "geometry" || (mode == "auto" && dent->needsGeometry(uvb)));
        if (dent->wantsDisplacement()) displace_edge = std::min(displace_edge, float(d["displacement_edge_mm"].num()));
        defect = std::move(dent);
      } else if (type == "rust") {
        RustParams rp;
        std::string origin = sampleValue(d["origin"], rng, local).get<std::string>();
        if (origin == "scratch") {
          rp.origin = "scratch";  // the config check made sure the config has scratches
        } else if (origin == "edge") {
          // Move the centre to the nearest edge of the UV chart.
          float dl = center.x - uvb.lo.x, dr = uvb.hi.x - center.x, db = center.y - uvb.lo.y, dt = uvb.hi.y - center.y;
          float m = std::min(std::min(dl, dr), std::min(db, dt));
          if (m == dl) center.x = uvb.lo.x;
          else if (m == dr) center.x = uvb.hi.x;
          else if (m == db) center.y = uvb.lo.y;
          else center.y = uvb.hi.y;
          rp.origin = "edge";
        }
        rp.origin_uv = center;
        rp.radius_mm = float(sampleNumber(d["radius_mm"], rng, local));
        rp.age_years = float(sampleNumber(d["age_years"], rng, local));
        rp.growth_years = float(sampleNumber(d["growth_years"], rng, local));
        rp.roughness = float(sampleNumber(d["roughness"], rng, local));
        rp.pit_depth_mm = float(sampleNumber(d["pit_depth_mm"], rng, local));
        rp.blister_width_mm = float(sampleNumber(d["blister_width_mm"], rng, local));
        rp.blister_height_mm = float(sampleNumber(d["blister_height_mm"], rng, local));
        rp.sigma_rad = degToRad(float(sampleNumber(d["sigma_deg"], rng, local)));
        rp.fresh = sampleRgb(d["fresh_color"], rng, local);
        rp.old = sampleRgb(d["old_color"], rng, local);
        rp.seed = instance_seed;
        if (origin == "scratch") {
          // Placed once every scratch of the sample exists (below).
          rust_at_scratch.push_back({g, k, rp});
        } else {
          defect = std::make_unique<Rust>(rp);
        }
      } else {
        PatinaParams pp;
        pp.center_uv = center;
        pp.radius_mm = float(sampleNumber(d["radius_mm"], rng, local));
        pp.age_years = float(sampleNumber(d["age_years"], rng, local));
        pp.environment = float(sampleNumber(d["environment"], rng, local));
        pp.cavity_weight = float(sampleNumber(d["cavity_weight"], rng, local));
        pp.scale_mm = float(sampleNumber(d["scale_mm"], rng, local));
        pp.bump_mm = float(sampleNumber(d["bump_mm"], rng, local));
        pp.sigma_rad = degToRad(float(sampleNumber(d["sigma_deg"], rng, local)));
        pp.seed = instance_seed;
        pp.part_uv = uvb;
        defect = std::make_unique<Patina>(pp);
      }
      // Per-instance draws are recorded under defects[g][k].key (hail: key#j for dent j).
      for (auto& kv : local.items()) {
        std::string key = kv.key();
        std::string base = "defects[" + std::to_string(g) + "]";
        rec[base + "[" + std::to_string(k) + "]" + key.substr(base.size())] = kv.value();
      }
      if (!defect) continue;  // hail clusters and scratches added their instances already
      addInstance(std::move(defect), g, json::object());
    }
  }
  // Rust that starts at scratches: along a stretch where a scratch cuts through the paint and
  // bares the steel, picked at random with probability proportional to its length.
  if (!rust_at_scratch.empty()) {
    struct Run {
      const Scratch* sc;
      double s0, s1;
    };
    std::vector<Run> runs;
    double total = 0;
    for (auto& d : *s.defects)
      if (d->cls() == DefectClass::Scratch) {
        const Scratch* sc = static_cast<const Scratch*>(d.get());
        for (const auto& r : sc->exposedRuns()) {
          runs.push_back({sc, r.first, r.second});
          total += r.second - r.first;
        }
      }
    json skipped = json::array();
    for (RustAtScratch& ras : rust_at_scratch) {
      if (runs.empty() || !(total > 0)) {
        skipped.push_back({{"group", ras.group}, {"index", ras.index},
                           {"reason", "no scratch in this sample cuts through the paint to the steel"}});
        continue;
      }
      Rng pick(hashKey(ras.rp.seed, 0x7275737473ull));  // the instance seed, salted
      double x = pick.uniformD() * total;
      size_t i = 0;
      for (; i + 1 < runs.size(); ++i) {
        double len = runs[i].s1 - runs[i].s0;
        if (x < len) break;
        x -= len;
      }
      const Run& run = runs[i];
      ScratchPath bare = run.sc->path().sub(run.s0, run.s1);
      ras.rp.origin_path = bare.points();
      Vec2d mid = bare.pointAt(0.5 * bare.length());
      ras.rp.origin_uv = {float(mid.x), float(mid.y)};
      ras.rp.origin_scratch = run.sc->instanceId();
      addInstance(std::make_unique<Rust>(ras.rp), ras.group,
                  {{"origin_run_mm", {run.s0, run.s1}}});
    }
    if (!skipped.empty()) meta["rust_not_placed"] = skipped;
  }
  // Dents rendered as geometry: this sample gets its own refined and displaced copy of the part
  // (and its own BVH); every other sample keeps sharing the dataset's part.
  std::vector<const Defect*> displaced;
  for (auto& d : *s.defects)
    if (d->wantsDisplacement()) displaced.push_back(d.get());
  s.scene.part = ds.part;
  if (!displaced.empty()) {
    DisplacementOptions opt;
    opt.max_edge_mm = displace_edge;
    DisplacementStats st;
    size_t triangles = 0;
    try {
      TriangleMesh moved = displaceMesh(ds.part->mesh(), displaced, opt, &st);
      triangles = moved.triangleCount();
      if (!check_only) s.scene.part = std::make_shared<PartGeometry>(std::move(moved), ds.part->shell());
    } catch (const std::runtime_error& e) {
      throw InputError(c.file, groups.line, groups.column,
                       "'defects': cannot displace the part for sample " + std::to_string(index) + ": " + e.what() +
                           " (raise displacement_edge_mm or use displacement: bump)");
    }
    meta["displacement"] = {{"dents", displaced.size()},
                            {"max_edge_mm", displace_edge},
                            {"triangles_split", st.triangles_split},
                            {"vertices_moved", st.vertices_moved},
                            {"triangles", triangles}};
  }
  // Scratches: the renderer's mode, and for the explicit-geometry reference a re-meshed part with
  // the cross-sections cut in (shared by nothing else: per sample, like displaced dents).
  std::vector<const Scratch*> scratches;
  for (auto& d : *s.defects)
    if (d->cls() == DefectClass::Scratch) scratches.push_back(static_cast<const Scratch*>(d.get()));
  s.scene.groove_shading = scratch_mode == "groove" && !scratches.empty();
  if (!scratches.empty()) {
    meta["scratches"] = {{"rendered_as", scratch_mode}};
    s.scene.layer_materials = layerMaterials(s.scene.material, scratches.front()->layers());
    s.scene.layer_stack = scratches.front()->layers();
  }
  if (scratch_mode == "geometry" && !scratches.empty()) {
    if (!displaced.empty())
      throw InputError(c.file, groups.line, groups.column,
                       "'defects': render.scratches: geometry cannot be combined with displaced dents");
    try {
      ScratchGeometryStats st;
      ScratchGeometryOptions opt;
      opt.count_only = check_only;
      opt.cell_mm = r["geometry_cell_mm"].num();
      opt.max_bytes = memoryLimit().bytes;  // taken before the cutting allocates anything
      TriangleMesh cut = scratchedMesh(ds.part->mesh(), scratches, opt, &st);
      if (!check_only) s.scene.part = std::make_shared<PartGeometry>(std::move(cut), ds.part->shell());
      meta["scratches"]["triangles"] = st.triangles;
      meta["scratches"]["cell_mm"] = st.cell_mm;
      meta["scratches"]["part_triangles_cut"] = st.part_triangles_cut;
      meta["scratches"]["cells_capped"] = st.cells_capped;
    } catch (const std::runtime_error& e) {
      throw InputError(c.file, r["scratches"].line, r["scratches"].column, "'render.scratches': geometry: " + std::string(e.what()));
    }
  }
  auto renderedAs = [&](uint16_t id) { return (*s.defects)[id - 1]->wantsDisplacement() ? "geometry" : "bump"; };
  for (auto& inst : s.instances)
    if (inst.cls == DefectClass::Dent) inst.attributes["rendered_as"] = renderedAs(inst.id);
  for (auto& e : dj)
    if (e["class"] == "dent") e["attributes"]["rendered_as"] = renderedAs(uint16_t(e["instance_id"].get<int>()));
  meta["defects"] = dj;
  meta["sampled"] = rec;
  s.scene.defects = s.defects.get();
  if (!check_only) s.scene.defect_index = DefectIndex(*s.defects, uvb);
  s.meta = std::move(meta);
  return s;
}

}  // namespace

void setFrameOutputs(const Value& r, RenderSettings& settings) {
  settings.want_rgb = r["png"].str() != "none" || r["exr"].flag();
  settings.want_depth = r["depth"].flag() && r["exr"].flag();
  settings.want_normals = r["normals"].flag() && r["exr"].flag();
  settings.want_coverage = r["masks"].flag();
}

Sample makeSample(const Dataset& ds, uint64_t seed, uint64_t index) { return buildSample(ds, seed, index, false); }

void checkSample(const Dataset& ds, uint64_t seed, uint64_t index) { buildSample(ds, seed, index, true); }

}  // namespace dg
