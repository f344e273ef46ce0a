#include "generator/runner.h"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <new>
#include <optional>
#include <sstream>

#include "core/error.h"
#include "core/fsutil.h"
#include "core/memory.h"
#include "core/parallel.h"
#include "core/rng.h"
#include "generator/scene_builder.h"
#include "labels/coco.h"
#include "labels/image_io.h"
#include "labels/visibility.h"

namespace dg {

namespace fs = std::filesystem;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

std::string idName(uint64_t i) {
  std::ostringstream s;
  s << std::setw(6) << std::setfill('0') << i;
  return s.str();
}

double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// CLI overrides are applied to the validated config, so that the config hash covers them.
void applyOverrides(Config& c, const GenerateOptions& o) {
  if (o.count) c.root.members.at("count").dist.constant = *o.count;
  if (o.seed) c.root.members.at("seed").dist.constant = *o.seed;
  Value& r = c.root.members.at("render");
  if (o.spp) r.members.at("spp").dist.constant = *o.spp;
  if (o.scale) {
    for (auto& it : r.members.at("resolution").items) {
      const double v = std::max(8.0, std::round(it.num() * *o.scale));
      if (v > 16384)
        throw InputError("--scale", "scales " + c.file + "'s render.resolution to " + std::to_string(int64_t(v)) +
                                        " pixels, past the largest, 16384");
      it.dist.constant = int64_t(v);
    }
    Value& cam = c.root.members.at("camera");
    if (cam.has("intrinsics"))
      for (auto& it : cam.members.at("intrinsics").items) {
        if (it.isConstant()) it.dist.constant = it.num() * *o.scale;
        else if (it.dist.kind == Dist::Kind::Choice) for (auto& ch : it.dist.choices) ch = ch.get<double>() * *o.scale;
        else { it.dist.a *= *o.scale; it.dist.b *= it.dist.kind == Dist::Kind::Normal ? *o.scale : *o.scale;
               it.dist.lo *= *o.scale; it.dist.hi *= *o.scale; }
      }
  }
}

// Bytes per pixel at a sample's peak: the frame that render() fills (RenderFrame), and on top of
// it the dearest of writeSampleFiles' steps. Checked against the peak RSS by the e2e test
// test_frame_memory_estimate_follows_the_peak.
uint64_t peakBytesPerPixel(const Value& r) {
  RenderSettings want;
  setFrameOutputs(r, want);
  const bool exr = r["exr"].flag(), masks = want.want_coverage;
  const std::string png = r["png"].str();
  const bool rgb = want.want_rgb, depth = want.want_depth, normals = want.want_normals;
  uint64_t frame = (rgb ? 12 : 0) + (depth ? 4 : 0) + (normals ? 12 : 0) + (masks ? 6 : 0);
  // The exposed copy of the RGB, held through all the writing.
  if (rgb && r["exposure_stops"].num() != 0) frame += 12;
  // The PNG: its 8- or 16-bit image and the encoded bytes, at most as many.
  uint64_t png_step = png == "8" ? 6 : png == "16" ? 12 : 0;
  // The masks: instance ids (kept to the end), the semantic mask, the encoded files, the image's
  // L* for the contrast figures, and the per-instance lists of L* values (one double per masked
  // pixel at most).
  uint64_t mask_step = masks ? 2 + 1 + 2 + (rgb ? 16 : 0) : 0;
  // The EXR: coverage and instance as floats (writeExr interleaves the channels a band of 64 rows
  // at a time, within the 200 MiB below).
  uint64_t exr_step = exr && masks ? 2 + 8 : 0;
  return frame + std::max({png_step, mask_step, exr_step});
}

// Refuses a resolution whose frame cannot fit in the memory this process may use, before anything
// is written: past it a render ends in std::bad_alloc or, with Linux's overcommit, is killed by the
// kernel without a message. Returns the estimate.
uint64_t checkFrameMemory(const Config& cfg) {
  const Value& r = cfg.root["render"];
  const Value& res = r["resolution"];
  const uint64_t need = frameMemoryEstimate(cfg);
  const MemoryLimit lim = memoryLimit();
  if (need > lim.bytes)
    throw InputError(cfg.file, res.line, res.column,
                     "'render.resolution': " + std::to_string(int64_t(res.items[0].num())) + " x " +
                         std::to_string(int64_t(res.items[1].num())) + " needs about " + formatBytes(need) + " (" +
                         std::to_string(peakBytesPerPixel(r)) +
                         " bytes per pixel for the image, masks and outputs asked for), more than the " +
                         formatBytes(lim.bytes) + " this process may use (" + lim.source +
                         "); lower the resolution or the outputs");
  return need;
}

class Progress {
 public:
  Progress(int total, bool quiet) : total_(total), quiet_(quiet), tty_(::isatty(2)), start_(Clock::now()) {}
  void done(uint64_t index, double secs) {
    ++n_;
    if (quiet_) return;
    double el = secondsSince(start_);
    double eta = n_ > 0 ? el / n_ * (total_ - n_) : 0;
    if (tty_) {
      int width = 30, fill = total_ ? int(width * n_ / total_) : width;
      std::fprintf(stderr, "\r[%s%s] %d/%d  %.1fs elapsed  ETA %.1fs ", std::string(size_t(fill), '#').c_str(),
                   std::string(size_t(width - fill), '.').c_str(), n_, total_, el, eta);
      if (n_ == total_) std::fprintf(stderr, "\n");
    } else {
      std::fprintf(stderr, "defectgen: sample %s done in %.2fs (%d/%d, ETA %.0fs)\n", idName(index).c_str(), secs,
                   n_, total_, eta);
    }
    std::fflush(stderr);
  }
  // A warning line, printed even with --quiet; on a terminal it first clears the progress bar,
  // which the next sample draws again.
  void warn(const std::string& line) const {
    if (tty_ && !quiet_ && n_ > 0 && n_ < total_) std::fprintf(stderr, "\r%78s\r", "");
    std::fprintf(stderr, "defectgen: warning: %s\n", line.c_str());
    std::fflush(stderr);
  }

