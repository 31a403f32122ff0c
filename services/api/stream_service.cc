#include "services/api/stream_service.h"

#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <tuple>
#include <utility>

#include "services/api/call_auth.h"
#include "services/api/grpc_status.h"
#include "services/export/version_export.h"
#include "services/store/blob_store.h"
#include "services/streaming/session_plan.h"
#include "services/streaming/session_runner.h"

namespace meshstream {

namespace {

using Clock = std::chrono::steady_clock;

// How long a session waits after SessionEnd for the client to half-close.
constexpr std::chrono::milliseconds kLinger{2000};
// With OpenRequest.repair: how long after SessionEnd the server waits for the
// client's RepairRequest (it flushes its last refinements first).
constexpr std::chrono::milliseconds kRepairWait{10000};

// The datagrams a RepairRequest names, checked against the session's plan:
// every item a primitive and refinement of this session, every ordinal one of
// its datagrams; repeats are sent once. InvalidArgument naming the first
// item that does not fit.
StatusOr<std::vector<ByteRange>> RepairDatagrams(const SessionPlan& plan, const v1::RepairRequest& request) {
  std::map<std::pair<uint32_t, uint32_t>, const PlannedRefinement*> by_key;
  for (const PlannedRefinement& r : plan.refinements) {
    by_key[{plan.primitives[r.primitive].stream, r.refinement}] = &r;
  }
  std::set<std::tuple<uint32_t, uint32_t, uint32_t>> seen;
  std::vector<ByteRange> out;
  for (int i = 0; i < request.items_size(); ++i) {
    const v1::RepairItem& item = request.items(i);
    const std::string where = "repair.items[" + std::to_string(i) + "]";
    auto it = by_key.find({item.primitive(), item.refinement()});
    if (it == by_key.end()) {
      return InvalidArgument(where + ": primitive " + std::to_string(item.primitive()) + " refinement " +
                             std::to_string(item.refinement()) + " is not part of this session");
    }
    const PlannedRefinement& r = *it->second;
    for (uint32_t k : item.datagrams()) {
      if (k >= r.datagrams.size()) {
        return InvalidArgument(where + ": datagram " + std::to_string(k) + " does not exist (the refinement has " +
                               std::to_string(r.datagrams.size()) + ")");
      }
      if (seen.insert({item.primitive(), item.refinement(), k}).second) out.push_back(r.datagrams[k]);
    }
  }
  return out;
}

std::string Slice(const std::vector<uint8_t>& bytes, const ByteRange& r) {
  return std::string(reinterpret_cast<const char*>(bytes.data() + r.offset), r.length);
}

v1::Transport ToProto(SessionTransport t) {
  return t == SessionTransport::kUdp ? v1::TRANSPORT_UDP : v1::TRANSPORT_GRPC;
}

// Writes the runner's blocks as ServerMessages on the call's stream.
class GrpcSink final : public SessionSink {
 public:
  GrpcSink(grpc::ServerReaderWriter<v1::ServerMessage, v1::ClientMessage>* stream, const SessionPlan& plan,
           const std::vector<uint8_t>& artifact, const VersionRecord& version, const StreamServiceOptions& options,
           const std::vector<uint8_t>& scene)
      : stream_(stream), plan_(plan), artifact_(artifact), version_(version), options_(options), scene_(scene) {}

  bool Start(SessionTransport transport, const UdpEndpoint::Session* udp) override {
    v1::ServerMessage message;
    v1::SessionStart& start = *message.mutable_session();
    start.set_session_id(RandomHex(16));
    start.set_asset(version_.asset);
    start.set_version(version_.version);
    start.set_transport(ToProto(transport));
    start.set_max_datagram_bytes(static_cast<uint32_t>(kMaxDatagramBytes));
    start.set_scene_glb(reinterpret_cast<const char*>(scene_.data()), scene_.size());
    if (udp != nullptr) {
      start.mutable_udp()->set_host(options_.udp_advertise_host);
      start.mutable_udp()->set_port(options_.udp_advertise_port);
      start.set_udp_session_id(udp->id());
      start.set_client_to_server_key(std::string(udp->keys().client_to_server.begin(), udp->keys().client_to_server.end()));
      start.set_server_to_client_key(std::string(udp->keys().server_to_client.begin(), udp->keys().server_to_client.end()));
    }
    for (const PlannedPrimitive& p : plan_.primitives) {
      v1::PrimitiveStart& out = *start.add_primitives();
      out.set_primitive(p.stream);
      out.set_mesh(p.mesh);
      out.set_mesh_primitive(p.mesh_primitive);
      out.set_header(Slice(artifact_, p.header));
      out.set_base_mesh(Slice(artifact_, p.base));
      out.set_refinements(p.refinements);
      for (const auto& [name, id] : p.draco_attributes) (*out.mutable_draco_attributes())[name] = id;
    }
    return stream_->Write(message);
  }

