// A uniform grid over a part's UV chart listing, per cell, the defects whose support overlaps it
// (Bosch 2007 used 100x100 to 200x200 cells). A shading point only looks at the defects listed in
// the cells its footprint touches. Built once per sample; empty when the sample has no defects,
// and then never consulted.
#pragma once
#include <algorithm>
#include <cstdint>
#include <vector>

#include "defects/defect.h"

namespace dg {

class DefectIndex {
 public:
  DefectIndex() = default;
  DefectIndex(const DefectList& defects, Box2 uv_bounds, int max_cells_per_axis = 128);
  bool empty() const { return ids_.empty(); }
  // Calls fn(const Defect&) for each defect whose support may meet the box [p - r, p + r]. A
  // defect is reported once per call.
  template <class Fn>
  void forEach(Vec2f p, float r, Fn&& fn) const {
    if (ids_.empty()) return;
    int x0 = cellX(p.x - r), x1 = cellX(p.x + r), y0 = cellY(p.y - r), y1 = cellY(p.y + r);
    if (x0 == x1 && y0 == y1) {
      size_t c = size_t(y0) * nx_ + x0;
      for (uint32_t i = start_[c]; i < start_[c + 1]; ++i) fn(*defects_[ids_[i]]);
      return;
    }
    // Several cells: report each defect once, in ascending index (deterministic order).
    seen_scratch(x0, x1, y0, y1, fn);
  }
  size_t cellCount() const { return size_t(nx_) * ny_; }

 private:
  int cellX(float u) const;
  int cellY(float v) const;
  template <class Fn>
  void seen_scratch(int x0, int x1, int y0, int y1, Fn&& fn) const {
    uint32_t found[256];  // more than 256 distinct defects under one footprint is not supported
    int n = 0;
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        size_t c = size_t(y) * nx_ + x;
        for (uint32_t i = start_[c]; i < start_[c + 1]; ++i) {
          uint32_t id = ids_[i];
          bool dup = false;
          for (int k = 0; k < n; ++k) dup |= (found[k] == id);
          if (!dup && n < 256) found[n++] = id;
        }
      }
    std::sort(found, found + n);
    for (int k = 0; k < n; ++k) fn(*defects_[found[k]]);
  }
  std::vector<const Defect*> defects_;
  Box2 bounds_;
  int nx_ = 0, ny_ = 0;
  float sx_ = 0, sy_ = 0;  // cells per mm
  std::vector<uint32_t> start_, ids_;
};

}  // namespace dg
