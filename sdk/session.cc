#include "sdk/session.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <map>
#include <mutex>
#include <thread>
#include <utility>

#include "codec/bitstream/format.h"
#include "codec/bitstream/reader.h"
#include "codec/core/byte_io.h"
#include "codec/loss/reconstructor.h"
#include "net/udp_socket.h"
#include "net/steady_clock.h"
#include "sdk/udp_receiver.h"
#include "codec/mesh/quantized_mesh.h"
#include "importers/draco_base_coder.h"
#include "importers/gltf_export.h"
#include "importers/gltf_import.h"
#include "meshstream/v1/stream.grpc.pb.h"
#include "proto/rpc_status.h"

namespace meshstream::sdk {

namespace {

using Clock = std::chrono::steady_clock;

double MsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
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

// What the client tracks of one refinement for its report.
struct RefinementTrack {
  bool has_control = false;
  std::string control;             // held until the refinement's END arrives (then given to the reconstructor)
  bool end_seen = false;           // its END datagram or its RefinementEnd arrived
  uint32_t datagrams = 0;          // data datagrams the server sends
  uint64_t first_packet_number = 0;
  std::vector<uint64_t> packet_numbers;  // UDP DATA that arrived (any order, no repeats: the replay window)
  uint64_t bytes = 0;
  uint64_t end_time_us = 0;        // when its END datagram arrived (0: never)
  bool reliable = false;           // its datagrams come on the gRPC stream (ControlBlock.reliable)
  // With repair: the control block and every data datagram that arrived,
  // kept until the session ends, and the ordinals the report found missing.
  std::string kept_control;
  std::vector<std::string> kept_datagrams;
  std::vector<uint32_t> missing;
};

struct PrimitiveState {
  v1::PrimitiveStart start;
  std::unique_ptr<StreamReconstructor> reconstructor;
  std::vector<RefinementTrack> tracks;  // per refinement of this session
  size_t reported = 0;                  // refinements reported
  size_t given = 0;                     // control blocks given to the reconstructor (in order)
  size_t ended = 0;                     // refinements [0, ended) have had an END (theirs or a later one's)
  size_t scene_slot = 0;                // index into its scene mesh's primitives
  QuantizedMesh kept_base;              // with repair: the decoded base, to decode again from
};


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
  Clock::time_point opened = Clock::now();

  // Filled by the reader thread and the UDP receiver.
  std::mutex mutex;
  std::condition_variable arrived;
  std::deque<std::pair<uint64_t, v1::ServerMessage>> queue;  // with when it arrived
  std::deque<UdpPacket> packets;
  bool finished = false;  // the stream ended (status below)
  Status final_status;

  // Owned by the Poll thread: what was taken from the queues and not yet handled.
  std::deque<std::pair<uint64_t, v1::ServerMessage>> local_messages;
  std::deque<UdpPacket> local_packets;

  // Owned by the Poll thread.
  std::unique_ptr<UdpReceiver> udp;
  std::vector<PrimitiveState> primitives;
  Scene scene;            // the asset's scene at level 0 (SessionStart.scene_glb)
  bool has_scene = false;
  std::map<uint32_t, size_t> by_stream;  // stream id -> index in primitives
  int32_t levels = 0;
  int32_t level_shown = -1;   // -1: not even the base
  int32_t level_announced = -1;
  bool session_end = false;   // SessionEnd arrived (or a budget ran out)
  uint64_t session_end_us = 0;
  // The clock stragglers are timed out by: when the UDP receiver last had
  // every datagram of its socket delivered (UdpReceiver::caught_up_us), read
  // as the arrivals are taken; the steady clock without UDP.
  uint64_t arrivals_until_us = 0;
  // The straggler clock at time `t`: never past the arrival horizon.
  uint64_t StragglerClock(uint64_t t) const { return std::min(t, arrivals_until_us); }
  // Every arrival taken from the queues has been handed to the reconstructors.
  bool HandedOver() const { return local_messages.empty() && local_packets.empty(); }
  bool writes_done = false;
  bool over = false;
  bool rtt_reported = false;
  // The repair (SessionOptions::repair): asked for, and its RepairEnd arrived.
  bool repair_asked = false;
  bool repair_ended = false;
  bool ready_to_complete = false;  // the session's end is decided: kComplete next
  uint64_t repair_asked_us = 0;
  static constexpr uint64_t kRepairWaitUs = 10000000;
  uint64_t kept_bytes = 0;
  static constexpr uint64_t kMaxKeptBytes = uint64_t{256} << 20;
  ReconstructorOptions reconstructor_options;
  std::deque<Event> events;
  SessionStats stats;

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

