// A streaming session of the SDK: opens StreamService.Open for an asset
// version, and refines the mesh as the session's blocks arrive
// (docs/spec/streaming-protocol.md). Poll model: the host calls Poll on its own
// thread and gets events; no callback ever runs on an internal thread.
//
// Events, in order: kBaseReady (every primitive's base mesh decoded), then
// kLevelReady with the level every primitive has reached (or all it has),
// increasing (levels completed before the host polls come as one event for
// the highest), then kComplete; or kError with the status, after which the
// session is over. At each event the meshes are at the event's level (the
// decoding goes on meanwhile; the next event shows what it did).
//
// Transport: UDP unless tcp_only (or the server has UDP off, or no HELLO
// got through: the server then says so and the datagrams come over gRPC).
// Over UDP what the network loses is predicted (codec/loss), never asked
// for again; a refinement is decoded when its END (the datagram or its
// reliable copy, RefinementEnd) and every datagram it announces have
// arrived, or `straggler_timeout_ms` after the first of its ENDs arrived,
// counted on the arrival horizon (UdpReceiver::caught_up_us), so a host
// that polls seldom or starves the UDP thread never loses what arrived
// (docs/spec/streaming-protocol.md).
//
// Budgets: max_level stops the server early; byte_budget (bytes received
// on both channels) and time_budget_ms (since Open) stop the session on the
// client's side: it tells the server it is done, decodes what arrived, and
// Poll returns kComplete at the level reached.
//
// Untrusted input: everything the server sends (every ServerMessage, every
// StreamDatagram and UDP payload) is checked before it is used, and no
// bytes from it can make the client crash, hang or hold more than its
// bounds (64 MiB of datagrams buffered per primitive, 65,536 UDP datagrams
// queued, 256 MiB of copies kept for a repair). A bad one either ends the
// session (Poll returns kError with the status; kInvalidInput unless named):
//   - SessionStart: a second one; a primitive announced twice; a stream
//     header that does not parse (kUnsupported for an unknown version);
//     more refinements than its header has; a base mesh that does not
//     decode, no POSITION or a malformed TEXCOORD_n attribute name; a
//     scene_glb that does not import or lacks a refined primitive's mesh;
//     with TRANSPORT_UDP, keys that are not 32 bytes or a port outside
//     1..65535 (an endpoint that does not resolve: its own status);
//   - ControlBlock: an unknown primitive, a refinement outside the session,
//     a second block for a refinement, more datagrams than two per split,
//     or split bits the decoder refuses;
//   - RefinementEnd: an unknown primitive or a refinement outside the session;
//   - RepairEnd without a repair asked for;
//   - a refinement that fails to decode (FinishRefinement);
//   - the call ending before SessionEnd: its status (kUnavailable if OK);
// or is dropped and counted in SessionStats:
//   - a datagram (on UDP or as a StreamDatagram) that does not parse, names
//     a stream not in the session, does not fit its stream (kind, refinement,
//     ordinals), announces in its END more than two datagrams per split,
//     arrives before SessionStart, or does not fit the buffers:
//     datagrams_rejected (with the UDP receiver's drops: unauthenticated,
//     wrong session, malformed packets);
//   - copies, replays and datagrams of refinements already decoded:
//     datagrams_duplicate;
// or is ignored: a ServerMessage of a kind this client does not know, a
// TransportChange to anything but TRANSPORT_GRPC, a SessionEnd after the
// first (the stragglers' window counts from the first) or after a budget
// ran out, a second RepairEnd. (sdk/session_core.h is where it is decided;
// tests/sdk/ and tests/fuzz/fuzz_sdk_session.cc check it.)
//
// Thread safety and ownership: a Session is used from one thread (Poll, the
// mesh accessors); Cancel may also be called from another thread. Mesh
// views stay valid until the next Poll. The Client must outlive the
// session. Internally one thread reads the gRPC stream and one the UDP
// socket, each into a queue, and the session's own thread decodes as the
// data arrives, in a deterministic core (sdk/session_core.h) that it hands
// every arrival with its arrival time, and the clock: a host that polls
// seldom, or spends its frame elsewhere, never holds the decoding back. At
// each event that thread takes the views (each primitive's mesh as the
// event shows it: a copy of what changed since the last event); Poll only
// hands over the events and their views, and stats() as of the last Poll.
#ifndef MESHSTREAM_SDK_SESSION_H_
#define MESHSTREAM_SDK_SESSION_H_

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "codec/core/status.h"
#include "codec/mesh/mesh.h"
#include "sdk/client.h"

