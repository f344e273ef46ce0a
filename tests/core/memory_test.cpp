#include "core/memory.h"

#include <gtest/gtest.h>

#include <map>
#include <string>

namespace dg {
namespace {

std::map<std::string, std::string> g_files;  // path below /sys/fs/cgroup -> contents
std::string readFake(const std::string& p) {
  auto it = g_files.find(p);
  return it == g_files.end() ? "" : it->second;
}

TEST(MemoryLimit, CgroupV2LimitOfTheProcesssOwnGroup) {
  g_files = {{"user.slice/job/memory.max", "2147483648\n"}};
  EXPECT_EQ(cgroupLimitFrom("0::/user.slice/job\n", readFake), 2147483648ull);
  // "max" is no limit; a container that mounts its own group as the root has the file at the top.
  g_files = {{"user.slice/job/memory.max", "max\n"}};
  EXPECT_EQ(cgroupLimitFrom("0::/user.slice/job\n", readFake), 0u);
  g_files = {{"memory.max", "1073741824\n"}};
  EXPECT_EQ(cgroupLimitFrom("0::/user.slice/job\n", readFake), 1073741824ull);
  EXPECT_EQ(cgroupLimitFrom("0::/\n", readFake), 1073741824ull);
}

TEST(MemoryLimit, CgroupV1MemoryController) {
  const std::string self = "9:name=systemd:/\n5:devices:/\n4:memory:/process_api/abc\n3:cpu,cpuacct:/\n";
  g_files = {{"memory/process_api/abc/memory.limit_in_bytes", "8589934592\n"}};
  EXPECT_EQ(cgroupLimitFrom(self, readFake), 8589934592ull);
  // v1 writes "no limit" as the largest page multiple below 2^63.
  g_files = {{"memory/process_api/abc/memory.limit_in_bytes", "9223372036854771712\n"}};
  EXPECT_EQ(cgroupLimitFrom(self, readFake), 0u);
  // The controller may share its hierarchy with others; the tighter of two files counts.
  g_files = {{"memory/memory.limit_in_bytes", "4294967296\n"}, {"memory/g/memory.limit_in_bytes", "8589934592\n"}};
  EXPECT_EQ(cgroupLimitFrom("4:cpuset,memory:/g\n", readFake), 4294967296ull);
  // Malformed lines and files are no limit, not an error.
  g_files = {{"memory/g/memory.limit_in_bytes", "lots\n"}};
  EXPECT_EQ(cgroupLimitFrom("garbage\n4:memory:/g\n\n", readFake), 0u);
  EXPECT_EQ(cgroupLimitFrom("", readFake), 0u);
}

TEST(MemoryLimit, ThisProcesssLimitIsSomeMemory) {
  const MemoryLimit m = memoryLimit();
  EXPECT_GT(m.bytes, 64ull << 20);
  EXPECT_GE(m.total, m.bytes);
  EXPECT_FALSE(m.source.empty());
}

TEST(MemoryLimit, FormatBytes) {
  EXPECT_EQ(formatBytes(512ull << 20), "512 MiB");
  EXPECT_EQ(formatBytes(3ull << 30), "3.0 GiB");
  EXPECT_EQ(formatBytes(uint64_t(12.34 * double(1ull << 30))), "12.3 GiB");
}

}  // namespace
}  // namespace dg