 private:
  int total_, n_ = 0;
  bool quiet_, tty_;
  Clock::time_point start_;
};

// Samples that render but are of no use, most likely from a config mistake: a camera that does
// not see the part (an image of the lights alone, with no labels), and a black image (lights that
// send nothing to the camera, or an exposure far too low). Each kind is warned about once, at its
// first sample, and counted at the end; the run goes on (such samples may be meant as negatives).
class UselessSamples {
 public:
  UselessSamples(const Config& cfg, const Progress& prog) : file_(cfg.file), prog_(prog) {
    const Value& r = cfg.root["render"];
    gain_ = std::exp2(r["exposure_stops"].num());
    // Half of the PNG's first code above black, in linear light (the sRGB curve is linear there,
    // with slope 12.92): an image whose every pixel is below it writes as black.
    black_below_ = 0.5 / (r["png"].str() == "16" ? 65535.0 : 255.0) / 12.92;
  }

  void check(uint64_t i, const Sample& s, const RenderFrame& f) {
    if (!f.stats.part_in_view) {
      if (++no_part_ > 1) return;
      const json& cam = s.meta.at("camera");
      prog_.warn("sample " + idName(i) + " does not show the part: no camera ray meets it (camera at " +
                 point(cam.at("position_mm")) + " mm, looking at " + point(cam.at("target_mm")) +
                 "); check camera.position, camera.target and camera.up in " + file_);
      return;
    }
    if (f.rgb.empty()) return;
    float brightest = 0.0f;
    for (float v : f.rgb.data) brightest = std::max(brightest, v);  // NaN-safe: max(x, NaN) = x
    if (!(brightest * gain_ < black_below_) || ++black_ > 1) return;
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.2g", brightest * gain_);
    prog_.warn("sample " + idName(i) + " is black: its brightest pixel, " + buf +
               " after render.exposure_stops, is below the PNG's first code; check the lights' positions, "
               "directions and radiance, and render.exposure_stops, in " + file_);
  }

