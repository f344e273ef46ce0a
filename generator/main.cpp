// defectgen command line: generate, validate, compare, config-reference.
#include <CLI/CLI.hpp>
#include <opencv2/core.hpp>

#include <cstdio>
#include <iostream>
#include <regex>
#include <string>

#include "core/error.h"
#include "core/memory.h"
#include "core/version.h"
#include "generator/cli_checks.h"
#include "generator/commands.h"
#include "generator/config.h"
#include "generator/runner.h"

namespace {
// Not a bug but a request larger than the machine: generate checks its frame beforehand
// (core/memory.h) and names the sample it was on; anything else that runs out ends here.
int outOfMemory(const CLI::App& app) {
  const dg::MemoryLimit lim = dg::memoryLimit();
  const std::string cmd = app.get_subcommands().empty() ? "defectgen" : app.get_subcommands().front()->get_name();
  std::fprintf(stderr, "defectgen: error: %s ran out of memory (%s: %s)\n", cmd.c_str(), lim.source.c_str(),
               dg::formatBytes(lim.total).c_str());
  return dg::kExitInputError;
}
}  // namespace

int main(int argc, char** argv) {
  using namespace dg;
  CLI::App app{"defectgen: labeled synthetic images of car-part defects (scratches, dents, rust, patina)"};
  // A flag error is one line like every other bad input: "defectgen: error: <what> (see --help)".
  app.failure_message([](const CLI::App*, const CLI::Error& e) {
    return "defectgen: error: " + withoutControlCharacters(e.what()) + " (see --help)\n";
  });
  app.require_subcommand(0, 1);
  bool show_version = false;
  app.add_flag("--version", show_version, "Print the version of defectgen and its libraries");

  GenerateOptions gen;
  std::string shard;
  int64_t count = 0, seed = 0;
  int spp = 0;
  double scale = 0;
  auto* g = app.add_subcommand("generate", "Render a dataset from a config");
  g->add_option("config", gen.config_path, "YAML config")->required()->check(nonEmptyPath());
  g->add_option("--out", gen.out_dir, "Output folder (default: out/<config name>)")->check(nonEmptyPath());
  auto* o_count = g->add_option("--count", count, "Number of samples (overrides the config)")->check(wholeNumberIn(1, 10000000));
  // The config's range for `seed` (docs/config.md).
  auto* o_seed = g->add_option("--seed", seed, "Seed (overrides the config)")->check(wholeNumberIn(0, 1000000000000000));
  g->add_option("--threads", gen.threads, "Worker threads (default: all cores)")->check(wholeNumberIn(0, 1024));
  g->add_option("--shard", shard, "Render only samples i with i % N == K, as K/N");
  g->add_flag("--resume", gen.resume, "Continue an interrupted run: skip complete samples");
  g->add_flag("--quiet", gen.quiet, "No progress output");
  auto* o_spp = g->add_option("--spp", spp, "Samples per pixel (overrides the config)")->check(wholeNumberIn(1, 65536));
  auto* o_scale = g->add_option("--scale", scale, "Scale the resolution (quick previews)")->check(numberIn(0.01, 16.0));

  std::string validate_path;
  auto* v = app.add_subcommand("validate", "Check a config and print it resolved, with every default and unit");
  v->add_option("config", validate_path, "YAML config")->required()->check(nonEmptyPath());

  auto* ref = app.add_subcommand("config-reference", "Print the config reference (docs/config.md)");
  addCompareCommand(app);
  addContactSheetCommand(app);

  try {
    // Subcommand callbacks (compare) run inside parse() and may throw InputError.
    try {
      app.parse(argc, argv);
    } catch (const CLI::Success& e) {
      return app.exit(e);
    } catch (const CLI::ParseError& e) {
      app.exit(e);
      return kExitInputError;
    }
    if (show_version) {
      auto vers = libraryVersions();
      std::printf("defectgen %s\n", DEFECTGEN_VERSION);
      for (auto& kv : vers.items())
        if (kv.key() != "defectgen") std::printf("  %s %s\n", kv.key().c_str(), kv.value().get<std::string>().c_str());
      return 0;
    }
    if (*g) {
      if (*o_count) gen.count = count;
      if (*o_seed) gen.seed = seed;
      if (*o_spp) gen.spp = spp;
      if (*o_scale) gen.scale = scale;
      if (!shard.empty()) {
        std::smatch m;
        if (!std::regex_match(shard, m, std::regex("([0-9]+)/([0-9]+)")))
          throw InputError("--shard", "expected K/N (for example 0/4), got '" + shard + "'");
        gen.shard_index = std::stoi(m[1]);
        gen.shard_count = std::stoi(m[2]);
        if (gen.shard_count < 1 || gen.shard_index >= gen.shard_count)
          throw InputError("--shard", "expected K/N with 0 <= K < N, got '" + shard + "'");
      }
      runGenerate(gen);
      return 0;
    }
    if (*v) {
      std::vector<InputError> errors;
      Config c = loadConfigAllErrors(validate_path, errors);
      if (!errors.empty()) {
        for (const InputError& e : errors) std::fprintf(stderr, "defectgen: error: %s\n", e.what());  // InputError: already one line
        std::fprintf(stderr, "defectgen: %zu error(s) in %s\n", errors.size(), validate_path.c_str());
        return kExitInputError;
      }
      std::cout << describeConfig(c);
      // What generate checks against the machine: told here, not refused, since a config may be
      // validated on one machine and rendered on another.
      const uint64_t need = frameMemoryEstimate(c);
      const MemoryLimit lim = memoryLimit();
      std::cerr << "defectgen: " << validate_path << " is valid; a sample needs about " << formatBytes(need)
                << " of memory";
      if (need > lim.bytes)
        std::cerr << ", more than the " << formatBytes(lim.bytes) << " this process may use here (" << lim.source
                  << "), so generate would refuse it here";
      std::cerr << "\n";
      return 0;
    }
    if (*ref) {
      std::cout << configReferenceMarkdown();
      return 0;
    }
    if (app.get_subcommands().empty()) {
      std::cout << app.help();
      return 0;
    }
  } catch (const InputError& e) {
    std::fprintf(stderr, "defectgen: error: %s\n", e.what());  // InputError: already one line
    return kExitInputError;
  } catch (const std::bad_alloc&) {
    return outOfMemory(app);
  } catch (const std::exception& e) {
    // OpenCV reports a failed allocation as its own exception (compare on large images).
    if (auto* cv_e = dynamic_cast<const cv::Exception*>(&e); cv_e && cv_e->code == cv::Error::StsNoMem)
      return outOfMemory(app);
    std::fprintf(stderr, "defectgen: internal error: %s\n", withoutControlCharacters(e.what()).c_str());
    return 1;
  }
  return 0;
}
