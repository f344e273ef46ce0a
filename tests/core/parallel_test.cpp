// Parallel helpers: the pages of a large array taken on all threads, its contents untouched.
#include "core/parallel.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <vector>

namespace dg {
namespace {

// Populating pages is only a request for memory: what is already written stays (a wrong madvise
// advice, MADV_DONTNEED or MADV_REMOVE, would hand back zero pages here).
TEST(Parallel, PopulatingKeepsWhatIsWritten) {
  const size_t n = size_t(24) << 20;  // 96 MiB of uint32: three slices and a part
  std::vector<uint32_t> v(n);
  for (size_t i = 0; i < n; ++i) v[i] = uint32_t(i * 2654435761u);
  // Unaligned at both ends: the pages inside the range are populated, the rest left alone.
  populateInParallel(reinterpret_cast<char*>(v.data()) + 5, n * sizeof(uint32_t) - 11);
  size_t wrong = 0;
  for (size_t i = 0; i < n; ++i) wrong += v[i] != uint32_t(i * 2654435761u);
  EXPECT_EQ(wrong, 0u);
}

TEST(Parallel, ResizeInParallelIsResize) {
  std::vector<float> v(1000);
  for (size_t i = 0; i < v.size(); ++i) v[i] = float(i) + 0.5f;
  const size_t n = size_t(20) << 20;  // 80 MiB: past the size where the pages are taken in slices
  resizeInParallel(v, n);
  ASSERT_EQ(v.size(), n);
  for (size_t i = 0; i < 1000; ++i) ASSERT_EQ(v[i], float(i) + 0.5f) << i;
  EXPECT_TRUE(std::all_of(v.begin() + 1000, v.end(), [](float x) { return x == 0.0f; }));
  // Storage reserved beforehand, and written: the new elements are still value-initialised.
  std::vector<int> w;
  w.reserve(n);
  w.push_back(7);
  resizeInParallel(w, n);
  EXPECT_EQ(w[0], 7);
  EXPECT_EQ(std::count(w.begin(), w.end(), 0), std::ptrdiff_t(n - 1));
  // Shrinking and small arrays are plain resizes.
  resizeInParallel(w, 3);
  EXPECT_EQ(w, (std::vector<int>{7, 0, 0}));
  resizeInParallel(w, 5);
  EXPECT_EQ(w, (std::vector<int>{7, 0, 0, 0, 0}));
}

}  // namespace
}  // namespace dg
