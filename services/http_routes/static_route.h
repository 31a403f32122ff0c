// The viewer's static files from a folder (docs/spec/http-api.md, "The viewer"):
// `--http-root DIR`, or by default the first folder that exists of
// `<folder of the binary>/../share/meshstream/web` (an installed tree) and
// `<folder of the binary>/../web`. Without one, every file request is 404
// with a JSON error naming where the server looked.
//
// `/` and any path ending in '/' serve that folder's index.html; no folder
// is ever listed. Only GET and HEAD. Refused before the file system is
// asked (400): a path not starting with '/', a backslash or a NUL (raw or
// percent-encoded), a percent-encoded '/', an empty segment ("//"), and
// any "." or ".." segment (also percent-encoded: "%2e%2e"). Files and
// folders whose name starts with '.' are not served (404). The path that
// remains is resolved with realpath(3) and must still lie inside the root's
// own real path: a symbolic link that leads out of the root is 404, one
// that stays inside it is followed. Only regular files of at most
// `max_file_bytes` are served.
//
// Files are read at each request (they are small; a change shows at once),
// served by representation.h with a strong ETag (the SHA-256 of the bytes),
// `Cache-Control: no-cache` (browsers revalidate: 304 when unchanged) and
// a Content-Type by extension (.html, .js/.mjs/.cjs text/javascript,
// .wasm application/wasm, .json, .css, .png, .glb, ...; others
// application/octet-stream).
//
// Contract: request paths are untrusted; the root is the operator's.
// Thread safety: Handle and Resolve from any thread at once (immutable
// after Open; blocking file I/O, so on the server's pool).
#ifndef MESHSTREAM_SERVICES_HTTP_ROUTES_STATIC_ROUTE_H_
#define MESHSTREAM_SERVICES_HTTP_ROUTES_STATIC_ROUTE_H_

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "codec/core/status.h"
#include "services/http/http_message.h"

namespace meshstream {

constexpr uint64_t kMaxStaticFileBytes = uint64_t{64} << 20;

struct WebRootSearch {
  std::string found;                  // empty: none of `searched` exists
  std::vector<std::string> searched;  // the folders looked at, in order
};

// The default folder of the viewer's files (see above).
WebRootSearch FindDefaultWebRoot();

// The Content-Type of a file name by its extension.
const char* StaticContentType(std::string_view file_name);

class StaticRoute {
 public:
  // `root`: a folder (InvalidArgument when it is not one), or empty for no
  // files at all (each request 404 naming `searched`).
  static StatusOr<std::unique_ptr<StaticRoute>> Open(const std::string& root, std::vector<std::string> searched,
                                                     uint64_t max_file_bytes = kMaxStaticFileBytes);

  HttpResponse Handle(const HttpRequest& request) const;

  // The real path of the file `encoded_path` names, inside the root:
  // InvalidArgument for a path that is refused, NotFound for one that
  // names nothing inside the root.
  StatusOr<std::string> Resolve(std::string_view encoded_path) const;

  const std::string& root() const { return root_; }  // real path; empty: none

 private:
  StaticRoute() = default;
  std::string root_;
  std::vector<std::string> searched_;
  uint64_t max_file_bytes_ = kMaxStaticFileBytes;
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_HTTP_ROUTES_STATIC_ROUTE_H_
