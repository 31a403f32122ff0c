// What a level means across the primitives of a scene, and the order their
// refinements travel in (docs/spec/streaming-protocol.md, "Levels of a scene";
// docs/spec/progressive-format.md, "Levels of a scene").
//
// The order: every refinement of every primitive, by the error its
// primitive still has before it (progressive/residual_error.h, in scene
// units: the primitive's grid step times the largest scale a node gives it),
// larger first; ties: the lower primitive, then the coarser refinement. A
// primitive's own errors never grow, so its refinements keep their order.
// The levels: a scene has as many as its primitives' most refinements (N),
// and level L is the first ceil(L x T / N) refinements of that order (T: all
// of them). A scene of one primitive therefore has its refinements as levels.
// Without errors for every primitive (files made before them), level L is
// min(L, refinements) of each primitive and the order is level by level,
// primitive by primitive.
//
// Why the largest error and not the error per byte: the distance a viewer
// sees is the worst place of the scene (the Hausdorff distance the
// benchmarks measure). To get under any error e, every refinement whose
// error before it is above e must arrive and no other is needed; sending
// refinements by that error, largest first, reaches every e with the fewest
// bytes there are, whatever the bytes of each refinement. A small part with
// coarse errors refines early, a large smooth one late.
//
// Contract: pure, safe on any input: `errors` should hold one vector per
// primitive of refinements[p] + 1 finite, non-negative, non-increasing
// values (ParseResidualErrors checks this for what it reads); when any
// differs in size, the scene gets the levels of a scene without errors.
#ifndef MESHSTREAM_CODEC_PROGRESSIVE_SCENE_LEVELS_H_
#define MESHSTREAM_CODEC_PROGRESSIVE_SCENE_LEVELS_H_

#include <cstddef>
#include <cstdint>
#include <vector>

namespace meshstream {

struct ScheduledRefinement {
  uint32_t primitive = 0;
  uint32_t refinement = 0;
  uint32_t level = 0;  // the first level that applies it (1-based)
};

struct SceneLevels {
  uint32_t levels = 0;  // the most refinements of any primitive
  // applied[p][L - 1]: refinements of primitive p applied at level L (1..levels);
  // non-decreasing in L, applied[p][levels - 1] == refinements[p].
  std::vector<std::vector<uint32_t>> applied;
  // Every refinement in sending order; each level is a prefix of it.
  std::vector<ScheduledRefinement> order;

  // Refinements of `primitive` at `level` (0: none; beyond the last: all).
  uint32_t At(size_t primitive, uint32_t level) const;
};

SceneLevels ScheduleSceneLevels(const std::vector<uint32_t>& refinements,
                                const std::vector<std::vector<double>>& errors);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_PROGRESSIVE_SCENE_LEVELS_H_
