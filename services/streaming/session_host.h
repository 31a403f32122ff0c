// The host of the streaming sessions (docs/spec/streaming-protocol.md,
// "Sessions"), whatever carries their reliable channel: the gRPC call
// (services/grpc/stream_service.h) and the WebSocket (services/http/
// stream_socket.h) are thin transports on it, each keeping only its wire.
//
// It owns what every session shares: the session slots (`max_sessions`),
// the opener pool (parallel/executor.h, every posted opening runs: a gRPC
// callback or an io thread must not block on the store), the hot artifacts (hot_artifacts.h: each artifact
// read, digest-checked, planned and its scene built once, kept between
// sessions), the READY versions already resolved, the send loop (send_loop.h:
// one thread for every session) and the UDP endpoint it is given. A
// transport's session goes through it in three steps, on the opener pool:
//   Admit     who (the transport authenticates: its credentials differ),
//             a slot (RESOURCE_EXHAUSTED when all are taken), draining
//             (UNAVAILABLE);
//   Prepare   the OpenRequest checked, its version resolved, the artifact,
//             plan, scene, SessionStart and sender made;
//   Register  the session joins the send loop, which drives the transport's
//             SessionStream (queued_session_stream.h) from then on;
// and ends with LogEnd's line. A session whose client sends nothing for
// `idle_timeout` ends DEADLINE_EXCEEDED ("timeout"); a draining server ends
// its sessions UNAVAILABLE.
//
// Thread safety: every method from any thread; the parts it holds are
// thread-safe.
#ifndef MESHSTREAM_SERVICES_STREAMING_SESSION_HOST_H_
#define MESHSTREAM_SERVICES_STREAMING_SESSION_HOST_H_

#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <tuple>

#include "meshstream/v1/stream.pb.h"
#include "net/pacer.h"
#include "net/rate_controller.h"
#include "parallel/call_limit.h"
#include "parallel/executor.h"
#include "services/auth/authenticator.h"
#include "services/store/store.h"
#include "services/streaming/hot_artifacts.h"
#include "services/streaming/send_loop.h"
#include "services/streaming/session_sender.h"
#include "services/streaming/udp_endpoint.h"

namespace meshstream {

struct SessionHostOptions {
  int max_sessions = 4096;                        // concurrent sessions; then RESOURCE_EXHAUSTED
  uint64_t max_artifact_bytes = uint64_t{4} << 30;
  uint64_t stream_cache_bytes = uint64_t{256} << 20;  // hot artifacts, plans and scenes kept (--stream-cache-mb)
  UdpEndpoint* udp = nullptr;                     // null: every session over the stream
  std::string udp_advertise_host;                 // what SessionStart names; empty: "the host you connected to"
  uint16_t udp_advertise_port = 0;
  std::chrono::milliseconds hello_timeout{1000};  // then fall back to the stream
  bool wait_for_hello = false;                    // --udp-wait-hello (SessionSenderOptions::wait_for_hello)
  std::chrono::milliseconds idle_timeout{30000};  // no client message this long: DEADLINE_EXCEEDED
  RateControllerOptions rate;                     // max_bps: the per-session cap
  RateShare* server_share = nullptr;              // --max-rate
  bool reliable_cut = true;                       // --no-reliable-cut: every datagram as UDP (the paper's scheme)
  bool parity = true;                             // --no-parity: no parity datagrams (docs/design/loss-protection.md)
  int opener_threads = 2;                         // the pool that opens sessions (store, plan, scene)
  std::function<void(const std::string&)> log;    // one line per session start and end; may be empty
};

// A session admitted: its tenant and its place among `max_sessions`, held
// for the session's life.
struct SessionAdmission {
  std::string tenant;
  CallLimit::Slot slot;
};

// A session's parts, made by SessionHost::Prepare on the opener pool: the
// OpenRequest checked, its version resolved, its artifact, plan and scene
// from the hot artifacts, the SessionStart but for what CompleteStart fills,
// and the sender.
struct PreparedSession {
  VersionRecord version;
  HotArtifacts::Entry hot;                 // the artifact, its plan and scene, shared with the cache
  std::unique_ptr<SessionPlan> cut_plan;   // with max_level: the session's own cut of hot->plan
  const SessionPlan* plan = nullptr;       // &hot->plan or cut_plan.get()
  std::shared_ptr<UdpEndpoint::Session> udp;  // null: the datagrams go on the stream
  v1::ServerMessage start;
  std::unique_ptr<SessionSender> sender;
};

// A READY version's stored progressive file, hot: the version and the
// artifact's entry (its bytes read and digest-checked once per load).
struct HotVersion {
  VersionRecord version;
  HotArtifacts::Entry hot;
};

class SessionHost {
 public:
  // `store`, `auth` and `draining` outlive the host.
  SessionHost(Store* store, const Authenticator* auth, SessionHostOptions options, const std::atomic<bool>* draining);
  ~SessionHost();
  SessionHost(const SessionHost&) = delete;
  SessionHost& operator=(const SessionHost&) = delete;

  // The transport's authentication result, then a slot and draining: the
  // refusal's status, or the admission.
  StatusOr<SessionAdmission> Admit(const StatusOr<Principal>& principal);
  // Blocks on the store: call it on the opener pool (openers()). With
  // `allow_udp` false (or no UDP endpoint, or TRANSPORT_GRPC asked) the
  // datagrams go on the stream.
  StatusOr<PreparedSession> Prepare(const std::string& tenant, const v1::OpenRequest& open, bool allow_udp);
  // Fills the SessionStart's transport, a fresh session id and, over UDP,
  // the endpoint and keys: SessionStream::Start's work.
  void CompleteStart(v1::ServerMessage& start, SessionTransport transport, const UdpEndpoint::Session* udp) const;
  // Adds the prepared session to the send loop with `stream`, logging its
  // opening ("session ASSET@VERSION opened (TRANSPORT)"); the caller Begins
  // the registration once it holds it.
  SendLoop::Registration Register(PreparedSession& session, SessionStream* stream, const std::string& transport);
  // "session ASSET@VERSION ended (REASON`note`): STATS`tail`", when logging.
  void LogEnd(const PreparedSession& session, const std::string& reason, const std::string& note,
              const SessionSenderStats& stats, const std::string& tail) const;

  // The hot artifact of a READY version (ResolveVersion's rules), loaded
  // from the store at most once while it is kept or held: what sessions
  // open with, and what the HTTP route serves ranges of the stored
  // progressive file from (a range is a lookup and a slice). Blocks on the
  // store on a miss.
  StatusOr<HotVersion> HotFile(const std::string& tenant, const std::string& asset, int64_t version);

  Executor& openers() { return openers_; }
  const Authenticator& authenticator() const { return *auth_; }
  bool draining() const { return draining_ != nullptr && draining_->load(); }
  const SessionHostOptions& options() const { return options_; }
  size_t active_sessions() const { return loop_.sessions(); }
  HotArtifactsStats hot_artifacts() const { return artifacts_.stats(); }

 private:
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
  SessionHostOptions options_;
  const std::atomic<bool>* draining_;
  CallLimit sessions_;
  HotArtifacts artifacts_;
  std::mutex ready_mutex_;  // below
  std::map<std::tuple<std::string, std::string, int64_t>, VersionRecord> ready_;
  std::deque<std::tuple<std::string, std::string, int64_t>> ready_order_;  // oldest first
  SendLoop loop_;       // before openers_: the pool stops first
  Executor openers_;
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STREAMING_SESSION_HOST_H_
