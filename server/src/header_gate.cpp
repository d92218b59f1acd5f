#include "header_gate.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <map>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>
#include <unordered_map>
#include <vector>

namespace gvd::server {
namespace {

using Clock = std::chrono::steady_clock;

/// How long a thread that has just answered a kept-alive connection waits for its next
/// request before giving the connection to the gate.
constexpr int kLingerMs = 2;

Clock::duration seconds(double s) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

int timeout_ms(time_t sec, time_t usec) {
  return static_cast<int>(std::min<int64_t>(int64_t{sec} * 1000 + usec / 1000, INT32_MAX));
}

/// poll() for `events`, restarting after signals; false on timeout, error or hang-up.
bool wait_for(int fd, short events, int ms) {
  pollfd p{fd, events, 0};
  const auto end = Clock::now() + std::chrono::milliseconds(ms);
  for (;;) {
    const int n = ::poll(&p, 1, ms);
    if (n > 0) return (p.revents & events) != 0 && (p.revents & (POLLERR | POLLNVAL)) == 0;
    if (n == 0 || errno != EINTR) return false;
    ms = static_cast<int>(std::max<int64_t>(
        0, std::chrono::duration_cast<std::chrono::milliseconds>(end - Clock::now()).count()));
  }
}

void address_of(const sockaddr_storage& a, std::string& ip, int& port) {
  char text[INET6_ADDRSTRLEN] = {};
  if (a.ss_family == AF_INET) {
    const auto& v4 = reinterpret_cast<const sockaddr_in&>(a);
    ::inet_ntop(AF_INET, &v4.sin_addr, text, sizeof text);
    port = ntohs(v4.sin_port);
  } else if (a.ss_family == AF_INET6) {
    const auto& v6 = reinterpret_cast<const sockaddr_in6&>(a);
    ::inet_ntop(AF_INET6, &v6.sin6_addr, text, sizeof text);
    port = ntohs(v6.sin6_port);
  } else {
    port = 0;
  }
  ip = text;
}

/// The request bodies being read and held, for GatedServer::begin_body: reader slots (in all
/// and per remote address) and bytes (each body's Content-Length). A reader slot is given back
/// once its body has been read; the bytes once the request is over (the body and whatever
/// its handler made of it are in memory until then).
class BodyLedger {
 public:
  BodyAdmission take(const std::string& client, uint64_t length, const GateLimits& limits) {
    std::lock_guard lock(mutex_);
    if (limits.max_body_readers > 0 && readers_ >= limits.max_body_readers) {
      return BodyAdmission::kTooManyReaders;
    }
    const auto it = by_client_.find(client);
    const int mine = it == by_client_.end() ? 0 : it->second;
    if (limits.max_body_readers_per_client > 0 && mine >= limits.max_body_readers_per_client) {
      return BodyAdmission::kTooManyForClient;
    }
    if (limits.max_body_bytes > 0 &&
        (length > limits.max_body_bytes || bytes_ > limits.max_body_bytes - length)) {
      return BodyAdmission::kOverBudget;
    }
    ++readers_;
    ++by_client_[client];
    bytes_ += length;
    return BodyAdmission::kAdmitted;
  }
  /// The body of `client`'s request has been read (or will not be).
  void end_read(const std::string& client) {
    std::lock_guard lock(mutex_);
    --readers_;
    if (const auto it = by_client_.find(client); it != by_client_.end() && --it->second <= 0) {
      by_client_.erase(it);
    }
  }
  /// The request whose body had `length` bytes is over.
  void release(uint64_t length) {
    std::lock_guard lock(mutex_);
    bytes_ -= std::min(bytes_, length);
  }
  int readers() const {
    std::lock_guard lock(mutex_);
    return readers_;
  }
  uint64_t bytes() const {
    std::lock_guard lock(mutex_);
    return bytes_;
  }

 private:
  mutable std::mutex mutex_;
  int readers_ = 0;
  uint64_t bytes_ = 0;
  std::unordered_map<std::string, int> by_client_;  ///< addresses reading a body now only
};

/// The socket as httplib's Stream, read through a small buffer (httplib reads headers a byte
/// at a time). The buffer belongs to the connection, so bytes of a pipelined next request
/// read with this one are not lost between requests.
class ConnectionStream final : public httplib::Stream {
 public:
  ConnectionStream(int fd, int read_ms, int write_ms)
      : fd_(fd), read_ms_(read_ms), write_ms_(write_ms) {}
  ~ConnectionStream() override { end_request(); }
  ConnectionStream(const ConnectionStream&) = delete;
  ConnectionStream& operator=(const ConnectionStream&) = delete;

