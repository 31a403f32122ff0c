// RecoverSplit: one split of a refinement with whatever of its data arrived.
// The driver classifies what is known of the split, then takes one of three
// paths: applied as coded (case 1), abandoned (LwoP), or predicted (cases
// 2-4), each a function below.
#include "codec/recovery/recover_split.h"

#include <algorithm>
#include <string>

#include "codec/progressive/midpoint.h"
#include "codec/progressive/normal_prediction.h"
#include "codec/progressive/texcoord_prediction.h"
#include "codec/recovery/degenerate_faces.h"

namespace meshstream {

namespace {

constexpr size_t kMaxScanValence = 32;

// What the decoder knows of split j before applying it.
struct SplitView {
  uint32_t w = 0;
  bool fan = false;         // w is a closed manifold fan; its ring is in state.scratch_ring
  bool fits = false;        // the coded wings fit that ring and are trusted
  bool distrusted = false;  // they fit, but the ring was changed by a prediction and geometry arrived
  size_t a_at = 0, b_at = 0;  // ring positions of the coded wings, when they fit (trusted or not)
  // With a tool that reads the ring's positions: its vertices' flags, OR-ed
  // (0 before the first prediction or abandoned split). A ring vertex whose
  // own ring a prediction changed may stand where the lossless ring has
  // another, so any flag means that the ring's frame and sums may differ.
  uint8_t ring_flags = 0;
};

constexpr ToolSet kRingTools = kToolGeometryPrediction | kToolLocalFrame | kToolWingRank | kToolTexcoordPrediction;

SplitView Classify(const Refinement& r, size_t j, bool has_structure, bool has_geometry, Recovery recovery,
                   const SplitCoding& coding, RefinementState& state, RecoveryScratch* scratch, RecoveryStats* stats) {
  SplitView view;
  view.w = r.split_vertices[j];
  const uint8_t flags = state.flags[view.w];
  view.fan = (flags & kAbsent) == 0 && state.connectivity.CyclicRing(view.w, state.scratch_ring);
  if (view.fan && (coding.tools & kRingTools) != 0) {
    RingGeometry(state, view.w, state.scratch_ring.data(), state.scratch_ring.size(), coding.tools,
                 &scratch->ring_positions, &scratch->local_frame);
  }
  // Error control: coded structure is checked against the ring the decoder
  // really has; what does not fit is treated as lost.
  view.fits = view.fan && has_structure &&
              CodedWingPositions(r.wings[j], coding.tools, state.scratch_ring, state.positions[view.w],
                                 scratch->ring_positions.data(), scratch->local_frame, &scratch->ranking,
                                 &scratch->crossings, &view.a_at, &view.b_at);
  // A ring a prediction changed may still fit the coded ranks and yet not be
  // the ring they count: when the geometry arrived, it decides the wings
  // (case 3) instead. Measured on the bunny at 12 % loss: the median
  // Hausdorff distance to the lossless decode drops from 1.5 % to 0.9 % of
  // the diagonal (docs/design/loss-tolerance.md).
  // Ranks in the ring's geometric order (the wing-rank tool) also count on
  // the ring's positions, and so do the split vector and the channels the
  // tools predict from the ring: a split applied as coded must be exact
  // (its vertices are not marked), so coded ranks on a ring with a
  // predicted position are distrusted. (Trusting them instead brought the
  // bunny closer to the lossless decode at 12 % loss, mean distance summed
  // over seeds 1-6 0.95 -> 0.89 % of the diagonal, but applied inexact
  // splits as exact; docs/design/loss-tolerance.md.)
  // (No flag is set before the first prediction or abandoned split.)
  // Without the rank, wings named by id fit or not whatever the positions,
  // but the split vector and the predicted channels still come from the
  // ring's positions: applied as coded, the split is then marked
  // (ApplyCoded).
  const bool any_flags = state.any_inexact || state.any_absent;
  if (view.fan && (coding.tools & kRingTools) != 0 && any_flags) {
    for (uint32_t x : state.scratch_ring) view.ring_flags |= state.flags[x];
  }
  const bool changed =
      (flags & kRingInexact) != 0 || ((coding.tools & kToolWingRank) != 0 && (view.ring_flags & kPositionInexact) != 0);
  const bool trust_ranks = recovery == Recovery::kLwop || !changed || !has_geometry;
  view.distrusted = view.fits && !trust_ranks;
  // The ring predictor's 2-ring term reads the ring's neighbours too: their
  // flags count like the ring's for the split vector (not for the ranks,
  // which read the ring alone).
  if (view.fan && ReadsUmbrellas(coding)) {
    RingUmbrellas(state, state.scratch_ring.data(), state.scratch_ring.size(), &scratch->umbrellas,
                  any_flags ? &view.ring_flags : nullptr);
  }
  if (view.distrusted) {
    view.fits = false;
    ++stats->structure_distrusted;
  }
  if (has_structure && view.fan && !view.fits && !view.distrusted) ++stats->structure_fallbacks;
  return view;
}

// The umbrellas Classify found for w's ring when the coding reads them.
const Umbrella* UmbrellasOf(const SplitCoding& coding, const RecoveryScratch& scratch) {
  return ReadsUmbrellas(coding) ? scratch.umbrellas.data() : nullptr;
}

// The split vector of split j from its coded form, on w's ring as
// RingGeometry found it, with the given wings.
Vec3i SplitVector(const Refinement& r, size_t j, const SplitCoding& coding, size_t a_at, size_t b_at,
                  const RecoveryScratch& scratch) {
  if (coding.tools == 0) return r.position_delta[j];
  return DecodeSplitVector(coding, r.position_delta[j], scratch.ring_positions.data(), scratch.ring_positions.size(),
                           a_at, b_at, scratch.local_frame, UmbrellasOf(coding, scratch));
}

// With texture coordinate prediction, the same for the texture coordinate
// and colour channels: the difference the ring's map predicts from the
// split vector (texcoord_prediction.h), on w's ring as RingGeometry found it.
void AddPredictedChannels(const SplitCoding& coding, size_t j, uint32_t w, uint32_t n, RefinementState& state,
                          const RecoveryScratch& scratch, Refinement* decoded) {
  if (coding.mapped_count <= 0) return;
  int32_t p[kMaxMappedChannels];
  PredictChannelDeltas(state, state.scratch_ring.data(), scratch.ring_positions.data(), scratch.ring_positions.size(),
                       scratch.local_frame, w, n, coding.mapped_first, coding.mapped_count, p);
  state.AddPredictedDeltas(j, w, n, static_cast<size_t>(coding.mapped_first), p,
                           static_cast<size_t>(coding.mapped_count), decoded);
}

// Case 1: applied as coded. Both vertices inherit what w depends on.
void ApplyCoded(const Refinement& r, size_t j, const SplitView& view, const SplitCoding& coding, Refinement* decoded,
                RefinementState& state, RecoveryScratch* scratch, RecoveryStats* stats) {
  ++stats->exact;
  const uint32_t w = view.w;
  const Refinement* apply = &r;
  if (coding.tools != 0) {
    decoded->position_delta[j] = SplitVector(r, j, coding, view.a_at, view.b_at, *scratch);
    if (coding.tools & kToolWingRank) decoded->wings[j] = WingsOf(state.scratch_ring, view.a_at, view.b_at);
    apply = decoded;
  }
  const uint32_t n = state.ApplySplitAt(*apply, j, view.a_at, view.b_at);
  AddPredictedNormals(coding.normal_bits, j, w, n, state, decoded);
  AddPredictedChannels(coding, j, w, n, state, *scratch, decoded);
  state.flags[n] = state.flags[w];
  state.reliable[n] = state.flags[n] == 0;
  // Exact values next to predicted ones, or on a ring a prediction changed,
  // can still line up. (Whether a ring is the lossless one is not known
  // cheaply enough to skip the check: it runs after any prediction.)
  // Values computed from predicted ring positions are predicted too.
  const bool moved = state.any_inexact && AvoidDegenerateFaces(&state, w, n);
  if (moved || view.ring_flags != 0) {
    state.Mark(w, kPositionInexact);
    state.Mark(n, kPositionInexact);
  }
}

// LwoP (paper, section 5.3): data lost, w never created, left unsplit by an
// earlier abandoned split, or next to one (its ring then lacks a vertex the
// coded wings may count). The new id stays reserved (kAbsent); w keeps its
// coarse position; its neighbours, which the new vertex would have joined,
// no longer have the lossless rings.
void Abandon(const Refinement& r, size_t j, const SplitView& view, RefinementState& state, RecoveryStats* stats) {
  ++stats->abandoned;
  const uint32_t w = view.w;
  const std::vector<uint32_t>& ring = state.scratch_ring;
  const bool lossless_ring = state.flags[w] == 0;
  state.Mark(w, kPositionInexact | kRingInexact);
  if (view.fits && lossless_ring) {
    // Known structure on the lossless ring: exactly the vertices the new
    // vertex would have joined (ring[b..a]) lose a ring entry or change one.
    const size_t d = ring.size();
    for (size_t step = 0, path = (view.a_at + d - view.b_at) % d; step <= path; ++step) {
      state.Mark(ring[(view.b_at + step) % d], kRingInexact);
    }
  } else if (view.fan) {
    for (uint32_t x : ring) state.Mark(x, kRingInexact);
  }
  const int channels = state.channels;
  state.connectivity.AddIsolatedVertex();
  state.positions.push_back(state.positions[w]);
  state.attributes.resize(state.attributes.size() + size_t(channels));
  std::copy_n(state.attributes.begin() + size_t(w) * channels, channels, state.attributes.end() - channels);
  state.flags.push_back(kAbsent | kRingInexact | kPositionInexact);
  state.reliable.push_back(0);
  state.PushTwin(r, j);
  state.any_absent = true;
}

// A seam split (w has a twin). The pair is applied or abandoned as one, so
// that the two sides never part (a crack): the primary decides, the
// secondary follows. Both sides' data travel in one unit, so they arrive
// together. The split vector is raw: applied from it the pair is exact where
// w is. Without it, prediction puts the pair on the seam from what both
// sides share: w and its two boundary neighbours, which only seam splits
// move, so that both sides predict the same point (SeamPrediction). LwoP
// abandons the pair when the vector is lost or either side's ring may not be
// the lossless one. A lost or unfitting wing is predicted on each side: the
// ring vertex nearest the new vertex.
Status RecoverSeamSplit(const Refinement& r, size_t j, bool has_structure, bool has_geometry, Recovery recovery,
                        RefinementState& state, RecoveryScratch* scratch, RecoveryStats* stats, Refinement* decoded) {
  if (decoded == nullptr) return Internal("RecoverSplit: seam splits need a decoded refinement");
  const uint32_t w = r.split_vertices[j];
  const uint32_t t = state.twin[w];
  const bool primary = w < t;
  std::vector<uint8_t>& decision = scratch->seam_decision;
  if (decision.size() < state.connectivity.vertex_count()) decision.resize(state.connectivity.vertex_count(), 0);
  SplitView view;
  view.w = w;
  view.fan = (state.flags[w] & kAbsent) == 0 && state.connectivity.OpenRing(w, state.scratch_ring);
  bool apply = false;
  if (primary) {
    std::vector<uint32_t>& other = scratch->twin_ring;
    const bool twin_fan = (state.flags[t] & kAbsent) == 0 && state.connectivity.OpenRing(t, other);
    // OpenRing(t) left its own triangles in the connectivity's scratch: w's again.
    if (view.fan) state.connectivity.OpenRing(w, state.scratch_ring);
    apply = view.fan && twin_fan &&
            (recovery == Recovery::kPredict || (has_geometry && state.flags[w] == 0 && state.flags[t] == 0));
    decision[t] = apply ? 1 : 2;
  } else {
    apply = decision[w] == 1 && view.fan;
    decision[w] = 0;
  }
  if (!apply) {
    Abandon(r, j, view, state, stats);
    return Status::Ok();
  }
  const std::vector<uint32_t>& ring = state.scratch_ring;
  const int channels = state.channels;
  const uint8_t inherited = state.flags[w];
  // The values the pair is applied with, in `decoded`.
  Vec3i& delta = decoded->position_delta[j];
  int32_t* channel_delta = decoded->attribute_delta.data() + j * size_t(channels);
  if (has_geometry) {
    delta = r.position_delta[j];
    std::copy_n(r.attribute_delta.begin() + j * size_t(channels), channels, channel_delta);
  } else {
    // The primary's new vertex takes the tail (toward ring.back()), so u - v
    // points from the tail to the head: a third of the way between the two
    // boundary neighbours, as if the three were evenly spaced. The secondary's
    // ring runs the other way round, so both sides compute the same vector.
    const uint32_t head = ring.front(), tail = ring.back();
    const uint32_t from = primary ? head : tail, to = primary ? tail : head;
    for (int k = 0; k < 3; ++k) {
      delta[k] = static_cast<int32_t>((int64_t{state.positions[from][k]} - state.positions[to][k]) / 3);
    }
    for (int k = 0; k < channels; ++k) {
      channel_delta[k] = static_cast<int32_t>((int64_t{state.attributes[size_t(from) * channels + k]} -
                                               state.attributes[size_t(to) * channels + k]) / 3);
    }
  }
  size_t a_at = r.wings[j][0];
  const bool fits = has_structure && a_at < ring.size() && (inherited & kRingInexact) == 0;
  if (!fits) {
    if (has_structure) ++stats->structure_fallbacks;
    // The wing nearest the new vertex.
    const Vec3i& s = state.positions[w];
    Vec3i nv{};
    for (int k = 0; k < 3; ++k) {
      const int32_t u = FromMidpoint(s[k], delta[k]);
      nv[k] = static_cast<int32_t>(int64_t{u} - delta[k]);
    }
    double best = 1e300;
    for (size_t k = 0; k < ring.size(); ++k) {
      double d2 = 0;
      for (int c = 0; c < 3; ++c) {
        const double e = double(state.positions[ring[k]][c]) - nv[c];
        d2 += e * e;
      }
      if (d2 < best) {
        best = d2;
        a_at = k;
      }
    }
    for (uint32_t x : ring) state.Mark(x, kRingInexact);
  }
  if (fits && has_geometry) ++stats->exact;
  else if (has_geometry) ++stats->predicted_structure;
  else if (fits) ++stats->predicted_geometry;
  else ++stats->predicted_both;
  decoded->wings[j] = {static_cast<uint16_t>(a_at), 0};
  const uint32_t n = state.ApplySeamSplitAt(*decoded, j, a_at);
  uint8_t both = inherited;
  if (!fits) both |= kRingInexact;
  if (!has_geometry) both |= kPositionInexact;
  state.Mark(w, both);
  state.Mark(n, both);
  if (!fits || !has_geometry) state.any_inexact = true;
  return Status::Ok();
}

// Would the split of w into (u, v) with wings at ring positions a, b make a
// collinear triangle?
bool SplitIsDegenerate(const std::vector<Vec3i>& ring, const Vec3i& u, const Vec3i& v, size_t a, size_t b) {
  const size_t d = ring.size();
  if (Collinear(u, v, ring[a]) || Collinear(v, u, ring[b])) return true;
  const size_t path = (a + d - b) % d;
  for (size_t step = 0; step < d; ++step) {
    const size_t k = (b + step) % d;
    if (Collinear(step < path ? v : u, ring[k], ring[(k + 1) % d])) return true;
  }
  return false;
}

// A split being predicted: its pair of positions and channels, and its wings.
struct PredictedSplit {
  Vec3i u{}, v{};     // w's and the new vertex's positions after the split
  size_t a_at = 0, b_at = 0;
  bool structure = false;  // the wings are the coded ones (trusted)
};

// The arrived geometry of split j (its split vector `delta`), undone around
// w's current values.
void ArrivedGeometry(const Refinement& r, size_t j, const Vec3i& delta, const RefinementState& state, uint32_t w,
                     PredictedSplit* split, RecoveryScratch* scratch) {
  const Vec3i& s = state.positions[w];
  for (int k = 0; k < 3; ++k) {
    split->u[k] = FromMidpoint(s[k], delta[k]);
    split->v[k] = static_cast<int32_t>(int64_t(split->u[k]) - delta[k]);
  }
  const int channels = state.channels;
  for (int k = 0; k < channels; ++k) {
    const int32_t dk = r.attribute_delta[j * channels + k];
    scratch->u_channels[k] = FromMidpoint(state.attributes[size_t(w) * channels + k], dk);
    scratch->v_channels[k] = static_cast<int32_t>(int64_t(scratch->u_channels[k]) - dk);
  }
}

// Cases 2 and 4: the geometry of the pair from the ring (paper, step 6),
// with the centroid of (w, a, b) as a fallback where it would be degenerate.
void PredictPairGeometry(const RefinementState& state, uint32_t w, const std::vector<uint32_t>& ring,
                         const Vec2d& new_uv, PredictedSplit* split, RecoveryScratch* scratch) {
  const int channels = state.channels;
  std::vector<int32_t>& values = scratch->values;
  values.clear();
  values.insert(values.end(), state.attributes.begin() + size_t(w) * channels,
                state.attributes.begin() + size_t(w + 1) * channels);
  for (uint32_t x : ring) {
    values.insert(values.end(), state.attributes.begin() + size_t(x) * channels,
                  state.attributes.begin() + size_t(x + 1) * channels);
  }
  PredictedGeometry& g = scratch->geometry;
  PredictGeometry(scratch->frame, split->a_at, split->b_at, new_uv, values, channels, &g,
                  split->structure ? 1.0 : kCase2Spread);
  // A predicted vertex must not make a triangle of w's or n's collinear; the
  // first fallback keeps w where it is and puts n at the centroid of (w, a, b).
  const std::vector<Vec3i>& rp = scratch->ring_positions;
  if (SplitIsDegenerate(rp, g.u, g.v, split->a_at, split->b_at)) {
    const Vec3i& s = state.positions[w];
    Vec3i c{};
    for (int k = 0; k < 3; ++k) {
      c[k] = static_cast<int32_t>((int64_t(s[k]) + rp[split->a_at][k] + rp[split->b_at][k]) / 3);
    }
    if (!SplitIsDegenerate(rp, s, c, split->a_at, split->b_at)) {
      g.u = s;
      g.v = c;
    }
  }
  split->u = g.u;
  split->v = g.v;
  scratch->u_channels.swap(g.u_channels);
  scratch->v_channels.swap(g.v_channels);
}

// Last resort, rare (a wrong ring or a prediction on a sliver): the wings
// that make no collinear triangle and best separate the ring between u and
// v. O(valence^3), only when the choice so far would be degenerate. True
// when it found such wings.
bool SeparatingWings(const std::vector<Vec3i>& rp, PredictedSplit* split) {
  const size_t d = rp.size();
  const Vec3i& u = split->u;
  const Vec3i& v = split->v;
  const Vec3d dir = {double(v[0]) - u[0], double(v[1]) - u[1], double(v[2]) - u[2]};
  auto score = [&](size_t k) {
    double t = 0;
    for (int c = 0; c < 3; ++c) t += (rp[k][c] - (double(u[c]) + v[c]) / 2) * dir[c];
    return t;
  };
  double best = -1e300;
  bool found = false;
  for (size_t b = 0; b < d; ++b) {
    for (size_t a = 0; a < d; ++a) {
      if (a == b || SplitIsDegenerate(rp, u, v, a, b)) continue;
      double value = score(a) + score(b);
      for (size_t k = (b + 1) % d; k != a; k = (k + 1) % d) value += 2 * score(k);
      if (value > best) {
        best = value;
        split->a_at = a;
        split->b_at = b;
        found = true;
      }
    }
  }
  return found;
}

// Cases 2-4: predicts what is missing, applies the split and sets the
// reliability bits.
Status Predict(const Refinement& r, size_t j, bool has_geometry, const SplitView& view, const SplitCoding& coding,
               Refinement* decoded, RefinementState& state, RecoveryScratch* scratch, RecoveryStats* stats) {
  const uint32_t w = view.w;
  if (!view.fan) return InvalidInput("split vertex " + std::to_string(w) + " is not a closed manifold fan");
  const std::vector<uint32_t>& ring = state.scratch_ring;
  const size_t d = ring.size();
  std::vector<Vec3i>& rp = scratch->ring_positions;
  rp.resize(d);
  for (size_t k = 0; k < d; ++k) rp[k] = state.positions[ring[k]];
  FitRingFrame(state.positions[w], rp, &scratch->frame, /*least_squares=*/!has_geometry);
  scratch->u_channels.resize(static_cast<size_t>(state.channels));
  scratch->v_channels.resize(static_cast<size_t>(state.channels));

  PredictedSplit split;
  split.structure = view.fits;
  split.a_at = view.a_at;
  split.b_at = view.b_at;
  // Version 2: the arrived split vector is relative to a prediction on the
  // wings, so without trusted wings (case 3, and wings that fit a changed
  // ring) it says little: it is dropped and both are predicted (case 2).
  // Measured at 12 % loss, split packing: on the wings case 2 would predict,
  // the geometry made fandisk farther from the lossless decode than LwoP on
  // 3 of 4 seeds; decoded on the first of the ring's pairs in rank order
  // whose geometry separates the ring at those wings, it brought the bunny
  // closer (ranks trusted on predicted positions, mean distance summed over
  // seeds 1-6: 0.89 -> 0.77 per cent of
  // the diagonal) but fandisk farther than LwoP on all 6 seeds
  // (docs/design/loss-tolerance.md).
  const bool relative = (coding.tools & kToolGeometryPrediction) != 0;
  const bool geometry = has_geometry && !(relative && !split.structure);
  Vec3i delta{};
  Vec2d new_uv{};
  if (geometry) {
    delta = DecodeSplitVector(coding, r.position_delta[j], rp.data(), d, split.a_at, split.b_at, scratch->local_frame,
                              UmbrellasOf(coding, *scratch));
    ArrivedGeometry(r, j, delta, state, w, &split, scratch);
  }
  if (!split.structure) {
    const PredictedWings wings =
        geometry ? WingsFromGeometry(scratch->frame, split.u, split.v) : PredictWings(scratch->frame);
    // Geometry and ranks agree: the coded structure, as if trusted (the
    // ring is not changed further, so errors stop spreading here).
    if (view.distrusted && wings.a_at == view.a_at && wings.b_at == view.b_at) split.structure = true;
    split.a_at = wings.a_at;
    split.b_at = wings.b_at;
    new_uv = wings.new_uv;
  } else if (!geometry) {
    new_uv = NewVertexUv(scratch->frame, split.a_at, split.b_at);
  }
  if (!geometry) PredictPairGeometry(state, w, ring, new_uv, &split, scratch);
  if (SplitIsDegenerate(rp, split.u, split.v, split.a_at, split.b_at) && d <= kMaxScanValence) {
    if (SeparatingWings(rp, &split) && split.structure) {
      split.structure = false;
      ++stats->structure_fallbacks;
    }
  }
  // Reliability bits (paper, section 4.5; docs/design/design.md, "Prediction"): the
  // vertices of a split inherit what w depends on; predicted geometry marks
  // both; predicted structure marks both and the neighbours the new vertex
  // joins (ring[b..a]), whose rings it changed. Nothing spreads further: a
  // later split of a marked vertex checks its structure against its real ring.
  uint8_t both = state.flags[w] & (kRingInexact | kPositionInexact);
  if (!geometry) both |= kPositionInexact;
  // Arrived geometry decoded on the ring's positions (version 2's
  // prediction and frame) is exact only where they are.
  if (geometry && both == 0 && view.ring_flags != 0) both |= kPositionInexact;
  if (!split.structure) {
    both |= kRingInexact;
    const size_t path = (split.a_at + d - split.b_at) % d;
    for (size_t step = 0; step <= path; ++step) state.Mark(ring[(split.b_at + step) % d], kRingInexact);
    ++(geometry ? stats->predicted_structure : stats->predicted_both);
  } else if (!geometry) {
    ++stats->predicted_geometry;
  } else {
    ++stats->exact;
  }

  if (decoded && geometry) decoded->position_delta[j] = delta;
  state.twin.push_back(kNoTwin);
  const int channels = state.channels;
  const uint32_t n = state.connectivity.SplitAt(w, ring, split.a_at, split.b_at);
  state.positions[w] = split.u;
  state.positions.push_back(split.v);
  state.attributes.resize(state.attributes.size() + size_t(channels));
  std::copy(scratch->u_channels.begin(), scratch->u_channels.end(), state.attributes.begin() + size_t(w) * channels);
  std::copy(scratch->v_channels.begin(), scratch->v_channels.end(), state.attributes.begin() + size_t(n) * channels);
  if (geometry) AddPredictedNormals(coding.normal_bits, j, w, n, state, decoded);
  if (geometry) AddPredictedChannels(coding, j, w, n, state, *scratch, decoded);
  state.flags.push_back(0);
  state.reliable.push_back(1);
  if (AvoidDegenerateFaces(&state, w, n)) both |= kPositionInexact;
  state.any_inexact = true;
  state.Mark(w, both);
  state.Mark(n, both);
  return Status::Ok();
}

}  // namespace

void RecoveryStats::Add(const RecoveryStats& o) {
  exact += o.exact;
  predicted_both += o.predicted_both;
  predicted_structure += o.predicted_structure;
  predicted_geometry += o.predicted_geometry;
  structure_fallbacks += o.structure_fallbacks;
  structure_distrusted += o.structure_distrusted;
  abandoned += o.abandoned;
  planned += o.planned;
}

Status RecoverSplit(const Refinement& r, size_t j, bool has_structure, bool has_geometry, Recovery recovery,
                    RefinementState* state, RecoveryScratch* scratch, RecoveryStats* stats, const SplitCoding& coding,
                    Refinement* decoded) {
  if (coding.tools != 0 && decoded == nullptr) return Internal("RecoverSplit: coded splits need a decoded refinement");
  const uint32_t w = r.split_vertices[j];
  if (w >= state->connectivity.vertex_count()) {
    return InvalidInput("split vertex " + std::to_string(w) + " does not exist");
  }
  if (state->twin[w] != kNoTwin) {
    return RecoverSeamSplit(r, j, has_structure, has_geometry, recovery, *state, scratch, stats, decoded);
  }
  const SplitView view = Classify(r, j, has_structure, has_geometry, recovery, coding, *state, scratch, stats);
  // LwoP applies a split only where w's ring is known to be the lossless
  // one: coded wings name ring vertices by rank, and a ring that lacks a
  // vertex LwoP never created could still fit them and name the wrong ones.
  // Prediction applies arrived data wherever it fits: geometry relative to
  // a predicted w gives a predicted pair, marked as such.
  const bool applicable = recovery == Recovery::kLwop ? state->flags[w] == 0 : true;
  if (view.fits && has_geometry && applicable) {
    ApplyCoded(r, j, view, coding, decoded, *state, scratch, stats);
    return Status::Ok();
  }
  // A vertex a seam split left absent (prediction abandons those too) has
  // nothing to split.
  if (recovery == Recovery::kLwop || (state->flags[w] & kAbsent) != 0) {
    Abandon(r, j, view, *state, stats);
    return Status::Ok();
  }
  return Predict(r, j, has_geometry, view, coding, decoded, *state, scratch, stats);
}

}  // namespace meshstream
