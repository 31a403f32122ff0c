#include "codec/progressive/encoder.h"

#include <algorithm>
#include <numeric>

#include "codec/progressive/refinement_state.h"
#include "codec/progressive/residual_error.h"
#include "codec/progressive/seam_twins.h"

namespace meshstream {

namespace {

Face Normalized(const Face& f) { return RotateTo(f, std::min({f[0], f[1], f[2]})); }

// Whether `actual` holds the same triangles as `expected` (as multisets, each
// up to rotation), with `expected` sorted in place: no copy of `actual`, one
// byte per triangle besides.
bool SameTriangleSet(std::vector<Face>& expected, const std::vector<Face>& actual) {
  if (expected.size() != actual.size()) return false;
  for (Face& f : expected) f = Normalized(f);
  std::sort(expected.begin(), expected.end());
  std::vector<uint8_t> matched(expected.size(), 0);
  for (const Face& f : actual) {
    const Face n = Normalized(f);
    auto it = std::lower_bound(expected.begin(), expected.end(), n);
    while (it != expected.end() && *it == n && matched[it - expected.begin()]) ++it;
    if (it == expected.end() || *it != n) return false;
    matched[it - expected.begin()] = 1;
  }
  return true;
}

// A 64-bit hash of one record (a run of 32-bit values), two chains with
// different seeds and steps.
class RecordHash {
 public:
  void Put(uint32_t value) {
    a_ = Mix(a_ ^ value);
    b_ = Mix(b_ + (uint64_t{value} << 32 | count_++));
  }
  uint64_t a() const { return a_; }
  uint64_t b() const { return b_; }

 private:
  static uint64_t Mix(uint64_t x) {  // splitmix64's finalizer
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
    return x ^ (x >> 31);
  }
  uint64_t a_ = 0x9e3779b97f4a7c15ull, b_ = 0x6a09e667f3bcc909ull;
  uint32_t count_ = 0;
};

// A fingerprint of a multiset of records: the count and the two sums of the
// records' hashes. Equal multisets have equal fingerprints; different ones
// the same with a probability of about 2^-128. The encoder's verification
// uses it to compare the replay with an input it no longer holds (a check
// against the encoder's own mistakes, not against an adversary).
class MultisetFingerprint {
 public:
  void Add(const RecordHash& record) {
    sum_[0] += record.a();
    sum_[1] += record.b();
    ++count_;
  }
  // A triangle, by its corners up to rotation.
  void AddTriangle(const Face& f) {
    RecordHash r;
    for (uint32_t x : Normalized(f)) r.Put(x);
    Add(r);
  }
  // A vertex: its id, position and channels.
  void AddVertex(uint32_t id, const Vec3i& p, const int32_t* channels, int ch) {
    RecordHash r;
    r.Put(id);
    for (int k = 0; k < 3; ++k) r.Put(static_cast<uint32_t>(p[k]));
    for (int k = 0; k < ch; ++k) r.Put(static_cast<uint32_t>(channels[k]));
    Add(r);
  }
  uint64_t count() const { return count_; }
  bool operator==(const MultisetFingerprint& o) const {
    return count_ == o.count_ && sum_[0] == o.sum_[0] && sum_[1] == o.sum_[1];
  }
  bool operator!=(const MultisetFingerprint& o) const { return !(*this == o); }

