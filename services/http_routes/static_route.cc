#include "services/http_routes/static_route.h"

#include <fcntl.h>
#include <limits.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <system_error>
#include <utility>

#include "proto/sha256.h"
#include "services/http/conditional.h"
#include "services/http/representation.h"
#include "services/http/url.h"

namespace meshstream {

namespace {

std::string RealPath(const std::string& path) {
  char* real = realpath(path.c_str(), nullptr);
  if (real == nullptr) return std::string();
  std::string out(real);
  free(real);
  return out;
}

std::string LowerExtension(std::string_view name) {
  const size_t slash = name.rfind('/');
  const size_t dot = name.rfind('.');
  if (dot == std::string_view::npos || (slash != std::string_view::npos && dot < slash)) return std::string();
  std::string ext(name.substr(dot));
  for (char& c : ext) {
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  }
  return ext;
}

// Closes a descriptor when it goes out of scope.
struct Fd {
  int fd = -1;
  ~Fd() {
    if (fd >= 0) close(fd);
  }
};

}  // namespace

WebRootSearch FindDefaultWebRoot() {
  WebRootSearch search;
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) return search;
  const std::filesystem::path dir = exe.parent_path();
  for (const std::filesystem::path& candidate :
       {dir / ".." / "share" / "meshstream" / "web", dir / ".." / "web"}) {
    const std::string name = candidate.lexically_normal().string();
    search.searched.push_back(name);
    if (search.found.empty() && std::filesystem::is_directory(candidate, ec)) search.found = name;
  }
  return search;
}

const char* StaticContentType(std::string_view file_name) {
  const std::string ext = LowerExtension(file_name);
  if (ext == ".html" || ext == ".htm") return "text/html; charset=utf-8";
  if (ext == ".js" || ext == ".mjs" || ext == ".cjs") return "text/javascript; charset=utf-8";
  if (ext == ".wasm") return "application/wasm";
  if (ext == ".json" || ext == ".map") return "application/json";
  if (ext == ".css") return "text/css; charset=utf-8";
  if (ext == ".png") return "image/png";
  if (ext == ".jpg" || ext == ".jpeg") return "image/jpeg";
  if (ext == ".svg") return "image/svg+xml";
  if (ext == ".ico") return "image/x-icon";
  if (ext == ".glb") return "model/gltf-binary";
  if (ext == ".gltf") return "model/gltf+json";
  if (ext == ".txt") return "text/plain; charset=utf-8";
  return "application/octet-stream";
}

StatusOr<std::unique_ptr<StaticRoute>> StaticRoute::Open(const std::string& root, std::vector<std::string> searched,
                                                         uint64_t max_file_bytes) {
  std::unique_ptr<StaticRoute> route(new StaticRoute());
  route->searched_ = std::move(searched);
  route->max_file_bytes_ = max_file_bytes;
  if (root.empty()) return route;
  std::error_code ec;
  if (!std::filesystem::is_directory(root, ec)) return InvalidArgument("--http-root " + root + ": not a folder");
  route->root_ = RealPath(root);
  if (route->root_.empty()) return IoError("--http-root " + root + ": " + std::strerror(errno));
  if (route->root_ == "/") return InvalidArgument("--http-root /: serving the whole file system is refused");
  return route;
}

