// One streaming session's sending side as a deterministic core
// (docs/spec/streaming-protocol.md, "Sessions"): the plan, the client's messages
// and the caller's clock in, the next thing to do out. It reads no clock,
// sleeps nowhere, starts no thread and touches no socket, as net/pacer.h and
// net/rate_controller.h; services/streaming/send_loop.h drives it for real
// (one thread for every session, the gRPC stream, the UDP endpoint), and
// tests/services/session_sender_test.cc drives it with a scripted client and
// a fake clock.
//
// What Next(now_us) hands out, in order:
//   kStart             the SessionStart, with the transport (kUdp when the
//                      driver registered a UDP session and the client wants it);
//   kTransportChange   UDP only, when no HELLO proved an address: the HELLO
//                      wait lasts `hello_timeout` from the first Next after the
//                      start has been handed to the transport; an
//                      authenticated HELLO that has not proven an address yet
//                      (OnHello) extends it to `hello_timeout` after that
//                      HELLO, up to three timeouts in all. Looked at before
//                      each refinement; then every refinement goes on the stream;
//   per refinement in the plan's order: kControl; kDatagrams (its data
//                      datagrams and the codec's END datagram, in batches:
//                      over UDP paced at the session's rate (net/pacer.h,
//                      net/rate_controller.h) and charged to the server's
//                      RateShare, at most `burst_datagrams` per batch; on the
//                      stream unpaced (TRANSPORT_GRPC) or, over UDP for the
//                      refinements begun before an address was proven (no
//                      round trip is spent waiting: data moves from the start)
//                      and those of the reliable cut, paced one datagram at a
//                      time); kRefinementEnd;
//   kEnd               "complete", or "max_level" when the plan was cut;
//   after kEnd         with `repair`: up to kRepairWaitUs for OnRepair, then
//                      the named datagrams on the stream (kDatagrams) and
//                      kRepairEnd; then up to kLingerUs for the client to
//                      close its side (OnClientClosed);
//   kFinish            the call's status (OK, INVALID_ARGUMENT for a bad or
//                      unasked repair, the latter at once whatever the phase,
//                      DEADLINE_EXCEEDED when the client said
//                      nothing for `idle_timeout`, CANCELLED for `done`
//                      before the end or a client that did not close within
//                      the linger) and end_reason() for the log; last.
//   kWait              nothing until `due_us` (kNever: until an event).
// The cut is decided per refinement just before its control block, for the
// loss the reports have shown (missing / (received + missing) over the UDP
// refinements once 32 datagrams were reported; before, `expected_loss`, or
// the reference loss).
//
// Contract: the plan and the artifact outlive the sender; a kDatagrams
// action's span views the sender's own list of the refinement's payloads
// (or of the repair's), so it and the pointers in it stay valid until the
// next call (no copy per batch). Times are microseconds of
// one non-decreasing clock of the caller's. Reports are untrusted and only
// steer the rate and the cut (a report of a refinement never sent over UDP,
// or reported twice, counts in stats only).
// Thread safety: none; the driver serialises every call (send_loop.h holds a
// mutex per session).
#ifndef MESHSTREAM_SERVICES_STREAMING_SESSION_SENDER_H_
#define MESHSTREAM_SERVICES_STREAMING_SESSION_SENDER_H_

#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "codec/core/erasure_code.h"
#include "codec/core/status.h"
#include "codec/loss/parity_plan.h"
#include "net/pacer.h"
#include "net/rate_controller.h"
#include "services/streaming/payload_span.h"
#include "services/streaming/repair_request.h"
#include "services/streaming/session_plan.h"