  // The level every primitive has reached (a primitive with fewer
  // refinements counts as done once it has all of its own).
  int32_t LevelEverywhere() const {
    int32_t level = levels;
    for (const PrimitiveState& p : primitives) {
      const int32_t own = static_cast<int32_t>(p.start.refinements());
      const int32_t applied = static_cast<int32_t>(p.reconstructor->applied());
      if (applied < own) level = std::min(level, applied);
    }
    return level;
  }

  bool AllDone() const {
    for (const PrimitiveState& p : primitives) {
      if (p.reconstructor->applied() < p.start.refinements()) return false;
    }
    return true;
  }

  Event Fail(Status s) {
    over = true;
    udp.reset();
    context.TryCancel();
    Event e;
    e.type = EventType::kError;
    e.status = std::move(s);
    return e;
  }

  void Finish(const std::string& reason) {
    if (!writes_done) {
      v1::ClientMessage done;
      done.mutable_done()->set_reason(reason);
      stream->Write(done);
      stream->WritesDone();
      writes_done = true;
    }
  }

  StatusOr<size_t> PrimitiveOf(uint32_t stream_id) const {
    auto it = by_stream.find(stream_id);
    if (it == by_stream.end()) return InvalidInput("a block for unknown primitive " + std::to_string(stream_id));
    return it->second;
  }

  Status Start(const v1::SessionStart& start) {
    stats.transport = start.transport() == v1::TRANSPORT_UDP ? "udp" : "grpc";
    ReconstructorOptions ro;
    ro.straggler_timeout_us = static_cast<uint64_t>(std::max(1, options.straggler_timeout_ms)) * 1000;
    // UDP may run ahead of the gRPC stream by many refinements (a loaded
    // client, a TCP queue): buffer datagrams for any refinement of the
    // stream, within the byte budget, rather than drop them for the window.
    ro.window = kMaxRefinements;
    ro.max_buffered_bytes = size_t{64} << 20;
    reconstructor_options = ro;
    for (const v1::PrimitiveStart& p : start.primitives()) {
      const std::string where = "primitive " + std::to_string(p.primitive());
      if (by_stream.count(p.primitive()) != 0) return InvalidInput(where + " announced twice");
      PrimitiveState state;
      state.start = p;
      ro.lod = static_cast<int>(p.refinements());
      auto reconstructor = StreamReconstructor::Create(reinterpret_cast<const uint8_t*>(p.header().data()),
                                                       p.header().size(), p.primitive(), ro);
      if (!reconstructor.ok()) return reconstructor.status().WithContext(where);
      state.reconstructor = std::make_unique<StreamReconstructor>(std::move(reconstructor).value());
      if (p.refinements() > state.reconstructor->reader().refinement_count()) {
        return InvalidInput(where + ": more refinements announced than its header has");
      }
      auto ids = IdsOf(p);
      if (!ids.ok()) return ids.status();
      auto base = DecodeDracoBase(reinterpret_cast<const uint8_t*>(p.base_mesh().data()), p.base_mesh().size(),
                                  ids.value(), state.reconstructor->reader().header().grids);
      if (!base.ok()) return base.status().WithContext(where);
      if (options.repair) state.kept_base = base.value();
      Status s = state.reconstructor->SetBase(std::move(base).value());
      if (!s.ok()) return s.WithContext(where);
      state.tracks.resize(p.refinements());
      levels = std::max(levels, static_cast<int32_t>(p.refinements()));
      stats.reliable_bytes += p.header().size() + p.base_mesh().size();
      by_stream[p.primitive()] = primitives.size();
      primitives.push_back(std::move(state));
    }
    if (!start.scene_glb().empty()) {
      const std::vector<uint8_t> glb(start.scene_glb().begin(), start.scene_glb().end());
      auto scene_or = ImportGltfBytes(glb, "", "the session's scene", ImportOptions{});
      if (!scene_or.ok()) return scene_or.status();
      scene = std::move(scene_or).value();
      for (PrimitiveState& p : primitives) {
        // The glTF primitive index counts carried primitives too (Mesh::Order).
        const uint32_t m = p.start.mesh(), k = p.start.mesh_primitive();
        const std::vector<Mesh::Ref> order = m < scene.meshes.size() ? scene.meshes[m].Order() : std::vector<Mesh::Ref>();
        if (k >= order.size() || order[k].carried) {
          return InvalidInput("primitive " + std::to_string(p.start.primitive()) + ": the scene has no refined mesh " +
                              std::to_string(m) + " primitive " + std::to_string(k));
        }
        p.scene_slot = order[k].index;
      }
      stats.reliable_bytes += start.scene_glb().size();
      has_scene = true;
    }
    if (start.transport() == v1::TRANSPORT_UDP) {
      if (start.client_to_server_key().size() != kPacketKeyBytes || start.server_to_client_key().size() != kPacketKeyBytes) {
        return InvalidInput("session start: the UDP keys are not 32 bytes each");
      }
      std::string host = start.udp().host();
      if (host.empty() || host == "0.0.0.0" || host == "::") host = HostOfTarget(server_target);
      if (start.udp().port() == 0 || start.udp().port() > 65535) return InvalidInput("session start: no UDP port");
      auto endpoint = options.udp_via.empty() ? SocketAddress::Resolve(host, static_cast<uint16_t>(start.udp().port()))
                                              : SocketAddress::Parse(options.udp_via);
      if (!endpoint.ok()) return endpoint.status().WithContext("the session's UDP endpoint");
      SessionKeys keys;
      std::copy(start.client_to_server_key().begin(), start.client_to_server_key().end(), keys.client_to_server.begin());
      std::copy(start.server_to_client_key().begin(), start.server_to_client_key().end(), keys.server_to_client.begin());
      auto receiver = UdpReceiver::Start(endpoint.value(), start.udp_session_id(), keys,
                                         [this](UdpPacket&& p) { Deliver(std::move(p)); });
      if (!receiver.ok()) return receiver.status();
      udp = std::move(receiver).value();
      stats.udp_local = udp->local().ToString();
    }
    stats.time_to_base_ms = MsSince(opened);
    level_shown = 0;
    return Status::Ok();
  }

