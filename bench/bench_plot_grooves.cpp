// Plots scripts/bench-grooves' CSV: one panel per scene, error (mean S-CIELAB Delta E) against render
// time, both on log axes (the errors span 0.04 to 14, and the comparison that matters is near the
// bottom), one line per method, each point labelled with its samples per pixel, and where a row
// averages several noise seeds (column `seeds`) a bar over their spread (`mean_de_min` to
// `mean_de_max`). The bare plate's time (method "bare_plate", the scene without scratches at
// 64 spp) is a dashed vertical line. The target is drawn as a shaded box: the region left of
// 1/20 of explicit geometry's time at 64 spp and below its error; a groove curve that enters the
// box meets the target on that scene.
// Usage: bench_plot_grooves CSV PNG. A CSV it cannot read gives one message naming the file and
// line and exit status 2.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace {
const std::string kBarePlate = "bare_plate";
const double kTargetShare = 1.0 / 20.0;  // issue 5: geometry@64's error in at most 1/20 of its time

struct Point {
  int spp = 0;
  double seconds = 0, mean_de = 0;
  int seeds = 1;
  double de_min = 0, de_max = 0;  // the spread over the seeds (equal to mean_de for one seed)
};

struct BadCsv {
  std::string what;
};

std::vector<std::string> splitCsv(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  std::string f;
  while (std::getline(ss, f, ',')) out.push_back(f);
  if (!line.empty() && line.back() == ',') out.emplace_back();
  return out;
}

double number(const std::string& s, const std::string& column) {
  size_t used = 0;
  double v = 0;
  try {
    v = std::stod(s, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != s.size() || !std::isfinite(v))
    throw BadCsv{"column '" + column + "': expected a number, got '" + s + "'"};
  return v;
}

// Scene -> method -> points, scenes in the order they first appear.
struct Table {
  std::vector<std::string> scenes;
  std::map<std::string, std::map<std::string, std::vector<Point>>> data;
};

Table readCsv(std::istream& in, const std::string& path) {
  Table t;
  std::string line;
  int line_no = 1;
  if (!std::getline(in, line)) throw BadCsv{path + ":1: empty file; expected a header line"};
  std::map<std::string, size_t> col;
  const std::vector<std::string> header = splitCsv(line);
  for (size_t i = 0; i < header.size(); ++i) col[header[i]] = i;
  for (const char* need : {"scene", "method", "spp", "seconds", "mean_de"})
    if (!col.count(need))
      throw BadCsv{path + ":1: the header has no column '" + need +
                   "'; expected scripts/bench-grooves' results.csv (scene, method, spp, seconds, mean_de, ...)"};
  const bool spread = col.count("seeds") && col.count("mean_de_min") && col.count("mean_de_max");
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty()) continue;
    const std::vector<std::string> f = splitCsv(line);
    const std::string at = path + ":" + std::to_string(line_no) + ": ";
    if (f.size() != header.size())
      throw BadCsv{at + std::to_string(f.size()) + " fields; expected " + std::to_string(header.size()) +
                   ", one per header column"};
    try {
      Point p;
      p.spp = int(number(f[col["spp"]], "spp"));
      p.seconds = number(f[col["seconds"]], "seconds");
      p.mean_de = number(f[col["mean_de"]], "mean_de");
      if (!(p.seconds > 0)) throw BadCsv{"column 'seconds': expected a time above 0, got " + f[col["seconds"]]};
      if (p.mean_de < 0) throw BadCsv{"column 'mean_de': expected an error of 0 or more, got " + f[col["mean_de"]]};
      p.de_min = p.de_max = p.mean_de;
      if (spread) {
        p.seeds = int(number(f[col["seeds"]], "seeds"));
        p.de_min = number(f[col["mean_de_min"]], "mean_de_min");
        p.de_max = number(f[col["mean_de_max"]], "mean_de_max");
      }
      const std::string& scene = f[col["scene"]];
      if (!t.data.count(scene)) t.scenes.push_back(scene);
      t.data[scene][f[col["method"]]].push_back(p);
    } catch (const BadCsv& e) {
      throw BadCsv{at + e.what};
    }
  }
  if (t.scenes.empty()) throw BadCsv{path + ": no rows after the header; expected at least one result"};
  return t;
}

