// A refinement whose data all arrived, decoded in two phases so that its
// splits can run on several cores with the output bit-identical to the
// one-thread decode (docs/results/decode-profile.md, "The batch in parallel"):
//
//   Plan (phase A, tasks on a TaskRunner, read-only on the state): per
//   split, w's ring and its triangles, the ring's positions and local
//   frame, the wings (rank or ids), the ring predictor's 2-ring term, the
//   split vector, the texture coordinate predictions;
//   Apply (phase B, one thread, in split order): the connectivity split from
//   the recorded ring, the values, the normal predictions (they read the new
//   fan) and the appends that fix the new vertices' ids.
//
// Why a plan is the serial decode's: the split vertices of a refinement are
// pairwise non-adjacent (checked here: a split whose ring holds another
// split vertex is not planned), so no split changes another's triangles, its
// ring's positions or values, and the 2-ring term counts only vertices no
// split of the refinement changes (RefinementState::BeginSplits). Valid only
// while no vertex carries a flag (RefinementState::any_inexact and
// any_absent false): a flag makes later splits depend on earlier ones.
//
// Seam splits (w has a twin) are not planned: the caller applies them in
// their turn by the serial path. A split that cannot be applied as coded (w
// not a closed fan, wings that do not fit its ring, a split neighbour) is
// not planned either, and the caller takes the serial path from it on.
//
// Contract: safe on any refinement the reader validated (hostile wings and
// vectors included); Plan writes nothing but the plan; no allocation once
// the plan's storage has grown. Thread safety: Plan calls the runner's
// tasks concurrently, each with its own worker scratch; Apply is serial.
#ifndef MESHSTREAM_CODEC_PROGRESSIVE_PARALLEL_REFINEMENT_H_
#define MESHSTREAM_CODEC_PROGRESSIVE_PARALLEL_REFINEMENT_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "codec/core/task_runner.h"
#include "codec/core/vec.h"
#include "codec/progressive/cut_crossings.h"
#include "codec/progressive/geometry_prediction.h"
#include "codec/progressive/local_frame.h"
#include "codec/progressive/refinement.h"
#include "codec/progressive/refinement_state.h"
#include "codec/progressive/ring_predictor.h"
#include "codec/progressive/split_connectivity.h"
#include "codec/progressive/wing_rank.h"

namespace meshstream {

class RefinementPlan {
 public:
  enum class Kind : uint8_t {
    kPlanned = 0,  // Apply applies it
    kSerial = 1,   // a seam split: the caller applies it by the serial path
    kStop = 2,     // cannot be applied as coded: the serial path from here on
  };
  // Splits per task, and per window (the plan holds one window at a time,
  // so its memory stays small whatever the refinement's size).
  static constexpr size_t kTaskSplits = 512;
  static constexpr size_t kWindowSplits = 64 * kTaskSplits;

  // Plans splits [first, first + count) of `coded` (count at most
  // kWindowSplits) on `state`, whose splitting marks must be set
  // (BeginSplits(coded)) and whose flags must all be 0.
  void Plan(const Refinement& coded, const SplitCoding& coding, const RefinementState& state, size_t first,
            size_t count, TaskRunner& runner);
  Kind kind(size_t j) const { return plans_[j - first_].kind; }
  // Whether planned split j still holds on `state` as it is now, right
  // before its turn: a plan that read the ring predictor's umbrellas holds
  // unless a ring vertex's triangle count crossed kMaxUmbrellaFaces since
  // the plan (a vertex of more triangles has none; the earlier splits of the
  // refinement add triangles to their wings). One that does not hold is
  // applied by the serial path.
  bool Holds(size_t j, const RefinementState& state) const;
  // Applies planned split j (in split order, within the planned window),
  // writing what it was applied with to split j of `decoded` (which holds
  // the coded data on entry; `coded` itself for coding without tools).
  void Apply(const Refinement& coded, size_t j, const SplitCoding& coding, RefinementState* state,
             Refinement* decoded) const;

 private:
  struct Split {
    uint32_t ring_at = 0;  // into its task's rings and faces
    uint32_t degree = 0;
    uint32_t a_at = 0, b_at = 0;
    Vec3i delta{};                      // the split vector decoded
    std::array<uint16_t, 2> wings{};    // the wings as decoded->wings holds them
    bool umbrellas = false;             // the split vector read the umbrellas
    uint64_t small = 0;                 // then: bit k set when ring[k] had at most kMaxUmbrellaFaces triangles
    Kind kind = Kind::kStop;
  };
  // Each on cache lines of its own: the workers write their task's vectors
  // and their scratch at every split, and two of them sharing a line would
  // pass it back and forth between the cores.
  struct alignas(64) Task {
    std::vector<uint32_t> rings, faces;
  };
  struct alignas(64) Worker {
    SplitConnectivity::RingWalk walk;
    std::vector<uint32_t> ring;
    std::vector<Vec3i> ring_positions;
    LocalFrame frame;
    WingRanking ranking;
    CutCrossings crossings;
    std::vector<Umbrella> umbrellas;
  };
  void PlanSplit(const Refinement& coded, const SplitCoding& coding, const RefinementState& state, size_t j,
                 Worker& worker, Task& task, Split& out, int32_t* mapped) const;

  size_t first_ = 0;
  std::vector<Split> plans_;
  std::vector<Task> tasks_;
  std::vector<Worker> workers_;
  std::vector<int32_t> mapped_;  // per planned split: its texture coordinate predictions (coding.mapped_count)
};

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_PROGRESSIVE_PARALLEL_REFINEMENT_H_
