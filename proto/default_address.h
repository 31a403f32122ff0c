// Where a meshstream server listens unless told otherwise, and where a client
// looks for one: `meshstream serve` (services/server/server.h), the SDK's
// ClientOptions (sdk/client.h), the CLI's --server and the C API's NULL
// server all use this one name.
#ifndef MESHSTREAM_PROTO_DEFAULT_ADDRESS_H_
#define MESHSTREAM_PROTO_DEFAULT_ADDRESS_H_

namespace meshstream {

inline constexpr char kDefaultAddress[] = "127.0.0.1:7600";

}  // namespace meshstream

#endif  // MESHSTREAM_PROTO_DEFAULT_ADDRESS_H_
