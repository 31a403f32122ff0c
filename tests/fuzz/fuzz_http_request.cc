// libFuzzer target for the parsers of services/http/ that read what a client
// sends (every byte from the network): the Range header (byte_range.h),
// If-None-Match and If-Range (conditional.h) and the two together with a
// body (ServeRepresentation, representation.h), the request target's
// percent-decoding, segments and query (url.h), the file route's path
// (ParseAssetRequest, asset_route.h), the viewer's file paths
// (StaticRoute::Resolve and Handle on a temporary folder, static_route.h),
// the Origin against a CORS policy (cors.h) and the checks before the
// WebSocket upgrade (StreamSocketRoute::CheckRequest, stream_socket.h, called
// from http_upgrade_request.cc: see there why).
//
// Input: 10 bytes of control, then the rest split at every 0xFF into at most
// kPieces strings (missing ones are empty):
//   byte 0: bit 0 TLS; bits 1-5 the upgrade request carries Origin, Host,
//           Authorization, Sec-WebSocket-Protocol, a second
//           Sec-WebSocket-Protocol line; bit 6 that second line comes after
//           Host and Sec-WebSocket-Version (not next to the first); bit 7
//           HEAD instead of GET;
//   byte 1: bits 0-2 the request carries Range, If-None-Match, If-Range;
//           bits 3-4 the body size's class (below); bit 5 the entity tag
//           of piece 3 is weak; bit 6 the CORS origins are piece 5 (else a
//           fixed list); bit 7 Range is sent as two lines;
//   bytes 2-9: a uint64 (little endian), the body size: modulo 17, 4097,
//           2^32 or as it is by the class.
//   pieces: 0 Range, 1 the request target (path[?query]), 2 If-None-Match
//           and If-Range, 3 the opaque part of the entity tag, 4 the
//           request's Origin, 5 the CORS origins (split at ','), 6 Host,
//           7 Sec-WebSocket-Protocol, 8 Authorization, 9 the second
//           Sec-WebSocket-Protocol line.
//
// Invariants (a violation stops the fuzzer with __builtin_trap; nothing may
// throw, which libFuzzer reports as a crash on its own):
//   - ParseByteRange agrees with an independent implementation of the
//     rules of byte_range.h (kind and bounds), and a satisfiable range lies
//     within the body: first <= last < size;
//   - ServeRepresentation on a body of that size (up to 64 KiB): 304 exactly
//     when If-None-Match matches, else the Range is used only on GET and
//     when If-Range (if any) is our strong tag; a 206 is the bytes
//     [first, last] of the body with their Content-Range, a 416 says
//     `bytes */SIZE`, a 200 is the whole body;
//   - IfRangeMatches is "the header without surrounding blanks is our
//     strong tag"; IfRangeMatches implies IfNoneMatchMatches; a header that
//     matches names our opaque part in quotes (or is `*`); adding a valid
//     tag to a matching list keeps it matching; our own tag and `*` match
//     it;
//   - PercentDecode succeeds exactly when every '%' starts %XX, and then
//     gives one byte per escape; percent-encoding every byte decodes back;
//     PathSegments joined by '/' is the path; ParseQuery gives at most 16
//     parameters and re-encoded parameters parse back to themselves;
//   - ParseAssetRequest: NotFound exactly when the path is not of the
//     shape /v1/assets/_/versions/_/_, else InvalidArgument or a request
//     whose asset is a valid name (the decoded segment), version >= 0, lod
//     in 0..2^20 and not with progressive; the canonical path and query of
//     what it parsed parse to the same; every refusal's JSON body is UTF-8;
//   - StaticRoute::Resolve: only InvalidArgument or NotFound, and what it
//     accepts is a real path strictly inside the root (never the folder
//     beside it, behind a symbolic link or sharing its prefix), from a path
//     without '.', '..', empty segments, NUL, backslash or encoded '/';
//     Handle answers the status of Resolve's refusal, or the file's bytes
//     (whole or the range) with its content type;
//   - CorsPolicy::Make accepts exactly the origins its rules allow (written
//     again here); AllowedOrigin, Decorate and Preflight agree with them;
//   - CheckRequest agrees with an independent implementation of the checks
//     of stream_socket.h, reading every Sec-WebSocket-Protocol line of the
//     request (RFC 9110, 5.3: lines of a list field are one list), also
//     when another field came between them (beast keeps the lines of one
//     name together, which CheckRequest's loop relies on), on the values as
//     beast keeps them (without the blanks around them).
// The static route's folder is made once per process under /dev/shm (or
// $TMPDIR), removed at exit (and by later runs when a crash left it).
#include <limits.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "codec/core/status.h"
#include "codec/core/utf8.h"
#include "services/http/byte_range.h"
#include "services/http/conditional.h"
#include "services/http/cors.h"
#include "services/http/http_message.h"
#include "services/http/representation.h"
#include "services/http/url.h"
#include "services/http_routes/asset_route.h"
#include "services/http_routes/static_route.h"
#include "services/store/store.h"
#include "tests/fuzz/fuzz_service_util.h"
#include "tests/fuzz/http_upgrade_request.h"

