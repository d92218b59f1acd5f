#pragma once

#include <memory>
#include <string>

#include "server_options.h"

namespace gvd::server {

/// The HTTP front: cpp-httplib configured at run time (thread pool, timeouts, keep-alive,
/// payload limit, MIME types), a pre-routing guard that refuses bad requests before their body
/// is read, the routes of routes.h, one catch boundary per request that turns errors into
/// problem documents, request logs and metrics. Owns the JobManager.
class HttpServer {
 public:
  /// Opens the store (recovering its jobs) and runs one tiny computation with the configured
  /// backend; throws gvd::Error when either fails.
  explicit HttpServer(const ServerOptions& options);
  ~HttpServer();
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  /// Binds the listening socket; returns the port (the chosen one for --port 0).
  int bind();
  /// Starts the job workers and serves until shutdown(). Returns false when listening failed.
  bool serve();
  /// Graceful stop (SIGTERM): /readyz and new jobs answer 503, running jobs get the grace
  /// period, then the listener closes and unfinished jobs stay persisted for the next start.
  void shutdown();
  /// The compute backend in use (what the warm-up computation reported).
  const std::string& backend() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace gvd::server
