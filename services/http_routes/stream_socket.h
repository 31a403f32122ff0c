// `GET /v1/stream` upgraded to a WebSocket: a live session for browsers
// (docs/spec/streaming-protocol.md, "WebSocket transport"), the same session as
// StreamService.Open over gRPC with its datagrams on the reliable channel
// (TRANSPORT_GRPC): a thin transport on the session host
// (services/streaming/session_host.h: the same OpenRequest check, version
// resolution, tenant, hot artifacts, send loop, limits, idle timeout and
// drain). Only the framing differs.
//
// Framing: every WebSocket message is binary and carries one message, its
// first byte saying what follows: 1 a ClientMessage (client to server),
// 2 a ServerMessage, 3 a datagram (server to client: the codec's datagram,
// the bytes a StreamDatagram's payload would hold). Anything else from the
// client (a text message, another type, a ClientMessage that does not
// parse, a first message that is not `open`) ends the session with
// INVALID_ARGUMENT.
//
// Before the upgrade:
//   - Origin: a request that carries one is accepted only from the server's
//     own origin (the Host it was asked with) or an origin of
//     --http-cors-origin; any other gets 403 (browsers do not apply CORS to
//     WebSockets: this is what keeps another site's page from opening
//     sessions with a user's token).
//   - Subprotocols: when the client offers any, it must offer
//     "meshstream.v1", which the server selects (else 400).
//   - The token: `Authorization: Bearer T`, or, since a browser cannot set
//     that header on a WebSocket, an offered subprotocol "bearer.T".
// After it, on the opener pool: authentication (with --auth), a session
// slot (max_sessions), draining. A refusal closes the socket with the code
// 4000 + the gRPC status code and the message as the reason (cut to 123
// bytes); a session ends with 1000 when its status is OK, else the same way.
//
// Limits: a client message is at most `max_message_bytes` (a bigger one ends
// the connection: 1009); the handshake and the closing handshake have
// `handshake_timeout`; while a session runs, its idle timeout (no client
// message) is the session's own. A write the client does not take is
// bounded by the send loop's queue and the session's idle timeout.
//
// Contract: everything the client sends is untrusted. Thread safety:
// Upgrade from the io threads at once; each connection is served on its
// strand and the send loop's thread.
#ifndef MESHSTREAM_SERVICES_HTTP_ROUTES_STREAM_SOCKET_H_
#define MESHSTREAM_SERVICES_HTTP_ROUTES_STREAM_SOCKET_H_

#include <chrono>
#include <cstdint>
#include <functional>
#include <string>

#include "services/http/cors.h"
#include "services/http/upgrade.h"
#include "services/streaming/session_host.h"

namespace meshstream {

// The first byte of a WebSocket message of the session's framing.
enum class StreamFrame : uint8_t { kClientMessage = 1, kServerMessage = 2, kDatagram = 3 };

// The subprotocol a browser offers and the server selects.
constexpr char kStreamSubprotocol[] = "meshstream.v1";

struct StreamSocketOptions {
  CorsPolicy cors;  // origins besides the server's own
  uint64_t max_message_bytes = uint64_t{1} << 20;
  std::chrono::milliseconds handshake_timeout{30000};
  std::function<void(const std::string&)> log;  // may be empty
};

class StreamSocketRoute final : public HttpUpgradeHandler {
 public:
  // `host` outlives the route and every connection it took over.
  StreamSocketRoute(SessionHost* host, StreamSocketOptions options);

  void Upgrade(HttpPlainStream stream, HttpUpgradeRequest request, HttpConnectionSlot slot) override;
  void Upgrade(HttpTlsStream stream, HttpUpgradeRequest request, HttpConnectionSlot slot) override;

  // For tests: the checks made before the upgrade, on the request alone.
  // The token found (empty: none) or the refusal (its HTTP status in
  // *http_status: 403 for the origin, 400 for the subprotocols).
  static StatusOr<std::string> CheckRequest(const HttpUpgradeRequest& request, const CorsPolicy& cors, bool tls,
                                            int* http_status, bool* offered_subprotocol);

 private:
  template <class Stream>
  void Take(Stream stream, HttpUpgradeRequest request, HttpConnectionSlot slot, bool tls);

  SessionHost* host_;
  StreamSocketOptions options_;
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_HTTP_ROUTES_STREAM_SOCKET_H_
