// Executor (parallel/executor.h): FIFO order, and each stop policy.
#include "parallel/executor.h"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace meshstream {
namespace {

// Holds the executor's one thread until released, so that what is posted
// after it stays queued (no timing involved).
struct Gate {
  std::mutex mutex;
  std::condition_variable cv;
  bool entered = false, open = false;
  void Hold() {
    std::unique_lock<std::mutex> lock(mutex);
    entered = true;
    cv.notify_all();
    cv.wait(lock, [this] { return open; });
  }
  void WaitEntered() {
    std::unique_lock<std::mutex> lock(mutex);
    cv.wait(lock, [this] { return entered; });
  }
  void Open() {
    std::lock_guard<std::mutex> lock(mutex);
    open = true;
    cv.notify_all();
  }
};

TEST(Executor, OneThreadRunsWorkInOrderOfArrival) {
  std::vector<int> order;
  {
    Executor executor(1, Executor::StopPolicy::kRunQueued);
    for (int i = 0; i < 100; ++i) ASSERT_TRUE(executor.Post([&order, i] { order.push_back(i); }));
  }  // the destructor runs what is queued
  ASSERT_EQ(order.size(), 100u);
  for (int i = 0; i < 100; ++i) EXPECT_EQ(order[static_cast<size_t>(i)], i);
}

TEST(Executor, RunQueuedRunsEverythingPostedBeforeStop) {
  Gate gate;
  std::atomic<int> ran{0};
  Executor executor(1, Executor::StopPolicy::kRunQueued);
  executor.Post([&] { gate.Hold(); });
  gate.WaitEntered();
  for (int i = 0; i < 10; ++i) executor.Post([&] { ran.fetch_add(1); });
  gate.Open();
  executor.Stop();
  EXPECT_EQ(ran.load(), 10);
  EXPECT_FALSE(executor.Post([&] { ran.fetch_add(1); }));
  EXPECT_EQ(ran.load(), 10);
}

TEST(Executor, DropQueuedDropsWhatHasNotStarted) {
  Gate gate;
  std::atomic<int> ran{0};
  auto token = std::make_shared<int>(0);  // destroyed with the dropped work
  Executor executor(1, Executor::StopPolicy::kDropQueued);
  executor.Post([&] { gate.Hold(); });
  gate.WaitEntered();
  for (int i = 0; i < 10; ++i) executor.Post([&ran, token] { ran.fetch_add(1); });
  std::thread stopper([&] { executor.Stop(); });
  // Stop drops the queue before it waits for the running work.
  while (token.use_count() > 1) std::this_thread::yield();
  gate.Open();
  stopper.join();
  EXPECT_EQ(ran.load(), 0);
  EXPECT_FALSE(executor.Post([&] { ran.fetch_add(1); }));
}

TEST(Executor, SeveralThreadsRunEveryWorkOnce) {
  std::vector<std::atomic<int>> runs(1000);
  {
    Executor executor(4, Executor::StopPolicy::kRunQueued);
    for (size_t i = 0; i < runs.size(); ++i) executor.Post([&runs, i] { runs[i].fetch_add(1); });
  }
  for (size_t i = 0; i < runs.size(); ++i) ASSERT_EQ(runs[i].load(), 1) << i;
}

}  // namespace
}  // namespace meshstream
