#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "gvd/common/peak_memory.h"

namespace gvd {
namespace {

// The VmFlags of the mapping of /proc/self/smaps that holds `address` ("" if none does).
[[maybe_unused]] std::string vm_flags_at(uintptr_t address) {
  std::ifstream smaps("/proc/self/smaps");
  std::string line;
  bool inside = false;
  while (std::getline(smaps, line)) {
    uintptr_t begin = 0, end = 0;
    char dash = 0;
    std::istringstream head(line);
    if (head >> std::hex >> begin >> dash >> end && dash == '-' &&
        line.find(':') > line.find(' ')) {
      inside = begin <= address && address < end;
    } else if (inside && line.rfind("VmFlags:", 0) == 0) {
      return line.substr(8) + " ";
    }
  }
  return "";
}

[[maybe_unused]] bool has_flag(const std::string& flags, const char* flag) {
  return flags.find(std::string(" ") + flag + " ") != std::string::npos;
}

// A small computation's heap asks for transparent huge pages (one fault maps 2 MiB, not
// 4 KiB); the room it grows into next is asked for too, and a computation that passes small
// asks for none from then on. Read from the kernel's own record of the advice (smaps).
TEST(HeapPolicy, SmallComputationsAskForHugePagesUntilTheyGrow) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "the sanitizer's allocator does not use the brk heap this policy advises";
#else
  if (!std::filesystem::exists("/sys/kernel/mm/transparent_hugepage/enabled")) {
    GTEST_SKIP() << "this kernel has no transparent huge pages";
  }
  use_returning_heap(true);
  heap_computation_starts();
  // Blocks below the mapped-block threshold, allocated after the advice (6 MiB, within the
  // 8 MiB of room grown before it): the highest lies in the heap's advised part, and so does
  // the heap's top.
  std::vector<std::unique_ptr<char[]> > blocks;
  uintptr_t last = 0;
  for (int i = 0; i < 96; ++i) {
    blocks.emplace_back(new char[64 << 10]);
    last = std::max(last, reinterpret_cast<uintptr_t>(blocks.back().get()));
  }
  const uintptr_t top = reinterpret_cast<uintptr_t>(sbrk(0)) - 1;
  EXPECT_TRUE(has_flag(vm_flags_at(last), "hg")) << vm_flags_at(last);
  EXPECT_TRUE(has_flag(vm_flags_at(top), "hg")) << vm_flags_at(top);

  heap_computation_grows(kSmallComputationLeaves);
  EXPECT_TRUE(has_flag(vm_flags_at(last), "nh")) << vm_flags_at(last);
  EXPECT_FALSE(has_flag(vm_flags_at(last), "hg")) << vm_flags_at(last);
  // Not asked again in the same computation, even at a checkpoint that finds it small.
  heap_checkpoint(1);
  EXPECT_FALSE(has_flag(vm_flags_at(last), "hg")) << vm_flags_at(last);

  // The next computation starts small again.
  heap_computation_starts();
  EXPECT_TRUE(has_flag(vm_flags_at(last), "hg")) << vm_flags_at(last);
  // And a process that goes back to the plain policy asks for none.
  use_returning_heap(false);
  EXPECT_FALSE(has_flag(vm_flags_at(last), "hg")) << vm_flags_at(last);
#endif
}

}  // namespace
}  // namespace gvd
