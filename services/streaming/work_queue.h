// A fixed number of threads that run queued work in order of arrival: where
// the streaming service does what blocks (the store, planning, the scene)
// for a session being opened, so that no gRPC callback blocks on it and no
// session gets a thread of its own.
//
// Contract: work is a callable that must not throw. The destructor runs what
// is still queued, then joins the threads.
// Thread safety: Post from any thread.
#ifndef MESHSTREAM_SERVICES_STREAMING_WORK_QUEUE_H_
#define MESHSTREAM_SERVICES_STREAMING_WORK_QUEUE_H_

#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace meshstream {

class WorkQueue {
 public:
  explicit WorkQueue(int threads);
  ~WorkQueue();
  WorkQueue(const WorkQueue&) = delete;
  WorkQueue& operator=(const WorkQueue&) = delete;

  void Post(std::function<void()> work);

 private:
  void Run();
  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::function<void()>> queue_;
  bool stop_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STREAMING_WORK_QUEUE_H_
