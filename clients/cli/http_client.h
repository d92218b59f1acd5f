#pragma once

// A small HTTP client for `gvd --server`: the only file that sees cpp-httplib is
// http_client.cpp (cpp-httplib is a heavy header: compiled once, behind a thin interface).

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace gvd::cli {

/// An HTTP answer: status, body and the headers the remote commands look at.
struct HttpAnswer {
  int status = 0;
  std::string body;
  std::string content_type;
  std::string location;     ///< Location (202 / 303)
  std::string retry_after;  ///< Retry-After (503), as sent
};

/// One file of a multipart/form-data body (`name` = the part name = the object label).
struct FilePart {
  std::string name;
  std::string filename;
  std::string content;
};

/// The server could not be reached or stopped answering (refused, reset, timed out).
struct NetworkError {
  std::string message;
};

/// Requests to one server. Keeps its connection alive between requests. Every method throws
/// NetworkError when no HTTP answer came back; any status is returned as an answer.
class HttpClient {
 public:
  /// `url`: [http://]host[:port][/prefix] (https when cpp-httplib was built with OpenSSL);
  /// anything else is a UsageError. `timeout_seconds`: for connecting and each read/write.
  HttpClient(const std::string& url, double timeout_seconds);
  ~HttpClient();
  HttpClient(const HttpClient&) = delete;
  HttpClient& operator=(const HttpClient&) = delete;

  HttpAnswer get(const std::string& path);
  HttpAnswer post(const std::string& path, const std::string& body,
                  const std::string& content_type);
  HttpAnswer post_multipart(const std::string& path, const std::vector<FilePart>& parts);
  HttpAnswer del(const std::string& path);

  /// GET of a text/event-stream: calls `on_event(event, data)` for every event (comments
  /// skipped; `event` defaults to "message"); stops when it returns false or the stream ends.
  /// A non-200 answer is returned with its body and no event is delivered. Reads may wait up
  /// to `idle_seconds` between events (the server sends a heartbeat every 10 s).
  HttpAnswer events(const std::string& path, double idle_seconds,
                    const std::function<bool(const std::string&, const std::string&)>& on_event);

  const std::string& url() const { return url_; }

 private:
  struct Impl;
  std::string url_;     ///< base + prefix, for messages
  std::string prefix_;  ///< a path the server is mounted under ("" or "/gvd")
  std::unique_ptr<Impl> impl_;
};

/// Percent-encodes everything but unreserved characters (RFC 3986), for path segments and
/// query values.
std::string url_encode(const std::string& text);

}  // namespace gvd::cli
