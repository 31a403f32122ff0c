// `meshstream serve`: the gRPC server with its store, its worker pool and the
// standard services (grpc.health.v1; reflection when asked or on loopback),
// and when asked the HTTP server (services/http/: the assets by ranges, the
// viewer's files; docs/spec/http-api.md).
//
// Secure by default: without authentication the server listens only on a
// loopback address (or a unix: socket); any other address is refused unless
// `insecure` is set, which logs a warning. TLS with a certificate and key
// in PEM files. SIGTERM (Drain) turns health to NOT_SERVING, stops claiming
// jobs, lets running requests finish within the grace period, then cancels
// the rest; unfinished jobs are taken up again by the next start (or by
// another server sharing the PostgreSQL store) (docs/design/deploy.md). HTTP stops
// accepting and closes its idle keep-alive connections at the same time as
// gRPC refuses new calls; its running responses get the same grace period.
//
// Thread safety: Start, then Drain from any thread (a signal handler thread),
// and Wait from one.
#ifndef MESHSTREAM_SERVICES_SERVER_SERVER_H_
#define MESHSTREAM_SERVICES_SERVER_SERVER_H_

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "codec/core/status.h"
#include "proto/default_address.h"

namespace meshstream {

struct ServerOptions {
  std::string listen = kDefaultAddress;   // host:port, [v6]:port or unix:/path; port 0 picks a free one
  std::string store = "./meshstream-data";  // a folder, or postgresql://...
  int workers = 0;                        // 0: the core count
  int encode_threads = 0;                 // per job (spatial parts, primitives); 0: the core count
  bool auth = false;
  bool insecure = false;                  // allow a non-loopback address without auth
  std::string tls_cert, tls_key;          // PEM files; both or neither
  std::optional<bool> reflection;         // unset: on only on loopback
  uint64_t max_upload_bytes = uint64_t{1} << 30;
  double grace_period_s = 20.0;
  // After health turns NOT_SERVING, keep serving this long before refusing
  // new calls, so that load balancers see the state and move traffic away.
  double drain_delay_s = 0.0;
  int64_t upload_ttl_ms = int64_t{24} * 3600 * 1000;  // resumable uploads idle this long are removed
  int64_t lease_ms = 30000;               // job lease; the worker renews it every third of it
  int32_t max_attempts = 3;               // a job claimed more often fails (a file that kills servers)
  int max_threads = 256;                  // gRPC threads; calls beyond them are RESOURCE_EXHAUSTED
  int max_watchers = 128;                 // concurrent WatchJob streams
  int max_exports = 0;                    // concurrent exports that decode (0: the worker count)
  // Streaming sessions (docs/spec/streaming-protocol.md). udp_listen empty: the
  // --listen host and the next port (port 0: any free one); "off": every
  // session over gRPC. udp_advertise empty: the bound address, or only its
  // port when it is 0.0.0.0 / :: (clients then use the host they connected to).
  std::string udp_listen;
  std::string udp_advertise;
  double max_rate_bps = 1e9;              // all sessions together (--max-rate)
  double max_session_rate_bps = 400e6;    // one session
  // Streaming sessions at once; each costs memory (about 40 KiB stalled,
  // plus its share of the artifact), no thread (docs/design/deploy.md, "Streaming
  // sessions per server": 4096 measured).
  int max_sessions = 4096;
  int64_t hello_timeout_ms = 1000;        // no HELLO proved an address: gRPC fallback
  bool udp_wait_hello = false;            // UDP sessions wait for the HELLO before their first UDP refinement
  bool no_reliable_cut = false;           // every datagram as UDP, none on the stream (the paper's scheme)
  bool no_parity = false;                 // no parity datagrams (docs/design/loss-protection.md)
  int64_t session_idle_timeout_ms = 30000;
  // Hot artifacts kept in memory for streaming sessions, with their plans and
  // scenes, by bytes, least recently used out first (--stream-cache-mb).
  uint64_t stream_cache_bytes = uint64_t{256} << 20;
  // HTTP (docs/spec/http-api.md): the assets by ranges and the viewer's files.
  // http_listen empty: off; HOST:PORT (7680 is the documented port) or
  // [V6]:PORT, port 0 picks a free one; the loopback rule of `listen`
  // applies, and TLS with the same certificate and key.
  std::string http_listen;
  std::vector<std::string> http_cors_origins;  // --http-cors-origin; "*" for any
  std::string http_root;                  // the viewer's files; empty: the default search (static_route.h)
  std::string server_id;                  // for job leases and logs; empty: host-pid-random
  // Log lines ("meshstream serve: ..."); default: stderr.
  std::function<void(const std::string&)> log;
};

// True for 127.0.0.0/8, ::1, localhost and unix: sockets.
bool IsLoopbackListen(const std::string& listen);

class Server {
 public:
  static StatusOr<std::unique_ptr<Server>> Start(const ServerOptions& options);
  ~Server();

  // The address really bound ("127.0.0.1:41234" when port 0 was asked).
  const std::string& address() const;
  // The UDP endpoint bound ("127.0.0.1:41235"), empty when UDP is off.
  std::string udp_address() const;
  // The HTTP address bound ("127.0.0.1:41236"), empty when HTTP is off.
  std::string http_address() const;
  // Health NOT_SERVING, stop claiming, finish within the grace period.
  void Drain();
  // Blocks until the server has shut down (after Drain).
  void Wait();

 private:
  struct Impl;
  explicit Server(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_SERVER_SERVER_H_
