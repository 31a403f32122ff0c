// A GET or HEAD of one representation (an export, a static file): the body
// with its entity tag, answered as 200, 206 for a single satisfiable Range,
// 416 for an unsatisfiable one, or 304 when If-None-Match matches
// (docs/spec/http-api.md, "Caching and ranges").
//
// Order, as RFC 9110 section 13.2.2 has it: If-None-Match first (304, which
// wins over Range); then Range on GET only (HEAD ignores it), kept only when
// an If-Range, if any, is our strong entity tag; a Range this server does
// not serve as 206 (several ranges, malformed) gets the whole body.
// Every 200, 206 and 304 carries the ETag, `Accept-Ranges: bytes` and the
// caller's headers (Cache-Control, Content-Location, Vary); 200 and 206 the
// Content-Type; 206 and 416 a Content-Range.
//
// Contract: the request's headers are untrusted (parsed by byte_range.h and
// conditional.h). Thread safety: a pure function; the body is shared, not
// copied (a 206 points into the same bytes).
#ifndef MESHSTREAM_SERVICES_HTTP_REPRESENTATION_H_
#define MESHSTREAM_SERVICES_HTTP_REPRESENTATION_H_

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "services/http/http_message.h"

namespace meshstream {

struct Representation {
  std::shared_ptr<const std::vector<uint8_t>> bytes;  // never null
  std::string etag;                                   // quoted: "\"<hex>\""
  std::string content_type;
  // Added to 200, 206 and 304 (not to 416, which is an error: no-store).
  std::vector<std::pair<std::string, std::string>> headers;
};

HttpResponse ServeRepresentation(const HttpRequest& request, const Representation& representation);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_HTTP_REPRESENTATION_H_