  bool is_readable() const override { return off_ < len_ || wait_for(fd_, POLLIN, wait_ms()); }
  bool is_writable() const override { return wait_for(fd_, POLLOUT, write_ms_); }

  ssize_t read(char* ptr, size_t size) override {
    if (off_ < len_) return counted(take(ptr, size));
    if (body_left_ > 0 && Clock::now() >= deadline_) {
      timed_out_ = true;
      return -1;
    }
    const int ms = wait_ms();
    if (!wait_for(fd_, POLLIN, ms)) {
      // The body's deadline, not the read time-out, ended the wait.
      if (body_left_ > 0 && ms < read_ms_) timed_out_ = true;
      return -1;
    }
    if (size >= sizeof buf_) return counted(receive(ptr, size));
    const ssize_t n = receive(buf_, sizeof buf_);
    if (n <= 0) return n;
    off_ = 0;
    len_ = static_cast<size_t>(n);
    return counted(take(ptr, size));
  }

  /// The next `length` bytes taken are a request body that must arrive by `deadline`; they
  /// were taken from `ledger` for `client` (which outlive the request): the reader slot is
  /// given back once they have been taken or at end_body(), the bytes at end_request().
  void begin_body(uint64_t length, Clock::time_point deadline, BodyLedger* ledger,
                  const std::string* client) {
    end_request();
    body_left_ = length;
    deadline_ = deadline;
    ledger_ = ledger;
    client_ = client;
    reading_ = true;
    held_ = length;
    in_body_ = true;
  }
  /// The body is over (read, or the request ended): its reader slot is given back.
  void end_body() {
    body_left_ = 0;
    if (reading_) ledger_->end_read(*client_);
    reading_ = false;
  }
  /// The request is over: its body's bytes are given back too.
  void end_request() {
    end_body();
    if (ledger_ != nullptr) ledger_->release(held_);
    ledger_ = nullptr;
    held_ = 0;
  }
  /// Before each request: no body yet, nothing timed out.
  void begin_request() {
    end_request();
    in_body_ = false;
    timed_out_ = false;
  }
  bool in_body() const { return in_body_; }
  bool timed_out() const { return timed_out_; }

  ssize_t write(const char* ptr, size_t size) override {
    if (!wait_for(fd_, POLLOUT, write_ms_)) return -1;
    for (;;) {
      const ssize_t n = ::send(fd_, ptr, size, MSG_NOSIGNAL);
      if (n >= 0 || errno != EINTR) return n;
    }
  }

  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    sockaddr_storage a{};
    socklen_t len = sizeof a;
    if (::getpeername(fd_, reinterpret_cast<sockaddr*>(&a), &len) == 0) {
      address_of(a, ip, port);
    }
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    sockaddr_storage a{};
    socklen_t len = sizeof a;
    if (::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len) == 0) {
      address_of(a, ip, port);
    }
  }
  socket_t socket() const override { return fd_; }

  /// Bytes read from the socket and not yet taken (a pipelined next request).
  std::string_view buffered() const { return {buf_ + off_, len_ - off_}; }

 private:
  /// How long one read may wait: the read time-out, or less when a body's deadline is nearer.
  int wait_ms() const {
    if (body_left_ == 0) return read_ms_;
    const auto left = std::chrono::ceil<std::chrono::milliseconds>(deadline_ - Clock::now());
    return static_cast<int>(std::clamp<int64_t>(left.count(), 0, read_ms_));
  }
  /// Counts bytes taken against the body being read.
  ssize_t counted(ssize_t n) {
    if (n > 0 && body_left_ > 0) {
      body_left_ -= std::min<uint64_t>(body_left_, static_cast<uint64_t>(n));
      if (body_left_ == 0) end_body();
    }
    return n;
  }
  ssize_t take(char* ptr, size_t size) {
    const size_t n = std::min(size, len_ - off_);
    std::memcpy(ptr, buf_ + off_, n);
    off_ += n;
    return static_cast<ssize_t>(n);
  }
  ssize_t receive(char* ptr, size_t size) {
    for (;;) {
      const ssize_t n = ::recv(fd_, ptr, size, 0);
      if (n >= 0 || errno != EINTR) return n;
    }
  }