// Geometry at 64 spp, where the scene has it: the point the target is measured against.
std::optional<Point> geometry64(const std::map<std::string, std::vector<Point>>& methods) {
  auto it = methods.find("geometry");
  if (it == methods.end()) return std::nullopt;
  for (const Point& p : it->second)
    if (p.spp == 64) return p;
  return std::nullopt;
}

void dashedLine(cv::Mat& img, cv::Point a, cv::Point b, const cv::Scalar& c) {
  const double len = std::hypot(double(b.x - a.x), double(b.y - a.y));
  for (double s = 0; s < len; s += 8) {
    const double e = std::min(s + 4, len);
    cv::line(img, a + cv::Point(int((b.x - a.x) * s / len), int((b.y - a.y) * s / len)),
             a + cv::Point(int((b.x - a.x) * e / len), int((b.y - a.y) * e / len)), c, 1);
  }
}

// The nearest of 1, 2 and 5 times a power of ten below v (or above it, `up`).
double niceBound(double v, bool up) {
  const double p = std::pow(10.0, std::floor(std::log10(v)));
  if (!up) return v >= 5 * p ? 5 * p : v >= 2 * p ? 2 * p : p;
  return v <= p * (1 + 1e-9) ? p : v <= 2 * p ? 2 * p : v <= 5 * p ? 5 * p : 10 * p;
}

std::string tick(double v, const char* unit) {
  std::ostringstream t;
  t << v << unit;
  return t.str();
}

