#include "services/http/cors.h"

namespace meshstream {

namespace {

std::string Lower(std::string s) {
  for (char& c : s) {
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  }
  return s;
}

Status CheckOrigin(const std::string& origin) {
  const std::string bad = "--http-cors-origin " + origin + ": ";
  const std::string o = Lower(origin);
  size_t host_start = 0;
  if (o.rfind("http://", 0) == 0) {
    host_start = 7;
  } else if (o.rfind("https://", 0) == 0) {
    host_start = 8;
  } else {
    return InvalidArgument(bad + "not * nor http://HOST[:PORT] or https://HOST[:PORT]");
  }
  const std::string host = o.substr(host_start);
  if (host.empty()) return InvalidArgument(bad + "no host");
  for (char c : host) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '.' || c == '-' || c == ':' ||
                    c == '[' || c == ']' || c == '_';
    if (!ok) {
      return InvalidArgument(bad + "an origin is a scheme and a host with an optional port, without a path, "
                                   "a trailing '/' or other characters");
    }
  }
  return Status::Ok();
}

constexpr char kExposed[] = "Content-Range, Content-Length, ETag, Accept-Ranges, Content-Location, Retry-After";

}  // namespace

StatusOr<CorsPolicy> CorsPolicy::Make(const std::vector<std::string>& origins) {
  CorsPolicy policy;
  for (const std::string& origin : origins) {
    if (origin == "*") {
      policy.any_ = true;
      continue;
    }
    if (Lower(origin) == "null") {
      return InvalidArgument("--http-cors-origin null: refused (sandboxed frames and local files all send it)");
    }
    Status s = CheckOrigin(origin);
    if (!s.ok()) return s;
    policy.origins_.push_back(Lower(origin));
  }
  return policy;
}

std::optional<std::string> CorsPolicy::AllowedOrigin(const std::optional<std::string>& origin) const {
  if (!origin || origin->empty()) return std::nullopt;
  if (any_) return std::string("*");
  const std::string o = Lower(*origin);
  for (const std::string& allowed : origins_) {
    if (allowed == o) return *origin;
  }
  return std::nullopt;
}

void CorsPolicy::Decorate(const HttpRequest& request, HttpResponse* response) const {
  if (!enabled()) return;
  response->AppendToken("Vary", "Origin");
  const auto allowed = AllowedOrigin(request.Header("origin"));
  if (!allowed) return;
  response->SetHeader("Access-Control-Allow-Origin", *allowed);
  response->SetHeader("Access-Control-Expose-Headers", kExposed);
}

HttpResponse CorsPolicy::Preflight(const HttpRequest& request) const {
  HttpResponse r;
  r.status = 204;
  r.SetHeader("Allow", "GET, HEAD, OPTIONS");
  if (!enabled()) return r;
  r.AppendToken("Vary", "Origin");
  const auto allowed = AllowedOrigin(request.Header("origin"));
  if (!allowed) return r;
  r.SetHeader("Access-Control-Allow-Origin", *allowed);
  r.SetHeader("Access-Control-Allow-Methods", "GET, HEAD");
  r.SetHeader("Access-Control-Allow-Headers", "Authorization, Range, If-None-Match, If-Range");
  r.SetHeader("Access-Control-Max-Age", "600");
  return r;
}

}  // namespace meshstream
