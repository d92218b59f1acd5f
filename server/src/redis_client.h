#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

struct redisContext;
struct redisReply;

namespace gvd::server {

/// Redis cannot be reached (connection refused, dropped, timed out): retry later.
struct RedisUnavailable : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// A reply, owned (hiredis' redisReply, RESP2). Views into it live as long as it does.
class RedisReply {
 public:
  explicit RedisReply(redisReply* r) : r_(r) {}
  RedisReply(RedisReply&&) noexcept;
  RedisReply& operator=(RedisReply&&) noexcept;
  RedisReply(const RedisReply&) = delete;
  RedisReply& operator=(const RedisReply&) = delete;
  ~RedisReply();

  bool is_nil() const;
  bool is_error() const;
  bool is_array() const;
  /// String, status or error text ("" for others).
  std::string str() const;
  int64_t integer() const;  ///< an integer reply, or a string holding one
  size_t size() const;      ///< elements of an array (0 otherwise)
  /// Element `i` of an array, as a non-owning view.
  const redisReply* at(size_t i) const;
  const redisReply* raw() const { return r_; }

 private:
  redisReply* r_;
};

/// Helpers on non-owning elements of an array reply.
std::string reply_str(const redisReply* r);
bool reply_is_nil(const redisReply* r);
size_t reply_size(const redisReply* r);
const redisReply* reply_at(const redisReply* r, size_t i);
int64_t reply_integer(const redisReply* r);

/// One synchronous connection (hiredis; not thread-safe: one per thread). Connects lazily and
/// again after any failure; every command either returns a reply (possibly an error reply)
/// or throws RedisUnavailable.
class RedisConnection {
 public:
  /// `timeout_seconds` bounds every reply (0: no bound); connecting takes at most 2 s.
  RedisConnection(std::string host, int port, int db, double timeout_seconds);
  ~RedisConnection();
  RedisConnection(const RedisConnection&) = delete;
  RedisConnection& operator=(const RedisConnection&) = delete;

  RedisReply command(const std::vector<std::string>& args);
  /// Blocks for the next pushed reply (pub/sub). Throws RedisUnavailable.
  RedisReply read_push();
  /// Wakes a thread blocked in command/read_push from another thread (it then throws, and
  /// so does every later call: for shutting down).
  void interrupt();
  void close();
  bool connected() const { return ctx_ != nullptr; }

 private:
  void connect();

  std::string host_;
  int port_;
  int db_;
  double timeout_;
  redisContext* ctx_ = nullptr;
  std::atomic<int> fd_{-1};
  std::atomic<bool> interrupted_{false};
};

}  // namespace gvd::server