namespace meshstream::sdk {

struct SessionOptions {
  std::string asset;
  int64_t version = 0;    // 0: the latest READY version
  int32_t max_level = -1; // the scene's level to stop at (docs/spec/streaming-protocol.md, "Levels of a scene"); -1: all
  bool tcp_only = false;  // ask for the datagrams over gRPC
  uint64_t byte_budget = 0;       // 0: none
  int64_t time_budget_ms = 0;     // 0: none
  // After a refinement's END, at most: reordering and jitter. A UDP refinement
  // is decoded sooner once later datagrams show that what is missing is lost
  // (three later packet numbers, or an eighth of the HELLO round trip after a
  // later one arrived).
  int32_t straggler_timeout_ms = 50;
  // "HOST:PORT": send the HELLO (so the whole UDP half) there instead of the
  // endpoint the server advertises: a relay that shapes the link, a tunnel,
  // debugging. Empty: the advertised endpoint.
  std::string udp_via;
  // Once the stream has ended, ask over the gRPC stream, once, for the data
  // datagrams that were lost and decode again with them: the final mesh is
  // then the exact one (the one a loss-free session gives). The last
  // kLevelReady shows the predicted mesh at once; kComplete comes after the
  // repair, with the exact mesh. Off by default (the paper's scheme never
  // asks again). Keeps a copy of the stream's control blocks and datagrams
  // until the session ends. Not with a byte or time budget (nothing to repair
  // towards: the session stops early by choice).
  bool repair = false;
  // The loss rate this client expects on its UDP path, in [0, 1] (e.g. the
  // last session's datagrams_lost / (datagrams_lost + datagrams_received)):
  // the server moves more of the stream to the reliable channel the higher
  // it is, until this session's reports show the real rate. < 0: the loss
  // the client's last session saw (Client::remembered_loss), or unknown
  // before any (the server then sizes its cut for the rate the artifact's
  // cut was made for, 12 %, and sends no parity until a loss is reported).
  double expected_loss = -1;
  // No parity datagrams for this session (docs/design/loss-protection.md): what UDP
  // loses is predicted (or repaired with `repair`), never rebuilt; the
  // stream is smaller by the parity's bytes. Off by default: the server
  // sizes parity by the loss this session reports, none while it reports
  // none.
  bool no_parity = false;
  // Threads that decode a refinement whose datagrams all arrived (the
  // output is the same bit for bit; docs/results/decode-profile.md): 0 or 1 the
  // session's own thread (the default: a host that runs its own threads
  // keeps the cores), N > 1 a pool of N started with the session, -1 one
  // per core; at most 64.
  int32_t decode_threads = 1;
  // The profile to stream (OpenRequest.profile; docs/spec/streaming-protocol.md,
  // "Profiles"): kAuto lets the server choose (the reliable profile over the
  // stream alone, the loss-tolerant one over UDP); kReliable asks for the
  // reliable one (the session is then TRANSPORT_GRPC: it has no datagrams);
  // kLossTolerant for the loss-tolerant one over any transport.
  enum class Profile { kAuto = 0, kReliable = 1, kLossTolerant = 2 };
  Profile profile = Profile::kAuto;
};

enum class EventType { kNone = 0, kBaseReady, kLevelReady, kComplete, kError };

struct Event {
  EventType type = EventType::kNone;
  int32_t level = 0;  // kBaseReady: 0; kLevelReady: the level now shown everywhere
  Status status;      // kError: why
};

struct SessionStats {
  uint64_t reliable_bytes = 0;      // headers, base meshes, control blocks
  uint64_t unreliable_bytes = 0;    // datagram payloads
  uint64_t datagrams_received = 0;  // data datagrams that brought something new
  uint64_t udp_datagrams_received = 0;  // data datagrams that came as UDP (the rest of them came on the stream)
  uint64_t datagrams_lost = 0;      // data datagrams sent and never received (predicted instead)
  uint64_t datagrams_rejected = 0;  // malformed, forged, replayed, or not fitting their stream
  uint64_t datagrams_duplicate = 0; // copies (a packet number seen before), and datagrams of refinements already decoded
  uint64_t hellos_sent = 0;
  double hello_rtt_ms = 0;
  std::string fallback_reason;      // why the session left UDP, if it did
  double time_to_base_ms = 0;
  double time_to_full_ms = 0;
  std::string transport;            // "grpc" or "udp"
  std::string profile;              // "reliable" or "loss-tolerant" (SessionStart.profile; empty before the start)
  std::string end_reason;           // the server's SessionEnd reason, or "byte_budget" / "time_budget"
  std::string udp_local;            // the client's UDP socket ("0.0.0.0:PORT"), empty without UDP
  uint32_t reliable_refinements = 0;  // refinements whose datagrams came on the gRPC stream over UDP (the reliable cut)
  uint64_t reliable_datagram_bytes = 0;
  uint32_t early_refinements = 0;   // ... on the stream because no UDP address was proven yet (no wait for the HELLO)
  uint64_t early_datagram_bytes = 0;
  uint64_t repaired_datagrams = 0;  // datagrams the repair brought
  uint64_t repair_bytes = 0;        // their bytes
  double time_to_exact_ms = 0;      // from open to the exact mesh: time_to_full_ms without loss, after the repair with it
  std::string repair_error;         // why a repair asked for did not complete (the predicted mesh stays)
  // Loss detection by packet numbers (docs/spec/streaming-protocol.md, "The client"):
  uint32_t losses_declared = 0;     // UDP refinements decoded incomplete because later datagrams had arrived
  uint32_t losses_spurious = 0;     // ... of which a datagram declared lost came after all (reordering)
  uint64_t datagrams_late = 0;      // UDP data datagrams that came after their refinement was decoded without
                                    // them (in datagrams_lost and datagrams_duplicate too: their vertices stay predicted)
  double reorder_window_ms = 0;     // the wait after a later datagram, as it ended (0: no RTT sample, straggler_timeout_ms)
  // Where the time to full went (docs/spec/streaming-protocol.md, "The client"):
  double last_arrival_ms = 0;       // from open to the last arrival before the full mesh (either channel)
  double decode_after_last_byte_ms = 0;  // time_to_full_ms - last_arrival_ms: the decoding left after it
  double session_thread_cpu_ms = 0; // CPU of the SDK's session thread so far (decoding, the protocol)
  uint64_t parallel_splits = 0;     // splits decoded on the decode_threads (0 with one thread)
  // Parity (docs/design/loss-protection.md): datagrams_lost counts what the network
  // lost (the raw loss the reports tell the server); of those, parity rebuilt
  // datagrams_recovered locally, without asking again.
  uint64_t parity_datagrams = 0;       // parity datagrams received
  uint64_t parity_bytes = 0;           // their bytes
  uint64_t datagrams_recovered = 0;    // data datagrams parity rebuilt
  uint64_t refinements_decoded_again = 0;  // refinements decoded again because parity rebuilt a datagram late
};

class Session {
 public:
  static StatusOr<std::unique_ptr<Session>> Open(const Client& client, const SessionOptions& options);
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  // Processes what arrived, waiting at most `timeout_ms` for something, and
  // returns the next event (kNone when the time ran out first).
  Event Poll(int32_t timeout_ms);
  // Stops the session (the server frees it); Poll then returns kError
  // (cancelled) once.
  void Cancel();