  int fd_;
  int read_ms_;
  int write_ms_;
  char buf_[4096];
  size_t off_ = 0;
  size_t len_ = 0;
  uint64_t body_left_ = 0;  ///< bytes of the body not yet taken (0: not reading one)
  Clock::time_point deadline_{};
  BodyLedger* ledger_ = nullptr;         ///< where this request's body was admitted (or null)
  const std::string* client_ = nullptr;  ///< whose body it is (the connection's address)
  bool reading_ = false;                 ///< holds a reader slot of ledger_
  uint64_t held_ = 0;                    ///< bytes held in ledger_ until the request is over
  bool in_body_ = false;                 ///< begin_body was called for this request
  bool timed_out_ = false;               ///< a read failed because the body's deadline passed
};

/// The end of a request's headers (a blank line; bare LF line ends count, as for httplib).
bool has_headers(std::string_view bytes) {
  return bytes.find("\r\n\r\n") != bytes.npos || bytes.find("\n\n") != bytes.npos;
}

/// Closes a socket. What has arrived and was not read is read first (a little, without
/// waiting): a socket closed with unread bytes is reset, which can destroy an answer just
/// sent (a 503 or 408 before the body) before the client has read it.
void close_socket(int fd) {
  char sink[4096];
  for (int i = 0; i < 16 && ::recv(fd, sink, sizeof sink, MSG_DONTWAIT) > 0; ++i) {
  }
  ::shutdown(fd, SHUT_RDWR);
  ::close(fd);
}

}  // namespace

struct GatedServer::Connection {
  int fd = -1;
  std::string client;  ///< remote address, for the per-client cap
  size_t requests_left = 0;
  std::unique_ptr<ConnectionStream> stream;
  Clock::time_point since;       ///< when it began to wait
  Clock::time_point deadline;    ///< when it is closed if still waiting
  bool partial = false;          ///< some bytes of the request have arrived
  bool priority = false;         ///< its ready request is for the probes' lane
  bool counted_partial = false;  ///< counted in its address's share of partial connections
  uint32_t turn = 0;             ///< which wait at the gate (epoll events carry it with the fd)
  ~Connection() {
    if (fd >= 0) close_socket(fd);
  }
};

namespace {

enum class Peek { kNothing, kPartial, kReady, kTooLarge, kClosed };

/// cpp-httplib 0.11.4 reads no header line longer than this (CPPHTTPLIB_HEADER_MAX_LENGTH):
/// it would answer 400 without a reason, so the gate answers 431 first.
constexpr size_t kHeaderLineMax = 8192;

/// Whether the next request's headers have arrived, looking without taking: what the
/// connection's stream has read ahead (part of a pipelined request) and then the socket.
Peek peek_headers(const GatedServer::Connection& c, size_t max_bytes, std::vector<char>& buffer) {
  const std::string_view ahead = c.stream->buffered();
  buffer.assign(ahead.begin(), ahead.end());
  const size_t room = max_bytes > ahead.size() ? max_bytes - ahead.size() : 1;
  buffer.resize(ahead.size() + room);
  const ssize_t n = ::recv(c.fd, buffer.data() + ahead.size(), room, MSG_PEEK | MSG_DONTWAIT);
  if (n == 0) return Peek::kClosed;
  if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) return Peek::kClosed;
  const std::string_view got(buffer.data(),
                             ahead.size() + static_cast<size_t>(std::max<ssize_t>(n, 0)));
  if (got.empty()) return Peek::kNothing;
  const size_t end = std::min(got.find("\r\n\r\n"), got.find("\n\n"));
  const std::string_view head = got.substr(0, end);
  // Header lines (after the request line, whose length httplib answers with 414 itself).
  const size_t first_end = head.find('\n');
  if (first_end != head.npos) {
    for (size_t at = first_end + 1; at < head.size();) {
      const size_t eol = std::min(head.find('\n', at), head.size());
      if (eol - at > kHeaderLineMax) return Peek::kTooLarge;
      at = eol + 1;
    }
  }
  if (end != got.npos) return Peek::kReady;
  if (got.size() < max_bytes) return Peek::kPartial;
  return first_end == head.npos ? Peek::kReady : Peek::kTooLarge;
}

/// The threads that run requests: cpp-httplib's ThreadPool with a bound on what waits. A task
/// is taken only while fewer than `max_queued` tasks would wait for a thread (a task for
/// which a thread is idle does not wait), so a burst cannot build a queue that takes seconds
/// to drain. Shut down, the threads finish what was queued, as httplib's do.
class BoundedPool {
 public:
  explicit BoundedPool(size_t threads) : idle_(threads) {
    for (size_t i = 0; i < threads; ++i) threads_.emplace_back([this] { work(); });
  }
  ~BoundedPool() { shutdown(); }
  BoundedPool(const BoundedPool&) = delete;
  BoundedPool& operator=(const BoundedPool&) = delete;

