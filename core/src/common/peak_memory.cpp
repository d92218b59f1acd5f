#include "gvd/common/peak_memory.h"

#include <malloc.h>

#include <fstream>
#include <string>

namespace gvd {

namespace {

// A "Name:  <n> kB" line of /proc/self/status, in bytes (0 if absent).
uint64_t status_kb(const std::string& name) {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind(name, 0) == 0) {
      try {
        return static_cast<uint64_t>(std::stoull(line.substr(name.size()))) * 1024;
      } catch (...) {
        return 0;
      }
    }
  }
  return 0;
}

}  // namespace

uint64_t peak_rss_bytes() { return status_kb("VmHWM:"); }

uint64_t rss_bytes() { return status_kb("VmRSS:"); }

uint64_t file_rss_bytes() { return status_kb("RssFile:"); }

void use_returning_heap() {
  // Setting the threshold also stops glibc from moving it (and the trim threshold with it).
  mallopt(M_MMAP_THRESHOLD, kReturnedBlockBytes);
}

}  // namespace gvd
