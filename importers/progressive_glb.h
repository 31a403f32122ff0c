// The progressive container: a valid .glb whose primitives carry their base
// mesh under KHR_draco_mesh_compression and their refinements in a
// bufferView named by our extension MESHSTREAM_progressive (listed in
// extensionsUsed, not in extensionsRequired), so any glTF reader shows the
// base level (docs/design/design.md, "glTF container"; docs/spec/progressive-format.md).
//
// Contract: DecodeProgressiveGlb is safe on untrusted bytes (the glTF import
// checks of gltf_import.h, then the stream reader's). Every refined (triangle)
// primitive of every mesh is encoded; carried primitives (points, lines,
// skinned or morphed triangles; mesh.h), skins, animations, scene structure,
// materials and textures are stored as plain glTF and come back unchanged.
#ifndef MESHSTREAM_IMPORTERS_PROGRESSIVE_GLB_H_
#define MESHSTREAM_IMPORTERS_PROGRESSIVE_GLB_H_

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "codec/mesh/mesh.h"
#include "codec/mesh/spatial_parts.h"
#include "codec/loss/datagram_harm.h"
#include "codec/loss/reliable_cut.h"
#include "codec/loss/simulator.h"
#include "codec/progressive/encoder.h"
#include "codec/progressive/scene_levels.h"
#include "codec/bitstream/reader.h"
#include "codec/bitstream/writer.h"
#include "importers/import.h"

