// The client's session as a deterministic core (docs/spec/streaming-protocol.md,
// "The client"): what sdk::Session decides, without its threads, sockets or
// clock. The driver (session.cc) owns the gRPC stream's reader thread, the
// UDP receiver (udp_receiver.h), the real clock and the queues between them;
// it hands the core every arrival with its arrival time and the arrival
// horizon, calls it with `now`, and carries out what the core asks for. A
// test drives the same core with simulated arrivals and a simulated clock.
//
// Inputs (all times in microseconds of one non-decreasing clock):
//   - TakeMessage / TakeDatagram: the arrivals of the two channels, each in
//     its channel's order, stamped with when they arrived. They wait in the
//     core's inbox until HandleArrivals hands them over, oldest first
//     across both channels.
//   - SetArrivalHorizon: every datagram that reached the UDP socket before
//     this time has been taken (UdpReceiver::caught_up_us; without UDP the
//     driver's clock). Stragglers are timed out by min(time, horizon).
//   - TakeStreamEnd: the gRPC stream ended with this status (every message
//     it delivered was taken before).
//   - SetUdpCounters: the UDP receiver's counters (statistics, the RTT sample).
//   - CheckEnd(now), then HandleArrivals(now) unless an event is waiting: the
//     session moves on at `now`, through its phases (SessionPhase): opening ->
//     streaming -> ending (SessionEnd or a budget; the stragglers' window)
//     -> [repairing] -> over.
// Outputs:
//   - NextEvent: kBaseReady, kLevelReady, kComplete or kError, in order
//     (sdk/session.h); after kComplete or kError the core is over().
//   - TakeOutgoing: the ClientMessages to write on the stream, in order
//     (reports, the repair request, done), each with `half_close` after the
//     last (done), and for a report the END's arrival time, from which the
//     sender fills hold_us at the moment it writes it (StampHold).
//   - TakeUdpStart / TakeUdpStop: start the UDP half (SessionStart said
//     TRANSPORT_UDP: where and with which keys; the driver resolves the
//     host, and on failure calls Fail) or stop it (the server fell back to
//     gRPC, or the session is over).
//
// Contract: no threads, sockets, sleeps or clock reads; the same inputs give
// the same outputs. Every ServerMessage and datagram is untrusted input
// (sdk/session.h lists what a bad one does): nothing a server sends can make
// the core crash, hang, or hold more than its bounds (the reconstructors'
// buffers, the repair copies: 256 MiB). A Status from the core's inputs is
// never returned: it becomes the kError event.
// Thread safety: none; one thread (the driver's Poll) uses it.
#ifndef MESHSTREAM_SDK_SESSION_CORE_H_
#define MESHSTREAM_SDK_SESSION_CORE_H_

#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "codec/core/status.h"
#include "codec/loss/reconstructor.h"
#include "codec/mesh/mesh.h"
#include "codec/mesh/quantized_mesh.h"
#include "meshstream/v1/stream.pb.h"
#include "net/packet_crypto.h"
#include "parallel/fork_join_pool.h"
#include "sdk/loss_detector.h"
#include "sdk/session_types.h"

