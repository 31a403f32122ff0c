#include "sdk/session.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <map>
#include <mutex>
#include <thread>
#include <utility>

#include "codec/bitstream/reader.h"
#include "codec/mesh/quantized_mesh.h"
#include "importers/draco_base_coder.h"
#include "importers/gltf_export.h"
#include "meshstream/v1/stream.grpc.pb.h"

namespace meshstream::sdk {

namespace {

using Clock = std::chrono::steady_clock;

double MsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// The status of a finished call as the SDK reports it.
Status FromCall(const grpc::Status& s) {
  const std::string& m = s.error_message();
  switch (s.error_code()) {
    case grpc::StatusCode::OK: return Status::Ok();
    case grpc::StatusCode::INVALID_ARGUMENT: return InvalidArgument(m);
    case grpc::StatusCode::NOT_FOUND: return NotFound(m);
    case grpc::StatusCode::FAILED_PRECONDITION: return FailedPrecondition(m);
    case grpc::StatusCode::UNAUTHENTICATED: return Unauthenticated(m);
    case grpc::StatusCode::PERMISSION_DENIED: return PermissionDenied(m);
    case grpc::StatusCode::RESOURCE_EXHAUSTED: return ResourceExhausted(m);
    case grpc::StatusCode::DATA_LOSS: return DataLoss(m);
    case grpc::StatusCode::UNAVAILABLE:
    case grpc::StatusCode::DEADLINE_EXCEEDED: return Unavailable(m.empty() ? "the server cannot be reached" : m);
    case grpc::StatusCode::CANCELLED: return Aborted("cancelled" + (m.empty() ? "" : ": " + m));
    default: return Internal(m);
  }
}

StatusOr<DracoAttributeIds> IdsOf(const v1::PrimitiveStart& p) {
  DracoAttributeIds ids;
  for (const auto& [name, id] : p.draco_attributes()) {
    if (name == "POSITION") {
      ids.position = id;
    } else if (name == "NORMAL") {
      ids.normal = id;
    } else if (name == "COLOR_0") {
      ids.color = id;
    } else if (name.rfind("TEXCOORD_", 0) == 0) {
      const std::string index = name.substr(9);
      if (index.empty() || index.size() > 2 || index.find_first_not_of("0123456789") != std::string::npos) {
        return InvalidInput("primitive " + std::to_string(p.primitive()) + ": Draco attribute " + name);
      }
      const size_t k = static_cast<size_t>(std::stoi(index));
      if (ids.texcoords.size() <= k) ids.texcoords.resize(k + 1, -1);
      ids.texcoords[k] = id;
    }
  }
  if (ids.position < 0) return InvalidInput("primitive " + std::to_string(p.primitive()) + ": no POSITION");
  return ids;
}

struct PrimitiveState {
  v1::PrimitiveStart start;
  std::unique_ptr<StreamReader> reader;
};

}  // namespace

struct Session::Impl {
  SessionOptions options;
  grpc::ClientContext context;
  std::unique_ptr<v1::StreamService::Stub> stub;
  std::unique_ptr<grpc::ClientReaderWriter<v1::ClientMessage, v1::ServerMessage>> stream;
  std::thread reader;
  Clock::time_point opened = Clock::now();

  // Filled by the reader thread.
  std::mutex mutex;
  std::condition_variable arrived;
  std::deque<v1::ServerMessage> queue;
  bool finished = false;  // the stream ended (status below)
  Status final_status;

  // Owned by the Poll thread.
  std::vector<PrimitiveState> primitives;
  size_t current = SIZE_MAX;  // the primitive whose refinement is open
  int32_t levels = 0;
  int32_t level_shown = -1;   // -1: not even the base
  bool over = false;
  SessionStats stats;

  void ReadAll() {
    v1::ServerMessage m;
    while (stream->Read(&m)) {
      std::lock_guard<std::mutex> lock(mutex);
      queue.push_back(std::move(m));
      arrived.notify_one();
    }
    const grpc::Status s = stream->Finish();
    std::lock_guard<std::mutex> lock(mutex);
    finished = true;
    final_status = FromCall(s);
    arrived.notify_one();
  }

  // The level every primitive has reached (a primitive with fewer
  // refinements counts as done once it has all of its own).
  int32_t LevelEverywhere() const {
    int32_t level = levels;
    for (const PrimitiveState& p : primitives) {
      const int32_t own = static_cast<int32_t>(p.start.refinements());
      const int32_t applied = static_cast<int32_t>(p.reader->applied());
      if (applied < own) level = std::min(level, applied);
    }
    return level;
  }

  Event Fail(Status s) {
    over = true;
    context.TryCancel();
    Event e;
    e.type = EventType::kError;
    e.status = std::move(s);
    return e;
  }

