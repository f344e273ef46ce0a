#include "core/memory.h"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace dg {

namespace {

std::string readSysFile(const std::string& below) {
  std::ifstream f("/sys/fs/cgroup/" + below);
  if (!f) return "";
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// A limit file's value: a byte count, or "max" (v2) or a huge number (v1: the largest multiple of
// the page size below 2^63) for none.
uint64_t parseLimit(const std::string& text) {
  if (text.empty() || text.compare(0, 3, "max") == 0) return 0;
  char* end = nullptr;
  unsigned long long v = std::strtoull(text.c_str(), &end, 10);
  if (end == text.c_str() || v >= (1ull << 60)) return 0;
  return uint64_t(v);
}

uint64_t pageSize() {
  long p = sysconf(_SC_PAGESIZE);
  return p > 0 ? uint64_t(p) : 4096;
}

}  // namespace

uint64_t cgroupLimitFrom(const std::string& proc_self_cgroup,
                         std::string (*read_cgroup_file)(const std::string&)) {
  uint64_t best = 0;
  auto take = [&](uint64_t v) {
    if (v > 0 && (best == 0 || v < best)) best = v;
  };
  std::istringstream lines(proc_self_cgroup);
  std::string line;
  while (std::getline(lines, line)) {
    // "hierarchy-id:controllers:path"; v2 is "0::path", v1's memory controller "N:memory:path".
    size_t a = line.find(':'), b = a == std::string::npos ? a : line.find(':', a + 1);
    if (b == std::string::npos) continue;
    const std::string ctrl = line.substr(a + 1, b - a - 1), path = line.substr(b + 1);
    std::string rel = (path.empty() || path == "/") ? "" : path.substr(path.front() == '/' ? 1 : 0) + "/";
    bool v1_memory = false;
    for (size_t s = 0; s <= ctrl.size();) {
      size_t e = ctrl.find(',', s);
      if (e == std::string::npos) e = ctrl.size();
      if (ctrl.compare(s, e - s, "memory") == 0) v1_memory = true;
      s = e + 1;
    }
    // Inside a container the cgroup's own folder is often mounted as the root, so the file is
    // looked for both under the path and at the top.
    if (ctrl.empty() && line.compare(0, 2, "0:") == 0) {
      take(parseLimit(read_cgroup_file(rel + "memory.max")));
      if (!rel.empty()) take(parseLimit(read_cgroup_file("memory.max")));
    } else if (v1_memory) {
      take(parseLimit(read_cgroup_file("memory/" + rel + "memory.limit_in_bytes")));
      if (!rel.empty()) take(parseLimit(read_cgroup_file("memory/memory.limit_in_bytes")));
    }
  }
  return best;
}

MemoryLimit memoryLimit() {
  MemoryLimit m;
  long pages = sysconf(_SC_PHYS_PAGES);
  m.bytes = m.total = pages > 0 ? uint64_t(pages) * pageSize() : ~uint64_t(0);
  m.source = "the machine's memory";
  std::ifstream cg("/proc/self/cgroup");
  if (cg) {
    std::stringstream ss;
    ss << cg.rdbuf();
    uint64_t c = cgroupLimitFrom(ss.str(), readSysFile);
    if (c > 0 && c < m.bytes) {
      m.bytes = m.total = c;
      m.source = "the cgroup's memory limit";
    }
  }
  rlimit rl{};
  if (getrlimit(RLIMIT_AS, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY) {
    // What is left of the address space: the limit less what is mapped now (statm's first field).
    uint64_t used = 0;
    if (std::ifstream st("/proc/self/statm"); st) {
      unsigned long long v = 0;
      if (st >> v) used = uint64_t(v) * pageSize();
    }
    uint64_t left = uint64_t(rl.rlim_cur) > used ? uint64_t(rl.rlim_cur) - used : 0;
    if (left < m.bytes) {
      m.bytes = left;
      m.total = uint64_t(rl.rlim_cur);
      m.source = "ulimit -v";
    }
  }
  return m;
}

std::string formatBytes(uint64_t bytes) {
  char buf[64];
  const double gib = double(bytes) / double(1ull << 30);
  if (gib >= 1.0)
    std::snprintf(buf, sizeof buf, "%.1f GiB", gib);
  else
    std::snprintf(buf, sizeof buf, "%.0f MiB", double(bytes) / double(1ull << 20));
  return buf;
}

}  // namespace dg
