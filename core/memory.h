// How much memory this process may use, so that a request that cannot fit (a 16384 x 16384 frame
// on a small machine or in a container) is refused with a message before anything is written,
// instead of ending in std::bad_alloc or, with Linux's overcommit, in the kernel's OOM killer,
// which leaves no message at all.
#pragma once
#include <cstdint>
#include <string>

namespace dg {

struct MemoryLimit {
  uint64_t bytes = 0;  // what is left under the tightest of the limits below
  uint64_t total = 0;  // that limit itself (for ulimit -v it counts what is mapped already)
  std::string source;  // which one: "the machine's memory", "the cgroup's memory limit", "ulimit -v"
};

// The tightest of: the machine's physical memory; the memory limit of this process's cgroup
// (cgroup v2 memory.max or v1 memory.limit_in_bytes, as containers set them); and the address
// space left under RLIMIT_AS (ulimit -v). Swap is not counted: a frame that fits only in swap
// renders too slowly to be meant.
MemoryLimit memoryLimit();

// Internal: the limit of a cgroup hierarchy, given the contents of /proc/self/cgroup and a reader
// of files below /sys/fs/cgroup (returns "" for a file that is not there). 0 means no limit.
// Exposed for the unit test.
uint64_t cgroupLimitFrom(const std::string& proc_self_cgroup,
                         std::string (*read_cgroup_file)(const std::string& path_below_sys_fs_cgroup));

// "12.3 GiB", "512 MiB".
std::string formatBytes(uint64_t bytes);

}  // namespace dg
