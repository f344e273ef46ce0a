// Parallel loops over independent work items (image tiles, samples). Results must not depend on
// the thread count: callers write each item's result to its own slot and merge in item order.
#pragma once
#include <cstddef>
#include <functional>
#include <vector>

namespace dg {

// Limits the worker threads for the lifetime of the object (0 = all cores).
class ThreadLimit {
 public:
  explicit ThreadLimit(int threads);
  ~ThreadLimit();
  ThreadLimit(const ThreadLimit&) = delete;
  ThreadLimit& operator=(const ThreadLimit&) = delete;

 private:
  void* control_ = nullptr;
};

// Calls body(i) for i in [0, n) on the TBB pool, one item per task.
void parallelFor(size_t n, const std::function<void(size_t)>& body);

// Cuts [0, n) into slices of `slice` (the last one shorter) and calls body(s, begin, end) for
// slice s on the TBB pool. The slices do not depend on the thread count, so per-slice results
// gathered in slice order do not either.
void parallelForSlices(size_t n, size_t slice, const std::function<void(size_t, size_t, size_t)>& body);

// Asks the system for the pages of [p, p + bytes) now, on all threads (Linux's
// MADV_POPULATE_WRITE, in slices). A fresh gigabyte-sized array is otherwise paged in by whichever
// thread first writes it, and when one thread fills it that is serial: the scratch reference's
// 20-million-triangle mesh spent seconds in the kernel's page zeroing on one core. Only a hint:
// where the system does not support it nothing happens and the pages come on first write as
// before. The contents are unchanged.
void populateInParallel(void* p, size_t bytes);

// v.resize(n) with the new storage's pages taken in parallel first (populateInParallel); the new
// elements are value-initialised as by resize. For arrays of tens of megabytes and more.
template <class T>
void resizeInParallel(std::vector<T>& v, size_t n) {
  if (n <= v.size()) {
    v.resize(n);
    return;
  }
  if (v.capacity() < n) v.reserve(n);
  populateInParallel(v.data() + v.size(), (n - v.size()) * sizeof(T));
  v.resize(n);
}

}  // namespace dg
