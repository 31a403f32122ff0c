// What a streaming session sends, in which order, as byte ranges of the
// stored artifact (docs/spec/streaming-protocol.md): per primitive its stream
// header and base mesh first (the session start), then the refinements by
// the scene's levels (codec/progressive/scene_levels.h: within a level, the
// refinement that leaves the larger error first, whichever primitive it
// belongs to; without the layout's residual errors, refinement 0 of every
// primitive, then refinement 1, ...), each as its control block followed by
// its data datagrams. Built from the version's stored layout without
// decoding anything (services/pipeline/stream_layout.h).
//
// Contract: the artifact bytes and the layout JSON come from the store
// (verified blob, JSON written by the pipeline) but are still checked: a
// layout that does not fit the bytes is DataLoss. `max_level` < 0 means
// every refinement; otherwise the scene's levels up to that one.
// Thread safety: pure.
#ifndef MESHSTREAM_SERVICES_STREAMING_SESSION_PLAN_H_
#define MESHSTREAM_SERVICES_STREAMING_SESSION_PLAN_H_

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "codec/core/status.h"
#include "codec/progressive/view_order.h"
#include "services/pipeline/stream_layout.h"

namespace meshstream {

struct PlannedPrimitive {
  uint32_t stream = 0;  // the stream number in its datagrams' headers
  uint32_t mesh = 0;
  uint32_t mesh_primitive = 0;
  ByteRange header;
  ByteRange base;
  uint32_t refinements = 0;  // in this session
  // Per level of this session (1..levels), its refinements applied at that
  // level (PrimitiveStart.level_refinements).
  std::vector<uint32_t> level_refinements;
  std::map<std::string, int32_t> draco_attributes;  // semantic -> Draco attribute id of the base mesh
  // The reliable cut (codec/loss/reliable_cut.h) of the stored layout (a
  // share of 0: the artifact has none), and per refinement (all of the
  // stream's, not only this session's) its datagram bytes; `stream_bytes` is
  // what a share is taken of (base, header, control blocks and datagrams of
  // every refinement).
  DeliveryRecord delivery;
  std::vector<uint64_t> refinement_bytes;
  uint64_t stream_bytes = 0;
  // What a view orders by (codec/progressive/view_order.h): the stream's
  // residual errors (all of its refinements + 1; empty: the artifact has
  // none) and the box of its base in the scene, over every node that shows
  // it (has_bounds false: the file says nothing or no node shows it).
  std::vector<double> residual_error;
  Box bounds;
  bool has_bounds = false;
};

// The refinements of `p` its session sends reliably when the client reports
// `loss` (ReliableShareForLoss, then CutForBudget): ascending.
std::vector<uint32_t> ReliableCutFor(const PlannedPrimitive& p, double loss);

struct PlannedRefinement {
  uint32_t primitive = 0;  // index into SessionPlan::primitives
  uint32_t refinement = 0;
  uint32_t level = 0;  // the scene's level it first belongs to (1-based)
  ByteRange control;
  std::vector<ByteRange> datagrams;
};

struct SessionPlan {
  std::vector<PlannedPrimitive> primitives;
  bool reliable_profile = false;  // every primitive's stream is of the reliable profile
  std::vector<PlannedRefinement> refinements;  // in sending order
  uint64_t reliable_bytes = 0;    // headers, base meshes and control blocks
  uint64_t unreliable_bytes = 0;  // datagrams
  uint32_t levels = 0;            // the scene's levels in this session
};

// `reliable`: of each primitive its reliable profile's stream when the
// artifact has one (stream_layout.h: no datagrams), else its loss-tolerant one.
StatusOr<SessionPlan> PlanSession(const std::vector<uint8_t>& artifact, const std::string& layout_json,
                                  int32_t max_level, bool reliable = false);

// The plan of a session with `max_level` from `full`, the plan of every
// refinement (PlanSession with -1): the same as PlanSession with `max_level`,
// without reading the artifact or the layout again (hot_artifacts.h keeps
// `full`). `max_level` < 0: `full` as it is.
SessionPlan CutPlan(const SessionPlan& full, int32_t max_level);

// Whether every primitive of `plan` has what a view orders by (residual
// errors of every refinement and a box).
bool ViewCanOrder(const SessionPlan& plan);

// `plan` with its refinements from `begun` on ordered by `view`
// (ViewErrors over each primitive's remaining errors, then the scene's
// scheduler), the ones before kept where they are. The levels keep their
// sizes (level L is still its first as many refinements), so the levels
// whose refinements all lie before `begun` do not change: *first_changed is
// the first that may. nullopt when the plan lacks what a view orders by
// (ViewCanOrder), every refinement has begun, or the order would not change.
std::optional<SessionPlan> OrderByView(const SessionPlan& plan, size_t begun, const View& view,
                                       uint32_t* first_changed);

// The plan of a session with `view` and `max_level` from `full` (PlanSession
// with -1): every refinement ordered by the view (OrderByView from the
// first), then cut at `max_level` as CutPlan does. Without what a view
// orders by (ViewCanOrder), CutPlan.
SessionPlan ViewPlan(const SessionPlan& full, const View& view, int32_t max_level);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STREAMING_SESSION_PLAN_H_
