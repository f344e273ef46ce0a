// Plots scripts/bench-grooves' CSV (scene, method, spp, seconds, mean_de, pct_ge_10): one panel per
// scene, error (mean S-CIELAB Delta E) against render time on a log axis, one line per method,
// each point labelled with its samples per pixel; the bare plate's time (method "bare_plate", the
// scene without scratches at 64 spp) as a dashed vertical line. Usage: bench_plot_grooves CSV PNG
#include <cmath>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace {
const std::string kBarePlate = "bare_plate";
struct Point {
  int spp;
  double seconds, mean_de, pct;
};
}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: bench_plot_grooves CSV PNG\n";
    return 2;
  }
  std::ifstream in(argv[1]);
  if (!in) {
    std::cerr << "bench_plot_grooves: cannot read " << argv[1] << "\n";
    return 2;
  }
  std::map<std::string, std::map<std::string, std::vector<Point>>> data;  // scene -> method -> points
  std::vector<std::string> scenes;
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string scene, method, f;
    Point p;
    std::getline(ss, scene, ',');
    std::getline(ss, method, ',');
    std::getline(ss, f, ',');
    p.spp = std::stoi(f);
    std::getline(ss, f, ',');
    p.seconds = std::stod(f);
    std::getline(ss, f, ',');
    p.mean_de = std::stod(f);
    std::getline(ss, f, ',');
    p.pct = std::stod(f);
    if (!data.count(scene)) scenes.push_back(scene);
    data[scene][method].push_back(p);
  }
  const int pw = 560, ph = 380, cols = 3, rows = int(scenes.size() + cols - 1) / cols;
  cv::Mat img(std::max(1, rows) * ph, cols * pw, CV_8UC3, cv::Scalar(255, 255, 255));
  const std::map<std::string, cv::Scalar> colour = {
      {"groove", cv::Scalar(40, 40, 220)}, {"geometry", cv::Scalar(200, 90, 30)}, {"normal_map", cv::Scalar(40, 160, 40)}};
  for (size_t si = 0; si < scenes.size(); ++si) {
    const auto& methods = data[scenes[si]];
    double tmin = 1e30, tmax = 0, emax = 0;
    for (auto& [m, pts] : methods)
      for (auto& p : pts) {
        tmin = std::min(tmin, p.seconds);
        tmax = std::max(tmax, p.seconds);
        if (m != kBarePlate) emax = std::max(emax, p.mean_de);
      }
    double lx0 = std::floor(std::log10(std::max(1e-3, tmin))), lx1 = std::ceil(std::log10(std::max(1e-3, tmax)));
    if (lx1 <= lx0) lx1 = lx0 + 1;
    emax = std::ceil(std::max(1.0, emax));
    int ox = int(si % cols) * pw, oy = int(si / cols) * ph;
    cv::Rect plot(ox + 60, oy + 40, pw - 90, ph - 100);
    cv::rectangle(img, plot, cv::Scalar(0, 0, 0), 1);
    auto X = [&](double t) { return plot.x + int((std::log10(t) - lx0) / (lx1 - lx0) * plot.width); };
    auto Y = [&](double e) { return plot.y + plot.height - int(e / emax * plot.height); };
    for (double l = lx0; l <= lx1; l += 1) {
      int x = X(std::pow(10.0, l));
      cv::line(img, {x, plot.y}, {x, plot.y + plot.height}, cv::Scalar(220, 220, 220), 1);
      std::ostringstream t;
      t << std::pow(10.0, l) << " s";
      cv::putText(img, t.str(), {x - 15, plot.y + plot.height + 18}, cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0), 1);
    }
    for (int k = 0; k <= 4; ++k) {
      double e = emax * k / 4;
      std::ostringstream t;
      t.precision(2);
      t << e;
      cv::putText(img, t.str(), {plot.x - 40, Y(e) + 4}, cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0), 1);
    }
    cv::putText(img, scenes[si] + ": mean S-CIELAB dE vs render time", {ox + 60, oy + 25}, cv::FONT_HERSHEY_SIMPLEX, 0.5,
                cv::Scalar(0, 0, 0), 1);
    int ly = plot.y + plot.height + 40;
    int lx = ox + 60;
    bool has_bare = false;
    for (auto& [m, pts] : methods) {
      cv::Scalar c = colour.count(m) ? colour.at(m) : cv::Scalar(0, 0, 0);
      if (m == kBarePlate) {  // a time, not an error: a dashed vertical line at it
        for (auto& p : pts)
          for (int y = plot.y; y < plot.y + plot.height; y += 8)
            cv::line(img, {X(p.seconds), y}, {X(p.seconds), std::min(y + 4, plot.y + plot.height)}, c, 1);
        has_bare = true;
        continue;
      }
      for (size_t i = 0; i < pts.size(); ++i) {
        cv::Point a(X(pts[i].seconds), Y(pts[i].mean_de));
        cv::circle(img, a, 3, c, cv::FILLED);
        cv::putText(img, std::to_string(pts[i].spp), a + cv::Point(4, -4), cv::FONT_HERSHEY_SIMPLEX, 0.33, c, 1);
        if (i) cv::line(img, {X(pts[i - 1].seconds), Y(pts[i - 1].mean_de)}, a, c, 1, cv::LINE_AA);
      }
      cv::line(img, {lx, ly}, {lx + 20, ly}, c, 2);
      cv::putText(img, m, {lx + 25, ly + 4}, cv::FONT_HERSHEY_SIMPLEX, 0.45, c, 1);
      lx += 120;
    }
    if (has_bare) {
      for (int x = lx; x < lx + 20; x += 8) cv::line(img, {x, ly}, {std::min(x + 4, lx + 20), ly}, cv::Scalar(0, 0, 0), 1);
      cv::putText(img, "bare plate@64", {lx + 25, ly + 4}, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0), 1);
    }
  }
  if (!cv::imwrite(argv[2], img)) {
    std::cerr << "bench_plot_grooves: cannot write " << argv[2] << "\n";
    return 2;
  }
  return 0;
}
