// meshstream.v1.StreamService: the reliable half of a streaming session
// (docs/streaming-protocol.md, "Sessions"), a thin translation between
// protobuf and the session runner (services/streaming/session_runner.h),
// which sends the plan (services/streaming/session_plan.h) and paces the
// UDP datagrams (services/streaming/udp_endpoint.h).
//
// Per call: authenticate, resolve the version the token sees, plan, then a
// reader thread takes the client's reports to the runner while the call's
// thread runs it. A session whose client sends nothing (no report, no
// HELLO) for `idle_timeout` is cancelled ("timeout"), as is one the server
// drains.
//
// Thread safety: gRPC calls Open from its threads at once; the class holds
// only pointers to thread-safe parts and a mutex-guarded registry.
#ifndef MESHSTREAM_SERVICES_API_STREAM_SERVICE_H_
#define MESHSTREAM_SERVICES_API_STREAM_SERVICE_H_

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <set>
#include <string>
#include <thread>

#include "meshstream/v1/stream.grpc.pb.h"
#include "net/pacer.h"
#include "net/rate_controller.h"
#include "services/api/call_limit.h"
#include "services/auth/authenticator.h"
#include "services/store/store.h"
#include "services/streaming/session_scene.h"
#include "services/streaming/udp_endpoint.h"

namespace meshstream {

struct StreamServiceOptions {
  int max_sessions = 256;                         // concurrent sessions; then RESOURCE_EXHAUSTED
  uint64_t max_artifact_bytes = uint64_t{4} << 30;
  UdpEndpoint* udp = nullptr;                     // null: every session over gRPC
  std::string udp_advertise_host;                 // what SessionStart names; empty: "the host you connected to"
  uint16_t udp_advertise_port = 0;
  std::chrono::milliseconds hello_timeout{1000};  // then fall back to gRPC
  std::chrono::milliseconds idle_timeout{30000};  // no client message nor HELLO this long: cancelled
  RateControllerOptions rate;                     // max_bps: the per-session cap
  RateShare* server_share = nullptr;              // --max-rate
  bool reliable_cut = true;                       // --no-reliable-cut: every datagram as UDP (the paper's scheme)
  std::function<void(const std::string&)> log;    // one line per session end; may be empty
};

class StreamServiceImpl final : public v1::StreamService::Service {
 public:
  StreamServiceImpl(Store* store, const Authenticator* auth, StreamServiceOptions options,
                    const std::atomic<bool>* draining);
  ~StreamServiceImpl() override;

  grpc::Status Open(grpc::ServerContext* context,
                    grpc::ServerReaderWriter<v1::ServerMessage, v1::ClientMessage>* stream) override;

  int active_sessions() const;

 private:
  struct Live;  // one running session, as the watchdog sees it
  void Watch();

  Store* store_;
  const Authenticator* auth_;
  StreamServiceOptions options_;
  const std::atomic<bool>* draining_;
  CallLimit sessions_;
  SessionSceneCache scenes_;

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::set<Live*> live_;
  bool stop_ = false;
  std::thread watchdog_;
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_API_STREAM_SERVICE_H_
