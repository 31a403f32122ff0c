#include "services/auth/authenticator.h"

#include "services/auth/api_token.h"

namespace meshstream {

StatusOr<Principal> Authenticator::Authenticate(const std::optional<std::string>& authorization) const {
  if (!enabled_) return Principal{kDefaultTenant, false};
  if (!authorization.has_value() || authorization->empty()) {
    return Unauthenticated("missing 'authorization: Bearer TOKEN' metadata (meshstream token create)");
  }
  const std::string scheme = "Bearer ";
  if (authorization->size() <= scheme.size() || authorization->compare(0, scheme.size(), scheme) != 0) {
    return Unauthenticated("authorization: expected 'Bearer TOKEN'");
  }
  const std::string token = authorization->substr(scheme.size());
  if (!LooksLikeApiToken(token)) return Unauthenticated("authorization: not a valid token");
  auto record = store_->FindToken(HashApiToken(token));
  if (!record.ok()) {
    if (record.status().code() == StatusCode::kNotFound) return Unauthenticated("authorization: not a valid token");
    return record.status();
  }
  return Principal{record->tenant, record->read_only};
}

Status Authenticator::CheckCanWrite(const Principal& principal) {
  if (principal.read_only) return PermissionDenied("this token is read-only (token create without --read-only)");
  return Status::Ok();
}

}  // namespace meshstream