 private:
  uint64_t sum_[2] = {0, 0};
  uint64_t count_ = 0;
};

std::vector<Face> FacesOf(const std::vector<uint32_t>& indices) {
  std::vector<Face> faces;
  faces.reserve(indices.size() / 3);
  for (size_t i = 0; i + 2 < indices.size(); i += 3) faces.push_back({indices[i], indices[i + 1], indices[i + 2]});
  return faces;
}

// Sorted positions of the neighbours of every vertex: tells coincident
// vertices apart by their surroundings.
std::vector<std::vector<Vec3i>> NeighbourSignatures(const QuantizedMesh& m) {
  std::vector<std::vector<Vec3i>> sig(m.vertex_count());
  for (size_t i = 0; i < m.indices.size(); i += 3) {
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = m.indices[i + k];
      sig[v].push_back(m.positions[m.indices[i + (k + 1) % 3]]);
      sig[v].push_back(m.positions[m.indices[i + (k + 2) % 3]]);
    }
  }
  for (auto& s : sig) std::sort(s.begin(), s.end());
  return sig;
}

// A vertex correspondence decoded -> base that maps positions onto equal
// positions and triangles onto triangles.
StatusOr<std::vector<uint32_t>> MatchBase(const QuantizedMesh& base, const QuantizedMesh& decoded) {
  if (decoded.vertex_count() != base.vertex_count() || decoded.face_count() != base.face_count()) {
    return Internal("the base coder returned " + std::to_string(decoded.vertex_count()) + " vertices and " +
                    std::to_string(decoded.face_count()) + " triangles for " + std::to_string(base.vertex_count()) +
                    " and " + std::to_string(base.face_count()));
  }
  const size_t n = base.vertex_count();
  std::vector<uint32_t> by_position(n);
  std::iota(by_position.begin(), by_position.end(), 0);
  std::sort(by_position.begin(), by_position.end(), [&](uint32_t a, uint32_t b) {
    return base.positions[a] != base.positions[b] ? base.positions[a] < base.positions[b] : a < b;
  });
  std::vector<std::vector<Vec3i>> base_sig, decoded_sig;
  std::vector<uint8_t> taken(n, 0);
  std::vector<uint32_t> out(n);
  for (uint32_t d = 0; d < n; ++d) {
    const Vec3i& p = decoded.positions[d];
    auto lo = std::lower_bound(by_position.begin(), by_position.end(), p,
                               [&](uint32_t v, const Vec3i& q) { return base.positions[v] < q; });
    auto hi = lo;
    while (hi != by_position.end() && base.positions[*hi] == p) ++hi;
    if (lo == hi) return Internal("the base coder moved a vertex off the grid");
    uint32_t chosen = UINT32_MAX;
    if (hi - lo == 1) {
      chosen = *lo;
    } else {
      if (base_sig.empty()) {
        base_sig = NeighbourSignatures(base);
        decoded_sig = NeighbourSignatures(decoded);
      }
      for (auto it = lo; it != hi && chosen == UINT32_MAX; ++it) {
        if (!taken[*it] && base_sig[*it] == decoded_sig[d]) chosen = *it;
      }
      for (auto it = lo; it != hi && chosen == UINT32_MAX; ++it) {
        if (!taken[*it]) chosen = *it;
      }
    }
    if (chosen == UINT32_MAX || taken[chosen]) return Internal("coincident base vertices cannot be told apart");
    taken[chosen] = 1;
    out[d] = chosen;
  }
  std::vector<uint32_t> mapped(decoded.indices.size());
  for (size_t i = 0; i < mapped.size(); ++i) mapped[i] = out[decoded.indices[i]];
  if (!SameTriangles(mapped, base.indices)) return Internal("the base coder changed the base mesh's triangles");
  return out;
}

}  // namespace

bool SameTriangles(const std::vector<uint32_t>& a, const std::vector<uint32_t>& b) {
  if (a.size() != b.size()) return false;
  std::vector<Face> expected = FacesOf(a);
  return SameTriangleSet(expected, FacesOf(b));
}

StatusOr<ProgressiveEncoded> EncodeProgressive(const Primitive& input, const ProgressiveEncodeOptions& options,
                                               const BaseMeshEncoder& base_encoder) {
  MS_ASSIGN_OR_RETURN(QuantizedMesh q, QuantizePrimitive(input, options.quantization));
  return EncodeProgressiveQuantized(std::move(q), options, base_encoder);
}