void drawPanel(cv::Mat& img, cv::Rect panel, const std::string& scene,
               const std::map<std::string, std::vector<Point>>& methods) {
  const cv::Scalar black(0, 0, 0), grid(225, 225, 225), target_fill(205, 240, 205), target_edge(60, 150, 60);
  const std::map<std::string, cv::Scalar> colour = {
      {"groove", cv::Scalar(40, 40, 220)}, {"geometry", cv::Scalar(200, 90, 30)}, {"normal_map", cv::Scalar(40, 160, 40)}};
  const std::optional<Point> g64 = geometry64(methods);
  double tmin = 1e30, tmax = 0, emin = 1e30, emax = 0;
  for (auto& [m, pts] : methods)
    for (auto& p : pts) {
      tmin = std::min(tmin, p.seconds);
      tmax = std::max(tmax, p.seconds);
      if (m == kBarePlate) continue;
      if (p.de_min > 0) emin = std::min(emin, p.de_min);
      emax = std::max(emax, p.de_max);
    }
  if (g64) tmin = std::min(tmin, g64->seconds * kTargetShare);
  if (!(emax > 0)) emax = 1;
  if (!(emin < emax)) emin = emax / 10;
  const double lx0 = std::floor(std::log10(std::max(1e-4, tmin))), lx1 = std::max(lx0 + 1, std::ceil(std::log10(tmax)));
  const double ly0 = std::log10(niceBound(std::max(1e-3, emin), false)), ly1 = std::log10(niceBound(emax, true));

  const cv::Rect plot(panel.x + 60, panel.y + 40, panel.width - 90, panel.height - 125);
  auto X = [&](double t) { return plot.x + int(std::lround((std::log10(t) - lx0) / (lx1 - lx0) * plot.width)); };
  auto Y = [&](double e) {
    const double l = std::log10(std::max(e, std::pow(10.0, ly0)));
    return plot.y + plot.height - int(std::lround((l - ly0) / (ly1 - ly0) * plot.height));
  };

  // The target region first, under everything else.
  if (g64) {
    const int x1 = X(g64->seconds * kTargetShare), y0 = Y(g64->mean_de);
    cv::rectangle(img, cv::Rect(cv::Point(plot.x, y0), cv::Point(x1, plot.y + plot.height)), target_fill, cv::FILLED);
    cv::line(img, {plot.x, y0}, {x1, y0}, target_edge, 1);
    cv::line(img, {x1, y0}, {x1, plot.y + plot.height}, target_edge, 1);
  }
  for (double l = lx0; l <= lx1; l += 1) {
    const int x = X(std::pow(10.0, l));
    cv::line(img, {x, plot.y}, {x, plot.y + plot.height}, grid, 1);
    cv::putText(img, tick(std::pow(10.0, l), " s"), {x - 15, plot.y + plot.height + 18}, cv::FONT_HERSHEY_SIMPLEX, 0.4,
                black, 1);
  }
  for (double l = std::floor(ly0 + 1e-9); l <= ly1; l += 1)
    for (double k : {1.0, 2.0, 5.0}) {
      const double e = k * std::pow(10.0, l);
      if (std::log10(e) < ly0 - 1e-9) continue;
      if (std::log10(e) > ly1 + 1e-9) break;
      const int y = Y(e);
      cv::line(img, {plot.x, y}, {plot.x + plot.width, y}, grid, 1);
      cv::putText(img, tick(e, ""), {plot.x - 45, y + 4}, cv::FONT_HERSHEY_SIMPLEX, 0.4, black, 1);
    }
  cv::rectangle(img, plot, black, 1);
  cv::putText(img, scene + ": mean S-CIELAB dE vs render time", {panel.x + 60, panel.y + 25}, cv::FONT_HERSHEY_SIMPLEX,
              0.5, black, 1);

  int ly = plot.y + plot.height + 40, lx = panel.x + 60;
  bool has_bare = false;
  for (auto& [m, pts] : methods) {
    const cv::Scalar c = colour.count(m) ? colour.at(m) : black;
    if (m == kBarePlate) {  // a time, not an error: a dashed vertical line at it
      for (auto& p : pts) dashedLine(img, {X(p.seconds), plot.y}, {X(p.seconds), plot.y + plot.height}, black);
      has_bare = true;
      continue;
    }
    for (size_t i = 0; i < pts.size(); ++i) {
      const cv::Point a(X(pts[i].seconds), Y(pts[i].mean_de));
      if (pts[i].seeds > 1) {
        cv::line(img, {a.x, Y(pts[i].de_min)}, {a.x, Y(pts[i].de_max)}, c, 1);
        for (double e : {pts[i].de_min, pts[i].de_max}) cv::line(img, {a.x - 3, Y(e)}, {a.x + 3, Y(e)}, c, 1);
      }
      cv::circle(img, a, 3, c, cv::FILLED);
      cv::putText(img, std::to_string(pts[i].spp), a + cv::Point(4, -4), cv::FONT_HERSHEY_SIMPLEX, 0.33, c, 1);
      if (i) cv::line(img, {X(pts[i - 1].seconds), Y(pts[i - 1].mean_de)}, a, c, 1, cv::LINE_AA);
    }
    cv::line(img, {lx, ly}, {lx + 20, ly}, c, 2);
    cv::putText(img, m, {lx + 25, ly + 4}, cv::FONT_HERSHEY_SIMPLEX, 0.45, c, 1);
    lx += 120;
  }
  ly += 20;
  lx = panel.x + 60;
  if (has_bare) {
    dashedLine(img, {lx, ly}, {lx + 20, ly}, black);
    cv::putText(img, "bare plate@64", {lx + 25, ly + 4}, cv::FONT_HERSHEY_SIMPLEX, 0.45, black, 1);
    lx += 150;
  }
  if (g64) {
    cv::rectangle(img, cv::Rect(lx, ly - 6, 20, 12), target_fill, cv::FILLED);
    cv::rectangle(img, cv::Rect(lx, ly - 6, 20, 12), target_edge, 1);
    cv::putText(img, "target: geometry@64's dE in 1/20 of its time", {lx + 25, ly + 4}, cv::FONT_HERSHEY_SIMPLEX, 0.4,
                target_edge, 1);
  }
}
}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: bench_plot_grooves CSV PNG\n";
    return 2;
  }
  std::ifstream in(argv[1]);
  if (!in) {
    std::cerr << "bench_plot_grooves: " << argv[1] << ": cannot read the file\n";
    return 2;
  }
  Table t;
  try {
    t = readCsv(in, argv[1]);
  } catch (const BadCsv& e) {
    std::cerr << "bench_plot_grooves: " << e.what << "\n";
    return 2;
  }
  const int pw = 560, ph = 410, cols = 3, rows = int(t.scenes.size() + cols - 1) / cols;
  cv::Mat img(rows * ph, cols * pw, CV_8UC3, cv::Scalar(255, 255, 255));
  for (size_t si = 0; si < t.scenes.size(); ++si)
    drawPanel(img, cv::Rect(int(si % cols) * pw, int(si / cols) * ph, pw, ph), t.scenes[si], t.data[t.scenes[si]]);
  bool written = false;
  try {
    written = cv::imwrite(argv[2], img);
  } catch (const cv::Exception&) {
    written = false;
  }
  if (!written) {
    std::cerr << "bench_plot_grooves: " << argv[2] << ": cannot write the picture\n";
    return 2;
  }
  return 0;
}