namespace meshstream {

enum class SessionTransport { kUdp, kGrpc };

struct SessionSenderOptions {
  // kUdp: the driver registered a UDP session for it; kGrpc: the client asked
  // for TRANSPORT_GRPC or the server has no UDP.
  SessionTransport transport = SessionTransport::kGrpc;
  uint64_t hello_timeout_us = 1000000;
  // UDP: wait for the HELLO's proof (up to the HELLO wait, as above) before
  // the first refinement that would go as UDP, instead of sending the
  // refinements begun before it on the stream (--udp-wait-hello): every
  // refinement off the reliable cut then travels as UDP, with its parity,
  // at the price of one round trip before the first refinement.
  bool wait_for_hello = false;
  uint64_t idle_timeout_us = 30000000;  // no client message this long: kFinish DEADLINE_EXCEEDED; 0: never
  RateControllerOptions rate;
  RateShare* server_share = nullptr;  // --max-rate; null: no server cap. Thread-safe, shared.
  size_t burst_datagrams = 8;         // UDP datagrams handed out in one batch when due
  // Over UDP, send the refinements of the artifact's reliable cut, adapted to
  // the reported loss (ReliableCutFor), on the stream; false: every datagram
  // as UDP (the paper's scheme; --no-reliable-cut).
  bool reliable_cut = true;
  double expected_loss = -1;  // OpenRequest.expected_loss; < 0: unknown
  bool repair = false;        // OpenRequest.repair
  // UDP: `count` consecutive packet numbers of the session's server->client
  // counter, the first returned (UdpEndpoint::Session::ReservePacketNumbers;
  // a counter in tests). Unused over gRPC.
  std::function<uint64_t(uint64_t count)> reserve_packet_numbers;
  // Parity datagrams (docs/design/loss-protection.md) over UDP for the refinements
  // the artifact's delivery record protects, sized for the loss the reports
  // show (ParityLossFor); null: none (--no-parity).
  ErasureCode* erasure = nullptr;
  ParityPlanOptions parity_plan;
};

struct ClientReportInfo {
  uint32_t stream = 0;
  uint32_t refinement = 0;
  uint32_t received = 0;
  uint32_t missing = 0;
  bool end_received = false;  // the END datagram arrived ...
  uint64_t hold_us = 0;       // ... this long before the report left
  std::vector<uint64_t> rtt_samples_us;
  // The delivery rate the client saw: span_bytes over arrival_span_us (0:
  // none). Last, so that positional initialisers keep their meaning.
  uint64_t arrival_span_us = 0;
  uint64_t span_bytes = 0;
  uint32_t missing_runs = 0;  // runs of consecutive missing ordinals (bursts)
};

struct SessionSenderStats {
  SessionTransport transport = SessionTransport::kGrpc;
  uint64_t datagrams_sent = 0;      // data and END datagrams of the refinements
  uint64_t bytes_sent = 0;          // the payloads of those sent as UDP
  uint64_t reports = 0;
  uint64_t reported_received = 0;
  uint64_t reported_missing = 0;
  double final_rate_bps = 0;
  uint32_t rate_decreases = 0;
  uint64_t min_rtt_us = 0, srtt_us = 0;
  uint32_t early_refinements = 0;     // sent on the stream over UDP before an address was proven (not of the cut)
  uint64_t early_bytes = 0;           // their data datagrams' bytes
  uint32_t reliable_refinements = 0;  // sent on the stream over UDP (the reliable cut)
  uint64_t reliable_datagrams = 0;    // their data datagrams
  uint64_t reliable_bytes = 0;        // and bytes
  double cut_loss = 0;                // the loss the last cut decision was made for
  uint64_t repaired = 0;              // datagrams sent again for a RepairRequest
  uint64_t repaired_bytes = 0;
  uint32_t parity_blocks = 0;         // blocks closed with at least one parity row
  uint64_t parity_datagrams = 0;      // parity datagrams sent (UDP)
  uint64_t parity_bytes = 0;          // and bytes
  double parity_loss = 0;             // the loss the last block was sized for ...
  double parity_burst = 0;            // ... and the mean loss run (0: independent)
};

// The loss the reports show (missing / (received + missing) over the UDP
// refinements) once kMinReportedForCut datagrams were reported; before,
// `expected_loss` when the client stated one (>= 0), else the reference loss.
// What the reliable cut is sized for.
double ReportedLoss(uint64_t received, uint64_t missing, double expected_loss);

// The loss a sender sizes parity for, from what the client reported over
// UDP (received and missing data datagrams, the runs the missing ones
// form): an upper bound (one-sided 95 %) of the raw loss rate once
// kMinReportedForCut datagrams were reported, 0 when they show no loss.
// Before: `expected_loss` when the client stated one above 0, else none
// until a report shows a loss, then at least the reference loss. So a
// client that states nothing and loses nothing gets no parity at all.
// `burst` gets the mean loss run (0 when runs were not seen).
double ParityLossFor(uint64_t received, uint64_t missing, uint64_t runs, double expected_loss, double* burst);

struct SenderAction {
  enum Kind {
    kWait,
    kStart,
    kTransportChange,
    kControl,
    kDatagrams,
    kRefinementEnd,
    kEnd,
    kRepairEnd,
    kFinish,
    kLevels,
  };
  static constexpr uint64_t kNever = std::numeric_limits<uint64_t>::max();

