// The parts of a request target (RFC 3986): percent-decoding, the path's
// segments and the query's parameters, for the routes of services/http/.
//
// Contract: every input is untrusted (any bytes; the server bounds the
// target's length with its header limit). A '%' not followed by two hex
// digits is InvalidArgument naming the field and the position; decoding
// may yield any byte (NUL, '/', non-UTF-8): callers check the result
// (asset names with CheckName, static paths with their own rules).
// Thread safety: pure functions.
#ifndef MESHSTREAM_SERVICES_HTTP_URL_H_
#define MESHSTREAM_SERVICES_HTTP_URL_H_

#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "codec/core/status.h"

namespace meshstream {

// At most this many parameters in a query (more is InvalidArgument).
constexpr size_t kMaxQueryParameters = 16;

// `text` with every %XX replaced by its byte ('+' stays '+').
StatusOr<std::string> PercentDecode(std::string_view field, std::string_view text);

// The segments of an absolute path, still encoded: "/v1/assets/" ->
// {"v1", "assets", ""}; "/" -> {""}.
std::vector<std::string_view> PathSegments(std::string_view path);

// The query's name=value pairs in order, both percent-decoded; an element
// without '=' has an empty value; empty elements ("a=1&&b=2") are skipped.
StatusOr<std::vector<std::pair<std::string, std::string>>> ParseQuery(std::string_view query);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_HTTP_URL_H_
