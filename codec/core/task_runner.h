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

// Independent tasks that may each use workers of their own (a scene's
// streams: each encodes or decodes alone, and one stream can share workers
// within itself): with a runner of several workers and several tasks, every
// task runs at once on one worker and gets no runner (fn(task, nullptr));
// otherwise they run one after the other on this thread, each given the
// runner (fn(task, runner)), until one returns false. Either way the work is
// the same; fn must not throw.
template <typename F>
void RunEachTask(TaskRunner* runner, size_t tasks, F&& fn) {
  if (runner != nullptr && runner->workers() > 1 && tasks > 1) {
    runner->Run(tasks, [&](size_t task, int) { fn(task, static_cast<TaskRunner*>(nullptr)); });
    return;
  }
  for (size_t task = 0; task < tasks; ++task) {
    if (!fn(task, runner)) return;
  }
}

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_CORE_TASK_RUNNER_H_
