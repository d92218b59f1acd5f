#include "redis_client.h"

#include <hiredis/hiredis.h>
#include <sys/socket.h>

#include <utility>

namespace gvd::server {

RedisReply::RedisReply(RedisReply&& o) noexcept : r_(std::exchange(o.r_, nullptr)) {}
RedisReply& RedisReply::operator=(RedisReply&& o) noexcept {
  if (this != &o) {
    if (r_ != nullptr) freeReplyObject(r_);
    r_ = std::exchange(o.r_, nullptr);
  }
  return *this;
}
RedisReply::~RedisReply() {
  if (r_ != nullptr) freeReplyObject(r_);
}
bool RedisReply::is_nil() const { return reply_is_nil(r_); }
bool RedisReply::is_error() const { return r_ != nullptr && r_->type == REDIS_REPLY_ERROR; }
bool RedisReply::is_array() const { return r_ != nullptr && r_->type == REDIS_REPLY_ARRAY; }
std::string RedisReply::str() const { return reply_str(r_); }
int64_t RedisReply::integer() const { return reply_integer(r_); }
size_t RedisReply::size() const { return reply_size(r_); }
const redisReply* RedisReply::at(size_t i) const { return reply_at(r_, i); }

std::string reply_str(const redisReply* r) {
  if (r == nullptr) return {};
  if (r->type == REDIS_REPLY_STRING || r->type == REDIS_REPLY_STATUS ||
      r->type == REDIS_REPLY_ERROR) {
    return std::string(r->str, r->len);
  }
  if (r->type == REDIS_REPLY_INTEGER) return std::to_string(r->integer);
  return {};
}
bool reply_is_nil(const redisReply* r) { return r == nullptr || r->type == REDIS_REPLY_NIL; }
size_t reply_size(const redisReply* r) {
  return r != nullptr && r->type == REDIS_REPLY_ARRAY ? r->elements : 0;
}
const redisReply* reply_at(const redisReply* r, size_t i) {
  return i < reply_size(r) ? r->element[i] : nullptr;
}
int64_t reply_integer(const redisReply* r) {
  if (r == nullptr) return 0;
  if (r->type == REDIS_REPLY_INTEGER) return r->integer;
  if (r->type == REDIS_REPLY_STRING) {
    try {
      return std::stoll(std::string(r->str, r->len));
    } catch (const std::exception&) {
      return 0;
    }
  }
  return 0;
}

RedisConnection::RedisConnection(std::string host, int port, int db, double timeout_seconds)
    : host_(std::move(host)), port_(port), db_(db), timeout_(timeout_seconds) {}

RedisConnection::~RedisConnection() { close(); }

void RedisConnection::close() {
  if (ctx_ != nullptr) redisFree(ctx_);
  ctx_ = nullptr;
  fd_ = -1;
}

void RedisConnection::interrupt() {
  interrupted_ = true;
  const int fd = fd_;
  if (fd >= 0) ::shutdown(fd, SHUT_RDWR);
}

void RedisConnection::connect() {
  if (ctx_ != nullptr) return;
  if (interrupted_) throw RedisUnavailable("redis: connection closed (shutting down)");
  const timeval connect_timeout{2, 0};
  redisContext* c = redisConnectWithTimeout(host_.c_str(), port_, connect_timeout);
  if (c == nullptr || c->err != 0) {
    const std::string why = c != nullptr ? c->errstr : "out of memory";
    if (c != nullptr) redisFree(c);
    throw RedisUnavailable("redis " + host_ + ":" + std::to_string(port_) + ": " + why);
  }
  timeval tv{};  // 0 = block (a subscriber; interrupt() wakes it)
  if (timeout_ > 0) {
    tv.tv_sec = static_cast<time_t>(timeout_);
    tv.tv_usec = static_cast<suseconds_t>((timeout_ - static_cast<double>(tv.tv_sec)) * 1e6);
  }
  redisSetTimeout(c, tv);
  redisEnableKeepAlive(c);
  ctx_ = c;
  fd_ = c->fd;
  if (interrupted_) ::shutdown(c->fd, SHUT_RDWR);  // interrupt() ran while connecting
  if (db_ != 0) {
    RedisReply r = command({"SELECT", std::to_string(db_)});
    if (r.is_error()) {
      close();
      throw RedisUnavailable("redis SELECT " + std::to_string(db_) + ": " + r.str());
    }
  }
}

RedisReply RedisConnection::command(const std::vector<std::string>& args) {
  connect();
  std::vector<const char*> argv;
  std::vector<size_t> lengths;
  argv.reserve(args.size());
  lengths.reserve(args.size());
  for (const std::string& a : args) {
    argv.push_back(a.data());
    lengths.push_back(a.size());
  }
  void* reply = redisCommandArgv(ctx_, static_cast<int>(args.size()), argv.data(), lengths.data());
  if (reply == nullptr) {
    const std::string why = ctx_->errstr;
    close();
    throw RedisUnavailable("redis " + host_ + ":" + std::to_string(port_) + ": " + why);
  }
  return RedisReply(static_cast<redisReply*>(reply));
}

RedisReply RedisConnection::read_push() {
  connect();
  void* reply = nullptr;
  if (redisGetReply(ctx_, &reply) != REDIS_OK || reply == nullptr) {
    const std::string why = ctx_->errstr;
    close();
    throw RedisUnavailable("redis " + host_ + ":" + std::to_string(port_) + ": " + why);
  }
  return RedisReply(static_cast<redisReply*>(reply));
}

}  // namespace gvd::server
