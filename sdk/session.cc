#include "sdk/session.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <thread>
#include <utility>

#include "codec/mesh/quantized_mesh.h"
#include "importers/gltf_export.h"
#include "meshstream/v1/stream.grpc.pb.h"
#include "proto/rpc_status.h"
#include "net/steady_clock.h"
#include "net/udp_socket.h"
#include "sdk/session_core.h"
#include "sdk/udp_receiver.h"

// The driver of a session: the gRPC stream's reader thread, the UDP receiver,
// the real clock and the queues between them and Poll. Every decision is the
// core's (sdk/session_core.h).
namespace meshstream::sdk {

namespace {

using Clock = std::chrono::steady_clock;

// The host part of "HOST:PORT" / "[V6]:PORT" / "dns:///HOST:PORT".
std::string HostOfTarget(std::string target) {
  const size_t scheme = target.find(":///");
  if (scheme != std::string::npos) target = target.substr(scheme + 4);
  std::string host;
  uint16_t port = 0;
  if (SplitHostPort(target, &host, &port).ok()) return host;
  return target;
}

}  // namespace

struct Session::Impl {
  SessionOptions options;
  std::string server_target;
  grpc::ClientContext context;
  std::unique_ptr<v1::StreamService::Stub> stub;
  std::unique_ptr<grpc::ClientReaderWriter<v1::ClientMessage, v1::ServerMessage>> stream;
  std::thread reader;

  // Filled by the reader thread and the UDP receiver.
  std::mutex mutex;
  std::condition_variable arrived;
  std::deque<std::pair<uint64_t, v1::ServerMessage>> queue;  // with when it arrived
  std::deque<UdpPacket> packets;
  bool finished = false;  // the stream ended (status below)
  Status final_status;

  // Owned by the Poll thread.
  std::unique_ptr<UdpReceiver> udp;
  std::unique_ptr<SessionCore> core;
  bool stream_end_taken = false;

  explicit Impl(const SessionOptions& o) : options(o), core(std::make_unique<SessionCore>(o, SteadyNowUs())) {}

  void ReadAll() {
    v1::ServerMessage m;
    while (stream->Read(&m)) {
      const uint64_t at = SteadyNowUs();
      std::lock_guard<std::mutex> lock(mutex);
      queue.emplace_back(at, std::move(m));
      arrived.notify_one();
    }
    const grpc::Status s = stream->Finish();
    std::lock_guard<std::mutex> lock(mutex);
    finished = true;
    final_status = FromGrpcStatus(s);
    arrived.notify_one();
  }

  void Deliver(UdpPacket&& p) {
    std::lock_guard<std::mutex> lock(mutex);
    // Bounded: the reconstructors bound what they buffer; this queue only
    // bridges to the Poll thread. Beyond it the datagram counts as lost.
    if (packets.size() >= kMaxQueuedPackets) return;
    packets.push_back(std::move(p));
    arrived.notify_one();
  }
  static constexpr size_t kMaxQueuedPackets = 65536;

  // Starts the UDP half the core asked for (SessionStart).
  Status StartUdp(const UdpStart& u) {
    std::string host = u.host;
    if (host.empty() || host == "0.0.0.0" || host == "::") host = HostOfTarget(server_target);
    auto endpoint = options.udp_via.empty() ? SocketAddress::Resolve(host, u.port) : SocketAddress::Parse(options.udp_via);
    if (!endpoint.ok()) return endpoint.status().WithContext("the session's UDP endpoint");
    MS_ASSIGN_OR_RETURN(udp, UdpReceiver::Start(endpoint.value(), u.session_id, u.keys,
                                                [this](UdpPacket&& p) { Deliver(std::move(p)); }));
    core->mutable_stats().udp_local = udp->local().ToString();
    return Status::Ok();
  }

  // What the UDP receiver counted, for the core's statistics and RTT sample.
  void ShowUdpCounters() {
    if (!udp) return;
    const DropCounters c = udp->counters();
    UdpCounters u;
    u.dropped = c.dropped();
    u.replayed = c.Get(DropReason::kReplayed);
    u.hellos_sent = udp->hellos_sent();
    u.hello_rtt_us = udp->hello_rtt_us();
    core->SetUdpCounters(u);
  }

  // Carries out what the core asked for: the UDP half and the stream's writes.
  void Apply() {
    if (auto start = core->TakeUdpStart()) {
      Status s = StartUdp(*start);
      if (!s.ok()) core->Fail(std::move(s));
    }
    if (core->TakeUdpStop()) {
      if (core->over() && udp) {
        udp->RequestStop();  // joined when the session is destroyed
      } else {
        udp.reset();  // the server fell back to gRPC
      }
    }
    for (Outgoing& o : core->TakeOutgoing()) {
      StampHold(o, SteadyNowUs());  // after the decode: the hold covers it
      stream->Write(o.message);
      if (o.half_close) stream->WritesDone();
    }
  }