  Kind kind = kWait;
  uint64_t due_us = kNever;       // kWait
  SessionTransport transport = SessionTransport::kGrpc;  // kStart, kTransportChange
  std::string reason;             // kTransportChange, kEnd
  const PlannedRefinement* refinement = nullptr;  // kControl, kRefinementEnd
  uint32_t stream = 0;            // kControl, kRefinementEnd: the wire stream id
  uint32_t count = 0;             // kControl, kRefinementEnd: data datagrams; kRepairEnd: datagrams
  uint32_t parity = 0;            // kRefinementEnd: parity datagrams sent over UDP after its END
  uint64_t bytes = 0;             // kRepairEnd
  uint64_t first_packet_number = 0;  // kControl, kDatagrams as UDP
  bool reliable = false;          // kControl: the datagrams follow on the stream
  bool before_proof = false;      // kControl, UDP: ... because no address was proven yet
  bool parity_follows = false;    // kControl, UDP: parity datagrams covering the refinement follow
  bool on_stream = true;          // kDatagrams: as StreamDatagrams (false: sealed UDP DATA)
  PayloadSpan datagrams;          // kDatagrams: valid until the next call (above)
  Status status;                  // kFinish
  uint32_t first_changed_level = 0;  // kLevels: the plan (SessionSender::plan()) was ordered by a view
};

class SessionSender {
 public:
  static constexpr uint64_t kRepairWaitUs = 10000000;  // after SessionEnd, for the RepairRequest
  static constexpr uint64_t kLingerUs = 2000000;       // then for the client to close its side
  static constexpr uint64_t kMinReportedForCut = 32;   // datagrams reported before the loss steers the cut
  static constexpr uint64_t kMinViewIntervalUs = 1000000;  // views acted on at most this often

  // `max_level` as OpenRequest.max_level (>= 0: the plan was cut there).
  // `now_us`: the session's start, the first moment the idle timeout counts from.
  SessionSender(const SessionPlan& plan, const std::vector<uint8_t>& artifact, int32_t max_level,
                SessionSenderOptions options, uint64_t now_us);

  SenderAction Next(uint64_t now_us);

  // Any client message (report, repair, done) at now_us: the idle timeout
  // counts from the last one.
  void OnClientMessage(uint64_t now_us);
  void OnReport(uint64_t now_us, const ClientReportInfo& report);
  // The one RepairRequest of the session (the driver reads nothing after
  // it), judged here, on the caller's thread (RepairDatagrams against the
  // plan): only the byte ranges it names, or its refusal, are kept for Next.
  void OnRepair(uint64_t now_us, const std::vector<RepairItem>& items);
  // The client closed its side: `done` (ClientMessage.done) or a half-close.
  // `done` before the end stops the session (CANCELLED, "client done").
  void OnClientClosed(uint64_t now_us, bool done);
  // UDP: the time of the last authenticated HELLO (the endpoint's clock,
  // the same as now_us) and whether an address is proven. Read only while
  // awaiting_hello().
  void OnHello(uint64_t last_hello_us, bool proven);
  // The client's view changed (ClientMessage.view, checked): before the
  // next refinement begins, the ones not begun are ordered by it
  // (codec/progressive/view_order.h) and Next hands out kLevels (the
  // driver sends plan()'s LevelPlan). At most one view per kMinViewIntervalUs
  // is acted on; a newer one replaces a waiting one. Ignored when the plan
  // lacks what a view orders by (ViewCanOrder) or every refinement has begun.
  void OnView(uint64_t now_us, const View& view);
  // The plan being sent: the one given, or its reordering by a view.
  const SessionPlan& plan() const { return *plan_; }
  // The driver stops the session: the next Next is kFinish with `status`
  // and `reason` (e.g. Cancelled / "client went away", Unavailable / "draining").
  void Cancel(Status status, std::string reason);

  // True once kFinish was handed out.
  bool finished() const { return phase_ == Phase::kFinished; }
  // True when the next Next is kFinish whatever the stream can take (a
  // Cancel, or the idle timeout ran out at now_us).
  bool stopping(uint64_t now_us) const { return cancelled_ || now_us >= idle_deadline_us(); }
  // When the idle timeout runs out (kNever: none); the driver wakes then
  // even while the stream cannot take more.
  uint64_t idle_deadline_us() const;
  SessionTransport transport() const { return transport_; }
  // UDP, until the HELLO wait is over (an address proven, or the fallback to
  // gRPC): after, HELLOs change nothing and the driver need not feed OnHello.
  bool awaiting_hello() const {
    return transport_ == SessionTransport::kUdp && !proven_ &&
           (phase_ == Phase::kStart || phase_ == Phase::kRefinements);
  }
  const std::string& end_reason() const { return end_reason_; }
  SessionSenderStats stats() const;

