#include "gvd/common/peak_memory.h"

#include <fstream>
#include <string>

namespace gvd {

uint64_t peak_rss_bytes() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmHWM:", 0) == 0) {
      try {
        return static_cast<uint64_t>(std::stoull(line.substr(6))) * 1024;  // kB
      } catch (...) {
        return 0;
      }
    }
  }
  return 0;
}

}  // namespace gvd
