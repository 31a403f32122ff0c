#include "services/api/stream_service.h"

#include <atomic>
#include <chrono>
#include <cstdio>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include <grpcpp/alarm.h>

#include "fec/reed_solomon.h"
#include "net/steady_clock.h"
#include "services/api/call_auth.h"
#include "proto/rpc_status.h"
#include "services/api/proto_convert.h"
#include "services/api/server_messages.h"
#include "services/export/version_export.h"
#include "services/store/blob_store.h"
#include "services/streaming/session_plan.h"
#include "services/streaming/session_sender.h"

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

// The session log line's last field: the server's own time from the Open's
// arrival to the SessionStart (the base meshes) handed to gRPC, when it was.
std::string OpenToBase(uint64_t open_us, uint64_t base_us) {
  if (base_us == 0 || base_us < open_us) return "";
  char text[64];
  std::snprintf(text, sizeof text, ", open to base %.3f ms", static_cast<double>(base_us - open_us) / 1000.0);
  return text;
}

SendLoopOptions LoopOptions(const std::atomic<bool>* draining) {
  SendLoopOptions options;  // the default max_queued
  options.draining = draining;
  return options;
}

}  // namespace

// One Open call: the reactor gRPC drives, and the SessionStream the send
// loop writes to. Its messages are written one at a time from a queue
// (gRPC allows one write in flight); the send loop stops feeding the
// session while the queue is full.
class StreamServiceImpl::Call final : public grpc::ServerBidiReactor<v1::ClientMessage, v1::ServerMessage>,
                                      public SessionStream {
 public:
  using Reactor = grpc::ServerBidiReactor<v1::ClientMessage, v1::ServerMessage>;

  Call(StreamServiceImpl* service, grpc::CallbackServerContext* context) : service_(service), context_(context) {
    cancel_->context = context;
    service_->openers_.Post([this] { Admit(); });
  }

  // The reactor.
  void OnReadDone(bool ok) override {
    if (!opened_) {
      opened_ = true;
      open_received_us_ = SteadyNowUs();
      if (!ok || in_.kind_case() != v1::ClientMessage::kOpen) {
        return FinishNow(InvalidArgument("the first message must be open"));
      }
      service_->openers_.Post([this] { OpenSession(); });
      return;
    }
    if (!ok) return registration_.OnClientClosed(false);  // a half-close, or the call ended
    switch (in_.kind_case()) {
      case v1::ClientMessage::kReport:
        registration_.OnReport(FromProto(in_.report()));
        break;
      case v1::ClientMessage::kRepair:
        // Once per session: after its repair request the server reads
        // nothing more from the client (a second one is never seen).
        return registration_.OnRepair(FromProto(in_.repair()));
      case v1::ClientMessage::kDone:
        return registration_.OnClientClosed(true);
      default:
        registration_.OnClientMessage();
        break;
    }
    StartRead(&in_);
  }

  void OnWriteDone(bool ok) override {
    const v1::ServerMessage* next = nullptr;
    bool more = false;
    bool finish = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      queue_.pop_front();
      if (!ok) {
        broken_ = true;
        queue_.clear();
      }
      if (!queue_.empty()) {
        next = &queue_.front();
        more = queue_.size() > 1;
      } else {
        writing_ = false;
        finish = finish_wanted_ && !finished_;
        finished_ = finished_ || finish;
      }
    }
    // A message with others queued behind it is written with gRPC's buffer
    // hint: its write completes at once and the transport sends it with the
    // next ones, in one TCP write when the last of them (never hinted) goes,
    // instead of one system call and one wake-up per message.
    if (next != nullptr) StartWrite(next, more ? grpc::WriteOptions().set_buffer_hint() : grpc::WriteOptions());
    if (finish) Reactor::Finish(finish_status_);
    if (ok) {
      registration_.OnWritten();
    } else {
      registration_.Cancel(Cancelled("the client went away"), "client went away");
    }
  }

  void OnCancel() override {
    cancelled_ = true;
    if (registered_) Stop();
  }

  // gRPC calls it once Finish was called and every reaction has returned.
  // No opener task runs then: each ends with its last touch of the call
  // (FinishNow, StartRead, or Begin, before which nothing can Finish).
  void OnDone() override {
    registration_ = SendLoop::Registration();  // after any step of the send loop under way
    {
      std::lock_guard<std::mutex> lock(cancel_->mutex);
      cancel_->context = nullptr;  // the grace alarm may still fire: it finds nothing to cancel
    }
    delete this;
  }

  // The SessionStream. Start: the SessionStart the opener built, with what
  // only the send loop knows.
  void Start(SessionTransport transport, const UdpEndpoint::Session* udp) override {
    service_->CompleteStart(session_.start, transport, udp);
    Queue(std::move(session_.start));
    base_handed_us_ = SteadyNowUs();
  }

  void TransportChanged(SessionTransport transport, const std::string& reason) override {
    Queue(TransportChangeMessage(transport, reason));
  }

  void Control(const SenderAction& control) override {
    Queue(ControlMessage(session_.hot->bytes, control));
  }

  void Datagram(const uint8_t* data, size_t size) override {
    Queue(DatagramMessage(data, size));
  }

  void RefinementEnd(uint32_t stream, uint32_t refinement, uint32_t datagrams_sent,
                     uint32_t parity_datagrams) override {
    Queue(RefinementEndMessage(stream, refinement, datagrams_sent, parity_datagrams));
  }

  void End(const std::string& reason) override {
    Queue(EndMessage(reason));
  }

  void RepairEnd(uint32_t datagrams, uint64_t bytes) override {
    Queue(RepairEndMessage(datagrams, bytes));
  }

  void Finish(const Status& status, const std::string& reason, const SessionSenderStats& stats) override {
    if (service_->options_.log) {
      service_->options_.log("session " + session_.version.asset + "@" + std::to_string(session_.version.version) + " ended (" +
                             reason + "): " + DescribeSession(stats) + OpenToBase(open_received_us_, base_handed_us_));
    }
    bool now = false, cut = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      finish_wanted_ = true;
      finish_status_ = ToGrpcStatus(status);
      if (!writing_) {
        now = !finished_;
        finished_ = true;
      } else if (!status.ok()) {
        // What is queued is dropped; the write in flight ends the call when
        // it completes (OnWriteDone finishes with the status). A stalled
        // client (the idle cut-off) never completes it: cancelled now. Any
        // other error (a client that asks for what its session has not,
        // say) keeps its status for a client that reads, and is cancelled
        // after a grace period if the write is still stuck then, so that a
        // client that stopped reading cannot hold its slot.
        while (queue_.size() > 1) queue_.pop_back();
        if (status.code() == StatusCode::kDeadlineExceeded) {
          cut = true;
        } else {
          std::shared_ptr<CancelHandle> handle = cancel_;
          grace_.Set(std::chrono::system_clock::now() + kFinishGrace, [handle](bool fired) {
            if (!fired) return;
            std::lock_guard<std::mutex> lock(handle->mutex);
            if (handle->context != nullptr) handle->context->TryCancel();
          });
        }
      }
    }
    if (now) Reactor::Finish(finish_status_);
    if (cut) context_->TryCancel();
  }

  size_t queued() const override {
    std::lock_guard<std::mutex> lock(mutex_);
    return queue_.size();
  }

 private:
  // On the opener pool: who, a slot, then the first message.
  void Admit() {
    auto principal = AuthenticateCall(*service_->auth_, *context_);
    if (!principal.ok()) return FinishNow(principal.status());
    tenant_ = principal->tenant;
    slot_ = service_->sessions_.Acquire(std::chrono::milliseconds(0));
    if (!slot_) {
      return FinishNow(ResourceExhausted("Open: " + std::to_string(service_->sessions_.limit()) +
                                         " sessions are running on this server; retry later"));
    }
    if (Draining()) return FinishNow(Unavailable("the server is shutting down; open the session on another server"));
    StartRead(&in_);
  }

  // On the opener pool: the OpenRequest checked and planned, then the
  // session joins the send loop.
  void OpenSession() {
    auto prepared = service_->PrepareSession(tenant_, in_.open(), /*allow_udp=*/true);
    if (!prepared.ok()) return FinishNow(prepared.status());
    session_ = std::move(prepared).value();
    // Until Begin the send loop does not step the session (send_loop.h): the
    // client's messages and a cancel are only recorded, nothing can Finish
    // the call, and so gRPC cannot end it (OnDone) while this runs.
    registration_ = service_->Register(session_, this, session_.udp ? "udp" : "grpc");
    StartRead(&in_);
    registered_ = true;
    if (cancelled_) Stop();
    registration_.Begin();  // the last touch of `this`: the session may finish at once
  }

  bool Draining() const { return service_->draining_ != nullptr && service_->draining_->load(); }

  // The call was cancelled: by the client, or by the server draining.
  void Stop() {
    if (Draining()) {
      registration_.Drain();
    } else {
      registration_.Cancel(Cancelled("the client went away"), "client went away");
    }
  }

  // Before the session joined the send loop: nothing is queued.
  void FinishNow(const Status& status) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      finished_ = true;
    }
    Reactor::Finish(ToGrpcStatus(status));
  }

  void Queue(v1::ServerMessage message) {
    const v1::ServerMessage* first = nullptr;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (broken_ || finish_wanted_) return;
      queue_.push_back(std::move(message));  // keeps references to the others valid
      if (writing_) return;
      writing_ = true;
      first = &queue_.front();
    }
    StartWrite(first);
  }

  // What the grace alarm of Finish cancels, shared with its callback, which
  // may run after the call is gone (context null then).
  struct CancelHandle {
    std::mutex mutex;
    grpc::CallbackServerContext* context = nullptr;
  };
  static constexpr std::chrono::seconds kFinishGrace{2};

  StreamServiceImpl* service_;
  grpc::CallbackServerContext* context_;
  std::shared_ptr<CancelHandle> cancel_ = std::make_shared<CancelHandle>();
  grpc::Alarm grace_;
  v1::ClientMessage in_;
  bool opened_ = false;  // the first read's callback, then the reads' (one at a time)
  uint64_t open_received_us_ = 0;  // when the OpenRequest arrived (SteadyNowUs)
  uint64_t base_handed_us_ = 0;    // when Start handed the SessionStart to gRPC (the send loop's thread)

  // Set by the opener before the session joins the loop, read-only after
  // (but the SessionStart, which Start moves out).
  std::string tenant_;
  CallLimit::Slot slot_;
  PreparedSession session_;
  SendLoop::Registration registration_;
  std::atomic<bool> registered_{false};
  std::atomic<bool> cancelled_{false};

  mutable std::mutex mutex_;  // below: the write queue
  std::deque<v1::ServerMessage> queue_;  // its front is being written while writing_
  bool writing_ = false;
  bool broken_ = false;  // a write failed: the client is gone
  bool finish_wanted_ = false;
  bool finished_ = false;  // Finish was called
  grpc::Status finish_status_;
};

