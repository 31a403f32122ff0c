// meshstream.v1.StreamService: the reliable half of a streaming session
// (docs/streaming-protocol.md, "Sessions") on gRPC's callback API, a thin
// translation between protobuf and services/streaming/: each Open is a
// grpc::ServerBidiReactor (StreamServiceImpl::Call) whose callbacks hand the
// client's messages to the session's SessionSender (session_sender.h), which
// one sending thread drives for every session (send_loop.h). No session has
// a thread of its own.
//
// Per call, on a small fixed pool of opener threads (work_queue.h), since a
// gRPC callback must not block: authenticate, take a session slot
// (RESOURCE_EXHAUSTED beyond `max_sessions`), read the OpenRequest, check
// it, resolve the version the token sees, take the artifact, its plan and
// its scene from the cache of hot artifacts (artifact_cache.h: loaded from
// the store, its digest checked, planned and its scene built once, kept
// between sessions); then the session joins the send loop and the server
// logs "session ASSET@VERSION opened (TRANSPORT)". A session whose client sends
// nothing for `idle_timeout` ends DEADLINE_EXCEEDED ("timeout"); a draining
// server ends its sessions UNAVAILABLE. One log line per session end.
//
// Thread safety: gRPC calls Open from its threads at once; the class holds
// pointers to thread-safe parts, the scene cache, the send loop and the pool.
#ifndef MESHSTREAM_SERVICES_API_STREAM_SERVICE_H_
#define MESHSTREAM_SERVICES_API_STREAM_SERVICE_H_

#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <mutex>
#include <tuple>
#include <functional>
#include <string>

#include "meshstream/v1/stream.grpc.pb.h"
#include "net/pacer.h"
#include "net/rate_controller.h"
#include "services/api/call_limit.h"
#include "services/auth/authenticator.h"
#include "services/store/store.h"
#include "services/streaming/artifact_cache.h"
#include "services/streaming/send_loop.h"
#include "services/streaming/udp_endpoint.h"
#include "services/streaming/work_queue.h"

namespace meshstream {

struct StreamServiceOptions {
  int max_sessions = 4096;                        // concurrent sessions; then RESOURCE_EXHAUSTED
  uint64_t max_artifact_bytes = uint64_t{4} << 30;
  uint64_t stream_cache_bytes = uint64_t{256} << 20;  // hot artifacts, plans and scenes kept (--stream-cache-mb)
  UdpEndpoint* udp = nullptr;                     // null: every session over gRPC
  std::string udp_advertise_host;                 // what SessionStart names; empty: "the host you connected to"
  uint16_t udp_advertise_port = 0;
  std::chrono::milliseconds hello_timeout{1000};  // then fall back to gRPC
  bool wait_for_hello = false;                    // --udp-wait-hello (SessionSenderOptions::wait_for_hello)
  std::chrono::milliseconds idle_timeout{30000};  // no client message this long: DEADLINE_EXCEEDED
  RateControllerOptions rate;                     // max_bps: the per-session cap
  RateShare* server_share = nullptr;              // --max-rate
  bool reliable_cut = true;                       // --no-reliable-cut: every datagram as UDP (the paper's scheme)
  bool parity = true;                             // --no-parity: no parity datagrams (docs/loss-protection.md)
  int opener_threads = 2;                         // the pool that opens sessions (store, plan, scene)
  std::function<void(const std::string&)> log;    // one line per session start and end; may be empty
};

// A session's parts every transport shares (the gRPC call here, the
// WebSocket route of services/http/stream_socket.h), made by
// StreamServiceImpl::PrepareSession on the opener pool: the OpenRequest
// checked, its version resolved, its artifact, plan and scene from the cache,
// the SessionStart but for what CompleteStart fills, and the sender.
struct PreparedSession {
  VersionRecord version;
  ArtifactCache::Entry hot;                // the artifact, its plan and scene, shared with the cache
  std::unique_ptr<SessionPlan> cut_plan;   // with max_level: the session's own cut of hot->plan
  const SessionPlan* plan = nullptr;       // &hot->plan or cut_plan.get()
  std::shared_ptr<UdpEndpoint::Session> udp;  // null: the datagrams go on the stream
  v1::ServerMessage start;
  std::unique_ptr<SessionSender> sender;
};

class StreamServiceImpl final : public v1::StreamService::CallbackService {
 public:
  StreamServiceImpl(Store* store, const Authenticator* auth, StreamServiceOptions options,
                    const std::atomic<bool>* draining);
  ~StreamServiceImpl() override;

  grpc::ServerBidiReactor<v1::ClientMessage, v1::ServerMessage>* Open(grpc::CallbackServerContext* context) override;

  size_t active_sessions() const { return loop_.sessions(); }

  // For the transports beside gRPC's (services/http/stream_socket.h): the
  // same limits, checks, cache and send loop as Open.
  // A place among `max_sessions`; empty when they are all taken.
  CallLimit::Slot TryAcquireSession() { return sessions_.Acquire(std::chrono::milliseconds(0)); }
  int session_limit() const { return sessions_.limit(); }
  // Blocks on the store: call it on the opener pool (openers()). With
  // `allow_udp` false (or no UDP endpoint, or TRANSPORT_GRPC asked) the
  // datagrams go on the stream.
  StatusOr<PreparedSession> PrepareSession(const std::string& tenant, const v1::OpenRequest& open, bool allow_udp);
  // Fills the SessionStart's transport, a fresh session id and, over UDP,
  // the endpoint and keys: SessionStream::Start's work.
  void CompleteStart(v1::ServerMessage& start, SessionTransport transport, const UdpEndpoint::Session* udp) const;
  // Adds the prepared session to the send loop with `stream`, logging its
  // opening; the caller Begins the registration once it holds it.
  SendLoop::Registration Register(PreparedSession& session, SessionStream* stream, const std::string& transport);
  WorkQueue& openers() { return openers_; }
  const Authenticator& authenticator() const { return *auth_; }
  bool draining() const { return draining_ != nullptr && draining_->load(); }
  const StreamServiceOptions& options() const { return options_; }

 private:
  class Call;

  // The READY version a session names: ResolveReadyVersion, except that a
  // version named by its number (> 0) is looked up in the store once and
  // kept (kMaxReadyVersions, the oldest out first): a READY version never
  // changes (versions are never deleted nor re-processed), and the store's
  // lookup was most of a session's opening. Version 0 (the latest) is
  // always asked of the store.
  StatusOr<VersionRecord> ResolveVersion(const std::string& tenant, const std::string& asset, int64_t version);
  static constexpr size_t kMaxReadyVersions = 1024;

  Store* store_;
  const Authenticator* auth_;
  StreamServiceOptions options_;
  const std::atomic<bool>* draining_;
  CallLimit sessions_;
  ArtifactCache artifacts_;
  std::mutex ready_mutex_;  // below
  std::map<std::tuple<std::string, std::string, int64_t>, VersionRecord> ready_;
  std::deque<std::tuple<std::string, std::string, int64_t>> ready_order_;  // oldest first
  SendLoop loop_;       // before openers_: the pool stops first
  WorkQueue openers_;
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_API_STREAM_SERVICE_H_
