#include "services/http/representation.h"

#include "services/http/byte_range.h"
#include "services/http/conditional.h"

namespace meshstream {

HttpResponse ServeRepresentation(const HttpRequest& request, const Representation& rep) {
  const uint64_t size = rep.bytes ? rep.bytes->size() : 0;
  const auto add_common = [&rep](HttpResponse* r) {
    r->SetHeader("ETag", rep.etag);
    r->SetHeader("Accept-Ranges", "bytes");
    for (const auto& [name, value] : rep.headers) r->SetHeader(name, value);
  };

  if (const auto inm = request.Header("if-none-match"); inm && IfNoneMatchMatches(*inm, rep.etag)) {
    HttpResponse r;
    r.status = 304;
    add_common(&r);
    return r;
  }

  HttpRange range;  // kWhole
  if (request.method == "GET") {
    const auto range_header = request.Header("range");
    if (range_header) {
      const auto if_range = request.Header("if-range");
      if (!if_range || IfRangeMatches(*if_range, rep.etag)) range = ParseByteRange(*range_header, size);
    }
  }

  if (range.kind == HttpRange::Kind::kUnsatisfiable) {
    HttpResponse r = JsonError(416,
                               "Range: no byte of the requested range is within the " +
                                   std::to_string(size) + " bytes of the body",
                               "RANGE_NOT_SATISFIABLE");
    r.SetHeader("Content-Range", "bytes */" + std::to_string(size));
    r.SetHeader("Accept-Ranges", "bytes");
    return r;
  }

  HttpResponse r;
  add_common(&r);
  r.SetHeader("Content-Type", rep.content_type);
  if (range.kind == HttpRange::Kind::kPartial) {
    r.status = 206;
    r.SetHeader("Content-Range", "bytes " + std::to_string(range.first) + "-" + std::to_string(range.last) + "/" +
                                     std::to_string(size));
    r.SetBody(rep.bytes, static_cast<size_t>(range.first), static_cast<size_t>(range.length()));
  } else {
    r.status = 200;
    r.SetBody(rep.bytes, 0, static_cast<size_t>(size));
  }
  return r;
}

}  // namespace meshstream
