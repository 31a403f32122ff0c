// The client's UDP half of a session (docs/spec/streaming-protocol.md, "HELLO and
// address validation", "Receiving"): one socket and one thread that proves
// the socket's address to the server and hands every authenticated DATA
// payload on.
//
// HELLO (zero echo) at once and every kHelloIntervalMs until a HELLO_ACK
// arrives; then HELLO echoing its challenge, repeated on the same timer
// until the first DATA arrives (kMaxHellos in all). Every datagram goes
// through the steps of "Receiving" and is dropped and counted at the first
// that fails; only DATA and HELLO_ACK of this session, authenticated under
// the server's key and new to the replay window, are acted on.
//
// Contract: safe on any bytes arriving at the socket; `deliver` runs on the
// receiver's thread and must not block for long.
// Thread safety: counters, hello_rtt_us and caught_up_us from any thread.
#ifndef MESHSTREAM_SDK_UDP_RECEIVER_H_
#define MESHSTREAM_SDK_UDP_RECEIVER_H_

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "codec/core/status.h"
#include "net/drop_reason.h"
#include "net/hello.h"
#include "net/packet_crypto.h"
#include "net/udp_socket.h"

namespace meshstream::sdk {

struct UdpPacket {
  uint64_t packet_number = 0;
  std::vector<uint8_t> payload;  // the codec's datagram
  uint64_t time_us = 0;          // steady clock, when it arrived
};

class UdpReceiver {
 public:
  static constexpr int kHelloIntervalMs = 100;
  static constexpr int kMaxHellos = 50;
  // The longest wait on an empty socket: the horizon is at most this old
  // while nothing arrives (a declared loss waits for it, sdk/session_core.h).
  static constexpr int kIdleWaitMs = 5;

  static StatusOr<std::unique_ptr<UdpReceiver>> Start(const SocketAddress& server, uint64_t session_id,
                                                      const SessionKeys& keys,
                                                      std::function<void(UdpPacket&&)> deliver);
  ~UdpReceiver();  // stops and joins the thread
  // Asks the thread to stop without waiting for it (the destructor joins).
  void RequestStop() { stop_ = true; }
  UdpReceiver(const UdpReceiver&) = delete;
  UdpReceiver& operator=(const UdpReceiver&) = delete;

  DropCounters counters() const;
  uint64_t hello_rtt_us() const { return hello_rtt_us_.load(); }  // 0: no HELLO_ACK yet
  uint64_t hellos_sent() const { return hellos_sent_.load(); }
  const SocketAddress& local() const { return socket_.local(); }
  // The arrival horizon: every datagram that was in the socket before this
  // steady-clock time (SteadyNowUs) has been handed to `deliver` (0: the
  // thread has not drained the socket yet). A client times stragglers out by
  // it, not by its own clock, so a receiver thread the host keeps off the
  // CPU cannot make datagrams that did arrive count as lost.
  uint64_t caught_up_us() const { return caught_up_us_.load(); }

 private:
  UdpReceiver() = default;
  void Run();
  void SendHello();
  void Handle(const IncomingDatagram& d);

  UdpSocket socket_;
  SocketAddress server_;
  uint64_t session_id_ = 0;
  SessionKeys keys_;
  std::function<void(UdpPacket&&)> deliver_;
  std::thread thread_;
  std::atomic<bool> stop_{false};

  // The thread's own state.
  uint64_t next_packet_number_ = 0;
  Challenge echo_{};
  bool have_challenge_ = false;
  bool have_data_ = false;
  uint64_t first_hello_us_ = 0;
  uint64_t last_hello_us_ = 0;
  std::atomic<uint64_t> hellos_sent_{0};
  std::atomic<uint64_t> hello_rtt_us_{0};
  std::atomic<uint64_t> caught_up_us_{0};

  mutable std::mutex mutex_;
  DropCounters counters_;
  class Window;  // the replay window (net/replay_window.h), owned by the thread
  std::unique_ptr<Window> window_;
};

}  // namespace meshstream::sdk

#endif  // MESHSTREAM_SDK_UDP_RECEIVER_H_