  // The END of refinement `refinement` of `p` arrived on either channel (the
  // earlier ones were sent before it).
  static void NoteEnd(PrimitiveState& p, size_t refinement) { p.ended = std::max(p.ended, refinement + 1); }

  // Gives the reconstructor the held control blocks of `p`, in order, as far
  // as they have arrived. A control block is held until its refinement's END
  // arrives on either channel (NoteEnd), so that the straggler timeout counts
  // from the end of the sending (a paced refinement may take longer to send
  // than the timeout), not from its start; and until every primitive has
  // reached its level, so that no primitive runs more than one refinement
  // ahead of the level shown and the views at an event are at the event's
  // level (a refinement of the reliable cut, on the stream, may overtake
  // another primitive's UDP datagrams). `flushing`: everything that arrived.
  Status GiveControls(PrimitiveState& p, uint64_t now, bool flushing) {
    while (p.given < p.tracks.size() && p.tracks[p.given].has_control &&
           (flushing || (p.given < p.ended && static_cast<int32_t>(p.given) <= LevelEverywhere()))) {
      RefinementTrack& t = p.tracks[p.given];
      Status s = p.reconstructor->OnControl(reinterpret_cast<const uint8_t*>(t.control.data()), t.control.size(), now);
      if (!s.ok()) return s.WithContext("primitive " + std::to_string(p.start.primitive()));
      if (options.repair) t.kept_control = std::move(t.control);
      t.control.clear();
      t.control.shrink_to_fit();
      ++p.given;
    }
    return Status::Ok();
  }

  Status GiveAllControls(uint64_t now, bool flushing) {
    for (PrimitiveState& p : primitives) {
      Status s = GiveControls(p, now, flushing);
      if (!s.ok()) return s;
    }
    return Status::Ok();
  }

