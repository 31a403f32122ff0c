// Who a request is: the tenant its token belongs to and whether it may write.
//
// With authentication on, a request must carry `authorization: Bearer TOKEN`
// naming a live token of the store (UNAUTHENTICATED otherwise, without saying
// whether the token was unknown or revoked). With it off (loopback only, see
// services/server/server.h), every request is the tenant "default" with
// full rights and any authorization header is ignored.
//
// Thread safety: Authenticate may be called from any thread at once.
#ifndef MESHSTREAM_SERVICES_AUTH_AUTHENTICATOR_H_
#define MESHSTREAM_SERVICES_AUTH_AUTHENTICATOR_H_

#include <optional>
#include <string>

#include "codec/core/status.h"
#include "services/store/store.h"

namespace meshstream {

constexpr char kDefaultTenant[] = "default";

struct Principal {
  std::string tenant;
  bool read_only = false;
};

class Authenticator {
 public:
  Authenticator(Store* store, bool enabled) : store_(store), enabled_(enabled) {}

  bool enabled() const { return enabled_; }
  // `authorization`: the request's header value, when it has one (untrusted).
  StatusOr<Principal> Authenticate(const std::optional<std::string>& authorization) const;
  // PermissionDenied for a read-only principal.
  static Status CheckCanWrite(const Principal& principal);

 private:
  Store* store_;
  bool enabled_;
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_AUTH_AUTHENTICATOR_H_
