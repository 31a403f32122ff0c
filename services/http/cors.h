// Cross-origin reads from browsers (the Fetch standard's CORS protocol), by
// `--http-cors-origin` (docs/spec/http-api.md, "CORS").
//
// A list of allowed origins, none by default: then no response carries a
// CORS header and browsers keep pages of other origins from reading ours.
// When the request's `Origin` is in the list, responses carry
// `Access-Control-Allow-Origin: <that origin>` and
// `Access-Control-Expose-Headers` (Content-Range, Content-Length, ETag,
// Accept-Ranges, Content-Location, Retry-After); a preflight (OPTIONS) is
// answered 204 with the methods GET, HEAD and the request headers
// Authorization, Range, If-None-Match, If-Range. `Vary: Origin` is on every
// response while a list is set, so that caches keep one copy per origin.
// An origin not in the list gets no CORS header at all.
//
// `*` allows every origin (`Access-Control-Allow-Origin: *`). With --auth
// that is unsafe: any web page a user opens may then use a token that page
// holds to read assets. No credentials (cookies) are ever allowed.
//
// Contract: the configured origins are checked by Make; the request's
// Origin is untrusted and only compared. Thread safety: immutable after
// Make; const methods from any thread.
#ifndef MESHSTREAM_SERVICES_HTTP_CORS_H_
#define MESHSTREAM_SERVICES_HTTP_CORS_H_

#include <optional>
#include <string>
#include <vector>

#include "codec/core/status.h"
#include "services/http/http_message.h"

namespace meshstream {

class CorsPolicy {
 public:
  CorsPolicy() = default;  // no origin allowed
  // Each origin is `*` or `http[s]://HOST[:PORT]` (no path, no trailing
  // '/'); InvalidArgument naming the origin otherwise. "null" is refused.
  static StatusOr<CorsPolicy> Make(const std::vector<std::string>& origins);

  bool enabled() const { return any_ || !origins_.empty(); }
  bool allows_any() const { return any_; }
  // The value of Access-Control-Allow-Origin for a request with `origin`,
  // or nullopt when it is not allowed (or absent).
  std::optional<std::string> AllowedOrigin(const std::optional<std::string>& origin) const;
  // Adds the CORS headers a response to `request` gets (Vary: Origin, and
  // the allow/expose headers when its Origin is allowed).
  void Decorate(const HttpRequest& request, HttpResponse* response) const;
  // The answer to an OPTIONS request: 204 with Allow, and the preflight's
  // headers when its Origin is allowed.
  HttpResponse Preflight(const HttpRequest& request) const;

 private:
  bool any_ = false;
  std::vector<std::string> origins_;  // lower case
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_HTTP_CORS_H_