  Status OfferDatagram(const uint8_t* data, size_t size, const UdpPacket* udp_packet, uint64_t now) {
    ByteReader r(data, size);
    auto h = DatagramHeader::Parse(r);
    if (!h.ok() || by_stream.count(h->stream) == 0) {
      ++stray_rejected;  // the reconstructors never see it
      return Status::Ok();
    }
    touched = by_stream[h->stream];
    PrimitiveState& p = primitives[touched];
    if (h->refinement < p.tracks.size()) {
      RefinementTrack& t = p.tracks[h->refinement];
      if (h->kind == DatagramKind::kEnd) {
        if (t.end_time_us == 0) t.end_time_us = now;
        t.end_seen = true;
      } else {
        t.bytes += size;
        if (udp_packet != nullptr && t.packet_numbers.size() < 4 * (size_t{1} << 16)) {
          t.packet_numbers.push_back(udp_packet->packet_number);
        }
        // Copies are kept too (the reconstructor drops them again); the cap
        // bounds what a hostile stream can make the client hold.
        if (options.repair && kept_bytes + size <= kMaxKeptBytes) {
          t.kept_datagrams.emplace_back(reinterpret_cast<const char*>(data), size);
          kept_bytes += size;
        }
      }
    }
    if (h->kind != DatagramKind::kEnd) stats.unreliable_bytes += size;
    p.reconstructor->OnDatagram(data, size, now);
    if (h->kind != DatagramKind::kEnd) return Status::Ok();
    NoteEnd(p, h->refinement);
    return GiveControls(p, now, false);
    return Status::Ok();
  }

  // Handles one message of the gRPC stream.
  Status Handle(const v1::ServerMessage& m, uint64_t now) {
    switch (m.kind_case()) {
      case v1::ServerMessage::kSession: {
        if (level_shown >= 0) return InvalidInput("a second session start");
        Status s = Start(m.session());
        if (!s.ok()) return s;
        Event e;
        e.type = EventType::kBaseReady;
        events.push_back(e);
        level_announced = 0;
        return Status::Ok();
      }
      case v1::ServerMessage::kTransportChange: {
        if (m.transport_change().transport() == v1::TRANSPORT_GRPC) {
          udp.reset();
          stats.transport = "grpc";
          stats.fallback_reason = m.transport_change().reason();
        }
        return Status::Ok();
      }
      case v1::ServerMessage::kControl: {
        const v1::ControlBlock& c = m.control();
        auto index = PrimitiveOf(c.primitive());
        if (!index.ok()) return index.status();
        touched = index.value();
        PrimitiveState& p = primitives[index.value()];
        if (c.refinement() >= p.tracks.size() || p.tracks[c.refinement()].has_control) {
          return InvalidInput("primitive " + std::to_string(c.primitive()) + ": a control block for refinement " +
                              std::to_string(c.refinement()) + " it does not expect");
        }
        RefinementTrack& t = p.tracks[c.refinement()];
        t.has_control = true;
        t.control = c.control();
        t.datagrams = c.datagrams();
        t.first_packet_number = c.first_packet_number();
        t.reliable = c.reliable();
        if (t.reliable && stats.transport == "udp") {
          ++stats.reliable_refinements;
          // Counted as they come; the reliable copy is charged to the datagram bytes.
        }
        stats.reliable_bytes += c.control().size();
        return t.end_seen ? GiveControls(p, now, false) : Status::Ok();
      }
      case v1::ServerMessage::kDatagram: {
        const std::string& d = m.datagram().payload();
        if (repair_asked && !repair_ended) {
          ++stats.repaired_datagrams;
          stats.repair_bytes += d.size();
        } else if (stats.transport == "udp") {
          stats.reliable_datagram_bytes += d.size();
        }
        return OfferDatagram(reinterpret_cast<const uint8_t*>(d.data()), d.size(), nullptr, now);
      }
      case v1::ServerMessage::kRepairEnd: {
        if (!repair_asked) return InvalidInput("a repair end for a repair not asked for");
        repair_ended = true;
        return Status::Ok();
      }
      case v1::ServerMessage::kRefinementEnd: {
        // The reliable copy of the END: the refinement is complete once its
        // announced datagrams are in, even when the END datagram was lost.
        const v1::RefinementEnd& e = m.refinement_end();
        auto index = PrimitiveOf(e.primitive());
        if (!index.ok()) return index.status();
        touched = index.value();
        PrimitiveState& p = primitives[index.value()];
        if (e.refinement() >= p.tracks.size()) return InvalidInput("a refinement end for a refinement not in the session");
        p.tracks[e.refinement()].end_seen = true;
        const std::vector<uint8_t> end = MakeEndDatagram(e.primitive(), e.refinement(), e.datagrams_sent(),
                                                         p.reconstructor->reader().header().version);
        p.reconstructor->OnDatagram(end.data(), end.size(), now);
        NoteEnd(p, e.refinement());
        return GiveControls(p, now, false);
      }
      case v1::ServerMessage::kEnd: {
        session_end = true;
        session_end_us = now;
        stats.end_reason = m.end().reason();
        return Status::Ok();
      }
      default: return Status::Ok();
    }
  }

