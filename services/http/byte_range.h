// The `Range` header of a GET against a body of known size (RFC 9110,
// section 14): which bytes to send, whether the range cannot be satisfied
// (416), or whether to ignore the header and send the whole body (200).
//
// Only a single byte range is served as 206: `bytes=A-B`, `bytes=A-` and
// `bytes=-N`. Everything else is answered with the whole body, which HTTP
// allows a server to do for any Range header:
//   - more than one range (`bytes=0-1,5-6`): no multipart/byteranges;
//   - a unit other than `bytes` (the unit is case-insensitive);
//   - a malformed set: no '=', no '-', a sign, a space inside a spec
//     (`bytes=1 - 2`), a spec with neither number (`bytes=-`), or B < A.
// Unsatisfiable (416, `Content-Range: bytes */SIZE`): a first position at or
// beyond the size (any `bytes=A-` or `bytes=A-B` on an empty body), and a
// suffix of length 0 (`bytes=-0`). A last position beyond the end is cut to
// the end; a suffix longer than the body is the whole body as 206. A suffix
// of a non-zero length on an empty body is answered with the whole (empty)
// body: there is no byte range to name in a Content-Range.
//
// Numbers of any length are accepted: digits beyond 2^64 - 1 saturate, so a
// huge first position is unsatisfiable and a huge last position or suffix
// reaches the end. Optional whitespace (spaces and tabs) around the header
// and around each comma-separated element is allowed, and empty elements
// (`bytes=0-9,`) are skipped, as the list syntax says.
//
// Contract: `header` is untrusted (any bytes, any length; the caller bounds
// the length of headers). Thread safety: a pure function.
#ifndef MESHSTREAM_SERVICES_HTTP_BYTE_RANGE_H_
#define MESHSTREAM_SERVICES_HTTP_BYTE_RANGE_H_

#include <cstdint>
#include <string_view>

namespace meshstream {

struct HttpRange {
  enum class Kind {
    kWhole,          // no usable Range: 200 with the whole body
    kPartial,        // 206 with bytes [first, last] (inclusive)
    kUnsatisfiable,  // 416 with Content-Range: bytes */size
  };
  Kind kind = Kind::kWhole;
  uint64_t first = 0;
  uint64_t last = 0;

  uint64_t length() const { return kind == Kind::kPartial ? last - first + 1 : 0; }
};

HttpRange ParseByteRange(std::string_view header, uint64_t size);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_HTTP_BYTE_RANGE_H_