  // Handles one message; an event when it completes one.
  Event Handle(const v1::ServerMessage& m) {
    Event none;
    switch (m.kind_case()) {
      case v1::ServerMessage::kSession: {
        const v1::SessionStart& start = m.session();
        stats.transport = start.transport() == v1::TRANSPORT_UDP ? "udp" : "grpc";
        for (const v1::PrimitiveStart& p : start.primitives()) {
          PrimitiveState state;
          state.start = p;
          auto reader = StreamReader::Create(reinterpret_cast<const uint8_t*>(p.header().data()), p.header().size(),
                                             p.primitive());
          if (!reader.ok()) return Fail(reader.status().WithContext("primitive " + std::to_string(p.primitive())));
          state.reader = std::make_unique<StreamReader>(std::move(reader).value());
          auto ids = IdsOf(p);
          if (!ids.ok()) return Fail(ids.status());
          auto base = DecodeDracoBase(reinterpret_cast<const uint8_t*>(p.base_mesh().data()), p.base_mesh().size(),
                                      ids.value(), state.reader->header().grids);
          if (!base.ok()) return Fail(base.status().WithContext("primitive " + std::to_string(p.primitive())));
          Status s = state.reader->SetBase(std::move(base).value());
          if (!s.ok()) return Fail(s.WithContext("primitive " + std::to_string(p.primitive())));
          if (p.refinements() > state.reader->refinement_count()) {
            return Fail(InvalidInput("primitive " + std::to_string(p.primitive()) + ": more refinements announced than its header has"));
          }
          levels = std::max(levels, static_cast<int32_t>(p.refinements()));
          stats.reliable_bytes += p.header().size() + p.base_mesh().size();
          primitives.push_back(std::move(state));
        }
        stats.time_to_base_ms = MsSince(opened);
        level_shown = 0;
        Event e;
        e.type = EventType::kBaseReady;
        e.level = 0;
        return e;
      }
      case v1::ServerMessage::kControl: {
        const v1::ControlBlock& c = m.control();
        current = SIZE_MAX;
        for (size_t i = 0; i < primitives.size(); ++i) {
          if (primitives[i].start.primitive() == c.primitive()) current = i;
        }
        if (current == SIZE_MAX) return Fail(InvalidInput("a control block for unknown primitive " + std::to_string(c.primitive())));
        StreamReader& r = *primitives[current].reader;
        if (c.refinement() != r.applied()) {
          return Fail(InvalidInput("primitive " + std::to_string(c.primitive()) + ": refinement " +
                                   std::to_string(c.refinement()) + " arrived, " + std::to_string(r.applied()) +
                                   " was next"));
        }
        Status s = r.BeginRefinement(reinterpret_cast<const uint8_t*>(c.control().data()), c.control().size());
        if (!s.ok()) return Fail(s.WithContext("primitive " + std::to_string(c.primitive())));
        stats.reliable_bytes += c.control().size();
        return none;
      }
      case v1::ServerMessage::kDatagram: {
        const std::string& d = m.datagram().payload();
        stats.unreliable_bytes += d.size();
        if (current == SIZE_MAX ||
            !primitives[current].reader->OfferDatagram(reinterpret_cast<const uint8_t*>(d.data()), d.size())) {
          ++stats.datagrams_rejected;
        } else {
          ++stats.datagrams_received;
        }
        return none;
      }
      case v1::ServerMessage::kRefinementEnd: {
        if (current == SIZE_MAX) return Fail(InvalidInput("a refinement end without its control block"));
        Status s = primitives[current].reader->FinishRefinement(Recovery::kPredict);
        if (!s.ok()) return Fail(s.WithContext("primitive " + std::to_string(primitives[current].start.primitive())));
        current = SIZE_MAX;
        const int32_t level = LevelEverywhere();
        if (level > level_shown) {
          level_shown = level;
          Event e;
          e.type = EventType::kLevelReady;
          e.level = level;
          return e;
        }
        return none;
      }
      case v1::ServerMessage::kEnd: {
        over = true;
        stats.time_to_full_ms = MsSince(opened);
        v1::ClientMessage done;
        done.mutable_done()->set_reason("complete");
        stream->Write(done);
        stream->WritesDone();
        Event e;
        e.type = EventType::kComplete;
        e.level = level_shown;
        return e;
      }
      default: return none;
    }
  }
};

Session::Session(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

Session::~Session() {
  if (!impl_) return;
  impl_->context.TryCancel();
  if (impl_->reader.joinable()) impl_->reader.join();
}

StatusOr<std::unique_ptr<Session>> Session::Open(const Client& client, const SessionOptions& options) {
  if (options.asset.empty()) return InvalidArgument("asset: must not be empty");
  if (options.max_level < -1) return InvalidArgument("max_level: -1 (all) or a level >= 0");
  auto impl = std::make_unique<Impl>();
  impl->options = options;
  client.Authorize(impl->context);
  impl->stub = v1::StreamService::NewStub(client.channel());
  impl->stream = impl->stub->Open(&impl->context);
  v1::ClientMessage open;
  open.mutable_open()->set_asset(options.asset);
  open.mutable_open()->set_version(options.version);
  open.mutable_open()->set_max_level(options.max_level);
  open.mutable_open()->set_transport(options.tcp_only ? v1::TRANSPORT_GRPC : v1::TRANSPORT_UNSPECIFIED);
  if (!impl->stream->Write(open)) {
    const grpc::Status s = impl->stream->Finish();
    return FromCall(s).ok() ? Unavailable("the server closed the session at once") : FromCall(s);
  }
  Impl* raw = impl.get();
  impl->reader = std::thread([raw] { raw->ReadAll(); });
  return std::unique_ptr<Session>(new Session(std::move(impl)));
}

Event Session::Poll(int32_t timeout_ms) {
  Impl& s = *impl_;
  Event none;
  if (s.over) return none;
  const auto deadline = Clock::now() + std::chrono::milliseconds(std::max(0, timeout_ms));
  for (;;) {
    v1::ServerMessage m;
    {
      std::unique_lock<std::mutex> lock(s.mutex);
      s.arrived.wait_until(lock, deadline, [&s] { return !s.queue.empty() || s.finished; });
      if (s.queue.empty()) {
        if (!s.finished) return none;  // timed out
        lock.unlock();
        Status status = s.final_status.ok() ? Unavailable("the server ended the session before its end") : s.final_status;
        return s.Fail(std::move(status));
      }
      m = std::move(s.queue.front());
      s.queue.pop_front();
    }
    Event e = s.Handle(m);
    if (e.type != EventType::kNone) return e;
  }
}

void Session::Cancel() { impl_->context.TryCancel(); }

size_t Session::primitive_count() const { return impl_->primitives.size(); }

StatusOr<Primitive> Session::Mesh(size_t primitive) const {
  if (primitive >= impl_->primitives.size()) return InvalidArgument("primitive: " + std::to_string(primitive) + " does not exist");
  return DequantizeMesh(impl_->primitives[primitive].reader->Mesh(), -1);
}

StatusOr<std::vector<uint8_t>> Session::Predicted(size_t primitive) const {
  if (primitive >= impl_->primitives.size()) return InvalidArgument("primitive: " + std::to_string(primitive) + " does not exist");
  const StreamReader& r = *impl_->primitives[primitive].reader;
  const size_t n = r.Mesh().vertex_count();
  std::vector<uint8_t> predicted(n, 0);
  const std::vector<uint8_t>& reliable = r.reliable();
  for (size_t v = 0; v < n && v < reliable.size(); ++v) predicted[v] = reliable[v] ? 0 : 1;
  return predicted;
}

std::pair<uint32_t, uint32_t> Session::GltfPosition(size_t primitive) const {
  if (primitive >= impl_->primitives.size()) return {0, 0};
  const v1::PrimitiveStart& p = impl_->primitives[primitive].start;
  return {p.mesh(), p.mesh_primitive()};
}

int32_t Session::levels() const { return impl_->levels; }

int32_t Session::level_shown() const { return impl_->level_shown; }

uint64_t Session::predicted_vertices() const {
  uint64_t n = 0;
  for (const PrimitiveState& p : impl_->primitives) n += p.reader->unreliable_vertices();
  return n;
}

Scene Session::CurrentScene() const {
  Scene scene;
  std::map<uint32_t, std::map<uint32_t, size_t>> by_mesh;  // glTF mesh -> primitive index -> ours
  for (size_t i = 0; i < impl_->primitives.size(); ++i) {
    const v1::PrimitiveStart& p = impl_->primitives[i].start;
    by_mesh[p.mesh()][p.mesh_primitive()] = i;
  }
  SceneRoot root;
  for (const auto& [mesh_index, primitives] : by_mesh) {
    meshstream::Mesh mesh;
    mesh.name = "mesh " + std::to_string(mesh_index);
    for (const auto& [primitive_index, ours] : primitives) {
      mesh.primitives.push_back(DequantizeMesh(impl_->primitives[ours].reader->Mesh(), -1));
    }
    Node node;
    node.name = mesh.name;
    node.mesh = static_cast<int32_t>(scene.meshes.size());
    root.nodes.push_back(static_cast<int32_t>(scene.nodes.size()));
    scene.nodes.push_back(node);
    scene.meshes.push_back(std::move(mesh));
  }
  scene.scenes.push_back(root);
  scene.default_scene = 0;
  return scene;
}

Status Session::Export(const std::string& path) const {
  if (impl_->level_shown < 0) return FailedPrecondition("export: the base mesh has not arrived yet");
  return ExportGltfFile(CurrentScene(), path, ExportOptions{});
}

const SessionStats& Session::stats() const { return impl_->stats; }

}  // namespace meshstream::sdk
