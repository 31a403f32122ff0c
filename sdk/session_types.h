// The public types of an SDK streaming session: what a host asks for
// (SessionOptions), what Poll returns (Event), and what it counts
// (SessionStats). sdk/session.h (the Session, its threads and sockets) and
// sdk/session_core.h (the deterministic core that decides what the session
// does) both use them; neither includes the other. The behaviour they
// describe is sdk/session.h's header comment and
// docs/spec/streaming-protocol.md, "The client".
//
// Thread safety: plain values.
#ifndef MESHSTREAM_SDK_SESSION_TYPES_H_
#define MESHSTREAM_SDK_SESSION_TYPES_H_

#include <cstdint>
#include <optional>
#include <string>

#include "codec/core/status.h"
#include "codec/progressive/view_order.h"

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
  // What the viewer sees at the start (OpenRequest.view; codec/progressive/
  // view_order.h): the server sends first what spans the most pixels of it.
  // Session::SetView changes it during the session. Unset: the scene's order.
  std::optional<View> view;
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
  uint32_t level_plans = 0;          // LevelPlans the server sent (a view reordered the session)
  uint64_t parallel_splits = 0;     // splits decoded on the decode_threads (0 with one thread, or several streams)
  uint32_t parallel_streams = 0;    // streams the decode_threads decode at once (0: one stream, or one thread)
  // Parity (docs/design/loss-protection.md): datagrams_lost counts what the network
  // lost (the raw loss the reports tell the server); of those, parity rebuilt
  // datagrams_recovered locally, without asking again.
  uint64_t parity_datagrams = 0;       // parity datagrams received
  uint64_t parity_bytes = 0;           // their bytes
  uint64_t datagrams_recovered = 0;    // data datagrams parity rebuilt
  uint64_t refinements_decoded_again = 0;  // refinements decoded again because parity rebuilt a datagram late
};

}  // namespace meshstream::sdk

#endif  // MESHSTREAM_SDK_SESSION_TYPES_H_
