#include "gvd/common/memory_account.h"

namespace gvd {
namespace {

/// The calling thread's account and what it has not yet passed on. Constant-initialised
/// (no guard on access): the allocator reads it on every allocation of every thread.
struct ThreadCharge {
  MemoryAccount* account = nullptr;
  int64_t pending = 0;
};
constinit thread_local ThreadCharge t_charge;

void pass_on(ThreadCharge& t) {
  if (t.account != nullptr && t.pending != 0) t.account->add(t.pending);
  t.pending = 0;
}

}  // namespace

void MemoryAccount::add(int64_t delta) {
  const int64_t now = bytes_.fetch_add(delta, std::memory_order_relaxed) + delta;
  int64_t peak = peak_.load(std::memory_order_relaxed);
  while (now > peak && !peak_.compare_exchange_weak(peak, now, std::memory_order_relaxed)) {
  }
  const int64_t limit = limit_.load(std::memory_order_acquire);
  if (limit > 0 && now > limit && !over_.exchange(true, std::memory_order_acq_rel)) {
    if (std::atomic<bool>* flag = flag_.load(std::memory_order_relaxed)) flag->store(true);
  }
}

MemoryAccount* current_memory_account() { return t_charge.account; }

ScopedMemoryAccount::ScopedMemoryAccount(MemoryAccount* account) : previous_(t_charge.account) {
  pass_on(t_charge);
  t_charge.account = account;
}

ScopedMemoryAccount::~ScopedMemoryAccount() {
  pass_on(t_charge);
  t_charge.account = previous_;
}

bool charging_memory() { return t_charge.account != nullptr; }

void charge_memory(int64_t delta) {
  ThreadCharge& t = t_charge;
  if (t.account == nullptr) return;
  t.pending += delta;
  if (t.pending >= kMemoryChargeStep || t.pending <= -kMemoryChargeStep) pass_on(t);
}

}  // namespace gvd
