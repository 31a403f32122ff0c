// Reads a progressive stream (stream_writer.h's mirror): the header, the base
// (decoded by the caller's single-rate decoder onto the header's grids), then
// refinement by refinement its control block and whichever datagrams arrive,
// in any order, duplicated or not.
//
// Contract: safe on hostile bytes. Header counts bound every allocation
// (at most kMaxStreamVertices vertices); a datagram is checked field by field
// before anything it carries is stored, and a datagram that does not decode
// cleanly is dropped whole and counted. Split bits and models are reliable:
// an error there fails the stream, and their decoding never looks at
// connectivity or positions (docs/design/design.md, "Reliable data"), so they decode bit-exactly
// whatever was lost.
//
// Loss (docs/design/loss-tolerance.md): FinishRefinement applies every split whose
// structure and geometry arrived, and recovers the others by `Recovery`:
// kPredict predicts what is missing (paper, section 4.4; split_prediction.h)
// so every level has the lossless vertex count; kLwop abandons the split and
// every later split that depends on it (paper, section 5.3). Per vertex, a
// reliability bit says whether it was decoded exactly (paper, section 4.5).
// Thread safety: one reader per stream.
#ifndef MESHSTREAM_CODEC_BITSTREAM_READER_H_
#define MESHSTREAM_CODEC_BITSTREAM_READER_H_

#include <cstdint>
#include <vector>

#include "codec/core/task_runner.h"
#include "codec/progressive/parallel_refinement.h"
#include "codec/progressive/refinement.h"
#include "codec/progressive/refinement_state.h"
#include "codec/recovery/recover_split.h"
#include "codec/bitstream/format.h"
#include "codec/bitstream/slot_model.h"
#include "codec/bitstream/reliable_payload.h"
#include "codec/progressive/split_bit_contexts.h"
#include "codec/progressive/split_bits_connected.h"
#include "codec/progressive/split_bits.h"
#include "codec/entropy/symbol_model.h"

namespace meshstream {

struct DatagramStats {
  uint64_t accepted = 0;
  uint64_t rejected = 0;    // malformed, wrong stream or refinement, bad ordinals
  uint64_t duplicates = 0;  // every unit it carried had already arrived
};

class StreamReader {
 public:
  static StatusOr<StreamReader> Create(const uint8_t* header, size_t size, uint32_t stream_id = 0);

  const StreamHeader& header() const { return header_; }
  // The base as the single-rate decoder returned it; fix-ups are applied here.
  Status SetBase(QuantizedMesh decoded_base);

  size_t refinement_count() const { return header_.split_counts.size(); }
  size_t applied() const { return next_; }

  Status BeginRefinement(const uint8_t* control, size_t size);
  bool OfferDatagram(const uint8_t* data, size_t size);
  // The same with the header already read (ParsedDatagram::Parse): the
  // header is not parsed again; everything else is checked as above.
  bool OfferDatagram(const ParsedDatagram& d);
  // With a runner of more than one worker, a refinement whose datagrams all
  // arrived, decoded while no vertex is flagged, has its splits planned on
  // the runner's workers (parallel_refinement.h); the output is the same
  // bit for bit. The runner must outlive the reader's use of it; null (the
  // default) decodes on the caller's thread alone.
  void SetTaskRunner(TaskRunner* runner) { runner_ = runner; }
  // Applies the current refinement; what was lost is recovered by `recovery`.
  // Within one stream every refinement must use the same recovery.
  Status FinishRefinement(Recovery recovery = Recovery::kPredict);

  // The current refinement as decoded: split vectors (and wings) as they
  // were applied (version 2 codes them relative to predictions).
  const Refinement& current() const { return current_; }
  const std::vector<uint8_t>& has_structure() const { return has_structure_; }
  // Between BeginRefinement and FinishRefinement: whether every split's
  // structure and geometry have arrived (nothing will be predicted).
  bool HasEveryUnit() const;
  const std::vector<uint8_t>& has_geometry() const { return has_geometry_; }
  const DatagramStats& stats() const { return stats_; }
  const RecoveryStats& recovery_stats() const { return recovery_stats_; }
  const RefinementState& state() const { return state_; }
  // Per canonical vertex id: 1 decoded exactly, 0 predicted, moved by a
  // prediction, or with a ring a prediction changed (docs/design/design.md, "Prediction").
  const std::vector<uint8_t>& reliable() const { return state_.reliable; }
  // Vertices that reliable() marks 0 and that exist.
  uint64_t unreliable_vertices() const;
  // What a viewer wants to know (the SDK's "predicted"): per canonical vertex
  // 1 when its position is the loss-free decode's, 0 when it may differ
  // (predicted, or placed relative to a predicted position or ring: the
  // kPositionInexact flag; reliable() also marks vertices whose ring alone a
  // prediction changed). Into `out`, reusing its capacity.
  void PositionExactInto(std::vector<uint8_t>& out) const;
  // Vertices that exist and whose position may differ.
  uint64_t inexact_positions() const;
  // The current level. Vertices that LwoP never created are left out (the
  // others keep their relative order), so no vertex is unreferenced.
  QuantizedMesh Mesh() const { return state_.Snapshot(header_.grids); }
  // The same into `out`, reusing its arrays' capacity.
  void MeshInto(QuantizedMesh& out) const { state_.SnapshotInto(header_.grids, out); }

 private:
  StreamHeader header_;
  uint32_t stream_id_ = 0;
  RefinementState state_;
  RecoveryScratch recovery_scratch_;
  bool has_base_ = false;
  size_t next_ = 0;          // refinements applied
  bool in_refinement_ = false;
  SplitHistory history_;            // versions 1 and 2
  SplitBitContexts split_contexts_;  // version 3 (kToolSplitContexts)
  ConnectedSplitBits connected_;     // version 4, reliable profile
  ReliablePayload payload_;          // version 4, reliable profile: the split data's models
  Refinement coded_;    // what the datagrams carry
  Refinement current_;  // what was applied
  SplitCoding coding_;
  PredictorWeights predictor_ = kInitialPredictor;  // the last refinement's (kToolRingPredictor)
  std::vector<uint8_t> has_structure_, has_geometry_;
  TaskRunner* runner_ = nullptr;
  RefinementPlan plan_;  // FinishRefinement's, with a runner
  std::vector<SlotModel> models_;  // slots: wing, offset, position x y z, channels
  // OfferDatagram's scratch: a datagram is decoded here before it is committed.
  std::vector<std::array<uint16_t, 2>> datagram_wings_;
  std::vector<Vec3i> datagram_deltas_;
  std::vector<int32_t> datagram_attributes_;
  std::vector<uint16_t> datagram_twin_wings_;
  std::vector<int32_t> datagram_twin_attributes_;
  std::vector<SlotCoder> datagram_coders_;
  // Per split of the current refinement: its seam twin's split, or kNoTwin
  // (empty in a stream without the seams tool).
  std::vector<uint32_t> partner_;
  DatagramStats stats_;
  RecoveryStats recovery_stats_;

  // The rest of a reliable profile's control block after its split bits:
  // the predictor record (or alpha) and the split data, into `ref`.
  Status BeginReliable(ByteReader& r, Refinement& ref, const std::string& where);
  // The predictor record (or alpha) of a control block into coding_.
  Status ReadPredictor(ByteReader& r, const std::string& where, PredictorWeights* predictor);
  // The splits of a complete refinement from the plans made on the runner,
  // window by window; returns the first split it left to the serial path
  // (split_count() when none).
  size_t ApplyPlanned(Recovery recovery, RecoveryStats* stats, Status* status);
};

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_BITSTREAM_READER_H_
