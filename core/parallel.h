// Parallel loops over independent work items (image tiles, samples). Results must not depend on
// the thread count: callers write each item's result to its own slot and merge in item order.
#pragma once
#include <cstddef>
#include <functional>

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

}  // namespace dg
