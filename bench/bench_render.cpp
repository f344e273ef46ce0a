// Renderer benchmark (prints figures, asserts nothing):
//  (a) primary-ray throughput of the renderer's camera pass against a bare Embree rtcIntersect1
//      loop over the same mesh and the same rays, in the same run, as a ratio (target >= 0.7);
//  (b) seconds per 1024 x 1024 sample at 16 spp on the door panel with 5 dents, and the share of
//      that time spent outside ray casting (ray time estimated from bare-loop rates);
//  (c) peak memory.
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <vector>

#include "core/parallel.h"
#include "core/rng.h"
#include "generator/scene_builder.h"

using namespace dg;
using Clock = std::chrono::steady_clock;

namespace {

const char* kScene = R"(part:
  type: door_panel
material:
  type: car_paint
  base_color: [0.5, 0.03, 0.03]
  flake_amount: 0.3
lights:
  - type: dome
    radiance: [0.25, 0.25, 0.27]
  - type: rect
    position: [0, 0, 1500]
    target: [0, 0, 0]
    size_mm: [1800, 70]
    radiance: [40, 40, 40]
  - type: rect
    position: [0, 500, 1500]
    target: [0, 500, 0]
    size_mm: [1800, 70]
    radiance: [40, 40, 40]
camera:
  fov_deg: 42
  position: [0, -350, 1500]
render:
  resolution: [1024, 1024]
  spp: 16
  max_bounces: 3
defects:
  - type: dent
    count: 5
    radius_mm: {uniform: [15, 45]}
    depth_mm: 1.0
    region: [0.1, 0.1, 0.9, 0.9]
)";

double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

struct RayBatch {
  std::vector<Vec3f> o, d;
};

// The bare loop: rtcIntersect1 over precomputed rays, split into the same number of tasks as the
// renderer's tiles so both use the thread pool alike.
uint64_t bareLoop(RTCScene scene, const RayBatch& b) {
  const size_t n = b.o.size(), chunk = 1024;
  std::vector<uint64_t> hits((n + chunk - 1) / chunk);
  parallelFor(hits.size(), [&](size_t c) {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    uint64_t h = 0;
    for (size_t i = c * chunk; i < std::min(n, (c + 1) * chunk); ++i) {
      RTCRayHit rh;
      rh.ray.org_x = b.o[i].x;
      rh.ray.org_y = b.o[i].y;
      rh.ray.org_z = b.o[i].z;
      rh.ray.dir_x = b.d[i].x;
      rh.ray.dir_y = b.d[i].y;
      rh.ray.dir_z = b.d[i].z;
      rh.ray.tnear = 0;
      rh.ray.tfar = 1e30f;
      rh.ray.time = 0;
      rh.ray.mask = ~0u;
      rh.ray.id = 0;
      rh.ray.flags = 0;
      rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      rtcIntersect1(scene, &ctx, &rh);
      h += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
    }
    hits[c] = h;
  });
  uint64_t t = 0;
  for (auto h : hits) t += h;
  return t;
}

}  // namespace