  void summary(int rendered) const {
    const std::string of = " of " + std::to_string(rendered) + " rendered samples ";
    if (no_part_ > 1) prog_.warn(std::to_string(no_part_) + of + "do not show the part");
    if (black_ > 1) prog_.warn(std::to_string(black_) + of + "are black");
  }

 private:
  static std::string point(const json& v) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "[%g, %g, %g]", v.at(0).get<double>() + 0.0, v.at(1).get<double>() + 0.0,
                  v.at(2).get<double>() + 0.0);  // + 0.0: no "-0"
    return buf;
  }
  std::string file_;
  const Progress& prog_;
  double gain_ = 1, black_below_ = 0;
  int64_t no_part_ = 0, black_ = 0;
};

// Samples where many of the groove renderer's footprints were past the polygon caps (docs/grooves.md,
// "Cost bound and fallback"), integrated with only their nearest grooves or shaded by the blend: at
// 1% of its groove footprints or more, the first such sample is named with its counts, and the
// others are counted at the end. Both can miss the glints where dense scratches cross
// (scripts/fuzz-grooves --kind clusters found renders with 3 to 9% of their footprints on the
// blend and 1.7 to 5.2% of pixels at S-CIELAB dE >= 10; c10_15, at 5.2% with the blend, has 0.69%
// with the nearest grooves), though not every such render suffers; fewer (a few footprints on the
// lens of configs/scratched_lens.yaml) are left unsaid.
class FootprintsPastCaps {
 public:
  FootprintsPastCaps(const Config& cfg, const Progress& prog) : file_(cfg.file), prog_(prog) {}

  void check(uint64_t i, const RenderStats& st) {
    const uint64_t past = st.groove_trimmed + st.groove_fallbacks, all = st.grooveFootprints();
    if (past == 0 || past * 100 < all || ++count_ > 1) return;
    char share[32];
    std::snprintf(share, sizeof share, "%.1f%%", 100.0 * double(past) / double(all));
    prog_.warn("sample " + idName(i) + ": " + std::to_string(past) + " of " + std::to_string(all) +
               " groove footprints (" + share + ") had more scratches or polygon pieces near them than the caps "
               "allow (" + std::to_string(st.groove_trimmed) + " integrated with only their nearest scratches, " +
               std::to_string(st.groove_fallbacks) +
               " shaded by the blend), which can miss the glints where dense scratches cross (docs/grooves.md, "
               "\"Cost bound and fallback\"); render.scratches: geometry at high spp renders such clusters "
               "exactly (" + file_ + ")");
  }

  void summary(int rendered) const {
    if (count_ > 1)
      prog_.warn(std::to_string(count_) + " of " + std::to_string(rendered) +
                 " rendered samples had 1% or more of their groove footprints past the polygon caps");
  }

 private:
  std::string file_;
  const Progress& prog_;
  int64_t count_ = 0;
};

