#include "sdk/session.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <optional>
#include <thread>
#include <ctime>
#include <utility>

#include "codec/mesh/quantized_mesh.h"
#include "codec/mesh/scene_flatten.h"
#include "importers/gltf_export.h"
#include "meshstream/v1/stream.grpc.pb.h"
#include "proto/rpc_status.h"
#include "net/steady_clock.h"
#include "net/udp_socket.h"
#include "sdk/session_core.h"
#include "sdk/udp_receiver.h"
#include "parallel/fork_join_pool.h"

// The driver of a session: the gRPC stream's reader thread, the UDP receiver,
// the real clock and the queues between them and Poll. Every decision is the
// core's (sdk/session_core.h).
namespace meshstream::sdk {

namespace {

using Clock = std::chrono::steady_clock;

// The CPU time of the calling thread.
double ThreadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) / 1e6;
}

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
  std::shared_ptr<LossMemory> loss_memory;  // the client's (Client::remembered_loss)
  grpc::ClientContext context;
  std::unique_ptr<v1::StreamService::Stub> stub;
  std::unique_ptr<grpc::ClientReaderWriter<v1::ClientMessage, v1::ServerMessage>> stream;
  std::thread reader;
  std::thread worker;  // the session thread: Run

  // Filled by the reader thread and the UDP receiver, taken by the session
  // thread; the events it makes, taken by Poll.
  std::mutex mutex;
  std::condition_variable arrived;    // for the session thread
  std::condition_variable published;  // for Poll
  std::deque<std::pair<uint64_t, v1::ServerMessage>> queue;  // with when it arrived
  std::deque<UdpPacket> packets;
  bool finished = false;  // the stream ended (status below)
  Status final_status;
  bool stopping = false;  // the session is being destroyed
  bool worker_over = false;  // the session thread has made its last event
  std::deque<std::pair<Event, std::shared_ptr<const SessionView>>> outbox;
  SessionStats live_stats;  // the core's, as of its last step

  // Owned by the session thread.
  std::unique_ptr<UdpReceiver> udp;
  std::unique_ptr<SessionCore> core;
  bool stream_end_taken = false;
  SessionView building;  // the view as of the last event (unchanged primitives shared)
  ViewBuffers buffers;   // the arrays of views no longer shown (Recycle under the mutex)
  std::optional<Event> waiting_level;  // a level to queue once Poll takes the one before
  std::optional<View> pending_view;    // SetView's, for the session thread to write

  // Owned by the Poll thread.
  std::shared_ptr<const SessionView> shown = std::make_shared<const SessionView>();
  SessionStats stats;

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
    // bridges to the session thread. Beyond it the datagram counts as lost.
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
    std::optional<View> view;
    {
      std::lock_guard<std::mutex> lock(mutex);
      view = std::exchange(pending_view, std::nullopt);
    }
    if (view && !core->over()) stream->Write(ViewMessage(*view));
    for (Outgoing& o : core->TakeOutgoing()) {
      StampHold(o, SteadyNowUs());  // after the decode: the hold covers it
      stream->Write(o.message);
      if (o.half_close) stream->WritesDone();
    }
  }

  // The session thread's statistics: the core's, and its own CPU.
  SessionStats StatsNow() const {
    SessionStats st = core->stats();
    st.session_thread_cpu_ms = ThreadCpuMs();
    return st;
  }

  // Hands an event to Poll with the views it shows. An error ends the call
  // and the UDP half. While a level waits untaken in the outbox a higher one
  // waits here, without views (a copy of every mesh per level costs about a
  // fifth of the decoding's CPU on the bunny; a host that polls once a frame
  // needs one per frame): it follows once Poll takes the one before
  // (PublishWaitingLevel), or before an end.
  void Publish(const Event& e) {
    if (e.type == EventType::kError) {
      udp.reset();
      context.TryCancel();
    }
    if (e.type == EventType::kLevelReady) {
      std::lock_guard<std::mutex> lock(mutex);
      if (!outbox.empty() && outbox.back().first.type == EventType::kLevelReady) {
        waiting_level = e;
        return;
      }
    }
    if (waiting_level && e.type != EventType::kLevelReady) Queue(*std::exchange(waiting_level, std::nullopt));
    waiting_level.reset();
    Queue(e);
  }

  void PublishWaitingLevel() {
    if (!waiting_level) return;
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (!outbox.empty() && outbox.back().first.type == EventType::kLevelReady) return;
    }
    Queue(*std::exchange(waiting_level, std::nullopt));
  }

  // Takes the views (into the arrays Poll no longer shows) and queues them
  // with `e`; a level replaces one untaken before it (a waiting level queued
  // at the end: one event for the levels since the host's last poll).
  void Queue(const Event& e) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      buffers.Recycle();
    }
    core->TakeView(building, &buffers);
    auto view = std::make_shared<const SessionView>(building);
    SessionStats st = StatsNow();
    std::lock_guard<std::mutex> lock(mutex);
    if (e.type == EventType::kLevelReady && !outbox.empty() && outbox.back().first.type == EventType::kLevelReady) {
      outbox.back() = {e, std::move(view)};
    } else {
      outbox.emplace_back(e, std::move(view));
    }
    live_stats = std::move(st);
    published.notify_one();
  }

  // The session thread: hands the core every arrival and the clock, and
  // publishes its events, until the session is over or destroyed.
  void Run() {
    SessionCore& c = *core;
    for (;;) {
      while (auto e = c.NextEvent()) Publish(*e);
      PublishWaitingLevel();
      if (c.over()) break;
      ShowUdpCounters();
      c.CheckEnd(SteadyNowUs());
      Apply();
      if (c.has_event()) continue;
      {
        std::unique_lock<std::mutex> lock(mutex);
        if (stopping) break;
        live_stats = StatsNow();
        if (c.handed_over()) {
          // Wake at least every 10 ms (refinements become ready by the clock
          // too, and the budgets and waits run out), and when a declared
          // loss is due.
          auto wake = Clock::now() + std::chrono::milliseconds(10);
          const uint64_t due = c.next_due_us(), now_us = SteadyNowUs();
          if (due != UINT64_MAX) wake = std::min(wake, Clock::now() + std::chrono::microseconds(due > now_us ? due - now_us : 0));
          arrived.wait_until(lock, wake, [this] {
            return !queue.empty() || !packets.empty() || finished || stopping || pending_view ||
                   (waiting_level && outbox.empty());
          });
          if (stopping) break;
        }
        // Read before the queue is taken: every datagram that reached the
        // socket before it is in the queue now.
        c.SetArrivalHorizon(udp ? udp->caught_up_us() : SteadyNowUs());
        for (auto& [at, m] : queue) c.TakeMessage(std::move(m), at);
        for (UdpPacket& p : packets) c.TakeDatagram(std::move(p.payload), p.packet_number, p.time_us);
        queue.clear();
        packets.clear();
        if (finished && !stream_end_taken) {
          stream_end_taken = true;
          c.TakeStreamEnd(final_status);
        }
      }
      ShowUdpCounters();
      c.HandleArrivals(SteadyNowUs());
      Apply();
    }
    std::lock_guard<std::mutex> lock(mutex);
    live_stats = StatsNow();
    // The raw UDP loss this session saw, for the client's next sessions.
    loss_memory->Add(live_stats.datagrams_lost, live_stats.udp_datagrams_received);
    worker_over = true;
    published.notify_all();
  }
};

