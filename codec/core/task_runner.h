// A way to run independent tasks that the caller gives the codec: codec/
// starts no threads of its own (docs/architecture.md), so a decoder that may
// work on several cores is handed a TaskRunner (parallel/fork_join_pool.h has
// one made of threads) and calls Run with the work split into tasks.
//
// Contract: Run(tasks, fn) calls fn(task, worker) exactly once for every task
// in [0, tasks), each on one of workers() workers (0 <= worker < workers()),
// and returns when every call has returned; a worker runs one task at a time,
// so per-worker scratch needs no lock. Tasks may run in any order and at
// once: they must not write what another task reads. fn must not throw.
// Thread safety: one Run at a time per runner.
#ifndef MESHSTREAM_CODEC_CORE_TASK_RUNNER_H_
#define MESHSTREAM_CODEC_CORE_TASK_RUNNER_H_

#include <cstddef>
#include <functional>

namespace meshstream {

class TaskRunner {
 public:
  virtual ~TaskRunner() = default;
  // How many tasks may run at once (at least 1).
  virtual int workers() const = 0;
  virtual void Run(size_t tasks, const std::function<void(size_t task, int worker)>& fn) = 0;
};

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_CORE_TASK_RUNNER_H_