StatusOr<ProgressiveEncoded> EncodeProgressiveQuantized(QuantizedMesh input, const ProgressiveEncodeOptions& options,
                                                        const BaseMeshEncoder& base_encoder) {
  if (options.simplify.rule == BatchRule::kPaper) {
    return InvalidArgument("the progressive codec takes the strict batch rule or the matching rule (docs/design/codec.md)");
  }
  // The matching rule's splits are applied one after the other, each on the
  // mesh the earlier ones of its refinement left (docs/spec/progressive-format.md,
  // "Version 4"); the strict rule's are independent.
  const bool sequential = options.simplify.rule == BatchRule::kMatching;
  const AttributeLayout layout = input.layout;
  const QuantizationGrid position_grid = input.position_grid;
  const int ch = layout.channels();
  const size_t input_vertices = input.vertex_count();
  // What the verification compares the replay with: the input's triangles
  // less those that repeat an index (the simplifier removes them) and the
  // values of the vertices they use, as fingerprints (the simplifier takes
  // the input's arrays).
  MultisetFingerprint input_triangles, input_values;
  {
    std::vector<uint8_t> used(input_vertices, 0);
    for (size_t i = 0; i + 2 < input.indices.size(); i += 3) {
      const Face f = {input.indices[i], input.indices[i + 1], input.indices[i + 2]};
      if (RepeatsAnIndex(f)) continue;
      input_triangles.AddTriangle(f);
      for (uint32_t v : f) used[v] = 1;
    }
    for (uint32_t v = 0; v < input_vertices; ++v) {
      if (used[v]) input_values.AddVertex(v, input.positions[v], input.attribute(v), ch);
    }
  }
  MS_ASSIGN_OR_RETURN(Hierarchy h, SimplifyInBatches(std::move(input), options.simplify));
  ProgressiveEncoded out;
  out.input_vertices = input_vertices;
  out.input_faces = h.input_faces;
  out.removed_faces = h.removed_faces;
  out.locked_vertices = h.locked_vertices;

  // The base mesh in compact ids.
  QuantizedMesh base;
  base.position_grid = position_grid;
  base.layout = layout;
  std::vector<uint32_t> compact(input_vertices, UINT32_MAX);
  std::vector<uint32_t> base_ids;
  for (uint32_t v = 0; v < input_vertices; ++v) {
    if (!h.in_base[v]) continue;
    compact[v] = static_cast<uint32_t>(base_ids.size());
    base_ids.push_back(v);
    base.positions.push_back(h.positions[v]);
    base.attributes.insert(base.attributes.end(), h.attributes.begin() + size_t(v) * ch,
                           h.attributes.begin() + size_t(v + 1) * ch);
  }
  for (uint32_t v : h.base_indices) base.indices.push_back(compact[v]);

  // Code it, and find the decoder's order.
  std::vector<uint32_t> decoded_to_base;
  EncodedBase encoded;
  Status last = Internal("no base coder method");
  for (int method = 0; method < kBaseMethods; ++method) {
    auto attempt = base_encoder(base, method);
    if (!attempt.ok()) {
      last = attempt.status();
      continue;
    }
    auto match = MatchBase(base, attempt->decoded);
    if (!match.ok()) {
      last = match.status();
      continue;
    }
    encoded = std::move(attempt).value();
    decoded_to_base = std::move(match).value();
    out.base_method = method;
    last = Status::Ok();
    break;
  }
  MS_RETURN_IF_ERROR(last);
  out.base_bytes = std::move(encoded.bytes);

  // The base in canonical order, with the fix-ups that make it exact.
  std::vector<uint32_t> canonical(input_vertices, UINT32_MAX);
  QuantizedMesh& cbase = out.mesh.base;
  cbase = encoded.decoded;
  for (uint32_t d = 0; d < decoded_to_base.size(); ++d) {
    const uint32_t b = decoded_to_base[d];
    canonical[base_ids[b]] = d;
    for (int k = 0; k < 3; ++k) out.base_position_fix.push_back(base.positions[b][k] - cbase.positions[d][k]);
    for (int k = 0; k < ch; ++k) {
      out.base_attribute_fix.push_back(base.attributes[size_t(b) * ch + k] - cbase.attributes[size_t(d) * ch + k]);
    }
    cbase.positions[d] = base.positions[b];
    std::copy(base.attributes.begin() + size_t(b) * ch, base.attributes.begin() + size_t(b + 1) * ch,
              cbase.attributes.begin() + size_t(d) * ch);
  }

  // Seam twins of the base (both copies of a seam vertex survive or go together).
  for (uint32_t v = 0; v < input_vertices; ++v) {
    const uint32_t t = v < h.twin.size() ? h.twin[v] : kNoTwin;
    if (t == kNoTwin || !h.in_base[v] || canonical[v] >= canonical[t]) continue;
    out.mesh.base_twins.push_back({canonical[v], canonical[t]});
  }
  std::sort(out.mesh.base_twins.begin(), out.mesh.base_twins.end());

  // Replay from coarse to fine, exactly as the decoder will.
  RefinementState state;
  MS_RETURN_IF_ERROR(state.Reset(cbase));
  MS_RETURN_IF_ERROR(state.SetTwins(out.mesh.base_twins).WithContext("replay"));
  size_t final_vertices = cbase.vertex_count();
  for (const CollapseBatch& b : h.batches) final_vertices += b.collapses.size();
  state.Reserve(static_cast<uint32_t>(final_vertices));  // once: no growth by doubling
  // The base has them; the rest of the replay reads the batches. (Freed by
  // moving empty vectors in: `= {}` keeps the capacity.)
  h.positions = decltype(h.positions)();
  h.attributes = decltype(h.attributes)();
  std::vector<uint32_t> ring;
  // Sequential replay: per input vertex of the current batch's collapses,
  // the other end of its collapse (the coarse vertex stands for a removed
  // end until its split is applied).
  std::vector<uint32_t> other_end(sequential ? input_vertices : 0, UINT32_MAX);
  auto id_of = [&](uint32_t x) {
    uint32_t c = canonical[x];
    if (c == UINT32_MAX && sequential && other_end[x] != UINT32_MAX) c = canonical[other_end[x]];
    return c;
  };
  for (auto batch = h.batches.rbegin(); batch != h.batches.rend(); ++batch) {
    const size_t k = batch->collapses.size();
    if (sequential) {
      for (const Collapse& c : batch->collapses) {
        other_end[c.u] = c.v;
        other_end[c.v] = c.u;
      }
    }
    // The split vertex of each collapse, fixed before any split of the batch
    // (a sequential replay renames as it goes).
    std::vector<uint32_t> split_id(k);
    for (size_t i = 0; i < k; ++i) split_id[i] = canonical[batch->collapses[i].u];
    std::vector<uint32_t> order(k);
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](uint32_t x, uint32_t y) { return split_id[x] < split_id[y]; });
    Refinement r;
    r.vertices_before = state.connectivity.vertex_count();
    std::vector<uint32_t> created(k);  // the input id that becomes the new vertex of split j
    for (uint32_t i : order) {
      const Collapse& c = batch->collapses[i];
      const uint32_t w = split_id[i];
      bool swap = false;  // v keeps w's id (the deltas are then v - u)
      std::array<uint16_t, 2> wings{};
      if (c.b == kNoWing) {
        // A seam split: the primary's new vertex takes the tail of w's open
        // fan, with the triangle (w, a, n); the secondary's the head, with
        // (w, n, a). The collapsed triangle's orientation says which end of
        // the edge is which (seam_twins.h).
        if (c.twin >= k || state.twin[w] != split_id[c.twin]) {
          return Internal("replay: a seam split's twin is not the other side's split");
        }
        if (!state.connectivity.OpenRing(w, ring)) return Internal("replay: a seam split vertex is not an open fan");
        const auto pa = std::find(ring.begin(), ring.end(), id_of(c.a));
        if (pa == ring.end()) return Internal("replay: a seam wing is not a neighbour of the split vertex");
        swap = (w < state.twin[w]) == c.uva;
        wings = {static_cast<uint16_t>(pa - ring.begin()), 0};
      } else {
        if (!state.connectivity.CyclicRing(w, ring)) return Internal("replay: a split vertex is not a closed fan");
        const auto pa = std::find(ring.begin(), ring.end(), id_of(c.a));
        const auto pb = std::find(ring.begin(), ring.end(), id_of(c.b));
        if (pa == ring.end() || pb == ring.end()) return Internal("replay: a wing is not a neighbour of the split vertex");
        const size_t d = ring.size();
        const size_t offset = (static_cast<size_t>(pb - pa) + d) % d;
        // Either end of the collapsed edge may keep w's id; keeping v instead
        // of u swaps the wings (offset d - offset) and negates the deltas.
        swap = offset > d / 2;
        const size_t a_at = static_cast<size_t>((swap ? pb : pa) - ring.begin());
        const size_t b_at = static_cast<size_t>((swap ? pa : pb) - ring.begin());
        wings = WingsOf(ring, a_at, b_at);
      }
      const uint32_t keep = swap ? c.v : c.u;
      r.split_vertices.push_back(w);
      r.wings.push_back(wings);
      r.position_delta.push_back(swap ? Vec3i{-c.delta[0], -c.delta[1], -c.delta[2]} : c.delta);
      const std::vector<int32_t>& ak = swap ? batch->attr_v : batch->attr_u;
      const std::vector<int32_t>& an = swap ? batch->attr_u : batch->attr_v;
      for (int m = 0; m < ch; ++m) r.attribute_delta.push_back(ak[size_t(i) * ch + m] - an[size_t(i) * ch + m]);
      canonical[keep] = w;
      const size_t j = r.split_vertices.size() - 1;
      created[j] = swap ? c.u : c.v;
      if (sequential) {
        // Applied now: the next split's ring is the mesh this one leaves.
        MS_RETURN_IF_ERROR(state.ApplySplit(r, j).WithContext("replay"));
        canonical[created[j]] = r.vertices_before + static_cast<uint32_t>(j);
      }
    }
    if (sequential) {
      for (const Collapse& c : batch->collapses) other_end[c.u] = other_end[c.v] = UINT32_MAX;
    } else {
      MS_RETURN_IF_ERROR(state.ApplyRefinement(r).WithContext("replay"));
      for (size_t j = 0; j < k; ++j) canonical[created[j]] = r.vertices_before + static_cast<uint32_t>(j);
    }
    *batch = CollapseBatch{};  // replayed: its memory is not needed any more
    out.mesh.refinements.push_back(std::move(r));
  }

  // Verify: the replay gives back the quantized input. Every vertex the
  // input's triangles use has a distinct id in the replay and every id one
  // such vertex; in input ids, the replay's triangles and values have the
  // input's fingerprints.
  const uint32_t final_count = state.connectivity.vertex_count();
  if (final_count != input_values.count()) {
    return Internal("replay gave " + std::to_string(final_count) + " vertices for " +
                    std::to_string(input_values.count()));
  }
  std::vector<uint32_t> input_of(final_count, UINT32_MAX);
  for (uint32_t v = 0; v < input_vertices; ++v) {
    const uint32_t c = canonical[v];
    if (c == UINT32_MAX) continue;  // only in removed triangles
    if (c >= final_count || input_of[c] != UINT32_MAX) return Internal("replay gave two vertices one id");
    input_of[c] = v;
  }
  canonical = decltype(canonical)();
  MultisetFingerprint replay_triangles, replay_values;
  for (const Face& f : state.connectivity.faces()) {
    Face mapped;
    for (int k = 0; k < 3; ++k) {
      mapped[k] = input_of[f[k]];
      if (mapped[k] == UINT32_MAX) return Internal("replay has a vertex that is not the input's");
    }
    replay_triangles.AddTriangle(mapped);
  }
  if (replay_triangles != input_triangles) return Internal("replay did not give back the input's triangles");
  for (uint32_t c = 0; c < final_count; ++c) {
    replay_values.AddVertex(input_of[c], state.positions[c], state.attributes.data() + size_t(c) * ch, ch);
  }
  if (replay_values != input_values) return Internal("replay did not give back the input's vertex values");
  out.residual_error = ResidualErrors(out.mesh, state);
  return out;
}

}  // namespace meshstream
