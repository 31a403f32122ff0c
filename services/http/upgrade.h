// The extension point of the HTTP server for routes that take over their
// connection: `GET /v1/stream` with `Upgrade: websocket` (docs/design/web.md,
// "Live"). Register a handler for a path in HttpServerOptions::upgrades
// (http_server.h); the server then hands it every GET of that exact path
// that is a WebSocket upgrade (beast::websocket::is_upgrade), and answers
// any other request of that path with 426 Upgrade Required itself.
//
// What the handler gets, on the connection's strand (an io thread):
//   - the stream, moved: a plain `beast::tcp_stream`, or a
//     `beast::ssl_stream<beast::tcp_stream>` whose TLS handshake is done
//     (the server's --tls-cert). Its executor is the connection's strand;
//     keep every operation on it. The stream's timeout is still the one of
//     the request's read: set your own (websocket::stream_base::timeout, or
//     expires_never() on the lowest layer) before anything else;
//   - the parsed request (its head and an empty body: the server refuses a
//     request whose bytes are followed by more before the upgrade, so no
//     client bytes are lost with the server's read buffer);
//   - the connection's slot: its place among --http max connections. Keep
//     it as long as the connection lives; dropping it frees the place.
// From then on the server neither reads nor writes the connection; it is
// the handler's to accept (websocket::stream::async_accept(request)),
// authenticate (the Authorization header, or whatever the handler defines),
// refuse with an HTTP response of its own, and close. A taken-over
// connection still counts until its slot is released: HttpServer::Stop
// waits for it until the grace deadline, then stops the io threads, which
// ends every operation still pending (handlers never run; their objects
// are destroyed). A handler should therefore end its sessions when the
// server drains (it learns that the way the gRPC services do: the server's
// `draining` flag).
//
// Contract: Upgrade must not block (it runs on one of a few io threads;
// post blocking work elsewhere) and must not throw. The request is
// untrusted; the server has bounded its size (docs/spec/http-api.md, "Limits").
// Thread safety: Upgrade is called from the io threads, for different
// connections at once.
#ifndef MESHSTREAM_SERVICES_HTTP_UPGRADE_H_
#define MESHSTREAM_SERVICES_HTTP_UPGRADE_H_

#include <memory>

#include <boost/beast/core/tcp_stream.hpp>
#include <boost/beast/http/message.hpp>
#include <boost/beast/http/string_body.hpp>
#include <boost/beast/ssl/ssl_stream.hpp>

namespace meshstream {

using HttpPlainStream = boost::beast::tcp_stream;
using HttpTlsStream = boost::beast::ssl_stream<boost::beast::tcp_stream>;
using HttpUpgradeRequest = boost::beast::http::request<boost::beast::http::string_body>;

class HttpConnectionTable;  // http_server.cc

// A place among the server's connections at once, released when destroyed
// (or by Release). Move-only. Thread safety: one owner at a time.
class HttpConnectionSlot {
 public:
  HttpConnectionSlot() = default;
  explicit HttpConnectionSlot(std::shared_ptr<HttpConnectionTable> table) : table_(std::move(table)) {}
  HttpConnectionSlot(HttpConnectionSlot&& other) noexcept = default;
  HttpConnectionSlot& operator=(HttpConnectionSlot&& other) noexcept {
    if (this != &other) {
      Release();
      table_ = std::move(other.table_);
    }
    return *this;
  }
  HttpConnectionSlot(const HttpConnectionSlot&) = delete;
  HttpConnectionSlot& operator=(const HttpConnectionSlot&) = delete;
  ~HttpConnectionSlot() { Release(); }

  explicit operator bool() const { return table_ != nullptr; }
  void Release();

 private:
  std::shared_ptr<HttpConnectionTable> table_;
};

class HttpUpgradeHandler {
 public:
  virtual ~HttpUpgradeHandler() = default;
  virtual void Upgrade(HttpPlainStream stream, HttpUpgradeRequest request, HttpConnectionSlot slot) = 0;
  virtual void Upgrade(HttpTlsStream stream, HttpUpgradeRequest request, HttpConnectionSlot slot) = 0;
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_HTTP_UPGRADE_H_