StreamServiceImpl::StreamServiceImpl(Store* store, const Authenticator* auth, StreamServiceOptions options,
                                     const std::atomic<bool>* draining)
    : store_(store), auth_(auth), options_(std::move(options)), draining_(draining), sessions_(options_.max_sessions),
      artifacts_(options_.stream_cache_bytes), loop_(LoopOptions(draining)), openers_(options_.opener_threads) {}

StreamServiceImpl::~StreamServiceImpl() = default;

StatusOr<PreparedSession> StreamServiceImpl::PrepareSession(const std::string& tenant, const v1::OpenRequest& open,
                                                            bool allow_udp) {
  MS_RETURN_IF_ERROR(CheckOpen(open));
  PreparedSession p;
  MS_ASSIGN_OR_RETURN(p.version, ResolveVersion(tenant, open.asset(), open.version()));
  // The artifact, its plan and its scene: kept in memory between sessions
  // (artifact_cache.h); the store's read, which checks the digest, only
  // when the cache has none.
  const std::string& sha = p.version.artifact.artifact_sha256;
  MS_ASSIGN_OR_RETURN(p.hot, artifacts_.Get(sha, p.version.artifact.layout_json, [&] {
    return store_->GetBlob(sha, options_.max_artifact_bytes);
  }));
  SessionSenderOptions options;
  // The reliable profile has no datagrams: a client that asks for it gets
  // the stream alone (docs/streaming-protocol.md, "Profiles").
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
  if (open.max_level() < 0) {
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

void StreamServiceImpl::CompleteStart(v1::ServerMessage& message, SessionTransport transport,
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

SendLoop::Registration StreamServiceImpl::Register(PreparedSession& session, SessionStream* stream,
                                                   const std::string& transport) {
  if (options_.log) {
    options_.log("session " + session.version.asset + "@" + std::to_string(session.version.version) + " opened (" +
                 transport + ")");
  }
  return loop_.Add(std::move(session.sender), stream, std::move(session.udp));
}

StatusOr<VersionRecord> StreamServiceImpl::ResolveVersion(const std::string& tenant, const std::string& asset,
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

grpc::ServerBidiReactor<v1::ClientMessage, v1::ServerMessage>* StreamServiceImpl::Open(
    grpc::CallbackServerContext* context) {
  return new Call(this, context);
}

}  // namespace meshstream
