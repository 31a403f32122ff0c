// Which route answers a request of `meshstream serve --http-listen`
// (docs/spec/http-api.md):
//   OPTIONS *any*          CORS preflight (cors.h): 204
//   /v1/health             200 {"status":"SERVING"}, 503 NOT_SERVING while draining
//   /v1/assets, /v1/assets/...   asset_route.h
//   /v1/stream             501: the live session over WebSocket is not on this
//                          server; a handler registered in
//                          HttpServerOptions::upgrades takes this path over
//                          (upgrade.h) and this answer is never reached
//   any other /v1/...      404 naming the routes
//   anything else          the viewer's files (static_route.h)
// Every answer gets the CORS headers of its Origin and
// `X-Content-Type-Options: nosniff`.
//
// Contract: requests are untrusted; no exception leaves Handle (one that a
// route throws becomes a 500 with a JSON error). Thread safety: Handle from
// the pool's threads at once; the routes it points to must outlive it.
#ifndef MESHSTREAM_SERVICES_HTTP_ROUTES_ROUTER_H_
#define MESHSTREAM_SERVICES_HTTP_ROUTES_ROUTER_H_

#include <atomic>
#include <functional>
#include <string>

#include "services/http/cors.h"
#include "services/http/http_message.h"
#include "services/http_routes/asset_route.h"
#include "services/http_routes/static_route.h"

namespace meshstream {

class HttpRouter {
 public:
  // `draining` (may be null) turns /v1/health to 503; `log` gets one line
  // per request that failed with a 5xx (may be empty).
  HttpRouter(AssetRoute* assets, const StaticRoute* files, CorsPolicy cors, const std::atomic<bool>* draining,
             std::function<void(const std::string&)> log);

  // Blocking: runs on the server's pool.
  HttpResponse Handle(const HttpRequest& request) const;

 private:
  HttpResponse Route(const HttpRequest& request) const;

  AssetRoute* assets_;
  const StaticRoute* files_;
  CorsPolicy cors_;
  const std::atomic<bool>* draining_;
  std::function<void(const std::string&)> log_;
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_HTTP_ROUTES_ROUTER_H_