StatusOr<std::string> StaticRoute::Resolve(std::string_view encoded) const {
  if (encoded.empty() || encoded.front() != '/') return InvalidArgument("path: must start with '/'");
  for (size_t i = 0; i + 2 < encoded.size(); ++i) {
    if (encoded[i] != '%') continue;
    const char a = encoded[i + 1];
    const char b = static_cast<char>(encoded[i + 2] | 0x20);  // lower case a letter
    if ((a == '2' && b == 'f') || (a == '5' && b == 'c') || (a == '0' && b == '0')) {
      return InvalidArgument("path: a percent-encoded '/', '\\' or NUL is not allowed");
    }
  }
  auto decoded = PercentDecode("path", encoded);
  if (!decoded.ok()) return decoded.status();
  const std::string& path = decoded.value();
  if (path.find('\0') != std::string::npos || path.find('\\') != std::string::npos) {
    return InvalidArgument("path: a backslash or NUL is not allowed");
  }
  std::string relative;
  std::vector<std::string_view> segments = PathSegments(path);
  for (size_t i = 0; i < segments.size(); ++i) {
    const std::string_view seg = segments[i];
    const bool last = i + 1 == segments.size();
    if (seg.empty()) {
      if (last) break;  // a trailing '/': the folder's index.html
      return InvalidArgument("path: an empty segment ('//') is not allowed");
    }
    if (seg == "." || seg == "..") return InvalidArgument("path: '.' and '..' segments are not allowed");
    if (seg.front() == '.') return NotFound("path: files whose name starts with '.' are not served");
    if (!relative.empty()) relative += '/';
    relative += seg;
  }
  if (path.back() == '/') relative += relative.empty() ? "index.html" : "/index.html";
  if (root_.empty()) return NotFound("no files to serve");
  const std::string real = RealPath(root_ + "/" + relative);
  if (real.empty()) return NotFound("no such file");
  if (real.compare(0, root_.size() + 1, root_ + "/") != 0) return NotFound("no such file (it lies outside the web root)");
  return real;
}

HttpResponse StaticRoute::Handle(const HttpRequest& request) const {
  if (request.method != "GET" && request.method != "HEAD") {
    HttpResponse r = JsonError(405, request.method + ": only GET and HEAD", "METHOD_NOT_ALLOWED");
    r.SetHeader("Allow", "GET, HEAD, OPTIONS");
    return r;
  }
  if (root_.empty()) {
    std::string where;
    for (const std::string& s : searched_) where += (where.empty() ? "" : ", ") + s;
    return JsonError(404,
                     "the viewer's files are not installed: looked in " + (where.empty() ? "no folder" : where) +
                         " (give meshstream serve --http-root DIR)",
                     "NOT_FOUND");
  }
  auto real = Resolve(request.path);
  if (!real.ok()) return StatusResponse(real.status());
  Fd file;
  file.fd = open(real->c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
  if (file.fd < 0) return StatusResponse(NotFound("no such file"));
  struct stat st {};
  if (fstat(file.fd, &st) != 0) return StatusResponse(IoError(std::string("stat: ") + std::strerror(errno)));
  if (S_ISDIR(st.st_mode)) return StatusResponse(NotFound("a folder (folders are not listed; add '/' for its index.html)"));
  if (!S_ISREG(st.st_mode)) return StatusResponse(NotFound("not a regular file"));
  if (static_cast<uint64_t>(st.st_size) > max_file_bytes_) {
    return JsonError(500,
                     "the file has " + std::to_string(st.st_size) + " bytes, more than the " +
                         std::to_string(max_file_bytes_) + " served from the web root",
                     "FILE_TOO_LARGE");
  }
  auto bytes = std::make_shared<std::vector<uint8_t>>(static_cast<size_t>(st.st_size));
  size_t got = 0;
  while (got < bytes->size()) {
    const ssize_t n = read(file.fd, bytes->data() + got, bytes->size() - got);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return StatusResponse(IoError(std::string("read: ") + std::strerror(errno)));
    if (n == 0) break;  // the file shrank meanwhile: serve what it holds now
    got += static_cast<size_t>(n);
  }
  bytes->resize(got);
  Representation rep;
  rep.etag = StrongEntityTag(Sha256Hex(bytes->data(), bytes->size()));
  rep.content_type = StaticContentType(*real);
  rep.headers = {{"Cache-Control", "no-cache"}};
  rep.bytes = std::move(bytes);
  return ServeRepresentation(request, rep);
}

}  // namespace meshstream
