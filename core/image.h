// Interleaved image buffer, row-major, channel-interleaved.
#pragma once
#include <cstddef>
#include <vector>

namespace dg {

template <class T>
struct Image {
  int width = 0, height = 0, channels = 0;
  std::vector<T> data;
  Image() = default;
  Image(int w, int h, int c, T fill = T()) : width(w), height(h), channels(c), data(size_t(w) * h * c, fill) {}
  T* at(int x, int y) { return &data[(size_t(y) * width + x) * channels]; }
  const T* at(int x, int y) const { return &data[(size_t(y) * width + x) * channels]; }
  T& operator()(int x, int y, int ch = 0) { return data[(size_t(y) * width + x) * channels + ch]; }
  T operator()(int x, int y, int ch = 0) const { return data[(size_t(y) * width + x) * channels + ch]; }
  bool empty() const { return data.empty(); }
};

using ImageF = Image<float>;

}  // namespace dg
