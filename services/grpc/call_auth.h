// Who a gRPC call is: the `authorization` metadata handed to the
// Authenticator (services/auth/authenticator.h). One place for every service.
#ifndef MESHSTREAM_SERVICES_GRPC_CALL_AUTH_H_
#define MESHSTREAM_SERVICES_GRPC_CALL_AUTH_H_

#include <optional>
#include <string>

#include <grpcpp/server_context.h>

#include "services/auth/authenticator.h"

namespace meshstream {

inline StatusOr<Principal> AuthenticateCall(const Authenticator& auth, const grpc::ServerContextBase& context) {
  std::optional<std::string> header;
  const auto& metadata = context.client_metadata();
  const auto it = metadata.find("authorization");
  if (it != metadata.end()) header = std::string(it->second.data(), it->second.size());
  return auth.Authenticate(header);
}

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_GRPC_CALL_AUTH_H_
