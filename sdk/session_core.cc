#include "sdk/session_core.h"

#include <algorithm>
#include <utility>

#include "codec/bitstream/format.h"
#include "codec/bitstream/reader.h"
#include "codec/mesh/quantized_mesh.h"
#include "fec/reed_solomon.h"
#include "importers/draco_base_coder.h"
#include "importers/draco_codec.h"
#include "importers/gltf_import.h"

namespace meshstream::sdk {

namespace {

std::string Where(uint32_t stream) { return "primitive " + std::to_string(stream); }

// The glTF semantics of the primitive's Draco attributes (POSITION required).
StatusOr<DracoAttributeIds> IdsOf(const v1::PrimitiveStart& p) {
  DracoAttributeIds ids;
  for (const auto& [name, id] : p.draco_attributes()) {
    Status s = AddDracoAttribute(name, id, ids);
    if (!s.ok()) return s.WithContext(Where(p.primitive()));
  }
  if (ids.position < 0) return InvalidInput(Where(p.primitive()) + ": no POSITION");
  return ids;
}

const uint8_t* Bytes(const std::string& s) { return reinterpret_cast<const uint8_t*>(s.data()); }

// A primitive's level list (docs/spec/streaming-protocol.md, "Levels of a
// scene": PrimitiveStart's, or a LevelPlan's): non-decreasing counts, the
// last one all of the session's `refinements`; empty is allowed.
template <typename List>
Status CheckLevelList(const List& at, uint32_t refinements, const std::string& where) {
  for (int i = 0; i < at.size(); ++i) {
    if (at[i] > refinements || (i > 0 && at[i] < at[i - 1])) {
      return InvalidInput(where + ": level_refinements[" + std::to_string(i) + "] = " + std::to_string(at[i]) +
                          " is not between the level before and the " + std::to_string(refinements) +
                          " refinements");
    }
  }
  if (!at.empty() && at[at.size() - 1] != refinements) {
    return InvalidInput(where + ": the last level applies " + std::to_string(at[at.size() - 1]) + " of " +
                        std::to_string(refinements) + " refinements");
  }
  return Status::Ok();
}

}  // namespace

// What the client tracks of one refinement for its report.
struct SessionCore::RefinementTrack {
  bool has_control = false;
  std::string control;             // held until the refinement's END arrives (then given to the reconstructor)
  bool end_seen = false;           // its END datagram or its RefinementEnd arrived
  uint32_t datagrams = 0;          // data datagrams the server sends
  uint64_t first_packet_number = 0;
  std::vector<uint64_t> packet_numbers;  // UDP DATA that arrived (any order, no repeats: the replay window)
  uint64_t bytes = 0;
  uint64_t end_time_us = 0;        // when its END datagram arrived (0: never)
  uint64_t udp_first_us = 0;       // when its first UDP data datagram arrived (0: none yet) ...
  uint64_t udp_last_us = 0;        // ... its latest one
  uint64_t span_bytes = 0;         // the bytes of those after the first (the delivery rate)
  bool reliable = false;           // its datagrams come on the gRPC stream (ControlBlock.reliable)
  bool before_proof = false;       // ... because no UDP address was proven yet (ControlBlock.before_proof)
  bool parity_follows = false;     // UDP: parity covering it follows (ControlBlock.parity_follows)
  uint64_t later_us = 0;           // UDP: when a datagram numbered after its data arrived (0: none yet)
  bool declared = false;           // UDP: what is missing was declared lost
  bool spurious = false;           // ... and a datagram of it came after all
  // With repair: the control block and every data datagram that arrived,
  // kept until the session ends, and the ordinals the report found missing.
  std::string kept_control;
  std::vector<std::string> kept_datagrams;
  std::vector<uint32_t> missing;
};

struct SessionCore::PrimitiveState {
  v1::PrimitiveStart start;             // as announced, without base_mesh (decoded, not kept)
  std::unique_ptr<StreamReconstructor> reconstructor;
  std::vector<RefinementTrack> tracks;  // per refinement of this session
  size_t reported = 0;                  // refinements reported
  size_t given = 0;                     // control blocks given to the reconstructor (in order)
  size_t ended = 0;                     // refinements [0, ended) have had an END (theirs or a later one's)
  uint64_t parity_expected = 0;         // parity datagrams the RefinementEnds announced
  uint64_t parity_seen = 0;             // parity datagrams that arrived
  QuantizedMesh kept_base;              // with repair: the decoded base, to decode again from
};

v1::View ViewProto(const View& view) {
  v1::View v;
  for (double c : view.camera) v.add_camera_position(c);
  for (double m : view.view_projection) v.add_view_projection(m);
  v.set_viewport_width(view.viewport_width);
  v.set_viewport_height(view.viewport_height);
  return v;
}

v1::ClientMessage ViewMessage(const View& view) {
  v1::ClientMessage m;
  *m.mutable_view() = ViewProto(view);
  return m;
}

void StampHold(Outgoing& o, uint64_t sent_at_us) {
  if (!o.message.has_report()) return;
  o.message.mutable_report()->set_hold_us(o.end_time_us != 0 && sent_at_us > o.end_time_us ? sent_at_us - o.end_time_us
                                                                                            : 0);
}

SessionCore::SessionCore(const SessionOptions& options, uint64_t opened_us)
    : options_(options),
      opened_us_(opened_us),
      losses_(static_cast<uint64_t>(std::max(0, options.straggler_timeout_ms)) * 1000) {}

SessionCore::~SessionCore() = default;

void SessionCore::TakeMessage(v1::ServerMessage m, uint64_t at_us) { inbox_messages_.emplace_back(at_us, std::move(m)); }

void SessionCore::TakeDatagram(std::vector<uint8_t> payload, uint64_t packet_number, uint64_t at_us) {
  inbox_datagrams_.push_back(TakenDatagram{std::move(payload), packet_number, at_us});
}

void SessionCore::TakeStreamEnd(Status status) {
  stream_ended_ = true;
  stream_status_ = std::move(status);
}

void SessionCore::SetUdpCounters(const UdpCounters& c) {
  udp_ = c;
  losses_.SetRtt(c.hello_rtt_us);
}

std::optional<Event> SessionCore::NextEvent() {
  if (events_.empty()) return std::nullopt;
  Event e = events_.front();
  events_.pop_front();
  return e;
}

std::vector<Outgoing> SessionCore::TakeOutgoing() { return std::exchange(outgoing_, {}); }

std::optional<UdpStart> SessionCore::TakeUdpStart() { return std::exchange(udp_start_, std::nullopt); }

bool SessionCore::TakeUdpStop() { return std::exchange(udp_stop_, false); }

double SessionCore::MsSinceOpen(uint64_t now_us) const {
  return now_us > opened_us_ ? static_cast<double>(now_us - opened_us_) / 1000.0 : 0.0;
}

void SessionCore::Push(EventType type, int32_t level) {
  Event e;
  e.type = type;
  e.level = level;
  events_.push_back(e);
}

uint32_t SessionCore::AppliedAt(const PrimitiveState& p, int32_t level) {
  if (level <= 0) return 0;
  const auto& at = p.start.level_refinements();
  if (at.empty()) return std::min(static_cast<uint32_t>(level), p.start.refinements());
  return at[std::min<int>(level, at.size()) - 1];
}

// The level every primitive has reached: the highest L whose count
// (AppliedAt) every primitive has applied.
int32_t SessionCore::LevelEverywhere() const {
  int32_t level = 0;
  while (level < levels_) {
    for (const PrimitiveState& p : primitives_) {
      if (p.reconstructor->applied() < AppliedAt(p, level + 1)) return level;
    }
    ++level;
  }
  return level;
}

bool SessionCore::AllDone() const {
  for (const PrimitiveState& p : primitives_) {
    if (p.reconstructor->applied() < p.start.refinements()) return false;
    // Parity announced and not all here, while something is still
    // predicted: it may yet rebuild it, until the reordering window after
    // the stream's end has passed (Settle: holds_released_).
    if (!holds_released_ && p.parity_seen < p.parity_expected && p.reconstructor->reader().inexact_positions() > 0) {
      return false;
    }
  }
  return true;
}

void SessionCore::Fail(Status status) {
  phase_ = SessionPhase::kOver;
  events_.clear();
  Event e;
  e.type = EventType::kError;
  e.status = std::move(status);
  events_.push_back(e);
  StopUdp();
}

// The UDP half ends (the server fell back to gRPC, or the session is over):
// a start not yet taken is dropped, a running half is asked to stop.
void SessionCore::StopUdp() {
  if (udp_running_) udp_stop_ = true;
  udp_running_ = false;
  udp_start_.reset();
}

void SessionCore::Finish(const std::string& reason) {
  if (writes_done_) return;
  Outgoing o;
  o.message.mutable_done()->set_reason(reason);
  o.half_close = true;
  outgoing_.push_back(std::move(o));
  writes_done_ = true;
}

// The transport and its name in the statistics, together.
void SessionCore::SetTransport(SessionTransport t) {
  transport_ = t;
  stats_.transport = t == SessionTransport::kUdp ? "udp" : "grpc";
}

StatusOr<size_t> SessionCore::PrimitiveOf(uint32_t stream_id) const {
  auto it = by_stream_.find(stream_id);
  if (it == by_stream_.end()) return InvalidInput("a block for unknown primitive " + std::to_string(stream_id));
  return it->second;
}

Status SessionCore::Start(const v1::SessionStart& start, uint64_t now) {
  SetTransport(start.transport() == v1::TRANSPORT_UDP ? SessionTransport::kUdp : SessionTransport::kGrpc);
  // (A server before version 4 names no profile: its streams are loss-tolerant.)
  stats_.profile = start.profile() == v1::PROFILE_RELIABLE ? "reliable" : "loss-tolerant";
  ReconstructorOptions ro;
  ro.straggler_timeout_us = static_cast<uint64_t>(std::max(1, options_.straggler_timeout_ms)) * 1000;
  // UDP may run ahead of the gRPC stream by many refinements (a loaded
  // client, a TCP queue): buffer datagrams for any refinement of the
  // stream, within the byte budget, rather than drop them for the window.
  ro.window = kMaxRefinements;
  ro.max_buffered_bytes = size_t{64} << 20;
  // Parity datagrams rebuild what UDP lost (docs/design/loss-protection.md).
  ro.erasure = &fec::DefaultErasureCode();
  const int threads = options_.decode_threads < 0 ? ForkJoinPool::HardwareWorkers() : options_.decode_threads;
  if (threads > 1) {
    decode_pool_ = std::make_unique<ForkJoinPool>(threads);
    // Several streams (a scene's primitives, a large mesh's spatial parts)
    // decode at once, each on one worker, at the end of each batch of
    // arrivals (Advance); one stream shares the workers within its
    // refinements. The meshes are the same bit for bit either way.
    across_streams_ = start.primitives_size() > 1;
    if (across_streams_) stats_.parallel_streams = static_cast<uint32_t>(start.primitives_size());
    if (!across_streams_) ro.runner = decode_pool_.get();
  }
  reconstructor_options_ = ro;
  for (const v1::PrimitiveStart& p : start.primitives()) {
    const std::string where = Where(p.primitive());
    if (by_stream_.count(p.primitive()) != 0) return InvalidInput(where + " announced twice");
    PrimitiveState state;
    state.start = p;
    // The base is decoded from `p` below and never read again: the copy kept
    // does not hold its bytes.
    std::string().swap(*state.start.mutable_base_mesh());
    MS_ASSIGN_OR_RETURN(StreamReconstructor reconstructor, NewReconstructor(p));
    state.reconstructor = std::make_unique<StreamReconstructor>(std::move(reconstructor));
    if (p.refinements() > state.reconstructor->reader().refinement_count()) {
      return InvalidInput(where + ": more refinements announced than its header has");
    }
    MS_ASSIGN_OR_RETURN(DracoAttributeIds ids, IdsOf(p));
    auto base = DecodeDracoBase(Bytes(p.base_mesh()), p.base_mesh().size(), ids,
                                state.reconstructor->reader().header().grids);
    if (!base.ok()) return base.status().WithContext(where);
    if (options_.repair) state.kept_base = base.value();
    Status s = state.reconstructor->SetBase(std::move(base).value());
    if (!s.ok()) return s.WithContext(where);
    // The scene's levels.
    const auto& at = p.level_refinements();
    MS_RETURN_IF_ERROR(CheckLevelList(at, p.refinements(), where));
    state.tracks.resize(p.refinements());
    levels_ = std::max(levels_, static_cast<int32_t>(at.empty() ? p.refinements() : at.size()));
    stats_.reliable_bytes += p.header().size() + p.base_mesh().size();
    by_stream_[p.primitive()] = primitives_.size();
    primitives_.push_back(std::move(state));
  }
  auto layout = std::make_shared<SessionLayout>();
  for (const PrimitiveState& p : primitives_) layout->places.push_back({p.start.mesh(), p.start.mesh_primitive(), 0});
  if (!start.scene_glb().empty()) {
    const std::vector<uint8_t> glb(start.scene_glb().begin(), start.scene_glb().end());
    MS_ASSIGN_OR_RETURN(layout->scene, ImportGltfBytes(glb, "", "the session's scene", ImportOptions{}));
    for (size_t i = 0; i < primitives_.size(); ++i) {
      // The glTF primitive index counts carried primitives too (Mesh::Order).
      SessionLayout::Place& place = layout->places[i];
      const uint32_t m = place.mesh, k = place.mesh_primitive;
      const std::vector<Mesh::Ref> order =
          m < layout->scene.meshes.size() ? layout->scene.meshes[m].Order() : std::vector<Mesh::Ref>();
      if (k >= order.size() || order[k].carried) {
        return InvalidInput(Where(primitives_[i].start.primitive()) + ": the scene has no refined mesh " +
                            std::to_string(m) + " primitive " + std::to_string(k));
      }
      place.scene_slot = order[k].index;
    }
    stats_.reliable_bytes += start.scene_glb().size();
    layout->has_scene = true;
  }
  layout_ = std::move(layout);
  if (transport_ == SessionTransport::kUdp) {
    if (start.client_to_server_key().size() != kPacketKeyBytes || start.server_to_client_key().size() != kPacketKeyBytes) {
      return InvalidInput("session start: the UDP keys are not 32 bytes each");
    }
    if (start.udp().port() == 0 || start.udp().port() > 65535) return InvalidInput("session start: no UDP port");
    UdpStart u;
    u.host = start.udp().host();
    u.port = static_cast<uint16_t>(start.udp().port());
    u.session_id = start.udp_session_id();
    std::copy(start.client_to_server_key().begin(), start.client_to_server_key().end(), u.keys.client_to_server.begin());
    std::copy(start.server_to_client_key().begin(), start.server_to_client_key().end(), u.keys.server_to_client.begin());
    udp_start_ = std::move(u);
    udp_running_ = true;
  }
  stats_.time_to_base_ms = MsSinceOpen(now);
  level_shown_ = 0;
  return Status::Ok();
}

// A reconstructor for the primitive `p` announces, with the session's
// options (reconstructor_options_) and its refinements as the level of detail.
StatusOr<StreamReconstructor> SessionCore::NewReconstructor(const v1::PrimitiveStart& p) const {
  ReconstructorOptions ro = reconstructor_options_;
  ro.lod = static_cast<int>(std::min<uint32_t>(p.refinements(), kMaxRefinements));
  auto reconstructor = StreamReconstructor::Create(Bytes(p.header()), p.header().size(), p.primitive(), ro);
  if (!reconstructor.ok()) return reconstructor.status().WithContext(Where(p.primitive()));
  return reconstructor;
}

// The END of refinement `refinement` of `p` arrived on either channel (the
// earlier ones were sent before it).
void SessionCore::NoteEnd(PrimitiveState& p, size_t refinement) { p.ended = std::max(p.ended, refinement + 1); }

// Gives the reconstructor the held control blocks of `p`, in order, as far
// as they have arrived. A control block is held until its refinement's END
// arrives on either channel (NoteEnd), so that the straggler timeout counts
// from the end of the sending (a paced refinement may take longer to send
// than the timeout), not from its start; and until every primitive has
// reached its level, so that no primitive runs ahead of the next level
// (its refinements there: AppliedAt) and the views at an event are at the
// event's level (a refinement of the reliable cut, on the stream, may overtake
// another primitive's UDP datagrams). `flushing`: everything that arrived.
Status SessionCore::GiveControls(PrimitiveState& p, uint64_t now, bool flushing) {
  while (p.given < p.tracks.size() && p.tracks[p.given].has_control &&
         (flushing || (p.given < p.ended && p.given < AppliedAt(p, LevelEverywhere() + 1)))) {
    RefinementTrack& t = p.tracks[p.given];
    Status s = p.reconstructor->OnControl(Bytes(t.control), t.control.size(), now);
    if (!s.ok()) return s.WithContext(Where(p.start.primitive()));
    if (t.parity_follows) p.reconstructor->ExpectParity(static_cast<uint32_t>(p.given));
    if (options_.repair) t.kept_control = std::move(t.control);
    t.control.clear();
    t.control.shrink_to_fit();
    ++p.given;
  }
  return Status::Ok();
}

Status SessionCore::GiveAllControls(uint64_t now, bool flushing) {
  for (PrimitiveState& p : primitives_) MS_RETURN_IF_ERROR(GiveControls(p, now, flushing));
  return Status::Ok();
}

// One datagram of either channel (`packet_number`: UDP's, null on the
// stream). Its header is read here, once, and the reconstructor gets it parsed.
Status SessionCore::OfferDatagram(const uint8_t* data, size_t size, const uint64_t* packet_number, uint64_t now,
                                  bool reliable_over_udp) {
  auto parsed = ParsedDatagram::Parse(data, size);
  const auto primitive = parsed.ok() ? by_stream_.find(parsed->header().stream) : by_stream_.end();
  if (primitive == by_stream_.end()) {
    ++stray_rejected_;  // the reconstructors never see it
    return Status::Ok();
  }
  const DatagramHeader& h = parsed->header();
  touched_ = primitive->second;
  PrimitiveState& p = primitives_[touched_];
  if (h.kind == DatagramKind::kParity) {
    // Not a refinement's datagram: the reconstructor rebuilds what it can.
    ++stats_.parity_datagrams;
    stats_.parity_bytes += size;
    ++p.parity_seen;
    p.reconstructor->OnDatagram(parsed.value(), now);
    if (packet_number != nullptr) {
      NotePacketNumber(*packet_number, now);
      MS_RETURN_IF_ERROR(DeclareLosses(StragglerClock(now)));
    }
    return Status::Ok();
  }
  const bool end = h.kind == DatagramKind::kEnd;
  if (h.refinement < p.tracks.size()) {
    RefinementTrack& t = p.tracks[h.refinement];
    // A datagram of the stream over UDP: the reliable cut's, or one sent
    // before an address was proven.
    if (reliable_over_udp && !end) (t.before_proof ? stats_.early_datagram_bytes : stats_.reliable_datagram_bytes) += size;
    if (!end && packet_number != nullptr && t.declared && !t.spurious &&
        std::find(t.packet_numbers.begin(), t.packet_numbers.end(), *packet_number) == t.packet_numbers.end()) {
      // Declared lost, yet here: reordering beyond the rules. The packet
      // rule stops and the time window doubles (RFC 9002 section 6.1.2's
      // adaptive thresholds), up to the straggler timeout.
      t.spurious = true;
      ++stats_.losses_spurious;
      losses_.OnSpurious();
    }
    if (end) {
      if (t.end_time_us == 0) t.end_time_us = now;
      t.end_seen = true;
    } else {
      t.bytes += size;
      if (packet_number != nullptr && t.packet_numbers.size() < 4 * (size_t{1} << 16)) {
        t.packet_numbers.push_back(*packet_number);
      }
      if (packet_number != nullptr) {
        if (t.udp_first_us == 0) {
          t.udp_first_us = now;
        } else {
          t.span_bytes += size;
        }
        t.udp_last_us = std::max(t.udp_last_us, now);
      }
      // Copies are kept too (the reconstructor drops them again); the cap
      // bounds what a hostile stream can make the client hold.
      if (options_.repair && kept_bytes_ + size <= kMaxKeptBytes) {
        t.kept_datagrams.emplace_back(reinterpret_cast<const char*>(data), size);
        kept_bytes_ += size;
      }
    }
  }
  if (!end) stats_.unreliable_bytes += size;
  if (!end && packet_number != nullptr) ++stats_.udp_datagrams_received;
  p.reconstructor->OnDatagram(parsed.value(), now);
  if (packet_number != nullptr) {
    NotePacketNumber(*packet_number, now);
    MS_RETURN_IF_ERROR(DeclareLosses(StragglerClock(now)));
  }
  if (!end) return Status::Ok();
  NoteEnd(p, h.refinement);
  return GiveControls(p, now, false);
}

// The wait after a later datagram before what is missing counts as lost
// (loss_detector.h).
uint64_t SessionCore::ReorderWindowUs() const { return losses_.WindowUs(); }

// A UDP datagram numbered `packet_number` arrived at `at`: the refinements
// whose data was all sent before it have had a later datagram.
template <typename Primitives, typename F>
Status SessionCore::ForOpenUdpRefinements(Primitives& primitives, F f) {
  for (auto& p : primitives) {
    for (size_t r = p.reconstructor->applied(); r < p.tracks.size() && p.tracks[r].has_control; ++r) {
      auto& t = p.tracks[r];
      if (t.reliable || t.declared || t.datagrams == 0) continue;
      MS_RETURN_IF_ERROR(f(p, r, t));
    }
  }
  return Status::Ok();
}

void SessionCore::NotePacketNumber(uint64_t packet_number, uint64_t at) {
  losses_.OnPacket(packet_number, at);
  (void)ForOpenUdpRefinements(primitives_, [&](PrimitiveState&, size_t, RefinementTrack& t) {
    if (t.later_us == 0 && packet_number >= t.first_packet_number + t.datagrams) t.later_us = at;
    return Status::Ok();
  });
}

// Declares lost what UDP refinements miss once later datagrams show it will
// not come (RFC 9002 section 6.1 on the receiver): a datagram numbered
// kPacketThreshold past the refinement's last data datagram arrived, or the
// reorder window has passed (by `clock`, the arrival horizon's) since the
// first datagram numbered after them arrived. Only with an RTT sample.
Status SessionCore::DeclareLosses(uint64_t clock) {
  if (!LossRulesActive() || transport_ != SessionTransport::kUdp) return Status::Ok();
  return ForOpenUdpRefinements(primitives_, [&](PrimitiveState& p, size_t r, const RefinementTrack& t) {
    const uint64_t last_data = t.first_packet_number + t.datagrams - 1;
    return losses_.LostByPackets(last_data) || losses_.LostByTime(t.later_us, clock) ? Declare(p, r, clock)
                                                                                    : Status::Ok();
  });
}

Status SessionCore::Declare(PrimitiveState& p, size_t refinement, uint64_t now) {
  RefinementTrack& t = p.tracks[refinement];
  t.declared = true;
  if (t.packet_numbers.size() < t.datagrams) ++stats_.losses_declared;
  p.reconstructor->Declare(static_cast<uint32_t>(refinement));
  if (t.end_seen) return GiveControls(p, now, false);
  // Its END datagram was lost too: the control block's count makes it.
  return GiveEnd(p, static_cast<uint32_t>(refinement), t.datagrams, now);
}

uint64_t SessionCore::next_due_us() const {
  uint64_t due = UINT64_MAX;
  if (phase_ == SessionPhase::kEnding && !holds_released_) due = session_end_us_ + ReorderWindowUs();
  if (!LossRulesActive() || transport_ != SessionTransport::kUdp) return due;
  const uint64_t window = ReorderWindowUs();
  (void)ForOpenUdpRefinements(primitives_, [&](const PrimitiveState&, size_t, const RefinementTrack& t) {
    if (t.later_us != 0) due = std::min(due, t.later_us + window);
    return Status::Ok();
  });
  return due;
}

// The reliable copy of the END: the refinement is complete once its
// announced datagrams are in, even when the END datagram was lost.
Status SessionCore::OnRefinementEnd(const v1::RefinementEnd& e, uint64_t now) {
  MS_ASSIGN_OR_RETURN(size_t index, PrimitiveOf(e.primitive()));
  touched_ = index;
  PrimitiveState& p = primitives_[index];
  if (e.refinement() >= p.tracks.size()) return InvalidInput("a refinement end for a refinement not in the session");
  p.parity_expected += e.parity_datagrams();
  return GiveEnd(p, e.refinement(), e.datagrams_sent(), now);
}

// An END for `refinement` of `p` announcing `datagrams`, made here (from
// RefinementEnd, or a declaration's count) rather than received.
Status SessionCore::GiveEnd(PrimitiveState& p, uint32_t refinement, uint32_t datagrams, uint64_t now) {
  p.tracks[refinement].end_seen = true;
  const std::vector<uint8_t> end = MakeStreamEndDatagram(Bytes(p.start.header()), p.start.header().size(),
                                                         p.start.primitive(), refinement, datagrams);
  p.reconstructor->OnDatagram(end.data(), end.size(), now);
  NoteEnd(p, refinement);
  return GiveControls(p, now, false);
}

// The server ordered what it had not begun by a new view: each primitive's
// level list is replaced, the levels before the first changed one being as
// they were, each list as PrimitiveStart's rules (non-decreasing, the last
// all of the primitive's refinements in this session).
Status SessionCore::OnLevelPlan(const v1::LevelPlan& plan) {
  if (phase_ == SessionPhase::kOpening) return InvalidInput("a level plan before the session start");
  if (static_cast<size_t>(plan.primitives_size()) != primitives_.size()) {
    return InvalidInput("a level plan for " + std::to_string(plan.primitives_size()) + " primitives, not " +
                        std::to_string(primitives_.size()));
  }
  const uint32_t first = plan.first_changed_level();
  for (size_t i = 0; i < primitives_.size(); ++i) {
    const PrimitiveState& p = primitives_[i];
    const auto& old = p.start.level_refinements();
    const auto& now = plan.primitives(static_cast<int>(i)).level_refinements();
    const std::string where = Where(p.start.primitive()) + ": level plan";
    if (old.empty() || now.size() != old.size()) return InvalidInput(where + ": " + std::to_string(now.size()) +
                                                                     " levels, the session has " + std::to_string(old.size()));
    MS_RETURN_IF_ERROR(CheckLevelList(now, p.start.refinements(), where));
    for (int l = 0; l + 1 < static_cast<int>(first) && l < now.size(); ++l) {
      if (now[l] != old[l]) {
        return InvalidInput(where + ": level " + std::to_string(l + 1) + " changed before the first changed level " +
                            std::to_string(first));
      }
    }
  }
  for (size_t i = 0; i < primitives_.size(); ++i) {
    *primitives_[i].start.mutable_level_refinements() = plan.primitives(static_cast<int>(i)).level_refinements();
  }
  ++stats_.level_plans;
  return Status::Ok();
}

// Handles one message of the gRPC stream.
Status SessionCore::Handle(const v1::ServerMessage& m, uint64_t now) {
  // Nothing but the start before the start: a block for a primitive not yet
  // announced is an unknown primitive.
  switch (m.kind_case()) {
    case v1::ServerMessage::kSession: {
      if (phase_ != SessionPhase::kOpening) return InvalidInput("a second session start");
      MS_RETURN_IF_ERROR(Start(m.session(), now));
      phase_ = end_reason_ == EndReason::kNone ? SessionPhase::kStreaming : SessionPhase::kEnding;
      Push(EventType::kBaseReady, 0);
      return Status::Ok();
    }
    case v1::ServerMessage::kTransportChange: {
      if (m.transport_change().transport() == v1::TRANSPORT_GRPC) {
        StopUdp();
        SetTransport(SessionTransport::kGrpc);
        stats_.fallback_reason = m.transport_change().reason();
      }
      return Status::Ok();
    }
    case v1::ServerMessage::kControl: {
      const v1::ControlBlock& c = m.control();
      MS_ASSIGN_OR_RETURN(size_t index, PrimitiveOf(c.primitive()));
      touched_ = index;
      PrimitiveState& p = primitives_[index];
      if (c.refinement() >= p.tracks.size() || p.tracks[c.refinement()].has_control) {
        return InvalidInput(Where(c.primitive()) + ": a control block for refinement " +
                            std::to_string(c.refinement()) + " it does not expect");
      }
      // At most two data datagrams per split (structure and geometry), as
      // for an END (reconstructor.h): the report sizes itself by this count.
      const uint64_t splits = p.reconstructor->reader().header().split_counts[c.refinement()];
      if (c.datagrams() > 2 * splits) {
        return InvalidInput(Where(c.primitive()) + ": refinement " + std::to_string(c.refinement()) + " announces " +
                            std::to_string(c.datagrams()) + " datagrams for " + std::to_string(splits) + " splits");
      }
      RefinementTrack& t = p.tracks[c.refinement()];
      t.has_control = true;
      t.control = c.control();
      t.datagrams = c.datagrams();
      t.first_packet_number = c.first_packet_number();
      t.reliable = c.reliable();
      t.before_proof = c.reliable() && c.before_proof();
      t.parity_follows = !c.reliable() && c.parity_follows();
      // UDP may run ahead of the stream: datagrams numbered after this
      // refinement's may have come already; the window counts from now.
      if (!t.reliable && t.datagrams > 0 && SeenPacketNumber(t.first_packet_number + t.datagrams)) {
        t.later_us = now;
      }
      // Counted as they come; the reliable copy is charged to the datagram bytes.
      if (t.reliable && transport_ == SessionTransport::kUdp) ++(t.before_proof ? stats_.early_refinements : stats_.reliable_refinements);
      stats_.reliable_bytes += c.control().size();
      return t.end_seen ? GiveControls(p, now, false) : Status::Ok();
    }
    case v1::ServerMessage::kDatagram: {
      const std::string& d = m.datagram().payload();
      const bool repair = phase_ == SessionPhase::kRepairing && !repair_ended_;
      if (repair) {
        ++stats_.repaired_datagrams;
        stats_.repair_bytes += d.size();
      }
      return OfferDatagram(Bytes(d), d.size(), nullptr, now, !repair && transport_ == SessionTransport::kUdp);
    }
    case v1::ServerMessage::kRepairEnd: {
      if (!repair_asked_) return InvalidInput("a repair end for a repair not asked for");
      repair_ended_ = true;
      return Status::Ok();
    }
    case v1::ServerMessage::kRefinementEnd: return OnRefinementEnd(m.refinement_end(), now);
    case v1::ServerMessage::kLevels: return OnLevelPlan(m.levels());
    case v1::ServerMessage::kEnd: {
      // A second end, or one after a budget ran out, changes nothing.
      if (end_reason_ != EndReason::kNone) return Status::Ok();
      end_reason_ = EndReason::kServer;
      session_end_us_ = now;
      if (phase_ == SessionPhase::kStreaming) phase_ = SessionPhase::kEnding;
      stats_.end_reason = m.end().reason();
      return Status::Ok();
    }
    default: return Status::Ok();  // a kind this client does not know: ignored
  }
}

// Reports every refinement decoded since the last report.
void SessionCore::Report() {
  const bool udp = transport_ == SessionTransport::kUdp;
  for (PrimitiveState& p : primitives_) {
    while (p.reported < p.reconstructor->applied() && p.reported < p.tracks.size()) {
      RefinementTrack& t = p.tracks[p.reported];
      Outgoing o;
      v1::ClientReport& r = *o.message.mutable_report();
      r.set_primitive(p.start.primitive());
      r.set_refinement(static_cast<uint32_t>(p.reported));
      std::vector<uint8_t> got(t.datagrams, 0);
      uint32_t received = 0;
      if (udp && !t.packet_numbers.empty()) {
        for (uint64_t pn : t.packet_numbers) {
          const uint64_t ordinal = pn - t.first_packet_number;
          if (ordinal < t.datagrams && !got[ordinal]) {
            got[ordinal] = 1;
            ++received;
          }
        }
      } else if (!udp || t.datagrams == 0 || t.reliable) {
        received = t.datagrams;  // over gRPC (the session's or the reliable cut's) nothing is lost
        std::fill(got.begin(), got.end(), 1);
      }
      for (uint32_t k = 0; k < t.datagrams; ++k) {
        if (got[k]) continue;
        r.add_missing(k);
        if (options_.repair) t.missing.push_back(k);
      }
      stats_.datagrams_lost += t.datagrams - received;
      r.set_datagrams_received(received);
      r.set_bytes_received(t.bytes);
      r.set_end_received(t.end_time_us != 0);
      if (t.span_bytes > 0 && t.udp_last_us > t.udp_first_us) {
        r.set_arrival_span_us(t.udp_last_us - t.udp_first_us);
        r.set_span_bytes(t.span_bytes);
      }
      o.end_time_us = t.end_time_us;  // hold_us: StampHold, when it is written (after the decode)
      if (!rtt_reported_ && udp_running_ && udp_.hello_rtt_us > 0) {
        r.add_rtt_samples_us(static_cast<uint32_t>(std::min<uint64_t>(udp_.hello_rtt_us, UINT32_MAX)));
        rtt_reported_ = true;
      }
      if (!writes_done_) outgoing_.push_back(std::move(o));
      t.packet_numbers.clear();
      t.packet_numbers.shrink_to_fit();
      ++p.reported;
    }
  }
}

// Decodes what is ready, reports it and queues the events it makes.
Status SessionCore::Advance(uint64_t now, bool flush) {
  if (!flush) MS_RETURN_IF_ERROR(DeclareLosses(now));
  // Flushing gives everything; otherwise what the levels reached let go.
  MS_RETURN_IF_ERROR(GiveAllControls(now, flush));
  auto decode = [&](PrimitiveState& p) -> Status {
    if (flush) {
      Status s = p.reconstructor->Flush();
      if (!s.ok()) return s.WithContext(Where(p.start.primitive()));
    } else {
      auto n = p.reconstructor->Poll(now);
      if (!n.ok()) return n.status().WithContext(Where(p.start.primitive()));
    }
    return Status::Ok();
  };
  if (across_streams_) {
    // Every stream at once; what their progress lets go (a level reached
    // everywhere) is decoded in the same call, round after round.
    for (uint32_t round = 0; round < kMaxRefinements + 1; ++round) {
      std::vector<size_t> applied;
      for (const PrimitiveState& p : primitives_) applied.push_back(p.reconstructor->applied());
      std::vector<Status> status(primitives_.size());
      decode_pool_->Run(primitives_.size(), [&](size_t i, int) { status[i] = decode(primitives_[i]); });
      for (const Status& s : status) MS_RETURN_IF_ERROR(s);
      bool advanced = false;
      for (size_t i = 0; i < primitives_.size(); ++i) advanced = advanced || primitives_[i].reconstructor->applied() != applied[i];
      if (!advanced || flush) break;
      MS_RETURN_IF_ERROR(GiveAllControls(now, false));
    }
  } else {
    for (PrimitiveState& p : primitives_) MS_RETURN_IF_ERROR(decode(p));
  }
  Report();
  AnnounceLevel();
  return Status::Ok();
}

// After one arrival: decodes what became ready in the primitive it touched
// (the others wait for the end of the batch, when every arrival has been
// handed over), and reports and announces only if it advanced.
Status SessionCore::AdvanceTouched(uint64_t now) {
  if (touched_ == SIZE_MAX) return Status::Ok();
  // Streams decoded at once wait for the end of the batch (Advance).
  if (across_streams_) {
    touched_ = SIZE_MAX;
    return Status::Ok();
  }
  PrimitiveState& p = primitives_[touched_];
  touched_ = SIZE_MAX;
  const size_t before = p.reconstructor->applied();
  auto n = p.reconstructor->Poll(now);
  if (!n.ok()) return n.status().WithContext(Where(p.start.primitive()));
  if (p.reconstructor->applied() == before) return Status::Ok();
  // The level may have risen: the controls it held back go to their
  // reconstructors, to be decoded at the next advance (after this event).
  MS_RETURN_IF_ERROR(GiveAllControls(now, false));
  Report();
  AnnounceLevel();
  return Status::Ok();
}

// One event for the level reached, even when several completed at once (a
// viewer wants the latest, and the views show it). Called only after the
// start (level_shown_ is 0 from then on).
void SessionCore::AnnounceLevel() {
  const int32_t level = LevelEverywhere();
  if (level_shown_ >= 0 && level_shown_ < level) {
    level_shown_ = level;
    Push(EventType::kLevelReady, level);
  }
}

// The repair request: every missing datagram of every refinement. False
// when nothing is missing (no request is sent).
bool SessionCore::AskRepair(uint64_t now) {
  Outgoing o;
  v1::RepairRequest& request = *o.message.mutable_repair();
  for (const PrimitiveState& p : primitives_) {
    for (size_t i = 0; i < p.tracks.size(); ++i) {
      if (p.tracks[i].missing.empty()) continue;
      v1::RepairItem& item = *request.add_items();
      item.set_primitive(p.start.primitive());
      item.set_refinement(static_cast<uint32_t>(i));
      for (uint32_t k : p.tracks[i].missing) item.add_datagrams(k);
    }
  }
  if (request.items_size() == 0 || writes_done_) return false;
  repair_asked_ = true;
  repair_asked_us_ = now;
  outgoing_.push_back(std::move(o));
  return true;
}

// Decodes every primitive again from its base with what it kept and what
// the repair brought, through a fresh reconstructor (the same checks), and
// swaps it in.
Status SessionCore::DecodeAgain(uint64_t now) {
  for (PrimitiveState& p : primitives_) {
    const std::string where = Where(p.start.primitive());
    auto fresh = NewReconstructor(p.start);
    if (!fresh.ok()) return fresh.status();
    Status s = fresh->SetBase(p.kept_base);
    if (!s.ok()) return s.WithContext(where);
    for (size_t i = 0; i < p.tracks.size(); ++i) {
      const RefinementTrack& t = p.tracks[i];
      s = fresh->OnControl(Bytes(t.kept_control), t.kept_control.size(), now);
      if (!s.ok()) return s.WithContext(where);
      for (const std::string& d : t.kept_datagrams) fresh->OnDatagram(Bytes(d), d.size(), now);
      const std::vector<uint8_t> end = MakeStreamEndDatagram(Bytes(p.start.header()), p.start.header().size(),
                                                             p.start.primitive(), static_cast<uint32_t>(i), t.datagrams);
      fresh->OnDatagram(end.data(), end.size(), now);
      auto n = fresh->Poll(now);
      if (!n.ok()) return n.status().WithContext(where);
    }
    s = fresh->Flush();
    if (!s.ok()) return s.WithContext(where);
    *p.reconstructor = std::move(fresh).value();
  }
  ++decodes_again_;
  return Status::Ok();
}

void SessionCore::UpdateStats() {
  uint64_t accepted = 0, rejected = 0, duplicates = 0, late = 0, planned = 0, recovered = 0, again = 0;
  for (const PrimitiveState& p : primitives_) {
    planned += p.reconstructor->reader().recovery_stats().planned;
    const ReconstructorStats& r = p.reconstructor->stats();
    recovered += r.recovered;
    again += r.redecoded;
    rejected += p.reconstructor->parity_stats().rejected + p.reconstructor->parity_stats().inconsistent;
    accepted += r.accepted;
    rejected += r.rejected + r.overflow;
    duplicates += r.duplicates + r.late;
    late += r.late;
  }
  stats_.datagrams_late = late;
  stats_.datagrams_recovered = recovered;
  stats_.refinements_decoded_again = again;
  stats_.parallel_splits = planned;
  stats_.datagrams_received = accepted;
  if (udp_running_) {
    // A repeated packet number is a copy the network made (or a replay: the
    // two look alike); it counts with the duplicates, not as rejected.
    udp_replays_seen_ = udp_.replayed;
    udp_drops_seen_ = udp_.dropped - std::min(udp_.dropped, udp_.replayed);
    stats_.hellos_sent = udp_.hellos_sent;
    if (udp_.hello_rtt_us > 0) stats_.hello_rtt_ms = static_cast<double>(udp_.hello_rtt_us) / 1000.0;
  }
  stats_.datagrams_duplicate = duplicates + udp_replays_seen_;
  stats_.reorder_window_ms = LossRulesActive() ? static_cast<double>(ReorderWindowUs()) / 1000.0 : 0.0;
  stats_.datagrams_rejected = rejected + stray_rejected_ + udp_drops_seen_;
}

// A budget ran out: stop here with what arrived.
void SessionCore::CheckBudgets(uint64_t now) {
  const bool bytes_out =
      options_.byte_budget > 0 && stats_.reliable_bytes + stats_.unreliable_bytes >= options_.byte_budget;
  const bool time_out = options_.time_budget_ms > 0 && MsSinceOpen(now) >= static_cast<double>(options_.time_budget_ms);
  if (!bytes_out && !time_out) return;
  end_reason_ = bytes_out ? EndReason::kByteBudget : EndReason::kTimeBudget;
  session_end_us_ = now;
  phase_ = SessionPhase::kEnding;
  stats_.end_reason = bytes_out ? "byte_budget" : "time_budget";
  Finish(stats_.end_reason);
  Status st = Advance(now, true);
  if (!st.ok()) Fail(st);
}

// The stream has ended: once everything is decoded, or the stragglers had
// their time, the session completes, or with repair asks for what was lost.
// Late only once every arrival taken is handed over: a step that stopped at
// an event leaves the rest of its arrivals in the inbox (commit 186bb1d).
void SessionCore::Settle(uint64_t now) {
  // Refinements held for parity (ControlBlock.parity_follows) wait no
  // longer than the reordering window after the stream's end: every parity
  // datagram was sent before it, and what has not come by then is lost
  // (once every arrival taken is handed over, as for `late` below).
  if (!holds_released_ && handed_over() && StragglerClock(now) >= session_end_us_ + ReorderWindowUs()) {
    holds_released_ = true;
    for (PrimitiveState& p : primitives_) p.reconstructor->StopHolding();
    Status st = Advance(now, false);
    if (!st.ok()) return Fail(st);
  }
  const uint64_t window_us = 2 * static_cast<uint64_t>(options_.straggler_timeout_ms) * 1000;
  const bool late = handed_over() && StragglerClock(now) > session_end_us_ + window_us;
  const bool budget = end_reason_ == EndReason::kByteBudget || end_reason_ == EndReason::kTimeBudget;
  if (!AllDone() && !late && !budget) return;
  if (!AllDone()) {
    Status st = Advance(now, true);
    if (!st.ok()) return Fail(st);
  }
  stats_.time_to_full_ms = MsSinceOpen(now);
  stats_.last_arrival_ms = MsSinceOpen(last_arrival_us_);
  stats_.decode_after_last_byte_ms = std::max(0.0, stats_.time_to_full_ms - stats_.last_arrival_ms);
  // With repair: ask for what was lost, then wait for it.
  if (options_.repair && !budget && AskRepair(now)) {
    phase_ = SessionPhase::kRepairing;
    return;
  }
  Complete();
}

// The repair asked for: its RepairEnd (decode again), or the call's end or
// 10 s without it (the predicted mesh stays).
void SessionCore::AwaitRepair(uint64_t now) {
  if (repair_ended_) {
    Status st = DecodeAgain(now);
    if (!st.ok()) return Fail(st);
    stats_.time_to_exact_ms = MsSinceOpen(now);
    return Complete();
  }
  const bool call_over = stream_ended_ && inbox_messages_.empty();
  if (!call_over && now < repair_asked_us_ + kRepairWaitUs) return;
  stats_.repair_error = call_over ? "the server ended the session before the repair" : "no repair within 10 s";
  Complete();
}

void SessionCore::Complete() {
  UpdateStats();
  if (stats_.time_to_exact_ms == 0 && stats_.datagrams_lost == 0) stats_.time_to_exact_ms = stats_.time_to_full_ms;
  Finish("complete");
  StopUdp();
  phase_ = SessionPhase::kOver;
  Push(EventType::kComplete, level_shown_);
}

void SessionCore::CheckEnd(uint64_t now) {
  if (!events_.empty()) return;
  if (phase_ == SessionPhase::kStreaming) CheckBudgets(now);
  if (phase_ == SessionPhase::kEnding) Settle(now);
  if (phase_ == SessionPhase::kRepairing) AwaitRepair(now);
}

void SessionCore::HandleArrivals(uint64_t now) {
  if (phase_ == SessionPhase::kOver) return;
  // The arrivals of both channels in the order they arrived, each decided on
  // with its own arrival time (a busy host thread must not time a refinement
  // out while its datagrams wait here), until one makes an event: the rest
  // waits for the next step, so the views match the event.
  while (events_.empty() && !handed_over()) {
    const bool message = !inbox_messages_.empty() &&
                         (inbox_datagrams_.empty() || inbox_messages_.front().first <= inbox_datagrams_.front().at_us);
    uint64_t at;
    Status st;
    if (message) {
      at = inbox_messages_.front().first;
      const v1::ServerMessage m = std::move(inbox_messages_.front().second);
      inbox_messages_.pop_front();
      st = Handle(m, at);
    } else {
      const TakenDatagram d = std::move(inbox_datagrams_.front());
      inbox_datagrams_.pop_front();
      at = d.at_us;
      st = OfferDatagram(d.payload.data(), d.payload.size(), &d.packet_number, at);
    }
    if (!st.ok()) return Fail(st);
    last_arrival_us_ = std::max(last_arrival_us_, at);
    if (phase_ != SessionPhase::kOpening && events_.empty()) {
      // A gRPC arrival may be stamped after datagrams that wait unread in
      // the socket: the horizon bounds the clock.
      st = AdvanceTouched(StragglerClock(at));
      if (!st.ok()) return Fail(st);
    }
  }
  if (phase_ != SessionPhase::kOpening && phase_ != SessionPhase::kOver) {
    if (handed_over() && events_.empty()) {
      Status st = Advance(StragglerClock(now), false);
      if (!st.ok()) return Fail(st);
    }
    UpdateStats();
  }
  if (stream_ended_ && handed_over() && end_reason_ == EndReason::kNone && events_.empty()) {
    Fail(stream_status_.ok() ? Unavailable("the server ended the session before its end") : stream_status_);
  }
}

size_t SessionCore::primitive_count() const { return primitives_.size(); }

const StreamReader& SessionCore::reader(size_t primitive) const { return primitives_[primitive].reconstructor->reader(); }

const v1::PrimitiveStart& SessionCore::start(size_t primitive) const { return primitives_[primitive].start; }

uint64_t SessionCore::predicted_vertices() const {
  uint64_t n = 0;
  for (const PrimitiveState& p : primitives_) n += p.reconstructor->reader().inexact_positions();
  return n;
}

namespace {

// A spare of `spares` to overwrite, or a new one.
template <typename T>
std::shared_ptr<T> Spare(std::vector<std::shared_ptr<T>>* spares) {
  if (spares == nullptr || spares->empty()) return std::make_shared<T>();
  std::shared_ptr<T> t = std::move(spares->back());
  spares->pop_back();
  return t;
}

// Room for `n` in `v`, grown geometrically: a spare from a level before is
// smaller than the mesh it is to hold (the mesh grows every level).
template <typename T>
void Grow(std::vector<T>& v, size_t n) {
  if (v.capacity() < n) v.reserve(std::max(n, v.capacity() + v.capacity() / 2 + n / 4));
}

template <typename T>
void Retire(std::shared_ptr<const T>& old, std::vector<std::shared_ptr<const T>>* retired) {
  if (old && retired != nullptr) retired->push_back(std::move(old));
}

template <typename T>
void RecycleInto(std::vector<std::shared_ptr<const T>>& retired, std::vector<std::shared_ptr<T>>& spares) {
  for (size_t i = 0; i < retired.size();) {
    if (retired[i].use_count() == 1) {
      spares.push_back(std::const_pointer_cast<T>(std::move(retired[i])));
      retired[i] = std::move(retired.back());
      retired.pop_back();
    } else {
      ++i;
    }
  }
}

}  // namespace

void ViewBuffers::Recycle() {
  RecycleInto(retired_meshes, spare_meshes);
  RecycleInto(retired_bits, spare_bits);
}

void SessionCore::TakeView(SessionView& view, ViewBuffers* buffers) const {
  if (view.layout != layout_) view = SessionView{layout_, {}, 0, -1, 0};
  view.primitives.resize(primitives_.size());
  for (size_t i = 0; i < primitives_.size(); ++i) {
    const StreamReader& r = primitives_[i].reconstructor->reader();
    PrimitiveView& v = view.primitives[i];
    // A decode again (the repair's, or parity's within the reconstructor)
    // changes the mesh without a new level.
    const uint64_t version = (decodes_again_ << 44) + (primitives_[i].reconstructor->decodes_again() << 20) +
                             primitives_[i].reconstructor->applied();
    if (v.mesh && v.version == version) continue;
    std::shared_ptr<QuantizedMesh> mesh = Spare(buffers ? &buffers->spare_meshes : nullptr);
    const RefinementState& state = r.state();
    Grow(mesh->positions, state.positions.size());
    Grow(mesh->attributes, state.attributes.size());
    Grow(mesh->indices, 3 * state.connectivity.face_count());
    r.MeshInto(*mesh);
    std::shared_ptr<std::vector<uint8_t>> bits = Spare(buffers ? &buffers->spare_bits : nullptr);
    Grow(*bits, r.reliable().size());
    r.PositionExactInto(*bits);
    Retire(v.mesh, buffers ? &buffers->retired_meshes : nullptr);
    Retire(v.reliable, buffers ? &buffers->retired_bits : nullptr);
    v.mesh = std::move(mesh);
    v.reliable = std::move(bits);
    v.unreliable_vertices = r.inexact_positions();
    v.version = version;
  }
  view.levels = levels_;
  view.level_shown = level_shown_;
  view.predicted_vertices = 0;  // from the views' own counts: no second walk of every reader
  for (const PrimitiveView& v : view.primitives) view.predicted_vertices += v.unreliable_vertices;
}

Scene ViewScene(const SessionView& view) {
  if (!view.layout) return Scene{};
  const SessionLayout& layout = *view.layout;
  if (layout.has_scene) {
    // The asset's scene, its refined primitives at the level reached (the
    // material and everything else of the primitive as the scene has it).
    Scene scene = layout.scene;
    for (size_t i = 0; i < view.primitives.size() && i < layout.places.size(); ++i) {
      Primitive& slot = scene.meshes[layout.places[i].mesh].primitives[layout.places[i].scene_slot];
      const int32_t material = slot.material;
      slot = DequantizeMesh(*view.primitives[i].mesh, material);
    }
    return scene;
  }
  Scene scene;
  std::map<uint32_t, std::map<uint32_t, size_t>> by_mesh;  // glTF mesh -> primitive index -> ours
  for (size_t i = 0; i < view.primitives.size() && i < layout.places.size(); ++i) {
    by_mesh[layout.places[i].mesh][layout.places[i].mesh_primitive] = i;
  }
  SceneRoot root;
  for (const auto& [mesh_index, primitives] : by_mesh) {
    meshstream::Mesh mesh;
    mesh.name = "mesh " + std::to_string(mesh_index);
    for (const auto& [primitive_index, ours] : primitives) {
      mesh.primitives.push_back(DequantizeMesh(*view.primitives[ours].mesh, -1));
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

}  // namespace meshstream::sdk