int main() {
  Dataset ds = prepareDataset(parseConfig(kScene, "bench_render"));
  Sample s = makeSample(ds, 1, 0);
  const int W = s.scene.camera.K.width, H = s.scene.camera.K.height;
  RayGenerator gen(s.scene.camera);
  std::printf("scene: door panel, %zu triangles, %dx%d, %d spp, %zu dents\n",
              ds.part->mesh().triangleCount(), W, H, s.settings.spp, s.defects->size());

  // (a) Same rays: the pixel centres through the renderer's ray generator.
  RayBatch primary;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      Vec3f o, d, dx, dy;
      gen.generate(float(x), float(y), o, d, dx, dy);
      primary.o.push_back(o);
      primary.d.push_back(d);
    }
  const int reps = 10;
  uint64_t h1 = 0, h2 = 0;
  primaryPass(s.scene, gen);  // warm-up
  bareLoop(ds.part->scene(), primary);
  double t_bare = 1e30, t_pass = 1e30;
  for (int r = 0; r < reps; ++r) {
    auto t0 = Clock::now();
    h1 = bareLoop(ds.part->scene(), primary);
    t_bare = std::min(t_bare, since(t0));
    t0 = Clock::now();
    h2 = primaryPass(s.scene, gen);
    t_pass = std::min(t_pass, since(t0));
  }
  double n = double(W) * H;
  std::printf("(a) primary rays: bare rtcIntersect1 %.2f Mrays/s, renderer camera pass %.2f Mrays/s "
              "(ray generation included), ratio %.3f (target >= 0.7); hits %llu / %llu\n",
              n / t_bare * 1e-6, n / t_pass * 1e-6, t_bare / t_pass, (unsigned long long)h2,
              (unsigned long long)h1);

  // Secondary-like rays (from primary hits into random directions) for the incoherent rate.
  RayBatch secondary;
  Rng rng(3, Stream::Test);
  for (size_t i = 0; i < primary.o.size(); i += 1) {
    float t = 0;
    // Reuse the primary ray's direction to find a point on the part: intersect once.
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHit rh{};
    rh.ray.org_x = primary.o[i].x;
    rh.ray.org_y = primary.o[i].y;
    rh.ray.org_z = primary.o[i].z;
    rh.ray.dir_x = primary.d[i].x;
    rh.ray.dir_y = primary.d[i].y;
    rh.ray.dir_z = primary.d[i].z;
    rh.ray.tfar = 1e30f;
    rh.ray.mask = ~0u;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(ds.part->scene(), &ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) continue;
    t = rh.ray.tfar;
    Vec3f p = primary.o[i] + primary.d[i] * (t * 0.999f);
    float z = rng.uniform() * 2 - 1, phi = 2 * kPiF * rng.uniform(), r = std::sqrt(1 - z * z);
    secondary.o.push_back(p);
    secondary.d.push_back({r * std::cos(phi), r * std::sin(phi), z});
  }
  double t_sec = 1e30;
  for (int r = 0; r < 3; ++r) {
    auto t0 = Clock::now();
    bareLoop(ds.part->scene(), secondary);
    t_sec = std::min(t_sec, since(t0));
  }
  double rate_primary = n / t_bare, rate_secondary = double(secondary.o.size()) / t_sec;
  std::printf("    incoherent (secondary-like) rays: bare %.2f Mrays/s\n", rate_secondary * 1e-6);

  // (b) One full sample.
  auto t0 = Clock::now();
  RenderFrame f = render(s.scene, s.settings);
  double t_render = since(t0);
  double n_primary = n * s.settings.spp;
  double n_cov = s.settings.want_coverage ? n * s.settings.coverage_grid * s.settings.coverage_grid : 0;
  double n_other = double(f.stats.rays) - n_primary - n_cov;
  double t_rays = (n_primary + n_cov) / rate_primary + std::max(0.0, n_other) / rate_secondary;
  std::printf("(b) 1024x1024 at 16 spp, 5 dents, masks on: %.2f s per sample, %.1f Mrays; estimated ray "
              "casting %.2f s, share outside ray casting %.0f %%\n",
              t_render, f.stats.rays * 1e-6, t_rays, 100.0 * std::max(0.0, 1.0 - t_rays / t_render));

  // (d) Weathering overhead: the same scene at 512 x 512 with rust spots and a patina region
  // added to the 5 dents, against dents only; and dents against no defects at all.
  {
    auto timeScene = [](const std::string& extra, bool dents) {
      std::string text = kScene;
      text.replace(text.find("resolution: [1024, 1024]"), 24, "resolution: [512, 512]");
      if (!dents) text = text.substr(0, text.find("defects:"));
      text += extra;
      Dataset d = prepareDataset(parseConfig(text, "bench_weathering"));
      Sample smp = makeSample(d, 1, 0);
      render(smp.scene, smp.settings);  // warm-up
      double best = 1e30;
      for (int r = 0; r < 2; ++r) {
        auto t = Clock::now();
        render(smp.scene, smp.settings);
        best = std::min(best, since(t));
      }
      return best;
    };
    std::string weathering =
        "  - type: rust\n    count: 4\n    radius_mm: 80\n    age_years: 6\n    region: [0.2, 0.2, 0.8, 0.8]\n"
        "  - type: patina\n    count: 1\n    radius_mm: 250\n    age_years: 10\n    center: [0.5, 0.5]\n";
    double t_none = timeScene("", false), t_dents = timeScene("", true), t_weather = timeScene(weathering, true);
    std::printf("(d) 512x512, 16 spp: no defects %.2f s, 5 dents %.2f s (x%.2f), + 4 rust spots and a patina "
                "region %.2f s (x%.2f over dents only; target <= 1.30)\n",
                t_none, t_dents, t_dents / t_none, t_weather, t_weather / t_dents);
  }

  // (c) Peak memory of this process.
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  std::printf("(c) peak resident memory: %.0f MiB\n", ru.ru_maxrss / 1024.0);
  return 0;
}
