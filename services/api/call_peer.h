// Where a gRPC call came from: the numeric host of the peer's address, from
// gRPC's peer string ("ipv4:1.2.3.4:5", "ipv6:[::1]:5", its URI form
// "ipv6:%5B::1%5D:5"). The UDP endpoint proves a session's first address by
// it (docs/streaming-protocol.md, "HELLO and address validation").
//
// Contract: "" for anything else (a Unix socket, an in-process call, a
// string it cannot read): the caller then trusts no host.
#ifndef MESHSTREAM_SERVICES_API_CALL_PEER_H_
#define MESHSTREAM_SERVICES_API_CALL_PEER_H_

#include <string>

namespace meshstream {

std::string PeerHost(const std::string& grpc_peer);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_API_CALL_PEER_H_
