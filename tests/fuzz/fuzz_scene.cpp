// libFuzzer targets for the scene parsers (`make fuzz`; tests/fuzz/README.md). One source, one
// target per format: GVD_FUZZ_FORMAT names it at compile time. Every input must either parse
// or fail with gvd::Error (which says what and where); anything else — another exception, a
// crash, a sanitizer report, a hang — is a finding.

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "gvd/common/error.h"
#include "gvd/scene/load_scene.h"

namespace {

// Small limits keep each run fast: a limit refused is an answer like any other.
gvd::scene::SceneLimits fuzz_limits() {
  gvd::scene::SceneLimits limits;
  limits.max_objects = 64;
  limits.max_simplices = 4096;
  return limits;
}

#if defined(GVD_FUZZ_PARTS)
// The multipart target: parts separated by a line "--part--" (the server's multipart framing
// is cpp-httplib's; what gvd does with the parts is parse_scene_parts).
void run_parts(std::span<const uint8_t> bytes) {
  const std::string_view text(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  constexpr std::string_view kSeparator = "\n--part--\n";
  std::vector<gvd::scene::ScenePart> parts;
  size_t at = 0;
  while (parts.size() < 8) {
    const size_t end = text.find(kSeparator, at);
    const size_t stop = end == std::string_view::npos ? text.size() : end;
    gvd::scene::ScenePart part;
    part.label = "p" + std::to_string(parts.size());
    part.bytes = bytes.subspan(at, stop - at);
    part.source = "part \"" + part.label + "\"";
    parts.push_back(part);
    if (end == std::string_view::npos) break;
    at = end + kSeparator.size();
  }
  (void)gvd::scene::parse_scene_parts(parts, fuzz_limits());
}
#endif

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::span<const uint8_t> bytes(data, size);
  try {
#if defined(GVD_FUZZ_PARTS)
    run_parts(bytes);
#else
    (void)gvd::scene::parse_scene_bytes(bytes, gvd::scene::SceneFormat::GVD_FUZZ_FORMAT, "fuzz",
                                        fuzz_limits());
#endif
  } catch (const gvd::Error&) {
    // An answer: the input was refused with a message.
  }
  return 0;
}