  bool TransportChanged(SessionTransport transport, const std::string& reason) override {
    v1::ServerMessage m;
    m.mutable_transport_change()->set_transport(ToProto(transport));
    m.mutable_transport_change()->set_reason(reason);
    return stream_->Write(m);
  }

  bool Control(const PlannedRefinement& r, uint32_t stream, uint32_t datagrams, uint64_t first_packet_number,
               bool reliable) override {
    v1::ServerMessage m;
    v1::ControlBlock& c = *m.mutable_control();
    c.set_primitive(stream);
    c.set_refinement(r.refinement);
    c.set_control(Slice(artifact_, r.control));
    c.set_datagrams(datagrams);
    c.set_first_packet_number(first_packet_number);
    c.set_reliable(reliable);
    return stream_->Write(m);
  }

  bool Datagram(const uint8_t* data, size_t size) override {
    v1::ServerMessage m;
    m.mutable_datagram()->set_payload(reinterpret_cast<const char*>(data), size);
    return stream_->Write(m);
  }

  bool RefinementEnd(uint32_t stream, uint32_t refinement, uint32_t datagrams_sent) override {
    v1::ServerMessage m;
    m.mutable_refinement_end()->set_primitive(stream);
    m.mutable_refinement_end()->set_refinement(refinement);
    m.mutable_refinement_end()->set_datagrams_sent(datagrams_sent);
    return stream_->Write(m);
  }

  bool End(const std::string& reason) override {
    v1::ServerMessage m;
    m.mutable_end()->set_reason(reason);
    return stream_->Write(m);
  }

 private:
  grpc::ServerReaderWriter<v1::ServerMessage, v1::ClientMessage>* stream_;
  const SessionPlan& plan_;
  const std::vector<uint8_t>& artifact_;
  const VersionRecord& version_;
  const StreamServiceOptions& options_;
  const std::vector<uint8_t>& scene_;
};

}  // namespace

struct StreamServiceImpl::Live {
  grpc::ServerContext* context = nullptr;
  std::atomic<int64_t> last_heard_ms{0};  // steady clock
  std::atomic<bool> timed_out{false};
};

namespace {

int64_t SteadyMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now().time_since_epoch()).count();
}

}  // namespace

StreamServiceImpl::StreamServiceImpl(Store* store, const Authenticator* auth, StreamServiceOptions options,
                                     const std::atomic<bool>* draining)
    : store_(store), auth_(auth), options_(std::move(options)), draining_(draining), sessions_(options_.max_sessions) {
  watchdog_ = std::thread([this] { Watch(); });
}

StreamServiceImpl::~StreamServiceImpl() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  watchdog_.join();
}

int StreamServiceImpl::active_sessions() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return static_cast<int>(live_.size());
}

void StreamServiceImpl::Watch() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stop_) {
    wake_.wait_for(lock, std::chrono::milliseconds(100));
    const int64_t now = SteadyMs();
    for (Live* live : live_) {
      const bool draining = draining_ != nullptr && draining_->load();
      if (draining || now - live->last_heard_ms.load() > options_.idle_timeout.count()) {
        if (!draining) live->timed_out = true;
        live->context->TryCancel();
      }
    }
  }
}