  // Reports every refinement decoded since the last report.
  void Report() {
    for (PrimitiveState& p : primitives) {
      while (p.reported < p.reconstructor->applied() && p.reported < p.tracks.size()) {
        RefinementTrack& t = p.tracks[p.reported];
        v1::ClientMessage m;
        v1::ClientReport& r = *m.mutable_report();
        r.set_primitive(p.start.primitive());
        r.set_refinement(static_cast<uint32_t>(p.reported));
        std::vector<uint8_t> got(t.datagrams, 0);
        uint32_t received = 0;
        if (stats.transport == "udp" && !t.packet_numbers.empty()) {
          for (uint64_t pn : t.packet_numbers) {
            const uint64_t ordinal = pn - t.first_packet_number;
            if (ordinal < t.datagrams && !got[ordinal]) {
              got[ordinal] = 1;
              ++received;
            }
          }
        } else if (stats.transport != "udp" || t.datagrams == 0 || t.reliable) {
          received = t.datagrams;  // over gRPC (the session's or the reliable cut's) nothing is lost
          std::fill(got.begin(), got.end(), 1);
        }
        for (uint32_t k = 0; k < t.datagrams; ++k) {
          if (got[k]) continue;
          r.add_missing(k);
          if (options.repair) t.missing.push_back(k);
        }
        stats.datagrams_lost += t.datagrams - received;
        r.set_datagrams_received(received);
        r.set_bytes_received(t.bytes);
        r.set_end_received(t.end_time_us != 0);
        const uint64_t sent_at = SteadyNowUs();  // after the decode: the hold covers it
        r.set_hold_us(t.end_time_us != 0 && sent_at > t.end_time_us ? sent_at - t.end_time_us : 0);
        if (!rtt_reported && udp && udp->hello_rtt_us() > 0) {
          r.add_rtt_samples_us(static_cast<uint32_t>(std::min<uint64_t>(udp->hello_rtt_us(), UINT32_MAX)));
          rtt_reported = true;
        }
        if (!writes_done) stream->Write(m);
        t.packet_numbers.clear();
        t.packet_numbers.shrink_to_fit();
        ++p.reported;
      }
    }
  }

  // Decodes what is ready, reports it and queues the events it makes.
  Status Advance(uint64_t now, bool flush) {
    // Flushing gives everything; otherwise what the levels reached let go.
    Status given = GiveAllControls(now, flush);
    if (!given.ok()) return given;
    for (PrimitiveState& p : primitives) {
      if (flush) {
        Status s = p.reconstructor->Flush();
        if (!s.ok()) return s.WithContext("primitive " + std::to_string(p.start.primitive()));
      } else {
        auto n = p.reconstructor->Poll(now);
        if (!n.ok()) return n.status().WithContext("primitive " + std::to_string(p.start.primitive()));
      }
    }
    Report();
    AnnounceLevel();
    return Status::Ok();
  }

