// The path tracer: next-event estimation toward every light with multiple importance sampling
// (Veach 1997, power heuristic), TBB over 32x32 tiles, ray differentials carried to every hit,
// counter-based random numbers keyed by (seed, sample, pixel, pixel sample) so that the image does
// not depend on the thread count or the tile order.
#pragma once
#include <cstdint>
#include <memory>

#include "core/image.h"
#include "defects/defect.h"
#include "defects/defect_index.h"
#include "defects/scratch.h"
#include "render/bsdf.h"
#include "render/camera.h"
#include "render/lights.h"
#include "render/paint.h"
#include "render/scene.h"

namespace dg {

struct RenderScene {
  std::shared_ptr<const PartGeometry> part;
  Material material;
  LightSet lights;
  Camera camera;
  const DefectList* defects = nullptr;  // may be null or empty
  DefectIndex defect_index;             // empty when there are no defects
  std::shared_ptr<const PaintVariation> paint;  // car paint's orange peel and flakes; null = none
  // Scratches by the groove renderer (Bosch 2007 §4.2-4.3, render/groove.h): camera hits whose
  // footprint meets a scratch integrate the footprint over its cross-section. Camera samples then
  // sit at the centres of an nx x ny grid of strata (nx * ny = spp) with a footprint of one stratum.
  bool groove_shading = false;
  // The material of each coating layer a scratch facet may expose (index = LayerStack layer; 0 =
  // the part's own material, which then keeps its paint variation).
  std::vector<Material> layer_materials;
  // Their stack. With a mesh that carries heights (the scratch reference), a hit below the part's
  // surface shows the layer at its depth.
  LayerStack layer_stack;
};

// The materials a scratch exposes, per layer: the part's own material for layer 0; for car paint
// the base coat (rough diffuse in the base colour), the primer (rough diffuse grey) and bare steel
// (exact conductor Fresnel, roughness 0.3) below it. Other parts (glass included) have a one-layer
// stack, so their scratches show the part's own material.
std::vector<Material> layerMaterials(const Material& part, const LayerStack& stack);

struct RenderSettings {
  int spp = 16;
  int max_bounces = 4;
  uint64_t seed = 0;
  uint64_t sample_index = 0;
  bool want_rgb = true;
  bool want_depth = false;     // camera-space z (mm) of the pixel-centre hit, 0 on a miss
  bool want_normals = false;   // world shading normal (after bump) of the pixel-centre hit
  bool want_coverage = false;  // per-pixel dominant defect instance and its coverage
  int coverage_grid = 4;       // the pixel footprint is sampled on a grid of n x n points
  // Inter-reflections followed inside a groove (Bosch §4.3), at most max_bounces - 1.
  int max_groove_bounces = 3;
  // Light samples per light at a groove footprint (stratified over the light), and at every other
  // camera hit when groove shading is on: the footprint is integrated exactly, so the light's
  // extent is what is left to sample.
  int groove_light_samples = 16;
  // Directions sampled per camera sample at a groove footprint (Latin-hypercube stratified over
  // the visible portions and the BSDF). They carry the inter-reflection, whose noise under a
  // low-angle bar light was the groove renderer's largest error: 8 gave 0.60% of pixels >= 10
  // against the converged reference on the parallel/bar scene at 4 spp, 32 gave 0.08%.
  int groove_bsdf_samples = 32;
  // More BSDF directions per camera sample at a groove footprint, four per visible facet portion
  // and at most this many, used for the direct light only (not continued; Tracer::lobeDirect).
  // They find a long light inside the sharp lobes of small portions: on parallel grooves about
  // one pixel wide under the bar light (the accuracy scene seen from 4 times as far), they took
  // the mean S-CIELAB dE of the groove pixels at 1 spp from 3.0 to 2.1 at the same time.
  int groove_lobe_samples = 32;
  // Chain directions per camera sample at a groove footprint (Tracer::Chain): first-level
  // directions drawn from a far facet's BSDF as seen from a light, for the light that reaches the
  // camera mirrored by the far facet and passed on by the seen one's lobe tail (a groove's dark
  // wall under a low bar light). Close up under the bar they cut the noise of parallel/bar at
  // 1 spp from mean dE 0.77 to 0.57 for 10% more time; 0 turns them off.
  int groove_chain_samples = 16;
  // Crossings and ends by area sampling with polygons (Bosch §4.2.4); false: the direction-share
  // and end-share blend that is otherwise only the fallback past the polygons' caps.
  bool groove_polygons = true;
  // Close views: a polygon surface built for one footprint serves the strata beside it
  // (Tracer::SharedArea in integrator.cpp); false builds one for each.
  bool groove_share_polygons = true;
  // With groove shading on, BSDF directions at every other camera hit, each continued as its own
  // path: glossy surfaces lit by wide lights converge alike on and off the grooves. At most
  // camera_hit_bsdf_samples (and 64) per camera sample, and no more than camera_hit_bsdf_per_pixel
  // / spp: at high spp the camera samples themselves supply the directions (32 at 1 spp, then 16,
  // 8, 4, 2, 1 at 2, 4, 8, 16, 32 spp; the pixel's samples share them by a lattice,
  // PixelPattern::resetDirections). With at most 8 per camera sample, as before 2026-11-26, the
  // accuracy scenes' mean dE at 1 spp was 7-20% higher (parallel/bar 0.69 against 0.62) for
  // 0-20% less time; 64 at 1 spp gained another 1-2% for 20-30% more time. Glass takes at most 8
  // (Tracer::cameraHitSplit).
  int camera_hit_bsdf_samples = 32;
  int camera_hit_bsdf_per_pixel = 32;
  // On a car-paint part, 128 (32 per camera sample up to 4 spp, then 16, 8, 4, 2, 1): the paint's
  // plate is lit mostly through these directions (the clear coat's sharp lobe and the base's
  // cosine lobe; a dome takes no light samples on paint), and with 32 per pixel it was the
  // noisiest part of a render above 2 spp. The plate's RMS error against a converged reference on
  // configs/scratch_rust.yaml at 320 x 240, 2 threads: 4 spp 1.59% in 1.52 s -> 0.80% in 2.33 s;
  // 16 spp 1.59% in 2.86 s -> 0.69% in 3.71 s (64 per pixel: 1.01% in 3.27 s); 64 spp 0.99% in
  // 5.71 s -> 0.68% in 6.18 s. configs/scratched_door.yaml at 256 x 256 and 4 spp, robust pixel
  // noise between noise seeds: 0.33% in 0.82 s -> 0.18% in 1.49 s (64: 0.24% in 1.06 s). 256 and
  // 512 per pixel are better for the time at 16 spp (0.49% in 4.78 s, 0.38% in 6.92 s) but take
  // up to twice as long per sample; below 8 spp the cap of 32 per camera sample makes them the
  // same as 128. Other materials keep 32 (not measured there).
  int camera_hit_bsdf_per_pixel_paint = 128;
  // And light samples per light at those camera hits: groove_light_samples, but no more than
  // camera_hit_light_per_pixel / spp (16 up to 8 spp, then 8, 4, 2, 1 at 16, 32, 64, 128 spp;
  // the pixel's samples share them by a lattice, PixelPattern::resetLights). With 16 at every
  // spp, a pixel at 64 spp took 1,024 samples per light where it took 32 directions, and more
  // spp bought little: on configs/scratch_rust.yaml at 320 x 240 and 64 spp, 19.3 s at a
  // relative pixel noise of 1.00% on the plate, now 6.0 s at 0.79%; on the ring-lit aluminium
  // plate at 64 spp 2.45 s at 0.070%, now 0.68 s at 0.057%; at 16 spp 5.3 -> 3.6 s (1.42% ->
  // 1.36%) and 0.67 -> 0.47 s (0.118% -> 0.122%). A budget of 64 was cheaper still on the paint
  // (2.5 s at 16 spp) but left the ring-lit plate noisier for its time (0.206% in 0.30 s).
  int camera_hit_light_per_pixel = 128;
  // Whether a camera hit's lobe choice (on car paint: the clear coat or the base) takes Latin
  // strata over the pixel's samples and their split directions (PixelPattern::lobe, lobeAt), where
  // the pixel has a pattern (spp > 1); false: over each camera sample's own directions, as before
  // 2026-11-28.
  bool pixel_lobe_strata = true;
  // With groove shading on, whether a constant environment (a dome) takes groove_light_samples
  // light samples at camera hits and groove footprints, as each area light does. Off: the BSDF
  // directions, which follow the BSDF, find it alone (Tracer::env_by_bsdf_): the same or less
  // noise on the accuracy scenes in 13% less time. An environment map always takes them.
  bool groove_env_light_samples = false;
  // With groove shading on at 1 spp, whether the light samples of camera hits and of
  // groove footprints that see only the flat surface are guided (LightGuide,
  // Tracer::buildGuides): drawn more densely where the shading point's BSDF makes more of the
  // light. Under the accuracy scenes' ring light the plate's share of the mean dE at 1 spp fell
  // by half (docs/grooves.md, "Cost per sample"); false draws them uniformly over the light.
  bool guide_light_samples = true;
};

struct RenderStats {
  uint64_t rays = 0;         // all rays cast (closest-hit and occlusion)
  double seconds_shading = 0;
  // Camera samples whose footprint the groove renderer integrated: by 1-D sections (isolated and
  // parallel grooves), by polygons (crossings and ends), and past the polygons' caps by polygons
  // over the nearest grooves only (`trimmed`) or, past those too, by the blend (`fallbacks`).
  uint64_t groove_sections = 0, groove_polygons = 0, groove_trimmed = 0, groove_fallbacks = 0;
  uint64_t grooveFootprints() const { return groove_sections + groove_polygons + groove_trimmed + groove_fallbacks; }
  // Of the polygon footprints, those that took the surface built for a stratum beside them (a
  // close view, Tracer::SharedArea in integrator.cpp).
  uint64_t groove_shared = 0;
  // Whether a primary ray of the mask pass (or, without one, through a pixel centre) meets the
  // part: false when the camera does not see the part at all (a camera looking past it).
  bool part_in_view = false;
};

struct RenderFrame {
  ImageF rgb;                  // linear Rec.709
  ImageF depth;                // 1 channel
  ImageF normal;               // 3 channels
  Image<uint16_t> dominant;    // instance id covering most of the pixel, 0 = none
  ImageF coverage;             // its coverage fraction
  RenderStats stats;
};

RenderFrame render(const RenderScene& scene, const RenderSettings& settings);

// The camera pass alone: one primary ray per pixel centre through the same ray generator and
// intersection call as render(); returns the number of hits. For the throughput benchmark.
uint64_t primaryPass(const RenderScene& scene, const RayGenerator& rays);

}  // namespace dg
