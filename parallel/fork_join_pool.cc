#include "parallel/fork_join_pool.h"

#include <algorithm>

namespace meshstream {

ForkJoinPool::ForkJoinPool(int workers) {
  const int n = std::clamp(workers, 1, kMaxWorkers);
  threads_.reserve(static_cast<size_t>(n - 1));
  for (int k = 1; k < n; ++k) threads_.emplace_back([this, k] { Loop(k); });
}

ForkJoinPool::~ForkJoinPool() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  for (std::thread& t : threads_) t.join();
}

int ForkJoinPool::HardwareWorkers() {
  const unsigned n = std::thread::hardware_concurrency();
  return n == 0 ? 1 : static_cast<int>(std::min<unsigned>(n, kMaxWorkers));
}

void ForkJoinPool::Work(int worker) {
  for (size_t task = next_.fetch_add(1, std::memory_order_relaxed); task < tasks_;
       task = next_.fetch_add(1, std::memory_order_relaxed)) {
    (*fn_)(task, worker);
  }
}

void ForkJoinPool::Loop(int worker) {
  uint64_t seen = 0;
  for (;;) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
      if (stop_) return;
      seen = generation_;
    }
    Work(worker);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (--busy_ == 0) done_.notify_one();
    }
  }
}

void ForkJoinPool::Run(size_t tasks, const std::function<void(size_t task, int worker)>& fn) {
  if (threads_.empty() || tasks <= 1) {
    for (size_t task = 0; task < tasks; ++task) fn(task, 0);
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    fn_ = &fn;
    tasks_ = tasks;
    next_.store(0, std::memory_order_relaxed);
    busy_ = static_cast<int>(threads_.size());
    ++generation_;
  }
  wake_.notify_all();
  Work(0);
  std::unique_lock<std::mutex> lock(mutex_);
  done_.wait(lock, [&] { return busy_ == 0; });
  fn_ = nullptr;
}

}  // namespace meshstream