namespace meshstream::sdk {

// How the datagrams travel (SessionStart.transport, TransportChange).
enum class SessionTransport { kNone, kGrpc, kUdp };
// Where a session is: before SessionStart; streaming; the stream has ended
// (SessionEnd, or a budget ran out) and the stragglers have their window;
// the repair is asked for and awaited; over (kComplete or kError queued).
enum class SessionPhase { kOpening, kStreaming, kEnding, kRepairing, kOver };
// Why the session's stream ended: the server said so (SessionEnd, its reason
// in SessionStats::end_reason), or a budget of the client's ran out.
enum class EndReason { kNone, kServer, kByteBudget, kTimeBudget };

// The UDP half to start: the endpoint SessionStart names (an empty, 0.0.0.0
// or :: host means the gRPC server's host: the driver's business) and keys.
struct UdpStart {
  std::string host;
  uint16_t port = 0;
  uint64_t session_id = 0;
  SessionKeys keys;
};

struct UdpCounters {
  uint64_t dropped = 0;   // every drop of the receiver, replays included
  uint64_t replayed = 0;  // drops for a packet number seen before (copies)
  uint64_t hellos_sent = 0;
  uint64_t hello_rtt_us = 0;  // 0: no HELLO_ACK yet
};

struct Outgoing {
  v1::ClientMessage message;
  uint64_t end_time_us = 0;  // a report: when its END datagram arrived (0: never)
  bool half_close = false;   // WritesDone after this message
};

// Fills a report's hold_us: the time from its END datagram's arrival to
// `sent_at_us`, when it is written (0 without an END datagram).
void StampHold(Outgoing& o, uint64_t sent_at_us);

// OpenRequest.view and ClientMessage.view of a view (checked by the caller).
v1::View ViewProto(const View& view);
v1::ClientMessage ViewMessage(const View& view);

// What a host sees of the session at an event (sdk/session.h's views),
// taken from the core when the event is made (SessionCore::TakeView), so
// that the decoding goes on while the host reads the event's meshes. A
// primitive that did not change since the view before shares its arrays
// with it. Immutable once taken: any thread may read it.
struct PrimitiveView {
  std::shared_ptr<const QuantizedMesh> mesh;
  // Per vertex 1 where its position is the loss-free decode's, 0 where it
  // may differ (StreamReader::PositionExactInto).
  std::shared_ptr<const std::vector<uint8_t>> reliable;
  uint64_t unreliable_vertices = 0;  // vertices whose position may differ
  uint64_t version = 0;  // when taken: the refinements applied, and the decodes again (repair, parity's)
};
// What SessionStart fixed: where each primitive sits in the asset's glTF.
struct SessionLayout {
  struct Place {
    uint32_t mesh = 0;            // glTF mesh
    uint32_t mesh_primitive = 0;  // glTF primitive index (carried ones counted)
    size_t scene_slot = 0;        // index into the scene mesh's primitives (with a scene)
  };
  std::vector<Place> places;  // per primitive, in the session's order
  Scene scene;                // the asset's scene at level 0 (SessionStart.scene_glb), if has_scene
  bool has_scene = false;
};
struct SessionView {
  std::shared_ptr<const SessionLayout> layout;  // null before SessionStart
  std::vector<PrimitiveView> primitives;
  int32_t levels = 0;
  int32_t level_shown = -1;
  uint64_t predicted_vertices = 0;
};
// The arrays of views no longer shown, kept for the next views to reuse:
// a view per level would otherwise allocate (and fault in) every mesh anew.
// TakeView retires what it replaces and reuses the spares; Recycle moves
// the retired arrays nobody else holds to the spares. Call Recycle where the
// other holders' last reads are ordered before it (the driver: under the
// lock its Poll drops views under).
struct ViewBuffers {
  std::vector<std::shared_ptr<QuantizedMesh>> spare_meshes;
  std::vector<std::shared_ptr<std::vector<uint8_t>>> spare_bits;
  std::vector<std::shared_ptr<const QuantizedMesh>> retired_meshes;
  std::vector<std::shared_ptr<const std::vector<uint8_t>>> retired_bits;
  void Recycle();
};
// The asset's scene with every refined primitive as `view` shows it (from a
// server that sends no scene: one glTF mesh per mesh of the refined
// primitives, one node each, no materials).
Scene ViewScene(const SessionView& view);

class SessionCore {
 public:
  // `options` as Session::Open checked them; `opened_us`: when the session
  // was opened (time budget, time_to_*_ms).
  SessionCore(const SessionOptions& options, uint64_t opened_us);
  ~SessionCore();
  SessionCore(const SessionCore&) = delete;
  SessionCore& operator=(const SessionCore&) = delete;

  void TakeMessage(v1::ServerMessage m, uint64_t at_us);
  // A UDP DATA payload (the codec's datagram) and its packet number.
  void TakeDatagram(std::vector<uint8_t> payload, uint64_t packet_number, uint64_t at_us);
  void TakeStreamEnd(Status status);
  void SetArrivalHorizon(uint64_t us) { horizon_us_ = us; }
  void SetUdpCounters(const UdpCounters& c);

