// API tokens: 32 random bytes from libsodium, printed once as
// "mst_" + 64 hex digits. The store keeps only HashApiToken(token), the
// SHA-256 of the whole text (a token has 256 bits of entropy, so a plain hash
// is as strong as a slow one and keeps every request cheap).
#ifndef MESHSTREAM_SERVICES_AUTH_API_TOKEN_H_
#define MESHSTREAM_SERVICES_AUTH_API_TOKEN_H_

#include <string>

namespace meshstream {

constexpr char kApiTokenPrefix[] = "mst_";

std::string NewApiToken();
std::string HashApiToken(const std::string& token);
// Shape only ("mst_" + 64 lower-case hex digits): a request with anything
// else is refused before the store is asked.
bool LooksLikeApiToken(const std::string& token);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_AUTH_API_TOKEN_H_
