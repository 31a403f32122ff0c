// Conditional GETs (RFC 9110, section 13): `If-None-Match` and `If-Range`
// against the entity tag of what the server would send.
//
// Entity tags are `"opaque"` (strong) or `W/"opaque"` (weak); the opaque
// part is any visible ASCII but '"', and obs-text. `If-None-Match` is `*` or
// a comma-separated list of tags compared weakly (W/ ignored on both sides);
// it matches when any tag does. `If-Range` holds one entity tag or a date;
// only a strong tag equal to ours keeps the Range (a weak tag or any date
// does not: our responses carry no Last-Modified).
//
// Contract: headers are untrusted (any bytes; the caller bounds their
// length); a malformed header never matches (If-None-Match is then ignored,
// and If-Range sends the whole body, which is always correct). `etag` is
// the server's own tag, quoted. Thread safety: pure functions.
#ifndef MESHSTREAM_SERVICES_HTTP_CONDITIONAL_H_
#define MESHSTREAM_SERVICES_HTTP_CONDITIONAL_H_

#include <string>
#include <string_view>

namespace meshstream {

// `"<opaque>"`: a strong entity tag (the opaque part must hold no '"').
std::string StrongEntityTag(std::string_view opaque);

// True when If-None-Match `header` matches `etag` (weak comparison).
bool IfNoneMatchMatches(std::string_view header, std::string_view etag);

// True when If-Range `header` is a strong entity tag equal to `etag`.
bool IfRangeMatches(std::string_view header, std::string_view etag);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_HTTP_CONDITIONAL_H_
