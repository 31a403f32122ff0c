// A TCP proxy that delays what it forwards, for the shaped-link part of the
// streaming benchmark (bench/stream/shaped.cc, docs/results/stream-benchmarks.md):
// the gRPC channels of the clients in a network namespace go through it so
// that they see the same one-way delay as the UDP half, which goes through
// the UDP relay (testing/udp_relay.h).
//
// It listens on `listen`; every connection it accepts gets its own
// connection to `upstream`, and bytes are forwarded both ways, each chunk
// read released `delay_us` after it was read (so each direction's bytes keep
// their order and are delayed by the same amount). A direction holds at most
// `max_buffered` bytes: beyond that the proxy stops reading its source, and
// TCP's flow control pushes back on the sender. A half-close (EOF) is passed
// on once the bytes before it are out; an error on either side closes both.
// Both sockets have TCP_NODELAY, so the proxy adds no Nagle wait.
//
// What it is not: a delay on the wire. The proxy ends the TCP connection it
// accepts, so the connection that crosses a shaped, lossy link between the
// client and the proxy has that link's round trip (without the delay) for
// its retransmissions and congestion control; the delay is added between
// the two connections. ConnectionInfo keeps what the kernel says of each
// accepted connection when it closes (TCP_INFO), so a report can show that
// round trip and the retransmissions.
//
// Thread safety: Start, then the accessors and Stop from any thread; one
// internal thread does all the forwarding (poll).
#ifndef MESHSTREAM_BENCH_TCP_DELAY_PROXY_H_
#define MESHSTREAM_BENCH_TCP_DELAY_PROXY_H_

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "codec/core/status.h"

namespace meshstream::bench {

struct TcpDelayProxyOptions {
  std::string listen = "127.0.0.1:0";  // numeric IPv4 "HOST:PORT"; port 0: any free one
  std::string upstream;                // numeric IPv4 "HOST:PORT" of the server
  uint64_t delay_us = 0;               // each direction
  size_t max_buffered = size_t{1} << 20;  // bytes held per direction of a connection
  size_t max_connections = 256;        // beyond: new connections are closed at once
};

// What the kernel said of an accepted (client-facing) connection as it closed.
struct TcpConnectionInfo {
  uint64_t bytes_to_client = 0, bytes_to_server = 0;
  double rtt_ms = 0, rttvar_ms = 0;  // TCP_INFO's smoothed round trip of the client-facing connection
  uint32_t total_retrans = 0;        // segments it retransmitted (towards the client)
  uint32_t lost = 0;                 // segments it had marked lost at the end
};

class TcpDelayProxy {
 public:
  static StatusOr<std::unique_ptr<TcpDelayProxy>> Start(const TcpDelayProxyOptions& options);
  ~TcpDelayProxy();
  TcpDelayProxy(const TcpDelayProxy&) = delete;
  TcpDelayProxy& operator=(const TcpDelayProxy&) = delete;

  // The address it listens on ("10.77.20.1:41234").
  const std::string& address() const { return address_; }
  uint64_t accepted() const { return accepted_.load(); }
  // Every accepted connection that has closed, in order of closing.
  std::vector<TcpConnectionInfo> closed() const;
  // Stops the thread and closes every socket (also the destructor's).
  void Stop();

 private:
  TcpDelayProxy() = default;
  void Run();

  TcpDelayProxyOptions options_;
  std::string address_;
  int listen_fd_ = -1;
  std::atomic<bool> stop_{false};
  std::atomic<uint64_t> accepted_{0};
  std::thread thread_;
  mutable std::mutex mutex_;  // closed_
  std::vector<TcpConnectionInfo> closed_;
};

}  // namespace meshstream::bench

#endif  // MESHSTREAM_BENCH_TCP_DELAY_PROXY_H_
