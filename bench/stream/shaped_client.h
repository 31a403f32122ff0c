// The shaped link's client: a child process of meshstream_bench_stream run
// inside the network namespace (`ip netns exec NS <this> --shaped-client
// ...`), so that its sockets really are behind the shaped, lossy veth.
#ifndef MESHSTREAM_BENCH_STREAM_SHAPED_CLIENT_H_
#define MESHSTREAM_BENCH_STREAM_SHAPED_CLIENT_H_

namespace meshstream::bench::stream {

// --shaped-client KIND SERVER UDP_VIA ASSET VERSION SNAPSHOTS MAX_SNAPSHOTS
// TIMEOUT_S EXPECTED_LOSS: one session (KIND udp; udp_no_parity, the same
// asking for no parity datagrams; or tcp_only), stating EXPECTED_LOSS (< 0:
// nothing) as a long-lived sdk::Client states the loss its sessions saw, or
// one Draco GLB download and decode (draco_export), on a warm channel; prints one JSON line (its
// times, events and stats, or its error); writes what it showed, flattened,
// into the file SNAPSHOTS (snapshots.h) after the clock has stopped.
// Returns 0 when it could report (even a failure), Dies on bad arguments.
int ShapedClientMain(int argc, char** argv);

}  // namespace meshstream::bench::stream

#endif  // MESHSTREAM_BENCH_STREAM_SHAPED_CLIENT_H_