  /// Queues `fn` and returns true, or returns false (and leaves `fn` alone) when every
  /// thread is busy and `max_queued` tasks wait already, or after shutdown.
  bool try_enqueue(std::function<void()>& fn, size_t max_queued) {
    {
      std::lock_guard lock(mutex_);
      if (shutdown_ || tasks_.size() >= idle_ + max_queued) return false;
      tasks_.push_back(std::move(fn));
    }
    ready_.notify_one();
    return true;
  }

  void shutdown() {
    {
      std::lock_guard lock(mutex_);
      if (shutdown_) return;
      shutdown_ = true;
    }
    ready_.notify_all();
    for (std::thread& t : threads_) t.join();
  }

  size_t busy() const {
    std::lock_guard lock(mutex_);
    return threads_.size() - idle_;
  }
  /// Tasks that wait for a thread (not those an idle thread is about to take).
  size_t queued() const {
    std::lock_guard lock(mutex_);
    return tasks_.size() > idle_ ? tasks_.size() - idle_ : 0;
  }

 private:
  void work() {
    std::unique_lock lock(mutex_);
    for (;;) {
      ready_.wait(lock, [this] { return !tasks_.empty() || shutdown_; });
      if (tasks_.empty()) return;  // shut down and drained
      std::function<void()> fn = std::move(tasks_.front());
      tasks_.pop_front();
      --idle_;
      lock.unlock();
      fn();
      fn = nullptr;  // what it holds goes before the thread counts as idle again
      lock.lock();
      ++idle_;
    }
  }

  mutable std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<std::function<void()>> tasks_;
  size_t idle_;  ///< threads not running a task
  bool shutdown_ = false;
  std::vector<std::thread> threads_;  ///< last: the threads start once the rest is set up
};

/// Whether `request` (its first bytes) asks for one of `paths` with GET: `GET <path>` and then
/// a space or a query.
bool is_priority(std::string_view request, const std::vector<std::string>& paths) {
  if (!request.starts_with("GET ")) return false;
  request.remove_prefix(4);
  for (const std::string& path : paths) {
    if (request.size() > path.size() && request.starts_with(path) &&
        (request[path.size()] == ' ' || request[path.size()] == '?')) {
      return true;
    }
  }
  return false;
}

thread_local GatedServer::Connection* t_connection = nullptr;  ///< the request being served

}  // namespace

/// The epoll thread that holds connections until their headers are complete, and the task
/// queue that cpp-httplib's accept loop feeds (its threads run the requests).
class GatedServer::Gate {
 public:
  explicit Gate(GatedServer& server) : server_(server) {}
  ~Gate() { stop(); }

  GateLimits limits;
  BodyLedger bodies;
  std::atomic<uint64_t> body_refused{0};
  std::atomic<uint64_t> body_refused_client{0};
  std::atomic<uint64_t> body_refused_bytes{0};
  std::atomic<uint64_t> body_timed_out{0};
  std::atomic<uint64_t> priority_served{0};

  /// Starts the epoll thread with `pool` running the requests and `probes` (may be null) the
  /// probes' lane.
  void start(BoundedPool* pool, BoundedPool* probes) {
    std::lock_guard lock(mutex_);
    pool_ = pool;
    probes_ = probes;
    epoll_ = ::epoll_create1(EPOLL_CLOEXEC);
    wake_ = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
    epoll_event ev{};
    ev.events = EPOLLIN;
    ev.data.u64 = kWakeKey;
    ::epoll_ctl(epoll_, EPOLL_CTL_ADD, wake_, &ev);
    stopping_ = false;
    running_ = true;
    thread_ = std::thread([this] { run(); });
  }

  /// Closes every waiting connection and joins the thread; later `wait` calls close theirs.
  void stop() {
    {
      std::lock_guard lock(mutex_);
      if (!running_) return;
      stopping_ = true;
    }
    const uint64_t one = 1;
    [[maybe_unused]] const ssize_t w = ::write(wake_, &one, sizeof one);
    thread_.join();
    std::lock_guard lock(mutex_);
    waiting_.clear();
    shares_.clear();
    ::close(epoll_);
    ::close(wake_);
    running_ = false;
    pool_ = nullptr;
    probes_ = nullptr;
  }