grpc::Status StreamServiceImpl::Open(grpc::ServerContext* context,
                                     grpc::ServerReaderWriter<v1::ServerMessage, v1::ClientMessage>* stream) {
  auto principal = AuthenticateCall(*auth_, *context);
  if (!principal.ok()) return ToGrpcStatus(principal.status());
  CallLimit::Slot slot = sessions_.Acquire(std::chrono::milliseconds(0));
  if (!slot) {
    return ToGrpcStatus(ResourceExhausted("Open: " + std::to_string(sessions_.limit()) +
                                          " sessions are running on this server; retry later"));
  }
  if (draining_ != nullptr && draining_->load()) {
    return ToGrpcStatus(Unavailable("the server is shutting down; open the session on another server"));
  }
  v1::ClientMessage first;
  if (!stream->Read(&first)) return ToGrpcStatus(InvalidArgument("the first message must be open"));
  if (first.kind_case() != v1::ClientMessage::kOpen) {
    return ToGrpcStatus(InvalidArgument("the first message must be open"));
  }
  const v1::OpenRequest& open = first.open();
  Status s = CheckName("asset", open.asset());
  if (!s.ok()) return ToGrpcStatus(s);
  if (open.max_level() < -1) return ToGrpcStatus(InvalidArgument("max_level: -1 (all) or a level >= 0"));
  if (!v1::Transport_IsValid(open.transport())) return ToGrpcStatus(InvalidArgument("transport: unknown value"));
  if (open.has_expected_loss() && !(open.expected_loss() >= 0 && open.expected_loss() <= 1)) {
    return ToGrpcStatus(InvalidArgument("expected_loss: a rate in [0, 1]"));
  }
  auto version = ResolveReadyVersion(*store_, principal->tenant, open.asset(), open.version());
  if (!version.ok()) return ToGrpcStatus(version.status());
  auto artifact = store_->GetBlob(version->artifact.artifact_sha256, options_.max_artifact_bytes);
  if (!artifact.ok()) return ToGrpcStatus(artifact.status());
  auto plan = PlanSession(artifact.value(), version->artifact.layout_json, open.max_level());
  if (!plan.ok()) return ToGrpcStatus(plan.status());
  std::vector<std::pair<uint32_t, uint32_t>> refined;
  for (const PlannedPrimitive& p : plan->primitives) refined.emplace_back(p.mesh, p.mesh_primitive);
  auto scene = scenes_.Get(version->artifact.artifact_sha256, artifact.value(), refined);
  if (!scene.ok()) return ToGrpcStatus(scene.status());

  SessionRunnerOptions runner_options;
  runner_options.want_udp = open.transport() != v1::TRANSPORT_GRPC;
  runner_options.udp = options_.udp;
  runner_options.hello_timeout = options_.hello_timeout;
  runner_options.rate = options_.rate;
  runner_options.server_share = options_.server_share;
  runner_options.reliable_cut = options_.reliable_cut;
  runner_options.expected_loss = open.has_expected_loss() ? open.expected_loss() : -1;
  SessionRunner runner(plan.value(), artifact.value(), open.max_level(), runner_options);

  Live live;
  live.context = context;
  live.last_heard_ms = SteadyMs();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    live_.insert(&live);
  }
  // The client's reports, on their own thread (gRPC allows one reader and
  // one writer at once); it ends when the client half-closes or the call is
  // cancelled, both of which happen before Open returns.
  std::atomic<bool> client_done{false};
  std::atomic<bool> reader_finished{false};
  // A RepairRequest, handed from the reader thread to this one (the writer).
  std::mutex repair_mutex;
  std::optional<v1::RepairRequest> repair_request;
  std::thread reader([&] {
    v1::ClientMessage m;
    while (stream->Read(&m)) {
      live.last_heard_ms = SteadyMs();
      if (m.kind_case() == v1::ClientMessage::kReport) {
        const v1::ClientReport& r = m.report();
        ClientReportInfo info;
        info.stream = r.primitive();
        info.refinement = r.refinement();
        info.received = r.datagrams_received();
        info.missing = static_cast<uint32_t>(std::min<int>(r.missing_size(), 1 << 20));
        info.end_received = r.end_received();
        info.hold_us = r.hold_us();
        for (int i = 0; i < r.rtt_samples_us_size() && i < 16; ++i) info.rtt_samples_us.push_back(r.rtt_samples_us(i));
        runner.OnReport(info);
      } else if (m.kind_case() == v1::ClientMessage::kRepair) {
        // Once per session: after its repair request the server reads
        // nothing more from the client (a second one is never seen).
        std::lock_guard<std::mutex> lock(repair_mutex);
        repair_request = m.repair();
        break;
      } else if (m.kind_case() == v1::ClientMessage::kDone) {
        client_done = true;
        break;
      }
    }
    reader_finished = true;
  });
  GrpcSink sink(stream, plan.value(), artifact.value(), version.value(), options_, *scene.value());
  const auto cancelled = [&] { return context->IsCancelled() || client_done.load(); };
  StatusOr<std::string> result = runner.Run(sink, cancelled);
  // The repair (OpenRequest.repair): once, after SessionEnd, the datagrams
  // the client names, on the stream, then RepairEnd.
  uint64_t repaired = 0, repaired_bytes = 0;
  Status repair_status = Status::Ok();
  if (result.ok() && open.repair()) {
    // The reader stops at the request (reader_finished), so waiting for the
    // reader is waiting for the request, or for the client to give up.
    const auto wait_until = Clock::now() + kRepairWait;
    while (!reader_finished && Clock::now() < wait_until && !context->IsCancelled()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    std::optional<v1::RepairRequest> request;
    if (reader_finished) {
      std::lock_guard<std::mutex> lock(repair_mutex);
      request = repair_request;
    }
    if (request) {
      auto ranges = RepairDatagrams(plan.value(), *request);
      if (!ranges.ok()) {
        repair_status = ranges.status();
      } else {
        bool written = true;
        for (const ByteRange& d : ranges.value()) {
          if (!(written = sink.Datagram(artifact->data() + d.offset, static_cast<size_t>(d.length)))) break;
          ++repaired;
          repaired_bytes += d.length;
        }
        v1::ServerMessage end;
        end.mutable_repair_end()->set_datagrams(static_cast<uint32_t>(repaired));
        end.mutable_repair_end()->set_bytes(repaired_bytes);
        if (written) stream->Write(end);
      }
    }
  }
  if (!repair_status.ok()) {
    // The reader stopped at the request: nothing is left to cancel.
    reader.join();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      live_.erase(&live);
    }
    return ToGrpcStatus(repair_status);
  }
  // After SessionEnd the client half-closes (or sends done); give it
  // kLinger to do so, so that the call ends OK, then cut it.
  if (result.ok()) {
    const auto linger_until = Clock::now() + kLinger;
    while (!reader_finished && Clock::now() < linger_until && !context->IsCancelled()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
  }
  if (!reader_finished) context->TryCancel();
  reader.join();
  if (result.ok() && !open.repair() && reader_finished) {
    std::lock_guard<std::mutex> lock(repair_mutex);
    if (repair_request) {
      std::lock_guard<std::mutex> live_lock(mutex_);
      live_.erase(&live);
      return ToGrpcStatus(InvalidArgument("repair: the session was not opened with repair"));
    }
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    live_.erase(&live);
  }
  const SessionRunnerStats st = runner.stats();
  const std::string reason = result.ok() ? result.value()
                             : live.timed_out ? "timeout"
                             : client_done ? "client done"
                             : (draining_ != nullptr && draining_->load()) ? "draining"
                                                                           : "client went away";
  if (options_.log) {
    char line[512];
    std::snprintf(line, sizeof line,
                  "session %s@%lld ended (%s): %s, %llu datagrams sent, %llu reports, %llu missing, rate %.1f Mbit/s, "
                  "%u decreases, srtt %.2f ms, %u refinements reliable (%llu bytes, for loss %.3f), %llu repaired",
                  version->asset.c_str(), static_cast<long long>(version->version), reason.c_str(),
                  st.transport == SessionTransport::kUdp ? "udp" : "grpc",
                  static_cast<unsigned long long>(st.datagrams_sent), static_cast<unsigned long long>(st.reports),
                  static_cast<unsigned long long>(st.reported_missing), st.final_rate_bps / 1e6, st.rate_decreases,
                  st.srtt_us / 1000.0, st.reliable_refinements, static_cast<unsigned long long>(st.reliable_bytes),
                  st.cut_loss, static_cast<unsigned long long>(repaired));
    options_.log(line);
  }
  if (result.ok()) return grpc::Status::OK;
  if (live.timed_out) {
    return grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED,
                        "the session was idle for " + std::to_string(options_.idle_timeout.count() / 1000) + " s");
  }
  if (draining_ != nullptr && draining_->load()) {
    return ToGrpcStatus(Unavailable("the server is shutting down; open the session again"));
  }
  return grpc::Status(grpc::StatusCode::CANCELLED, "the client went away");
}

}  // namespace meshstream