namespace meshstream {

constexpr char kProgressiveExtension[] = "MESHSTREAM_progressive";

// Which profiles of format version 4 (codec/bitstream/format.h) a file
// carries: one, or both from one hierarchy (the strict rule's: both profiles
// then have the same levels and vertex ids), the reliable profile's blob
// under MESHSTREAM_progressive's "reliable" and the loss-tolerant one's
// under its "bufferView" (docs/spec/progressive-format.md, section 1).
enum class ProfileSet : uint8_t { kLossTolerant, kReliable, kBoth };

struct ProgressiveGlbOptions {
  ProgressiveEncodeOptions encode;
  StreamWriteOptions stream;  // its `profile` is set from `profiles`
  ProfileSet profiles = ProfileSet::kLossTolerant;
  int draco_compression_level = 7;
  // The share of each stream's bytes whose refinements travel reliably with
  // their datagrams (codec/loss/reliable_cut.h; recorded in the extension's
  // "delivery"); 0: none (the paper's scheme).
  double reliable_share = kDefaultReliableShare;
  // Measure each refinement's harm (codec/loss/datagram_harm.h) and record
  // which refinements parity protects (codec/loss/protection.h; the
  // delivery's "parity" and "harm"). About one decode per refinement.
  bool measure_harm = true;
  // The batch rule of a file of the reliable profile alone: kStrict (the
  // default: the loss-tolerant profile's hierarchy, the smaller stream on
  // every shared model but spot) or kMatching (fuller batches, fewer levels;
  // docs/design/codec.md, "Version 4"). Both profiles in one file share kStrict's.
  BatchRule reliable_rule = BatchRule::kStrict;
  // A refined primitive with more referenced vertices than this is cut into
  // spatial parts (codec/mesh/spatial_parts.h), each a stream and a primitive
  // of the same glTF mesh with its material; 0: never cut.
  uint64_t part_vertices = kDefaultPartVertices;
  // Workers (parallel/fork_join_pool.h): with several streams (primitives or
  // parts) they encode streams at once, each on one worker; with one, they
  // share its harm measure. The file is the same bit for bit with any
  // count; null: this thread.
  TaskRunner* runner = nullptr;
  // Called with (primitive index, batch index, vertices left) during
  // encoding: the index counts the scene's refined primitives as given
  // (parts are not counted), the vertices left are summed over a
  // primitive's parts. Calls never overlap (from the worker that reports);
  // one that throws cancels the encoding and the exception reaches the caller.
  std::function<void(size_t, int, size_t)> progress;
};

struct PrimitiveStreamReport {
  uint64_t vertices = 0;  // referenced input vertices
  uint64_t faces = 0;
  std::vector<uint32_t> level_vertices;
  // Per level (as level_vertices), the stream's bytes a client needs to show
  // it: the base's Draco bytes, the header, and every control block and
  // datagram of the refinements up to it (Total: by the scene's levels).
  std::vector<uint64_t> level_bytes;
  uint64_t base_bytes = 0;
  uint64_t reliable_bytes = 0;    // header, fix-ups, split bits, models (base excluded)
  uint64_t unreliable_bytes = 0;  // datagrams with their headers
  uint64_t datagrams = 0;
  uint64_t removed_faces = 0;
  ToolSet tools = 0;  // the coding tools its stream was written with (StreamTool bits; Total: their union)
  uint64_t reliable_cut_bytes = 0;       // datagram bytes of the reliable cut (part of unreliable_bytes)
  // Per level (level_vertices' count) the estimated error left, in scene
  // units (codec/progressive/residual_error.h times the primitive's grid step
  // and scale in the scene): the extension's "residual_error".
  std::vector<double> residual_error;
  std::vector<uint32_t> reliable_cut;    // its refinements, ascending (Total: none)
  std::vector<uint32_t> parity;          // the refinements parity protects, ascending (Total: none)
  // With both profiles, the figures above are the loss-tolerant stream's
  // and these the reliable one's (its header and control blocks; per level
  // as level_bytes); with the reliable profile alone, the figures above are
  // its own and these stay empty.
  uint64_t reliable_profile_bytes = 0;
  std::vector<uint64_t> reliable_level_bytes;
  // Milliseconds of each step of its encoding (Total: their sums): the
  // hierarchy (quantized mesh to refinements: simplification, base coding,
  // replay and its verification), the stream (the bitstream writer), the
  // harm estimate (codec/loss/datagram_harm.h, with the base decoded as a
  // client decodes it) and the delivery record (cut and parity choice).
  double hierarchy_ms = 0, stream_ms = 0, harm_ms = 0, delivery_ms = 0;
};

struct ProgressiveGlbReport {
  std::vector<PrimitiveStreamReport> primitives;
  uint64_t file_bytes = 0;
  // Sums over primitives; level_vertices[K] counts every primitive at the
  // scene's level K (codec/progressive/scene_levels.h: by the primitives'
  // residual errors when every one has them, else min(K, its own level count)).
  PrimitiveStreamReport Total() const;
};

// The scene's levels of primitives with these level vertex counts (one
// entry more than refinements each) and residual errors (empty: unknown).
SceneLevels SceneLevelsOf(const std::vector<std::vector<uint32_t>>& level_vertices,
                          const std::vector<std::vector<double>>& residual_errors);
// The vertices of the scene at each of its levels, the base first.
std::vector<uint32_t> SceneLevelVertices(const SceneLevels& levels,
                                         const std::vector<std::vector<uint32_t>>& level_vertices);

StatusOr<std::vector<uint8_t>> EncodeProgressiveGlb(const Scene& scene, const ProgressiveGlbOptions& options,
                                                    ProgressiveGlbReport* report);
// The same bytes, with less memory: each refined primitive's vertex and index
// arrays are released as soon as it is quantized (the imported floats, 36
// bytes a vertex for positions and triangles, are not held through the
// simplification). Afterwards (and after a failure) the refined primitives of
// *scene have no vertices and no triangles; everything else of it (structure,
// materials, carried data, warnings) is unchanged. For a caller that does not
// need the imported meshes after encoding them (the CLI, the service).
StatusOr<std::vector<uint8_t>> EncodeProgressiveGlbReleasing(Scene* scene, const ProgressiveGlbOptions& options,
                                                             ProgressiveGlbReport* report);

// Which stream of a primitive a decode reads (a file may carry both
// profiles: ProfileSet::kBoth).
enum class DecodeProfile : uint8_t {
  kAuto,          // the reliable profile's when the file has it and nothing is lost, else the other
  kReliable,      // the reliable profile's (an error when the file has none)
  kLossTolerant,  // the loss-tolerant profile's (an error when the file has none)
};

struct ProgressiveDecodeOptions {
  DecodeProfile profile = DecodeProfile::kAuto;
  // The scene's level to decode to (codec/progressive/scene_levels.h: with
  // one primitive, its refinements; with several, by their "residual_error",
  // or K refinements of each in a file without it); -1: all.
  int lod = -1;
  // The network every primitive's stream crosses (codec/loss/simulator.h):
  // the seed of primitive k is seed + k. A zero model takes the same path.
  LossModel loss;
  Recovery recovery = Recovery::kPredict;
  // Which refinements travel reliably: < 0 the cut the file records
  // ("delivery"; none in a file without it), 0 none (the paper's scheme),
  // > 0 the cut for that share of each stream's bytes from the file's ranking.
  double reliable_share = -1;
  // Parity datagrams (docs/design/loss-protection.md) as a session sends them: for
  // the refinements the file's delivery record protects, sized for the
  // model's own loss and burst (a client's reports), rebuilt by the
  // reconstructor with this code (codec/core/erasure_code.h; fec/ has one);
  // null: none.
  ErasureCode* parity = nullptr;
  // Workers for the decode of complete refinements (parallel/fork_join_pool.h
  // has a pool of threads; the output is the same bit for bit); null: the
  // caller's thread alone.
  TaskRunner* runner = nullptr;
};

// Checks `delivery_json` (untrusted text: the "delivery" object) against a
// stream of `refinements` refinements: InvalidInput naming the member that is
// wrong.
StatusOr<DeliveryRecord> ParseDeliveryRecord(const std::string& delivery_json, size_t refinements);
// One JSON object, the inverse.
std::string DeliveryRecordJson(const DeliveryRecord& record);
// Checks `residual_json` (untrusted text: the "residual_error" array) against
// a stream of `refinements` refinements: refinements + 1 finite,
// non-negative, non-increasing numbers ending with 0; InvalidInput naming the
// entry that is not.
StatusOr<std::vector<double>> ParseResidualErrors(const std::string& residual_json, size_t refinements);
// The inverse: one JSON array, each value at float precision.
std::string ResidualErrorsJson(const std::vector<double>& errors);
// The stream's bytes a share is taken of: base, reliable and unreliable.
uint64_t StreamTotalBytes(uint64_t base_bytes, const ProgressiveStream& stream);
// Per refinement, the bytes of its datagrams.
std::vector<uint64_t> RefinementDatagramBytes(const ProgressiveStream& stream);
// The record EncodeProgressiveGlb writes for an encoded primitive: the
// ranking of its refinements and the cut for `share` of its bytes (the base's
// `base_bytes` and the stream's), and with `harm` (datagram_harm.h) each
// refinement's harm and the refinements to protect with parity
// (protection.h).
DeliveryRecord MakeDeliveryRecord(const ProgressiveMesh& mesh, const ProgressiveStream& stream, uint64_t base_bytes,
                                  double share, const DatagramHarm* harm = nullptr);

struct ProgressiveDecodeReport {
  uint64_t levels = 0;           // the most refinements any primitive has
  uint64_t levels_applied = 0;
  uint64_t datagrams = 0;        // data datagrams sent
  uint64_t lost_datagrams = 0;   // dropped by the simulated network
  uint64_t late_datagrams = 0;   // arrived after their refinement was decoded
  uint64_t reliable_datagrams = 0;       // sent on the reliable channel (the cut)
  uint64_t reliable_datagram_bytes = 0;
  RecoveryStats recovery;        // summed over primitives
  uint64_t predicted_vertices = 0;  // vertices whose position may differ (StreamReader::inexact_positions)
  uint64_t parity_datagrams = 0;    // parity datagrams sent (options.parity)
  uint64_t parity_bytes = 0;
  uint64_t recovered_datagrams = 0; // lost data datagrams parity rebuilt (not in lost_datagrams' complement)
  uint64_t refinements_decoded_again = 0;  // decoded again because parity rebuilt a datagram after a prediction
  std::vector<uint32_t> level_vertices;  // summed over primitives (lossless counts)
  ToolSet tools = 0;             // the coding tools of the streams (StreamTool bits, their union)
  uint32_t reliable_profile_streams = 0;  // streams decoded from the reliable profile
  uint32_t loss_tolerant_streams = 0;     // ... from the loss-tolerant profile (versions 1-3 included)
};

// Decodes a progressive .glb held in memory into a scene at the requested
// level of detail. Primitives without our extension come back as they are.
StatusOr<Scene> DecodeProgressiveGlb(const std::vector<uint8_t>& bytes, const ProgressiveDecodeOptions& options,
                                     ProgressiveDecodeReport* report);

}  // namespace meshstream

#endif  // MESHSTREAM_IMPORTERS_PROGRESSIVE_GLB_H_
