// The server's sending thread (docs/spec/streaming-protocol.md, "The server"):
// one thread drives every session's SessionSender (session_sender.h) by its
// next due time, from a timer heap, so that a session costs no thread of its
// own. It hands each session's actions to that session's SessionStream (the
// gRPC call, services/grpc/stream_service.cc, which queues them as
// ServerMessages) and its UDP DATA to the UDP endpoint (udp_endpoint.h):
// sealed into the thread's DatagramOutbox as each session is stepped and sent
// in one sendmmsg for every session of the pass, never waiting on a full
// kernel buffer (what it refuses is tried again every 200 us for 4 ms, then
// counted lost). The
// call's callbacks feed the client's messages in through the session's
// Registration, which also removes the session when it is destroyed (RAII).
//
// Back-pressure: a session whose stream holds `max_queued` unwritten
// messages (a client that reads nothing, a slow link) is not stepped until
// its stream reports a write (Registration::OnWritten); such sessions have
// no timer, and the thread looks at their idle deadlines once per 100 ms, so
// that a stalled client is cut off (kFinish DEADLINE_EXCEEDED) whatever the
// stream holds. After the SessionStart the
// session waits until the stream has written it before its HELLO wait starts.
// An authenticated HELLO wakes its session while the sender waits for one
// (SessionSender::awaiting_hello); once the wait is over the hook is cleared
// and the endpoint is no longer asked whether an address is proven.
// While `draining` is true every session is stopped (UNAVAILABLE, "draining")
// within the thread's 100 ms period.
//
// Contract: a SessionStream stays valid until its Registration is destroyed;
// the loop calls it only from its thread, with the session's mutex held, and
// calls Finish exactly once, last. The SendLoop outlives every Registration.
// Thread safety: Add and every Registration method from any thread.
#ifndef MESHSTREAM_SERVICES_STREAMING_SEND_LOOP_H_
#define MESHSTREAM_SERVICES_STREAMING_SEND_LOOP_H_

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <queue>
#include <string>
#include <thread>
#include <unordered_map>
#include <utility>
#include <vector>

#include "codec/core/status.h"
#include "services/streaming/session_sender.h"
#include "services/streaming/udp_endpoint.h"

namespace meshstream {

// A session's reliable channel, as the send loop sees it. Every method but
// queued() queues one message and never blocks.
class SessionStream {
 public:
  virtual ~SessionStream() = default;
  // `udp` is null for TRANSPORT_GRPC.
  virtual void Start(SessionTransport transport, const UdpEndpoint::Session* udp) = 0;
  virtual void TransportChanged(SessionTransport transport, const std::string& reason) = 0;
  // A kControl action: its refinement, stream id, count, first packet
  // number, and whether its datagrams follow on this stream (`reliable`,
  // `before_proof`).
  virtual void Control(const SenderAction& control) = 0;
  virtual void Datagram(const uint8_t* data, size_t size) = 0;
  virtual void RefinementEnd(uint32_t stream, uint32_t refinement, uint32_t datagrams_sent,
                             uint32_t parity_datagrams) = 0;
  virtual void End(const std::string& reason) = 0;
  virtual void RepairEnd(uint32_t datagrams, uint64_t bytes) = 0;
  // The refinements not begun were ordered by a view: `plan`'s level lists
  // from `first_changed_level` on (LevelPlan).
  virtual void Levels(const SessionPlan& plan, uint32_t first_changed_level) = 0;
  // The session is over: end the call with `status` once what is queued is
  // written (at once, dropping it, when `status` is not OK). `reason` and
  // `stats` are for the log.
  virtual void Finish(const Status& status, const std::string& reason, const SessionSenderStats& stats) = 0;
  // Messages queued and not yet written.
  virtual size_t queued() const = 0;
};

struct SendLoopOptions {
  size_t max_queued = 32;                        // unwritten messages per session before it waits
  const std::atomic<bool>* draining = nullptr;   // true: stop every session (UNAVAILABLE)
};

class SendLoop {
 public:
  class Registration;

