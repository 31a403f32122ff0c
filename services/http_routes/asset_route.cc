#include "services/http_routes/asset_route.h"

#include <chrono>
#include <exception>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "proto/export_formats.h"
#include "services/export/export_version.h"
#include "services/http/conditional.h"
#include "services/http/representation.h"
#include "services/http/url.h"
#include "services/store/store_checks.h"

namespace meshstream {

namespace {

constexpr char kFileRoute[] = "/v1/assets/{asset}/versions/{version}/{format}[?lod=K]";
constexpr int kMaxLod = 1 << 20;  // the CLI's --lod range

// A decimal number without sign or leading zeros, at most `max`.
std::optional<int64_t> Decimal(std::string_view text, int64_t max) {
  if (text.empty() || text.size() > 19) return std::nullopt;
  if (text.size() > 1 && text[0] == '0') return std::nullopt;
  int64_t value = 0;
  for (char c : text) {
    if (c < '0' || c > '9') return std::nullopt;
    const int64_t digit = c - '0';
    if (value > (max - digit) / 10) return std::nullopt;
    value = value * 10 + digit;
  }
  return value;
}

// A short, printable quote of what a client sent, for messages.
std::string Quote(std::string_view text) {
  std::string out = "'";
  for (size_t i = 0; i < text.size() && i < 64; ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    out += c >= 0x20 && c < 0x7f ? static_cast<char>(c) : '?';
  }
  if (text.size() > 64) out += "...";
  return out + "'";
}

// The URL of a numbered version (asset names need no encoding).
std::string FileUrl(const std::string& asset, int64_t version, ExportFormat format, std::optional<int> lod) {
  std::string url = "/v1/assets/" + asset + "/versions/" + std::to_string(version) + "/" + InfoOf(format).name;
  if (lod) url += "?lod=" + std::to_string(*lod);
  return url;
}

}  // namespace

StatusOr<AssetRequest> ParseAssetRequest(std::string_view path, std::string_view query) {
  const std::vector<std::string_view> s = PathSegments(path);
  if (s.size() != 6 || s[0] != "v1" || s[1] != "assets" || s[3] != "versions") {
    return NotFound(std::string("no such route: the files are at ") + kFileRoute);
  }
  AssetRequest r;
  auto asset = PercentDecode("asset", s[2]);
  if (!asset.ok()) return asset.status();
  Status name = CheckName("asset", asset.value());
  if (!name.ok()) return name;
  r.asset = std::move(asset).value();

  if (s[4] == "latest") {
    r.version = 0;
  } else {
    const auto version = Decimal(s[4], std::numeric_limits<int64_t>::max());
    if (!version || *version == 0) {
      return InvalidArgument("version: " + Quote(s[4]) +
                             " is neither a positive number (without sign or leading zeros) nor 'latest'");
    }
    r.version = *version;
  }

  const ExportFormatInfo* format = ExportFormatNamed(s[5]);
  if (format == nullptr) return InvalidArgument("format: " + Quote(s[5]) + " is not one of " + ExportFormatNames());
  r.format = format->format;

  auto params = ParseQuery(query);
  if (!params.ok()) return params.status();
  for (const auto& [key, value] : params.value()) {
    if (key != "lod") return InvalidArgument("query: unknown parameter " + Quote(key) + " (only lod=K)");
    if (r.lod) return InvalidArgument("query: lod given more than once");
    const auto lod = Decimal(value, kMaxLod);
    if (!lod) {
      return InvalidArgument("query: lod=" + Quote(value) + " is not a level 0.." + std::to_string(kMaxLod));
    }
    r.lod = static_cast<int>(*lod);
  }
  if (r.lod && !InfoOf(r.format).decodes) {
    // Refused here as ExportArtifact would, before the store is asked.
    return InvalidArgument("lod: not supported for the progressive format (it holds every level)");
  }
  return r;
}

AssetRoute::AssetRoute(Store* store, const Authenticator* auth, CallLimit* exports, AssetRouteOptions options,
                       SessionHost* sessions)
    : store_(store),
      auth_(auth),
      exports_(exports),
      options_(options),
      sessions_(sessions),
      decode_requests_(options.max_decode_requests),
      bytes_in_flight_(std::make_shared<std::atomic<uint64_t>>(0)) {}

bool AssetRoute::Matches(std::string_view path) {
  return path == "/v1/assets" || path.rfind("/v1/assets/", 0) == 0;
}

void AssetRoute::AddCaching(HttpResponse* response, bool immutable) const {
  const bool auth = auth_->enabled();
  if (immutable) {
    response->SetHeader("Cache-Control", std::string(auth ? "private" : "public") + ", max-age=31536000, immutable");
  } else {
    response->SetHeader("Cache-Control", auth ? "private, no-cache" : "no-cache");
  }
  if (auth) response->AppendToken("Vary", "Authorization");
}

HttpResponse AssetRoute::Handle(const HttpRequest& request) {
  if (request.method != "GET" && request.method != "HEAD") {
    HttpResponse r = JsonError(405, request.method + " " + request.path + ": only GET and HEAD", "METHOD_NOT_ALLOWED");
    r.SetHeader("Allow", "GET, HEAD, OPTIONS");
    return r;
  }
  // The shape of the request first: a malformed one is 400 whoever sends it.
  std::optional<AssetRequest> file;
  if (request.path != "/v1/assets") {
    auto parsed = ParseAssetRequest(request.path, request.query);
    if (!parsed.ok()) {
      if (parsed.status().code() == StatusCode::kNotFound) {
        return JsonError(404,
                         "no such route: " + Quote(request.path) + " (the routes: /v1/assets and " + kFileRoute + ")",
                         "NOT_FOUND");
      }
      return StatusResponse(parsed.status());
    }
    file = std::move(parsed).value();
  }
  auto authorization = request.Header("authorization");
  // The scheme is case-insensitive in HTTP (RFC 9110, section 11.1).
  if (authorization && authorization->size() > 7 && EqualsIgnoreCase(authorization->substr(0, 7), "bearer ")) {
    authorization->replace(0, 7, "Bearer ");
  }
  if (auth_->enabled() && !authorization) {
    return StatusResponse(Unauthenticated("missing 'Authorization: Bearer TOKEN' header (meshstream token create)"));
  }
  auto principal = auth_->Authenticate(authorization);
  if (!principal.ok()) return StatusResponse(principal.status());
  if (!file) return List(request, principal.value());
  return Export(request, principal.value(), *file);
}

HttpResponse AssetRoute::List(const HttpRequest& request, const Principal& principal) {
  auto params = ParseQuery(request.query);
  if (!params.ok()) return StatusResponse(params.status());
  int32_t page_size = 0;
  std::string page_token;
  for (const auto& [key, value] : params.value()) {
    if (key == "page_size") {
      const auto n = Decimal(value, options_.max_page_size);
      if (!n) {
        return StatusResponse(InvalidArgument("query: page_size=" + Quote(value) + " is not a number 0.." +
                                              std::to_string(options_.max_page_size)));
      }
      page_size = static_cast<int32_t>(*n);
    } else if (key == "page_token") {
      page_token = value;
    } else {
      return StatusResponse(InvalidArgument("query: unknown parameter " + Quote(key) + " (page_size, page_token)"));
    }
  }
  if (page_size == 0) page_size = std::min<int32_t>(kDefaultPageSize, options_.max_page_size);
  auto page = store_->ListAssets(principal.tenant, page_size, page_token);
  if (!page.ok()) return StatusResponse(page.status());
  nlohmann::json assets = nlohmann::json::array();
  for (const AssetRecord& a : page->items) {
    nlohmann::json item = {{"name", a.name}, {"latest_version", a.latest_version}, {"updated_ms", a.updated_ms}};
    auto ready = store_->GetLatestReadyVersion(principal.tenant, a.name);
    if (ready.ok()) {
      item["ready_version"] = ready->version;
      item["formats"] = nlohmann::json::array();
      for (const ExportFormatInfo& format : ExportFormats()) item["formats"].push_back(format.name);
    } else if (ready.status().code() == StatusCode::kNotFound) {
      item["ready_version"] = nullptr;
      item["formats"] = nlohmann::json::array();
    } else {
      return StatusResponse(ready.status());
    }
    assets.push_back(std::move(item));
  }
  nlohmann::json body = {{"assets", std::move(assets)}, {"next_page_token", page->next_page_token}};
  HttpResponse r = JsonResponse(200, body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
  AddCaching(&r, false);
  return r;
}

HttpResponse AssetRoute::Export(const HttpRequest& request, const Principal& principal, const AssetRequest& file) {
  if (sessions_ != nullptr && file.format == ExportFormat::kProgressiveGlb && !file.lod) {
    // The stored file, from the hot artifacts sessions read: a lookup.
    auto hot = sessions_->HotFile(principal.tenant, file.asset, file.version);
    if (!hot.ok()) return StatusResponse(hot.status());
    if (hot->hot->bytes.size() > options_.max_export_bytes) {
      return StatusResponse(ResourceExhausted("the progressive file has " + std::to_string(hot->hot->bytes.size()) +
                                              " bytes, more than the server's limit of " +
                                              std::to_string(options_.max_export_bytes)));
    }
    const HotArtifacts::Entry& entry = hot->hot;
    return Serve(request, file, entry->sha256, hot->version.version,
                 std::shared_ptr<const std::vector<uint8_t>>(entry, &entry->bytes), true);
  }
  // Exports that decode hold a scene in memory: a few at a time, a slot of
  // the limit the gRPC service takes too. The stored file and the export
  // cache's hits take no slot.
  CallLimit::Slot waiting;
  CallLimit::Slot slot;
  const auto take_slot = [&]() -> Status {
    waiting = decode_requests_.Acquire(std::chrono::milliseconds(0));
    if (!waiting) return Unavailable("the server is busy with other exports; retry later");
    slot = exports_->Acquire(std::chrono::milliseconds(options_.export_wait_ms));
    if (!slot) return Unavailable("the server is busy with other exports; retry later");
    return Status::Ok();
  };
  auto exported = ExportVersion(*store_, principal.tenant, file.asset, file.version, file.format, file.lod,
                                options_.max_export_bytes, take_slot);
  slot = CallLimit::Slot();
  waiting = CallLimit::Slot();
  if (!exported.ok()) return StatusResponse(exported.status());
  return Serve(request, file, exported->sha256, exported->version.version,
               std::make_shared<const std::vector<uint8_t>>(std::move(exported->bytes)), false);
}

HttpResponse AssetRoute::Serve(const HttpRequest& request, const AssetRequest& file, const std::string& sha256,
                               int64_t resolved_version, std::shared_ptr<const std::vector<uint8_t>> bytes,
                               bool kept) {
  Representation rep;
  rep.bytes = std::move(bytes);
  rep.etag = StrongEntityTag(sha256);
  rep.content_type = InfoOf(file.format).content_type;
  HttpResponse caching;
  AddCaching(&caching, file.version != 0);
  if (file.version == 0) {
    caching.SetHeader("Content-Location", FileUrl(file.asset, resolved_version, file.format, file.lod));
  }
  rep.headers = std::move(caching.headers);
  HttpResponse r = ServeRepresentation(request, rep);
  rep.bytes.reset();
  if (!r.data || r.size == 0 || request.head()) return r;
  if (!kept && r.size < r.data->size()) {
    // A range keeps its slice only, not the whole file, while it is written.
    const auto begin = r.data->begin() + static_cast<std::ptrdiff_t>(r.offset);
    r.SetBody(std::make_shared<const std::vector<uint8_t>>(begin, begin + static_cast<std::ptrdiff_t>(r.size)), 0,
              r.size);
  }
  // Admitted when the bytes fit the budget, or when nothing else is held. A
  // kept file counts the bytes this response serves (the rest is the
  // cache's, bounded by it).
  const uint64_t n = kept ? r.size : r.data->size();
  uint64_t held = bytes_in_flight_->load();
  do {
    if (held != 0 && (held > options_.max_bytes_in_flight || n > options_.max_bytes_in_flight - held)) {
      return StatusResponse(Unavailable("the server holds " + std::to_string(held) +
                                        " bytes of responses that clients are still reading; retry later"));
    }
  } while (!bytes_in_flight_->compare_exchange_weak(held, held + n));
  std::shared_ptr<const std::vector<uint8_t>> data = std::move(r.data);
  const std::vector<uint8_t>* raw = data.get();
  r.data = std::shared_ptr<const std::vector<uint8_t>>(
      raw, [counter = bytes_in_flight_, data = std::move(data), n](const std::vector<uint8_t>*) mutable {
        data.reset();
        counter->fetch_sub(n);
      });
  return r;
}

}  // namespace meshstream