void writeSampleFiles(const fs::path& out, const Config& cfg, const Sample& s, const RenderFrame& f,
                      json& timings) {
  const Value& r = cfg.root["render"];
  std::string id = idName(s.index);
  auto t0 = Clock::now();
  std::string png = r["png"].str();
  // The image as written to the PNG (and as the contrast below sees it): exposure applied, in a
  // copy only where there is exposure to apply.
  const float gain = std::exp2(float(r["exposure_stops"].num()));
  ImageF exposed;
  if (gain != 1.0f) {
    exposed = f.rgb;
    for (float& v : exposed.data) v *= gain;
  }
  const ImageF& img = gain != 1.0f ? exposed : f.rgb;
  if (png != "none") {
    fs::path p = out / "images" / (id + ".png");
    writeAtomically(p, [&](const fs::path& tmp) {
      if (png == "16") {
        writePngRgb16(tmp.string(), img);
      } else if (r["dither"].flag()) {
        const uint64_t key = hashKey(s.settings.seed, 0x646974686572ull, s.settings.sample_index);
        writePngRgb8(tmp.string(), img, &key);
      } else {
        writePngRgb8(tmp.string(), img);
      }
    });
  }
  Image<uint16_t> inst;
  json coco_anns = json::array();
  int W = s.scene.camera.K.width, H = s.scene.camera.K.height;
  if (r["masks"].flag()) {
    CoverageFrame cf{f.dominant, f.coverage, s.instances};
    inst = instanceMask(cf);
    Image<uint8_t> sem = semanticMask(cf);
    writeAtomically(out / "masks" / (id + "_semantic.png"), [&](const fs::path& t) { writePngGray8(t.string(), sem); });
    writeAtomically(out / "masks" / (id + "_instance.png"), [&](const fs::path& t) { writePngGray16(t.string(), inst); });
    int64_t next = int64_t(s.index) * 65536 + 1;  // unique across samples and shards
    coco_anns = cocoAnnotations(int(s.index), inst, s.instances, next);
    // How much each instance stands out in the image as written (labels/visibility.h).
    if (!img.empty()) {
      const std::vector<InstanceContrast> con = instanceContrast(inst, img, kContrastRingPixels);
      for (json& a : coco_anns) {
        const int id = a["instance_id"].get<int>();
        auto c = std::find_if(con.begin(), con.end(), [&](const InstanceContrast& x) { return x.id == id; });
        if (c == con.end()) continue;
        json cj = {{"mask_L", c->mask_l}, {"ring_px", kContrastRingPixels}, {"ring_pixels", c->ring_pixels}};
        if (c->ring_pixels > 0)
          cj.update({{"ring_L", c->ring_l}, {"delta_L", c->delta_l}, {"p90_abs_delta_L", c->p90_abs_delta_l}});
        a["contrast"] = cj;
      }
    }
  }
  if (r["exr"].flag()) {
    std::vector<ExrLayer> layers;
    layers.push_back({"", {"R", "G", "B"}, &f.rgb});
    if (!f.depth.empty()) layers.push_back({"depth", {"Z"}, &f.depth});
    if (!f.normal.empty()) layers.push_back({"normal", {"X", "Y", "Z"}, &f.normal});
    ImageF cov_inst;
    if (r["masks"].flag()) {
      cov_inst = ImageF(W, H, 2);
      for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
          cov_inst(x, y, 0) = f.coverage(x, y);
          cov_inst(x, y, 1) = float(f.dominant(x, y));
        }
      layers.push_back({"mask", {"coverage", "instance"}, &cov_inst});
    }
    writeAtomically(out / "images" / (id + ".exr"), [&](const fs::path& t) { writeExr(t.string(), W, H, layers); });
  }
  timings["write_s"] = secondsSince(t0);
  json meta = s.meta;
  meta["coco"] = {{"image", cocoImageEntry(int(s.index), "images/" + id + ".png", W, H)},
                  {"annotations", coco_anns}};
  // Written last: its presence marks the sample complete (for --resume and for assembly).
  writeTextAtomically(out / "samples" / (id + ".json"), meta.dump(2) + "\n");
}

// A sample is complete when its JSON (written last) reads back whole and the image it names is
// there. defectgen writes every file whole or not at all, so anything else was damaged from
// outside: such a sample is left out of annotations.json and rendered again by --resume.
std::optional<json> completeSample(const fs::path& out, uint64_t i) {
  const fs::path p = out / "samples" / (idName(i) + ".json");
  if (!fs::is_regular_file(p)) return std::nullopt;
  try {
    json m = json::parse(readTextFile(p));
    const json& image = m.at("coco").at("image");
    if (!fs::is_regular_file(out / image.at("file_name").get<std::string>())) return std::nullopt;
    return m;
  } catch (const std::exception&) {  // json::exception, or InputError from readTextFile
    return std::nullopt;
  }
}