  // The event to return; an error ends the call and the UDP half.
  Event Returned(Event e) {
    if (e.type == EventType::kError) {
      udp.reset();
      context.TryCancel();
    }
    return e;
  }
};

Session::Session(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

Session::~Session() {
  if (!impl_) return;
  impl_->udp.reset();
  impl_->context.TryCancel();
  if (impl_->reader.joinable()) impl_->reader.join();
}

StatusOr<std::unique_ptr<Session>> Session::Open(const Client& client, const SessionOptions& options) {
  if (options.asset.empty()) return InvalidArgument("asset: must not be empty");
  if (options.max_level < -1) return InvalidArgument("max_level: -1 (all) or a level >= 0");
  if (options.time_budget_ms < 0) return InvalidArgument("time_budget_ms: not negative (0: none)");
  if (options.expected_loss > 1 || options.expected_loss != options.expected_loss) {
    return InvalidArgument("expected_loss: a rate in [0, 1], or < 0 for unknown");
  }
  if (options.straggler_timeout_ms < 1 || options.straggler_timeout_ms > 60000) {
    return InvalidArgument("straggler_timeout_ms: 1..60000");
  }
  auto impl = std::make_unique<Impl>(options);
  impl->server_target = client.options().server;
  client.Authorize(impl->context);
  impl->stub = v1::StreamService::NewStub(client.channel());
  impl->stream = impl->stub->Open(&impl->context);
  v1::ClientMessage open;
  open.mutable_open()->set_asset(options.asset);
  open.mutable_open()->set_version(options.version);
  open.mutable_open()->set_max_level(options.max_level);
  open.mutable_open()->set_transport(options.tcp_only ? v1::TRANSPORT_GRPC : v1::TRANSPORT_UNSPECIFIED);
  open.mutable_open()->set_repair(options.repair);
  if (options.expected_loss >= 0) open.mutable_open()->set_expected_loss(options.expected_loss);
  if (!impl->stream->Write(open)) {
    const grpc::Status s = impl->stream->Finish();
    return FromGrpcStatus(s).ok() ? Unavailable("the server closed the session at once") : FromGrpcStatus(s);
  }
  Impl* raw = impl.get();
  impl->reader = std::thread([raw] { raw->ReadAll(); });
  return std::unique_ptr<Session>(new Session(std::move(impl)));
}

Event Session::Poll(int32_t timeout_ms) {
  Impl& s = *impl_;
  SessionCore& core = *s.core;
  const auto deadline = Clock::now() + std::chrono::milliseconds(std::max(0, timeout_ms));
  for (;;) {
    if (auto e = core.NextEvent()) return s.Returned(*e);
    if (core.over()) return Event{};
    s.ShowUdpCounters();
    core.CheckEnd(SteadyNowUs());
    s.Apply();
    if (core.has_event()) continue;
    {
      std::unique_lock<std::mutex> lock(s.mutex);
      if (core.handed_over()) {
        // Wake at least every 10 ms (refinements become ready by the clock
        // too), and when a declared loss is due.
        auto wake = std::min(deadline, Clock::now() + std::chrono::milliseconds(10));
        const uint64_t due = core.next_due_us(), now_us = SteadyNowUs();
        if (due != UINT64_MAX) wake = std::min(wake, Clock::now() + std::chrono::microseconds(due > now_us ? due - now_us : 0));
        s.arrived.wait_until(lock, wake, [&s] { return !s.queue.empty() || !s.packets.empty() || s.finished; });
      }
      // Read before the queue is taken: every datagram that reached the
      // socket before it is in the queue now.
      core.SetArrivalHorizon(s.udp ? s.udp->caught_up_us() : SteadyNowUs());
      for (auto& [at, m] : s.queue) core.TakeMessage(std::move(m), at);
      for (UdpPacket& p : s.packets) core.TakeDatagram(std::move(p.payload), p.packet_number, p.time_us);
      s.queue.clear();
      s.packets.clear();
      if (s.finished && !s.stream_end_taken) {
        s.stream_end_taken = true;
        core.TakeStreamEnd(s.final_status);
      }
    }
    s.ShowUdpCounters();
    core.HandleArrivals(SteadyNowUs());
    s.Apply();
    if (!core.has_event() && Clock::now() >= deadline) return Event{};
  }
}

void Session::Cancel() { impl_->context.TryCancel(); }

size_t Session::primitive_count() const { return impl_->core->primitive_count(); }

StatusOr<Primitive> Session::Mesh(size_t primitive) const {
  if (primitive >= primitive_count()) return InvalidArgument("primitive: " + std::to_string(primitive) + " does not exist");
  return DequantizeMesh(impl_->core->reader(primitive).Mesh(), -1);
}

StatusOr<std::vector<uint8_t>> Session::Predicted(size_t primitive) const {
  if (primitive >= primitive_count()) return InvalidArgument("primitive: " + std::to_string(primitive) + " does not exist");
  const StreamReader& r = impl_->core->reader(primitive);
  const size_t n = r.Mesh().vertex_count();
  std::vector<uint8_t> predicted(n, 0);
  const std::vector<uint8_t>& reliable = r.reliable();
  for (size_t v = 0; v < n && v < reliable.size(); ++v) predicted[v] = reliable[v] ? 0 : 1;
  return predicted;
}

std::pair<uint32_t, uint32_t> Session::GltfPosition(size_t primitive) const {
  if (primitive >= primitive_count()) return {0, 0};
  const v1::PrimitiveStart& p = impl_->core->start(primitive);
  return {p.mesh(), p.mesh_primitive()};
}

int32_t Session::levels() const { return impl_->core->levels(); }

int32_t Session::level_shown() const { return impl_->core->level_shown(); }

uint64_t Session::predicted_vertices() const { return impl_->core->predicted_vertices(); }

Scene Session::CurrentScene() const { return impl_->core->CurrentScene(); }

Status Session::Export(const std::string& path) const {
  if (level_shown() < 0) return FailedPrecondition("export: the base mesh has not arrived yet");
  return ExportGltfFile(CurrentScene(), path, ExportOptions{});
}

const SessionStats& Session::stats() const { return impl_->core->stats(); }

}  // namespace meshstream::sdk