  // After one arrival: decodes what became ready in the primitive it
  // touched (the others wait for the end of the batch, when every arrival
  // has been handed over), and reports and announces only if it advanced.
  Status AdvanceTouched(uint64_t now) {
    if (touched == SIZE_MAX) return Status::Ok();
    PrimitiveState& p = primitives[touched];
    touched = SIZE_MAX;
    const size_t before = p.reconstructor->applied();
    auto n = p.reconstructor->Poll(now);
    if (!n.ok()) return n.status().WithContext("primitive " + std::to_string(p.start.primitive()));
    if (p.reconstructor->applied() == before) return Status::Ok();
    // The level may have risen: the controls it held back go to their
    // reconstructors, to be decoded at the next advance (after this event).
    Status given = GiveAllControls(now, false);
    if (!given.ok()) return given;
    Report();
    AnnounceLevel();
    return Status::Ok();
  }

  // One event for the level reached, even when several completed at once
  // (a viewer wants the latest, and the views show it).
  void AnnounceLevel() {
    const int32_t level = LevelEverywhere();
    if (level_announced >= 0 && level_announced < level) {
      level_announced = level;
      Event e;
      e.type = EventType::kLevelReady;
      e.level = level;
      events.push_back(e);
    }
    level_shown = std::max(level_shown, level);
  }

  // The repair request: every missing datagram of every refinement. False
  // when nothing is missing (no request is sent).
  bool AskRepair(uint64_t now) {
    v1::ClientMessage m;
    v1::RepairRequest& request = *m.mutable_repair();
    for (const PrimitiveState& p : primitives) {
      for (size_t i = 0; i < p.tracks.size(); ++i) {
        if (p.tracks[i].missing.empty()) continue;
        v1::RepairItem& item = *request.add_items();
        item.set_primitive(p.start.primitive());
        item.set_refinement(static_cast<uint32_t>(i));
        for (uint32_t k : p.tracks[i].missing) item.add_datagrams(k);
      }
    }
    if (request.items_size() == 0) return false;
    repair_asked = true;
    repair_asked_us = now;
    stream->Write(m);
    return true;
  }

  // Decodes every primitive again from its base with what it kept and what
  // the repair brought, through a fresh reconstructor (the same checks), and
  // swaps it in.
  Status DecodeAgain(uint64_t now) {
    for (PrimitiveState& p : primitives) {
      const std::string where = "primitive " + std::to_string(p.start.primitive());
      auto fresh = StreamReconstructor::Create(reinterpret_cast<const uint8_t*>(p.start.header().data()),
                                               p.start.header().size(), p.start.primitive(), reconstructor_options);
      if (!fresh.ok()) return fresh.status().WithContext(where);
      Status s = fresh->SetBase(p.kept_base);
      if (!s.ok()) return s.WithContext(where);
      for (size_t i = 0; i < p.tracks.size(); ++i) {
        const RefinementTrack& t = p.tracks[i];
        s = fresh->OnControl(reinterpret_cast<const uint8_t*>(t.kept_control.data()), t.kept_control.size(), now);
        if (!s.ok()) return s.WithContext(where);
        for (const std::string& d : t.kept_datagrams) {
          fresh->OnDatagram(reinterpret_cast<const uint8_t*>(d.data()), d.size(), now);
        }
        const std::vector<uint8_t> end = MakeEndDatagram(p.start.primitive(), static_cast<uint32_t>(i), t.datagrams,
                                                         fresh->reader().header().version);
        fresh->OnDatagram(end.data(), end.size(), now);
        auto n = fresh->Poll(now);
        if (!n.ok()) return n.status().WithContext(where);
      }
      s = fresh->Flush();
      if (!s.ok()) return s.WithContext(where);
      *p.reconstructor = std::move(fresh).value();
    }
    return Status::Ok();
  }

