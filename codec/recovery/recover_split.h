// One split of a refinement with whatever of its data arrived (paper,
// sections 4.3-4.5 and 5.3; docs/design/loss-tolerance.md):
//   case 1  structure and geometry arrived and fit the ring: applied as coded;
//   case 2  both lost: wings and geometry predicted (recovery/prediction.h);
//   case 3  structure lost (or not trusted), geometry arrived: wings from it;
//   case 4  geometry lost, structure arrived: geometry predicted on the wings.
// With Recovery::kLwop (the paper's "loss without prediction") a split whose
// data is missing, or that depends on one that was abandoned, is abandoned.
//
// Reliability bits (docs/design/design.md, "Prediction"): predicted vertices, split
// vertices a prediction moved, and every vertex whose ring a prediction
// changed are marked in the state's flags; a later split of a marked vertex
// checks its coded structure against the ring it really has.
//
// Contract: safe on any combination of arrived data (the refinement itself
// comes from the reliable channel and was validated by the reader). Never
// creates a collinear triangle where a fallback avoids it, never a
// non-manifold edge; keeps the vertex numbering (an abandoned split still
// takes its id). O(valence) per split with no allocation once `scratch` has
// grown. Thread safety: none.
#ifndef MESHSTREAM_CODEC_RECOVERY_RECOVER_SPLIT_H_
#define MESHSTREAM_CODEC_RECOVERY_RECOVER_SPLIT_H_

#include <cstddef>
#include <cstdint>
#include <vector>

#include "codec/core/status.h"
#include "codec/core/vec.h"
#include "codec/progressive/geometry_prediction.h"
#include "codec/progressive/refinement.h"
#include "codec/progressive/refinement_state.h"
#include "codec/progressive/cut_crossings.h"
#include "codec/progressive/wing_rank.h"
#include "codec/recovery/prediction.h"
#include "codec/recovery/ring_frame.h"

namespace meshstream {

enum class Recovery : uint8_t {
  kPredict = 0,  // predict lost structure and/or geometry (the default)
  kLwop = 1,     // loss without prediction: abandon lost splits and their dependants
};

// What became of the splits of the refinements finished so far.
struct RecoveryStats {
  uint64_t exact = 0;               // case 1: both arrived and applied as coded
  uint64_t predicted_both = 0;      // case 2: both lost, both predicted
  uint64_t predicted_structure = 0; // case 3: structure lost (or did not fit the ring), geometry arrived
  uint64_t predicted_geometry = 0;  // case 4: geometry lost, structure arrived
  uint64_t structure_fallbacks = 0; // arrived structure that did not fit the ring the decoder has
  uint64_t structure_distrusted = 0; // arrived structure on a changed ring, replaced by case 3
  uint64_t abandoned = 0;           // kLwop: splits not applied
  uint64_t planned = 0;             // of `exact`: planned on a runner's workers (StreamReader::SetTaskRunner)
  uint64_t predicted() const { return predicted_both + predicted_structure + predicted_geometry; }
  void Add(const RecoveryStats& o);
};

// Storage reused from split to split so that predicting one allocates nothing.
struct RecoveryScratch {
  std::vector<Vec3i> ring_positions;  // with coding tools: w's ring, filled once per split
  LocalFrame local_frame;             // and its local frame
  std::vector<Umbrella> umbrellas;    // and with the ring predictor reading the 2-ring, its umbrellas
  WingRanking ranking;
  CutCrossings crossings;
  std::vector<int32_t> values, u_channels, v_channels;
  RingFrame frame;
  PredictedGeometry geometry;
  // Seam pairs: per vertex, what the primary decided for its twin (1 apply,
  // 2 abandon, 0 not yet), and the twin's ring.
  std::vector<uint8_t> seam_decision;
  std::vector<uint32_t> twin_ring;
};

// Split j of `r` with only the parts that arrived (has_structure,
// has_geometry); the rest is predicted or, with kLwop, the split is
// abandoned. Errors (a split vertex that does not exist, or is not a closed
// manifold fan where a prediction needs one) leave the state valid.
// `r` holds the split's data as coded under `coding` (format version 2: the
// split vector's residual; geometry_prediction.h); the values the split was
// applied with are written to split j of `decoded`, which must be given
// when coding has tools (it may be `r` itself for version 1).
Status RecoverSplit(const Refinement& r, size_t j, bool has_structure, bool has_geometry, Recovery recovery,
                    RefinementState* state, RecoveryScratch* scratch, RecoveryStats* stats,
                    const SplitCoding& coding = {}, Refinement* decoded = nullptr);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_RECOVERY_RECOVER_SPLIT_H_
