#include "codec/bitstream/reader.h"

#include <algorithm>

#include "codec/entropy/range_coder.h"

namespace meshstream {

namespace {

std::string ModelSlotName(size_t k, ToolSet tools) {
  static const char* const kNames[5] = {"wing index", "ring offset", "position x", "position y", "position z"};
  static const char* const kRanked[2] = {"cut rank, low digit", "cut rank, high digit"};
  static const char* const kFramed[3] = {"position, first tangential", "position, second tangential",
                                         "position, normal"};
  if (k < 2 && (tools & kToolWingRank)) return kRanked[k];
  if (k >= 2 && k < 5 && (tools & kToolLocalFrame)) return kFramed[k - 2];
  return k < 5 ? kNames[k] : "channel " + std::to_string(k - 5);
}

}  // namespace

uint64_t StreamReader::unreliable_vertices() const {
  uint64_t n = 0;
  for (uint8_t f : state_.flags) n += f != 0 && (f & kAbsent) == 0 ? 1 : 0;
  return n;
}

void StreamReader::PositionExactInto(std::vector<uint8_t>& out) const {
  out.resize(state_.flags.size());
  for (size_t v = 0; v < out.size(); ++v) out[v] = (state_.flags[v] & (kPositionInexact | kAbsent)) == 0;
}

uint64_t StreamReader::inexact_positions() const {
  uint64_t n = 0;
  for (uint8_t f : state_.flags) n += (f & kPositionInexact) != 0 && (f & kAbsent) == 0 ? 1 : 0;
  return n;
}

StatusOr<StreamReader> StreamReader::Create(const uint8_t* header, size_t size, uint32_t stream_id) {
  StreamReader r;
  MS_ASSIGN_OR_RETURN(r.header_, StreamHeader::Parse(header, size));
  r.stream_id_ = stream_id;
  return r;
}

Status StreamReader::SetBase(QuantizedMesh base) {
  const StreamHeader& h = header_;
  if (base.vertex_count() != h.base_vertices || base.face_count() != h.base_faces) {
    return InvalidInput("the base mesh has " + std::to_string(base.vertex_count()) + " vertices and " +
                        std::to_string(base.face_count()) + " triangles; the stream expects " +
                        std::to_string(h.base_vertices) + " and " + std::to_string(h.base_faces));
  }
  const int ch = h.grids.layout.channels();
  if (base.layout.channels() != ch) return InvalidInput("the base mesh's attributes do not match the stream");
  MS_RETURN_IF_ERROR(header_.DecodeFixups());
  // A fix-up that takes a value outside 32 bits describes no grid point.
  auto fix = [](int32_t& value, int32_t delta, const char* what, size_t v) {
    const int64_t sum = int64_t{value} + delta;
    if (sum < INT32_MIN || sum > INT32_MAX) {
      return InvalidInput(std::string("stream header: ") + what + " of base vertex " + std::to_string(v) +
                          " overflows 32 bits");
    }
    value = static_cast<int32_t>(sum);
    return Status::Ok();
  };
  for (size_t v = 0; v < base.vertex_count(); ++v) {
    for (int k = 0; k < 3; ++k) MS_RETURN_IF_ERROR(fix(base.positions[v][k], h.base_position_fix[v * 3 + k], "position fix-up", v));
    for (int k = 0; k < ch; ++k)
      MS_RETURN_IF_ERROR(fix(base.attributes[v * ch + k], h.base_attribute_fix[v * ch + k], "attribute fix-up", v));
  }
  base.position_grid = h.grids.position_grid;
  base.layout = h.grids.layout;
  MS_RETURN_IF_ERROR(state_.Reset(base));
  MS_RETURN_IF_ERROR(state_.SetTwins(header_.seam_twins).WithContext("stream header"));
  history_ = SplitHistory();
  history_.vertices = static_cast<uint32_t>(base.vertex_count());
  if (h.has(kToolSplitContexts) && !h.reliable()) {
    MS_RETURN_IF_ERROR(split_contexts_.Reset(static_cast<uint32_t>(base.vertex_count()), base.indices));
  }
  if (h.reliable()) {
    connected_.Reset(state_.connectivity);
    payload_.Reset(ch);
  }
  models_.clear();
  predictor_ = kInitialPredictor;
  has_base_ = true;
  next_ = 0;
  return Status::Ok();
}

Status StreamReader::ReadPredictor(ByteReader& r, const std::string& where, PredictorWeights* predictor) {
  uint32_t alpha = 0;
  if (header_.has(kToolRingPredictor)) {
    auto mode = r.U8("predictor record");
    if (!mode.ok()) return mode.status().WithContext(where + ": control block");
    if (mode.value() > 1) {
      return InvalidInput(where + ": control block: predictor record " + std::to_string(mode.value()) + " is not 0 or 1");
    }
    if (mode.value() == 1) {
      static const char* const kWeightNames[kPredictorFeatures] = {"Laplacian", "sides", "ring"};
      for (int g = 0; g < 2; ++g) {
        for (int f = 0; f < kPredictorFeatures; ++f) {
          const std::string what = std::string(g == 0 ? "tangential " : "normal ") + kWeightNames[f] + " weight";
          auto z = r.Varint("predictor weight", uint64_t{2} * kMaxPredictorWeight);
          if (!z.ok()) return z.status().WithContext(where + ": control block: " + what);
          (g == 0 ? predictor->tangential : predictor->normal)[f] = UnZigZag(static_cast<uint32_t>(z.value()));
        }
      }
    }
  } else if (header_.has(kToolGeometryPrediction)) {
    auto a = r.U8("alpha");
    if (!a.ok()) return a.status().WithContext(where + ": control block");
    alpha = a.value();
  }
  coding_ = SplitCoding{header_.tools, alpha, *predictor, 0};
  if (header_.has(kToolAttributePrediction) && header_.grids.layout.has_normals) coding_.normal_bits = header_.grids.layout.qn;
  if (header_.has(kToolTexcoordPrediction)) {
    coding_.mapped_first = header_.grids.layout.texcoord_offset(0);
    coding_.mapped_count = header_.grids.layout.channels() - coding_.mapped_first;
  }
  return Status::Ok();
}

Status StreamReader::BeginReliable(ByteReader& r, Refinement& ref, const std::string& where) {
  PredictorWeights predictor = predictor_;
  MS_RETURN_IF_ERROR(ReadPredictor(r, where, &predictor));
  const size_t k = ref.split_count();
  const int ch = header_.grids.layout.channels();
  ref.wings.assign(k, {0, 0});
  ref.position_delta.assign(k, Vec3i{});
  ref.attribute_delta.assign(k * ch, 0);
  const size_t length = r.remaining();
  MS_ASSIGN_OR_RETURN(const uint8_t* data_bytes, r.Take(length, "split data"));
  const Status data = payload_.Decode(data_bytes, length, partner_, &ref);
  if (!data.ok()) return data.WithContext(where);
  predictor_ = predictor;
  has_structure_.assign(k, 1);
  has_geometry_.assign(k, 1);
  coded_ = ref;
  current_ = std::move(ref);
  return Status::Ok();
}

Status StreamReader::BeginRefinement(const uint8_t* control, size_t size) {
  if (!has_base_) return InvalidArgument("the base mesh must be set before refinements");
  if (in_refinement_) return InvalidArgument("the previous refinement is not finished");
  if (next_ >= refinement_count()) return InvalidInput("the stream has no refinement " + std::to_string(next_));
  const std::string where = "refinement " + std::to_string(next_);
  ByteReader r(control, size);
  size_t length = 0;
  MS_ASSIGN_OR_RETURN(const uint8_t* bits, r.Block("split bits", &length));
  const uint32_t n = state_.connectivity.vertex_count();
  Refinement ref;
  ref.vertices_before = n;
  const std::vector<uint32_t>* twins = header_.has(kToolSeams) ? &state_.twin : nullptr;
  const bool reliable = header_.reliable();
  const bool contexts = header_.has(kToolSplitContexts) && !reliable;
  if (reliable ? connected_.vertices() != n : (contexts ? split_contexts_.vertices() : history_.vertices) != n) {
    return Internal(where + ": split history is out of step");
  }
  // Nothing of the reader changes until the whole block is valid.
  SplitBitContexts::Decoded decoded;
  ConnectedSplitBits::Decoded connected;
  if (reliable) {
    auto got = connected_.Decode(bits, length, state_.connectivity, twins);
    if (!got.ok()) return got.status().WithContext(where);
    connected = std::move(got).value();
    decoded.bits = connected.bits;
  } else if (contexts) {
    auto got = split_contexts_.Decode(bits, length, twins);
    if (!got.ok()) return got.status().WithContext(where);
    decoded = std::move(got).value();
  } else {
    auto got = DecodeSplitBits(bits, length, history_, twins);
    if (!got.ok()) return got.status().WithContext(where);
    decoded.bits = std::move(got).value();
  }
  const std::vector<uint8_t>& split = decoded.bits;
  ref.split_vertices.reserve(std::min<size_t>(header_.split_counts[next_], n));  // checked against the bits below
  for (uint32_t v = 0; v < n; ++v)
    if (split[v]) ref.split_vertices.push_back(v);
  if (ref.split_vertices.size() != header_.split_counts[next_]) {
    return InvalidInput(where + ": " + std::to_string(ref.split_vertices.size()) + " split bits are set, the header says " +
                        std::to_string(header_.split_counts[next_]));
  }
  // Seam pairs split together (reliable data: the twins and the split bits).
  partner_.clear();
  if (header_.has(kToolSeams)) {
    const Status pairs = SeamPartners(ref.split_vertices, state_.twin, &partner_);
    if (!pairs.ok()) return pairs.WithContext(where + ": split bits");
  }
  if (reliable) {
    MS_RETURN_IF_ERROR(BeginReliable(r, ref, where));
    connected_.Advance(std::move(connected));
    in_refinement_ = true;
    return Status::Ok();
  }
  // Models: per slot, a flag (0: the previous refinement's, 1: a new one
  // follows), or with the model modes tool a mode (slot_model.h).
  const size_t slots = 5 + static_cast<size_t>(header_.grids.layout.channels());
  const bool modes = header_.has(kToolModelModes);
  // Only the new models are kept aside; a reused one stays where it is
  // (nothing is copied), and models_ changes only once the block is valid.
  std::vector<SlotModel> models;
  std::vector<uint8_t> fresh_slots(slots, 0);
  for (size_t k = 0; k < slots; ++k) {
    // Named only when something is wrong (no string work per slot otherwise).
    auto slot = [&] {
      return where + ": model slot " + std::to_string(k) + " (" + ModelSlotName(k, header_.tools) + ")";
    };
    auto flag = r.U8(modes ? "model mode" : "model flag");
    if (!flag.ok()) return flag.status().WithContext(slot());
    const uint8_t mode = flag.value();
    if (mode >= (modes ? kModelModes : 2)) {
      return InvalidInput(slot() + (modes ? ": model mode " + std::to_string(mode) + " is not 0, 1, 2 or 3"
                                          : ": model flag " + std::to_string(mode) + " is not 0 or 1"));
    }
    if (mode == static_cast<uint8_t>(ModelMode::kReuse)) {
      if (models_.size() != slots) {
        return InvalidInput(slot() + (modes ? ": model mode 0" : ": model flag 0") +
                            " reuses a model that was never sent");
      }
      continue;
    }
    const uint32_t alphabet = SlotAlphabet(k);
    SlotModel m;
    if (mode == static_cast<uint8_t>(ModelMode::kParametric)) {
      auto x = r.U8("model parameter");
      if (!x.ok()) return x.status().WithContext(slot());
      if (x.value() >= kParametricParameters) {
        return InvalidInput(slot() + ": model parameter " + std::to_string(x.value()) + " is out of range (0.." +
                            std::to_string(kParametricParameters - 1) + ")");
      }
      m.adaptive = true;
      m.prior = CachedParametricPrior(SlotKind(k), x.value());
    } else {
      auto table = StaticModel::Parse(r, alphabet);
      if (!table.ok()) return table.status().WithContext(slot());
      m.table = std::move(table).value();
      if (mode == static_cast<uint8_t>(ModelMode::kAdaptiveTable)) {
        m.adaptive = true;
        m.prior = TablePrior(m.table, alphabet);
      }
    }
    models.push_back(std::move(m));
    fresh_slots[k] = 1;
  }
  // The ring predictor's record, or version 2's alpha.
  PredictorWeights predictor = predictor_;
  MS_RETURN_IF_ERROR(ReadPredictor(r, where, &predictor));
  if (r.remaining() != 0) {
    return InvalidInput(where + ": control block: " + std::to_string(r.remaining()) + " stray bytes after the models");
  }
  predictor_ = predictor;
  if (models_.size() != slots) models_.resize(slots);  // the first block: every slot is fresh (checked above)
  for (size_t k = 0, next = 0; k < slots; ++k) {
    if (fresh_slots[k]) models_[k] = std::move(models[next++]);
  }
  const size_t k = ref.split_count();
  const int ch = header_.grids.layout.channels();
  ref.wings.assign(k, {0, 0});
  ref.position_delta.assign(k, Vec3i{});
  ref.attribute_delta.assign(k * ch, 0);
  has_structure_.assign(k, 0);
  has_geometry_.assign(k, 0);
  coded_ = ref;
  current_ = std::move(ref);  // its split vertices now, its data once the refinement is finished
  if (contexts) {
    split_contexts_.Advance(std::move(decoded));
  } else {
    history_ = history_.Next(split);
  }
  in_refinement_ = true;
  return Status::Ok();
}

bool StreamReader::OfferDatagram(const uint8_t* data, size_t size) {
  auto parsed = ParsedDatagram::Parse(data, size);
  if (!parsed.ok()) {
    ++stats_.rejected;
    return false;
  }
  return OfferDatagram(parsed.value());
}

bool StreamReader::OfferDatagram(const ParsedDatagram& d) {
  const DatagramHeader& h = d.header();
  if (!in_refinement_ || h.kind == DatagramKind::kEnd || h.stream != stream_id_ || h.refinement != next_ ||
      !DatagramFits(h, header_)) {
    ++stats_.rejected;
    return false;
  }
  // Decode into scratch first: a datagram is used whole or not at all.
  const bool structure = h.kind != DatagramKind::kGeometry;
  const bool geometry = h.kind != DatagramKind::kStructure;
  const int ch = header_.grids.layout.channels();
  RangeDecoder dec(d.payload(), d.payload_size());
  // (Member scratch, reused from datagram to datagram: no allocation once grown.)
  std::vector<std::array<uint16_t, 2>>& wings = datagram_wings_;
  std::vector<Vec3i>& deltas = datagram_deltas_;
  std::vector<int32_t>& attrs = datagram_attributes_;
  wings.assign(h.count, {0, 0});
  deltas.assign(geometry ? h.count : 0, Vec3i{});
  attrs.assign(geometry ? size_t(h.count) * ch : 0, 0);
  // A seam pair's primary unit carries both sides (the twin's wing, then
  // after the shared vector the twin's channels); the secondary's is empty.
  const bool seams = !partner_.empty();
  std::vector<uint16_t>& twin_wings = datagram_twin_wings_;
  std::vector<int32_t>& twin_attrs = datagram_twin_attributes_;
  twin_wings.assign(seams ? h.count : 0, 0);
  twin_attrs.assign(seams && geometry ? size_t(h.count) * ch : 0, 0);
  // Every datagram starts its adaptive models afresh (slot_model.h).
  std::vector<SlotCoder>& coders = datagram_coders_;
  coders.resize(models_.size());
  for (size_t k = 0; k < coders.size(); ++k) coders[k].Reset(models_[k]);
  for (uint32_t i = 0; i < h.count; ++i) {
    const size_t j = h.offset + size_t(i) * h.stride;
    const bool seam = seams && partner_[j] != kNoTwin;
    if (seam && partner_[j] < j) continue;  // secondary
    if (structure) {
      if (seam) {
        wings[i][0] = static_cast<uint16_t>(dec.DecodeRaw(kSeamWingBits));
        twin_wings[i] = static_cast<uint16_t>(dec.DecodeRaw(kSeamWingBits));
      } else {
        wings[i][0] = static_cast<uint16_t>(coders[0].Decode(dec));
        wings[i][1] = static_cast<uint16_t>(coders[1].Decode(dec));
      }
    }
    if (geometry) {
      for (int c = 0; c < 3; ++c) deltas[i][c] = DecodeSigned(dec, coders[2 + c]);
      for (int c = 0; c < ch; ++c) attrs[size_t(i) * ch + c] = DecodeSigned(dec, coders[5 + c]);
      if (seam)
        for (int c = 0; c < ch; ++c) twin_attrs[size_t(i) * ch + c] = DecodeSigned(dec, coders[5 + c]);
    }
  }
  // The payload must end with its last unit: a stray byte or a cut makes the
  // datagram malformed.
  if (dec.overran() || !dec.ended_exactly()) {
    ++stats_.rejected;
    return false;
  }
  bool fresh = false;
  for (uint32_t i = 0; i < h.count; ++i) {
    const size_t j = h.offset + size_t(i) * h.stride;
    const size_t t = seams ? partner_[j] : kNoTwin;
    if (t != kNoTwin && t < j) continue;  // a secondary arrives with its primary
    if (structure && !has_structure_[j]) {
      coded_.wings[j] = wings[i];
      has_structure_[j] = 1;
      if (t != kNoTwin) {
        coded_.wings[t] = {twin_wings[i], 0};
        has_structure_[t] = 1;
      }
      fresh = true;
    }
    if (geometry && !has_geometry_[j]) {
      coded_.position_delta[j] = deltas[i];
      std::copy(attrs.begin() + size_t(i) * ch, attrs.begin() + size_t(i + 1) * ch,
                coded_.attribute_delta.begin() + j * ch);
      has_geometry_[j] = 1;
      if (t != kNoTwin) {
        coded_.position_delta[t] = deltas[i];
        std::copy(twin_attrs.begin() + size_t(i) * ch, twin_attrs.begin() + size_t(i + 1) * ch,
                  coded_.attribute_delta.begin() + t * ch);
        has_geometry_[t] = 1;
      }
      fresh = true;
    }
  }
  if (fresh) ++stats_.accepted;
  else ++stats_.duplicates;
  return true;
}

bool StreamReader::HasEveryUnit() const {
  return in_refinement_ && std::find(has_structure_.begin(), has_structure_.end(), 0) == has_structure_.end() &&
         std::find(has_geometry_.begin(), has_geometry_.end(), 0) == has_geometry_.end();
}

Status StreamReader::FinishRefinement(Recovery recovery) {
  if (!in_refinement_) return InvalidArgument("no refinement was begun");
  const std::string where = "refinement " + std::to_string(next_);
  if (coded_.vertices_before != state_.connectivity.vertex_count()) return Internal(where + ": out of step");
  // What was applied starts as what arrived; the splits write what they decode.
  current_.wings = coded_.wings;
  current_.position_delta = coded_.position_delta;
  current_.attribute_delta = coded_.attribute_delta;
  state_.ReserveSplits(current_.split_count());
  RecoveryStats stats;
  const size_t count = current_.split_count();
  // A refinement that is all there, decoded while nothing is flagged, can
  // be planned in parallel.
  const bool parallel = runner_ != nullptr && runner_->workers() > 1 && !state_.any_inexact && !state_.any_absent &&
                        std::find(has_structure_.begin(), has_structure_.end(), 0) == has_structure_.end() &&
                        std::find(has_geometry_.begin(), has_geometry_.end(), 0) == has_geometry_.end();
  // The ring predictor's 2-ring term reads only the vertices no split of
  // this refinement changes (ring_predictor.h), and the plans check their
  // rings against them: marked only when read.
  const bool stable = ReadsUmbrellas(coding_) || parallel;
  if (stable) state_.BeginSplits(coded_);
  Status status = Status::Ok();
  size_t j = parallel ? ApplyPlanned(recovery, &stats, &status) : 0;
  for (; j < count && status.ok(); ++j) {
    status = RecoverSplit(coded_, j, has_structure_[j] != 0, has_geometry_[j] != 0, recovery, &state_,
                          &recovery_scratch_, &stats, coding_, &current_);
  }
  if (stable) state_.EndSplits(coded_);
  if (!status.ok()) return status.WithContext(where);
  recovery_stats_.Add(stats);
  in_refinement_ = false;
  ++next_;
  return Status::Ok();
}

size_t StreamReader::ApplyPlanned(Recovery recovery, RecoveryStats* stats, Status* status) {
  const size_t count = current_.split_count();
  for (size_t first = 0; first < count;) {
    const size_t end = std::min(count, first + RefinementPlan::kWindowSplits);
    plan_.Plan(coded_, coding_, state_, first, end - first, *runner_);
    for (size_t j = first; j < end; ++j) {
      switch (plan_.kind(j)) {
        case RefinementPlan::Kind::kPlanned:
          if (plan_.Holds(j, state_)) {
            plan_.Apply(coded_, j, coding_, &state_, &current_);
            ++stats->exact;
            ++stats->planned;
            break;
          }
          [[fallthrough]];
        case RefinementPlan::Kind::kSerial:
          // A seam split, or a plan that no longer holds, in its turn by
          // the serial path; should it leave a flag, the plans after it no
          // longer hold.
          *status = RecoverSplit(coded_, j, true, true, recovery, &state_, &recovery_scratch_, stats, coding_, &current_);
          if (!status->ok() || state_.any_inexact || state_.any_absent) return j + 1;
          break;
        case RefinementPlan::Kind::kStop:
          return j;
      }
    }
    first = end;
  }
  return count;
}

}  // namespace meshstream