  /// Holds `c` until its next request's headers are complete (or closes it). Headers that
  /// are there already go straight to a thread.
  void wait(std::unique_ptr<Connection> c) {
    std::lock_guard lock(mutex_);
    if (!running_ || stopping_) return;  // c closes
    const auto now = Clock::now();
    c->since = now;
    c->partial = !c->stream->buffered().empty();
    c->deadline = now + seconds(c->partial ? limits.header_seconds : limits.idle_seconds);
    const Peek p = peek(*c);
    if (p == Peek::kClosed) return;
    if (p == Peek::kTooLarge) {
      refuse(*c, 431);
      return;
    }
    if (p == Peek::kReady) {
      serve_later(std::move(c));
      return;
    }
    if (c->partial) limit_partial(c->client, -1, 1);
    limit_total();
    c->turn = ++turns_;
    epoll_event ev = event_for(*c);
    if (::epoll_ctl(epoll_, EPOLL_CTL_ADD, c->fd, &ev) != 0) return;
    next_sweep_ = std::min(next_sweep_, c->deadline);
    track(*c, +1);
    const int fd = c->fd;
    waiting_[fd] = std::move(c);
  }

  GateCounts counts() const {
    std::lock_guard lock(mutex_);
    GateCounts n{waiting_.size(), timed_out_, evicted_};
    if (pool_ != nullptr) {
      n.busy = pool_->busy();
      n.queued = pool_->queued();
    }
    n.overloaded = overloaded_;
    n.body_readers = static_cast<uint64_t>(std::max(bodies.readers(), 0));
    n.body_bytes = bodies.bytes();
    n.body_refused = body_refused;
    n.body_refused_client = body_refused_client;
    n.body_refused_bytes = body_refused_bytes;
    n.body_timed_out = body_timed_out;
    n.priority_served = priority_served;
    return n;
  }

 private:
  using Waiting = std::map<int, std::unique_ptr<Connection>>;

  /// Connections of one remote address waiting at the gate: all, and those with part of
  /// their headers.
  struct Share {
    int waiting = 0;
    int partial = 0;
  };

  static constexpr uint64_t kWakeKey = ~uint64_t{0};

  /// What to report of `c` while it waits: each arrival of bytes (edge-triggered). The gate
  /// only peeks, so the bytes of partial headers stay unread in the socket; level-triggered
  /// (a one-shot re-armed after each event, as this was) the socket is ready again at once,
  /// and every slow client's connection was reported in a loop — the gate and the accept
  /// thread took both cores under 200 slow connections, and probes waited 1-3 s.
  static epoll_event event_for(const Connection& c) {
    epoll_event ev{};
    ev.events = EPOLLIN | EPOLLRDHUP | EPOLLET;
    ev.data.u64 = uint64_t{c.turn} << 32 | static_cast<uint32_t>(c.fd);
    return ev;
  }

  /// Counts `c` in (+1) or out (-1) of its address's share of the waiting connections.
  void track(Connection& c, int sign) {
    Share& s = shares_[c.client];
    s.waiting += sign;
    if (sign > 0 && c.partial) c.counted_partial = true;
    if (c.counted_partial) s.partial += sign;
    if (sign < 0) c.counted_partial = false;
    if (s.waiting <= 0) shares_.erase(c.client);
  }

  /// Takes `it` out of the waiting connections (its socket stays open).
  std::unique_ptr<Connection> take(Waiting::iterator it) {
    ::epoll_ctl(epoll_, EPOLL_CTL_DEL, it->first, nullptr);
    track(*it->second, -1);
    std::unique_ptr<Connection> c = std::move(it->second);
    waiting_.erase(it);
    return c;
  }

  void drop(Waiting::iterator it) { take(it); }  // closes the socket

  /// Makes room for a waiting connection by closing `victim`, unless its headers have just
  /// arrived (its event not yet handled): then it is served, which makes room as well.
  void evict(Waiting::iterator victim) {
    const Peek p = peek(*victim->second);
    if (p == Peek::kReady) {
      serve_later(take(victim));
      return;
    }
    if (p != Peek::kClosed) ++evicted_;
    drop(victim);
  }

  /// Before (`coming` = 1) or after (0) a connection of `client` counts as partial: while
  /// that address would hold more than its share of partial connections, its oldest partial
  /// one other than `keep` (a descriptor, or -1) is closed.
  void limit_partial(const std::string& client, int keep, int coming) {
    for (;;) {
      const auto share = shares_.find(client);
      const int partial = (share == shares_.end() ? 0 : share->second.partial) + coming;
      if (partial <= limits.max_waiting_per_client) return;
      auto victim = waiting_.end();
      for (auto it = waiting_.begin(); it != waiting_.end(); ++it) {
        const Connection& w = *it->second;
        if (!w.partial || it->first == keep || w.client != client) continue;
        if (victim == waiting_.end() || w.since < victim->second->since) victim = it;
      }
      if (victim == waiting_.end()) return;
      evict(victim);
    }
  }

