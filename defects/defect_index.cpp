#include "defects/defect_index.h"

#include <algorithm>
#include <cmath>

namespace dg {

DefectIndex::DefectIndex(const DefectList& defects, Box2 uv, int max_cells) {
  if (defects.empty()) return;
  for (auto& d : defects) defects_.push_back(d.get());
  // Extend the bounds by the supports so that every support lies inside the grid.
  for (auto& d : defects) {
    Box2 s = d->support();
    uv.lo.x = std::min(uv.lo.x, s.lo.x);
    uv.lo.y = std::min(uv.lo.y, s.lo.y);
    uv.hi.x = std::max(uv.hi.x, s.hi.x);
    uv.hi.y = std::max(uv.hi.y, s.hi.y);
  }
  bounds_ = uv;
  float w = std::max(uv.hi.x - uv.lo.x, 1e-3f), h = std::max(uv.hi.y - uv.lo.y, 1e-3f);
  float cell = std::max(w, h) / float(max_cells);
  nx_ = std::clamp(int(std::ceil(w / cell)), 1, max_cells);
  ny_ = std::clamp(int(std::ceil(h / cell)), 1, max_cells);
  sx_ = float(nx_) / w;
  sy_ = float(ny_) / h;
  std::vector<std::vector<uint32_t>> cells(size_t(nx_) * ny_);
  for (uint32_t i = 0; i < defects_.size(); ++i) {
    Box2 s = defects_[i]->support();
    for (int y = cellY(s.lo.y); y <= cellY(s.hi.y); ++y)
      for (int x = cellX(s.lo.x); x <= cellX(s.hi.x); ++x) cells[size_t(y) * nx_ + x].push_back(i);
  }
  start_.resize(cells.size() + 1, 0);
  for (size_t c = 0; c < cells.size(); ++c) {
    start_[c + 1] = start_[c] + uint32_t(cells[c].size());
    ids_.insert(ids_.end(), cells[c].begin(), cells[c].end());
  }
}

int DefectIndex::cellX(float u) const {
  return std::clamp(int(std::floor((u - bounds_.lo.x) * sx_)), 0, nx_ - 1);
}
int DefectIndex::cellY(float v) const {
  return std::clamp(int(std::floor((v - bounds_.lo.y) * sy_)), 0, ny_ - 1);
}

}  // namespace dg
