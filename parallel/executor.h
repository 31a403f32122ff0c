// A fixed number of threads that run posted work in order of arrival (FIFO):
// where a server does what may block (the store, planning a session, an
// export that decodes, a file) so that no gRPC callback or io thread blocks
// on it. The one queue of the server's opener pool (services/streaming/
// session_host.h) and of the HTTP routes (services/http/http_server.h).
//
// What happens to work still queued when the executor stops is said once,
// when it is made:
//   kRunQueued   Stop (and the destructor) runs what is queued, then joins:
//                every posted callable runs (a session's opener must answer
//                its call);
//   kDropQueued  Stop drops what is queued (its destructors run on the
//                caller's thread), waits for the running work and joins (a
//                draining HTTP server answers nothing more).
// Post after Stop returns false and drops the work.
//
// Contract: work is a callable that must not throw.
// Thread safety: Post and Stop from any thread; one Stop joins, the others
// wait for it.
#ifndef MESHSTREAM_PARALLEL_EXECUTOR_H_
#define MESHSTREAM_PARALLEL_EXECUTOR_H_

#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace meshstream {

class Executor {
 public:
  enum class StopPolicy { kRunQueued, kDropQueued };

  Executor(int threads, StopPolicy policy);
  ~Executor();
  Executor(const Executor&) = delete;
  Executor& operator=(const Executor&) = delete;

  bool Post(std::function<void()> work);
  void Stop();

 private:
  void Run();

  const StopPolicy policy_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::function<void()>> queue_;
  bool stop_ = false;
  std::vector<std::thread> threads_;
  std::mutex join_mutex_;  // one Stop joins; the others wait for it
};

}  // namespace meshstream

#endif  // MESHSTREAM_PARALLEL_EXECUTOR_H_
