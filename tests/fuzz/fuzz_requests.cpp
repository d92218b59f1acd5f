// libFuzzer targets for what the server and the queries read besides scenes (`make fuzz`):
// job parameters (the query string's name=value pairs and the "params" JSON), batch query
// points, and stored results. GVD_FUZZ_TARGET names the target at compile time. Every input
// must either be read or fail with gvd::Error.

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "gvd/common/error.h"
#include "gvd/io/result_file.h"
#include "gvd/query/gvd_index.h"
#if defined(GVD_FUZZ_JOB_PARAMS)
#include "job_params.h"
#include "server_options.h"
#endif

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
#if defined(GVD_FUZZ_JOB_PARAMS)
    // First line: the "params" JSON; then name=value lines, as a query string gives them.
    const size_t eol = text.find('\n');
    const std::string json(text.substr(0, eol));
    gvd::server::JobParams params;
    try {
      params = gvd::server::JobParams::from_json(json);
    } catch (const gvd::Error&) {
    }
    size_t at = eol == std::string_view::npos ? text.size() : eol + 1;
    while (at < text.size()) {
      const size_t end = std::min(text.find('\n', at), text.size());
      const std::string_view line = text.substr(at, end - at);
      const size_t eq = line.find('=');
      if (eq != std::string_view::npos) {
        try {
          params.set(std::string(line.substr(0, eq)), std::string(line.substr(eq + 1)));
        } catch (const gvd::Error&) {
        }
      }
      at = end + 1;
    }
    gvd::server::ServerOptions server;
    for (const int dimension : {2, 3}) {
      try {
        params.check(dimension, server);
        (void)params.pipeline_options(server);
      } catch (const gvd::Error&) {
      }
    }
    (void)gvd::server::JobParams::from_json(params.to_json());  // its own form reads back
#elif defined(GVD_FUZZ_POINTS)
    for (const int dimension : {2, 3}) {
      try {
        (void)gvd::query::parse_points_json(text, dimension);
      } catch (const gvd::Error&) {
      }
    }
#elif defined(GVD_FUZZ_RESULT)
    (void)gvd::io::load_result_bytes(std::span<const uint8_t>(data, size));
#else
#error "GVD_FUZZ_JOB_PARAMS, GVD_FUZZ_POINTS or GVD_FUZZ_RESULT"
#endif
  } catch (const gvd::Error&) {
  }
  return 0;
}
