#pragma once

#include <array>
#include <string_view>

namespace gvd::server {

/// Every route of the API: the method, the regular expression cpp-httplib matches (0.11.4 has
/// no path parameters), the OpenAPI path it is documented under, and the name used in logs and
/// metrics. The server registers exactly these; a test checks /openapi.json lists each one.
struct Route {
  std::string_view method;
  std::string_view pattern;
  std::string_view openapi_path;
};

inline constexpr std::string_view kJobId = "([^/]+)";

inline constexpr std::array<Route, 27> kRoutes = {{
    {"GET", R"(/)", "/"},
    {"GET", R"(/viewer/(.+))", "/viewer/{path}"},
    {"GET", R"(/vendor/(.+))", "/vendor/{path}"},
    {"GET", R"(/healthz)", "/healthz"},
    {"GET", R"(/readyz)", "/readyz"},
    {"GET", R"(/metrics)", "/metrics"},
    {"GET", R"(/openapi.json)", "/openapi.json"},
    {"POST", R"(/v1/jobs)", "/v1/jobs"},
    {"GET", R"(/v1/jobs)", "/v1/jobs"},
    {"GET", R"(/v1/jobs/([^/]+))", "/v1/jobs/{id}"},
    {"DELETE", R"(/v1/jobs/([^/]+))", "/v1/jobs/{id}"},
    {"GET", R"(/v1/jobs/([^/]+)/events)", "/v1/jobs/{id}/events"},
    {"GET", R"(/v1/jobs/([^/]+)/gvd\.glb)", "/v1/jobs/{id}/gvd.glb"},
    {"GET", R"(/v1/jobs/([^/]+)/gvd\.gltf)", "/v1/jobs/{id}/gvd.gltf"},
    {"GET", R"(/v1/jobs/([^/]+)/gvd\.json)", "/v1/jobs/{id}/gvd.json"},
    {"GET", R"(/v1/jobs/([^/]+)/graph)", "/v1/jobs/{id}/graph"},
    {"GET", R"(/v1/jobs/([^/]+)/result\.gvd)", "/v1/jobs/{id}/result.gvd"},
    {"GET", R"(/v1/jobs/([^/]+)/objects/(.+)/neighbors)",
     "/v1/jobs/{id}/objects/{label}/neighbors"},
    {"GET", R"(/v1/jobs/([^/]+)/nearest)", "/v1/jobs/{id}/nearest"},
    {"POST", R"(/v1/jobs/([^/]+)/nearest)", "/v1/jobs/{id}/nearest"},
    {"POST", R"(/v1/jobs/([^/]+)/paths)", "/v1/jobs/{id}/paths"},
    {"GET", R"(/v1/jobs/([^/]+)/explode)", "/v1/jobs/{id}/explode"},
    {"GET", R"(/v1/jobs/([^/]+)/tight)", "/v1/jobs/{id}/tight"},
    {"GET", R"(/v1/jobs/([^/]+)/contacts)", "/v1/jobs/{id}/contacts"},
    {"GET", R"(/v1/jobs/([^/]+)/field\.npy)", "/v1/jobs/{id}/field.npy"},
    {"GET", R"(/v1/jobs/([^/]+)/labels\.npy)", "/v1/jobs/{id}/labels.npy"},
    {"GET", R"(/problems/([a-z-]+))", "/problems/{name}"},
}};

}  // namespace gvd::server
