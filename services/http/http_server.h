// The HTTP/1.1 server of `meshstream serve --http-listen` (docs/spec/http-api.md):
// Boost.Beast over Boost.Asio, with TLS by Asio's OpenSSL stream when a
// certificate and a key are given.
//
// Threads: `io_threads` run the io_context (accept, TLS, parse, write); each
// connection lives on its own strand. A request that parsed is handed as a
// plain HttpRequest to the handler on an Executor of `pool_threads`
// (parallel/executor.h: the handler may block on the store or a decode), and the
// response is written back on the connection's strand. One request per
// connection at a time (keep-alive, pipelined requests answered in order).
//
// What the server itself answers (the handler never sees these):
//   - a request that cannot be parsed: 400; a head over `max_header_bytes`
//     (request line and fields): 431; a body over `max_body_bytes`: 413;
//     each then closes the connection;
//   - a method other than GET, HEAD, OPTIONS: 405 with `Allow`;
//   - a target that is not an absolute path (nor `*` for OPTIONS): 400;
//   - a path registered in `upgrades` (upgrade.h): a WebSocket upgrade is
//     handed to its handler, anything else is 426.
// HEAD gets the GET's headers and Content-Length without the body.
//
// Limits on everything a client controls: connections at once
// (`max_connections`; beyond, a new connection is closed at once), the head's
// size, the body's, the time to send a head (`header_timeout` for the first
// request and the TLS handshake, `idle_timeout` between requests of a
// kept-alive connection), and the time a response may go without the
// client taking a byte of it (`send_timeout`). Each timeout closes the
// connection.
//
// Drain: BeginDrain stops accepting, closes connections waiting for a
// request, and makes every later response end with `Connection: close`;
// Stop(deadline) waits for the running responses (and connections taken
// over by an upgrade handler) until the deadline, closes what is left,
// drops queued requests and joins every thread.
//
// Contract: everything from the network is untrusted; no exception escapes
// (a handler's is its own to catch: the router catches all). Thread
// safety: Start, then BeginDrain/Stop from any thread, once or more.
#ifndef MESHSTREAM_SERVICES_HTTP_HTTP_SERVER_H_
#define MESHSTREAM_SERVICES_HTTP_HTTP_SERVER_H_

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>

#include "codec/core/status.h"
#include "services/http/http_message.h"

namespace meshstream {

class HttpUpgradeHandler;  // upgrade.h

struct HttpServerOptions {
  std::string listen;              // HOST:PORT or [V6]:PORT; port 0: any free one
  std::string tls_cert, tls_key;   // PEM files: TLS when both are given
  int io_threads = 2;
  int pool_threads = 8;
  int max_connections = 1024;
  uint32_t max_header_bytes = 16 << 10;
  uint64_t max_body_bytes = 4 << 10;
  std::chrono::milliseconds header_timeout{30000};
  std::chrono::milliseconds idle_timeout{30000};
  std::chrono::milliseconds send_timeout{60000};
  // Exact paths whose WebSocket upgrades a handler takes over (upgrade.h).
  std::map<std::string, std::shared_ptr<HttpUpgradeHandler>> upgrades;
  std::function<void(const std::string&)> log;  // may be empty
};

// Runs on the pool; must not throw.
using HttpHandler = std::function<HttpResponse(const HttpRequest&)>;

struct HttpServerStats {
  uint64_t accepted = 0;  // connections
  uint64_t refused = 0;   // connections closed at once (max_connections)
  uint64_t requests = 0;  // responses written, by the server or the handler
  uint64_t upgraded = 0;  // connections handed to an upgrade handler
};

class HttpServer {
 public:
  // Binds, listens and starts the threads. InvalidArgument for a bad
  // address or TLS files, Unavailable when the address cannot be bound.
  static StatusOr<std::unique_ptr<HttpServer>> Start(HttpServerOptions options, HttpHandler handler);
  ~HttpServer();  // Stop(now) unless stopped
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  // The address bound: "127.0.0.1:41234", "[::1]:41234".
  const std::string& address() const;
  bool tls() const;
  void BeginDrain();
  void Stop(std::chrono::steady_clock::time_point deadline);
  HttpServerStats stats() const;

 private:
  struct Impl;
  explicit HttpServer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_HTTP_HTTP_SERVER_H_
