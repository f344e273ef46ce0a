#include "labels/visibility.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "labels/colorimetry.h"

namespace dg {

std::vector<InstanceContrast> instanceContrast(const Image<uint16_t>& instance, const ImageF& linear,
                                               int ring_px) {
  const int w = instance.width, h = instance.height;
  if (instance.channels != 1 || linear.channels != 3 || linear.width != w || linear.height != h)
    throw std::logic_error("instanceContrast: expected a 1-channel instance mask and a 3-channel image of its size");
  if (ring_px < 1) throw std::logic_error("instanceContrast: ring_px must be at least 1");

  // Lightness of every pixel (CIE 15:2004: L* = 116 f(Y / Yn) - 16), Y from the clipped values.
  const cv::Matx33d& m = color::linearSrgbToXyz();
  std::vector<double> lstar(size_t(w) * h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float* p = linear.at(x, y);
      double Y = 0;
      for (int c = 0; c < 3; ++c) Y += m(1, c) / 100.0 * std::clamp(double(p[c]), 0.0, 1.0);
      lstar[size_t(y) * w + x] = 116.0 * color::labF(Y) - 16.0;
    }

  uint16_t max_id = 0;
  for (uint16_t v : instance.data) max_id = std::max(max_id, v);
  std::vector<std::vector<double>> in(size_t(max_id) + 1);
  std::vector<double> ring_sum(size_t(max_id) + 1, 0.0);
  std::vector<int64_t> ring_n(size_t(max_id) + 1, 0);
  std::vector<uint16_t> near;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double l = lstar[size_t(y) * w + x];
      const uint16_t id = instance(x, y);
      if (id != 0) {
        in[id].push_back(l);
        continue;
      }
      // An unlabelled pixel belongs to the ring of every instance within ring_px of it (once each).
      near.clear();
      for (int yy = std::max(0, y - ring_px); yy <= std::min(h - 1, y + ring_px); ++yy)
        for (int xx = std::max(0, x - ring_px); xx <= std::min(w - 1, x + ring_px); ++xx) {
          const uint16_t o = instance(xx, yy);
          if (o != 0 && std::find(near.begin(), near.end(), o) == near.end()) near.push_back(o);
        }
      for (uint16_t o : near) {
        ring_sum[o] += l;
        ++ring_n[o];
      }
    }

  std::vector<InstanceContrast> out;
  for (size_t id = 1; id <= max_id; ++id) {
    std::vector<double>& v = in[id];
    if (v.empty()) continue;
    InstanceContrast c;
    c.id = uint16_t(id);
    c.mask_pixels = int64_t(v.size());
    c.ring_pixels = ring_n[id];
    double s = 0;
    for (double l : v) s += l;
    c.mask_l = s / double(v.size());
    if (c.ring_pixels > 0) {
      c.ring_l = ring_sum[id] / double(c.ring_pixels);
      c.delta_l = c.mask_l - c.ring_l;
      for (double& l : v) l = std::fabs(l - c.ring_l);
      // The 90th percentile by the nearest rank: the smallest value that at least 90% of the
      // pixels do not exceed.
      const size_t k = size_t(std::ceil(0.9 * double(v.size()))) - 1;
      std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(k), v.end());
      c.p90_abs_delta_l = v[k];
    }
    out.push_back(c);
  }
  return out;
}

}  // namespace dg
