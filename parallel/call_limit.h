// A bound on how many calls of one kind run at once (WatchJob streams,
// exports that decode): a counting semaphore whose acquisition is an RAII
// slot. Thread-safe.
#ifndef MESHSTREAM_PARALLEL_CALL_LIMIT_H_
#define MESHSTREAM_PARALLEL_CALL_LIMIT_H_

#include <chrono>
#include <condition_variable>
#include <mutex>

namespace meshstream {

class CallLimit {
 public:
  explicit CallLimit(int limit) : limit_(limit < 1 ? 1 : limit) {}

  class Slot {
   public:
    Slot() = default;
    explicit Slot(CallLimit* owner) : owner_(owner) {}
    Slot(Slot&& other) noexcept : owner_(other.owner_) { other.owner_ = nullptr; }
    Slot& operator=(Slot&& other) noexcept {
      Release();
      owner_ = other.owner_;
      other.owner_ = nullptr;
      return *this;
    }
    ~Slot() { Release(); }
    explicit operator bool() const { return owner_ != nullptr; }

   private:
    void Release() {
      if (owner_ == nullptr) return;
      {
        std::lock_guard<std::mutex> lock(owner_->mutex_);
        --owner_->running_;
      }
      owner_->freed_.notify_one();
      owner_ = nullptr;
    }
    CallLimit* owner_ = nullptr;
  };

  // A slot, waiting at most `wait` for one; an empty Slot when none freed up.
  Slot Acquire(std::chrono::milliseconds wait) {
    std::unique_lock<std::mutex> lock(mutex_);
    if (!freed_.wait_for(lock, wait, [this] { return running_ < limit_; })) return Slot();
    ++running_;
    return Slot(this);
  }

  int limit() const { return limit_; }

 private:
  const int limit_;
  std::mutex mutex_;
  std::condition_variable freed_;
  int running_ = 0;
};

}  // namespace meshstream

#endif  // MESHSTREAM_PARALLEL_CALL_LIMIT_H_
