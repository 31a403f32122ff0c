// ForkJoinPool (parallel/fork_join_pool.h): the codec's TaskRunner made of threads.
#include <atomic>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "parallel/fork_join_pool.h"

namespace meshstream {
namespace {

TEST(ForkJoinPool, RunsEveryTaskOnceOnAWorkerInRange) {
  ForkJoinPool pool(3);
  ASSERT_EQ(pool.workers(), 3);
  for (int round = 0; round < 50; ++round) {  // the same threads, Run after Run
    const size_t tasks = 1 + static_cast<size_t>(round) * 7;
    std::vector<std::atomic<int>> runs(tasks);
    std::atomic<int> bad_worker{0};
    pool.Run(tasks, [&](size_t task, int worker) {
      runs[task].fetch_add(1);
      if (worker < 0 || worker >= 3) bad_worker.fetch_add(1);
    });
    for (size_t t = 0; t < tasks; ++t) ASSERT_EQ(runs[t].load(), 1) << "round " << round << ", task " << t;
    EXPECT_EQ(bad_worker.load(), 0);
  }
}

TEST(ForkJoinPool, ReturnsOnlyWhenEveryTaskHasReturned) {
  ForkJoinPool pool(2);
  std::atomic<int> finished{0};
  pool.Run(8, [&](size_t, int) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    finished.fetch_add(1);
  });
  EXPECT_EQ(finished.load(), 8);
}

TEST(ForkJoinPool, TheOtherWorkersTakeTasksWhileTheCallerIsBusy) {
  ForkJoinPool pool(2);
  // Task 0 waits until another worker has run task 1: with one thread this
  // would never end, so it proves the second worker runs tasks concurrently.
  std::atomic<bool> second{false};
  std::atomic<int> worker_of_second{-1};
  pool.Run(2, [&](size_t task, int worker) {
    if (task == 1) {
      worker_of_second = worker;
      second = true;
      return;
    }
    while (!second.load()) std::this_thread::yield();
  });
  EXPECT_TRUE(second.load());
  EXPECT_GE(worker_of_second.load(), 0);
}

TEST(ForkJoinPool, OneWorkerRunsTheTasksInOrderOnTheCallersThread) {
  ForkJoinPool pool(1);
  EXPECT_EQ(pool.workers(), 1);
  std::vector<size_t> order;
  const std::thread::id caller = std::this_thread::get_id();
  bool elsewhere = false;
  pool.Run(5, [&](size_t task, int worker) {
    order.push_back(task);
    elsewhere |= std::this_thread::get_id() != caller || worker != 0;
  });
  EXPECT_EQ(order, (std::vector<size_t>{0, 1, 2, 3, 4}));
  EXPECT_FALSE(elsewhere);
}

TEST(ForkJoinPool, WorkerCountsAreClamped) {
  EXPECT_EQ(ForkJoinPool(0).workers(), 1);
  EXPECT_EQ(ForkJoinPool(-4).workers(), 1);
  EXPECT_GE(ForkJoinPool::HardwareWorkers(), 1);
  EXPECT_LE(ForkJoinPool::HardwareWorkers(), ForkJoinPool::kMaxWorkers);
}

TEST(ForkJoinPool, NoTasksIsFine) {
  ForkJoinPool pool(2);
  bool called = false;
  pool.Run(0, [&](size_t, int) { called = true; });
  EXPECT_FALSE(called);
}

}  // namespace
}  // namespace meshstream