  // The session's end: a budget that ran out, every refinement decoded or
  // the stragglers' time over (late only once every arrival taken is
  // handed over), the repair asked for and awaited; kComplete when decided.
  void CheckEnd(uint64_t now_us);
  // Hands the taken arrivals over in arrival order until one makes an event
  // (the rest waits: the views match the event), then decodes what the
  // clock lets go; a stream that ended before SessionEnd is an error.
  void HandleArrivals(uint64_t now_us);
  // Ends the session with `status` (kError next; earlier events are dropped).
  void Fail(Status status);

  std::optional<Event> NextEvent();
  bool has_event() const { return !events_.empty(); }
  std::vector<Outgoing> TakeOutgoing();
  std::optional<UdpStart> TakeUdpStart();
  bool TakeUdpStop();

  // When a refinement becomes ready by the clock (loss declared by a later
  // datagram's arrival plus the reorder window), by the arrival horizon's
  // clock; SenderAction::kNever-like UINT64_MAX: nothing is waiting. The
  // driver wakes then rather than on a fixed period.
  uint64_t next_due_us() const;
  // Every arrival taken has been handed to the reconstructors.
  bool handed_over() const { return inbox_messages_.empty() && inbox_datagrams_.empty(); }
  bool over() const { return phase_ == SessionPhase::kOver; }
  SessionPhase phase() const { return phase_; }
  EndReason end_reason() const { return end_reason_; }
  bool repair_asked() const { return repair_asked_; }

  // The views (sdk/session.h): valid until the next call that moves the session.
  size_t primitive_count() const;
  const StreamReader& reader(size_t primitive) const;
  const v1::PrimitiveStart& start(size_t primitive) const;  // without base_mesh (not kept)
  int32_t levels() const { return levels_; }
  int32_t level_shown() const { return level_shown_; }
  uint64_t predicted_vertices() const;
  // Brings `view` to what the views show now: copies the meshes of the
  // primitives that changed since `view` was taken (all on a fresh one),
  // into `buffers`' spares where it has them (null: new arrays).
  void TakeView(SessionView& view, ViewBuffers* buffers = nullptr) const;
  // The statistics; the driver adds udp_local.
  const SessionStats& stats() const { return stats_; }
  SessionStats& mutable_stats() { return stats_; }

  // The repair's wait for RepairEnd, and the cap on the copies kept for it.
  static constexpr uint64_t kRepairWaitUs = 10000000;
  static constexpr uint64_t kMaxKeptBytes = uint64_t{256} << 20;

 private:
  struct RefinementTrack;
  struct PrimitiveState;
  struct TakenDatagram {
    std::vector<uint8_t> payload;
    uint64_t packet_number = 0;
    uint64_t at_us = 0;
  };