  size_t primitive_count() const;
  // The current mesh of a primitive (dequantized), and per vertex 1 where
  // its position may differ from the loss-free decode: predicted, or placed
  // relative to a predicted position (StreamReader::PositionExactInto; not
  // the decoder's reliability bits, which also mark every vertex whose ring
  // a prediction touched). All 0 when nothing was lost or parity rebuilt it.
  StatusOr<Primitive> Mesh(size_t primitive) const;
  StatusOr<std::vector<uint8_t>> Predicted(size_t primitive) const;
  // Where the primitive sits in the asset's glTF (mesh, primitive index).
  std::pair<uint32_t, uint32_t> GltfPosition(size_t primitive) const;
  int32_t levels() const;  // the most refinements any primitive has in this session
  // The level every primitive has reached (-1 before kBaseReady).
  int32_t level_shown() const;
  // Vertices, over all primitives, whose position may differ from the loss-free decode.
  uint64_t predicted_vertices() const;
  // The asset's scene (nodes, materials, textures, animations, carried
  // primitives: SessionStart.scene_glb) with every refined primitive at the
  // level reached. From a server that sends no scene: one glTF mesh per
  // mesh of the refined primitives, one node each, no materials.
  Scene CurrentScene() const;
  // CurrentScene written as .glb or .gltf (by the extension), through importers/.
  Status Export(const std::string& path) const;
  const SessionStats& stats() const;

 private:
  struct Impl;
  explicit Session(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace meshstream::sdk

#endif  // MESHSTREAM_SDK_SESSION_H_
