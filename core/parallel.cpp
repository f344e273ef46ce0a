#include "core/parallel.h"

#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>

#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

namespace dg {

ThreadLimit::ThreadLimit(int threads) {
  if (threads > 0)
    control_ = new tbb::global_control(tbb::global_control::max_allowed_parallelism, size_t(threads));
}

ThreadLimit::~ThreadLimit() { delete static_cast<tbb::global_control*>(control_); }

void parallelFor(size_t n, const std::function<void(size_t)>& body) {
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) body(i);
  });
}

void parallelForSlices(size_t n, size_t slice, const std::function<void(size_t, size_t, size_t)>& body) {
  parallelFor((n + slice - 1) / slice, [&](size_t s) { body(s, s * slice, std::min(n, (s + 1) * slice)); });
}

void populateInParallel(void* p, size_t bytes) {
#ifdef MADV_POPULATE_WRITE
  constexpr size_t kSlice = size_t(32) << 20;  // 32 MiB a task
  if (bytes < kSlice) return;                  // not worth the tasks: first writes page it in
  const uintptr_t page = uintptr_t(sysconf(_SC_PAGESIZE));
  const uintptr_t a = (uintptr_t(p) + page - 1) / page * page;  // whole pages inside the range
  const uintptr_t b = (uintptr_t(p) + bytes) / page * page;
  if (b <= a) return;
  parallelForSlices(size_t(b - a), kSlice, [&](size_t, size_t begin, size_t end) {
    madvise(reinterpret_cast<void*>(a + begin), end - begin, MADV_POPULATE_WRITE);  // a failure leaves it to first write
  });
#else
  (void)p;
  (void)bytes;
#endif
}

}  // namespace dg
