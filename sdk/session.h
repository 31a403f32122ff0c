// A streaming session of the SDK: opens StreamService.Open for an asset
// version, and refines the mesh as the session's blocks arrive
// (docs/spec/streaming-protocol.md). Poll model: the host calls Poll on its own
// thread and gets events; no callback ever runs on an internal thread.
//
// Events, in order: kBaseReady (every primitive's base mesh decoded), then
// kLevelReady with the level every primitive has reached (or all it has),
// increasing (levels completed before the host polls come as one event for
// the highest), then kComplete; or kError with the status, after which the
// session is over. At each event the meshes are at the event's level (the
// decoding goes on meanwhile; the next event shows what it did).
//
// Transport: UDP unless tcp_only (or the server has UDP off, or no HELLO
// got through: the server then says so and the datagrams come over gRPC).
// Over UDP what the network loses is predicted (codec/loss), never asked
// for again; a refinement is decoded when its END (the datagram or its
// reliable copy, RefinementEnd) and every datagram it announces have
// arrived, or `straggler_timeout_ms` after the first of its ENDs arrived,
// counted on the arrival horizon (UdpReceiver::caught_up_us), so a host
// that polls seldom or starves the UDP thread never loses what arrived
// (docs/spec/streaming-protocol.md).
//
// Budgets: max_level stops the server early; byte_budget (bytes received
// on both channels) and time_budget_ms (since Open) stop the session on the
// client's side: it tells the server it is done, decodes what arrived, and
// Poll returns kComplete at the level reached.
//
// Untrusted input: everything the server sends (every ServerMessage, every
// StreamDatagram and UDP payload) is checked before it is used, and no
// bytes from it can make the client crash, hang or hold more than its
// bounds (64 MiB of datagrams buffered per primitive, 65,536 UDP datagrams
// queued, 256 MiB of copies kept for a repair). A bad one either ends the
// session (Poll returns kError with the status; kInvalidInput unless named):
//   - SessionStart: a second one; a primitive announced twice; a stream
//     header that does not parse (kUnsupported for an unknown version);
//     more refinements than its header has; a base mesh that does not
//     decode, no POSITION or a malformed TEXCOORD_n attribute name; a
//     scene_glb that does not import or lacks a refined primitive's mesh;
//     with TRANSPORT_UDP, keys that are not 32 bytes or a port outside
//     1..65535 (an endpoint that does not resolve: its own status);
//   - ControlBlock: an unknown primitive, a refinement outside the session,
//     a second block for a refinement, more datagrams than two per split,
//     or split bits the decoder refuses;
//   - RefinementEnd: an unknown primitive or a refinement outside the session;
//   - RepairEnd without a repair asked for;
//   - a refinement that fails to decode (FinishRefinement);
//   - the call ending before SessionEnd: its status (kUnavailable if OK);
// or is dropped and counted in SessionStats:
//   - a datagram (on UDP or as a StreamDatagram) that does not parse, names
//     a stream not in the session, does not fit its stream (kind, refinement,
//     ordinals), announces in its END more than two datagrams per split,
//     arrives before SessionStart, or does not fit the buffers:
//     datagrams_rejected (with the UDP receiver's drops: unauthenticated,
//     wrong session, malformed packets);
//   - copies, replays and datagrams of refinements already decoded:
//     datagrams_duplicate;
// or is ignored: a ServerMessage of a kind this client does not know, a
// TransportChange to anything but TRANSPORT_GRPC, a SessionEnd after the
// first (the stragglers' window counts from the first) or after a budget
// ran out, a second RepairEnd. (sdk/session_core.h is where it is decided;
// tests/sdk/ and tests/fuzz/fuzz_sdk_session.cc check it.)
//
// Thread safety and ownership: a Session is used from one thread (Poll, the
// mesh accessors); Cancel may also be called from another thread. Mesh
// views stay valid until the next Poll. The Client must outlive the
// session. Internally one thread reads the gRPC stream and one the UDP
// socket, each into a queue, and the session's own thread decodes as the
// data arrives, in a deterministic core (sdk/session_core.h) that it hands
// every arrival with its arrival time, and the clock: a host that polls
// seldom, or spends its frame elsewhere, never holds the decoding back. At
// each event that thread takes the views (each primitive's mesh as the
// event shows it: a copy of what changed since the last event); Poll only
// hands over the events and their views, and stats() as of the last Poll.
#ifndef MESHSTREAM_SDK_SESSION_H_
#define MESHSTREAM_SDK_SESSION_H_

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "codec/core/status.h"
#include "codec/mesh/mesh.h"
#include "codec/mesh/quantized_mesh.h"
#include "sdk/client.h"
#include "sdk/session_types.h"