  /// Before a connection waits: while the gate is full, the oldest waiting connection of the
  /// address with the most waiting ones is closed.
  void limit_total() {
    while (static_cast<int>(waiting_.size()) >= limits.max_waiting) {
      const std::string* largest = nullptr;
      int most = 0;
      for (const auto& [client, share] : shares_) {
        if (share.waiting > most) {
          most = share.waiting;
          largest = &client;
        }
      }
      if (largest == nullptr) return;
      auto victim = waiting_.end();
      for (auto it = waiting_.begin(); it != waiting_.end(); ++it) {
        if (it->second->client != *largest) continue;
        if (victim == waiting_.end() || it->second->since < victim->second->since) victim = it;
      }
      if (victim == waiting_.end()) return;
      evict(victim);
    }
  }

  /// Answers `status` on `c` without waiting (the caller closes the socket).
  void refuse(const Connection& c, int status) {
    std::string bytes;
    if (limits.answer) bytes = limits.answer(status);
    if (bytes.empty()) {
      bytes = "HTTP/1.1 " + std::to_string(status) +
              (status == 408 ? " Request Timeout" : " Request Header Fields Too Large") +
              "\r\nConnection: close\r\nContent-Length: 0\r\n\r\n";
    }
    [[maybe_unused]] const ssize_t w =
        ::send(c.fd, bytes.data(), bytes.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
  }

  /// Gives `c` to a thread of the pool (a probe to the probes' lane), or answers it at once
  /// when the pool is full.
  void serve_later(std::unique_ptr<Connection> c) {
    const bool priority = c->priority && probes_ != nullptr;
    Connection* raw = c.release();
    std::function<void()> task = [this, raw] { server_.serve(std::unique_ptr<Connection>(raw)); };
    BoundedPool* pool = priority ? probes_ : pool_;
    if (pool->try_enqueue(task, static_cast<size_t>(std::max(limits.max_queued, 0)))) return;
    c.reset(raw);  // not queued: still ours
    refuse_overloaded(*c);
  }

  /// Answers a ready request for which no thread is free and the queue is full, here and now
  /// (the caller closes the connection). What has arrived of the request is read first: the
  /// request line says what to answer, and a socket closed with unread bytes is reset, which
  /// can destroy the answer before the client reads it.
  void refuse_overloaded(Connection& c) {
    ++overloaded_;
    constexpr size_t kReadMax = 64 * 1024;
    std::string request(c.stream->buffered());
    char chunk[8192];
    while (request.size() < kReadMax) {
      const ssize_t n = ::recv(c.fd, chunk, sizeof chunk, MSG_DONTWAIT);
      if (n <= 0) break;
      request.append(chunk, static_cast<size_t>(n));
    }
    const std::string_view all(request);
    const std::string_view line = all.substr(0, all.find_first_of("\r\n"));
    const size_t method_end = std::min(line.find(' '), line.size());
    const std::string_view method = line.substr(0, method_end);
    std::string_view target = line.substr(std::min(method_end + 1, line.size()));
    target = target.substr(0, std::min({target.find(' '), target.find('?'), target.size()}));
    std::string bytes;
    if (limits.overloaded) bytes = limits.overloaded(method, target);
    if (bytes.empty()) {
      bytes = "HTTP/1.1 503 Service Unavailable\r\nConnection: close\r\nContent-Length: 0\r\n\r\n";
    }
    [[maybe_unused]] const ssize_t w =
        ::send(c.fd, bytes.data(), bytes.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
  }

  /// Looks at what has arrived without taking it: ready when the headers are complete (or
  /// as large as the gate lets them grow: httplib then refuses them with a reason). A ready
  /// request is marked for the probes' lane when it is a probe.
  Peek peek(Connection& c) {
    const Peek p = peek_headers(c, limits.max_header_bytes, buffer_);
    if (p == Peek::kPartial && !c.partial) {
      c.partial = true;
      c.deadline = Clock::now() + seconds(limits.header_seconds);
    }
    if (p == Peek::kReady) {
      c.priority = !limits.priority_paths.empty() &&
                   is_priority({buffer_.data(), buffer_.size()}, limits.priority_paths);
    }
    return p;
  }

  /// One event of the waiting connection `it`.
  void handle(Waiting::iterator it, uint32_t events) {
    Connection& c = *it->second;
    const Peek p = peek(c);
    const bool hung_up = (events & (EPOLLRDHUP | EPOLLHUP | EPOLLERR)) != 0;
    if (p == Peek::kReady) {
      serve_later(take(it));
    } else if (p == Peek::kTooLarge) {
      refuse(c, 431);
      drop(it);
    } else if (p == Peek::kClosed || hung_up) {
      drop(it);
    } else {
      const int fd = it->first;
      if (c.partial && !c.counted_partial) {
        // Began its headers: now it counts toward its address's share of partial ones.
        ++shares_[c.client].partial;
        c.counted_partial = true;
        next_sweep_ = std::min(next_sweep_, c.deadline);
        const std::string client = c.client;
        limit_partial(client, fd, 0);
      }
      // Still waiting (unless limit_partial closed it): the next bytes report it again.
    }
  }

  /// Closes the connections past their deadline (408 if they sent part of their headers) and
  /// sets when to look again.
  void sweep(Clock::time_point now) {
    auto next = now + std::chrono::seconds(1);
    for (auto it = waiting_.begin(); it != waiting_.end();) {
      if (it->second->deadline > now) {
        next = std::min(next, it->second->deadline);
        ++it;
        continue;
      }
      if (it->second->partial) {
        refuse(*it->second, 408);
        ++timed_out_;
      }
      auto following = std::next(it);
      drop(it);
      it = following;
    }
    next_sweep_ = next;
  }

  void run() {
    std::vector<epoll_event> events(256);
    for (;;) {
      int ms = 1000;
      {
        std::lock_guard lock(mutex_);
        if (stopping_) return;
        const auto left =
            std::chrono::duration_cast<std::chrono::milliseconds>(next_sweep_ - Clock::now())
                .count();
        ms = static_cast<int>(std::clamp<int64_t>(left + 1, 0, ms));
      }
      const int n = ::epoll_wait(epoll_, events.data(), static_cast<int>(events.size()), ms);
      {
        std::lock_guard lock(mutex_);
        if (stopping_) return;
        for (int i = 0; i < n; ++i) {
          const uint64_t key = events[static_cast<size_t>(i)].data.u64;
          if (key == kWakeKey) {
            uint64_t v = 0;
            [[maybe_unused]] const ssize_t r = ::read(wake_, &v, sizeof v);
            continue;
          }
          // An event of a connection closed (by another thread) after epoll_wait returned
          // may name a descriptor already given to a new one: the turn tells them apart.
          const int fd = static_cast<int>(key & 0xFFFFFFFFu);
          const auto it = waiting_.find(fd);
          if (it == waiting_.end() || it->second->turn != key >> 32) continue;
          handle(it, events[static_cast<size_t>(i)].events);
        }
        // The deadlines are looked at only when the earliest may have passed (not at every
        // event: with many kept-alive connections waiting that was a scan per request).
        const auto now = Clock::now();
        if (now >= next_sweep_) sweep(now);
      }
    }
  }

  GatedServer& server_;
  mutable std::mutex mutex_;
  Waiting waiting_;
  std::unordered_map<std::string, Share> shares_;  ///< per remote address
  BoundedPool* pool_ = nullptr;
  BoundedPool* probes_ = nullptr;
  int epoll_ = -1;
  int wake_ = -1;
  bool running_ = false;
  bool stopping_ = false;
  std::thread thread_;
  std::vector<char> buffer_;
  uint32_t turns_ = 0;  ///< counts waits; kWakeKey is no connection's key (its fd half is -1)
  /// No waiting connection's deadline is earlier (it may be later: a sweep then finds none).
  Clock::time_point next_sweep_ = Clock::time_point::max();
  uint64_t timed_out_ = 0;
  uint64_t evicted_ = 0;
  uint64_t overloaded_ = 0;
};

namespace {

/// What cpp-httplib's accept loop feeds (the only caller of enqueue: each task is
/// process_and_close_socket of a new connection), with the gate and the request threads
/// started and stopped beside it: the gate stops first (it enqueues), then the pools drain
/// what was queued.
class GateQueue final : public httplib::TaskQueue {
 public:
  GateQueue(GatedServer::Gate& gate, int threads)
      : gate_(gate),
        pool_(static_cast<size_t>(threads)),
        probes_(gate.limits.priority_paths.empty()
                    ? nullptr
                    : std::make_unique<BoundedPool>(
                          static_cast<size_t>(std::max(gate.limits.priority_threads, 1)))) {
    gate_.start(&pool_, probes_.get());
  }
  ~GateQueue() override { gate_.stop(); }
  /// Runs the task here, in the accept thread: handing a new connection to the gate only
  /// peeks at it and never blocks, and through the pool it would wait behind busy threads.
  void enqueue(std::function<void()> fn) override { fn(); }
  void shutdown() override {
    gate_.stop();
    pool_.shutdown();
    if (probes_) probes_->shutdown();
  }

 private:
  GatedServer::Gate& gate_;
  BoundedPool pool_;
  std::unique_ptr<BoundedPool> probes_;
};

}  // namespace

GatedServer::GatedServer(int threads) : gate_(std::make_unique<Gate>(*this)) {
  new_task_queue = [this, threads] { return new GateQueue(*gate_, threads); };
}

GatedServer::~GatedServer() = default;

void GatedServer::set_gate_limits(const GateLimits& limits) { gate_->limits = limits; }

GateCounts GatedServer::gate_counts() const { return gate_->counts(); }

BodyAdmission GatedServer::begin_body(uint64_t length) {
  Connection* c = t_connection;
  if (c == nullptr || length == 0 || c->stream->in_body()) return BodyAdmission::kAdmitted;
  const GateLimits& limits = gate_->limits;
  const BodyAdmission admitted = gate_->bodies.take(c->client, length, limits);
  switch (admitted) {
    case BodyAdmission::kAdmitted:
      break;
    case BodyAdmission::kTooManyReaders:
      ++gate_->body_refused;
      return admitted;
    case BodyAdmission::kTooManyForClient:
      ++gate_->body_refused_client;
      return admitted;
    case BodyAdmission::kOverBudget:
      ++gate_->body_refused_bytes;
      return admitted;
  }
  const double allowed =
      limits.body_seconds + static_cast<double>(length) / std::max(limits.min_body_rate, 1.0);
  c->stream->begin_body(length, Clock::now() + seconds(std::min(allowed, 1e7)), &gate_->bodies,
                        &c->client);
  return admitted;
}

bool GatedServer::body_timed_out() {
  return t_connection != nullptr && t_connection->stream->timed_out();
}

bool GatedServer::process_and_close_socket(socket_t sock) {
  auto c = std::make_unique<Connection>();
  c->fd = sock;
  c->requests_left = keep_alive_max_count_;
  c->stream =
      std::make_unique<ConnectionStream>(sock, timeout_ms(read_timeout_sec_, read_timeout_usec_),
                                         timeout_ms(write_timeout_sec_, write_timeout_usec_));
  int port = 0;
  c->stream->get_remote_ip_and_port(c->client, port);
  gate_->wait(std::move(c));
  return true;
}

void GatedServer::serve(std::unique_ptr<Connection> c) {
  while (c->requests_left > 0 && svr_sock_ != INVALID_SOCKET) {
    const bool close_connection = c->requests_left == 1;
    bool closed = false;
    c->stream->begin_request();
    t_connection = c.get();  // for begin_body and body_timed_out, called by the handlers
    const bool ok = process_request(*c->stream, close_connection, closed, nullptr);
    t_connection = nullptr;
    const bool timed_out = c->stream->timed_out();
    c->stream->end_request();
    if (timed_out) ++gate_->body_timed_out;
    if (c->priority) ++gate_->priority_served;
    if (after_request_) after_request_();
    --c->requests_left;
    if (!ok || closed || close_connection || timed_out) return;
    // A probes' thread serves one request per turn: the connection goes back to the gate,
    // which sends its next request to whichever threads it is for. Lingering here, a client
    // asking /healthz as fast as it can kept a probes' thread to itself (p99 135 ms for the
    // others with 8 such connections).
    if (c->priority) {
      gate_->wait(std::move(c));
      return;
    }
    // The next request is served here when it is already read into the buffer (pipelined) or
    // arrives whole within a moment (a busy keep-alive client sends it as soon as it has the
    // answer; handing it over through the gate would cost a wake-up of two threads). Anything
    // slower waits at the gate, not in this thread: a thread waits at most kLinger per request.
    if (has_headers(c->stream->buffered())) continue;
    thread_local std::vector<char> buffer;
    if (wait_for(c->fd, POLLIN, kLingerMs) &&
        peek_headers(*c, gate_->limits.max_header_bytes, buffer) == Peek::kReady) {
      continue;
    }
    gate_->wait(std::move(c));
    return;
  }
}

}  // namespace gvd::server
