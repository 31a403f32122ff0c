#include "services/http_routes/router.h"

#include <exception>
#include <utility>

namespace meshstream {

HttpRouter::HttpRouter(AssetRoute* assets, const StaticRoute* files, CorsPolicy cors, const std::atomic<bool>* draining,
                       std::function<void(const std::string&)> log)
    : assets_(assets), files_(files), cors_(std::move(cors)), draining_(draining), log_(std::move(log)) {}

HttpResponse HttpRouter::Route(const HttpRequest& request) const {
  if (request.method == "OPTIONS") return cors_.Preflight(request);
  const std::string& path = request.path;
  if (path == "/v1/health") {
    const bool serving = draining_ == nullptr || !draining_->load();
    HttpResponse r = JsonResponse(serving ? 200 : 503, serving ? R"({"status":"SERVING"})" : R"({"status":"NOT_SERVING"})");
    r.SetHeader("Cache-Control", "no-store");
    if (!serving) r.SetHeader("Retry-After", std::to_string(kRetryAfterSeconds));
    return r;
  }
  if (AssetRoute::Matches(path)) return assets_->Handle(request);
  if (path == "/v1/stream") {
    return JsonError(501,
                     "GET /v1/stream: the live session over WebSocket is not available on this server; "
                     "read the files by ranges from /v1/assets/{asset}/versions/{version}/{format}, or stream "
                     "over gRPC (meshstream.v1.StreamService)",
                     "NOT_IMPLEMENTED");
  }
  if (path == "/v1" || path.rfind("/v1/", 0) == 0) {
    return JsonError(404,
                     "no such route (the routes: /v1/assets, "
                     "/v1/assets/{asset}/versions/{version}/{format}[?lod=K], /v1/stream, /v1/health)",
                     "NOT_FOUND");
  }
  return files_->Handle(request);
}

HttpResponse HttpRouter::Handle(const HttpRequest& request) const {
  HttpResponse r;
  try {
    r = Route(request);
  } catch (const std::exception& e) {
    r = JsonError(500, std::string("internal error: ") + e.what(), "INTERNAL");
  } catch (...) {
    r = JsonError(500, "internal error", "INTERNAL");
  }
  if (r.status >= 500 && r.status != 501 && r.status != 503 && log_) {
    std::string_view body = r.body().substr(0, 300);
    while (!body.empty() && body.back() == '\n') body.remove_suffix(1);
    log_("http: " + request.method + " " + request.path.substr(0, 200) + " -> " + std::to_string(r.status) + " " +
         std::string(body));
  }
  cors_.Decorate(request, &r);
  r.SetHeader("X-Content-Type-Options", "nosniff");
  return r;
}

}  // namespace meshstream
