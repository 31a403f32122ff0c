#include "codec/bitstream/writer.h"

#include <cmath>

#include "codec/bitstream/reliable_payload.h"
#include "codec/bitstream/slot_model.h"
#include "codec/entropy/range_coder.h"
#include "codec/progressive/cut_crossings.h"
#include "codec/progressive/geometry_prediction.h"
#include "codec/progressive/normal_prediction.h"
#include "codec/progressive/refinement_state.h"
#include "codec/progressive/ring_predictor_fit.h"
#include "codec/progressive/seam_twins.h"
#include "codec/progressive/wing_rank.h"
#include "codec/progressive/split_bit_contexts.h"
#include "codec/progressive/split_bits_connected.h"
#include "codec/progressive/split_bits.h"
#include "codec/progressive/texcoord_prediction.h"
#include "codec/entropy/symbol_model.h"

namespace meshstream {

namespace {

// The models of one refinement, by slot: wing, offset, position x, y, z,
// then one per attribute channel. Each slot either carries a new model or
// reuses the previous refinement's (when that costs fewer bits); with the
// model modes tool a new model may be adaptive (slot_model.h), see
// docs/spec/progressive-format.md, "Control block".
struct RefinementModels {
  std::vector<SlotModel> slots;
};

// A refinement as the datagrams carry it: its splits and, per split, the
// index of its seam twin's split (kNoTwin for an interior split). A seam
// pair's primary (the smaller index) carries both sides; the secondary's
// unit is empty (docs/spec/progressive-format.md, "Seam split").
struct CodedRefinement {
  const Refinement& r;
  const std::vector<uint32_t>& partner;
  bool interior(size_t j) const { return partner.empty() || partner[j] == kNoTwin; }
  bool secondary(size_t j) const { return !interior(j) && partner[j] < j; }
};

// The symbols split j puts in `slot`, in coding order (appended to `out`).
void SlotSymbols(const CodedRefinement& cr, size_t j, size_t slot, int channels, std::vector<uint32_t>& out) {
  const Refinement& r = cr.r;
  if (cr.secondary(j)) return;
  if (slot < 2) {
    if (cr.interior(j)) out.push_back(r.wings[j][slot]);  // a seam's wings are raw bits
  } else if (slot < 5) {
    out.push_back(SignedSymbol(r.position_delta[j][slot - 2]));
  } else {
    const size_t c = slot - 5;
    out.push_back(SignedSymbol(r.attribute_delta[j * channels + c]));
    if (!cr.interior(j)) out.push_back(SignedSymbol(r.attribute_delta[cr.partner[j] * channels + c]));
  }
}

std::vector<std::vector<uint64_t>> Histograms(const CodedRefinement& cr, int channels) {
  std::vector<std::vector<uint64_t>> h(5 + channels);
  std::vector<uint32_t> symbols;
  for (size_t k = 0; k < h.size(); ++k) {
    h[k].assign(SlotAlphabet(k), 0);
    for (size_t j = 0; j < cr.r.split_count(); ++j) {
      symbols.clear();
      SlotSymbols(cr, j, k, channels, symbols);
      for (uint32_t s : symbols) ++h[k][s];
    }
  }
  return h;
}

double CostWith(const StaticModel& m, const std::vector<uint64_t>& counts) {
  double bits = 0;
  for (size_t s = 0; s < counts.size(); ++s) {
    if (counts[s] == 0) continue;
    if (!m.Has(static_cast<uint32_t>(s))) return 1e300;
    bits += counts[s] * m.Cost(static_cast<uint32_t>(s));
  }
  return bits;
}

// The bits of `slot`'s symbols when every datagram (split j in datagram
// j mod stride) starts an adaptive model from `prior`.
double AdaptiveCost(const ModelPrior& prior, const CodedRefinement& cr, int channels, size_t slot, size_t stride) {
  AdaptiveModel m;
  std::vector<uint32_t> symbols;
  double bits = 0;
  const size_t k = cr.r.split_count();
  for (size_t d = 0; d < stride && d < k; ++d) {
    m.Reset(prior);
    for (size_t j = d; j < k; j += stride) {
      symbols.clear();
      SlotSymbols(cr, j, slot, channels, symbols);
      for (uint32_t s : symbols) {
        bits += m.Cost(s);
        m.Update(s);
      }
    }
  }
  return bits;
}

// A split's bits in a datagram of `kind`, estimated with each slot's table
// (an adaptive slot's: its symbols' counts in this refinement).
double UnitCost(const RefinementModels& m, const CodedRefinement& cr, size_t j, int channels, DatagramKind kind) {
  const Refinement& r = cr.r;
  if (cr.secondary(j)) return 0;
  auto slot = [&m](size_t k) -> const StaticModel& { return m.slots[k].table; };
  double bits = 0;
  const bool seam = !cr.interior(j);
  if (kind != DatagramKind::kGeometry) {
    bits += seam ? 2 * kSeamWingBits : slot(0).Cost(r.wings[j][0]) + slot(1).Cost(r.wings[j][1]);
  }
  if (kind != DatagramKind::kStructure) {
    for (int k = 0; k < 3; ++k) bits += SignedCost(slot(2 + k), r.position_delta[j][k]);
    for (int k = 0; k < channels; ++k) bits += SignedCost(slot(5 + k), r.attribute_delta[j * channels + k]);
    if (seam) {
      const size_t t = cr.partner[j];
      for (int k = 0; k < channels; ++k) bits += SignedCost(slot(5 + k), r.attribute_delta[t * channels + k]);
    }
  }
  return bits;
}

// The first number of datagrams Packetize tries for a refinement of k
// splits whose units of one kind take about `bits`.
size_t FirstStride(double bits, size_t k, const StreamWriteOptions& o) {
  const double capacity = std::max(8.0, double(o.packet_bytes) - 24.0);  // header and coder flush
  const size_t stride = std::max<size_t>(1, static_cast<size_t>(std::ceil(bits / 8.0 / (capacity * 0.92))));
  return std::min(stride, std::max<size_t>(k, 1));
}

double KindBits(const RefinementModels& m, const CodedRefinement& r, int channels, DatagramKind kind) {
  double bits = 0;
  for (size_t j = 0; j < r.r.split_count(); ++j) bits += UnitCost(m, r, j, channels, kind);
  return bits;
}

// Chooses and writes the models of a refinement; `previous` is the previous
// refinement's (none for the first). With the model modes tool a slot may be
// adaptive, priced with the datagrams dealt as the static tables' estimate
// deals them (FirstStride; Packetize then deals them for real).
RefinementModels WriteModels(const CodedRefinement& r, int channels, const RefinementModels* previous,
                             const StreamWriteOptions& o, bool modes, ByteWriter& w) {
  const auto histograms = Histograms(r, channels);
  // Every slot's fresh table: what it would send, and the estimate of its symbols' bits.
  RefinementModels fresh;
  for (const auto& h : histograms) fresh.slots.push_back(SlotModel{false, StaticModel::FromCounts(h), {}});
  size_t strides[2] = {1, 1};  // structure slots, geometry slots
  if (modes) {
    const size_t k = r.r.split_count();
    if (o.packing == Packing::kBundled) {
      strides[0] = strides[1] = FirstStride(KindBits(fresh, r, channels, DatagramKind::kBundled), k, o);
    } else {
      strides[0] = FirstStride(KindBits(fresh, r, channels, DatagramKind::kStructure), k, o);
      strides[1] = FirstStride(KindBits(fresh, r, channels, DatagramKind::kGeometry), k, o);
    }
  }
  RefinementModels chosen;
  for (size_t k = 0; k < histograms.size(); ++k) {
    const std::vector<uint64_t>& h = histograms[k];
    StaticModel& table = fresh.slots[k].table;
    ByteWriter serialized;
    table.Serialize(serialized);
    const double table_bits = 8.0 * serialized.size();
    const double fresh_bits = CostWith(table, h) + table_bits;
    const SlotModel* before = previous ? &previous->slots[k] : nullptr;
    const size_t stride = strides[k < 2 ? 0 : 1];
    if (!modes) {
      const bool reuse = before && CostWith(before->table, h) < fresh_bits;
      w.U8(reuse ? 0 : 1);
      if (reuse) {
        chosen.slots.push_back(*before);
      } else {
        w.Bytes(serialized.bytes());
        chosen.slots.push_back(SlotModel{false, std::move(table), {}});
      }
      continue;
    }
    // Every mode priced in bits, its mode byte and what follows it included.
    const SymbolKind kind = SlotKind(k);
    double best = 8.0 + fresh_bits;
    ModelMode mode = ModelMode::kTable;
    if (before) {
      const double reuse = 8.0 + (before->adaptive ? AdaptiveCost(before->prior, r, channels, k, stride)
                                                   : CostWith(before->table, h));
      if (reuse < best) {
        best = reuse;
        mode = ModelMode::kReuse;
      }
    }
    const uint32_t parameter = BestParameter(kind, h);
    const ModelPrior& parametric = CachedParametricPrior(kind, parameter);
    const double parametric_bits = 16.0 + AdaptiveCost(parametric, r, channels, k, stride);
    if (parametric_bits < best) {
      best = parametric_bits;
      mode = ModelMode::kParametric;
    }
    ModelPrior from_table = TablePrior(table, SlotAlphabet(k));
    if (8.0 + table_bits + AdaptiveCost(from_table, r, channels, k, stride) < best) mode = ModelMode::kAdaptiveTable;
    w.U8(static_cast<uint8_t>(mode));
    switch (mode) {
      case ModelMode::kReuse:
        chosen.slots.push_back(*before);
        // An adaptive slot's table is only the writer's estimate: this refinement's.
        if (before->adaptive) chosen.slots.back().table = std::move(table);
        break;
      case ModelMode::kTable:
        w.Bytes(serialized.bytes());
        chosen.slots.push_back(SlotModel{false, std::move(table), {}});
        break;
      case ModelMode::kParametric:
        w.U8(static_cast<uint8_t>(parameter));
        chosen.slots.push_back(SlotModel{true, std::move(table), parametric});
        break;
      case ModelMode::kAdaptiveTable:
        w.Bytes(serialized.bytes());
        chosen.slots.push_back(SlotModel{true, std::move(table), std::move(from_table)});
        break;
    }
  }
  return chosen;
}

void EncodeStructure(RangeEncoder& enc, std::vector<SlotCoder>& m, const CodedRefinement& cr, size_t j) {
  const Refinement& r = cr.r;
  if (cr.secondary(j)) return;
  if (!cr.interior(j)) {
    enc.EncodeRaw(r.wings[j][0], kSeamWingBits);
    enc.EncodeRaw(r.wings[cr.partner[j]][0], kSeamWingBits);
    return;
  }
  m[0].Encode(enc, r.wings[j][0]);
  m[1].Encode(enc, r.wings[j][1]);
}

void EncodeGeometry(RangeEncoder& enc, std::vector<SlotCoder>& m, const CodedRefinement& cr, size_t j, int channels) {
  const Refinement& r = cr.r;
  if (cr.secondary(j)) return;
  for (int k = 0; k < 3; ++k) EncodeSigned(enc, m[2 + k], r.position_delta[j][k]);
  for (int k = 0; k < channels; ++k) EncodeSigned(enc, m[5 + k], r.attribute_delta[j * channels + k]);
  if (cr.interior(j)) return;
  const size_t t = cr.partner[j];
  for (int k = 0; k < channels; ++k) EncodeSigned(enc, m[5 + k], r.attribute_delta[t * channels + k]);
}

// Deals the splits of a refinement to as few datagrams as fit.
std::vector<std::vector<uint8_t>> Packetize(const RefinementModels& m, const CodedRefinement& r, int channels,
                                            DatagramKind kind, uint32_t refinement, const StreamWriteOptions& o) {
  const size_t k = r.r.split_count();
  std::vector<std::vector<uint8_t>> out;
  if (k == 0) return out;
  size_t stride = FirstStride(KindBits(m, r, channels, kind), k, o);
  std::vector<SlotCoder> coders(m.slots.size());
  for (;;) {
    out.clear();
    bool fits = true;
    for (size_t d = 0; d < stride && fits; ++d) {
      DatagramHeader h;
      h.version = o.version;
      h.kind = kind;
      h.stream = o.stream_id;
      h.refinement = refinement;
      h.stride = static_cast<uint32_t>(stride);
      h.offset = static_cast<uint32_t>(d);
      h.count = static_cast<uint32_t>((k - d + stride - 1) / stride);
      ByteWriter w;
      h.Serialize(w);
      RangeEncoder enc;
      for (size_t s = 0; s < coders.size(); ++s) coders[s].Reset(m.slots[s]);  // every datagram starts afresh
      for (size_t j = d; j < k; j += stride) {
        if (kind != DatagramKind::kGeometry) EncodeStructure(enc, coders, r, j);
        if (kind != DatagramKind::kStructure) EncodeGeometry(enc, coders, r, j, channels);
      }
      w.Bytes(enc.Finish());
      if (w.size() > o.packet_bytes) fits = false;
      out.push_back(std::move(w.bytes()));
    }
    if (fits) return out;
    if (stride == k) return out;  // a single split larger than a datagram: send it as it is
    stride = std::min(k, stride + std::max<size_t>(1, stride / 8));
  }
}

// The order-0 cost of a residual's three components with a model per
// component (what the refinement's models will cost, up to their bytes).
double ResidualBits(const std::vector<Vec3i>& residuals) {
  double bits = 0;
  for (int c = 0; c < 3; ++c) {
    std::vector<uint64_t> counts(kSignedSymbols, 0);
    double raw = 0;
    for (const Vec3i& r : residuals) {
      ++counts[SignedSymbol(r[c])];
      const uint32_t z = ZigZag(r[c]);
      if (z >= kDirectSymbols) raw += (32 - __builtin_clz(z)) - 2;
    }
    const double n = double(residuals.size());
    for (uint64_t k : counts)
      if (k) bits -= double(k) * std::log2(double(k) / n);
    bits += raw;
  }
  return bits;
}

// At most this many splits of a refinement enter the predictor's fit (evenly
// spaced): the fit's cost and memory stay bounded on any mesh.
constexpr size_t kMaxPredictorSamples = 1 << 16;

// The ring predictor's record in a control block (docs/spec/progressive-format.md
// section 4.7): 0 to keep the previous refinement's weights, or 1 and the
// six weights as zigzag varints.
void WritePredictorRecord(const PredictorWeights& w, const PredictorWeights& previous, ByteWriter& out) {
  if (w == previous) {
    out.U8(0);
    return;
  }
  out.U8(1);
  for (const auto* group : {&w.tangential, &w.normal})
    for (int32_t x : *group) out.Varint(ZigZag(x));
}

// Refinement r with its split vectors (and, with the wing-rank tool, its
// wings) replaced by their coded form under the stream's tools
// (geometry_prediction.h, wing_rank.h), given the coarser mesh `state`
// (which is then refined by r). Chooses the refinement's alpha, or with the
// ring predictor its weights (coding->predictor holds the previous
// refinement's on entry). False when a split's wings cannot be ranked (a
// ring beyond kMaxRankedValence): the caller then writes the stream without
// that tool.
bool CodeRefinement(const Refinement& r, ToolSet tools, const AttributeLayout& layout, double ring_term_bits,
                    RefinementState& state, SplitCoding* coding, Refinement* out) {
  Refinement& coded = *out;
  coded = r;
  WingRanking ranking;
  CutCrossings crossings;
  const PredictorWeights previous = coding->predictor;
  const bool predictor = (tools & kToolRingPredictor) != 0;
  coding->tools = tools;
  coding->alpha = 0;
  if (tools & kToolTexcoordPrediction) {
    coding->mapped_first = layout.texcoord_offset(0);
    coding->mapped_count = layout.channels() - coding->mapped_first;
  }
  const size_t k = r.split_count();
  struct Split {
    size_t a_at = 0, b_at = 0, ring_at = 0, degree = 0;
    bool seam = false;
  };
  std::vector<Split> splits(k);
  std::vector<Vec3i> rings;  // every split's ring positions, back to back
  std::vector<Vec3i> coarse(k);
  std::vector<LocalFrame> frames(k);
  // With the ring predictor: every split's features, from the coarser mesh's
  // stable vertices (ring_predictor.h).
  std::vector<PredictorFeatures> features(predictor ? k : 0);
  std::vector<Umbrella> umbrellas;
  state.ReserveSplits(k);
  if (predictor) state.BeginSplits(r);
  for (size_t j = 0; j < k; ++j) {
    const uint32_t w = r.split_vertices[j];
    std::vector<uint32_t>& ring = state.scratch_ring;
    Split& s = splits[j];
    if (state.twin[w] != kNoTwin) {
      // A seam split is coded as it is: its wing by position, its vector
      // and channels raw (no tool predicts across a boundary).
      state.connectivity.OpenRing(w, ring);
      s.seam = true;
      state.ApplySeamSplitAt(r, j, r.wings[j][0]);
      continue;
    }
    // The encoder's own hierarchy: every split vertex is a closed fan and its wings fit.
    state.connectivity.CyclicRing(w, ring);
    WingPositions(ring, r.wings[j], &s.a_at, &s.b_at);
    s.ring_at = rings.size();
    s.degree = ring.size();
    for (uint32_t x : ring) rings.push_back(state.positions[x]);
    coarse[j] = state.positions[w];
    frames[j] = RingLocalFrame(coarse[j], rings.data() + s.ring_at, s.degree);
    if (predictor) {
      RingUmbrellas(state, ring.data(), s.degree, &umbrellas);
      features[j] = SplitFeatures(rings.data() + s.ring_at, umbrellas.data(), s.degree, s.a_at, s.b_at);
    }
    if (tools & kToolWingRank) {
      uint32_t rank = 0;
      const bool ranked = (tools & kToolCutCrossings)
                              ? crossings.Reset(coarse[j], rings.data() + s.ring_at, s.degree, frames[j]) &&
                                    crossings.RankOf(s.a_at, s.b_at, &rank)
                              : ranking.Reset(coarse[j], rings.data() + s.ring_at, s.degree, frames[j]) &&
                                    ranking.RankOf(s.a_at, s.b_at, &rank);
      if (!ranked) {
        if (predictor) state.EndSplits(r);
        return false;
      }
      coded.wings[j] = RankSymbols(rank);
    }
    const uint32_t n = state.ApplySplitAt(r, j, s.a_at, s.b_at);
    if ((tools & kToolAttributePrediction) && layout.has_normals) {
      // Relative to the difference the decoded geometry predicts (normal_prediction.h).
      const std::array<int32_t, 2> p = PredictNormalDelta(state, w, n, layout.qn);
      const int ch = layout.channels();
      for (int c = 0; c < 2; ++c) {
        int32_t& e = coded.attribute_delta[j * ch + c];
        e = static_cast<int32_t>(std::clamp<int64_t>(int64_t{e} - p[c], INT32_MIN, INT32_MAX));
      }
    }
    if (coding->mapped_count > 0) {
      // Relative to the difference the ring's map predicts from the split vector (texcoord_prediction.h).
      int32_t p[kMaxMappedChannels];
      PredictChannelDeltas(state, ring.data(), rings.data() + s.ring_at, s.degree, frames[j], w, n,
                           coding->mapped_first, coding->mapped_count, p);
      const int ch = layout.channels();
      for (int c = 0; c < coding->mapped_count; ++c) {
        int32_t& e = coded.attribute_delta[j * ch + coding->mapped_first + c];
        e = static_cast<int32_t>(std::clamp<int64_t>(int64_t{e} - p[c], INT32_MIN, INT32_MAX));
      }
    }
  }
  if (predictor) state.EndSplits(r);
  auto code_all = [&](const SplitCoding& c, std::vector<Vec3i>* out) {
    out->clear();
    for (size_t j = 0; j < k; ++j) {
      const Split& s = splits[j];
      if (s.seam) continue;
      out->push_back(predictor ? ResidualInFrame(c.predictor, features[j], frames[j], r.position_delta[j])
                               : CodeSplitVector(c, r.position_delta[j], rings.data() + s.ring_at, s.degree, s.a_at,
                                                 s.b_at, frames[j]));
    }
  };
  std::vector<Vec3i> residuals;
  if (predictor) {
    // The weights by the cost of the residuals and of sending them: the
    // previous refinement's, or fitted on (a sample of) this one's splits
    // over the Laplacian alone, with the sides, and with the 2-ring term.
    std::vector<PredictorSample> samples;
    size_t plain = 0;
    for (const Split& s : splits) plain += s.seam ? 0 : 1;
    const size_t stride = (plain + kMaxPredictorSamples - 1) / kMaxPredictorSamples;
    for (size_t j = 0, n = 0; j < k; ++j) {
      if (splits[j].seam) continue;
      if (n++ % stride == 0) samples.push_back(SampleOf(features[j], frames[j], r.position_delta[j]));
    }
    const PredictorWeights candidates[] = {previous, FitPredictorWeights(samples, 1), FitPredictorWeights(samples, 2),
                                           FitPredictorWeights(samples, 3)};
    double best = 1e300;
    for (const PredictorWeights& w : candidates) {
      SplitCoding c = *coding;
      c.predictor = w;
      code_all(c, &residuals);
      ByteWriter record;
      WritePredictorRecord(w, previous, record);
      // The 2-ring term costs the decoder a walk over the ring's faces: it
      // must pay for it in bits (StreamWriteOptions::ring_term_bits).
      const double bits = ResidualBits(residuals) + 8.0 * double(record.size()) +
                          (w.reads_ring() ? ring_term_bits * double(plain) : 0.0);
      if (bits < best) {
        best = bits;
        coding->predictor = w;
      }
    }
  } else if (tools & kToolGeometryPrediction) {
    // alpha by the cost of the residuals: a coarse scan, then its neighbours.
    double best = 1e300;
    uint32_t best_alpha = 0;
    auto consider = [&](uint32_t alpha) {
      SplitCoding c = *coding;
      c.alpha = alpha;
      code_all(c, &residuals);
      const double bits = ResidualBits(residuals);
      if (bits < best) {
        best = bits;
        best_alpha = alpha;
      }
    };
    for (uint32_t alpha = 0; alpha <= 64; alpha += 8) consider(alpha);
    const uint32_t centre = best_alpha;
    for (uint32_t alpha = centre > 7 ? centre - 7 : 0; alpha <= centre + 7 && alpha <= 255; ++alpha)
      if (alpha % 8 != 0) consider(alpha);
    coding->alpha = best_alpha;
  }
  code_all(*coding, &residuals);
  for (size_t j = 0, next = 0; j < k; ++j)
    if (!splits[j].seam) coded.position_delta[j] = residuals[next++];
  return true;
}

}  // namespace

ToolSet ApplicableTools(ToolSet requested, const QuantizationParams& quantization, const AttributeLayout& layout) {
  ToolSet tools = requested;
  if (quantization.qp > 24) tools &= static_cast<ToolSet>(~kToolLocalFrame);
  // The ring predictor works in the local frame, on top of the prediction tool's place in the format.
  if ((tools & kToolLocalFrame) == 0 || (tools & kToolGeometryPrediction) == 0) {
    tools &= static_cast<ToolSet>(~kToolRingPredictor);
  }
  if (layout.texcoord_sets == 0 && !layout.has_colors) tools &= static_cast<ToolSet>(~kToolTexcoordPrediction);
  // The crossings order the rank tool's ranks.
  if ((tools & kToolWingRank) == 0) tools &= static_cast<ToolSet>(~kToolCutCrossings);
  return tools;
}

StatusOr<ProgressiveStream> WriteStream(const ProgressiveEncoded& e, const QuantizationParams& quantization,
                                        const StreamWriteOptions& o) {
  if (o.packet_bytes < kMinPacketBytes || o.packet_bytes > kMaxPacketBytes) {
    return InvalidArgument("--packet-bytes must be between " + std::to_string(kMinPacketBytes) + " and " +
                           std::to_string(kMaxPacketBytes));
  }
  const ProgressiveMesh& pm = e.mesh;
  if (pm.refinements.size() > kMaxRefinements) return InvalidArgument("too many refinements");
  const int channels = pm.base.layout.channels();

  StreamHeader h;
  h.version = o.version;
  if (!IsStreamVersion(o.version)) {
    return InvalidArgument("stream version " + std::to_string(o.version) + " is not " + kStreamVersionsText);
  }
  if ((o.tools & ~kEveryTool) != 0) return InvalidArgument("unknown coding tools " + std::to_string(o.tools));
  // An older version carries the tools it defines (none in version 1).
  h.tools = o.tools & DefinedTools(o.version);
  // The local frame's rotation is exact for residuals below 2^28, which
  // grids of at most 24 bits guarantee (local_frame.h); the texture
  // coordinate prediction only where there are such channels.
  h.tools = ApplicableTools(h.tools, quantization, pm.base.layout);
  // Seams: the hierarchy decides (SimplifyOptions::collapse_seams); the
  // header lists the base's twins when there are any.
  if (pm.base_twins.empty()) {
    h.tools &= static_cast<ToolSet>(~kToolSeams);
  } else if (!h.has(kToolSeams)) {
    return InvalidArgument("the mesh was simplified with seam collapses: only a stream of version 2 or later with "
                           "the seams tool can carry them");
  }
  h.seam_twins = pm.base_twins;
  h.packing = o.packing;
  h.profile = o.profile;
  const bool reliable = h.reliable();
  if (reliable) {
    if (o.version < 4) return InvalidArgument("the reliable profile needs format version 4");
    h.packing = Packing::kSplit;  // no datagrams: the byte is 0
    // Its split bits and models are its own (section 11 of the spec).
    h.tools &= static_cast<ToolSet>(~(kToolSplitContexts | kToolModelModes));
  }
  h.quantization = quantization;
  h.grids.position_grid = pm.base.position_grid;
  h.grids.layout = pm.base.layout;
  h.base_vertices = static_cast<uint32_t>(pm.base.vertex_count());
  h.base_faces = static_cast<uint32_t>(pm.base.face_count());
  h.base_method = static_cast<uint8_t>(e.base_method);
  for (const Refinement& r : pm.refinements) h.split_counts.push_back(static_cast<uint32_t>(r.split_count()));
  h.base_position_fix = e.base_position_fix;
  h.base_attribute_fix = e.base_attribute_fix;
  ProgressiveStream s;
  s.version = h.version;
  ByteWriter hw;
  h.Serialize(hw);
  s.header = std::move(hw.bytes());

  // Split bits: version 3's contexts (split_bit_contexts.h), or version 2's (split_bits.h).
  SplitHistory history;
  history.vertices = static_cast<uint32_t>(pm.base.vertex_count());
  SplitBitContexts split_contexts;
  if (h.has(kToolSplitContexts)) {
    MS_RETURN_IF_ERROR(split_contexts.Reset(static_cast<uint32_t>(pm.base.vertex_count()), pm.base.indices));
  }
  RefinementModels previous;
  // The coarser mesh as the decoder will have it, for the tools that predict from it.
  RefinementState state;
  if (h.tools != 0 || reliable) {
    MS_RETURN_IF_ERROR(state.Reset(pm.base));
    MS_RETURN_IF_ERROR(state.SetTwins(pm.base_twins));
  }
  // The reliable profile: split bits in contexts of the coarser mesh, the
  // split data in the control block (docs/spec/progressive-format.md, "Version 4").
  ConnectedSplitBits connected;
  ReliablePayload payload;
  if (reliable) {
    connected.Reset(state.connectivity);
    payload.Reset(channels);
  }
  std::vector<uint32_t> partner;
  PredictorWeights predictor = kInitialPredictor;  // the previous refinement's weights
  for (size_t i = 0; i < pm.refinements.size(); ++i) {
    SplitCoding coding;
    coding.predictor = predictor;
    Refinement coded;
    partner.clear();
    std::vector<uint32_t> twin_before;  // the coarser mesh's twins (CodeRefinement refines the state)
    if (h.has(kToolSeams)) {
      MS_RETURN_IF_ERROR(SeamPartners(pm.refinements[i].split_vertices, state.twin, &partner));
      twin_before = state.twin;
    }
    std::vector<uint8_t> connected_bits;  // the reliable profile's split bits, from the coarser mesh
    if (reliable) {
      std::vector<uint8_t> bits(pm.refinements[i].vertices_before, 0);
      for (uint32_t v : pm.refinements[i].split_vertices) bits[v] = 1;
      connected_bits = connected.Encode(bits, state.connectivity, h.has(kToolSeams) ? &state.twin : nullptr);
      if (h.tools == 0) MS_RETURN_IF_ERROR(state.ApplyRefinement(pm.refinements[i]).WithContext("refinement " + std::to_string(i)));
    }
    if (h.tools != 0 && !CodeRefinement(pm.refinements[i], h.tools, pm.base.layout, o.ring_term_bits, state, &coding, &coded)) {
      // A ring the wing ranking does not cover: the whole stream without it.
      StreamWriteOptions without = o;
      without.tools = static_cast<ToolSet>(h.tools & ~(kToolWingRank | kToolCutCrossings));
      return WriteStream(e, quantization, without);
    }
    const Refinement& plain = h.tools != 0 ? coded : pm.refinements[i];
    const CodedRefinement r{plain, partner};
    if (reliable) {
      // Split bits, the predictor's record (or alpha), the split data.
      ByteWriter cw;
      cw.Block(connected_bits);
      if (h.has(kToolRingPredictor)) {
        WritePredictorRecord(coding.predictor, predictor, cw);
        predictor = coding.predictor;
      } else if (h.tools & kToolGeometryPrediction) {
        cw.U8(static_cast<uint8_t>(coding.alpha));
      }
      auto data = payload.Encode(plain, partner);
      if (!data.ok()) return data.status().WithContext("refinement " + std::to_string(i));
      cw.Bytes(data.value());
      s.control.push_back(std::move(cw.bytes()));
      s.datagrams.emplace_back();
      continue;
    }
    // Split bits, then the models.
    std::vector<uint8_t> bits(plain.vertices_before, 0);
    for (uint32_t v : plain.split_vertices) bits[v] = 1;
    ByteWriter cw;
    // A seam twin's bit is its twin's (not coded).
    const std::vector<uint32_t>* twins = h.has(kToolSeams) ? &twin_before : nullptr;
    if (h.has(kToolSplitContexts)) {
      cw.Block(split_contexts.Encode(bits, twins));
    } else {
      cw.Block(EncodeSplitBits(bits, history, twins));
      history = history.Next(bits);
    }
    const RefinementModels models = WriteModels(r, channels, i == 0 ? nullptr : &previous, o, h.has(kToolModelModes), cw);
    if (h.has(kToolRingPredictor)) {
      WritePredictorRecord(coding.predictor, predictor, cw);
      predictor = coding.predictor;
    } else if (h.tools & kToolGeometryPrediction) {
      cw.U8(static_cast<uint8_t>(coding.alpha));
    }
    s.control.push_back(std::move(cw.bytes()));
    previous = models;

    // Datagrams.
    std::vector<std::vector<uint8_t>> datagrams;
    const uint32_t index = static_cast<uint32_t>(i);
    if (o.packing == Packing::kBundled) {
      datagrams = Packetize(models, r, channels, DatagramKind::kBundled, index, o);
    } else {
      datagrams = Packetize(models, r, channels, DatagramKind::kStructure, index, o);
      auto geometry = Packetize(models, r, channels, DatagramKind::kGeometry, index, o);
      for (auto& d : geometry) datagrams.push_back(std::move(d));
    }
    s.datagrams.push_back(std::move(datagrams));
  }
  return s;
}

}  // namespace meshstream
