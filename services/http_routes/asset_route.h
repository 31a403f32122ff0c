// The assets over HTTP (docs/spec/http-api.md, "Assets"): a thin translation of
//   GET|HEAD /v1/assets/{asset}/versions/{version}/{format}[?lod=K]
//   GET|HEAD /v1/assets[?page_size=N&page_token=T]
// to the calls the gRPC AssetService makes (services/grpc/asset_service.cc):
// the Authenticator for the tenant, CheckName for the asset, ExportVersion
// with a slot of the same limit on concurrent exports that decode and the
// same largest export, Store::ListAssets for the list.
//
// {asset} is percent-decoded, then must be a name (CheckName);
// {version} is a positive decimal number without leading zeros, or
// `latest`; {format} one of `meshstream export --format`: glb, draco,
// progressive, obj, ply; lod=K a level 0..2^20 (the CLI's range). Anything
// else in the path or the query is 400 naming what and where; a path under
// /v1/assets of another shape is 404 naming the routes.
//
// The file is served by representation.h (ranges, ETag = the SHA-256 of
// the bytes served, 304). Cache-Control: a numbered version never changes,
// so `public, max-age=31536000, immutable` (`private` instead of `public`
// with authentication on, and then `Vary: Authorization`: two tenants have
// the same URLs); `latest` moves, so `no-cache` and a Content-Location
// naming the numbered version it resolved to.
//
// The stored progressive file is served from the session host's hot
// artifacts (services/streaming/session_host.h, HotFile) when the route has
// a host: the same in-memory bytes sessions read, loaded and digest-checked
// once per load, so a range is a lookup and a slice (a browser's view makes
// two or three). Without a host, and for every other format, the file
// comes from ExportVersion (a verified read of the whole blob per request).
//
// Memory: a 206 keeps only its slice (a hot file's slice is a view of the
// kept bytes, not a copy); the bodies of responses still being written are
// bounded together by `max_bytes_in_flight` (503 beyond), a hot file's by
// the bytes the response serves.
//
// Exports that decode wait at most `export_wait_ms` for a slot of the
// shared limit, as gRPC's do; but at most `max_decode_requests` requests
// may be inside a decode (waiting or running) at once, so that waiting
// exports never hold every thread of the server's pool: beyond that, and
// when the wait ends without a slot, the answer is 503 with Retry-After.
//
// Contract: requests are untrusted. Errors are JSON (http_message.h);
// nothing throws. Thread safety: Handle is called from the pool's threads
// at once; the route holds pointers to thread-safe parts and a CallLimit.
#ifndef MESHSTREAM_SERVICES_HTTP_ROUTES_ASSET_ROUTE_H_
#define MESHSTREAM_SERVICES_HTTP_ROUTES_ASSET_ROUTE_H_

#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "parallel/call_limit.h"
#include "services/auth/authenticator.h"
#include "services/http/http_message.h"
#include "services/pipeline/export_artifact.h"
#include "services/store/store.h"
#include "services/streaming/session_host.h"

namespace meshstream {

struct AssetRouteOptions {
  uint64_t max_export_bytes = uint64_t{4} << 30;  // as AssetServiceOptions
  int export_wait_ms = 30000;                     // as AssetServiceOptions
  int max_decode_requests = 4;                    // requests waiting for or running a decode
  int32_t max_page_size = 100;                    // assets in one GET /v1/assets
  // Bytes of response bodies held until clients have taken them (slow
  // readers): beyond, 503 with Retry-After (one response is always admitted).
  uint64_t max_bytes_in_flight = uint64_t{1} << 30;
};

// What a file path names: "/v1/assets/bunny/versions/3/glb?lod=2".
struct AssetRequest {
  std::string asset;
  int64_t version = 0;  // 0: latest
  ExportFormat format = ExportFormat::kGlb;
  std::optional<int> lod;
};

// The asset request of `path` (still percent-encoded, split at '/') and
// `query`: InvalidArgument naming the part that is wrong, NotFound when the
// path is not of the file route's shape.
StatusOr<AssetRequest> ParseAssetRequest(std::string_view path, std::string_view query);

class AssetRoute {
 public:
  // `exports`: the server's limit on concurrent exports that decode, shared
  // with the gRPC service; `sessions` (may be null): the session host whose
  // hot artifacts serve the stored progressive file. Both outlive the route.
  AssetRoute(Store* store, const Authenticator* auth, CallLimit* exports, AssetRouteOptions options,
             SessionHost* sessions = nullptr);

  // True for /v1/assets and every path under it (this route answers them).
  static bool Matches(std::string_view path);

  // Blocking (the store, decodes): runs on the server's pool.
  HttpResponse Handle(const HttpRequest& request);

 private:
  HttpResponse List(const HttpRequest& request, const Principal& principal);
  HttpResponse Export(const HttpRequest& request, const Principal& principal, const AssetRequest& asset);
  // The file's response (ranges, 304) admitted against the bytes in flight.
  HttpResponse Serve(const HttpRequest& request, const AssetRequest& file, const std::string& sha256,
                     int64_t resolved_version, std::shared_ptr<const std::vector<uint8_t>> bytes, bool kept);
  // `Cache-Control` (and Vary) of a response of this route.
  void AddCaching(HttpResponse* response, bool immutable) const;

  Store* store_;
  const Authenticator* auth_;
  CallLimit* exports_;
  AssetRouteOptions options_;
  SessionHost* sessions_;
  CallLimit decode_requests_;
  // Shared with the bodies' deleters, which may run on any thread.
  std::shared_ptr<std::atomic<uint64_t>> bytes_in_flight_;
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_HTTP_ROUTES_ASSET_ROUTE_H_
