// The server's UDP half of the streaming sessions (docs/spec/streaming-protocol.md,
// "HELLO and address validation", "Receiving"): one socket, one receiving
// thread that answers HELLOs, and the table of live sessions.
//
// A session registers (RegisterSession) before its SessionStart is sent and
// gets its id and keys; its client's HELLOs then prove an address, and the
// session sends its DATA to that address only (SendData). Every datagram
// that fails a step of "Receiving" is dropped and counted, never answered.
// Towards an address that is not proven the endpoint sends only HELLO_ACKs,
// and never more bytes than it received from that address in authenticated
// HELLOs (net/amplification_limit.h).
//
// Contract: safe on any bytes arriving at the socket. A session accepts at
// most kMaxAddressesPerSession addresses (HELLOs from more are dropped and
// counted as addresses_refused). Memory: per session a fixed amount.
// Thread safety: every method, the endpoint's and a session handle's, may
// be called from any thread (the send loop calls every session's from its
// one thread; the HELLO hook runs on the endpoint's receiving thread).
#ifndef MESHSTREAM_SERVICES_STREAMING_UDP_ENDPOINT_H_
#define MESHSTREAM_SERVICES_STREAMING_UDP_ENDPOINT_H_

#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <shared_mutex>
#include <thread>
#include <unordered_map>
#include <vector>

#include "codec/core/status.h"
#include "net/amplification_limit.h"
#include "net/drop_reason.h"
#include "net/hello.h"
#include "net/packet_crypto.h"
#include "net/replay_window.h"
#include "net/udp_socket.h"
#include "services/streaming/payload_span.h"

namespace meshstream {

struct UdpEndpointStats {
  DropCounters received;          // every datagram that arrived, by what became of it
  uint64_t addresses_refused = 0; // authenticated HELLOs from one address too many
  uint64_t hello_acks_sent = 0;
  uint64_t data_sent = 0;         // DATA datagrams
  uint64_t data_bytes_sent = 0;
  uint64_t send_errors = 0;       // datagrams the kernel refused (buffer full)
  uint64_t send_calls = 0;        // sendmmsg calls for DATA (batches across sessions: DatagramOutbox)
  uint64_t send_retries = 0;      // flushes that left datagrams for later (the kernel's buffer was full)
};

class UdpEndpoint;

// Sealed DATA datagrams of the sessions of one endpoint, waiting to leave in
// one sendmmsg: the send loop seals what each session it steps has due
// (Session::SealData) and flushes once for all of them. Its buffers are
// reused, so that sealing allocates nothing per datagram once it has grown;
// at most kMaxPending wait (sealing more flushes first). Flush never waits:
// what the kernel does not take now stays for the next Flush (the caller
// retries and gives up with Drop, which counts the rest as send errors: the
// receiver predicts them).
// Thread safety: one thread at a time (the send loop's).
class DatagramOutbox {
 public:
  static constexpr size_t kMaxPending = 256;

  DatagramOutbox() = default;
  DatagramOutbox(const DatagramOutbox&) = delete;
  DatagramOutbox& operator=(const DatagramOutbox&) = delete;

  size_t pending() const { return end_ - first_; }
  // Sends what the kernel takes now, in order; returns how many are left.
  size_t Flush();
  // Forgets what is left, counted as send errors.
  void Drop();

 private:
  friend class UdpEndpoint;
  struct Slot {
    SocketAddress to;
    size_t size = 0;
    std::array<uint8_t, kMaxDatagramBytes> bytes;
  };
  UdpEndpoint* endpoint_ = nullptr;  // of every pending datagram
  std::vector<Slot> slots_;          // [first_, end_) pending; kept for reuse
  size_t first_ = 0, end_ = 0;
  std::vector<OutgoingDatagram> batch_;
};

class UdpEndpoint {
 public:
  static constexpr size_t kMaxAddressesPerSession = 4;

  class Session;

  static StatusOr<std::unique_ptr<UdpEndpoint>> Start(const SocketAddress& listen);
  ~UdpEndpoint();  // stops the thread; live sessions' sends fail from then on
  UdpEndpoint(const UdpEndpoint&) = delete;
  UdpEndpoint& operator=(const UdpEndpoint&) = delete;

  const SocketAddress& local() const { return socket_.local(); }
  // A new session with fresh keys and a random id; it stays in the table
  // until the handle is destroyed.
  StatusOr<std::shared_ptr<Session>> RegisterSession();
  UdpEndpointStats stats() const;
  size_t session_count() const;

 private:
  struct SessionState;
  explicit UdpEndpoint(UdpSocket socket) : socket_(std::move(socket)) {}
  void Run();
  void Handle(const IncomingDatagram& d);
  void Unregister(uint64_t id);

  UdpSocket socket_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
  mutable std::shared_mutex table_mutex_;
  std::unordered_map<uint64_t, std::shared_ptr<SessionState>> table_;
  mutable std::mutex stats_mutex_;
  UdpEndpointStats stats_;
  friend class Session;
  friend class DatagramOutbox;
};

class UdpEndpoint::Session {
 public:
  ~Session();
  uint64_t id() const;
  const SessionKeys& keys() const;
  bool proven() const;
  SocketAddress address() const;  // the proven address (empty before)
  // `count` consecutive packet numbers of this session's server->client
  // counter, for one refinement's DATA (the first is returned).
  uint64_t ReservePacketNumbers(uint64_t count);
  // Seals each payload as DATA with packet numbers first, first + 1, ...
  // into `out` (to the proven address), to leave with the next Flush.
  // FailedPrecondition before an address is proven.
  Status SealData(PayloadSpan payloads, uint64_t first_packet_number, DatagramOutbox* out);
  // SealData into an outbox of its own and one Flush, at once, without
  // waiting: what the kernel does not take counts as a send error.
  Status SendData(PayloadSpan payloads, uint64_t first_packet_number);
  // Microseconds (steady clock) when an authenticated HELLO last arrived.
  uint64_t last_hello_us() const;
  // Called on the endpoint's thread when an authenticated HELLO arrives and
  // when it proves an address (so a session waiting for its HELLO wakes at
  // once). It runs under the session's lock: it must only wake someone, not
  // call back into the session. Null: none. Never called after it is
  // replaced, nor after the handle is destroyed.
  void SetOnHello(std::function<void()> on_hello);

 private:
  friend class UdpEndpoint;
  Session(UdpEndpoint* endpoint, std::shared_ptr<SessionState> state) : endpoint_(endpoint), state_(std::move(state)) {}
  UdpEndpoint* endpoint_;
  std::shared_ptr<SessionState> state_;
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STREAMING_UDP_ENDPOINT_H_
