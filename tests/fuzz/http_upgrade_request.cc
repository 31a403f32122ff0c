#include "tests/fuzz/http_upgrade_request.h"

#include <boost/beast/http/field.hpp>
#include <boost/beast/http/verb.hpp>

#include "services/http_routes/stream_socket.h"

namespace meshstream::fuzz {

namespace http = boost::beast::http;

const char kUpgradeSubprotocol[] = "meshstream.v1";
static_assert(sizeof kUpgradeSubprotocol == sizeof kStreamSubprotocol);

StatusOr<std::string> CheckUpgradeRequest(const UpgradeFields& u, const CorsPolicy& cors, int* http_status,
                                          bool* offered_subprotocol) {
  if (std::string(kUpgradeSubprotocol) != kStreamSubprotocol) return Internal("the subprotocol changed");
  HttpUpgradeRequest request;
  request.method(http::verb::get);
  request.target("/v1/stream");
  request.version(11);
  request.insert(http::field::upgrade, "websocket");
  request.insert(http::field::connection, "Upgrade");
  if (u.origin) request.insert(http::field::origin, *u.origin);
  if (!u.protocols.empty()) request.insert(http::field::sec_websocket_protocol, u.protocols[0]);
  if (u.protocols.size() > 1 && !u.split) request.insert(http::field::sec_websocket_protocol, u.protocols[1]);
  if (u.host) request.insert(http::field::host, *u.host);
  request.insert(http::field::sec_websocket_version, "13");
  if (u.protocols.size() > 1 && u.split) request.insert(http::field::sec_websocket_protocol, u.protocols[1]);
  if (u.authorization) request.insert(http::field::authorization, *u.authorization);
  return StreamSocketRoute::CheckRequest(request, cors, u.tls, http_status, offered_subprotocol);
}

}  // namespace meshstream::fuzz