Session::Session(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

Session::~Session() {
  if (!impl_) return;
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    impl_->stopping = true;
    impl_->arrived.notify_all();
  }
  impl_->context.TryCancel();  // a write the session thread is in returns
  if (impl_->worker.joinable()) impl_->worker.join();
  impl_->udp.reset();
  if (impl_->reader.joinable()) impl_->reader.join();
}

StatusOr<std::unique_ptr<Session>> Session::Open(const Client& client, const SessionOptions& options) {
  if (options.asset.empty()) return InvalidArgument("asset: must not be empty");
  if (options.max_level < -1) return InvalidArgument("max_level: -1 (all) or a level >= 0");
  if (options.time_budget_ms < 0) return InvalidArgument("time_budget_ms: not negative (0: none)");
  if (options.expected_loss > 1 || options.expected_loss != options.expected_loss) {
    return InvalidArgument("expected_loss: a rate in [0, 1], or < 0 for unknown");
  }
  if (options.decode_threads < -1 || options.decode_threads > ForkJoinPool::kMaxWorkers) {
    return InvalidArgument("decode_threads: -1 (one per core), 0 or 1 (the session's thread) or up to " +
                           std::to_string(ForkJoinPool::kMaxWorkers));
  }
  if (options.straggler_timeout_ms < 1 || options.straggler_timeout_ms > 60000) {
    return InvalidArgument("straggler_timeout_ms: 1..60000");
  }
  if (options.view) {
    const Status checked = CheckView(*options.view);
    if (!checked.ok()) return InvalidArgument(checked.message());
  }
  auto impl = std::make_unique<Impl>(options);
  impl->server_target = client.options().server;
  impl->loss_memory = client.loss_memory();
  client.Authorize(impl->context);
  impl->stub = v1::StreamService::NewStub(client.channel());
  impl->stream = impl->stub->Open(&impl->context);
  v1::ClientMessage open;
  open.mutable_open()->set_asset(options.asset);
  open.mutable_open()->set_version(options.version);
  open.mutable_open()->set_max_level(options.max_level);
  open.mutable_open()->set_transport(options.tcp_only ? v1::TRANSPORT_GRPC : v1::TRANSPORT_UNSPECIFIED);
  open.mutable_open()->set_repair(options.repair);
  open.mutable_open()->set_no_parity(options.no_parity);
  open.mutable_open()->set_profile(static_cast<v1::Profile>(static_cast<int>(options.profile)));
  if (options.view) *open.mutable_open()->mutable_view() = ViewProto(*options.view);
  const double remembered = client.remembered_loss();
  if (options.expected_loss >= 0) {
    open.mutable_open()->set_expected_loss(options.expected_loss);
  } else if (remembered >= 0 && !options.tcp_only) {
    open.mutable_open()->set_expected_loss(remembered);
  }
  if (!impl->stream->Write(open)) {
    const grpc::Status s = impl->stream->Finish();
    return FromGrpcStatus(s).ok() ? Unavailable("the server closed the session at once") : FromGrpcStatus(s);
  }
  Impl* raw = impl.get();
  impl->reader = std::thread([raw] { raw->ReadAll(); });
  impl->worker = std::thread([raw] { raw->Run(); });
  return std::unique_ptr<Session>(new Session(std::move(impl)));
}

