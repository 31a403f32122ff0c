// 3. of the stream benchmark: the shaped, lossy link.
//
// The server (this process, host namespace) listens on the host side of a
// veth pair (testing/netns.h); the clients are children of this program
// (`ip netns exec NS <this> --shaped-client ...`, shaped_client.h), so their
// sockets are really inside the namespace, one child per session or
// download. The namespace drops a share of every packet it receives
// (nftables, TCP and UDP: the downloads and the server's ACKs), tbf limits
// both veth ends to --shaped-rate, and both channels see the same one-way
// delay: the UDP half through the UDP relay (udp_via), every gRPC channel
// (meshstream's and the Draco download's) through the TCP delay proxy
// (bench/tcp_delay_proxy.h), both bound on the veth's host address. Per
// model (the bunny, the horse, the largest shared model by vertices): the
// time to the first visible mesh and to the full mesh, and the distance of
// what is shown over time to the full lossless mesh (shaped_distances.h).
#ifndef MESHSTREAM_BENCH_STREAM_SHAPED_H_
#define MESHSTREAM_BENCH_STREAM_SHAPED_H_

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/stream/args.h"
#include "bench/stream/models.h"

namespace meshstream::bench::stream {

// The "shaped" object: a server of its own on `store` (ingesting the models
// the loopback parts did not), snapshots under `folder`. {"skipped": why}
// when a namespace or tbf cannot be made, or no model is left.
nlohmann::json RunShaped(const Args& args, const std::string& store, const std::string& folder,
                         const std::vector<Model>& main_models);

}  // namespace meshstream::bench::stream

#endif  // MESHSTREAM_BENCH_STREAM_SHAPED_H_
