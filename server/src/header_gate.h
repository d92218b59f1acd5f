#pragma once

#include <httplib.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace gvd::server {

/// How long and how many connections may wait for their request headers.
struct GateLimits {
  double header_seconds = 10;  ///< from a request's first byte to the end of its headers
  double idle_seconds = 5;     ///< for the first byte (a new or a kept-alive connection)
  /// Bytes that may wait without the end of the headers: past them the gate answers 431
  /// itself (or, if the request line alone is that long, lets httplib answer 414). The
  /// header limit plus a request line.
  size_t max_header_bytes = 16384 + 8192;
  /// Per remote address: connections that have sent part of a request's headers and wait for
  /// the rest (a slowloris holds partial headers); past it the oldest such one is closed. A
  /// kept-alive connection idle between requests holds nothing but a descriptor and is not
  /// counted here (a busy client, or a proxy, keeps many of them), only in `max_waiting`.
  int max_waiting_per_client = 64;
  /// In all, idle or partial; past it the oldest waiting connection of the address with the
  /// most waiting ones is closed (so one address cannot push every other one out).
  int max_waiting = 4096;
  /// The whole answer (status line, headers, body) the gate sends before closing a
  /// connection itself: 408 (headers too slow) or 431 (a header line over cpp-httplib's
  /// 8 KiB, or headers over max_header_bytes). Empty: a bare status line.
  std::function<std::string(int status)> answer;
  /// Requests whose headers have arrived and that wait for a thread. When every thread is
  /// busy and this many wait, a further request is not queued: the gate answers it at once
  /// with `overloaded` and closes the connection (0: answered so whenever no thread is free).
  int max_queued = 256;
  /// The whole answer (status line, headers, body) to a request refused because the threads
  /// and the queue are full, from its method and path (target without the query). It runs
  /// in the gate's thread or the accept thread, with the gate locked: it must be quick and
  /// must not call back into the server. Empty: a bare 503.
  std::function<std::string(std::string_view method, std::string_view path)> overloaded;
  /// Health probes' lane: a request whose request line is `GET <path>` (then a space or a
  /// `?`) for one of these paths is served by `priority_threads` threads of its own, never
  /// queued behind other requests (a probe must say within its timeout whether the process
  /// lives, however long the other requests take). When they are busy too and
  /// `max_queued` probes wait, the overloaded answer is sent as for any request.
  std::vector<std::string> priority_paths;
  int priority_threads = 1;
  /// Request bodies are read in the threads. At most this many threads read one at once
  /// (0: no cap): GatedServer::begin_body refuses more, so that slow bodies cannot take every
  /// thread. A body must arrive within `body_seconds` + its length / `min_body_rate`
  /// (bytes per second) of the moment its reading began; past that the read fails and
  /// GatedServer::body_timed_out() says why (the connection is then closed).
  int max_body_readers = 0;
  /// Of those, how many bodies one remote address may be reading at once (0: no cap of its
  /// own), so that one client cannot take every reader slot from the others.
  int max_body_readers_per_client = 0;
  /// Bytes of request bodies (their Content-Length) held at once, from begin_body until the
  /// request is over, when the body and what its handler made of it are gone (0: no budget).
  /// A body that would take the sum past it is refused; one larger than it, always.
  uint64_t max_body_bytes = 0;
  double body_seconds = 30;
  double min_body_rate = 1 << 20;
};

/// Whether a request body may be read now (GatedServer::begin_body), or which limit refuses it.
enum class BodyAdmission {
  kAdmitted,
  kTooManyReaders,    ///< GateLimits::max_body_readers bodies are being read
  kTooManyForClient,  ///< the remote address is reading max_body_readers_per_client bodies
  kOverBudget,        ///< the bodies held would exceed GateLimits::max_body_bytes
};

/// What the gate has done since the server started (the /metrics counters).
struct GateCounts {
  uint64_t waiting = 0;              ///< connections waiting for headers now
  uint64_t timed_out = 0;            ///< closed because their headers did not arrive in time
  uint64_t evicted = 0;              ///< closed to make room (per-client or total cap)
  uint64_t busy = 0;                 ///< threads running a request now
  uint64_t queued = 0;               ///< requests with complete headers waiting for a thread now
  uint64_t overloaded = 0;           ///< answered by the gate because threads and queue were full
  uint64_t body_readers = 0;         ///< threads reading a request body now
  uint64_t body_bytes = 0;           ///< bytes of the bodies held now (being read or handled)
  uint64_t body_refused = 0;         ///< bodies refused since start: max_body_readers were read
  uint64_t body_refused_client = 0;  ///< ... their address read max_body_readers_per_client
  uint64_t body_refused_bytes = 0;   ///< ... they would have taken max_body_bytes past it
  uint64_t body_timed_out = 0;       ///< bodies that did not arrive within their deadline
  uint64_t priority_served = 0;      ///< requests served by the probes' lane since start
};

/// An httplib::Server whose threads never wait for request headers. cpp-httplib gives each
/// connection a thread from accept to close, and its read timeout is per recv(): a client
/// sending a header byte a second holds a thread for as long as it likes, and as many such
/// clients as threads stop the server (slowloris). Here a connection goes to one epoll thread
/// (the gate) whenever it waits for a request — after accept and between kept-alive requests
/// — which peeks at the socket until the headers are complete and only then gives it to a
/// thread. The bytes stay in the kernel until httplib reads them, so nothing is parsed twice.
/// A connection whose headers take longer than the limits is closed (408 if it sent part of
/// them), and each remote address may keep only so many connections waiting.
///
/// Ready requests queue for the threads up to GateLimits::max_queued; past that the gate
/// answers them itself (503 + Retry-After, built by GateLimits::overloaded) instead of letting
/// them wait in an unbounded queue. New connections are taken over by the gate in the accept
/// thread, so they never wait behind busy threads either. Probes (GateLimits::priority_paths)
/// go to threads of their own instead of that queue. Bodies are read in the threads, each
/// with a deadline, and only so many at once (begin_body).
class GatedServer : public httplib::Server {
 public:
  explicit GatedServer(int threads);
  ~GatedServer() override;
  GatedServer(const GatedServer&) = delete;
  GatedServer& operator=(const GatedServer&) = delete;

  void set_gate_limits(const GateLimits& limits);  ///< before listening
  /// Called in the request's thread once each request is over and its Request and Response
  /// are gone (the server returns memory to the system there after large bodies).
  void set_after_request(std::function<void()> fn) { after_request_ = std::move(fn); }
  GateCounts gate_counts() const;

  /// In a request's thread, before its body is read (a pre-routing or Expect handler): takes
  /// one of GateLimits::max_body_readers (and of the remote address's
  /// max_body_readers_per_client) and `length` bytes of max_body_bytes for a body of
  /// `length` bytes, and starts its deadline. Anything but kAdmitted says which limit is
  /// reached: refuse the request without reading its body. The slots are given back once the
  /// body has been read, the bytes once the request is over. Calling it again for the same
  /// request changes nothing. Outside a request thread of this server (or for an empty body)
  /// it admits.
  BodyAdmission begin_body(uint64_t length);
  /// In a request's thread: whether this request's body missed its deadline (its read failed
  /// for that reason; the error handler answers 408 and the connection is closed).
  static bool body_timed_out();

  struct Connection;
  class Gate;

 private:
  bool process_and_close_socket(socket_t sock) override;
  void serve(std::unique_ptr<Connection> c);

  std::unique_ptr<Gate> gate_;
  std::function<void()> after_request_;
};

}  // namespace gvd::server
