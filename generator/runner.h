// The dataset runner behind `defectgen generate`: validates everything before touching the output
// folder, renders the samples of this shard, writes each file under a temporary name and renames
// it when complete, and assembles annotations.json and manifest.json from the complete samples.
#pragma once
#include <cstdint>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

namespace dg {

struct Config;

struct GenerateOptions {
  std::string config_path;
  std::string out_dir;  // empty = out/<config stem>
  std::optional<int64_t> count, seed;
  std::optional<int> spp;          // override render.spp (previews, tests)
  std::optional<double> scale;     // scale render.resolution (and pixel intrinsics)
  int threads = 0;                 // 0 = all cores
  int shard_index = 0, shard_count = 1;
  bool resume = false;
  bool quiet = false;
};

struct GenerateResult {
  std::string out_dir;
  int rendered = 0, skipped = 0;
  double seconds = 0;
};

GenerateResult runGenerate(const GenerateOptions& opts);

// The memory a sample takes at its peak: the frame and the outputs the config asks for, at its
// resolution, plus the process's own (docs/output.md, "Memory"). generate refuses a config whose
// estimate is more than the process may use (core/memory.h); validate prints it.
uint64_t frameMemoryEstimate(const Config& cfg);

// Rebuilds annotations.json from the complete samples in a dataset folder (used at the end of
// every run, so shards that write into one folder end with the whole dataset's annotations).
// Returns how many complete samples it holds.
int64_t assembleAnnotations(const std::string& out_dir, int64_t count);

// Versions of defectgen and of every library it links, for manifest.json and --version.
nlohmann::json libraryVersions();

}  // namespace dg
