#include "http_client.h"

#include <httplib.h>

#include <cctype>
#include <cmath>
#include <csignal>
#include <regex>

#include "cli_options.h"

namespace gvd::cli {
namespace {

void set_timeouts(httplib::Client& c, double seconds) {
  const auto sec = static_cast<time_t>(seconds);
  const auto usec = static_cast<time_t>((seconds - std::floor(seconds)) * 1e6);
  c.set_connection_timeout(sec, usec);
  c.set_read_timeout(sec, usec);
  c.set_write_timeout(sec, usec);
}

/// What went wrong, in words (httplib's own names are terse: "Connection", "Read").
std::string describe(httplib::Error e) {
  switch (e) {
    case httplib::Error::Connection:
      return "cannot connect (connection refused or host unreachable)";
    case httplib::Error::ConnectionTimeout:
      return "connection timed out";
    case httplib::Error::Read:
      return "no answer (connection closed, or read timed out)";
    case httplib::Error::Write:
      return "the server closed the connection while the request was sent (a body larger than "
             "it accepts? see gvd-server --max-body)";
    default:
      return httplib::to_string(e);
  }
}

HttpAnswer answer(const httplib::Result& r, const std::string& what, const std::string& url) {
  if (!r) {
    throw NetworkError{what + " " + url + ": " + describe(r.error())};
  }
  HttpAnswer a;
  a.status = r->status;
  a.body = r->body;
  a.content_type = r->get_header_value("Content-Type");
  a.location = r->get_header_value("Location");
  a.retry_after = r->get_header_value("Retry-After");
  return a;
}

/// http://host[:port][/prefix] -> ("http://host:port", "/prefix"); a missing scheme is http.
std::pair<std::string, std::string> split_url(const std::string& url) {
  static const std::regex re(
      R"(^(?:(https?)://)?([^/:?#\[\]\s]+|\[[0-9A-Fa-f:.]+\])(?::(\d+))?(/[^?#]*)?$)");
  std::smatch m;
  if (!std::regex_match(url, m, re)) {
    throw UsageError{"--server expects http://host[:port][/prefix], got \"" + url + "\""};
  }
  const std::string scheme = m[1].matched ? m[1].str() : "http";
  std::string base = scheme + "://" + m[2].str();
  if (m[3].matched) base += ":" + m[3].str();
  std::string prefix = m[4].matched ? m[4].str() : "";
  while (!prefix.empty() && prefix.back() == '/') prefix.pop_back();
  return {base, prefix};
}

}  // namespace

struct HttpClient::Impl {
  Impl(const std::string& url, double timeout) : client(url), timeout_seconds(timeout) {
    client.set_keep_alive(true);
    client.set_tcp_nodelay(true);  // Nagle + delayed ACK: ~27 ms per keep-alive request otherwise
    client.set_follow_location(false);
    set_timeouts(client, timeout);
  }
  httplib::Client client;
  double timeout_seconds;
};

HttpClient::HttpClient(const std::string& url, double timeout_seconds) {
  // cpp-httplib 0.11.4 writes with plain send(): a server that closes the connection while we
  // send (a body over its --max-body) would kill the process with SIGPIPE. Failed writes are
  // reported as errors instead.
  std::signal(SIGPIPE, SIG_IGN);
  auto [base, prefix] = split_url(url);
  url_ = base + prefix;
  prefix_ = prefix;
  impl_ = std::make_unique<Impl>(base, timeout_seconds);
  if (!impl_->client.is_valid()) throw UsageError{"not a usable server URL: " + url};
}

HttpClient::~HttpClient() = default;

HttpAnswer HttpClient::get(const std::string& path) {
  return answer(impl_->client.Get(prefix_ + path), "GET", url_ + path);
}

HttpAnswer HttpClient::post(const std::string& path, const std::string& body,
                            const std::string& content_type) {
  return answer(impl_->client.Post(prefix_ + path, body, content_type), "POST", url_ + path);
}

HttpAnswer HttpClient::post_multipart(const std::string& path, const std::vector<FilePart>& parts) {
  httplib::MultipartFormDataItems items;
  for (const FilePart& p : parts) {
    items.push_back({p.name, p.content, p.filename, "application/octet-stream"});
  }
  return answer(impl_->client.Post(prefix_ + path, items), "POST", url_ + path);
}

HttpAnswer HttpClient::del(const std::string& path) {
  return answer(impl_->client.Delete(prefix_ + path), "DELETE", url_ + path);
}

HttpAnswer HttpClient::events(
    const std::string& path, double idle_seconds,
    const std::function<bool(const std::string&, const std::string&)>& on_event) {
  // A separate connection: the stream holds it until the job ends.
  httplib::Client stream(split_url(url_).first);
  set_timeouts(stream, impl_->timeout_seconds);
  stream.set_read_timeout(static_cast<time_t>(std::ceil(idle_seconds)), 0);
  stream.set_tcp_nodelay(true);
  int status = 0;
  std::string buffer, body;
  bool stopped = false;
  auto on_response = [&](const httplib::Response& r) {
    status = r.status;
    return true;
  };
  auto on_data = [&](const char* data, size_t n) {
    if (status != 200) {
      body.append(data, n);
      return true;
    }
    buffer.append(data, n);
    size_t end;
    while ((end = buffer.find("\n\n")) != std::string::npos) {
      const std::string block = buffer.substr(0, end);
      buffer.erase(0, end + 2);
      std::string event = "message", payload;
      bool has_data = false;
      size_t start = 0;
      while (start < block.size()) {
        size_t eol = block.find('\n', start);
        if (eol == std::string::npos) eol = block.size();
        std::string line = block.substr(start, eol - start);
        start = eol + 1;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (line.rfind("event:", 0) == 0) {
          event = line.substr(6);
          if (!event.empty() && event[0] == ' ') event.erase(0, 1);
        } else if (line.rfind("data:", 0) == 0) {
          std::string d = line.substr(5);
          if (!d.empty() && d[0] == ' ') d.erase(0, 1);
          if (has_data) payload += '\n';
          payload += d;
          has_data = true;
        }
      }
      if (has_data && !on_event(event, payload)) {
        stopped = true;
        return false;
      }
    }
    return true;
  };
  httplib::Headers headers = {{"Accept", "text/event-stream"}};
  const httplib::Result r = stream.Get(prefix_ + path, headers, on_response, on_data);
  HttpAnswer a;
  if (!r) {
    // Stopping on purpose ends the request with Error::Canceled.
    if (stopped && r.error() == httplib::Error::Canceled) {
      a.status = 200;
      return a;
    }
    throw NetworkError{"GET " + url_ + path + ": " + describe(r.error())};
  }
  a.status = r->status;
  a.body = status == 200 ? std::string() : body;
  a.content_type = r->get_header_value("Content-Type");
  a.retry_after = r->get_header_value("Retry-After");
  return a;
}

std::string url_encode(const std::string& text) {
  static const char* kHex = "0123456789ABCDEF";
  std::string out;
  for (const unsigned char c : text) {
    if (std::isalnum(c) || c == '-' || c == '_' || c == '.' || c == '~') {
      out += static_cast<char>(c);
    } else {
      out += '%';
      out += kHex[c >> 4];
      out += kHex[c & 15];
    }
  }
  return out;
}

}  // namespace gvd::cli