Status Session::SetView(const View& view) {
  const Status checked = CheckView(view);
  if (!checked.ok()) return InvalidArgument(checked.message());
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    impl_->pending_view = view;
  }
  impl_->arrived.notify_one();
  return Status::Ok();
}

Event Session::Poll(int32_t timeout_ms) {
  Impl& s = *impl_;
  const auto deadline = Clock::now() + std::chrono::milliseconds(std::max(0, timeout_ms));
  std::unique_lock<std::mutex> lock(s.mutex);
  s.published.wait_until(lock, deadline, [&s] { return !s.outbox.empty() || s.worker_over; });
  s.stats = s.live_stats;
  if (s.outbox.empty()) return Event{};
  Event e = s.outbox.front().first;
  s.shown = std::move(s.outbox.front().second);  // the views shown before go (under the lock: ViewBuffers)
  s.outbox.pop_front();
  s.arrived.notify_one();  // a level may wait for this one to be taken
  return e;
}

void Session::Cancel() { impl_->context.TryCancel(); }

size_t Session::primitive_count() const { return impl_->shown->primitives.size(); }

StatusOr<Primitive> Session::Mesh(size_t primitive) const {
  if (primitive >= primitive_count()) return InvalidArgument("primitive: " + std::to_string(primitive) + " does not exist");
  return DequantizeMesh(*impl_->shown->primitives[primitive].mesh, -1);
}

StatusOr<std::vector<uint8_t>> Session::Predicted(size_t primitive) const {
  if (primitive >= primitive_count()) return InvalidArgument("primitive: " + std::to_string(primitive) + " does not exist");
  const PrimitiveView& v = impl_->shown->primitives[primitive];
  const size_t n = v.mesh->vertex_count();
  std::vector<uint8_t> predicted(n, 0);
  const std::vector<uint8_t>& reliable = *v.reliable;
  for (size_t i = 0; i < n && i < reliable.size(); ++i) predicted[i] = reliable[i] ? 0 : 1;
  return predicted;
}

StatusOr<Session::QuantizedView> Session::Quantized(size_t primitive) const {
  if (primitive >= primitive_count()) return InvalidArgument("primitive: " + std::to_string(primitive) + " does not exist");
  const PrimitiveView& v = impl_->shown->primitives[primitive];
  return QuantizedView{v.mesh.get(), v.reliable.get()};
}

std::vector<std::array<double, 16>> Session::Instances(size_t primitive) const {
  std::vector<std::array<double, 16>> out;
  if (primitive >= primitive_count() || !impl_->shown->layout) return out;
  const SessionLayout& layout = *impl_->shown->layout;
  if (!layout.has_scene) {
    out.push_back({1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1});
    return out;
  }
  const int32_t mesh = static_cast<int32_t>(layout.places[primitive].mesh);
  ForEachMeshInstance(layout.scene, [&](int32_t m, const Mat4d& world, bool) {
    if (m == mesh) out.push_back(world);
  });
  return out;
}

std::pair<uint32_t, uint32_t> Session::GltfPosition(size_t primitive) const {
  if (primitive >= primitive_count()) return {0, 0};
  const SessionLayout::Place& p = impl_->shown->layout->places[primitive];
  return {p.mesh, p.mesh_primitive};
}

int32_t Session::levels() const { return impl_->shown->levels; }

int32_t Session::level_shown() const { return impl_->shown->level_shown; }

uint64_t Session::predicted_vertices() const { return impl_->shown->predicted_vertices; }

Scene Session::CurrentScene() const { return ViewScene(*impl_->shown); }

Status Session::Export(const std::string& path) const {
  if (level_shown() < 0) return FailedPrecondition("export: the base mesh has not arrived yet");
  return ExportGltfFile(CurrentScene(), path, ExportOptions{});
}

const SessionStats& Session::stats() const { return impl_->stats; }

}  // namespace meshstream::sdk
