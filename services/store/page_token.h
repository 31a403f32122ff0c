// Page tokens and page sizes, shared by both store backends (store.h), so a
// client sees the same behaviour whichever backend serves it.
//
// A token is opaque to clients: base64url (no padding) of
// "<kind>\0<cursor>" followed by a 4-byte check value (the start of a
// SHA-256 over the same bytes). `kind` says which listing issued it
// ("assets", "versions"), `cursor` where the next page starts: the last name
// of the page for assets, the last version number for versions.
//
// Contract: tokens arrive from clients and are untrusted. A token that is not
// base64url, too long, fails its check value or was issued for another kind
// of listing is InvalidArgument "page_token: not a token this server
// issued". The check value catches typing errors and tokens handed to the
// wrong listing; it is not a secret, so a client can make a token for a
// cursor of its choosing. That is harmless: the cursor only says where a
// listing of the caller's own objects starts, and the backends bind it as a
// query parameter. The cursor helpers below re-check what they decode.
// Thread safety: pure functions.
#ifndef MESHSTREAM_SERVICES_STORE_PAGE_TOKEN_H_
#define MESHSTREAM_SERVICES_STORE_PAGE_TOKEN_H_

#include <cstdint>
#include <string>

#include "codec/core/status.h"

namespace meshstream {

// The kinds of listing the store pages through.
inline constexpr const char kAssetsPageKind[] = "assets";
inline constexpr const char kVersionsPageKind[] = "versions";

// Tokens longer than this are refused before decoding.
constexpr size_t kMaxPageTokenChars = 512;

// The token for `cursor` in a listing of `kind` (kind must not contain '\0').
std::string EncodePageToken(const std::string& kind, const std::string& cursor);
// The cursor of a token issued by EncodePageToken for `kind`. An empty token
// is the first page and decodes to an empty cursor.
StatusOr<std::string> DecodePageToken(const std::string& kind, const std::string& token);

// 0 -> kDefaultPageSize, above kMaxPageSize -> kMaxPageSize, negative ->
// InvalidArgument "page_size: must not be negative".
StatusOr<int32_t> EffectivePageSize(int32_t requested);

// ListAssets: the cursor is the last asset name of the page. Decoding an
// empty token gives "" (start before every name); a cursor that is not a
// valid name is refused like a forged token.
std::string EncodeAssetsPageToken(const std::string& last_name);
StatusOr<std::string> DecodeAssetsPageToken(const std::string& token);

// ListVersions: the cursor is the last version number of the page (decimal).
// Decoding an empty token gives 0 (start before version 1).
std::string EncodeVersionsPageToken(int64_t last_version);
StatusOr<int64_t> DecodeVersionsPageToken(const std::string& token);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STORE_PAGE_TOKEN_H_
