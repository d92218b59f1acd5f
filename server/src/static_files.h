#pragma once

#include <string>
#include <string_view>

namespace httplib {
struct Request;
struct Response;
}  // namespace httplib

namespace gvd::server {

/// Where the web viewer's files are (a directory holding index.html, viewer/ and vendor/):
/// `configured` when not empty (a UsageError-worthy std::runtime_error when it has no
/// index.html), else the first of <dir of exe>/../web (the build tree: build/web next to
/// build/server/gvd-server) and <dir of exe>/../share/gvd/web (an installed layout) that holds
/// an index.html; empty when there is none (the server then answers `/` with a short page).
std::string find_web_root(const std::string& configured, const std::string& exe_path);

/// The media type answered for a file name, by extension (JavaScript modules must be
/// text/javascript or the browser refuses them).
std::string_view media_type_for(std::string_view file_name);

/// Read-only static files under one root, for the web viewer. Paths are checked (segments of
/// letters, digits, '-', '_', '.', none starting with '.'), so nothing outside the root is
/// reachable. Answers carry an ETag (size + modification time) and `Cache-Control: no-cache`
/// (the browser revalidates, a current copy costs a 304), and honour If-None-Match.
class StaticFiles {
 public:
  explicit StaticFiles(std::string root) : root_(std::move(root)) {}

  bool available() const { return !root_.empty(); }
  const std::string& root() const { return root_; }

  /// Serves `relative` (e.g. "viewer/main.js"). False when there is no such file (the caller
  /// answers 404); the body is read per request, so a rebuilt viewer is served at once.
  bool serve(const httplib::Request& req, httplib::Response& res,
             const std::string& relative) const;

 private:
  std::string root_;
};

}  // namespace gvd::server
