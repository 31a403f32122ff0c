// RefinementState::RecoverSplit: one split of a refinement with whatever of
// its data arrived (paper, sections 4.3-4.5 and 5.3; docs/loss-tolerance.md).
#include <algorithm>

#include "codec/batch_simplifier.h"
#include "codec/progressive_mesh.h"
#include "codec/split_prediction.h"

namespace meshstream {

namespace {

constexpr size_t kMaxScanValence = 32;

// Twice the area vector of (a, b, c) on the integer grid is zero.
bool Collinear(const Vec3i& a, const Vec3i& b, const Vec3i& c) {
  const int64_t e[3] = {int64_t(b[0]) - a[0], int64_t(b[1]) - a[1], int64_t(b[2]) - a[2]};
  const int64_t f[3] = {int64_t(c[0]) - a[0], int64_t(c[1]) - a[1], int64_t(c[2]) - a[2]};
  return e[1] * f[2] - e[2] * f[1] == 0 && e[2] * f[0] - e[0] * f[2] == 0 && e[0] * f[1] - e[1] * f[0] == 0;
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
}

Status RefinementState::RecoverSplit(const Refinement& r, size_t j, bool has_structure, bool has_geometry,
                                     Recovery recovery, RecoveryStats* stats) {
  const uint32_t w = r.split_vertices[j];
  if (w >= connectivity.vertex_count()) return InvalidInput("split vertex " + std::to_string(w) + " does not exist");
  auto mark = [&](uint32_t v, uint8_t bits) {
    flags[v] |= bits;
    reliable[v] = flags[v] == 0;
  };
  std::vector<uint32_t>& ring = scratch_ring;
  const bool fan = (flags[w] & kAbsent) == 0 && connectivity.CyclicRing(w, ring);
  // Error control: coded structure is checked against the ring the decoder
  // really has; what does not fit is treated as lost.
  size_t a_at = 0, b_at = 0;
  bool fits = fan && has_structure && WingPositions(ring, r.wings[j], &a_at, &b_at);
  // A ring a prediction changed may still fit the coded ranks and yet not be
  // the ring they count: when the geometry arrived, it decides the wings
  // (case 3) instead. Measured on the bunny at 12 % loss: the median
  // Hausdorff distance to the lossless decode drops from 1.5 % to 0.9 % of
  // the diagonal (docs/loss-tolerance.md).
  const bool trust_ranks = recovery == Recovery::kLwop || (flags[w] & kRingInexact) == 0 || !has_geometry;
  const bool distrusted = fits && !trust_ranks;
  size_t coded_a = a_at, coded_b = b_at;
  if (distrusted) {
    fits = false;
    ++stats->structure_distrusted;
  }
  if (has_structure && fan && !fits && !distrusted) ++stats->structure_fallbacks;
  // LwoP applies a split only where w's ring is known to be the lossless
  // one: coded wings name ring vertices by rank, and a ring that lacks a
  // vertex LwoP never created could still fit them and name the wrong ones.
  // Prediction applies arrived data wherever it fits: geometry relative to
  // a predicted w gives a predicted pair, marked as such.
  const bool applicable = recovery == Recovery::kLwop ? flags[w] == 0 : true;
  if (fits && has_geometry && applicable) {
    // Case 1: applied as coded. Both vertices inherit what w depends on.
    ++stats->exact;
    const uint32_t n = ApplySplitAt(r, j, a_at, b_at);
    flags[n] = flags[w];
    reliable[n] = flags[n] == 0;
    // Exact values next to predicted ones, or on a ring a prediction changed,
    // can still line up. (Whether a ring is the lossless one is not known
    // cheaply enough to skip the check: it runs after any prediction.)
    if (any_inexact && AvoidDegenerateFaces(w, n)) {
      mark(w, kPositionInexact);
      mark(n, kPositionInexact);
    }
    return Status::Ok();
  }

  if (recovery == Recovery::kLwop) {
    // Abandoned (paper, section 5.3): data lost, w never created, left
    // unsplit by an earlier abandoned split, or next to one (its ring then
    // lacks a vertex the coded wings may count). The new id stays reserved
    // (kAbsent); w keeps its coarse position; its neighbours, which the new
    // vertex would have joined, no longer have the lossless rings.
    ++stats->abandoned;
    const bool lossless_ring = flags[w] == 0;
    mark(w, kPositionInexact | kRingInexact);
    if (fits && lossless_ring) {
      // Known structure on the lossless ring: exactly the vertices the new
      // vertex would have joined (ring[b..a]) lose a ring entry or change one.
      const size_t d = ring.size();
      for (size_t step = 0, path = (a_at + d - b_at) % d; step <= path; ++step) {
        mark(ring[(b_at + step) % d], kRingInexact);
      }
    } else if (fan) {
      for (uint32_t x : ring) mark(x, kRingInexact);
    }
    connectivity.AddIsolatedVertex();
    positions.push_back(positions[w]);
    attributes.resize(attributes.size() + size_t(channels));
    std::copy_n(attributes.begin() + size_t(w) * channels, channels, attributes.end() - channels);
    flags.push_back(kAbsent | kRingInexact | kPositionInexact);
    reliable.push_back(0);
    any_absent = true;
    return Status::Ok();
  }

  if (!fan) return InvalidInput("split vertex " + std::to_string(w) + " is not a closed manifold fan");
  bool structure = fits;

  std::vector<Vec3i>& ring_positions = prediction.ring_positions;
  ring_positions.resize(ring.size());
  for (size_t k = 0; k < ring.size(); ++k) ring_positions[k] = positions[ring[k]];
  const Vec3i s = positions[w];
  RingFrame& frame = prediction.frame;
  FitRingFrame(s, ring_positions, &frame, /*least_squares=*/!has_geometry);

  Vec3i u{}, v{};
  std::vector<int32_t>& u_ch = prediction.u_channels;
  std::vector<int32_t>& v_ch = prediction.v_channels;
  u_ch.resize(static_cast<size_t>(channels));
  v_ch.resize(static_cast<size_t>(channels));
  if (has_geometry) {
    for (int k = 0; k < 3; ++k) {
      u[k] = FromMidpoint(s[k], r.position_delta[j][k]);
      v[k] = static_cast<int32_t>(int64_t(u[k]) - r.position_delta[j][k]);
    }
    for (int k = 0; k < channels; ++k) {
      const int32_t dk = r.attribute_delta[j * channels + k];
      u_ch[k] = FromMidpoint(attributes[size_t(w) * channels + k], dk);
      v_ch[k] = static_cast<int32_t>(int64_t(u_ch[k]) - dk);
    }
  }
  // Would the split (u, v, wings at a_at, b_at) make a collinear triangle?
  const size_t d = ring.size();
  auto degenerate = [&](const Vec3i& pu, const Vec3i& pv, size_t a, size_t b) {
    if (Collinear(pu, pv, ring_positions[a]) || Collinear(pv, pu, ring_positions[b])) return true;
    const size_t path = (a + d - b) % d;
    for (size_t step = 0; step < d; ++step) {
      const size_t k = (b + step) % d;
      if (Collinear(step < path ? pv : pu, ring_positions[k], ring_positions[(k + 1) % d])) return true;
    }
    return false;
  };
  Vec2d new_uv{};
  if (!structure) {
    const PredictedWings wings = has_geometry ? WingsFromGeometry(frame, u, v) : PredictWings(frame);
    a_at = wings.a_at;
    b_at = wings.b_at;
    new_uv = wings.new_uv;
    // Geometry and ranks agree: the coded structure, as if trusted (the
    // ring is not changed further, so errors stop spreading here).
    if (distrusted && a_at == coded_a && b_at == coded_b) structure = true;
  } else if (!has_geometry) {
    new_uv = NewVertexUv(frame, a_at, b_at);
  }
  if (!has_geometry) {
    std::vector<int32_t>& values = prediction.values;
    values.clear();
    values.insert(values.end(), attributes.begin() + size_t(w) * channels,
                  attributes.begin() + size_t(w + 1) * channels);
    for (uint32_t x : ring)
      values.insert(values.end(), attributes.begin() + size_t(x) * channels,
                    attributes.begin() + size_t(x + 1) * channels);
    PredictedGeometry& g = prediction.geometry;
    PredictGeometry(frame, a_at, b_at, new_uv, values, channels, &g, structure ? 1.0 : kCase2Spread);
    // A predicted vertex must not make a triangle of w's or n's collinear; the
    // first fallback keeps w where it is and puts n at the centroid of (w, a, b).
    if (degenerate(g.u, g.v, a_at, b_at)) {
      Vec3i c{};
      for (int k = 0; k < 3; ++k) {
        c[k] = static_cast<int32_t>((int64_t(s[k]) + ring_positions[a_at][k] + ring_positions[b_at][k]) / 3);
      }
      if (!degenerate(s, c, a_at, b_at)) {
        g.u = s;
        g.v = c;
      }
    }
    u = g.u;
    v = g.v;
    u_ch.swap(g.u_channels);
    v_ch.swap(g.v_channels);
  }
  // Last resort, rare (a wrong ring or a prediction on a sliver): the wings
  // that make no collinear triangle and best separate the ring between u and
  // v. O(valence^3), only when the choice above would be degenerate.
  if (degenerate(u, v, a_at, b_at) && d <= kMaxScanValence) {
    const Vec3d dir = {double(v[0]) - u[0], double(v[1]) - u[1], double(v[2]) - u[2]};
    auto score = [&](size_t k) {
      double t = 0;
      for (int c = 0; c < 3; ++c) t += (ring_positions[k][c] - (double(u[c]) + v[c]) / 2) * dir[c];
      return t;
    };
    double best = -1e300;
    bool found = false;
    for (size_t b = 0; b < d; ++b) {
      for (size_t a = 0; a < d; ++a) {
        if (a == b || degenerate(u, v, a, b)) continue;
        double value = score(a) + score(b);
        for (size_t k = (b + 1) % d; k != a; k = (k + 1) % d) value += 2 * score(k);
        if (value > best) {
          best = value;
          a_at = a;
          b_at = b;
          found = true;
        }
      }
    }
    if (found && structure) {
      structure = false;
      ++stats->structure_fallbacks;
    }
  }
  // Reliability bits (paper, section 4.5; BRIEF, property 6): the vertices
  // of a split inherit what w depends on; predicted geometry marks both;
  // predicted structure marks both and the neighbours the new vertex joins
  // (ring[b..a]), whose rings it changed. Nothing spreads further: a later
  // split of a marked vertex checks its structure against its real ring.
  const uint8_t inherited = flags[w] & (kRingInexact | kPositionInexact);
  uint8_t both = inherited;
  if (!has_geometry) both |= kPositionInexact;
  if (!structure) {
    both |= kRingInexact;
    const size_t path = (a_at + d - b_at) % d;
    for (size_t step = 0; step <= path; ++step) mark(ring[(b_at + step) % d], kRingInexact);
    ++(has_geometry ? stats->predicted_structure : stats->predicted_both);
  } else if (!has_geometry) {
    ++stats->predicted_geometry;
  } else {
    ++stats->exact;
  }

  const uint32_t n = connectivity.SplitAt(w, ring, a_at, b_at);
  positions[w] = u;
  positions.push_back(v);
  attributes.resize(attributes.size() + size_t(channels));
  std::copy(u_ch.begin(), u_ch.end(), attributes.begin() + size_t(w) * channels);
  std::copy(v_ch.begin(), v_ch.end(), attributes.begin() + size_t(n) * channels);
  flags.push_back(0);
  reliable.push_back(1);
  if (AvoidDegenerateFaces(w, n)) both |= kPositionInexact;
  any_inexact = true;
  mark(w, both);
  mark(n, both);
  return Status::Ok();
}

int RefinementState::Degenerate(uint32_t v) const {
  int count = 0;
  for (uint32_t f : connectivity.faces_of(v)) {
    const Face& t = connectivity.faces()[f];
    count += Collinear(positions[t[0]], positions[t[1]], positions[t[2]]) ? 1 : 0;
  }
  return count;
}

bool RefinementState::AvoidDegenerateFaces(uint32_t w, uint32_t n) {
  if (Degenerate(w) == 0 && Degenerate(n) == 0) return false;
  // The new vertex, then w, moves by the smallest grid step that leaves the
  // fewest collinear triangles around the two (a prediction, whatever
  // arrived). Moving one vertex changes only its own triangles.
  for (uint32_t moving : {n, w}) {
    int best = Degenerate(moving);
    Vec3i best_at = positions[moving];
    const Vec3i at = positions[moving];
    for (int32_t r = 1; r <= 3 && best > 0; ++r) {
      for (int k = 0; k < 27 && best > 0; ++k) {
        if (k == 13) continue;
        positions[moving] = {at[0] + r * (k % 3 - 1), at[1] + r * (k / 3 % 3 - 1), at[2] + r * (k / 9 - 1)};
        const int count = Degenerate(moving);
        if (count < best) {
          best = count;
          best_at = positions[moving];
        }
      }
    }
    positions[moving] = best_at;
  }
  return true;
}

}  // namespace meshstream