  void UpdateStats() {
    uint64_t accepted = 0, rejected = 0, duplicates = 0;
    for (const PrimitiveState& p : primitives) {
      const ReconstructorStats& r = p.reconstructor->stats();
      accepted += r.accepted;
      rejected += r.rejected + r.overflow;
      duplicates += r.duplicates + r.late;
    }
    stats.datagrams_received = accepted;
    stats.datagrams_duplicate = duplicates + udp_replays_seen;
    uint64_t udp_drops = udp_drops_seen;
    if (udp) {
      // A repeated packet number is a copy the network made (or a replay:
      // the two look alike); it counts with the duplicates, not as rejected.
      const DropCounters c = udp->counters();
      udp_replays_seen = c.Get(DropReason::kReplayed);
      udp_drops = c.dropped() - udp_replays_seen;
      udp_drops_seen = udp_drops;
      stats.hellos_sent = udp->hellos_sent();
      if (udp->hello_rtt_us() > 0) stats.hello_rtt_ms = udp->hello_rtt_us() / 1000.0;
    }
    stats.datagrams_rejected = rejected + stray_rejected + udp_drops;
  }
  uint64_t udp_drops_seen = 0;
  uint64_t udp_replays_seen = 0;
  uint64_t stray_rejected = 0;   // datagrams no primitive's reconstructor could take
  size_t touched = SIZE_MAX;     // the primitive the last arrival went to
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
  auto impl = std::make_unique<Impl>();
  impl->options = options;
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
  Event none;
  const auto deadline = Clock::now() + std::chrono::milliseconds(std::max(0, timeout_ms));
  for (;;) {
    if (!s.events.empty()) {
      Event e = s.events.front();
      s.events.pop_front();
      return e;
    }
    if (s.over) return none;
    const uint64_t now = SteadyNowUs();
    // A budget ran out: stop here with what arrived.
    if (!s.session_end && s.level_shown >= 0) {
      const bool bytes_out = s.options.byte_budget > 0 && s.stats.reliable_bytes + s.stats.unreliable_bytes >= s.options.byte_budget;
      const bool time_out = s.options.time_budget_ms > 0 && MsSince(s.opened) >= static_cast<double>(s.options.time_budget_ms);
      if (bytes_out || time_out) {
        s.session_end = true;
        s.session_end_us = now;
        s.stats.end_reason = bytes_out ? "byte_budget" : "time_budget";
        s.Finish(s.stats.end_reason);
        Status st = s.Advance(now, true);
        if (!st.ok()) return s.Fail(st);
      }
    }
    if (s.session_end && s.level_shown >= 0) {
      // Everything is decoded, or the stragglers had their time.
      // Late only once every arrival taken is handed over: a poll that
      // stopped at an event leaves the rest of its arrivals queued here.
      const uint64_t window_us = 2 * static_cast<uint64_t>(s.options.straggler_timeout_ms) * 1000;
      const bool late = s.HandedOver() && s.StragglerClock(now) > s.session_end_us + window_us;
      const bool budget = s.stats.end_reason == "byte_budget" || s.stats.end_reason == "time_budget";
      if (!s.repair_asked && (s.AllDone() || late || budget)) {
        if (!s.AllDone()) {
          Status st = s.Advance(now, true);
          if (!st.ok()) return s.Fail(st);
        }
        s.stats.time_to_full_ms = MsSince(s.opened);
        // With repair: ask for what was lost, then wait for it below.
        if (!s.options.repair || budget || !s.AskRepair(now)) s.ready_to_complete = true;
      }
      if (s.repair_asked && !s.ready_to_complete) {
        bool call_over = false;
        {
          std::lock_guard<std::mutex> lock(s.mutex);
          call_over = s.finished && s.queue.empty() && s.local_messages.empty();
        }
        if (s.repair_ended) {
          Status st = s.DecodeAgain(now);
          if (!st.ok()) return s.Fail(st);
          s.stats.time_to_exact_ms = MsSince(s.opened);
          s.ready_to_complete = true;
        } else if (call_over || now >= s.repair_asked_us + Impl::kRepairWaitUs) {
          // The predicted mesh stays.
          s.stats.repair_error = call_over ? "the server ended the session before the repair" : "no repair within 10 s";
          s.ready_to_complete = true;
        }
      }
      if (s.ready_to_complete) {
        s.UpdateStats();
        if (s.stats.time_to_exact_ms == 0 && s.stats.datagrams_lost == 0) s.stats.time_to_exact_ms = s.stats.time_to_full_ms;
        s.Finish("complete");
        if (s.udp) s.udp->RequestStop();  // joined when the session is destroyed
        s.over = true;
        Event e;
        e.type = EventType::kComplete;
        e.level = s.level_shown;
        s.events.push_back(e);
        continue;
      }
    }
    bool finished = false;
    Status final_status;
    {
      std::unique_lock<std::mutex> lock(s.mutex);
      if (s.local_messages.empty() && s.local_packets.empty()) {
        // Wake at least every 10 ms: refinements become ready by the clock too.
        const auto wake = std::min(deadline, Clock::now() + std::chrono::milliseconds(10));
        s.arrived.wait_until(lock, wake, [&s] { return !s.queue.empty() || !s.packets.empty() || s.finished; });
      }
      // Read before the queue is taken: every datagram that reached the
      // socket before it is in the queue now.
      s.arrivals_until_us = s.udp ? s.udp->caught_up_us() : SteadyNowUs();
      for (auto& m : s.queue) s.local_messages.push_back(std::move(m));
      for (auto& p : s.packets) s.local_packets.push_back(std::move(p));
      s.queue.clear();
      s.packets.clear();
      finished = s.finished;
      final_status = s.final_status;
    }
    // The arrivals of both channels in the order they arrived, each decided
    // on with its own arrival time (a busy host thread must not time a
    // refinement out while its datagrams wait here), until one makes an
    // event: the rest waits for the next poll, so the views match the event.
    while (s.events.empty() && (!s.local_messages.empty() || !s.local_packets.empty())) {
      const bool message = !s.local_messages.empty() &&
                           (s.local_packets.empty() || s.local_messages.front().first <= s.local_packets.front().time_us);
      uint64_t at;
      Status st;
      if (message) {
        at = s.local_messages.front().first;
        const v1::ServerMessage m = std::move(s.local_messages.front().second);
        s.local_messages.pop_front();
        st = s.Handle(m, at);
      } else {
        const UdpPacket p = std::move(s.local_packets.front());
        s.local_packets.pop_front();
        at = p.time_us;
        st = s.OfferDatagram(p.payload.data(), p.payload.size(), &p, at);
      }
      if (!st.ok()) return s.Fail(st);
      if (s.level_shown >= 0 && s.events.empty()) {
        // A gRPC arrival may be stamped after datagrams that wait unread
        // in the socket: the horizon bounds the clock.
        st = s.AdvanceTouched(s.StragglerClock(at));
        if (!st.ok()) return s.Fail(st);
      }
    }
    const bool drained = s.HandedOver();
    if (s.level_shown >= 0) {
      if (drained && s.events.empty()) {
        Status st = s.Advance(s.StragglerClock(SteadyNowUs()), false);
        if (!st.ok()) return s.Fail(st);
      }
      s.UpdateStats();
    }
    if (finished && drained && !s.session_end) {
      Status status = final_status.ok() ? Unavailable("the server ended the session before its end") : final_status;
      return s.Fail(std::move(status));
    }
    if (s.events.empty() && Clock::now() >= deadline) return none;
  }
}

void Session::Cancel() { impl_->context.TryCancel(); }

size_t Session::primitive_count() const { return impl_->primitives.size(); }

StatusOr<Primitive> Session::Mesh(size_t primitive) const {
  if (primitive >= impl_->primitives.size()) return InvalidArgument("primitive: " + std::to_string(primitive) + " does not exist");
  return DequantizeMesh(impl_->primitives[primitive].reconstructor->reader().Mesh(), -1);
}

StatusOr<std::vector<uint8_t>> Session::Predicted(size_t primitive) const {
  if (primitive >= impl_->primitives.size()) return InvalidArgument("primitive: " + std::to_string(primitive) + " does not exist");
  const StreamReader& r = impl_->primitives[primitive].reconstructor->reader();
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
  for (const PrimitiveState& p : impl_->primitives) n += p.reconstructor->reader().unreliable_vertices();
  return n;
}

Scene Session::CurrentScene() const {
  if (impl_->has_scene) {
    // The asset's scene, its refined primitives at the level reached (the
    // material and everything else of the primitive as the scene has it).
    Scene scene = impl_->scene;
    for (const PrimitiveState& p : impl_->primitives) {
      Primitive& slot = scene.meshes[p.start.mesh()].primitives[p.scene_slot];
      const int32_t material = slot.material;
      slot = DequantizeMesh(p.reconstructor->reader().Mesh(), material);
    }
    return scene;
  }
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
      mesh.primitives.push_back(DequantizeMesh(impl_->primitives[ours].reconstructor->reader().Mesh(), -1));
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
