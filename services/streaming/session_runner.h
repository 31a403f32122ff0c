// One streaming session's sending side (docs/streaming-protocol.md,
// "Sessions"): walks the SessionPlan and hands every block to a SessionSink
// (the gRPC stream, written by services/api/stream_service.cc), and the data
// datagrams either to the sink (TRANSPORT_GRPC) or, sealed and paced, to the
// client's proven UDP address (services/streaming/udp_endpoint.h).
//
// UDP: the session registers with the endpoint, waits at most
// `hello_timeout` for the client to prove an address and otherwise falls
// back to gRPC (the sink's TransportChanged). Per refinement: the control
// block (with the first packet number of its datagrams), the data datagrams
// and the codec's END datagram paced at the session's rate (net/pacer.h,
// net/rate_controller.h, and the server's RateShare), then RefinementEnd.
// Reports from the client (OnReport, any thread) adapt the rate. The
// refinements of the reliable cut (session_plan.h, ReliableCutFor) go over
// UDP sessions as over gRPC ones: their datagrams on the stream. The cut is
// decided per refinement just before it is sent, for the loss the reports
// have shown (missing / (received + missing) over the UDP refinements once
// 32 datagrams have been reported; before, the loss the client said it
// expects, or the reference loss, which gives the stored cut).
//
// Contract: the plan and the artifact outlive the runner. Run returns the
// SessionEnd reason it sent ("complete", "max_level"), Aborted when
// `cancelled` said so or the sink refused a write (the client went away).
// Thread safety: Run on one thread; OnReport, OnClientMessage and stats from any.
#ifndef MESHSTREAM_SERVICES_STREAMING_SESSION_RUNNER_H_
#define MESHSTREAM_SERVICES_STREAMING_SESSION_RUNNER_H_

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "codec/core/status.h"
#include "net/pacer.h"
#include "net/rate_controller.h"
#include "services/streaming/session_plan.h"
#include "services/streaming/udp_endpoint.h"

namespace meshstream {

enum class SessionTransport { kUdp, kGrpc };

// What the runner writes on the reliable channel; false: the client is gone.
class SessionSink {
 public:
  virtual ~SessionSink() = default;
  // The session start; `udp` is null for TRANSPORT_GRPC.
  virtual bool Start(SessionTransport transport, const UdpEndpoint::Session* udp) = 0;
  virtual bool TransportChanged(SessionTransport transport, const std::string& reason) = 0;
  // `reliable`: the refinement's datagrams follow on this stream (always over
  // TRANSPORT_GRPC; over UDP for the refinements of the reliable cut).
  virtual bool Control(const PlannedRefinement& r, uint32_t stream, uint32_t datagrams, uint64_t first_packet_number,
                       bool reliable) = 0;
  virtual bool Datagram(const uint8_t* data, size_t size) = 0;  // datagrams on the stream
  virtual bool RefinementEnd(uint32_t stream, uint32_t refinement, uint32_t datagrams_sent) = 0;
  virtual bool End(const std::string& reason) = 0;
};

struct SessionRunnerOptions {
  bool want_udp = true;      // the client did not ask for gRPC
  UdpEndpoint* udp = nullptr;  // null: UDP is off on this server
  std::chrono::milliseconds hello_timeout{1000};
  RateControllerOptions rate;
  RateShare* server_share = nullptr;  // --max-rate; null: no server cap
  size_t burst_datagrams = 8;         // sent in one system call when due
  // Over UDP, send the refinements of the artifact's reliable cut, adapted to
  // the loss the client reports (ReliableCutFor), on the stream; false: every
  // datagram as UDP (the paper's scheme; --reliable-cut off).
  bool reliable_cut = true;
  // The loss the client expects (OpenRequest.expected_loss); < 0: unknown.
  double expected_loss = -1;
};

struct ClientReportInfo {
  uint32_t stream = 0;
  uint32_t refinement = 0;
  uint32_t received = 0;
  uint32_t missing = 0;
  bool end_received = false;  // the END datagram arrived ...
  uint64_t hold_us = 0;       // ... this long before the report left
  std::vector<uint64_t> rtt_samples_us;
};

struct SessionRunnerStats {
  SessionTransport transport = SessionTransport::kGrpc;
  uint64_t datagrams_sent = 0;      // data and END datagrams
  uint64_t bytes_sent = 0;          // their payloads
  uint64_t reports = 0;
  uint64_t reported_received = 0;
  uint64_t reported_missing = 0;
  double final_rate_bps = 0;
  uint32_t rate_decreases = 0;
  uint64_t min_rtt_us = 0, srtt_us = 0;
  uint32_t reliable_refinements = 0;  // sent on the stream over UDP (the reliable cut)
  uint64_t reliable_datagrams = 0;    // their data datagrams
  uint64_t reliable_bytes = 0;        // and bytes
  double cut_loss = 0;                // the loss the last cut decision was made for
};

class SessionRunner {
 public:
  SessionRunner(const SessionPlan& plan, const std::vector<uint8_t>& artifact, int32_t max_level,
                SessionRunnerOptions options);

  StatusOr<std::string> Run(SessionSink& sink, const std::function<bool()>& cancelled);
  void OnReport(const ClientReportInfo& report);
  SessionRunnerStats stats() const;

 private:
  bool SendRefinementUdp(const PlannedRefinement& r, uint32_t stream, SessionSink& sink,
                         const std::function<bool()>& cancelled);
  // `paced`: the datagrams wait for the session's pacer and the server's
  // share (WaitToSend), with this as the cancellation test; null: as fast as
  // the stream takes them (TRANSPORT_GRPC).
  bool SendRefinementGrpc(const PlannedRefinement& r, uint32_t stream, SessionSink& sink,
                          const std::function<bool()>* paced = nullptr);
  // Waits until `bytes` may leave at the session's rate and within the
  // server's share; false when `cancelled` said so meanwhile.
  bool WaitToSend(size_t bytes, const std::function<bool()>& cancelled);
  // Whether `r` goes on the stream over UDP: in the cut for the loss reported so far.
  bool InReliableCut(const PlannedRefinement& r);

  std::vector<uint8_t> EndDatagram(const PlannedRefinement& r, uint32_t stream, uint32_t count) const;
  const SessionPlan& plan_;
  const std::vector<uint8_t>& artifact_;
  int32_t max_level_;
  SessionRunnerOptions options_;
  std::shared_ptr<UdpEndpoint::Session> udp_;
  Pacer pacer_;  // the sending thread's

  mutable std::mutex mutex_;  // below
  RateController controller_;
  std::map<std::pair<uint32_t, uint32_t>, uint64_t> end_sent_us_;  // (stream, refinement) -> when its END left
  SessionRunnerStats stats_;
  uint64_t udp_reported_received_ = 0, udp_reported_missing_ = 0;  // over UDP refinements
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STREAMING_SESSION_RUNNER_H_
