// The threads where the HTTP server's routes run: everything that may block
// (store reads, exports that decode, files) happens here, never on the io
// threads, which only parse, dispatch and write (http_server.h).
//
// A fixed number of threads take work in order of arrival. The queue needs
// no bound of its own: each connection has at most one request in it (the
// server reads the next request only after the response is written), so it
// holds at most --http max connections items.
//
// Contract: work must not throw (the server's work catches everything).
// Stop drops what is still queued (its destructors run on the caller's
// thread), waits for the running work and joins; Post after Stop returns
// false and drops the work.
// Thread safety: Post and Stop from any thread.
#ifndef MESHSTREAM_SERVICES_HTTP_REQUEST_POOL_H_
#define MESHSTREAM_SERVICES_HTTP_REQUEST_POOL_H_

#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace meshstream {

class RequestPool {
 public:
  explicit RequestPool(int threads);
  ~RequestPool();
  RequestPool(const RequestPool&) = delete;
  RequestPool& operator=(const RequestPool&) = delete;

  bool Post(std::function<void()> work);
  void Stop();

 private:
  void Run();
  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::function<void()>> queue_;
  bool stop_ = false;
  std::vector<std::thread> threads_;
  std::mutex join_mutex_;  // one Stop joins; the others wait for it
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_HTTP_REQUEST_POOL_H_
