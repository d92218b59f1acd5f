#include "static_files.h"

#include <httplib.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>

namespace gvd::server {
namespace fs = std::filesystem;

namespace {

bool has_index(const fs::path& dir) {
  std::error_code ec;
  return fs::is_regular_file(dir / "index.html", ec);
}

/// "viewer/main.js" -> true; "", "../x", "a//b", ".git/config", "a/.hidden" -> false.
bool is_safe_relative(const std::string& relative) {
  if (relative.empty() || relative.size() > 512) return false;
  size_t start = 0;
  while (start <= relative.size()) {
    size_t slash = relative.find('/', start);
    if (slash == std::string::npos) slash = relative.size();
    const std::string_view segment(relative.data() + start, slash - start);
    if (segment.empty() || segment.front() == '.') return false;
    const bool ok = std::all_of(segment.begin(), segment.end(), [](char c) {
      return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
             c == '-' || c == '_' || c == '.';
    });
    if (!ok) return false;
    start = slash + 1;
  }
  return true;
}

}  // namespace

std::string find_web_root(const std::string& configured, const std::string& exe_path) {
  if (!configured.empty()) {
    if (!has_index(configured)) {
      throw std::runtime_error("--web-root " + configured + " has no index.html");
    }
    return fs::absolute(configured).lexically_normal().string();
  }
  if (exe_path.empty()) return {};
  const fs::path bin = fs::path(exe_path).parent_path();
  for (const fs::path& candidate : {bin / ".." / "web", bin / ".." / "share" / "gvd" / "web"}) {
    if (has_index(candidate)) return candidate.lexically_normal().string();
  }
  return {};
}

std::string_view media_type_for(std::string_view file_name) {
  const size_t dot = file_name.rfind('.');
  const std::string_view ext = dot == std::string_view::npos ? "" : file_name.substr(dot + 1);
  if (ext == "html") return "text/html; charset=utf-8";
  if (ext == "js" || ext == "mjs") return "text/javascript; charset=utf-8";
  if (ext == "css") return "text/css; charset=utf-8";
  if (ext == "json" || ext == "map") return "application/json";
  if (ext == "svg") return "image/svg+xml";
  if (ext == "png") return "image/png";
  if (ext == "ico") return "image/x-icon";
  if (ext == "txt" || ext == "md" || file_name.ends_with("LICENSE"))
    return "text/plain; charset=utf-8";
  return "application/octet-stream";
}

bool StaticFiles::serve(const httplib::Request& req, httplib::Response& res,
                        const std::string& relative) const {
  if (root_.empty() || !is_safe_relative(relative)) return false;
  const fs::path file = fs::path(root_) / relative;
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) return false;
  const uintmax_t size = fs::file_size(file, ec);
  if (ec) return false;
  const auto mtime = fs::last_write_time(file, ec);
  if (ec) return false;
  char etag[64];
  std::snprintf(etag, sizeof etag, "\"%jx-%llx\"", size,
                static_cast<unsigned long long>(mtime.time_since_epoch().count()));
  res.set_header("ETag", etag);
  res.set_header("Cache-Control", "no-cache");
  res.set_header("X-Content-Type-Options", "nosniff");
  const std::string inm = req.get_header_value("If-None-Match");
  if (!inm.empty() && (inm == "*" || inm.find(etag) != std::string::npos)) {
    res.status = 304;
    return true;
  }
  std::ifstream in(file, std::ios::binary);
  if (!in) return false;
  std::string body((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  res.set_content(std::move(body), std::string(media_type_for(file.filename().string())));
  return true;
}

}  // namespace gvd::server
