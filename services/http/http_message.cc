#include "services/http/http_message.h"

#include <time.h>

#include <algorithm>
#include <cstdio>

#include <nlohmann/json.hpp>

namespace meshstream {

namespace {

char Lower(char c) { return c >= 'A' && c <= 'Z' ? static_cast<char>(c - 'A' + 'a') : c; }

}  // namespace

bool EqualsIgnoreCase(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    if (Lower(a[i]) != Lower(b[i])) return false;
  }
  return true;
}

std::optional<std::string> HttpRequest::Header(std::string_view name) const {
  std::optional<std::string> value;
  for (const auto& [n, v] : headers) {
    if (n != name) continue;
    if (value) {
      *value += ", ";
      *value += v;
    } else {
      value = v;
    }
  }
  return value;
}

void HttpResponse::SetHeader(std::string_view name, std::string value) {
  RemoveHeader(name);
  headers.emplace_back(std::string(name), std::move(value));
}

void HttpResponse::AddHeader(std::string name, std::string value) { headers.emplace_back(std::move(name), std::move(value)); }

std::optional<std::string> HttpResponse::Header(std::string_view name) const {
  for (const auto& [n, v] : headers) {
    if (EqualsIgnoreCase(n, name)) return v;
  }
  return std::nullopt;
}

void HttpResponse::RemoveHeader(std::string_view name) {
  headers.erase(std::remove_if(headers.begin(), headers.end(),
                               [name](const auto& h) { return EqualsIgnoreCase(h.first, name); }),
                headers.end());
}

void HttpResponse::AppendToken(std::string_view name, std::string_view token) {
  for (auto& [n, v] : headers) {
    if (!EqualsIgnoreCase(n, name)) continue;
    // Already listed? (tokens are compared without case)
    size_t start = 0;
    while (start <= v.size()) {
      size_t comma = v.find(',', start);
      if (comma == std::string::npos) comma = v.size();
      std::string_view item(v.data() + start, comma - start);
      while (!item.empty() && item.front() == ' ') item.remove_prefix(1);
      while (!item.empty() && item.back() == ' ') item.remove_suffix(1);
      if (EqualsIgnoreCase(item, token)) return;
      start = comma + 1;
    }
    v += ", ";
    v += token;
    return;
  }
  headers.emplace_back(std::string(name), std::string(token));
}

void HttpResponse::SetBody(std::string text) {
  auto bytes = std::make_shared<std::vector<uint8_t>>(text.begin(), text.end());
  const size_t n = bytes->size();
  SetBody(std::move(bytes), 0, n);
}

void HttpResponse::SetBody(std::shared_ptr<const std::vector<uint8_t>> bytes, size_t from, size_t length) {
  data = std::move(bytes);
  offset = from;
  size = length;
}

std::string_view HttpResponse::body() const {
  if (!data || size == 0) return {};
  return std::string_view(reinterpret_cast<const char*>(data->data()) + offset, size);
}

int HttpStatusOf(StatusCode code) {
  switch (code) {
    case StatusCode::kOk: return 200;
    case StatusCode::kInvalidArgument:
    case StatusCode::kInvalidInput:
    case StatusCode::kUnsupported: return 400;
    case StatusCode::kUnauthenticated: return 401;
    case StatusCode::kPermissionDenied: return 403;
    case StatusCode::kNotFound: return 404;
    case StatusCode::kFailedPrecondition:
    case StatusCode::kAlreadyExists: return 409;
    case StatusCode::kResourceExhausted: return 429;
    case StatusCode::kUnavailable:
    case StatusCode::kCancelled: return 503;
    case StatusCode::kDeadlineExceeded: return 504;
    case StatusCode::kIoError:
    case StatusCode::kDataLoss:
    case StatusCode::kInternal:
    case StatusCode::kAborted: return 500;
  }
  return 500;
}

HttpResponse JsonError(int status, std::string_view message, std::string_view code) {
  nlohmann::json body = nlohmann::json::object();
  body["error"] = std::string(message);
  if (!code.empty()) body["code"] = std::string(code);
  HttpResponse r = JsonResponse(status, body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
  r.SetHeader("Cache-Control", "no-store");
  return r;
}

HttpResponse StatusResponse(const Status& status) {
  const int http = HttpStatusOf(status.code());
  HttpResponse r = JsonError(http, status.message(), StatusCodeName(status.code()));
  if (http == 401) r.SetHeader("WWW-Authenticate", "Bearer realm=\"meshstream\"");
  if (http == 503) r.SetHeader("Retry-After", std::to_string(kRetryAfterSeconds));
  return r;
}

HttpResponse JsonResponse(int status, std::string json) {
  HttpResponse r;
  r.status = status;
  r.SetHeader("Content-Type", "application/json");
  json += "\n";
  r.SetBody(std::move(json));
  return r;
}

std::string HttpDate(int64_t unix_seconds) {
  const time_t t = static_cast<time_t>(unix_seconds);
  struct tm utc {};
  gmtime_r(&t, &utc);
  static const char* const kDays[] = {"Sun", "Mon", "Tue", "Wed", "Thu", "Fri", "Sat"};
  static const char* const kMonths[] = {"Jan", "Feb", "Mar", "Apr", "May", "Jun",
                                        "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"};
  char text[64];
  std::snprintf(text, sizeof text, "%s, %02d %s %04d %02d:%02d:%02d GMT", kDays[utc.tm_wday % 7], utc.tm_mday,
                kMonths[utc.tm_mon % 12], utc.tm_year + 1900, utc.tm_hour, utc.tm_min, utc.tm_sec);
  return text;
}

}  // namespace meshstream
