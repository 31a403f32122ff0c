// A request and a response of the HTTP server as plain values: what a route
// (services/http_routes/router.h) reads and returns, with no Boost type in sight, so
// that routes are tested without sockets and run on any thread.
//
// Also the one mapping of a Status to HTTP (docs/spec/http-api.md, "Status
// codes"): every error leaves as a JSON body `{"error": "...", "code":
// "NOT_FOUND"}` with `Cache-Control: no-store`.
//
// Contract: a request's fields are untrusted (the server has bounded their
// size: docs/spec/http-api.md, "Limits"). Header names of a request are lower
// case; values are as sent (the parser has removed surrounding whitespace).
// Thread safety: plain values; a response's body is shared immutable bytes,
// safe to hand between threads.
#ifndef MESHSTREAM_SERVICES_HTTP_HTTP_MESSAGE_H_
#define MESHSTREAM_SERVICES_HTTP_HTTP_MESSAGE_H_

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "codec/core/status.h"

namespace meshstream {

struct HttpRequest {
  std::string method;  // as sent: "GET", "HEAD", "OPTIONS" (the server refuses others)
  std::string target;  // as sent: "/v1/assets?page_size=10"
  std::string path;    // the target before '?', still percent-encoded
  std::string query;   // after the first '?', without it (empty when none)
  std::vector<std::pair<std::string, std::string>> headers;  // names lower case
  std::string remote;  // the peer, "ADDRESS:PORT", for logs

  // The values of every line of the field `name` (lower case), joined by
  // ", " as one list; nullopt when the field is absent.
  std::optional<std::string> Header(std::string_view name) const;
  bool head() const { return method == "HEAD"; }
};

struct HttpResponse {
  int status = 200;
  // Names as they are sent ("Content-Type"). The server adds Date, Server,
  // Connection and Content-Length itself (routes never set them).
  std::vector<std::pair<std::string, std::string>> headers;
  // The body is data[offset, offset + size); null data: no body. A HEAD
  // request gets the same response with the body left out (Content-Length
  // still says its size).
  std::shared_ptr<const std::vector<uint8_t>> data;
  size_t offset = 0;
  size_t size = 0;

  // Replaces every line of `name` (compared without case) with one.
  void SetHeader(std::string_view name, std::string value);
  // Adds a line, keeping any of the same name.
  void AddHeader(std::string name, std::string value);
  // The first value of `name` (compared without case).
  std::optional<std::string> Header(std::string_view name) const;
  void RemoveHeader(std::string_view name);
  // Appends `token` to a comma-separated field (Vary), once.
  void AppendToken(std::string_view name, std::string_view token);

  void SetBody(std::string text);
  void SetBody(std::shared_ptr<const std::vector<uint8_t>> bytes, size_t offset, size_t size);
  std::string_view body() const;
};

// The HTTP status of a meshstream Status code (docs/spec/http-api.md):
// InvalidArgument/InvalidInput/Unsupported 400, Unauthenticated 401,
// PermissionDenied 403, NotFound 404, FailedPrecondition/AlreadyExists 409,
// ResourceExhausted 429, Unavailable/Cancelled 503, DeadlineExceeded 504,
// the rest (IoError, DataLoss, Internal, Aborted) 500.
int HttpStatusOf(StatusCode code);

// The JSON error response: `{"error": message, "code": code}` (code left out
// when empty), Content-Type application/json, Cache-Control no-store.
// Messages need not be UTF-8: ill-formed bytes become U+FFFD.
HttpResponse JsonError(int status, std::string_view message, std::string_view code = {});

// JsonError of a non-OK Status with its HTTP status, plus
// `WWW-Authenticate: Bearer realm="meshstream"` on 401 and `Retry-After` on
// 503 (seconds).
constexpr int kRetryAfterSeconds = 2;
HttpResponse StatusResponse(const Status& status);

// A 200 (or `status`) with a JSON body.
HttpResponse JsonResponse(int status, std::string json);

// The IMF-fixdate of a Unix time: "Sun, 06 Nov 1994 08:49:37 GMT".
std::string HttpDate(int64_t unix_seconds);

// ASCII case-insensitive equality (header names, tokens).
bool EqualsIgnoreCase(std::string_view a, std::string_view b);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_HTTP_HTTP_MESSAGE_H_