bool sampleComplete(const fs::path& out, uint64_t i) { return completeSample(out, i).has_value(); }

}  // namespace

uint64_t frameMemoryEstimate(const Config& cfg) {
  const Value& r = cfg.root["render"];
  const Value& res = r["resolution"];
  // 200 MiB for the process itself: its libraries, the part and the defects' tables.
  return uint64_t(res.items[0].num()) * uint64_t(res.items[1].num()) * peakBytesPerPixel(r) + (200ull << 20);
}

int64_t assembleAnnotations(const std::string& out_dir, int64_t count) {
  // Streamed, one sample at a time: holding every annotation as a JSON tree took about 55 KB per
  // sample (1.1 GB for 20,000 samples of the quickstart, so a few hundred thousand would not fit).
  // The bytes are those of the tree's dump: nlohmann's objects keep their keys sorted, so the
  // top level reads annotations, categories, images, info, licenses. Only the images' entries,
  // about 80 bytes each, wait in memory for their place after the annotations.
  fs::path out(out_dir);
  int64_t n_images = 0;
  writeStreamAtomically(out / "annotations.json", [&](std::ostream& f) {
    std::string images;
    bool first_ann = true;
    f << "{\"annotations\":[";
    for (int64_t i = 0; i < count; ++i) {
      const std::optional<json> sample = completeSample(out, uint64_t(i));
      if (!sample) continue;
      const json& coco = (*sample)["coco"];
      images += (n_images++ ? "," : "") + coco["image"].dump();
      for (const json& a : coco["annotations"]) {
        f << (first_ann ? "" : ",") << a.dump();
        first_ann = false;
      }
    }
    const json info = {{"description", "defectgen synthetic defect dataset"}, {"version", "1.0"}};
    f << "],\"categories\":" << cocoCategories().dump() << ",\"images\":[" << images << "],\"info\":" << info.dump()
      << ",\"licenses\":[]}\n";
  });
  return n_images;
}