namespace meshstream::sdk {

class Session {
 public:
  static StatusOr<std::unique_ptr<Session>> Open(const Client& client, const SessionOptions& options);
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  // Processes what arrived, waiting at most `timeout_ms` for something, and
  // returns the next event (kNone when the time ran out first).
  Event Poll(int32_t timeout_ms);
  // Stops the session (the server frees it); Poll then returns kError
  // (cancelled) once.
  void Cancel();
  // The viewer's view changed: the server orders what it has not begun by it
  // (ClientMessage.view; acted on at most once a second, the latest wins).
  // Callable from any thread; InvalidArgument for a view CheckView refuses.
  Status SetView(const View& view);

  size_t primitive_count() const;
  // The current mesh of a primitive (dequantized), and per vertex 1 where
  // its position may differ from the loss-free decode: predicted, or placed
  // relative to a predicted position (StreamReader::PositionExactInto; not
  // the decoder's reliability bits, which also mark every vertex whose ring
  // a prediction touched). All 0 when nothing was lost or parity rebuilt it.
  StatusOr<Primitive> Mesh(size_t primitive) const;
  StatusOr<std::vector<uint8_t>> Predicted(size_t primitive) const;
  // The same mesh as the decoder holds it, without a copy: quantized (its
  // grids dequantize it, DequantizeVerticesInto), and per vertex 1 where its
  // position is the loss-free decode's (a vertex past its end: exact). Both
  // valid until the next Poll (what sdk/mesh_changes.h compares).
  struct QuantizedView {
    const QuantizedMesh* mesh = nullptr;
    const std::vector<uint8_t>* exact = nullptr;
  };
  StatusOr<QuantizedView> Quantized(size_t primitive) const;
  // Where the primitive is drawn: the world matrix (column-major, glTF) of
  // every node instance of its glTF mesh reached from the asset's default
  // scene (ForEachMeshInstance); the identity once from a server that sends
  // no scene. Empty for a primitive that does not exist or no node shows.
  std::vector<std::array<double, 16>> Instances(size_t primitive) const;
  // Where the primitive sits in the asset's glTF (mesh, primitive index).
  std::pair<uint32_t, uint32_t> GltfPosition(size_t primitive) const;
  int32_t levels() const;  // the most refinements any primitive has in this session
  // The level every primitive has reached (-1 before kBaseReady).
  int32_t level_shown() const;
  // Vertices, over all primitives, whose position may differ from the loss-free decode.
  uint64_t predicted_vertices() const;
  // The asset's scene (nodes, materials, textures, animations, carried
  // primitives: SessionStart.scene_glb) with every refined primitive at the
  // level reached. From a server that sends no scene: one glTF mesh per
  // mesh of the refined primitives, one node each, no materials.
  Scene CurrentScene() const;
  // CurrentScene written as .glb or .gltf (by the extension), through importers/.
  Status Export(const std::string& path) const;
  const SessionStats& stats() const;

 private:
  struct Impl;
  explicit Session(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace meshstream::sdk

#endif  // MESHSTREAM_SDK_SESSION_H_