  explicit SendLoop(SendLoopOptions options = {});
  ~SendLoop();  // stops the thread
  SendLoop(const SendLoop&) = delete;
  SendLoop& operator=(const SendLoop&) = delete;

  // Registers `sender`; it is driven from Registration::Begin on. Before
  // Begin the Registration's methods only feed the sender and a HELLO wakes
  // nothing: the loop never steps it, so it calls neither the stream nor
  // Finish, and the caller may still set the call up. Begin's step at once
  // takes up whatever they asked for. `udp` is the session's UDP
  // registration (null over gRPC), held until the session falls back to gRPC
  // or ends.
  Registration Add(std::unique_ptr<SessionSender> sender, SessionStream* stream,
                   std::shared_ptr<UdpEndpoint::Session> udp);

  size_t sessions() const;

 private:
  struct Entry;
  void Run();
  void Step(const std::shared_ptr<Entry>& entry);
  // Due at `due_us` (sooner wins); from any thread. Before Begin nothing
  // is scheduled (Begin steps the session at once).
  void Schedule(const std::shared_ptr<Entry>& entry, uint64_t due_us);
  void Begin(std::shared_ptr<Entry> entry);
  void Remove(Entry* entry);
  // Sends what the stepped sessions sealed (one sendmmsg for all of them);
  // what the kernel did not take is tried again after kRetryUs, then dropped.
  void FlushOutbox();

  SendLoopOptions options_;
  mutable std::mutex mutex_;  // below
  std::condition_variable wake_;
  struct Timer {
    uint64_t due_us;
    uint64_t seq;
    std::shared_ptr<Entry> entry;
    bool operator>(const Timer& o) const { return due_us != o.due_us ? due_us > o.due_us : seq > o.seq; }
  };
  std::priority_queue<Timer, std::vector<Timer>, std::greater<Timer>> timers_;
  uint64_t seq_ = 0;
  std::unordered_map<Entry*, std::shared_ptr<Entry>> entries_;
  bool stop_ = false;
  // The thread's own: UDP DATA sealed by the sessions of one pass, sent together.
  DatagramOutbox outbox_;
  uint64_t stuck_since_us_ = 0;  // the first flush that left datagrams (0: none left)
  uint64_t retry_at_us_ = 0;
  std::thread thread_;
};

// One session in the loop. Movable; destroying it removes the session (and
// its sender) after any step under way, so the stream is never called again.
class SendLoop::Registration {
 public:
  Registration() = default;
  Registration(Registration&& other) noexcept { *this = std::move(other); }
  Registration& operator=(Registration&& other) noexcept;
  ~Registration();
  explicit operator bool() const { return entry_ != nullptr; }

  // The session's first step, at once (once the caller holds the
  // registration and has set up what the stream needs). From then on the
  // session may finish at any moment: for a caller that the stream's Finish
  // lets go (a gRPC call deleted in OnDone), Begin is its last touch of the call.
  void Begin();

  // The client's messages, from the call's callbacks.
  void OnClientMessage();
  void OnReport(const ClientReportInfo& report);
  // The request is judged at once, on the caller's thread (SessionSender::OnRepair).
  void OnRepair(const std::vector<RepairItem>& items);
  // ClientMessage.view as FromProto read it: a bad one ends the session with its status.
  void OnView(const StatusOr<View>& view);
  void OnClientClosed(bool done);
  // The stream wrote a message: a session waiting for room goes on.
  void OnWritten();
  // Stop the session (the call was cancelled, a write failed).
  void Cancel(Status status, std::string reason);
  // Stop it as `draining` stops every session (UNAVAILABLE, "draining").
  void Drain();

 private:
  friend class SendLoop;
  Registration(SendLoop* loop, std::shared_ptr<Entry> entry) : loop_(loop), entry_(std::move(entry)) {}
  void Reset();
  SendLoop* loop_ = nullptr;
  std::shared_ptr<Entry> entry_;
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STREAMING_SEND_LOOP_H_
