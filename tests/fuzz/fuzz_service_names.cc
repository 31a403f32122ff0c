// libFuzzer target for the small parsers of untrusted strings of the asset
// service: resource names, main file names and asset, tenant and upload
// names (CheckResourceName, CheckMainFilename, IsValidName, CheckName in
// proto/api_names.h), the encode options' JSON (ParseSettingsJson,
// ResolveSettings in services/pipeline/encode_options.h) and the
// authorization header (Authenticator::Authenticate, services/auth/).
//
// Input: the bytes split at every 0xFF (a byte that no valid UTF-8 holds, so
// the separator costs the names nothing) into at most kMaxPieces strings;
// every string goes through every check. The first 21 bytes, when there are
// that many, are also an EncodeSettings for ResolveSettings (qp, qn, qt as
// int32, packet_bytes as uint32, then 4 bytes and byte 20 for base_ratio and
// the packing).
//
// Invariants (a violation stops the fuzzer with __builtin_trap):
//   - an accepted resource name is a relative path that stays inside the
//     upload: non-empty, at most kMaxResourceNameBytes, valid UTF-8, no
//     control character or backslash, not starting with '/' or a drive
//     letter, no empty, "." or ".." segment, and /base/<name> lexically
//     normalised still lies strictly under /base/; the checker agrees with an
//     independent implementation of those rules both ways;
//   - an accepted main file name is an accepted resource name without '/',
//     at most kMaxMainFilenameBytes, with one of the six extensions;
//   - every refusal is InvalidArgument with a message that is valid UTF-8
//     without control characters (the name is quoted made printable);
//     PrintableName always gives such text;
//   - IsValidName is [A-Za-z0-9._-]{1,128} but "." and "..", and CheckName agrees with it;
//   - settings that parse are resolved (every field in range, ResolveSettings
//     returns them unchanged), and CanonicalJson of them parses back to
//     them; settings that resolve do the same;
//   - with authentication on, over a real SqliteStore (opened once in a
//     per-process temporary folder, removed at exit) holding a read-write
//     token, a read-only one and a revoked one: a header authenticates only
//     when it is exactly "Bearer " and one of the two live tokens, as that
//     token's tenant and rights; every other header is Unauthenticated, and a
//     well-formed token that is unknown gets the same message as the revoked
//     one; with authentication off every header is the default tenant.
#include <signal.h>
#include <sys/types.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "codec/bitstream/format.h"
#include "codec/core/status.h"
#include "codec/core/utf8.h"
#include "codec/mesh/quantization.h"
#include "proto/api_names.h"
#include "services/auth/api_token.h"
#include "services/auth/authenticator.h"
#include "services/pipeline/encode_options.h"
#include "services/store/sqlite_store.h"
#include "services/store/store.h"
#include "tests/fuzz/fuzz_service_util.h"

