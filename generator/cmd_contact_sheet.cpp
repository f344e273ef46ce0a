#include <CLI/CLI.hpp>

#include <filesystem>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/fsutil.h"
#include "generator/cli_checks.h"
#include "generator/commands.h"
#include "labels/classes.h"
#include "labels/compare.h"
#include "labels/image_io.h"

namespace dg {

namespace fs = std::filesystem;

namespace {

cv::Mat overlay(const cv::Mat& img, const cv::Mat& sem, const cv::Mat& inst) {
  cv::Mat out = img.clone();
  for (int c = 1; c <= kNumDefectClasses; ++c) {
    uint8_t rgb[3];
    classColor(DefectClass(c), rgb);
    cv::Scalar bgr(rgb[2], rgb[1], rgb[0]);
    cv::Mat m = sem == c;
    if (cv::countNonZero(m) == 0) continue;
    cv::Mat tint(out.size(), out.type(), bgr), blended;
    cv::addWeighted(out, 0.55, tint, 0.45, 0.0, blended);
    blended.copyTo(out, m);
  }
  // Outline every instance in its class colour.
  double maxid;
  cv::minMaxLoc(inst, nullptr, &maxid);
  for (int id = 1; id <= int(maxid); ++id) {
    cv::Mat m = inst == id;
    if (cv::countNonZero(m) == 0) continue;
    std::vector<std::vector<cv::Point>> contours;
    cv::findContours(m, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
    cv::Point p;
    cv::minMaxLoc(m, nullptr, nullptr, nullptr, &p);
    uint8_t rgb[3];
    classColor(DefectClass(sem.at<uint8_t>(p)), rgb);
    cv::drawContours(out, contours, -1, cv::Scalar(rgb[2], rgb[1], rgb[0]), 1, cv::LINE_8);
  }
  return out;
}

// Returns how many images the dataset has (the sheet shows the first `max_images`).
size_t makeContactSheet(const std::string& dir, const std::string& out_png, int columns, int thumb, int max_images) {
  if (lowerExtension(out_png) != ".png") throw InputError(out_png, "--out: expected a file name ending in .png");
  fs::path d(dir);
  if (!fs::is_directory(d / "images")) throw InputError(dir, "not a defectgen dataset folder (no images/)");
  // Each sample's PNG, or where a dataset has none (render.png: none), its EXR.
  std::map<std::string, fs::path> by_stem;
  for (auto& e : fs::directory_iterator(d / "images")) {
    const std::string ext = e.path().extension().string(), stem = e.path().stem().string();
    if (stem.empty() || stem[0] == '.' || (ext != ".png" && ext != ".exr")) continue;
    auto [it, added] = by_stem.emplace(stem, e.path());
    if (!added && ext == ".png") it->second = e.path();
  }
  std::vector<fs::path> images;
  for (auto& [stem, path] : by_stem) images.push_back(path);
  std::sort(images.begin(), images.end());
  if (images.empty()) throw InputError(dir, "no images in images/");
  // A sheet is an overview: a dataset of thousands would make one of billions of pixels.
  const size_t total = images.size();
  if (images.size() > size_t(max_images)) images.resize(size_t(max_images));
  std::vector<cv::Mat> tiles;
  for (auto& p : images) {
    cv::Mat img;
    if (p.extension() == ".exr") {
      // Linear RGB, shown through the sRGB curve (render.exposure_stops applies to PNGs only).
      cv::cvtColor(toDisplay8(readColorImage(p.string()).rgb), img, cv::COLOR_RGB2BGR);
    } else {
      img = cv::imread(p.string(), cv::IMREAD_COLOR);
      if (img.empty()) throw InputError(p.string(), "cannot read image");
      if (img.depth() != CV_8U) img.convertTo(img, CV_8U, 1.0 / 257.0);
    }
    std::string stem = p.stem().string();
    fs::path sem_p = d / "masks" / (stem + "_semantic.png"), inst_p = d / "masks" / (stem + "_instance.png");
    cv::Mat sem, inst;
    if (fs::is_regular_file(sem_p) && fs::is_regular_file(inst_p)) {
      sem = cv::imread(sem_p.string(), cv::IMREAD_UNCHANGED);
      inst = cv::imread(inst_p.string(), cv::IMREAD_UNCHANGED);
    }
    if (!sem.empty() && !inst.empty()) {
      inst.convertTo(inst, CV_32S);
      img = overlay(img, sem, inst);
    }
    cv::Mat t;
    double s = double(thumb) / img.cols;
    cv::resize(img, t, cv::Size(thumb, std::max(1, int(img.rows * s + 0.5))), 0, 0, cv::INTER_AREA);
    cv::putText(t, stem, cv::Point(4, 14), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
    tiles.push_back(t);
  }
  int rows = (int(tiles.size()) + columns - 1) / columns;
  int th = 0;
  for (auto& t : tiles) th = std::max(th, t.rows);
  int cols = std::min(columns, int(tiles.size()));
  cv::Mat sheet(rows * (th + 2), cols * (thumb + 2), CV_8UC3, cv::Scalar(32, 32, 32));
  for (size_t i = 0; i < tiles.size(); ++i) {
    int r = int(i) / columns, c = int(i) % columns;
    tiles[i].copyTo(sheet(cv::Rect(c * (thumb + 2) + 1, r * (th + 2) + 1, tiles[i].cols, tiles[i].rows)));
  }
  // The folder of --out is made if missing, as generate and compare make theirs.
  std::error_code ec;
  const fs::path folder = fs::path(out_png).parent_path();
  if (!folder.empty()) fs::create_directories(folder, ec);
  if (ec || (!folder.empty() && !fs::is_directory(folder)))
    throw InputError(out_png, "--out: cannot create its folder" + (ec ? ": " + ec.message() : std::string()));
  writeAtomically(out_png, [&](const fs::path& tmp) {
    writePngBgr8(tmp.string(), sheet.ptr<uint8_t>(0), sheet.cols, sheet.rows, sheet.step);
  });
  return total;
}

}  // namespace

void addContactSheetCommand(CLI::App& app) {
  struct Opts {
    std::string dir, out;
    int columns = 5, thumb = 256, max_images = 100;
  };
  auto o = std::make_shared<Opts>();
  auto* c = app.add_subcommand("contact-sheet", "Grid of a dataset's images with the masks overlaid");
  c->add_option("dataset", o->dir, "Dataset folder written by generate")->required()->check(nonEmptyPath());
  c->add_option("--out", o->out, "Output PNG (default: DATASET/contact_sheet.png)")->check(nonEmptyPath());
  c->add_option("--columns", o->columns, "Images per row")->check(wholeNumberIn(1, 64));
  c->add_option("--thumb", o->thumb, "Width of each image in pixels")->check(wholeNumberIn(16, 4096));
  c->add_option("--max", o->max_images, "Show the first N images, in name order (default 100)")
      ->check(wholeNumberIn(1, 10000));
  c->callback([o] {
    std::string out = o->out.empty() ? (fs::path(o->dir) / "contact_sheet.png").string() : o->out;
    const size_t total = makeContactSheet(o->dir, out, o->columns, o->thumb, o->max_images);
    if (total > size_t(o->max_images))
      std::fprintf(stderr, "defectgen: contact sheet of the first %d of %zu images (--max) written to %s\n",
                   o->max_images, total, out.c_str());
    else
      std::fprintf(stderr, "defectgen: contact sheet written to %s\n", out.c_str());
  });
}

}  // namespace dg
