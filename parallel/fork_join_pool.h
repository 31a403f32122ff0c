// A fork-join pool: a fixed set of threads that runs a TaskRunner's tasks (codec/core/
// task_runner.h): the codec's parallel decode takes one, so that the codec
// itself starts no threads. The calling thread is worker 0 and works too, so
// a pool of N workers starts N - 1 threads, once, in its constructor; they
// sleep between Runs and are joined by the destructor.
//
// Contract: Run hands tasks out one at a time from a shared counter (a task
// that takes longer does not hold the others up) and returns when all have
// run; with one worker (or one task) it runs them in order on the caller's
// thread with no synchronization. Thread safety: one Run at a time.
#ifndef MESHSTREAM_PARALLEL_FORK_JOIN_POOL_H_
#define MESHSTREAM_PARALLEL_FORK_JOIN_POOL_H_

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "codec/core/task_runner.h"

namespace meshstream {

class ForkJoinPool final : public TaskRunner {
 public:
  // `workers` is clamped to [1, kMaxWorkers].
  explicit ForkJoinPool(int workers);
  ~ForkJoinPool() override;
  ForkJoinPool(const ForkJoinPool&) = delete;
  ForkJoinPool& operator=(const ForkJoinPool&) = delete;

  int workers() const override { return static_cast<int>(threads_.size()) + 1; }
  void Run(size_t tasks, const std::function<void(size_t task, int worker)>& fn) override;

  // More threads than this buys nothing for one decode (docs/results/decode-profile.md).
  static constexpr int kMaxWorkers = 64;
  // The workers a host has (std::thread::hardware_concurrency, at least 1).
  static int HardwareWorkers();

 private:
  void Loop(int worker);
  void Work(int worker);

  std::vector<std::thread> threads_;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  uint64_t generation_ = 0;  // one per Run; a worker runs each generation once
  int busy_ = 0;             // threads still in the current generation
  bool stop_ = false;
  // The current Run (read by the threads after they see its generation).
  const std::function<void(size_t, int)>* fn_ = nullptr;
  size_t tasks_ = 0;
  std::atomic<size_t> next_{0};
};

}  // namespace meshstream

#endif  // MESHSTREAM_PARALLEL_FORK_JOIN_POOL_H_