namespace {

namespace fs = std::filesystem;
using meshstream::HttpRange;
using meshstream::HttpRequest;
using meshstream::HttpResponse;
using meshstream::Status;
using meshstream::StatusCode;

constexpr char kTarget[] = "fuzz_http_request";
[[noreturn]] void Bug(const std::string& what) { meshstream::fuzz::FuzzBug(kTarget, what); }
using meshstream::fuzz::RemoveStaleFolders;
using meshstream::fuzz::Shown;
using meshstream::fuzz::TempRoot;

constexpr size_t kMaxInputBytes = 8192;  // the server bounds a head to 16 KiB; pieces are a part of one
constexpr size_t kControlBytes = 10;
constexpr size_t kPieces = 10;
constexpr uint64_t kMaxServedBody = 64 * 1024;  // bodies ServeRepresentation is run on
constexpr uint64_t kMax = UINT64_MAX;

std::string Lower(std::string s) {
  for (char& c : s) {
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  }
  return s;
}

std::string TrimBlanks(std::string_view s) {
  size_t a = 0, b = s.size();
  while (a < b && (s[a] == ' ' || s[a] == '\t')) ++a;
  while (b > a && (s[b - 1] == ' ' || s[b - 1] == '\t')) --b;
  return std::string(s.substr(a, b - a));
}

std::vector<std::string> Split(const std::string& s, char separator) {
  std::vector<std::string> out(1);
  for (char c : s) {
    if (c == separator) {
      out.emplace_back();
    } else {
      out.back().push_back(c);
    }
  }
  return out;
}

bool IsHex(char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F'); }

// Every byte as %XX.
std::string EncodeAll(std::string_view s) {
  static const char kHex[] = "0123456789ABCDEF";
  std::string out;
  for (unsigned char c : s) {
    out.push_back('%');
    out.push_back(kHex[c >> 4]);
    out.push_back(kHex[c & 15]);
  }
  return out;
}

// Only what a query element cannot hold as it is: '%', '&', '=', '+' stays.
std::string EncodeQueryPart(std::string_view s) {
  std::string out;
  for (char c : s) {
    if (c == '%' || c == '&' || c == '=') {
      out += EncodeAll(std::string_view(&c, 1));
    } else {
      out.push_back(c);
    }
  }
  return out;
}

std::string ShowStatus(const Status& s) { return Shown(s.ToString()); }

void CheckErrorBody(const char* what, const HttpResponse& r) {
  const std::string_view body = r.body();
  if (body.empty() || body.front() != '{' || !meshstream::IsValidUtf8(body)) {
    Bug(std::string(what) + ": the error body is not UTF-8 JSON: " + Shown(std::string(body)));
  }
}

// --- Range -------------------------------------------------------------------

// A run of digits as a saturated uint64 (the rule of byte_range.h), by
// comparing the digits' text with 2^64 - 1 rather than by arithmetic.
std::optional<uint64_t> ReferenceDigits(const std::string& s) {
  if (s.empty() || s.find_first_not_of("0123456789") != std::string::npos) return std::nullopt;
  const size_t nonzero = s.find_first_not_of('0');
  if (nonzero == std::string::npos) return 0;
  const std::string digits = s.substr(nonzero);
  static const std::string kMaxText = std::to_string(kMax);
  if (digits.size() > kMaxText.size() || (digits.size() == kMaxText.size() && digits > kMaxText)) return kMax;
  return std::stoull(digits);
}

HttpRange ReferenceRange(const std::string& header, uint64_t size) {
  HttpRange whole, unsatisfiable, partial;
  unsatisfiable.kind = HttpRange::Kind::kUnsatisfiable;
  partial.kind = HttpRange::Kind::kPartial;
  const std::string h = TrimBlanks(header);
  const size_t equals = h.find('=');
  if (equals == std::string::npos || Lower(h.substr(0, equals)) != "bytes") return whole;
  std::vector<std::string> specs;
  for (const std::string& element : Split(h.substr(equals + 1), ',')) {
    const std::string spec = TrimBlanks(element);
    if (!spec.empty()) specs.push_back(spec);
  }
  if (specs.size() != 1) return whole;
  const std::string& spec = specs[0];
  const size_t dash = spec.find('-');
  if (dash == std::string::npos) return whole;
  const std::string a = spec.substr(0, dash), b = spec.substr(dash + 1);
  if (a.empty()) {
    const auto n = ReferenceDigits(b);
    if (!n) return whole;
    if (*n == 0) return unsatisfiable;
    if (size == 0) return whole;
    partial.first = *n >= size ? 0 : size - *n;
    partial.last = size - 1;
    return partial;
  }
  const auto first = ReferenceDigits(a);
  if (!first) return whole;
  std::optional<uint64_t> last;
  if (!b.empty()) {
    last = ReferenceDigits(b);
    if (!last || *last < *first) return whole;
  }
  if (*first >= size) return unsatisfiable;
  partial.first = *first;
  partial.last = last ? std::min(*last, size - 1) : size - 1;
  return partial;
}

const char* KindName(HttpRange::Kind k) {
  switch (k) {
    case HttpRange::Kind::kWhole: return "whole";
    case HttpRange::Kind::kPartial: return "partial";
    case HttpRange::Kind::kUnsatisfiable: return "unsatisfiable";
  }
  return "?";
}

std::string ShowRange(const HttpRange& r) {
  return std::string(KindName(r.kind)) + " " + std::to_string(r.first) + "-" + std::to_string(r.last);
}

HttpRange CheckRange(const std::string& header, uint64_t size) {
  const HttpRange r = meshstream::ParseByteRange(header, size);
  const HttpRange expected = ReferenceRange(header, size);
  const bool same = r.kind == expected.kind && (r.kind != HttpRange::Kind::kPartial ||
                                                (r.first == expected.first && r.last == expected.last));
  if (!same) {
    Bug("ParseByteRange('" + Shown(header) + "', " + std::to_string(size) + ") is " + ShowRange(r) + ", expected " +
        ShowRange(expected));
  }
  if (r.kind == HttpRange::Kind::kPartial) {
    if (!(r.first <= r.last && r.last < size) || r.length() != r.last - r.first + 1 || r.length() == 0) {
      Bug("ParseByteRange('" + Shown(header) + "', " + std::to_string(size) + ") is outside the body: " + ShowRange(r));
    }
  } else if (r.length() != 0) {
    Bug("a range that is not partial has a length");
  }
  return r;
}

// --- entity tags -------------------------------------------------------------

bool IsEtagChar(unsigned char c) { return c == 0x21 || (c >= 0x23 && c <= 0x7e) || c >= 0x80; }

bool ValidOpaque(const std::string& opaque) {
  for (unsigned char c : opaque) {
    if (!IsEtagChar(c)) return false;
  }
  return true;
}

void CheckConditional(const std::string& header, const std::string& opaque, bool weak) {
  const std::string etag = (weak ? "W/" : "") + meshstream::StrongEntityTag(opaque);
  if (meshstream::StrongEntityTag(opaque) != "\"" + opaque + "\"") Bug("StrongEntityTag does not quote");
  const bool valid = ValidOpaque(opaque);
  const bool inm = meshstream::IfNoneMatchMatches(header, etag);
  const bool if_range = meshstream::IfRangeMatches(header, etag);
  const std::string where = "header '" + Shown(header) + "' against tag '" + Shown(etag) + "'";

  const bool expected_range = valid && !weak && TrimBlanks(header) == etag;
  if (if_range != expected_range) Bug("IfRangeMatches of " + where + " is " + (if_range ? "true" : "false"));
  if (if_range && !inm) Bug("IfRangeMatches but not IfNoneMatchMatches: " + where);
  if (inm) {
    if (!valid) Bug("IfNoneMatchMatches a malformed tag: " + where);
    if (TrimBlanks(header) != "*" && header.find("\"" + opaque + "\"") == std::string::npos) {
      Bug("IfNoneMatchMatches with a header that does not name the tag: " + where);
    }
    if (TrimBlanks(header) != "*" && !meshstream::IfNoneMatchMatches(header + ", \"other\"", etag)) {
      Bug("a matching If-None-Match stops matching when a tag is added: " + where);
    }
  }
  if (valid) {
    if (!meshstream::IfNoneMatchMatches(etag, etag) || !meshstream::IfNoneMatchMatches(" * ", etag) ||
        !meshstream::IfNoneMatchMatches("\"x\", W/" + meshstream::StrongEntityTag(opaque), etag)) {
      Bug("IfNoneMatchMatches does not match our own tag '" + Shown(etag) + "'");
    }
    if (!weak && !meshstream::IfRangeMatches("\t" + etag + " ", etag)) {
      Bug("IfRangeMatches does not match our own tag '" + Shown(etag) + "'");
    }
    if (meshstream::IfRangeMatches("W/" + meshstream::StrongEntityTag(opaque), etag)) {
      Bug("IfRangeMatches takes a weak tag");
    }
  }
}

// --- a representation served -------------------------------------------------

void CheckServe(const HttpRequest& request, uint64_t size) {
  if (size > kMaxServedBody) return;
  static const std::vector<uint8_t> pattern = [] {
    std::vector<uint8_t> p(kMaxServedBody);
    for (size_t i = 0; i < p.size(); ++i) p[i] = static_cast<uint8_t>(i * 31 + (i >> 8) + 7);
    return p;
  }();
  meshstream::Representation rep;
  rep.bytes = std::make_shared<const std::vector<uint8_t>>(pattern.begin(), pattern.begin() + size);
  rep.etag = meshstream::StrongEntityTag("0123abcd");
  rep.content_type = "model/gltf-binary";
  rep.headers = {{"Cache-Control", "no-cache"}};
  const HttpResponse r = meshstream::ServeRepresentation(request, rep);

  const auto inm = request.Header("if-none-match");
  const auto range = request.Header("range");
  const auto if_range = request.Header("if-range");
  const std::string what = std::string(request.method) + " of " + std::to_string(size) + " bytes with Range '" +
                           Shown(range.value_or("(none)")) + "', If-None-Match '" + Shown(inm.value_or("(none)")) +
                           "', If-Range '" + Shown(if_range.value_or("(none)")) + "'";
  if (inm && meshstream::IfNoneMatchMatches(*inm, rep.etag)) {
    if (r.status != 304 || r.data != nullptr || r.Header("ETag") != rep.etag) Bug(what + ": not a 304");
    return;
  }
  HttpRange expected;
  if (request.method == "GET" && range && (!if_range || meshstream::IfRangeMatches(*if_range, rep.etag))) {
    expected = meshstream::ParseByteRange(*range, size);
  }
  const std::string status = ": status " + std::to_string(r.status);
  switch (expected.kind) {
    case HttpRange::Kind::kUnsatisfiable:
      if (r.status != 416 || r.Header("Content-Range") != "bytes */" + std::to_string(size)) Bug(what + status);
      CheckErrorBody("416", r);
      return;
    case HttpRange::Kind::kPartial: {
      const std::string content_range = "bytes " + std::to_string(expected.first) + "-" +
                                        std::to_string(expected.last) + "/" + std::to_string(size);
      if (r.status != 206 || r.Header("Content-Range") != content_range) Bug(what + status);
      break;
    }
    case HttpRange::Kind::kWhole:
      if (r.status != 200 || r.Header("Content-Range")) Bug(what + status);
      break;
  }
  if (r.data != rep.bytes || r.offset > size || r.size > size - r.offset) Bug(what + ": the body is not in the bytes");
  const uint64_t first = expected.kind == HttpRange::Kind::kPartial ? expected.first : 0;
  const uint64_t length = expected.kind == HttpRange::Kind::kPartial ? expected.length() : size;
  if (r.offset != first || r.size != length) Bug(what + ": the body is not the range");
  if (r.Header("ETag") != rep.etag || r.Header("Accept-Ranges") != "bytes" ||
      r.Header("Content-Type") != rep.content_type || r.Header("Cache-Control") != "no-cache") {
    Bug(what + ": a header is missing");
  }
}

// --- the request target ------------------------------------------------------

void CheckUrl(const std::string& path, const std::string& query) {
  // PercentDecode.
  bool decodable = true;
  size_t escapes = 0;
  for (size_t i = 0; i < path.size(); ++i) {
    if (path[i] != '%') continue;
    if (i + 2 >= path.size() || !IsHex(path[i + 1]) || !IsHex(path[i + 2])) {
      decodable = false;
      break;
    }
    ++escapes;
    i += 2;
  }
  auto decoded = meshstream::PercentDecode("path", path);
  if (decoded.ok() != decodable) {
    Bug("PercentDecode('" + Shown(path) + "') is " + (decoded.ok() ? "OK" : ShowStatus(decoded.status())));
  }
  if (decoded.ok()) {
    if (decoded->size() != path.size() - 2 * escapes) Bug("PercentDecode gave the wrong number of bytes");
    auto again = meshstream::PercentDecode("path", EncodeAll(decoded.value()));
    if (!again.ok() || again.value() != decoded.value()) Bug("percent-encoding then decoding changes the bytes");
  } else if (decoded.status().code() != StatusCode::kInvalidArgument || decoded.status().message().empty()) {
    Bug("PercentDecode refused with " + ShowStatus(decoded.status()));
  }

  // PathSegments.
  const std::vector<std::string_view> segments = meshstream::PathSegments(path);
  std::string joined;
  for (size_t i = 0; i < segments.size(); ++i) joined += (i ? "/" : "") + std::string(segments[i]);
  const std::string stripped = !path.empty() && path[0] == '/' ? path.substr(1) : path;
  if (joined != stripped || segments.empty()) Bug("PathSegments('" + Shown(path) + "') does not join to the path");

  // ParseQuery.
  auto params = meshstream::ParseQuery(query);
  if (!params.ok()) {
    if (params.status().code() != StatusCode::kInvalidArgument || params.status().message().empty()) {
      Bug("ParseQuery refused with " + ShowStatus(params.status()));
    }
    return;
  }
  if (params->size() > meshstream::kMaxQueryParameters) Bug("ParseQuery gave more than 16 parameters");
  std::string rebuilt;
  for (const auto& [name, value] : params.value()) {
    rebuilt += (rebuilt.empty() ? "" : "&") + EncodeQueryPart(name) + "=" + EncodeQueryPart(value);
  }
  auto back = meshstream::ParseQuery(rebuilt);
  if (!back.ok()) {
    // An element "=" (empty name, empty value) is kept; re-encoded it is "=" again.
    Bug("query '" + Shown(query) + "' re-encoded as '" + Shown(rebuilt) + "' is refused: " + ShowStatus(back.status()));
  }
  if (back.value() != params.value()) Bug("query '" + Shown(query) + "' re-encoded parses to other parameters");
}

const char* FormatName(meshstream::ExportFormat f) {
  switch (f) {
    case meshstream::ExportFormat::kGlb: return "glb";
    case meshstream::ExportFormat::kDracoGlb: return "draco";
    case meshstream::ExportFormat::kProgressiveGlb: return "progressive";
    case meshstream::ExportFormat::kObj: return "obj";
    case meshstream::ExportFormat::kPly: return "ply";
  }
  return "?";
}

void CheckAssetRequest(const std::string& path, const std::string& query) {
  auto parsed = meshstream::ParseAssetRequest(path, query);
  const std::vector<std::string_view> s = meshstream::PathSegments(path);
  const bool shape = s.size() == 6 && s[0] == "v1" && s[1] == "assets" && s[3] == "versions";
  const std::string what = "ParseAssetRequest('" + Shown(path) + "', '" + Shown(query) + "')";
  if (!parsed.ok()) {
    const StatusCode code = parsed.status().code();
    if (code != (shape ? StatusCode::kInvalidArgument : StatusCode::kNotFound) || parsed.status().message().empty()) {
      Bug(what + " is " + ShowStatus(parsed.status()));
    }
    CheckErrorBody("ParseAssetRequest", meshstream::StatusResponse(parsed.status()));
    return;
  }
  if (!shape) Bug(what + " accepted a path of another shape");
  const meshstream::AssetRequest& r = parsed.value();
  auto asset = meshstream::PercentDecode("asset", s[2]);
  if (!asset.ok() || asset.value() != r.asset || !meshstream::IsValidName(r.asset)) {
    Bug(what + " gave asset '" + Shown(r.asset) + "'");
  }
  if (r.version < 0 || (r.version == 0) != (s[4] == "latest") ||
      (r.version > 0 && std::to_string(r.version) != s[4])) {
    Bug(what + " gave version " + std::to_string(r.version));
  }
  if (s[5] != FormatName(r.format)) Bug(what + " gave another format");
  if (r.lod && (*r.lod < 0 || *r.lod > (1 << 20) || r.format == meshstream::ExportFormat::kProgressiveGlb)) {
    Bug(what + " gave lod " + std::to_string(*r.lod));
  }
  const std::string canonical = "/v1/assets/" + r.asset + "/versions/" +
                                (r.version ? std::to_string(r.version) : std::string("latest")) + "/" +
                                FormatName(r.format);
  auto again = meshstream::ParseAssetRequest(canonical, r.lod ? "lod=" + std::to_string(*r.lod) : "");
  if (!again.ok() || again->asset != r.asset || again->version != r.version || again->format != r.format ||
      again->lod != r.lod) {
    Bug(what + ": its canonical path '" + canonical + "' parses to something else");
  }
}

// --- the viewer's files ------------------------------------------------------

struct Fixture {
  std::string dir;
  std::string outside;
  std::unique_ptr<meshstream::StaticRoute> route;
};

Fixture* fixture = nullptr;

void RemoveFixture() {
  if (fixture == nullptr) return;
  std::error_code ec;
  fs::remove_all(fixture->dir, ec);
}

void WriteFile(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  if (!out) Bug("cannot write " + path);
}

// <dir>/web is the root; beside it <dir>/outside and <dir>/web-other (a
// folder whose name the root's is a prefix of), reached from inside the root
// by symbolic links; in it, hidden files, a file above the size limit and
// links that stay inside.
Fixture& GetFixture() {
  if (fixture != nullptr) return *fixture;
  const std::string root = TempRoot();
  const std::string prefix = std::string("meshstream-") + kTarget + "-";
  RemoveStaleFolders(root, prefix);
  fixture = new Fixture;
  fixture->dir = root + "/" + prefix + std::to_string(getpid());
  std::error_code ec;
  fs::remove_all(fixture->dir, ec);
  const std::string web = fixture->dir + "/web";
  fixture->outside = fixture->dir + "/outside";
  for (const std::string& d : {web, web + "/sub", web + "/sub/.hidden", web + "/js", fixture->outside,
                               fixture->dir + "/web-other"}) {
    fs::create_directories(d, ec);
    if (ec) Bug("cannot create " + d + ": " + ec.message());
  }
  std::atexit(RemoveFixture);
  WriteFile(web + "/index.html", "<!doctype html><title>viewer</title>\n");
  WriteFile(web + "/js/app.mjs", "export const answer = 42;\n");
  WriteFile(web + "/sub/index.html", "<p>sub</p>\n");
  WriteFile(web + "/sub/style.css", "body { margin: 0 }\n");
  WriteFile(web + "/sub/.hidden/x.txt", "hidden\n");
  WriteFile(web + "/.secret", "secret inside\n");
  WriteFile(web + "/A b%.TXT", "odd name\n");
  WriteFile(web + "/big.bin", std::string(5000, 'x'));
  WriteFile(fixture->outside + "/secret.txt", "secret outside\n");
  WriteFile(fixture->dir + "/web-other/secret.txt", "secret beside\n");
  WriteFile(fixture->dir + "/index.html", "the parent's index\n");
  const std::pair<std::string, std::string> links[] = {
      {fixture->outside + "/secret.txt", web + "/escape.txt"},
      {fixture->dir, web + "/up"},
      {"../web-other", web + "/other"},
      {"../web-other/secret.txt", web + "/other.txt"},
      {"/", web + "/fsroot"},
      {web + "/js/app.mjs", web + "/inside.mjs"},
      {".", web + "/self"},
      {"sub", web + "/sub-link"},
      {"missing", web + "/dangling"},
  };
  for (const auto& [target, link] : links) {
    if (symlink(target.c_str(), link.c_str()) != 0) Bug("cannot link " + link);
  }
  auto route = meshstream::StaticRoute::Open(web, {}, 4096);
  if (!route.ok()) Bug("cannot open the static route: " + route.status().ToString());
  fixture->route = std::move(route).value();
  return *fixture;
}

std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void CheckStatic(const HttpRequest& request) {
  Fixture& f = GetFixture();
  const std::string& root = f.route->root();
  const std::string& path = request.path;
  auto real = f.route->Resolve(path);
  const std::string what = "Resolve('" + Shown(path) + "')";
  if (!real.ok()) {
    const StatusCode code = real.status().code();
    if ((code != StatusCode::kInvalidArgument && code != StatusCode::kNotFound) || real.status().message().empty()) {
      Bug(what + " is " + ShowStatus(real.status()));
    }
  } else {
    const std::string& r = real.value();
    if (r.size() <= root.size() + 1 || r.compare(0, root.size() + 1, root + "/") != 0) {
      Bug(what + " is outside the root: " + Shown(r));
    }
    char buffer[PATH_MAX];
    if (realpath(r.c_str(), buffer) == nullptr || r != buffer) Bug(what + " is not a real path: " + Shown(r));
    // What was accepted, decoded: no '.', '..' or empty segment (but a
    // trailing '/'), no NUL or backslash, and no encoded '/', '\' or NUL.
    auto decoded = meshstream::PercentDecode("path", path);
    if (!decoded.ok() || path.empty() || path[0] != '/') Bug(what + " accepted a path that does not decode");
    if (decoded->find('\0') != std::string::npos || decoded->find('\\') != std::string::npos) {
      Bug(what + " accepted a NUL or a backslash");
    }
    const std::string lower = Lower(path);
    if (lower.find("%2f") != std::string::npos || lower.find("%5c") != std::string::npos ||
        lower.find("%00") != std::string::npos) {
      Bug(what + " accepted an encoded '/', '\\' or NUL");
    }
    const std::vector<std::string_view> segments = meshstream::PathSegments(decoded.value());
    for (size_t i = 0; i < segments.size(); ++i) {
      if ((segments[i].empty() && i + 1 != segments.size()) || segments[i] == "." || segments[i] == ".." ||
          (!segments[i].empty() && segments[i][0] == '.')) {
        Bug(what + " accepted segment '" + Shown(std::string(segments[i])) + "'");
      }
    }
  }

  const HttpResponse response = f.route->Handle(request);
  const std::string handled = "Handle(" + request.method + " '" + Shown(path) + "')";
  if (!real.ok()) {
    if (response.status != meshstream::HttpStatusOf(real.status().code())) {
      Bug(handled + " is " + std::to_string(response.status) + " where Resolve said " + ShowStatus(real.status()));
    }
    CheckErrorBody("StaticRoute::Handle", response);
    return;
  }
  struct stat st {};
  if (stat(real->c_str(), &st) != 0) Bug(handled + ": the file resolved is gone");
  if (!S_ISREG(st.st_mode) || st.st_size > 4096) {
    if (response.status != 404 && response.status != 500) Bug(handled + " is " + std::to_string(response.status));
    CheckErrorBody("StaticRoute::Handle", response);
    return;
  }
  if (response.status == 304 || response.status == 416) return;  // CheckServe judges these
  if (response.status != 200 && response.status != 206) Bug(handled + " is " + std::to_string(response.status));
  const std::string bytes = ReadAll(real.value());
  if (response.body() != std::string_view(bytes).substr(response.offset, response.size) ||
      (response.status == 200 && response.size != bytes.size())) {
    Bug(handled + ": the body is not the file's");
  }
  if (response.Header("Content-Type") != meshstream::StaticContentType(real.value())) {
    Bug(handled + ": the content type is not the file's");
  }
}

// --- CORS --------------------------------------------------------------------

bool ReferenceOriginOk(const std::string& origin) {
  if (origin == "*") return true;
  const std::string o = Lower(origin);
  if (o == "null") return false;
  size_t host = 0;
  if (o.rfind("http://", 0) == 0) {
    host = 7;
  } else if (o.rfind("https://", 0) == 0) {
    host = 8;
  } else {
    return false;
  }
  if (o.size() == host) return false;
  return o.find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789.-:[]_", host) == std::string::npos;
}

struct Cors {
  meshstream::CorsPolicy policy;
  bool any = false;
  std::vector<std::string> lowered;
};

Cors MakeCors(const std::vector<std::string>& origins) {
  Cors c;
  auto made = meshstream::CorsPolicy::Make(origins);
  bool expected = true;
  for (const std::string& o : origins) expected = expected && ReferenceOriginOk(o);
  std::string shown;
  for (const std::string& o : origins) shown += "'" + Shown(o) + "' ";
  if (made.ok() != expected) Bug("CorsPolicy::Make(" + shown + ") is " + (made.ok() ? "OK" : ShowStatus(made.status())));
  if (!made.ok()) {
    if (made.status().code() != StatusCode::kInvalidArgument) Bug("CorsPolicy::Make refused with another code");
    return c;
  }
  c.policy = std::move(made).value();
  for (const std::string& o : origins) {
    if (o == "*") {
      c.any = true;
    } else {
      c.lowered.push_back(Lower(o));
    }
  }
  if (c.policy.allows_any() != c.any || c.policy.enabled() != (c.any || !c.lowered.empty())) {
    Bug("CorsPolicy::Make(" + shown + ") is not enabled as it should");
  }
  return c;
}

std::optional<std::string> ReferenceAllowed(const Cors& c, const std::optional<std::string>& origin) {
  if (!origin || origin->empty()) return std::nullopt;
  if (c.any) return std::string("*");
  for (const std::string& o : c.lowered) {
    if (o == Lower(*origin)) return *origin;
  }
  return std::nullopt;
}

void CheckCors(const Cors& c, const HttpRequest& request) {
  const auto origin = request.Header("origin");
  const auto allowed = c.policy.AllowedOrigin(origin);
  if (allowed != ReferenceAllowed(c, origin)) {
    Bug("AllowedOrigin('" + Shown(origin.value_or("(none)")) + "') is '" + Shown(allowed.value_or("(none)")) + "'");
  }
  if (c.policy.AllowedOrigin(std::nullopt)) Bug("AllowedOrigin allows a request without Origin");
  HttpResponse decorated;
  c.policy.Decorate(request, &decorated);
  const HttpResponse preflight = c.policy.Preflight(request);
  if (preflight.status != 204) Bug("a preflight is not 204");
  for (const HttpResponse* r : {static_cast<const HttpResponse*>(&decorated), &preflight}) {
    if (r->Header("Vary") != (c.policy.enabled() ? std::optional<std::string>("Origin") : std::nullopt)) {
      Bug("Vary: Origin is wrong for origin '" + Shown(origin.value_or("(none)")) + "'");
    }
    if (r->Header("Access-Control-Allow-Origin") != allowed) {
      Bug("Access-Control-Allow-Origin is wrong for origin '" + Shown(origin.value_or("(none)")) + "'");
    }
    if (r->Header("Access-Control-Allow-Credentials")) Bug("credentials are allowed");
  }
}

// --- the WebSocket upgrade ---------------------------------------------------

using meshstream::fuzz::UpgradeFields;

// beast keeps a field's value without the blanks around it (as its parser
// hands it over), so CheckRequest sees the values trimmed.
std::optional<std::string> Trimmed(const std::optional<std::string>& v) {
  if (!v) return std::nullopt;
  return TrimBlanks(*v);
}

void CheckUpgrade(const UpgradeFields& fields, const Cors& c) {
  UpgradeFields u = fields;
  u.origin = Trimmed(u.origin);
  u.host = Trimmed(u.host);
  u.authorization = Trimmed(u.authorization);
  for (std::string& line : u.protocols) line = TrimBlanks(line);
  int http_status = -1;
  bool offered_subprotocol = true;
  auto result = meshstream::fuzz::CheckUpgradeRequest(fields, c.policy, &http_status, &offered_subprotocol);
  std::string what = "CheckRequest(Origin '" + Shown(u.origin.value_or("(none)")) + "', Host '" +
                     Shown(u.host.value_or("(none)")) + "', Authorization '" +
                     Shown(u.authorization.value_or("(none)")) + "', protocols";
  for (const std::string& p : u.protocols) what += " '" + Shown(p) + "'";
  what += std::string(u.split ? " (apart)" : "") + (u.tls ? ", TLS)" : ")");

  // The origin: this server's own, or one of the CORS list.
  if (u.origin) {
    const std::string own = u.host ? Lower((u.tls ? "https://" : "http://") + *u.host) : "";
    const bool same_origin = !own.empty() && Lower(*u.origin) == own;  // no Host: no origin is our own
    if (!same_origin && !ReferenceAllowed(c, *u.origin)) {
      if (result.ok() || result.status().code() != StatusCode::kPermissionDenied || http_status != 403) {
        Bug(what + " is " + (result.ok() ? "OK" : ShowStatus(result.status())) + ", expected 403");
      }
      return;
    }
  }
  // The subprotocols: every item of every line.
  bool offered = false, ours = false;
  std::string token;
  for (const std::string& line : u.protocols) {
    for (const std::string& element : Split(line, ',')) {
      const std::string item = TrimBlanks(element);
      if (item.empty()) continue;
      offered = true;
      if (item == meshstream::fuzz::kUpgradeSubprotocol) ours = true;
      if (item.rfind("bearer.", 0) == 0) token = item.substr(7);
    }
  }
  if (offered && !ours) {
    if (result.ok() || result.status().code() != StatusCode::kInvalidArgument || http_status != 400) {
      Bug(what + " is " + (result.ok() ? "OK" : ShowStatus(result.status())) + ", expected 400");
    }
    return;
  }
  if (!result.ok()) Bug(what + " is " + ShowStatus(result.status()) + ", expected OK");
  if (http_status != -1) Bug(what + " set an HTTP status on success");
  if (offered_subprotocol != offered) Bug(what + ": offered_subprotocol is wrong");
  const std::string expected = u.authorization ? *u.authorization : token.empty() ? "" : "Bearer " + token;
  if (result.value() != expected) Bug(what + " gave token '" + Shown(result.value()) + "', expected '" +
                                      Shown(expected) + "'");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < kControlBytes || size > kMaxInputBytes) return 0;
  const uint8_t upgrade_bits = data[0], request_bits = data[1];
  uint64_t raw = 0;
  for (int i = 0; i < 8; ++i) raw |= uint64_t{data[2 + i]} << (8 * i);
  uint64_t body_size = raw;
  switch ((request_bits >> 3) & 3) {
    case 0: body_size = raw % 17; break;
    case 1: body_size = raw % 4097; break;
    case 2: body_size = raw % (uint64_t{1} << 32); break;
    default: break;
  }
  std::vector<std::string> p(1);
  for (size_t i = kControlBytes; i < size; ++i) {
    if (data[i] == 0xFF && p.size() < kPieces) {
      p.emplace_back();
    } else {
      p.back().push_back(static_cast<char>(data[i]));
    }
  }
  p.resize(kPieces);

  // The Range header, then the entity tags.
  CheckRange(p[0], body_size);
  CheckRange(p[0], 0);
  CheckRange(p[0], kMax);
  CheckConditional(p[2], p[3], request_bits & 0x20);

  // The request as the server's parser hands it to a route.
  HttpRequest request;
  request.method = upgrade_bits & 0x80 ? "HEAD" : "GET";
  request.target = p[1];
  const size_t question = p[1].find('?');
  request.path = p[1].substr(0, question);
  request.query = question == std::string::npos ? "" : p[1].substr(question + 1);
  if (request_bits & 1) {
    request.headers.emplace_back("range", p[0]);
    if (request_bits & 0x80) request.headers.emplace_back("range", "bytes=0-0");
  }
  if (request_bits & 2) request.headers.emplace_back("if-none-match", p[2]);
  if (request_bits & 4) request.headers.emplace_back("if-range", p[2]);
  if (upgrade_bits & 2) request.headers.emplace_back("origin", p[4]);
  CheckServe(request, body_size);

  CheckUrl(request.path, request.query);
  CheckAssetRequest(request.path, request.query);
  CheckStatic(request);

  static const std::vector<std::string> kDefaultOrigins = {"https://viewer.example", "http://localhost:7680"};
  const Cors cors = MakeCors(request_bits & 0x40 ? Split(p[5], ',') : kDefaultOrigins);
  CheckCors(cors, request);

  UpgradeFields u;
  u.tls = upgrade_bits & 1;
  if (upgrade_bits & 2) u.origin = p[4];
  if (upgrade_bits & 4) u.host = p[6];
  if (upgrade_bits & 8) u.authorization = p[8];
  if (upgrade_bits & 16) {
    u.protocols.push_back(p[7]);
    if (upgrade_bits & 32) u.protocols.push_back(p[9]);
  }
  u.split = upgrade_bits & 64;
  CheckUpgrade(u, cors);
  return 0;
}