  uint64_t StragglerClock(uint64_t t) const { return std::min(t, horizon_us_); }
  double MsSinceOpen(uint64_t now_us) const;
  // Refinements of `p` applied at the scene's level `level` (PrimitiveStart.level_refinements).
  static uint32_t AppliedAt(const PrimitiveState& p, int32_t level);
  // The highest level every primitive has reached.
  int32_t LevelEverywhere() const;
  bool AllDone() const;
  void Finish(const std::string& reason);
  void StopUdp();
  void SetTransport(SessionTransport t);
  StatusOr<size_t> PrimitiveOf(uint32_t stream_id) const;
  Status Start(const v1::SessionStart& start, uint64_t now);
  StatusOr<StreamReconstructor> NewReconstructor(const v1::PrimitiveStart& p) const;
  static void NoteEnd(PrimitiveState& p, size_t refinement);
  Status GiveControls(PrimitiveState& p, uint64_t now, bool flushing);
  Status GiveAllControls(uint64_t now, bool flushing);
  // `reliable_over_udp`: a StreamDatagram of a UDP session (not a repair),
  // for the statistics.
  Status OfferDatagram(const uint8_t* data, size_t size, const uint64_t* packet_number, uint64_t now,
                       bool reliable_over_udp = false);
  // Loss detection by packet numbers (RFC 9002's rules on the receiver):
  // the window, a UDP datagram's effect on it, and the declarations.
  uint64_t ReorderWindowUs() const;
  bool LossRulesActive() const { return losses_.active(); }
  void NotePacketNumber(uint64_t packet_number, uint64_t at);
  // Calls f(p, refinement, track) for every UDP refinement of `primitives`
  // (primitives_, const or not) whose control block has come and that is not
  // decoded, declared lost, or on the stream; stops at the first error.
  template <typename Primitives, typename F>
  static Status ForOpenUdpRefinements(Primitives& primitives, F f);
  // Whether a UDP datagram numbered `packet_number` or above has come.
  bool SeenPacketNumber(uint64_t packet_number) const { return losses_.Seen(packet_number); }
  Status DeclareLosses(uint64_t clock);
  Status Declare(PrimitiveState& p, size_t refinement, uint64_t now);
  Status Handle(const v1::ServerMessage& m, uint64_t now);
  Status OnRefinementEnd(const v1::RefinementEnd& e, uint64_t now);
  Status OnLevelPlan(const v1::LevelPlan& plan);
  Status GiveEnd(PrimitiveState& p, uint32_t refinement, uint32_t datagrams, uint64_t now);
  void Report();
  Status Advance(uint64_t now, bool flush);
  Status AdvanceTouched(uint64_t now);
  void AnnounceLevel();
  bool AskRepair(uint64_t now);
  Status DecodeAgain(uint64_t now);
  void UpdateStats();
  void CheckBudgets(uint64_t now);
  void Settle(uint64_t now);
  void AwaitRepair(uint64_t now);
  void Complete();
  void Push(EventType type, int32_t level);

  SessionOptions options_;
  uint64_t opened_us_ = 0;
  std::deque<std::pair<uint64_t, v1::ServerMessage>> inbox_messages_;
  std::deque<TakenDatagram> inbox_datagrams_;
  uint64_t horizon_us_ = 0;
  bool stream_ended_ = false;
  Status stream_status_;
  UdpCounters udp_;
  bool udp_running_ = false;  // asked to start and not asked to stop

  std::vector<PrimitiveState> primitives_;
  std::shared_ptr<SessionLayout> layout_;  // made by Start
  uint64_t decodes_again_ = 0;  // DecodeAgain calls: a view's version of every primitive
  uint64_t last_arrival_us_ = 0;  // the latest arrival handed over (decode after the last byte)
  std::map<uint32_t, size_t> by_stream_;  // stream id -> index in primitives_
  int32_t levels_ = 0;
  int32_t level_shown_ = -1;  // -1: not even the base; the last level announced (kBaseReady: 0)
  SessionTransport transport_ = SessionTransport::kNone;
  EndReason end_reason_ = EndReason::kNone;
  uint64_t session_end_us_ = 0;
  bool holds_released_ = false;  // the reconstructors stopped holding for parity (Settle)
  bool writes_done_ = false;
  SessionPhase phase_ = SessionPhase::kOpening;
  bool rtt_reported_ = false;
  bool repair_asked_ = false;  // a RepairRequest went out (RepairEnd is expected)
  bool repair_ended_ = false;
  uint64_t repair_asked_us_ = 0;
  uint64_t kept_bytes_ = 0;
  ReconstructorOptions reconstructor_options_;
  std::unique_ptr<ForkJoinPool> decode_pool_;  // with decode_threads > 1 or -1
  bool across_streams_ = false;  // the pool decodes several streams at once (Advance)
  std::deque<Event> events_;
  std::vector<Outgoing> outgoing_;
  std::optional<UdpStart> udp_start_;
  bool udp_stop_ = false;
  SessionStats stats_;
  uint64_t udp_drops_seen_ = 0;
  uint64_t udp_replays_seen_ = 0;
  uint64_t stray_rejected_ = 0;  // datagrams no primitive's reconstructor could take
  LossDetector losses_;  // packet numbers and the reorder window (loss_detector.h)
  size_t touched_ = SIZE_MAX;    // the primitive the last arrival went to
};

}  // namespace meshstream::sdk

#endif  // MESHSTREAM_SDK_SESSION_CORE_H_