namespace {

namespace fs = std::filesystem;
using meshstream::Status;
using meshstream::StatusCode;

constexpr char kTarget[] = "fuzz_service_names";
[[noreturn]] void Bug(const std::string& what) { meshstream::fuzz::FuzzBug(kTarget, what); }
using meshstream::fuzz::Shown;
using meshstream::fuzz::TempRoot;
using meshstream::fuzz::RemoveStaleFolders;
constexpr size_t kMaxInputBytes = 8192;
constexpr size_t kMaxPieces = 8;

// The tokens of the store (fixed, so runs are reproducible; never used anywhere else).
const std::string kReadWriteToken = "mst_0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef";
const std::string kReadOnlyToken = "mst_fedcba9876543210fedcba9876543210fedcba9876543210fedcba9876543210";
const std::string kRevokedToken = "mst_00112233445566778899aabbccddeeff00112233445566778899aabbccddeeff";
constexpr char kReadWriteTenant[] = "fuzz-rw";
constexpr char kReadOnlyTenant[] = "fuzz-ro";

bool IsControl(unsigned char c) { return c < 0x20 || c == 0x7f; }

bool Printable(const std::string& s) {
  if (!meshstream::IsValidUtf8(s)) return false;
  for (unsigned char c : s) {
    if (IsControl(c)) return false;
  }
  return true;
}

void CheckRefusal(const char* what, const Status& status, const std::string& input) {
  if (status.code() != StatusCode::kInvalidArgument) {
    Bug(std::string(what) + " of '" + Shown(input) + "' failed with " + status.ToString());
  }
  if (status.message().empty() || !Printable(status.message())) {
    Bug(std::string(what) + " of '" + Shown(input) + "': the message is empty or not printable: " +
        Shown(status.message()));
  }
}

// --- the temporary store ---------------------------------------------------

struct Fixture {
  std::string dir;
  std::unique_ptr<meshstream::SqliteStore> store;
  std::unique_ptr<meshstream::Authenticator> on;
  std::unique_ptr<meshstream::Authenticator> off;
  std::string unknown_message;  // what a revoked token gets
};

Fixture* fixture = nullptr;

void RemoveFixture() {
  if (fixture == nullptr) return;
  fixture->on.reset();
  fixture->off.reset();
  fixture->store.reset();
  std::error_code ec;
  fs::remove_all(fixture->dir, ec);
}

Fixture& GetFixture() {
  if (fixture != nullptr) return *fixture;
  const std::string root = TempRoot();
  const std::string prefix = std::string("meshstream-") + kTarget + "-";
  RemoveStaleFolders(root, prefix);
  fixture = new Fixture;
  fixture->dir = root + "/" + prefix + std::to_string(getpid());
  std::error_code ec;
  fs::remove_all(fixture->dir, ec);
  auto store = meshstream::SqliteStore::Open(fixture->dir);
  if (!store.ok()) Bug("cannot open the store in " + fixture->dir + ": " + store.status().ToString());
  fixture->store = std::move(store).value();
  std::atexit(RemoveFixture);
  auto rw = fixture->store->CreateToken(kReadWriteTenant, false, meshstream::HashApiToken(kReadWriteToken));
  auto ro = fixture->store->CreateToken(kReadOnlyTenant, true, meshstream::HashApiToken(kReadOnlyToken));
  auto revoked = fixture->store->CreateToken("fuzz-revoked", false, meshstream::HashApiToken(kRevokedToken));
  if (!rw.ok() || !ro.ok() || !revoked.ok()) Bug("cannot create the tokens");
  if (!fixture->store->RevokeToken(revoked->id).ok()) Bug("cannot revoke a token");
  fixture->on = std::make_unique<meshstream::Authenticator>(fixture->store.get(), true);
  fixture->off = std::make_unique<meshstream::Authenticator>(fixture->store.get(), false);
  auto refused = fixture->on->Authenticate("Bearer " + kRevokedToken);
  if (refused.ok() || refused.status().code() != StatusCode::kUnauthenticated) Bug("a revoked token authenticates");
  fixture->unknown_message = refused.status().message();
  return *fixture;
}

// --- names -------------------------------------------------------------------

// The rules of proto/api_names.h, written again.
bool ExpectedResourceName(const std::string& n, size_t max_bytes) {
  if (n.empty() || n.size() > max_bytes || !meshstream::IsValidUtf8(n)) return false;
  for (unsigned char c : n) {
    if (IsControl(c) || c == '\\') return false;
  }
  if (n[0] == '/') return false;
  if (n.size() >= 2 && n[1] == ':' && ((n[0] >= 'A' && n[0] <= 'Z') || (n[0] >= 'a' && n[0] <= 'z'))) return false;
  size_t start = 0;
  for (;;) {
    const size_t slash = n.find('/', start);
    const std::string segment = n.substr(start, slash == std::string::npos ? std::string::npos : slash - start);
    if (segment.empty() || segment == "." || segment == "..") return false;
    if (slash == std::string::npos) return true;
    start = slash + 1;
  }
}

void CheckResourceName(const std::string& name) {
  const Status s = meshstream::CheckResourceName(name);
  const bool expected = ExpectedResourceName(name, meshstream::kMaxResourceNameBytes);
  if (s.ok() != expected) {
    Bug("CheckResourceName('" + Shown(name) + "') is " + (s.ok() ? "OK" : s.ToString()) + ", expected " +
        (expected ? "OK" : "a refusal"));
  }
  if (!s.ok()) {
    CheckRefusal("CheckResourceName", s, name);
    if (s.message().compare(0, 15, "resource name '") != 0) Bug("a resource name refusal does not say what it is");
    return;
  }
  // What the materializer does with it: <work folder>/<name>.
  const fs::path base = "/work-folder";
  const std::string joined = (base / name).lexically_normal().string();
  if (joined.compare(0, base.string().size() + 1, base.string() + "/") != 0 || joined.size() <= base.string().size() + 1) {
    Bug("accepted resource name '" + Shown(name) + "' leaves its folder: " + Shown(joined));
  }
  if (name.find("..") != std::string::npos) {
    // Allowed inside a segment ("a..b"), never as one.
    if (name == ".." || name.compare(0, 3, "../") == 0 || name.find("/../") != std::string::npos ||
        (name.size() >= 3 && name.compare(name.size() - 3, 3, "/..") == 0)) {
      Bug("accepted resource name '" + Shown(name) + "' has a '..' segment");
    }
  }
  if (name.find("//") != std::string::npos || name.back() == '/') Bug("accepted resource name has an empty segment");
}

void CheckMainFilename(const std::string& name) {
  const Status s = meshstream::CheckMainFilename(name);
  if (!s.ok()) {
    CheckRefusal("CheckMainFilename", s, name);
    if (s.message().compare(0, 10, "filename '") != 0) Bug("a filename refusal does not say what it is");
    return;
  }
  if (!ExpectedResourceName(name, meshstream::kMaxMainFilenameBytes) || name.find('/') != std::string::npos) {
    Bug("accepted main file name '" + Shown(name) + "' is not a plain file name");
  }
  if (!meshstream::CheckResourceName(name).ok()) Bug("accepted main file name is not a valid resource name");
  const size_t dot = name.find_last_of('.');
  std::string ext = dot == std::string::npos ? "" : name.substr(dot);
  for (char& c : ext) {
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  }
  if (ext != ".gltf" && ext != ".glb" && ext != ".obj" && ext != ".ply" && ext != ".off" && ext != ".stl") {
    Bug("accepted main file name '" + Shown(name) + "' has extension '" + Shown(ext) + "'");
  }
}

void CheckNames(const std::string& name) {
  bool expected = !name.empty() && name.size() <= 128 && name != "." && name != "..";
  for (const char c : name) {
    expected = expected && ((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '.' ||
                            c == '_' || c == '-');
  }
  if (meshstream::IsValidName(name) != expected) Bug("IsValidName('" + Shown(name) + "') is wrong");
  const Status s = meshstream::CheckName("asset", name);
  if (s.ok() != expected) Bug("CheckName and IsValidName disagree on '" + Shown(name) + "'");
  if (!s.ok()) CheckRefusal("CheckName", s, name);
  const std::string shown = meshstream::PrintableName(name);
  if (!Printable(shown)) Bug("PrintableName('" + Shown(name) + "') is not printable: " + Shown(shown));
}

// --- encode settings ---------------------------------------------------------

void CheckResolved(const meshstream::EncodeSettings& s, const char* from) {
  auto in = [](int64_t v, int64_t lo, int64_t hi) { return v >= lo && v <= hi; };
  if (!in(s.qp, meshstream::kMinQuantizationBits, meshstream::kMaxQuantizationBits) ||
      !in(s.qn, meshstream::kMinNormalBits, meshstream::kMaxNormalBits) ||
      !in(s.qt, meshstream::kMinQuantizationBits, meshstream::kMaxQuantizationBits) ||
      !in(s.packet_bytes, meshstream::kMinPacketBytes, meshstream::kMaxPacketBytes) ||
      (s.packing != "split" && s.packing != "bundled") ||
      !(s.base_ratio >= meshstream::kMinBaseRatio && s.base_ratio <= meshstream::kMaxBaseRatio)) {
    Bug(std::string(from) + " gave settings out of range: " + meshstream::CanonicalJson(s));
  }
  auto again = meshstream::ResolveSettings(s);
  if (!again.ok() || again.value() != s) Bug(std::string(from) + ": resolving resolved settings changed them");
  const std::string json = meshstream::CanonicalJson(s);
  auto back = meshstream::ParseSettingsJson(json);
  if (!back.ok()) Bug(std::string(from) + ": CanonicalJson " + json + " does not parse: " + back.status().ToString());
  if (back.value() != s) {
    Bug(std::string(from) + ": CanonicalJson " + json + " parses to " + meshstream::CanonicalJson(back.value()));
  }
  if (meshstream::CanonicalJson(back.value()) != json) Bug(std::string(from) + ": CanonicalJson is not stable");
}

void CheckSettingsJson(const std::string& text) {
  auto parsed = meshstream::ParseSettingsJson(text);
  if (!parsed.ok()) {
    CheckRefusal("ParseSettingsJson", parsed.status(), text);
    return;
  }
  CheckResolved(parsed.value(), "ParseSettingsJson");
}

void CheckSettingsBytes(const uint8_t* data) {
  meshstream::EncodeSettings s;
  int32_t q[3];
  std::memcpy(q, data, sizeof q);
  s.qp = q[0];
  s.qn = q[1];
  s.qt = q[2];
  std::memcpy(&s.packet_bytes, data + 12, 4);
  float ratio;
  std::memcpy(&ratio, data + 16, 4);
  uint16_t fraction;
  std::memcpy(&fraction, data + 16, 2);
  switch ((data[20] >> 2) & 3) {
    case 0: s.base_ratio = 0.0; break;
    case 1: s.base_ratio = static_cast<double>(ratio); break;  // any float, NaN and infinities too
    case 2: s.base_ratio = std::ldexp(fraction, -16); break;  // [0, 1)
    default:  // just outside the range
      s.base_ratio = data[16] & 1 ? std::nextafter(meshstream::kMinBaseRatio, 0.0)
                                  : std::nextafter(meshstream::kMaxBaseRatio, 2.0);
      break;
  }
  const char* const packings[4] = {"", "split", "bundled", "Split"};
  s.packing = packings[data[20] & 3];
  auto resolved = meshstream::ResolveSettings(s);
  if (!resolved.ok()) {
    CheckRefusal("ResolveSettings", resolved.status(), meshstream::CanonicalJson(s));
    return;
  }
  CheckResolved(resolved.value(), "ResolveSettings");
  // Resolution only fills what was left at 0 or empty.
  const meshstream::EncodeSettings& r = resolved.value();
  if ((s.qp != 0 && r.qp != s.qp) || (s.qn != 0 && r.qn != s.qn) || (s.qt != 0 && r.qt != s.qt) ||
      (!s.packing.empty() && r.packing != s.packing) || (s.packet_bytes != 0 && r.packet_bytes != s.packet_bytes) ||
      (s.base_ratio != 0.0 && r.base_ratio != s.base_ratio)) {
    Bug("ResolveSettings changed a field that was set: " + meshstream::CanonicalJson(s) + " -> " +
        meshstream::CanonicalJson(r));
  }
}

// --- authorization -----------------------------------------------------------

void CheckAuthorization(const std::optional<std::string>& header) {
  Fixture& f = GetFixture();
  auto off = f.off->Authenticate(header);
  if (!off.ok() || off->tenant != meshstream::kDefaultTenant || off->read_only) {
    Bug("with authentication off, a header did not give the default tenant");
  }
  auto on = f.on->Authenticate(header);
  const bool is_rw = header.has_value() && *header == "Bearer " + kReadWriteToken;
  const bool is_ro = header.has_value() && *header == "Bearer " + kReadOnlyToken;
  if (on.ok()) {
    if (!is_rw && !is_ro) Bug("header '" + Shown(header.value_or("")) + "' authenticates as " + on->tenant);
    if (on->tenant != (is_rw ? kReadWriteTenant : kReadOnlyTenant) || on->read_only != is_ro) {
      Bug("a token authenticates as the wrong principal");
    }
    return;
  }
  if (is_rw || is_ro) Bug("a live token was refused: " + on.status().ToString());
  if (on.status().code() != StatusCode::kUnauthenticated || on.status().message().empty()) {
    Bug("header '" + Shown(header.value_or("")) + "' refused with " + on.status().ToString());
  }
  if (header.has_value() && header->compare(0, 7, "Bearer ") == 0 &&
      meshstream::LooksLikeApiToken(header->substr(7)) && on.status().message() != f.unknown_message) {
    Bug("an unknown token and a revoked one get different messages: '" + on.status().message() + "' and '" +
        f.unknown_message + "'");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > kMaxInputBytes) return 0;
  std::vector<std::string> pieces(1);
  for (size_t i = 0; i < size; ++i) {
    if (data[i] == 0xFF && pieces.size() < kMaxPieces) {
      pieces.emplace_back();
    } else {
      pieces.back().push_back(static_cast<char>(data[i]));
    }
  }
  for (const std::string& piece : pieces) {
    CheckResourceName(piece);
    CheckMainFilename(piece);
    CheckNames(piece);
    CheckSettingsJson(piece);
    CheckAuthorization(piece);
  }
  static const bool no_header = (CheckAuthorization(std::nullopt), true);
  (void)no_header;
  if (size >= 21) CheckSettingsBytes(data);
  return 0;
}