namespace {

// The dataset's subfolders (docs/output.md).
constexpr const char* kSubfolders[] = {"images", "masks", "samples"};

// Makes the dataset folder with its manifest and subfolders in one step: they are made in a
// temporary folder beside it, which is then renamed to it (rename(2) takes the place of a missing
// or empty folder atomically). Shards started together into one folder then never see it without
// its manifest, which they would refuse as someone else's (it happened to about half of the runs of
// eight shards started together). Returns false, leaving nothing behind, where the folder could not
// be made this way: another shard made it first, or it cannot be renamed onto (a mount point).
bool createDatasetFolder(const fs::path& out, const std::string& manifest_text) {
  std::error_code ec;
  const fs::path parent = out.has_parent_path() ? out.parent_path() : fs::path(".");
  fs::create_directories(parent, ec);
  if (ec) throw InputError(out.string(), "cannot create the output folder: " + ec.message());
  const fs::path tmp = parent / (".tmp-" + std::to_string(::getpid()) + "-" + out.filename().string());
  fs::remove_all(tmp, ec);
  bool made = fs::create_directory(tmp, ec);
  for (const char* sub : kSubfolders) made = made && fs::create_directory(tmp / sub, ec);
  if (!made) {
    const std::string why = ec.message();  // before remove_all resets ec ("Success")
    fs::remove_all(tmp, ec);
    throw InputError(out.string(), "cannot create the output folder: " + why);
  }
  writeTextAtomically(tmp / "manifest.json", manifest_text);
  fs::rename(tmp, out, ec);
  if (!ec) return true;
  fs::remove_all(tmp, ec);
  return false;
}

// Sample files in the folder (complete or not): a cheap count to see whether another shard added
// samples while this one assembled the annotations.
int64_t countSampleFiles(const fs::path& out) {
  int64_t n = 0;
  std::error_code ec;
  for (fs::directory_iterator it(out / "samples", ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    n += name.size() > 5 && name.compare(name.size() - 5, 5, ".json") == 0 && name.compare(0, 5, ".tmp-") != 0;
  }
  return n;
}

// The end of the message of a run stopped at a sample: every file is written whole or not at all,
// so what is there is a valid part of the dataset.
std::string keptSoFar(int rendered) {
  return "; the " + std::to_string(rendered) + " sample(s) written before it are kept and --resume continues "
         "the dataset";
}

// The temporaries that a killed run left in the dataset's folders (`.tmp-PID-NAME`, renamed
// into place only when whole). A live run on another host that shares the folder cannot be told
// from a dead one by its PID, so only files untouched for an hour are taken: no file of ours takes
// that long to write. Returns how many were removed.
int removeAbandonedTemporaries(const fs::path& out) {
  int n = 0;
  const auto now = fs::file_time_type::clock::now();
  for (const char* sub : kSubfolders) {
    std::error_code ec;
    for (fs::directory_iterator it(out / sub, ec), end; !ec && it != end; it.increment(ec)) {
      if (it->path().filename().string().compare(0, 5, ".tmp-") != 0) continue;
      std::error_code e2;
      const auto t = fs::last_write_time(it->path(), e2);
      if (!e2 && now - t > std::chrono::hours(1) && fs::remove(it->path(), e2)) ++n;
    }
  }
  return n;
}

}  // namespace

GenerateResult runGenerate(const GenerateOptions& o) {
  auto t_start = Clock::now();
  if (o.shard_count < 1 || o.shard_index < 0 || o.shard_index >= o.shard_count)
    throw InputError("--shard", "expected K/N with 0 <= K < N");
  // 1. Everything that can be wrong with the input is checked before the output folder is touched.
  Config cfg = loadConfig(o.config_path);
  applyOverrides(cfg, o);
  const uint64_t frame_need = checkFrameMemory(cfg);
  // --threads holds for all the work from here on: the part's setup and the samples' scenes (a
  // cut or displaced mesh and its BVH) as well as the rendering.
  ThreadLimit limit(o.threads);
  auto t_load = Clock::now();
  Dataset ds = prepareDataset(cfg);
  double part_s = secondsSince(t_load);
  const int64_t count = int64_t(ds.config.root["count"].num());
  const uint64_t seed = uint64_t(ds.config.root["seed"].num());
  std::vector<uint64_t> mine;
  for (int64_t i = o.shard_index; i < count; i += o.shard_count) mine.push_back(uint64_t(i));
  fs::path out = o.out_dir.empty() ? fs::path("out") / fs::path(o.config_path).stem() : fs::path(o.out_dir);
  out = out.lexically_normal();
  if (!out.has_filename() && out.has_parent_path()) out = out.parent_path();  // "data/" -> "data"
  // This run's samples that are not yet complete. With --resume, those an earlier run of this
  // config completed are neither checked nor built again (the folder is only read here; a folder
  // of another dataset is refused below, before anything is written). Checking them again cost
  // the explicit-geometry reference a count of each sample's cut mesh, and the first sample was
  // built whole to be thrown away: seconds to minutes a sample on scratched_door.
  std::vector<uint64_t> pending;
  if (o.resume && fs::is_directory(out / "samples")) {
    for (uint64_t i : mine)
      if (!sampleComplete(out, i)) pending.push_back(i);
  } else {
    pending = mine;
  }
  // Every pending sample's draws are checked (the error of the first sample that fails is the one
  // reported). The first sample is checked last and kept for the render loop: a scene can be dear
  // to build (scratched_door in the explicit-geometry reference mode cuts a mesh of 20 million
  // triangles, and building it twice was half of the run), and this way at most one is held at a
  // time. Its build time still counts in its render_s. The others are only checked (checkSample:
  // no BVH, the scratch reference cut and counted but not stored) and built again when rendered.
  std::optional<Sample> kept;
  double kept_build_s = 0;
  {
    std::exception_ptr later;
    // About 1 ms a sample for scratched_door: silent for minutes at a million samples, unless said.
    const auto t_check = Clock::now();
    bool told = false;
    for (size_t k = 1; k < pending.size() && !later; ++k) {
      try {
        checkSample(ds, seed, pending[k]);
      } catch (const InputError&) {
        later = std::current_exception();
      }
      if (!told && !o.quiet && (k & 255) == 0 && secondsSince(t_check) > 2.0) {
        std::fprintf(stderr, "defectgen: checking the draws of all %zu samples before writing anything (%zu so far)\n",
                     pending.size(), k);
        told = true;
      }
    }
    if (told && !later)
      std::fprintf(stderr, "defectgen: %zu samples checked in %.1f s\n", pending.size(), secondsSince(t_check));
    if (!pending.empty()) {
      auto t0 = Clock::now();
      kept.emplace(makeSample(ds, seed, pending[0]));
      kept_build_s = secondsSince(t0);
    }
    if (later) std::rethrow_exception(later);
  }

  std::string hash = ds.config.hash();
  const std::string scene_hash = ds.config.sceneHash();
  json manifest = {{"config_file", o.config_path},
                   {"config_hash", hash},
                   {"scene_hash", scene_hash},
                   {"seed", seed},
                   {"count", count},
                   {"versions", libraryVersions()}};
  if (fs::exists(out) && !fs::is_directory(out)) throw InputError(out.string(), "--out: exists and is not a folder");
  const bool made = (!fs::exists(out) || fs::is_empty(out)) && createDatasetFolder(out, manifest.dump(2) + "\n");
  if (!made && fs::is_directory(out) && !fs::is_empty(out)) {
    fs::path man = out / "manifest.json";
    bool same = false;
    int64_t had = -1;  // the count of a dataset of this config and seed with another count
    if (fs::is_regular_file(man)) {
      try {
        json m = json::parse(readTextFile(man));
        const bool same_seed = m.value("seed", uint64_t(0)) == seed;
        same = same_seed && m.value("config_hash", "") == hash && m.value("count", int64_t(-1)) == count;
        // Sample i is a function of the seed and i alone, so a larger count adds samples to the
        // same dataset (manifests before 2026-11-27 have no scene_hash: not grown).
        if (!same && same_seed && m.value("scene_hash", "") == scene_hash) had = m.value("count", int64_t(-1));
      } catch (const json::exception& e) {
        // defectgen writes it whole or not at all (renamed into place), so something else changed it.
        throw InputError(man.string(), std::string("not a readable manifest (") + e.what() +
                                           "), so the folder cannot be checked or resumed; remove the folder or "
                                           "choose another --out");
      }
    }
    if (had > count)
      throw InputError(out.string(), "output folder holds " + std::to_string(had) +
                                         " samples of this config and seed; a count of " + std::to_string(count) +
                                         " would leave samples out of it (a dataset grows, it does not shrink): "
                                         "pass --count " + std::to_string(had) +
                                         " or more, or choose another --out");
    if (had >= 0 && !o.resume)
      throw InputError(out.string(), "output folder holds " + std::to_string(had) +
                                         " samples of this config and seed; pass --resume to add samples " +
                                         std::to_string(had) + " to " + std::to_string(count - 1) +
                                         " to it, or remove the folder to start again");
    if (!same && had < 0)
      throw InputError(out.string(), "output folder is not empty and holds no dataset of this config, seed and "
                                     "count; choose another --out or remove the folder");
    if (!o.resume && o.shard_count == 1)
      throw InputError(out.string(), "output folder already holds this dataset; pass --resume to continue it "
                                     "or remove the folder to start again");
  }
  if (!made) {  // an existing dataset, or an empty folder that could not be renamed onto
    for (const char* sub : kSubfolders) {
      std::error_code ec;
      fs::create_directories(out / sub, ec);
      if (ec) throw InputError(out.string(), "cannot create the output folder: " + ec.message());
    }
    if (!fs::exists(out / "manifest.json")) writeTextAtomically(out / "manifest.json", manifest.dump(2) + "\n");
  }

  // 2. Render this shard's samples.
  GenerateResult res;
  res.out_dir = out.string();
  if (o.resume) {
    const int removed = removeAbandonedTemporaries(out);
    if (removed > 0 && !o.quiet)
      std::fprintf(stderr, "defectgen: removed %d temporary file(s) that an interrupted run left\n", removed);
  }
  // Only this shard writes its samples, so what was complete above still is.
  const std::vector<uint64_t>& todo = pending;
  res.skipped = int(mine.size() - pending.size());
  Progress prog(int(todo.size()), o.quiet);
  json per_sample = json::array();
  double render_total = 0;
  UselessSamples useless(ds.config, prog);
  FootprintsPastCaps past_caps(ds.config, prog);
  for (uint64_t i : todo) {
    auto t0 = Clock::now();
    const bool was_kept = kept && i == pending.front();
    json t;
    try {
      Sample s = was_kept ? std::move(*kept) : makeSample(ds, seed, i);
      kept.reset();
      RenderFrame f = render(s.scene, s.settings);
      double rs = secondsSince(t0) + (was_kept ? kept_build_s : 0.0);
      render_total += rs;
      t = {{"index", i}, {"render_s", rs}, {"rays", f.stats.rays}};
      if (f.stats.grooveFootprints() > 0)
        t["groove_footprints"] = {{"sections", f.stats.groove_sections},
                                  {"polygons", f.stats.groove_polygons},
                                  {"trimmed", f.stats.groove_trimmed},
                                  {"fallbacks", f.stats.groove_fallbacks},
                                  {"shared", f.stats.groove_shared}};
      useless.check(i, s, f);
      past_caps.check(i, f.stats);
      writeSampleFiles(out, ds.config, s, f, t);
    } catch (const WriteError& e) {
      throw WriteError("", std::string(e.what()) + keptSoFar(res.rendered));
    } catch (const std::bad_alloc&) {
      const MemoryLimit lim = memoryLimit();
      throw InputError(cfg.file, "ran out of memory while rendering sample " + idName(i) + " (" + lim.source +
                                     ": " + formatBytes(lim.total) + ")" + keptSoFar(res.rendered));
    }
    per_sample.push_back(t);
    ++res.rendered;
    prog.done(i, secondsSince(t0));
  }
  // Shards that share a folder may finish together: one could scan the samples before another's
  // last ones are written and rename its annotations.json (and manifest) into place after the
  // other's. So each run counts the sample files before and after assembling and writing, and does
  // it again if any appeared meanwhile: a run whose counts agree wrote everything there was, and a
  // sample written after that belongs to a run that assembles later.
  for (int64_t present = countSampleFiles(out);;) {
    manifest["samples_complete"] = assembleAnnotations(out.string(), count);
    res.seconds = secondsSince(t_start);
    rusage ru{};
    getrusage(RUSAGE_SELF, &ru);
    manifest["last_run"] = {{"shard", std::to_string(o.shard_index) + "/" + std::to_string(o.shard_count)},
                            {"threads", o.threads},
                            {"rendered", res.rendered},
                            {"skipped", res.skipped},
                            {"timings", {{"total_s", res.seconds}, {"part_setup_s", part_s},
                                         {"render_s", render_total},
                                         {"peak_rss_mib", double(ru.ru_maxrss) / 1024.0},
                                         {"samples", per_sample}}},
                            {"memory_estimate_mib", double(frame_need) / double(1 << 20)}};
    writeTextAtomically(out / "manifest.json", manifest.dump(2) + "\n");
    const int64_t now = countSampleFiles(out);
    if (now == present) break;
    present = now;
  }
  useless.summary(res.rendered);
  past_caps.summary(res.rendered);
  if (!o.quiet)
    std::fprintf(stderr, "defectgen: %d sample(s) rendered, %d skipped, in %.1f s; dataset in %s\n", res.rendered,
                 res.skipped, res.seconds, out.string().c_str());
  return res;
}

}  // namespace dg