 private:
  enum class Phase { kStart, kRefinements, kAwaitRepair, kRepairing, kLinger, kFinished };
  enum class Step { kControl, kDatagrams, kRefinementEnd };

  SenderAction Finish(Status status, std::string reason);
  // UDP before a proof: whether the HELLO wait has run out at now_us.
  bool HelloWaitOver(uint64_t now_us);
  SenderAction NextRefinementStep(uint64_t now_us);
  SenderAction AfterEnd(uint64_t now_us);
  bool InReliableCut(const PlannedRefinement& r);
  // Parity: refinement `r` goes over UDP with these payloads; the open block
  // of its primitive closes first when `r` cannot join it, and after it when
  // `r` is the primitive's last protected refinement of the plan.
  bool JoinParityBlock(const PlannedRefinement& r);  // whether r joined a block
  double ParityLossNow(double* burst) const;          // ParityLossFor this session's reports so far
  void CloseParityBlock(uint32_t primitive);
  // The next batch of the current refinement: due now or kWait.
  SenderAction NextBatch(uint64_t now_us);

  // Orders the refinements from index_ on by pending_view_ (OrderByView; a copy of the
  // plan the first time); returns the first level that changed (0: none).
  uint32_t ApplyView(uint64_t now_us);
  // Where each primitive's last protected refinement lies in the plan.
  void FindLastProtected();

  const SessionPlan* plan_;
  std::unique_ptr<SessionPlan> own_plan_;  // after a view: the reordered plan
  std::optional<View> pending_view_;
  std::optional<uint64_t> view_applied_us_;  // when the last view was acted on
  const std::vector<uint8_t>& artifact_;
  int32_t max_level_;
  SessionSenderOptions options_;
  SessionTransport transport_;
  Pacer pacer_;
  RateController controller_;
  SessionSenderStats stats_;
  uint64_t udp_reported_received_ = 0, udp_reported_missing_ = 0;  // over UDP refinements
  std::map<std::pair<uint32_t, uint32_t>, uint64_t> end_sent_us_;  // (stream, refinement) -> when its END left

  Phase phase_ = Phase::kStart;
  uint64_t last_heard_us_;
  // The HELLO wait.
  bool hello_started_ = false;
  uint64_t hello_registered_us_ = 0, hello_deadline_us_ = 0, hello_last_deadline_us_ = 0;
  uint64_t last_hello_us_ = 0;
  bool proven_ = false;
  // The refinement being sent.
  size_t index_ = 0;
  Step step_ = Step::kControl;
  enum class Mode { kUdp, kStreamPaced, kStream } mode_ = Mode::kStream;
  std::vector<DatagramPayload> payloads_;  // data datagrams, the END, then parity due; kDatagrams views it
  std::vector<uint8_t> end_datagram_;
  size_t next_payload_ = 0;
  uint64_t first_packet_number_ = 0;
  uint64_t batch_due_us_ = 0;  // the pending batch's due time, once reserved
  bool batch_reserved_ = false;
  size_t batch_size_ = 0;
  // After the end.
  uint64_t ended_us_ = 0;
  bool client_closed_ = false;
  bool client_done_ = false;
  bool repair_received_ = false;
  Status repair_status_;                // the request's refusal (not OK), or OK
  // Parity: per primitive its tiers (protection.h) and open block, the
  // index of its last protected refinement in the plan, and the parity
  // datagrams made and not yet sent (they follow the next UDP refinement's
  // END, or go out after the last refinement).
  struct OpenBlock {
    uint8_t tier = 0;
    uint32_t first_refinement = 0;
    std::vector<ByteRange> members;
  };
  std::vector<std::vector<uint8_t>> tiers_;
  std::vector<OpenBlock> open_blocks_;
  std::vector<size_t> last_protected_;
  std::vector<std::vector<uint8_t>> parity_due_;   // made, waiting for a UDP refinement
  std::vector<std::vector<uint8_t>> parity_sent_;  // in payloads_ now (kept until the refinement is over)
  uint64_t udp_reported_runs_ = 0;
  bool trailing_parity_ = false;  // payloads_ holds the parity sent after the last refinement
  std::vector<DatagramPayload> repair_payloads_;  // the datagrams it names, each once; kDatagrams views it
  size_t repair_next_ = 0;
  // Cancel.
  bool cancelled_ = false;
  Status cancel_status_;
  std::string end_reason_;
};

// The session's log line after "ended (reason): ": transport, datagrams,
// reports, missing, the final rate, decreases, srtt, the refinements sent
// reliably (bytes, the loss the cut was sized for) and the datagrams repaired.
std::string DescribeSession(const SessionSenderStats& stats);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STREAMING_SESSION_SENDER_H_
