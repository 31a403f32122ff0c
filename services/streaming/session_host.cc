#include "services/streaming/session_host.h"

#include <utility>

#include "fec/reed_solomon.h"
#include "net/steady_clock.h"
#include "proto/sha256.h"
#include "services/store/ready_version.h"
#include "services/streaming/session_messages.h"

namespace meshstream {

namespace {

Status CheckOpen(const v1::OpenRequest& open) {
  MS_RETURN_IF_ERROR(CheckName("asset", open.asset()));
  if (open.max_level() < -1) return InvalidArgument("max_level: -1 (all) or a level >= 0");
  if (!v1::Transport_IsValid(open.transport())) return InvalidArgument("transport: unknown value");
  if (!v1::Profile_IsValid(open.profile())) return InvalidArgument("profile: unknown value");
  if (open.has_expected_loss() && !(open.expected_loss() >= 0 && open.expected_loss() <= 1)) {
    return InvalidArgument("expected_loss: a rate in [0, 1]");
  }
  return Status::Ok();
}

SendLoopOptions LoopOptions(const std::atomic<bool>* draining) {
  SendLoopOptions options;  // the default max_queued
  options.draining = draining;
  return options;
}

}  // namespace

SessionHost::SessionHost(Store* store, const Authenticator* auth, SessionHostOptions options,
                         const std::atomic<bool>* draining)
    : store_(store), auth_(auth), options_(std::move(options)), draining_(draining), sessions_(options_.max_sessions),
      artifacts_(options_.stream_cache_bytes), loop_(LoopOptions(draining)),
      openers_(options_.opener_threads, Executor::StopPolicy::kRunQueued) {}

SessionHost::~SessionHost() = default;

StatusOr<SessionAdmission> SessionHost::Admit(const StatusOr<Principal>& principal) {
  if (!principal.ok()) return principal.status();
  SessionAdmission admission;
  admission.tenant = principal->tenant;
  admission.slot = sessions_.Acquire(std::chrono::milliseconds(0));
  if (!admission.slot) {
    return ResourceExhausted("Open: " + std::to_string(sessions_.limit()) +
                             " sessions are running on this server; retry later");
  }
  if (draining()) return Unavailable("the server is shutting down; open the session on another server");
  return admission;
}

StatusOr<PreparedSession> SessionHost::Prepare(const std::string& tenant, const v1::OpenRequest& open,
                                               bool allow_udp) {
  MS_RETURN_IF_ERROR(CheckOpen(open));
  PreparedSession p;
  MS_ASSIGN_OR_RETURN(HotVersion file, HotFile(tenant, open.asset(), open.version()));
  p.version = std::move(file.version);
  p.hot = std::move(file.hot);
  SessionSenderOptions options;
  // The reliable profile has no datagrams: a client that asks for it gets
  // the stream alone (docs/spec/streaming-protocol.md, "Profiles").
  const bool wants_reliable = open.profile() == v1::PROFILE_RELIABLE;
  if (allow_udp && open.transport() != v1::TRANSPORT_GRPC && !wants_reliable && options_.udp != nullptr) {
    auto registered = options_.udp->RegisterSession();
    if (registered.ok()) p.udp = std::move(registered).value();
  }
  options.transport = p.udp ? SessionTransport::kUdp : SessionTransport::kGrpc;
  // The profile: the reliable one wherever nothing is lost (the stream:
  // TRANSPORT_GRPC and the WebSocket), the loss-tolerant one over UDP
  // (every refinement of a UDP session, also those begun on the stream
  // before the HELLO, is of one profile: the decoder's state is the
  // profile's), or what the client asked for.
  const bool reliable =
      open.profile() == v1::PROFILE_RELIABLE ||
      (open.profile() == v1::PROFILE_AUTO && options.transport == SessionTransport::kGrpc);
  const SessionPlan& full = reliable ? p.hot->reliable_plan : p.hot->plan;
  if (open.has_view()) {
    // What the client sees orders the session (docs/spec/streaming-protocol.md, "Views").
    MS_ASSIGN_OR_RETURN(View view, FromProto(open.view()));
    p.cut_plan = std::make_unique<SessionPlan>(ViewPlan(full, view, open.max_level()));
    p.plan = p.cut_plan.get();
  } else if (open.max_level() < 0) {
    p.plan = &full;
  } else {
    p.cut_plan = std::make_unique<SessionPlan>(CutPlan(full, open.max_level()));
    p.plan = p.cut_plan.get();
  }
  if (p.udp) {
    UdpEndpoint::Session* raw = p.udp.get();
    options.reserve_packet_numbers = [raw](uint64_t count) { return raw->ReservePacketNumbers(count); };
  }
  options.hello_timeout_us = static_cast<uint64_t>(options_.hello_timeout.count()) * 1000;
  options.wait_for_hello = options_.wait_for_hello;
  options.idle_timeout_us = static_cast<uint64_t>(options_.idle_timeout.count()) * 1000;
  options.rate = options_.rate;
  options.server_share = options_.server_share;
  options.reliable_cut = options_.reliable_cut;
  options.erasure = options_.parity && !open.no_parity() ? &fec::DefaultErasureCode() : nullptr;
  options.expected_loss = open.has_expected_loss() ? open.expected_loss() : -1;
  options.repair = open.repair();
  // Every header, base mesh and the scene copied here, on the opener pool,
  // not on the send thread under the session's lock.
  p.start = SessionStartMessage(*p.plan, p.hot->bytes, options.transport);
  p.start.mutable_session()->set_asset(p.version.asset);
  p.start.mutable_session()->set_version(p.version.version);
  p.start.mutable_session()->set_scene_glb(reinterpret_cast<const char*>(p.hot->scene.data()), p.hot->scene.size());
  p.sender = std::make_unique<SessionSender>(*p.plan, p.hot->bytes, open.max_level(), std::move(options), SteadyNowUs());
  return p;
}

void SessionHost::CompleteStart(v1::ServerMessage& message, SessionTransport transport,
                                const UdpEndpoint::Session* udp) const {
  v1::SessionStart& start = *message.mutable_session();
  start.set_transport(ToProto(transport));
  start.set_session_id(RandomHex(16));
  if (udp != nullptr) {
    start.mutable_udp()->set_host(options_.udp_advertise_host);
    start.mutable_udp()->set_port(options_.udp_advertise_port);
    start.set_udp_session_id(udp->id());
    const SessionKeys& keys = udp->keys();
    start.set_client_to_server_key(std::string(keys.client_to_server.begin(), keys.client_to_server.end()));
    start.set_server_to_client_key(std::string(keys.server_to_client.begin(), keys.server_to_client.end()));
  }
}

SendLoop::Registration SessionHost::Register(PreparedSession& session, SessionStream* stream,
                                             const std::string& transport) {
  if (options_.log) {
    options_.log("session " + session.version.asset + "@" + std::to_string(session.version.version) + " opened (" +
                 transport + ")");
  }
  return loop_.Add(std::move(session.sender), stream, std::move(session.udp));
}

void SessionHost::LogEnd(const PreparedSession& session, const std::string& reason, const std::string& note,
                         const SessionSenderStats& stats, const std::string& tail) const {
  if (!options_.log) return;
  options_.log("session " + session.version.asset + "@" + std::to_string(session.version.version) + " ended (" +
               reason + note + "): " + DescribeSession(stats) + tail);
}

StatusOr<HotVersion> SessionHost::HotFile(const std::string& tenant, const std::string& asset, int64_t version) {
  HotVersion out;
  MS_ASSIGN_OR_RETURN(out.version, ResolveVersion(tenant, asset, version));
  // The artifact, its plans and its scene: kept in memory between sessions
  // (hot_artifacts.h); the store's read, which checks the digest, only
  // when the cache has none.
  const std::string& sha = out.version.artifact.artifact_sha256;
  MS_ASSIGN_OR_RETURN(out.hot, artifacts_.Get(sha, out.version.artifact.layout_json, [&] {
    return store_->GetBlob(sha, options_.max_artifact_bytes);
  }));
  return out;
}

StatusOr<VersionRecord> SessionHost::ResolveVersion(const std::string& tenant, const std::string& asset,
                                                    int64_t version) {
  auto key = std::make_tuple(tenant, asset, version);
  if (version > 0) {
    std::lock_guard<std::mutex> lock(ready_mutex_);
    auto it = ready_.find(key);
    if (it != ready_.end()) return it->second;
  }
  auto record = ResolveReadyVersion(*store_, tenant, asset, version);
  if (!record.ok() || version <= 0) return record;
  std::lock_guard<std::mutex> lock(ready_mutex_);
  if (ready_.emplace(key, record.value()).second) {
    ready_order_.push_back(std::move(key));
    if (ready_order_.size() > kMaxReadyVersions) {
      ready_.erase(ready_order_.front());
      ready_order_.pop_front();
    }
  }
  return record;
}

}  // namespace meshstream
