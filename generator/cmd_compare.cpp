// `defectgen compare`: the command-line front of labels/compare.h. Parses and validates the flags,
// then runs one comparison or a batch (--pairs). Bad input throws dg::InputError (exit status 2).
#include <CLI/CLI.hpp>

#include <cmath>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/error.h"
#include "generator/cli_checks.h"
#include "generator/commands.h"
#include "labels/compare.h"

namespace dg {

namespace {

struct CompareFlags {
  std::string reference, test, out = "compare_out", metric = "scielab", deltaE = "1976";
  std::string filters = "paper", mask, pairs;
  std::vector<std::string> reg;
  double spd = 0, dpi = 0, pitch = 0, distance = 0;
  std::string observer = "2";
  CLI::Option *oSpd = nullptr, *oDpi = nullptr, *oPitch = nullptr, *oDistance = nullptr;
};

double valueOrNan(const CLI::Option* o, double v, const char* name) {
  if (o->count() == 0) return std::numeric_limits<double>::quiet_NaN();
  if (std::isnan(v)) throw InputError(name, "must be a number, got nan");
  return v;
}

CompareRequest buildRequest(const CompareFlags& f) {
  CompareRequest req;
  req.reference = f.reference;
  req.test = f.test;
  req.outDir = f.out;
  req.maskPath = f.mask;
  req.pairsCsv = f.pairs;
  if (req.outDir.empty()) throw InputError("--out", "must not be empty");
  CompareOptions& o = req.options;

  if (f.metric == "scielab" || f.metric == "s-cielab")
    o.metric.metric = SpatialMetric::Scielab;
  else if (f.metric == "ycxcz" || f.metric == "ycxcz/lab")
    o.metric.metric = SpatialMetric::Ycxcz;
  else if (f.metric == "cielab" || f.metric == "lab")
    o.metric.metric = SpatialMetric::Cielab;
  else
    throw InputError("--metric", "expected scielab, ycxcz or cielab, got '" + f.metric + "'");

  if (f.deltaE == "1976" || f.deltaE == "76")
    o.metric.deltaE = color::DeltaE::CIE76;
  else if (f.deltaE == "94" || f.deltaE == "1994")
    o.metric.deltaE = color::DeltaE::CIE94;
  else if (f.deltaE == "2000" || f.deltaE == "00")
    o.metric.deltaE = color::DeltaE::CIEDE2000;
  else
    throw InputError("--delta-e", "expected 1976, 94 or 2000, got '" + f.deltaE + "'");

  if (f.filters == "paper")
    o.metric.filters = ScielabFilters::Paper;
  else if (f.filters == "isetcam")
    o.metric.filters = ScielabFilters::Isetcam;
  else
    throw InputError("--filters", "expected paper or isetcam, got '" + f.filters + "'");

  if (f.observer == "2")
    o.metric.observer = color::Observer::Deg2;
  else if (f.observer == "10")
    o.metric.observer = color::Observer::Deg10;
  else
    throw InputError("--observer", "expected 2 or 10, got '" + f.observer + "'");

  o.viewing = resolveViewingGeometry(valueOrNan(f.oSpd, f.spd, "--samples-per-degree"),
                                     valueOrNan(f.oDpi, f.dpi, "--dpi"), valueOrNan(f.oPitch, f.pitch, "--pixel-pitch-mm"),
                                     valueOrNan(f.oDistance, f.distance, "--distance-mm"));
  o.metric.samplesPerDegree = o.viewing.samplesPerDegree;

  if (!f.reg.empty()) {
    const std::string& mode = f.reg[0];
    if (mode == "none" || mode == "auto") {
      if (f.reg.size() > 1)
        throw InputError("--register", "unexpected argument '" + f.reg[1] + "' after --register " + mode);
      o.registration.mode = mode == "none" ? RegistrationMode::None : RegistrationMode::Auto;
    } else if (mode == "points") {
      if (f.reg.size() < 2) throw InputError("--register", "points needs a FILE of point pairs: --register points FILE");
      o.registration.mode = RegistrationMode::Points;
      o.registration.pointsFile = f.reg[1];
    } else {
      throw InputError("--register", "expected auto, none or points FILE, got '" + mode + "'");
    }
  }
  if (f.pairs.empty() && (f.reference.empty() || f.test.empty())) {
    std::string hint = o.registration.mode == RegistrationMode::Points && f.test.empty()
                           ? " (--register points takes a FILE before the images)"
                           : "";
    throw InputError("compare", "needs the images REFERENCE and TEST (or --pairs CSV)" + hint);
  }
  return req;
}

// The images and --register's values in command-line order. `--register points FILE` takes two
// values, `--register auto` one; CLI11 decides how many tokens an option takes before it sees them,
// so a `--register auto` written before the images may have swallowed the first image as a second
// value. CLI11's parse order tells where every value came from, which puts such a value back in its
// place among the images.
void collectImagesAndRegister(const CLI::App& c, const CLI::Option* ref, const CLI::Option* tst,
                              const CLI::Option* reg, std::vector<std::string>& images, std::vector<std::string>& regValues) {
  std::map<const CLI::Option*, size_t> seen;
  std::string mode;
  for (const CLI::Option* o : c.parse_order()) {
    const size_t k = seen[o]++;
    if (k >= o->results().size()) continue;
    const std::string& v = o->results()[k];
    if (o == ref || o == tst) {
      images.push_back(v);
    } else if (o == reg) {
      if (k == 0) {
        mode = v;
        regValues.push_back(v);
      } else if (k == 1 && mode == "points") {
        regValues.push_back(v);
      } else {
        images.push_back(v);
      }
    }
  }
}

}  // namespace

void addCompareCommand(CLI::App& app) {
  auto f = std::make_shared<CompareFlags>();
  CLI::App* c = app.add_subcommand(
      "compare",
      "Compare a test image (photograph or render) with a reference: registration, then per-pixel Delta E in "
      "S-CIELAB, YCxCz/Lab or CIELAB; writes delta_e.exr, false-colour, >=10 overlay and histogram PNGs and "
      "report.json (docs/compare.md)");
  // The images are checked in the callback (they are not needed with --pairs).
  CLI::Option* ref = c->add_option("REFERENCE", f->reference,
                                   "Reference image: PNG, JPEG, TIFF (8/16-bit sRGB) or EXR (linear)")
                         ->check(nonEmptyPath());
  CLI::Option* tst = c->add_option("TEST", f->test, "Test image, resampled onto the reference when registering")
                         ->check(nonEmptyPath());
  c->add_option("--out", f->out, "Output folder (default: compare_out)")->check(nonEmptyPath());
  c->add_option("--metric", f->metric, "scielab (default), ycxcz or cielab");
  c->add_option("--delta-e", f->deltaE, "Colour difference: 1976 (default), 94 or 2000");
  f->oSpd = c->add_option("--samples-per-degree", f->spd, "Pixels per degree of visual angle (spatial metrics)")->check(finiteNumber());
  f->oDpi = c->add_option("--dpi", f->dpi, "Display resolution; with --distance-mm")->check(finiteNumber());
  f->oPitch = c->add_option("--pixel-pitch-mm", f->pitch, "Size of one pixel on the object, mm; with --distance-mm")->check(finiteNumber());
  f->oDistance = c->add_option("--distance-mm", f->distance, "Viewing (working) distance, mm")->check(finiteNumber());
  CLI::Option* reg =
      c->add_option("--register", f->reg, "none (default; sizes must match), auto (AKAZE + RANSAC + ECC) or points FILE")
          ->expected(1, 2)
          ->allow_extra_args(false)
          ->type_name("MODE [FILE]");
  c->add_option("--mask", f->mask, "Mask image of the reference's size: statistics also inside / outside it")->check(nonEmptyPath());
  CLI::Option* oFilters = c->add_option("--filters", f->filters, "S-CIELAB filters: paper (default) or isetcam");
  CLI::Option* oObserver =
      c->add_option("--observer", f->observer, "S-CIELAB opponent transform for the 2 (default) or 10 degree observer");
  c->add_option("--pairs", f->pairs,
                "Batch: CSV with columns reference,test[,mask][,points][,name]; writes OUT/<name>/ and OUT/summary.csv")
      ->check(nonEmptyPath());
  c->callback([f, c, ref, tst, reg, oFilters, oObserver] {
    std::vector<std::string> images;
    CompareFlags g = *f;
    g.reg.clear();
    collectImagesAndRegister(*c, ref, tst, reg, images, g.reg);
    if (images.size() > 2)
      throw InputError("compare", "expected the two images REFERENCE TEST, got " + std::to_string(images.size()) +
                                      " arguments ('" + images[0] + "', '" + images[1] + "', '" + images[2] + "', ...)");
    g.reference = images.size() > 0 ? images[0] : std::string();
    g.test = images.size() > 1 ? images[1] : std::string();
    if (!g.pairs.empty() && !images.empty())
      throw InputError("--pairs", "give either REFERENCE TEST or --pairs CSV, not both");
    CompareRequest req = buildRequest(g);
    // Options that the chosen metric does not use are accepted but said so.
    const SpatialMetric m = req.options.metric.metric;
    if (m != SpatialMetric::Scielab && (oFilters->count() || oObserver->count()))
      std::cerr << "compare: note: --filters and --observer apply to --metric scielab only; ignored\n";
    if (m == SpatialMetric::Cielab && (f->oSpd->count() || f->oDpi->count() || f->oPitch->count()))
      std::cerr << "compare: note: --metric cielab does not filter; the viewing geometry is not used\n";
    if (!req.pairsCsv.empty())
      runComparePairs(req);
    else
      runCompare(req);
  });
}

}  // namespace dg
