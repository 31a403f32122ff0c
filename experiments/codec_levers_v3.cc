// Measures the candidate coding levers of codec format version 3 (issue 24)
// before they are built: encodes a model as today's writer does
// (WriteStream, version 2, split packing), replays its hierarchy exactly as
// the decoder sees it (the coded residuals and ranks through the library's
// own functions, alpha read from the control blocks) and prices, in bits per
// split, each candidate against today's v2 coding computed the same way:
//   1. adaptive symbol models per datagram instead of static tables per
//      refinement (the datagrams dealt as today: split j to datagram j mod S);
//   2. contexts for the geometry residuals;
//   3. better geometry predictors (least squares over ring features);
//   4. split-bit contexts from reliable data only;
//   5. contexts for the cut-edge rank;
//   6. today's per-refinement overhead.
// Sizes only (ideal arithmetic coding: sum of -log2 p); the real coder is
// within a few bytes per datagram (measured below against the real stream).
// Usage: meshstream_codec_levers_v3 [--model FILE] [--qp N] [--out FILE.json]
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <string>

#include <nlohmann/json.hpp>

#include "bench/bench_util.h"
#include "experiments/estimate_main.h"
#include "codec/bitstream/format.h"
#include "codec/bitstream/writer.h"
#include "codec/core/byte_io.h"
#include "codec/entropy/range_coder.h"
#include "codec/entropy/symbol_model.h"
#include "codec/progressive/geometry_prediction.h"
#include "codec/progressive/local_frame.h"
#include "codec/progressive/normal_prediction.h"
#include "codec/progressive/refinement_state.h"
#include "codec/progressive/seam_twins.h"
#include "codec/progressive/split_bits.h"
#include "codec/progressive/texcoord_prediction.h"
#include "codec/progressive/wing_rank.h"
#include "importers/import.h"

namespace ms = meshstream;
using ms::Vec3d;
using ms::Vec3i;

namespace {

// ---------------------------------------------------------------------------
// Symbols

constexpr int kStructSlots = 2;
constexpr uint32_t kWingAlphabet = 16;

inline double RawBits(int32_t v) {
  const uint32_t z = ms::ZigZag(v);
  return z >= ms::kDirectSymbols ? double((32 - __builtin_clz(z)) - 2) : 0.0;
}
inline int BitLength(uint64_t x) { return x == 0 ? 0 : 64 - __builtin_clzll(x); }

// An adaptive frequency model: counts (every symbol of the alphabet at least
// 1, so anything decodes), `inc` added per coded symbol, all halved (rounding
// up) when the total exceeds `limit`. Cost of a symbol: -log2(count / total).
struct AdaptiveModel {
  std::vector<uint32_t> c;
  uint64_t total = 0;
  uint32_t inc = 32, limit = 1 << 16;
  void Uniform(size_t n) {
    c.assign(n, 1);
    total = n;
  }
  // From probabilities p (sum 1) with a prior weight: count = max(1, p weight).
  void From(const std::vector<double>& p, double weight) {
    c.resize(p.size());
    total = 0;
    for (size_t s = 0; s < p.size(); ++s) {
      c[s] = std::max<uint32_t>(1, static_cast<uint32_t>(std::lround(p[s] * weight)));
      total += c[s];
    }
  }
  double Code(uint32_t s) {
    const double b = -std::log2(double(c[s]) / double(total));
    c[s] += inc;
    total += inc;
    if (total > limit) {
      total = 0;
      for (uint32_t& x : c) {
        x = (x + 1) / 2;
        total += x;
      }
    }
    return b;
  }
};

// The probabilities a static model of the format gives its symbols (zero
// for absent ones), over `alphabet` symbols.
std::vector<double> ModelProbabilities(const ms::StaticModel& m, size_t alphabet) {
  std::vector<double> p(alphabet, 0.0);
  for (uint32_t s = 0; s < alphabet && s < m.alphabet(); ++s)
    if (m.Has(s)) p[s] = std::exp2(-m.Cost(s));
  return p;
}

size_t ModelBytes(const ms::StaticModel& m) {
  ms::ByteWriter w;
  m.Serialize(w);
  return w.size();
}

// Static cost of a histogram with the format's model built from it (what
// today's writer sends when it sends a fresh model): symbols only.
double StaticCost(const ms::StaticModel& m, const std::vector<uint64_t>& h) {
  double bits = 0;
  for (size_t s = 0; s < h.size(); ++s)
    if (h[s]) bits += double(h[s]) * m.Cost(static_cast<uint32_t>(s));
  return bits;
}

double Order0(const std::vector<uint64_t>& h) {
  uint64_t n = 0;
  for (uint64_t k : h) n += k;
  double bits = 0;
  for (uint64_t k : h)
    if (k) bits -= double(k) * std::log2(double(k) / double(n));
  return bits;
}

// A one-parameter family of models, one byte per (refinement, slot): a
// two-sided geometric distribution P(v) ~ theta^|v| on the signed value,
// summed over each symbol's bucket (slots 2..), or P(s) ~ theta^s on the
// structure symbols (slots 0, 1); theta = 1 - 2^-(x / 8), x = 1..120.
// Probabilities are floored at 1/4096 and renormalized (a 12-bit table).
constexpr int kThetas = 120;
double ThetaOf(int x) { return 1.0 - std::exp2(-(x + 1) / 8.0); }

double GeoSum(double theta, double a, double b) {  // sum of theta^v for integer v in [a, b)
  if (b <= a) return 0;
  return (std::pow(theta, a) - std::pow(theta, b)) / (1 - theta);
}

std::vector<double> ParametricProbs(bool structure, int x) {
  const double th = ThetaOf(x);
  std::vector<double> p;
  if (structure) {
    p.resize(kWingAlphabet);
    for (uint32_t s = 0; s < kWingAlphabet; ++s) p[s] = std::pow(th, double(s));
  } else {
    p.assign(ms::kSignedSymbols, 0.0);
    for (uint32_t s = 0; s < ms::kSignedSymbols; ++s) {
      double z0, z1;
      if (s < ms::kDirectSymbols) {
        z0 = s;
        z1 = s + 1;
      } else {
        const int L = int(s - ms::kDirectSymbols) / 2 + 5, bit = int(s - ms::kDirectSymbols) % 2;
        z0 = std::ldexp(1.0, L - 1) + bit * std::ldexp(1.0, L - 2);
        z1 = z0 + std::ldexp(1.0, L - 2);
      }
      // even z: v = z / 2 >= 0; odd z: v = -(z + 1) / 2.
      const double pos = GeoSum(th, std::ceil(z0 / 2), std::ceil(z1 / 2));
      const double neg = GeoSum(th, std::ceil((z0 + 1) / 2), std::ceil((z1 + 1) / 2));
      p[s] = pos + neg;
    }
  }
  double t = 0;
  for (double v : p) t += v;
  for (double& v : p) v = std::max(v / t, 1.0 / 4096);
  t = 0;
  for (double v : p) t += v;
  for (double& v : p) v /= t;
  return p;
}

const std::vector<double>& Parametric(bool structure, int x) {
  static std::vector<std::vector<double>> cache[2];
  auto& c = cache[structure ? 1 : 0];
  if (c.empty())
    for (int k = 0; k < kThetas; ++k) c.push_back(ParametricProbs(structure, k));
  return c[x];
}

// The parameter that codes histogram h best, and its cost (symbols only).
int BestTheta(bool structure, const std::vector<uint64_t>& h, double* bits) {
  double best = 1e300;
  int bx = 0;
  for (int x = 0; x < kThetas; ++x) {
    const std::vector<double>& p = Parametric(structure, x);
    double b = 0;
    for (size_t s = 0; s < h.size(); ++s)
      if (h[s]) b -= double(h[s]) * std::log2(p[s]);
    if (b < best) {
      best = b;
      bx = x;
    }
  }
  if (bits) *bits = best;
  return bx;
}

// ---------------------------------------------------------------------------
// The replayed hierarchy

// kRing2S: kRing2 with each ring vertex's Laplacian over its stable
// neighbours only (not splitting in this refinement), so that no split of a
// refinement reads what another writes.
enum Feature { kLap, kWing, kSides, kStrict, kRing2, kUmbrella, kRing2S, kRing2U, kFeatures };

struct SplitRec {
  bool seam = false, secondary = false;
  uint32_t w = 0;
  int degree = 0;
  uint32_t rank = 0;
  std::array<uint16_t, 2> sym{};  // structure symbols as coded (slots 0, 1)
  int64_t key0 = 0, key1 = 0;     // the best and second-best keys of the ranking
  Vec3i coded{};                  // the coded residual (slots 2..4), exact
  std::vector<int32_t> att;       // coded channel residuals (slots 5..), both sides for a seam primary
  Vec3d fd{};                     // the split vector in the local frame (exact integer rotation)
  std::array<Vec3d, kFeatures> f{};  // features in the local frame
  double scale = 0;               // mean ring edge length
  double aniso = 0;               // sqrt(l_max) - sqrt(l_min) of the ring's tangential second moment / degree
};

struct LevelRec {
  uint32_t vertices_before = 0;
  uint32_t alpha = 0;
  size_t stride_struct = 1, stride_geom = 1, n_struct = 0, n_geom = 0;
  size_t control_bytes = 0, split_block_bytes = 0;   // split block incl. its length varint
  size_t models_bytes = 0;                           // flags + model tables + alpha
  size_t dgram_header_bytes = 0, dgram_payload_struct = 0, dgram_payload_geom = 0;
  std::vector<SplitRec> s;
  double median_scale = 1, median_aniso = 1;
};

struct Replay {
  std::vector<LevelRec> levels;
  int channels = 0;
  uint64_t splits = 0;      // every split (seam secondaries included)
  size_t header_bytes = 0, base_bytes = 0;
  const ms::ProgressiveMesh* pm = nullptr;
};

Vec3d ToD(const Vec3i& v) { return {double(v[0]), double(v[1]), double(v[2])}; }

// A real vector through the integer frame, at 1/64 precision.
Vec3d InFrame(const ms::LocalFrame& fr, const Vec3d& v) {
  Vec3i q;
  for (int c = 0; c < 3; ++c) q[c] = static_cast<int32_t>(std::clamp(std::llround(64 * v[c]), -(1LL << 30), 1LL << 30));
  const Vec3i r = fr.Forward(q);
  return {r[0] / 64.0, r[1] / 64.0, r[2] / 64.0};
}

void ParseDatagrams(const std::vector<std::vector<uint8_t>>& dg, LevelRec& L) {
  for (const auto& bytes : dg) {
    ms::ByteReader r(bytes.data(), bytes.size());
    auto h = ms::DatagramHeader::Parse(r);
    if (!h.ok()) ms::bench::Die("datagram header");
    L.dgram_header_bytes += r.position();
    const size_t payload = bytes.size() - r.position();
    if (h->kind == ms::DatagramKind::kStructure) {
      L.stride_struct = h->stride;
      ++L.n_struct;
      L.dgram_payload_struct += payload;
    } else {
      L.stride_geom = h->stride;
      ++L.n_geom;
      L.dgram_payload_geom += payload;
    }
  }
}

Replay Build(const ms::ProgressiveEncoded& e, const ms::ProgressiveStream& stream) {
  Replay out;
  const ms::ProgressiveMesh& pm = e.mesh;
  out.pm = &pm;
  out.header_bytes = stream.header.size();
  out.base_bytes = e.base_bytes.size();
  const ms::AttributeLayout& layout = pm.base.layout;
  const int ch = layout.channels();
  out.channels = ch;
  ms::StreamHeader hdr;
  {
    auto h = ms::StreamHeader::Parse(stream.header.data(), stream.header.size());
    if (!h.ok()) ms::bench::Die("stream header");
    hdr = *h;
  }
  const uint8_t tools = hdr.tools;
  if (!(tools & ms::kToolGeometryPrediction) || !(tools & ms::kToolWingRank)) ms::bench::Die("expected v2 tools");
  ms::RefinementState st;
  if (!st.Reset(pm.base).ok() || !st.SetTwins(pm.base_twins).ok()) ms::bench::Die("reset");
  ms::SplitHistory history;
  history.vertices = static_cast<uint32_t>(pm.base.vertex_count());
  std::vector<uint32_t> partner, sorted;
  for (size_t i = 0; i < pm.refinements.size(); ++i) {
    const ms::Refinement& r = pm.refinements[i];
    LevelRec L;
    L.vertices_before = r.vertices_before;
    // Real bytes of today's stream.
    L.control_bytes = stream.control[i].size();
    L.alpha = stream.control[i].back();
    partner.clear();
    std::vector<uint32_t> twin_before;
    const bool seams = (tools & ms::kToolSeams) != 0;
    if (seams) {
      if (!ms::SeamPartners(r.split_vertices, st.twin, &partner).ok()) ms::bench::Die("partners");
      twin_before = st.twin;
    }
    {
      std::vector<uint8_t> bits(r.vertices_before, 0);
      for (uint32_t v : r.split_vertices) bits[v] = 1;
      const auto block = ms::EncodeSplitBits(bits, history, seams ? &twin_before : nullptr);
      ms::ByteWriter bw;
      bw.Block(block);
      L.split_block_bytes = bw.size();
      history = history.Next(bits);
    }
    L.models_bytes = L.control_bytes - L.split_block_bytes;
    ParseDatagrams(stream.datagrams[i], L);

    ms::SplitCoding coding;
    coding.tools = tools;
    coding.alpha = L.alpha;
    if (tools & ms::kToolTexcoordPrediction) {
      coding.mapped_first = layout.texcoord_offset(0);
      coding.mapped_count = ch - coding.mapped_first;
    }
    const size_t k = r.split_count();
    L.s.resize(k);
    // Phase A: everything from the coarser mesh, before any split of this refinement.
    std::vector<std::vector<uint32_t>> rings(k);
    std::vector<std::array<size_t, 2>> wings_at(k);
    std::vector<ms::LocalFrame> frames(k);
    std::vector<uint8_t> splitting(st.positions.size(), 0);
    for (uint32_t v : r.split_vertices) splitting[v] = 1;
    ms::WingRanking ranking;
    for (size_t j = 0; j < k; ++j) {
      SplitRec& s = L.s[j];
      s.w = r.split_vertices[j];
      if (seams && partner[j] != ms::kNoTwin) {
        s.seam = true;
        s.secondary = partner[j] < j;
        s.coded = r.position_delta[j];
        continue;
      }
      std::vector<uint32_t>& ring = rings[j];
      if (!st.connectivity.CyclicRing(s.w, ring)) ms::bench::Die("not a fan");
      size_t a_at, b_at;
      if (!ms::WingPositions(ring, r.wings[j], &a_at, &b_at)) ms::bench::Die("wings");
      wings_at[j] = {a_at, b_at};
      const size_t D = ring.size();
      s.degree = static_cast<int>(D);
      std::vector<Vec3i> rp(D);
      for (size_t x = 0; x < D; ++x) rp[x] = st.positions[ring[x]];
      const Vec3i m = st.positions[s.w];
      frames[j] = ms::RingLocalFrame(m, rp.data(), D);
      const ms::LocalFrame& fr = frames[j];
      if (!ranking.Reset(m, rp.data(), D, fr) || !ranking.RankOf(a_at, b_at, &s.rank)) ms::bench::Die("rank");
      s.sym = ms::RankSymbols(s.rank);
      int64_t keys[2] = {0, 0};
      ranking.KeysInOrder(keys, 2);
      s.key0 = keys[0];
      s.key1 = keys[1];
      s.coded = ms::CodeSplitVector(coding, r.position_delta[j], rp.data(), D, a_at, b_at, fr);
      // Features (world), then into the frame.
      const ms::SplitPrediction lp = ms::PredictSplit(rp.data(), D, a_at, b_at);
      Vec3d lap;
      for (int c = 0; c < 3; ++c) lap[c] = double(lp.numerator[c]) / double(lp.denominator);
      const Vec3d md = ToD(m);
      const Vec3d wing = ms::Sub(ToD(rp[a_at]), ToD(rp[b_at]));
      // P = b..a (new vertex's side), Q = a..b (w's side), inclusive.
      Vec3d sp{0, 0, 0}, sq{0, 0, 0}, spx{0, 0, 0}, sqx{0, 0, 0}, l2p{0, 0, 0}, l2q{0, 0, 0}, cen{0, 0, 0};
      size_t kp = 0, kq = 0, kpx = 0, kqx = 0;
      const size_t plen = (a_at + D - b_at) % D;  // steps b -> a
      std::vector<Vec3d> lapx(D), lapsx(D);
      Vec3d l2ps{0, 0, 0}, l2qs{0, 0, 0}, l2pu{0, 0, 0}, l2qu{0, 0, 0};
      std::vector<Vec3d> lapux(D);
      for (size_t x = 0; x < D; ++x) {
        st.connectivity.SortedNeighbours(ring[x], sorted);
        Vec3d acc{0, 0, 0}, accs{0, 0, 0};
        size_t ns = 0;
        for (uint32_t y : sorted) {
          acc = ms::Add(acc, ToD(st.positions[y]));
          if (!splitting[y]) {
            accs = ms::Add(accs, ToD(st.positions[y]));
            ++ns;
          }
        }
        lapx[x] = sorted.empty() ? Vec3d{0, 0, 0} : ms::Sub(ToD(rp[x]), ms::Scale(acc, 1.0 / double(sorted.size())));
        lapsx[x] = ns == 0 ? Vec3d{0, 0, 0} : ms::Sub(ToD(rp[x]), ms::Scale(accs, 1.0 / double(ns)));
        lapux[x] = ms::Scale(ms::Sub(ms::Scale(ToD(rp[x]), double(ns)), accs), 1.0 / 6.0);
        cen = ms::Add(cen, ToD(rp[x]));
      }
      for (size_t t = 0; t <= plen; ++t) {
        const size_t x = (b_at + t) % D;
        sp = ms::Add(sp, ToD(rp[x]));
        l2p = ms::Add(l2p, lapx[x]);
        l2ps = ms::Add(l2ps, lapsx[x]);
        l2pu = ms::Add(l2pu, lapux[x]);
        ++kp;
        if (t != 0 && t != plen) {
          spx = ms::Add(spx, ToD(rp[x]));
          ++kpx;
        }
      }
      for (size_t t = 0; t <= D - plen; ++t) {
        const size_t x = (a_at + t) % D;
        sq = ms::Add(sq, ToD(rp[x]));
        l2q = ms::Add(l2q, lapx[x]);
        l2qs = ms::Add(l2qs, lapsx[x]);
        l2qu = ms::Add(l2qu, lapux[x]);
        ++kq;
        if (t != 0 && t != D - plen) {
          sqx = ms::Add(sqx, ToD(rp[x]));
          ++kqx;
        }
      }
      const Vec3d mid_ab = ms::Scale(ms::Add(ToD(rp[a_at]), ToD(rp[b_at])), 0.5);
      const Vec3d cq = ms::Scale(sq, 1.0 / kq), cp = ms::Scale(sp, 1.0 / kp);
      const Vec3d cqx = kqx ? ms::Scale(sqx, 1.0 / kqx) : mid_ab, cpx = kpx ? ms::Scale(spx, 1.0 / kpx) : mid_ab;
      std::array<Vec3d, kFeatures> fw;
      fw[kLap] = lap;
      fw[kWing] = wing;
      fw[kSides] = ms::Sub(cq, cp);
      fw[kStrict] = ms::Sub(cqx, cpx);
      fw[kRing2] = ms::Sub(ms::Scale(l2q, 1.0 / kq), ms::Scale(l2p, 1.0 / kp));
      fw[kUmbrella] = ms::Sub(md, ms::Scale(cen, 1.0 / double(D)));
      fw[kRing2S] = ms::Sub(ms::Scale(l2qs, 1.0 / kq), ms::Scale(l2ps, 1.0 / kp));
      fw[kRing2U] = ms::Sub(ms::Scale(l2qu, 1.0 / kq), ms::Scale(l2pu, 1.0 / kp));
      for (int f = 0; f < kFeatures; ++f) s.f[f] = InFrame(fr, fw[f]);
      s.fd = ToD(fr.Forward(r.position_delta[j]));
      double el = 0;
      for (size_t x = 0; x < D; ++x) el += ms::Norm(ms::Sub(ToD(rp[(x + 1) % D]), ToD(rp[x])));
      s.scale = el / double(D);
      double a00 = 0, a01 = 0, a11 = 0;
      for (size_t x = 0; x < D; ++x) {
        const Vec3d q = InFrame(fr, ms::Sub(ToD(rp[x]), md));
        a00 += q[0] * q[0];
        a01 += q[0] * q[1];
        a11 += q[1] * q[1];
      }
      const double tr = a00 + a11, det = a00 * a11 - a01 * a01;
      const double disc = std::sqrt(std::max(0.0, tr * tr / 4 - det));
      s.aniso = (std::sqrt(std::max(0.0, tr / 2 + disc)) - std::sqrt(std::max(0.0, tr / 2 - disc))) / std::sqrt(double(D));
    }
    // Phase B: apply the splits in order, with the channels' predictions as the writer makes them.
    st.ReserveSplits(k);
    for (size_t j = 0; j < k; ++j) {
      SplitRec& s = L.s[j];
      const uint32_t w = s.w;
      if (s.seam) {
        st.connectivity.OpenRing(w, st.scratch_ring);
        st.ApplySeamSplitAt(r, j, r.wings[j][0]);
        continue;
      }
      st.connectivity.CyclicRing(w, st.scratch_ring);
      std::vector<Vec3i> rp;
      for (uint32_t x : st.scratch_ring) rp.push_back(st.positions[x]);
      const std::vector<uint32_t> ring_ids = st.scratch_ring;
      const uint32_t n = st.ApplySplitAt(r, j, wings_at[j][0], wings_at[j][1]);
      s.att.assign(r.attribute_delta.begin() + j * ch, r.attribute_delta.begin() + (j + 1) * ch);
      if ((tools & ms::kToolAttributePrediction) && layout.has_normals) {
        const std::array<int32_t, 2> p = ms::PredictNormalDelta(st, w, n, layout.qn);
        for (int c = 0; c < 2; ++c) s.att[c] = static_cast<int32_t>(std::clamp<int64_t>(int64_t{s.att[c]} - p[c], INT32_MIN, INT32_MAX));
      }
      if (coding.mapped_count > 0) {
        int32_t p[ms::kMaxMappedChannels];
        ms::PredictChannelDeltas(st, ring_ids.data(), rp.data(), rp.size(), frames[j], w, n, coding.mapped_first,
                                 coding.mapped_count, p);
        for (int c = 0; c < coding.mapped_count; ++c) {
          int32_t& v = s.att[coding.mapped_first + c];
          v = static_cast<int32_t>(std::clamp<int64_t>(int64_t{v} - p[c], INT32_MIN, INT32_MAX));
        }
      }
    }
    // Seam primaries carry both sides' raw channels.
    for (size_t j = 0; j < k; ++j) {
      SplitRec& s = L.s[j];
      if (!s.seam || s.secondary) continue;
      s.att.assign(r.attribute_delta.begin() + j * ch, r.attribute_delta.begin() + (j + 1) * ch);
      const size_t t = partner[j];
      s.att.insert(s.att.end(), r.attribute_delta.begin() + t * ch, r.attribute_delta.begin() + (t + 1) * ch);
    }
    std::vector<double> sc, an;
    for (const SplitRec& s : L.s)
      if (!s.seam) {
        sc.push_back(s.scale);
        an.push_back(s.aniso);
      }
    if (!sc.empty()) {
      std::nth_element(sc.begin(), sc.begin() + sc.size() / 2, sc.end());
      std::nth_element(an.begin(), an.begin() + an.size() / 2, an.end());
      L.median_scale = std::max(1e-9, sc[sc.size() / 2]);
      L.median_aniso = std::max(1e-9, an[an.size() / 2]);
    }
    out.splits += k;
    out.levels.push_back(std::move(L));
  }
  return out;
}

// ---------------------------------------------------------------------------
// Coding schemes over slots. A slot's value for a split: structure symbols
// (slots 0, 1; unsigned), then signed values (slots 2.., c0 c1 c2 and the
// channels). A context function maps (level, split, slot) to a context.

struct Unit {
  uint32_t slot;
  int32_t value;
  int ctx;
};

using CtxFn = std::function<int(const LevelRec&, const SplitRec&, int slot)>;

// The units of one split of `kind` (0 structure, 1 geometry) with contexts.
void UnitsOf(const LevelRec& L, const SplitRec& s, int kind, int channels, const CtxFn& ctx, std::vector<Unit>& out,
             double* raw_fixed) {
  out.clear();
  if (s.secondary) return;
  if (kind == 0) {
    if (s.seam) {
      *raw_fixed += 2 * ms::kSeamWingBits;
      return;
    }
    for (int k = 0; k < 2; ++k) out.push_back({uint32_t(k), int32_t(s.sym[k]), ctx ? ctx(L, s, k) : 0});
    return;
  }
  for (int k = 0; k < 3; ++k) out.push_back({uint32_t(2 + k), s.coded[k], ctx && !s.seam ? ctx(L, s, 2 + k) : 0});
  for (size_t a = 0; a < s.att.size(); ++a)
    out.push_back({uint32_t(5 + a % channels), s.att[a], 0});
}

inline uint32_t SymOf(const Unit& u) {
  return u.slot < kStructSlots ? static_cast<uint32_t>(u.value) : ms::SignedSymbol(u.value);
}
inline double RawOf(const Unit& u) { return u.slot < kStructSlots ? 0.0 : RawBits(u.value); }
inline size_t AlphabetOf(uint32_t slot) { return slot < kStructSlots ? kWingAlphabet : ms::kSignedSymbols; }

using Key = std::pair<uint32_t, int>;  // (slot, context)

struct Cost {
  double bits = 0;        // symbols and raw bits
  double table_bits = 0;  // models sent (flags included)
  double total() const { return bits + table_bits; }
};

// Static models per refinement and (slot, context), fresh every refinement:
// symbols + tables (+ one flag byte per model). `order0` gives the entropy
// with no table instead.
Cost StaticScheme(const Replay& R, int kind, const CtxFn& ctx, bool order0, bool parametric = false) {
  Cost c;
  std::vector<Unit> units;
  for (const LevelRec& L : R.levels) {
    std::map<Key, std::vector<uint64_t>> h;
    double raw = 0, fixed = 0;
    for (const SplitRec& s : L.s) {
      UnitsOf(L, s, kind, R.channels, ctx, units, &fixed);
      for (const Unit& u : units) {
        auto& v = h[{u.slot, u.ctx}];
        if (v.empty()) v.assign(AlphabetOf(u.slot), 0);
        ++v[SymOf(u)];
        raw += RawOf(u);
      }
    }
    c.bits += raw + fixed;
    for (auto& [key, hist] : h) {
      if (order0) {
        c.bits += Order0(hist);
      } else if (parametric) {
        double b = 0;
        BestTheta(key.first < kStructSlots, hist, &b);
        c.bits += b;
        c.table_bits += 8.0;
      } else {
        const ms::StaticModel m = ms::StaticModel::FromCounts(hist);
        c.bits += StaticCost(m, hist);
        c.table_bits += 8.0 * (1 + ModelBytes(m));
      }
    }
  }
  return c;
}

// Today's writer exactly (bitstream/writer.cc, WriteModels): per refinement
// and slot a fresh model, or the previous refinement's when it codes the
// slot's symbols in fewer bits than the fresh one with its bytes; a flag
// byte per slot. Symbols (ideal coder) and tables, per kind.
void TodayExact(const Replay& R, Cost* structure, Cost* geometry) {
  const size_t slots = 5 + R.channels;
  std::vector<ms::StaticModel> previous;
  std::vector<Unit> units;
  for (size_t i = 0; i < R.levels.size(); ++i) {
    const LevelRec& L = R.levels[i];
    std::vector<std::vector<uint64_t>> h(slots);
    for (size_t k = 0; k < slots; ++k) h[k].assign(AlphabetOf(uint32_t(k)), 0);
    for (int kind = 0; kind < 2; ++kind) {
      Cost& c = kind == 0 ? *structure : *geometry;
      for (const SplitRec& s : L.s) {
        double fixed = 0;
        UnitsOf(L, s, kind, R.channels, nullptr, units, &fixed);
        c.bits += fixed;
        for (const Unit& u : units) {
          ++h[u.slot][SymOf(u)];
          c.bits += RawOf(u);
        }
      }
    }
    std::vector<ms::StaticModel> chosen;
    for (size_t k = 0; k < slots; ++k) {
      Cost& c = k < kStructSlots ? *structure : *geometry;
      const ms::StaticModel fresh = ms::StaticModel::FromCounts(h[k]);
      const double fresh_bits = StaticCost(fresh, h[k]) + 8.0 * ModelBytes(fresh);
      double reuse_bits = 1e300;
      if (i > 0) {
        bool ok = true;
        for (size_t q = 0; q < h[k].size(); ++q)
          if (h[k][q] && !previous[k].Has(uint32_t(q))) ok = false;
        if (ok) reuse_bits = StaticCost(previous[k], h[k]);
      }
      c.table_bits += 8.0;
      if (reuse_bits < fresh_bits) {
        c.bits += reuse_bits;
        chosen.push_back(previous[k]);
      } else {
        c.bits += StaticCost(fresh, h[k]);
        c.table_bits += 8.0 * ModelBytes(fresh);
        chosen.push_back(fresh);
      }
    }
    geometry->table_bits += 8.0;  // alpha
    previous = std::move(chosen);
  }
}

enum class Init { kUniform, kRefinementTable, kStreamTable, kPreviousTable, kParametric };

struct AdaptiveParams {
  Init init = Init::kUniform;
  uint32_t inc = 32, limit = 1 << 16;
  double prior = 1024;  // weight of an initial table
  bool whole_refinement = false;  // one model set per refinement (not per datagram): not decodable alone, reference
};

// Adaptive models per datagram (split j in datagram j mod S, S as today's
// stream), per (slot, context), initialised per `p`.
// `per_key` (optional): per refinement and (slot, context), the bits of
// that model's symbols and its per-refinement table (for a per-slot choice
// between initialisations; the choice fits in today's flag byte).
using PerKey = std::vector<std::map<Key, double>>;
Cost AdaptiveScheme(const Replay& R, int kind, const CtxFn& ctx, const AdaptiveParams& p, PerKey* per_key = nullptr) {
  Cost c;
  if (per_key) per_key->assign(R.levels.size(), {});
  std::vector<Unit> units;
  // Histograms: per refinement and for the whole stream.
  std::map<Key, std::vector<uint64_t>> stream_h;
  std::vector<std::map<Key, std::vector<uint64_t>>> level_h(R.levels.size());
  double fixed_dummy = 0;
  for (size_t i = 0; i < R.levels.size(); ++i)
    for (const SplitRec& s : R.levels[i].s) {
      UnitsOf(R.levels[i], s, kind, R.channels, ctx, units, &fixed_dummy);
      for (const Unit& u : units) {
        for (auto* m : {&stream_h, &level_h[i]}) {
          auto& v = (*m)[{u.slot, u.ctx}];
          if (v.empty()) v.assign(AlphabetOf(u.slot), 0);
          ++v[SymOf(u)];
        }
      }
    }
  std::map<Key, std::vector<double>> stream_p;
  if (p.init == Init::kStreamTable) {
    for (auto& [key, hist] : stream_h) {
      const ms::StaticModel m = ms::StaticModel::FromCounts(hist);
      stream_p[key] = ModelProbabilities(m, hist.size());
      c.table_bits += 8.0 * (1 + ModelBytes(m));
    }
  }
  std::map<Key, std::vector<double>> prev_p;
  for (size_t i = 0; i < R.levels.size(); ++i) {
    const LevelRec& L = R.levels[i];
    std::map<Key, std::vector<double>> level_p;
    if (p.init == Init::kParametric) {
      for (auto& [key, hist] : level_h[i]) {
        level_p[key] = Parametric(key.first < kStructSlots, BestTheta(key.first < kStructSlots, hist, nullptr));
        c.table_bits += 8.0;
        if (per_key) (*per_key)[i][key] += 8.0;
      }
    }
    if (p.init == Init::kRefinementTable || p.init == Init::kPreviousTable) {
      for (auto& [key, hist] : level_h[i]) {
        const ms::StaticModel m = ms::StaticModel::FromCounts(hist);
        level_p[key] = ModelProbabilities(m, hist.size());
        if (p.init == Init::kRefinementTable) {
          c.table_bits += 8.0 * (1 + ModelBytes(m));
          if (per_key) (*per_key)[i][key] += 8.0 * (1 + ModelBytes(m));
        }
      }
      if (p.init == Init::kPreviousTable && i == 0) {
        // The first refinement sends its table; later ones start from the previous one's.
        for (auto& [key, hist] : level_h[i]) c.table_bits += 8.0 * (1 + ModelBytes(ms::StaticModel::FromCounts(hist)));
      }
    }
    const size_t k = L.s.size();
    const size_t S = p.whole_refinement ? 1 : std::max<size_t>(1, kind == 0 ? L.stride_struct : L.stride_geom);
    for (size_t o = 0; o < S && o < k; ++o) {
      std::map<Key, AdaptiveModel> models;
      for (size_t j = o; j < k; j += S) {
        double fixed = 0;
        UnitsOf(L, L.s[j], kind, R.channels, ctx, units, &fixed);
        c.bits += fixed;
        for (const Unit& u : units) {
          const Key key{u.slot, u.ctx};
          auto it = models.find(key);
          if (it == models.end()) {
            AdaptiveModel m;
            m.inc = p.inc;
            m.limit = p.limit;
            const std::vector<double>* init = nullptr;
            if (p.init == Init::kStreamTable) init = &stream_p[key];
            if (p.init == Init::kRefinementTable || p.init == Init::kParametric) init = &level_p[key];
            if (p.init == Init::kPreviousTable && i == 0) init = &level_p[key];
            if (p.init == Init::kPreviousTable && i > 0) {
              auto f = prev_p.find(key);
              if (f != prev_p.end()) init = &f->second;
            }
            if (init && !init->empty()) m.From(*init, p.prior);
            else m.Uniform(AlphabetOf(u.slot));
            it = models.emplace(key, std::move(m)).first;
          }
          const double b = it->second.Code(SymOf(u)) + RawOf(u);
          c.bits += b;
          if (per_key) (*per_key)[i][key] += b;
        }
      }
    }
    if (p.init == Init::kPreviousTable) {
      // Refinement i's table is what i + 1 starts from (sent in i's control block).
      std::map<Key, std::vector<double>> next;
      for (auto& [key, hist] : level_h[i]) {
        const ms::StaticModel m = ms::StaticModel::FromCounts(hist);
        next[key] = ModelProbabilities(m, hist.size());
        if (i > 0) c.table_bits += 8.0 * (1 + ModelBytes(m));
      }
      prev_p = std::move(next);
    }
  }
  return c;
}

// ---------------------------------------------------------------------------
// Contexts

int MagBucket(int64_t v, int n) { return std::min(n - 1, BitLength(static_cast<uint64_t>(std::llabs(v)))); }
int ValenceClass(int d) { return std::clamp(d, 5, 8) - 5; }
int ScaleClass(const LevelRec& L, const SplitRec& s, int n) {
  const double r = s.scale / L.median_scale;
  if (n == 3) return r < 0.75 ? 0 : r > 4.0 / 3 ? 2 : 1;
  // 5 classes: < 0.6, < 0.85, < 1.2, < 1.6, above
  return r < 0.6 ? 0 : r < 0.85 ? 1 : r < 1.2 ? 2 : r < 1.6 ? 3 : 4;
}
int AnisoClass(const LevelRec& L, const SplitRec& s) {
  const double r = s.aniso / L.median_aniso;
  return r < 0.6 ? 0 : r < 0.85 ? 1 : r < 1.2 ? 2 : r < 1.6 ? 3 : 4;
}
// Within the same split: c1 by |c0|'s class, c2 by (|c0| + |c1|)'s.
int SameSplit(const SplitRec& s, int slot, int n) {
  if (slot == 3) return MagBucket(s.coded[0], n);
  if (slot == 4) return MagBucket(std::llabs(s.coded[0]) + std::llabs(s.coded[1]), n);
  return 0;
}
// The key gap between the best and second-best pair, relative to the best key.
int GapClass(const SplitRec& s) {
  if (s.key0 == INT64_MIN || s.key1 == INT64_MIN) return 0;
  const double g = double(s.key0) - double(s.key1);
  const double rel = g / (std::fabs(double(s.key0)) + 1.0);
  return rel < 1.0 / 64 ? 0 : rel < 1.0 / 16 ? 1 : rel < 1.0 / 4 ? 2 : rel < 1.0 ? 3 : 4;
}

// ---------------------------------------------------------------------------
// Item 1, 2, 5, 6 reports

double PerSplit(const Replay& R, double bits) { return bits / double(R.splits); }

nlohmann::json CostJson(const Replay& R, const Cost& c) {
  return {{"symbols", PerSplit(R, c.bits)}, {"tables", PerSplit(R, c.table_bits)}, {"total", PerSplit(R, c.total())}};
}

void ReportCoding(const Replay& R, nlohmann::json& j) {
  // Today's real bytes.
  double models = 0, headers = 0, pay_s = 0, pay_g = 0, split_blocks = 0;
  size_t n_s = 0, n_g = 0;
  for (const LevelRec& L : R.levels) {
    models += 8.0 * L.models_bytes;
    headers += 8.0 * L.dgram_header_bytes;
    pay_s += 8.0 * L.dgram_payload_struct;
    pay_g += 8.0 * L.dgram_payload_geom;
    split_blocks += 8.0 * L.split_block_bytes;
    n_s += L.n_struct;
    n_g += L.n_geom;
  }
  nlohmann::json real;
  real["control_models_flags_alpha"] = PerSplit(R, models);
  real["datagram_headers"] = PerSplit(R, headers);
  real["payload_structure"] = PerSplit(R, pay_s);
  real["payload_geometry"] = PerSplit(R, pay_g);
  real["split_bit_blocks"] = PerSplit(R, split_blocks);
  real["datagrams_structure"] = n_s;
  real["datagrams_geometry"] = n_g;
  real["refinements"] = R.levels.size();
  real["end_datagrams_bytes_est"] = PerSplit(R, 8.0 * 8 * R.levels.size());
  j["real_stream"] = real;

  {
    Cost cs, cg;
    TodayExact(R, &cs, &cg);
    j["item1_structure"]["today_exact"] = CostJson(R, cs);
    j["item1_geometry"]["today_exact"] = CostJson(R, cg);
    j["real_stream"]["coder_flush"] = PerSplit(R, pay_s + pay_g - cs.bits - cg.bits);
    j["real_stream"]["models_check_sim"] = PerSplit(R, cs.table_bits + cg.table_bits);
  }
  const CtxFn none;
  for (int kind = 0; kind < 2; ++kind) {
    const std::string name = kind == 0 ? "structure" : "geometry";
    nlohmann::json& g = j["item1_" + name];
    g["order0_per_refinement"] = CostJson(R, StaticScheme(R, kind, none, true));
    g["static_fresh_tables"] = CostJson(R, StaticScheme(R, kind, none, false));
    g["static_parametric_1byte"] = CostJson(R, StaticScheme(R, kind, none, false, true));
    nlohmann::json ad;
    struct Cfg {
      const char* name;
      AdaptiveParams p;
    };
    std::vector<Cfg> cfgs;
    for (uint32_t inc : {16u, 32u})
      for (uint32_t lim : {1u << 13, 1u << 16}) {
        AdaptiveParams p;
        p.inc = inc;
        p.limit = lim;
        cfgs.push_back({nullptr, p});
      }
    for (const Cfg& cf : cfgs) {
      for (Init init : {Init::kUniform, Init::kRefinementTable, Init::kStreamTable, Init::kPreviousTable, Init::kParametric}) {
        const std::vector<double> priors =
            init == Init::kUniform ? std::vector<double>{0} : std::vector<double>{256, 1024, 4096};
        for (double prior : priors) {
          AdaptiveParams p = cf.p;
          p.init = init;
          p.prior = prior;
          const std::string key = std::string(init == Init::kUniform           ? "b_uniform"
                                              : init == Init::kRefinementTable ? "c_refinement_table"
                                              : init == Init::kStreamTable     ? "d_stream_table"
                                              : init == Init::kParametric      ? "f_parametric_1byte"
                                                                               : "e_previous_refinement_table") +
                                  "_inc" + std::to_string(p.inc) + "_lim" + std::to_string(BitLength(p.limit) - 1) +
                                  (init == Init::kUniform ? "" : "_prior" + std::to_string(int(prior)));
          ad[key] = CostJson(R, AdaptiveScheme(R, kind, none, p));
        }
      }
    }
    {
      AdaptiveParams p;
      p.whole_refinement = true;
      ad["ref_uniform_whole_refinement_not_decodable_alone"] = CostJson(R, AdaptiveScheme(R, kind, none, p));
    }
    {
      // Per refinement and slot, the better of a 1-byte parametric start and
      // a full table start (the flag byte says which).
      AdaptiveParams p;
      p.inc = 32;
      p.limit = 1 << 16;
      p.prior = 4096;
      PerKey a, b;
      p.init = Init::kParametric;
      AdaptiveScheme(R, kind, none, p, &a);
      p.init = Init::kRefinementTable;
      AdaptiveScheme(R, kind, none, p, &b);
      double fixed = 0;
      std::vector<Unit> units;
      PerKey st(R.levels.size());  // static fresh table: symbols + raw + flag + table
      for (size_t i = 0; i < R.levels.size(); ++i) {
        const LevelRec& L = R.levels[i];
        std::map<Key, std::vector<uint64_t>> h;
        for (const SplitRec& s : L.s) {
          UnitsOf(L, s, kind, R.channels, none, units, &fixed);
          for (const Unit& u : units) {
            auto& v = h[{u.slot, u.ctx}];
            if (v.empty()) v.assign(AlphabetOf(u.slot), 0);
            ++v[SymOf(u)];
            st[i][{u.slot, u.ctx}] += RawOf(u);
          }
        }
        for (auto& [key, hist] : h) {
          const ms::StaticModel m = ms::StaticModel::FromCounts(hist);
          st[i][key] += StaticCost(m, hist) + 8.0 * (1 + ModelBytes(m));
        }
      }
      double total = fixed, total3 = fixed;
      for (size_t i = 0; i < a.size(); ++i)
        for (auto& [key, bits] : a[i]) {
          const double tb = b[i].count(key) ? b[i][key] : 1e300;
          total += std::min(bits, tb);
          total3 += std::min({bits, tb, st[i][key]});
        }
      ad["g_best_of_parametric_or_table_per_slot_inc32_lim16_prior4096"] = {
          {"symbols", PerSplit(R, total)}, {"tables", 0.0}, {"total", PerSplit(R, total)}};
      ad["h_best_of_static_table_or_adaptive_parametric_or_table_per_slot"] = {
          {"symbols", PerSplit(R, total3)}, {"tables", 0.0}, {"total", PerSplit(R, total3)}};
    }
    g["adaptive_per_datagram"] = ad;
  }
}

// Context variants for the geometry (item 2) and the structure (item 5),
// each static (fresh tables per refinement) and adaptive (per datagram,
// uniform start and from a stream table).
void ReportContexts(const Replay& R, nlohmann::json& j) {
  struct Variant {
    std::string name;
    CtxFn ctx;
  };
  auto eval = [&](int kind, const std::vector<Variant>& vs) {
    nlohmann::json out;
    for (const Variant& v : vs) {
      nlohmann::json e;
      e["order0"] = CostJson(R, StaticScheme(R, kind, v.ctx, true));
      e["static_fresh_tables"] = CostJson(R, StaticScheme(R, kind, v.ctx, false));
      e["static_parametric_1byte"] = CostJson(R, StaticScheme(R, kind, v.ctx, false, true));
      AdaptiveParams p;
      p.inc = 32;
      p.limit = 1 << 13;
      e["adaptive_uniform"] = CostJson(R, AdaptiveScheme(R, kind, v.ctx, p));
      p.init = Init::kStreamTable;
      p.prior = 1024;
      e["adaptive_stream_table"] = CostJson(R, AdaptiveScheme(R, kind, v.ctx, p));
      p.prior = 4096;
      e["adaptive_stream_table_prior4096"] = CostJson(R, AdaptiveScheme(R, kind, v.ctx, p));
      p.init = Init::kRefinementTable;
      p.prior = 1024;
      e["adaptive_refinement_table"] = CostJson(R, AdaptiveScheme(R, kind, v.ctx, p));
      p.init = Init::kParametric;
      p.limit = 1 << 16;
      for (double prior : {1024.0, 4096.0, 16384.0}) {
        p.prior = prior;
        e["adaptive_parametric_prior" + std::to_string(int(prior))] = CostJson(R, AdaptiveScheme(R, kind, v.ctx, p));
      }
      out[v.name] = e;
    }
    return out;
  };
  std::vector<Variant> geo = {
      {"none", nullptr},
      {"same_split_mag4", [](const LevelRec&, const SplitRec& s, int slot) { return SameSplit(s, slot, 4); }},
      {"same_split_mag6", [](const LevelRec&, const SplitRec& s, int slot) { return SameSplit(s, slot, 6); }},
      {"same_split_mag8", [](const LevelRec&, const SplitRec& s, int slot) { return SameSplit(s, slot, 8); }},
      {"valence4_UNSAFE", [](const LevelRec&, const SplitRec& s, int) { return ValenceClass(s.degree); }},
      {"scale3_UNSAFE", [](const LevelRec& L, const SplitRec& s, int) { return ScaleClass(L, s, 3); }},
      {"scale5_UNSAFE", [](const LevelRec& L, const SplitRec& s, int) { return ScaleClass(L, s, 5); }},
      {"aniso5_UNSAFE", [](const LevelRec& L, const SplitRec& s, int) { return AnisoClass(L, s); }},
      {"mag6_x_scale3_UNSAFE",
       [](const LevelRec& L, const SplitRec& s, int slot) { return SameSplit(s, slot, 6) * 3 + ScaleClass(L, s, 3); }},
      {"mag6_x_aniso5_UNSAFE",
       [](const LevelRec& L, const SplitRec& s, int slot) { return SameSplit(s, slot, 6) * 5 + AnisoClass(L, s); }},
  };
  j["item2_geometry_contexts"] = eval(1, geo);
  std::vector<Variant> st = {
      {"none", nullptr},
      {"valence4_UNSAFE", [](const LevelRec&, const SplitRec& s, int) { return ValenceClass(s.degree); }},
      {"keygap5_UNSAFE", [](const LevelRec&, const SplitRec& s, int) { return GapClass(s); }},
      {"valence4_x_keygap5_UNSAFE",
       [](const LevelRec&, const SplitRec& s, int) { return ValenceClass(s.degree) * 5 + GapClass(s); }},
      {"k_given_a_bucket", [](const LevelRec&, const SplitRec& s, int slot) { return slot == 1 ? std::min<int>(s.sym[0], 3) : 0; }},
  };
  j["item5_structure_contexts"] = eval(0, st);
}

// ---------------------------------------------------------------------------
// Item 3: geometry predictors, in the local frame. Residual r = round(fd -
// prediction) per component (an estimate of the exact integer path: the
// prediction is rounded in the frame instead of before it; the Laplacian
// through this path is reported beside the exact one). Order-0 entropy per
// refinement and component (the docs' baseline measure).

double Order0Signed(const std::vector<int64_t>& v) {
  std::vector<uint64_t> h(ms::kSignedSymbols, 0);
  double raw = 0;
  for (int64_t x : v) {
    const int32_t y = static_cast<int32_t>(std::clamp<int64_t>(x, INT32_MIN / 2, INT32_MAX / 2));
    ++h[ms::SignedSymbol(y)];
    raw += RawBits(y);
  }
  return Order0(h) + raw;
}

// Solves (X^T W X + ridge) b = X^T W y for small k.
std::vector<double> SolveLS(const std::vector<std::vector<double>>& X, const std::vector<double>& y,
                            const std::vector<double>& wt) {
  const size_t k = X.empty() ? 0 : X[0].size();
  std::vector<std::vector<double>> A(k, std::vector<double>(k + 1, 0.0));
  for (size_t r = 0; r < X.size(); ++r)
    for (size_t a = 0; a < k; ++a) {
      for (size_t b = 0; b < k; ++b) A[a][b] += wt[r] * X[r][a] * X[r][b];
      A[a][k] += wt[r] * X[r][a] * y[r];
    }
  for (size_t a = 0; a < k; ++a) A[a][a] += 1e-6 * (A[a][a] + 1);
  for (size_t c = 0; c < k; ++c) {
    size_t piv = c;
    for (size_t r = c + 1; r < k; ++r)
      if (std::fabs(A[r][c]) > std::fabs(A[piv][c])) piv = r;
    std::swap(A[c], A[piv]);
    if (std::fabs(A[c][c]) < 1e-300) continue;
    for (size_t r = 0; r < k; ++r) {
      if (r == c) continue;
      const double f = A[r][c] / A[c][c];
      for (size_t q = c; q <= k; ++q) A[r][q] -= f * A[c][q];
    }
  }
  std::vector<double> b(k, 0.0);
  for (size_t a = 0; a < k; ++a) b[a] = std::fabs(A[a][a]) > 1e-300 ? A[a][k] / A[a][a] : 0.0;
  return b;
}

struct PredResult {
  double bits = 0;       // order-0
  double param_bits = 0; // weights sent
};

// A linear predictor over `feats`, fitted per refinement by IRLS (about L1),
// weights quantized to 1/64 (12 bits each), tangential (t1, t2 pooled) and
// normal parts separately when `split_tn`.
PredResult FitPredictor(const Replay& R, const std::vector<int>& feats, bool split_tn, Replay* with_residuals = nullptr,
                        bool per_stream = false) {
  PredResult res;
  // The weights: per refinement, or (per_stream) one set fitted over all.
  auto fit = [&](const std::vector<const SplitRec*>& ss, const std::vector<int>& comps) {
    std::vector<std::vector<double>> X;
    std::vector<double> y;
    for (const SplitRec* s : ss)
      for (int c : comps) {
        std::vector<double> row;
        for (int f : feats) row.push_back(s->f[f][c]);
        X.push_back(row);
        y.push_back(s->fd[c]);
      }
    std::vector<double> wt(y.size(), 1.0), b;
    for (int it = 0; it < 4; ++it) {
      b = SolveLS(X, y, wt);
      for (size_t r = 0; r < y.size(); ++r) {
        double p = 0;
        for (size_t a = 0; a < b.size(); ++a) p += b[a] * X[r][a];
        wt[r] = 1.0 / (std::fabs(y[r] - p) + 1.0);
      }
    }
    for (double& x : b) x = std::round(64 * x) / 64;
    res.param_bits += 12.0 * b.size();
    return b;
  };
  std::vector<double> stream_b[2];
  if (per_stream) {
    std::vector<const SplitRec*> all;
    for (const LevelRec& L : R.levels)
      for (const SplitRec& s : L.s)
        if (!s.seam) all.push_back(&s);
    for (int group = 0; group < (split_tn ? 2 : 1); ++group)
      stream_b[group] = fit(all, !split_tn ? std::vector<int>{0, 1, 2} : group == 0 ? std::vector<int>{0, 1} : std::vector<int>{2});
  }
  for (size_t li = 0; li < R.levels.size(); ++li) {
    const LevelRec& L = R.levels[li];
    std::vector<const SplitRec*> ss;
    for (const SplitRec& s : L.s)
      if (!s.seam) ss.push_back(&s);
    if (ss.empty()) continue;
    std::vector<int64_t> out[3];
    for (int group = 0; group < (split_tn ? 2 : 1); ++group) {
      std::vector<int> comps = !split_tn ? std::vector<int>{0, 1, 2} : group == 0 ? std::vector<int>{0, 1} : std::vector<int>{2};
      const std::vector<double> b = per_stream ? stream_b[group] : fit(ss, comps);
      for (const SplitRec* s : ss) {
        for (int c : comps) {
          double p = 0;
          for (size_t a = 0; a < b.size(); ++a) p += b[a] * s->f[feats[a]][c];
          const int64_t v = std::llround(s->fd[c] - std::round(p));
          out[c].push_back(v);
          if (with_residuals)
            with_residuals->levels[li].s[size_t(s - L.s.data())].coded[c] =
                static_cast<int32_t>(std::clamp<int64_t>(v, INT32_MIN / 2, INT32_MAX / 2));
        }
      }
    }
    for (int c = 0; c < 3; ++c) res.bits += Order0Signed(out[c]);
  }
  return res;
}

void ReportPredictors(const Replay& R, nlohmann::json& j) {
  nlohmann::json g;
  // The exact v2 residuals (library): order-0 per refinement and component.
  double exact = 0, approx_lap = 0, two_alpha = 0;
  for (const LevelRec& L : R.levels) {
    std::vector<int64_t> ex[3], ap[3];
    std::vector<const SplitRec*> ss;
    for (const SplitRec& s : L.s) {
      if (s.secondary) continue;
      for (int c = 0; c < 3; ++c) ex[c].push_back(s.coded[c]);
      if (s.seam) continue;
      ss.push_back(&s);
      for (int c = 0; c < 3; ++c) ap[c].push_back(std::llround(s.fd[c] - std::round(L.alpha / 32.0 * s.f[kLap][c])));
    }
    for (int c = 0; c < 3; ++c) {
      exact += Order0Signed(ex[c]);
      approx_lap += Order0Signed(ap[c]);
    }
    // Two alphas (tangential, normal) by search, 1/32 steps.
    double bt = 1e300, bn = 1e300;
    for (int a = 0; a <= 48; ++a) {
      std::vector<int64_t> t0, t1, n;
      for (const SplitRec* s : ss) {
        t0.push_back(std::llround(s->fd[0] - std::round(a / 32.0 * s->f[kLap][0])));
        t1.push_back(std::llround(s->fd[1] - std::round(a / 32.0 * s->f[kLap][1])));
        n.push_back(std::llround(s->fd[2] - std::round(a / 32.0 * s->f[kLap][2])));
      }
      bt = std::min(bt, Order0Signed(t0) + Order0Signed(t1));
      bn = std::min(bn, Order0Signed(n));
    }
    two_alpha += bt + bn;
    // seams' raw geometry is in `exact` only; add it to the others so they compare
    for (int c = 0; c < 3; ++c) (void)c;
  }
  g["v2_exact_laplacian_alpha"] = PerSplit(R, exact);
  g["v2_estimate_path_laplacian_alpha"] = PerSplit(R, approx_lap);
  g["two_alphas_t_n"] = PerSplit(R, two_alpha);
  g["two_alphas_t_n_param_bits"] = PerSplit(R, 8.0 * R.levels.size());
  struct Set {
    std::string name;
    std::vector<int> feats;
    bool split;
    bool per_stream = false;
  };
  std::vector<Set> sets = {
      {"ls_lap_one_weight", {kLap}, false},
      {"ls_lap_t_n", {kLap}, true},
      {"ls_lap_wing_t_n", {kLap, kWing}, true},
      {"ls_lap_sides_t_n", {kLap, kSides}, true},
      {"ls_lap_ring2_t_n", {kLap, kRing2}, true},
      {"ls_lap_umbrella_t_n", {kLap, kUmbrella}, true},
      {"ls_lap_sides_strict_ring2_t_n", {kLap, kSides, kStrict, kRing2}, true},
      {"ls_all6_t_n", {kLap, kWing, kSides, kStrict, kRing2, kUmbrella}, true},
      {"ls_all6_one_set", {kLap, kWing, kSides, kStrict, kRing2, kUmbrella}, false},
      {"ls_lap_sides_strict_t_n", {kLap, kSides, kStrict}, true},
      {"stream_lap_t_n", {kLap}, true, true},
      {"stream_lap_sides_t_n", {kLap, kSides}, true, true},
      {"stream_lap_sides_strict_t_n", {kLap, kSides, kStrict}, true, true},
      {"stream_lap_ring2_t_n", {kLap, kRing2}, true, true},
      {"stream_lap_sides_strict_ring2_t_n", {kLap, kSides, kStrict, kRing2}, true, true},
      {"ls_lap_ring2s_t_n", {kLap, kRing2S}, true},
      {"stream_lap_ring2s_t_n", {kLap, kRing2S}, true, true},
      {"stream_lap_sides_ring2s_t_n", {kLap, kSides, kRing2S}, true, true},
      {"stream_lap_sides_strict_ring2s_t_n", {kLap, kSides, kStrict, kRing2S}, true, true},
      {"ls_lap_sides_strict_ring2s_t_n", {kLap, kSides, kStrict, kRing2S}, true},
      {"ls_lap_sides_ring2s_t_n", {kLap, kSides, kRing2S}, true},
      {"ls_lap_sides_ring2u_t_n", {kLap, kSides, kRing2U}, true},
      {"ls_lap_ring2u_t_n", {kLap, kRing2U}, true},
      {"stream_lap_sides_ring2u_t_n", {kLap, kSides, kRing2U}, true, true},
      {"stream_lap_ring2u_t_n", {kLap, kRing2U}, true, true},
  };
  for (const Set& s : sets) {
    const PredResult r = FitPredictor(R, s.feats, s.split, nullptr, s.per_stream);
    g[s.name] = {{"bits", PerSplit(R, r.bits)}, {"param_bits", PerSplit(R, r.param_bits)},
                 {"total", PerSplit(R, r.bits + r.param_bits)}};
  }
  j["item3_predictors"] = g;
  // Items 1 + 3 together: the geometry datagrams coded by today's writer and
  // by the parametric adaptive scheme, with the v2 Laplacian residual of the
  // estimate path and with the LS (Laplacian + 2-ring, t/n) residual.
  Replay lap = R, ls = R;
  for (size_t li = 0; li < R.levels.size(); ++li)
    for (size_t k = 0; k < R.levels[li].s.size(); ++k) {
      SplitRec& s = lap.levels[li].s[k];
      if (s.seam) continue;
      for (int c = 0; c < 3; ++c)
        s.coded[c] = static_cast<int32_t>(std::llround(s.fd[c] - std::round(R.levels[li].alpha / 32.0 * s.f[kLap][c])));
    }
  const PredResult pr = FitPredictor(R, {kLap, kRing2}, true, &ls);
  nlohmann::json comb;
  for (int which = 0; which < 2; ++which) {
    const Replay& X = which == 0 ? lap : ls;
    const double extra = which == 0 ? 0.0 : pr.param_bits - 8.0 * R.levels.size();  // weights replace alpha
    Cost cs, cg;
    TodayExact(X, &cs, &cg);
    AdaptiveParams p;
    p.inc = 32;
    p.limit = 1 << 16;
    p.prior = 4096;
    p.init = Init::kParametric;
    const Cost f = AdaptiveScheme(X, 1, nullptr, p);
    const std::string n = which == 0 ? "laplacian_estimate_path" : "ls_lap_ring2_t_n";
    comb[n]["today_writer"] = PerSplit(R, cg.total() + extra);
    comb[n]["adaptive_parametric"] = PerSplit(R, f.total() + extra);
  }
  j["item13_combined_geometry"] = comb;
}

// ---------------------------------------------------------------------------
// Item 4: split bits from reliable data only.

struct VertexInfo {
  int created = -1;     // refinement that created it (-1: base)
  int last_split = -1;  // last refinement in which it split
  uint32_t parent = UINT32_MAX;
  uint32_t base_anc = 0;
  int splits = 0;       // how many times it split
};

struct BitCtxModel {
  // Per context: the library's adaptive bit model, and a count model.
  std::vector<ms::BitModel> bm;
  std::vector<std::array<double, 2>> cnt;
  double bits_shift5 = 0, bits_count = 0;
  void Reset(size_t n, uint16_t p0) {
    bm.assign(n, ms::BitModel{});
    for (auto& b : bm) b.p0 = p0;
    cnt.assign(n, {0.4, 0.4});
  }
  void Code(size_t ctx, int bit) {
    const double p0 = bm[ctx].p0 / double(ms::kProbabilityOne);
    bits_shift5 -= std::log2(bit ? 1 - p0 : p0);
    bm[ctx].Update(bit);
    auto& c = cnt[ctx];
    bits_count -= std::log2(c[bit] / (c[0] + c[1]));
    c[bit] += 1;
    if (c[0] + c[1] > 1024) {
      c[0] /= 2;
      c[1] /= 2;
    }
  }
};

struct BitFeatures {
  int today = 0;        // 2 age + related (0..5)
  int age = 0;          // refinements since creation (0 = created by i-1), capped
  int since = 0;        // refinements since it last split or was created, capped
  int parent_now = 0;   // parent's bit in this refinement (age 0 only meaningful)
  int gp_now = 0;       // grandparent's bit now
  int own_prev = 0;     // own bit in i-1
  int split_rel_now = 0;   // reliable neighbours with smaller id that split now (count, capped)
  int rel_deg = 0;         // reliable neighbours (capped)
  int rel_prev = 0;        // reliable neighbours that split in i-1
  int base_val = 0;        // base ancestor's base valence class
  int nsplits = 0;         // times it split (capped)
  int child_prev = 0;      // its newest child's bit in i-1 (if the child existed then)
  int share = 0;           // bucket of the refinement's split share (header)
};

void ReportSplitBits(const Replay& R, nlohmann::json& j) {
  const ms::ProgressiveMesh& pm = *R.pm;
  const uint32_t V0 = static_cast<uint32_t>(pm.base.vertex_count());
  std::vector<std::vector<uint32_t>> rel(V0);
  for (size_t f = 0; f + 2 < pm.base.indices.size(); f += 3)
    for (int c = 0; c < 3; ++c) {
      const uint32_t x = pm.base.indices[f + c], y = pm.base.indices[f + (c + 1) % 3];
      rel[x].push_back(y);
      rel[y].push_back(x);
    }
  std::vector<int> base_val(V0);
  for (uint32_t v = 0; v < V0; ++v) {
    auto& l = rel[v];
    std::sort(l.begin(), l.end());
    l.erase(std::unique(l.begin(), l.end()), l.end());
    base_val[v] = static_cast<int>(l.size());
  }
  std::vector<VertexInfo> info(V0);
  for (uint32_t v = 0; v < V0; ++v) info[v].base_anc = v;
  std::vector<uint32_t> newest_child(V0, UINT32_MAX);
  std::vector<uint8_t> prev_bits;
  // The context sets: name -> function of the features, with its count.
  struct CtxSet {
    std::string name;
    int n;
    std::function<int(const BitFeatures&)> f;
  };
  std::vector<CtxSet> sets = {
      {"today_2age_related", 6, [](const BitFeatures& b) { return b.today; }},
      {"today_plus_inference", 7, [](const BitFeatures& b) { return b.split_rel_now ? 6 : b.today; }},
      {"age5_related", 10, [](const BitFeatures& b) { return std::min(b.age, 4) * 2 + (b.age == 0 ? b.parent_now : b.own_prev); }},
      {"since5_related", 10, [](const BitFeatures& b) { return std::min(b.since, 4) * 2 + (b.age == 0 ? b.parent_now : b.own_prev); }},
      {"today_x_since4", 24, [](const BitFeatures& b) { return b.today * 4 + std::min(b.since, 3); }},
      {"today_x_gp", 12, [](const BitFeatures& b) { return b.today * 2 + b.gp_now; }},
      {"today_x_reldeg4", 24, [](const BitFeatures& b) { return b.today * 4 + std::min(b.rel_deg, 3); }},
      {"today_x_relprev3", 18, [](const BitFeatures& b) { return b.today * 3 + std::min(b.rel_prev, 2); }},
      {"today_x_baseval3", 18, [](const BitFeatures& b) { return b.today * 3 + b.base_val; }},
      {"today_x_nsplits4", 24, [](const BitFeatures& b) { return b.today * 4 + std::min(b.nsplits, 3); }},
      {"today_x_childprev", 12, [](const BitFeatures& b) { return b.today * 2 + b.child_prev; }},
      {"today_x_share3", 18, [](const BitFeatures& b) { return b.today * 3 + b.share; }},
      {"inf_since4_rel_gp_reldeg3", 0, nullptr},  // filled below
  };
  sets.back().n = 2 * 4 * 2 * 2 * 3 + 1;
  sets.back().f = [](const BitFeatures& b) {
    if (b.split_rel_now) return 2 * 4 * 2 * 2 * 3;
    const int young = b.age == 0 ? 1 : 0;
    const int rel = b.age == 0 ? b.parent_now : b.own_prev;
    return (((young * 4 + std::min(b.since, 3)) * 2 + rel) * 2 + b.gp_now) * 3 + std::min(b.rel_deg, 2);
  };
  sets.push_back({"inf_since4_rel_gp_childprev_nsplits3", 2 * 4 * 2 * 2 * 2 * 3 + 1, [](const BitFeatures& b) {
                    if (b.split_rel_now) return 2 * 4 * 2 * 2 * 2 * 3;
                    const int young = b.age == 0 ? 1 : 0;
                    const int rel = b.age == 0 ? b.parent_now : b.own_prev;
                    return ((((young * 4 + std::min(b.since, 3)) * 2 + rel) * 2 + b.gp_now) * 2 + b.child_prev) * 3 +
                           std::min(b.nsplits, 2);
                  }});
  sets.push_back({"inf_since5_rel_reldeg4_nsplits3", 5 * 2 * 4 * 3 + 1, [](const BitFeatures& b) {
                    if (b.split_rel_now) return 5 * 2 * 4 * 3;
                    const int rel = b.age == 0 ? b.parent_now : b.own_prev;
                    return ((std::min(b.since, 4) * 2 + rel) * 4 + std::min(b.rel_deg, 3)) * 3 + std::min(b.nsplits, 2);
                  }});
  sets.push_back({"inf_young_since5_rel_gp_reldeg4_nsplits3", 2 * 5 * 2 * 2 * 4 * 3 + 1, [](const BitFeatures& b) {
                    if (b.split_rel_now) return 2 * 5 * 2 * 2 * 4 * 3;
                    const int young = b.age == 0 ? 1 : 0;
                    const int rel = b.age == 0 ? b.parent_now : b.own_prev;
                    return ((((young * 5 + std::min(b.since, 4)) * 2 + rel) * 2 + b.gp_now) * 4 + std::min(b.rel_deg, 3)) * 3 +
                           std::min(b.nsplits, 2);
                  }});
  sets.push_back({"inf_since5_rel_reldeg4", 5 * 2 * 4 + 1, [](const BitFeatures& b) {
                    if (b.split_rel_now) return 5 * 2 * 4;
                    const int rel = b.age == 0 ? b.parent_now : b.own_prev;
                    return (std::min(b.since, 4) * 2 + rel) * 4 + std::min(b.rel_deg, 3);
                  }});
  // Per set: reset per refinement (p0 = 1/2, as today), reset with p0 from the
  // header's split share, one model set for the whole stream.
  const int kModes = 3;
  std::vector<std::array<BitCtxModel, kModes>> models(sets.size());
  std::vector<std::map<int, std::array<uint64_t, 2>>> order0(sets.size());
  for (size_t si = 0; si < sets.size(); ++si) models[si][2].Reset(sets[si].n, ms::kProbabilityOne / 2);
  uint64_t inferable = 0, total_bits = 0;
  for (size_t i = 0; i < pm.refinements.size(); ++i) {
    const ms::Refinement& r = pm.refinements[i];
    const uint32_t nb = r.vertices_before;
    std::vector<uint8_t> bits(nb, 0);
    for (uint32_t v : r.split_vertices) bits[v] = 1;
    const double share = double(r.split_count()) / double(nb);
    const uint16_t p0 = static_cast<uint16_t>(std::clamp(std::lround((1 - share) * ms::kProbabilityOne), 31L, long(ms::kProbabilityOne) - 31));
    for (size_t si = 0; si < sets.size(); ++si) {
      models[si][0].Reset(sets[si].n, ms::kProbabilityOne / 2);
      models[si][1].Reset(sets[si].n, p0);
      order0[si].clear();
    }
    const int ii = static_cast<int>(i);
    for (uint32_t v = 0; v < nb; ++v) {
      const VertexInfo& vi = info[v];
      BitFeatures b;
      b.age = ii - 1 - vi.created;  // created by i-1: 0
      const int event = std::max(vi.created, vi.last_split);
      b.since = ii - 1 - event;
      const int age_fmt = b.age == 0 ? 0 : b.age == 1 ? 1 : 2;
      b.own_prev = v < prev_bits.size() ? prev_bits[v] : 0;
      if (vi.parent != UINT32_MAX) {
        b.parent_now = bits[vi.parent];
        const uint32_t gp = info[vi.parent].parent;
        b.gp_now = gp != UINT32_MAX ? bits[gp] : 0;
      }
      b.today = age_fmt * 2 + (b.age == 0 ? b.parent_now : b.own_prev);
      for (uint32_t u : rel[v]) {
        if (u < v && bits[u]) ++b.split_rel_now;
        if (u < prev_bits.size() && prev_bits[u]) ++b.rel_prev;
      }
      b.rel_deg = static_cast<int>(rel[v].size());
      const int bv = base_val[vi.base_anc];
      b.base_val = bv <= 5 ? 0 : bv == 6 ? 1 : 2;
      b.nsplits = vi.splits;
      const uint32_t c = v < newest_child.size() ? newest_child[v] : UINT32_MAX;
      b.child_prev = (c != UINT32_MAX && c < prev_bits.size()) ? prev_bits[c] : 0;
      b.share = share < 0.12 ? 0 : share < 0.16 ? 1 : 2;
      if (b.split_rel_now) {
        ++inferable;
        if (bits[v]) ms::bench::Die("inference contradicts the strict rule");
      }
      ++total_bits;
      for (size_t si = 0; si < sets.size(); ++si) {
        const int ctx = sets[si].f(b);
        for (int md = 0; md < kModes; ++md) models[si][md].Code(ctx, bits[v]);
        ++order0[si][ctx][bits[v]];
      }
    }
    for (size_t si = 0; si < sets.size(); ++si) {
      double h = 0;
      for (auto& [c, k] : order0[si]) {
        const double t = double(k[0] + k[1]);
        for (int q = 0; q < 2; ++q)
          if (k[q]) h -= k[q] * std::log2(k[q] / t);
      }
      models[si][0].bits_count += 0;  // (order-0 kept apart)
      sets[si].name += "";
      if (i == 0) j["item4_split_bits"][sets[si].name]["order0"] = 0.0;
      j["item4_split_bits"][sets[si].name]["order0"] = j["item4_split_bits"][sets[si].name]["order0"].get<double>() + h;
    }
    // Update the reliable state.
    for (size_t jj = 0; jj < r.split_count(); ++jj) {
      const uint32_t w = r.split_vertices[jj];
      for (uint32_t x : rel[w]) {
        auto& l = rel[x];
        l.erase(std::remove(l.begin(), l.end(), w), l.end());
      }
      const uint32_t n = nb + static_cast<uint32_t>(jj);
      rel[w] = {n};
      rel.push_back({w});
      VertexInfo ni;
      ni.created = ii;
      ni.last_split = -1;
      ni.parent = w;
      ni.base_anc = info[w].base_anc;
      info.push_back(ni);
      info[w].last_split = ii;
      ++info[w].splits;
      newest_child[w] = n;
      newest_child.push_back(UINT32_MAX);
    }
    prev_bits = bits;
  }
  for (size_t si = 0; si < sets.size(); ++si) {
    auto& e = j["item4_split_bits"][sets[si].name];
    e["order0"] = PerSplit(R, e["order0"].get<double>());
    e["contexts"] = sets[si].n;
    e["adaptive_shift5_reset_per_refinement"] = PerSplit(R, models[si][0].bits_shift5);
    e["adaptive_shift5_reset_p0_from_share"] = PerSplit(R, models[si][1].bits_shift5);
    e["adaptive_shift5_whole_stream"] = PerSplit(R, models[si][2].bits_shift5);
    e["counts_reset_per_refinement"] = PerSplit(R, models[si][0].bits_count);
    e["counts_whole_stream"] = PerSplit(R, models[si][2].bits_count);
  }
  j["item4_inferable_fraction"] = double(inferable) / double(total_bits);
}

nlohmann::json MeasureModel(const std::string& name, int qp) {
  auto scene = ms::bench::Check(ms::ImportFile(std::string(MESHSTREAM_MODELS_DIR) + "/" + name), name);
  ms::ProgressiveEncodeOptions options;
  options.quantization.qp = qp;
  ms::DracoAttributeIds ids;
  const ms::ProgressiveEncoded e = ms::bench::EncodeWithDracoBase(*ms::bench::Primitives(scene)[0], options, &ids, name);
  ms::StreamWriteOptions wo;  // version 2 (the levers are priced against it), all its tools, split packing, 1200 bytes
  wo.version = 2;
  const ms::ProgressiveStream stream = ms::bench::Check(ms::WriteStream(e, options.quantization, wo), name + ": WriteStream");
  const Replay R = Build(e, stream);
  nlohmann::json j;
  j["model"] = name;
  j["qp"] = qp;
  j["splits"] = R.splits;
  j["refinements"] = R.levels.size();
  j["channels"] = R.channels;
  j["reliable_bytes"] = stream.reliable_bytes();
  j["unreliable_bytes"] = stream.unreliable_bytes();
  ReportCoding(R, j);
  ReportContexts(R, j);
  ReportSplitBits(R, j);
  ReportPredictors(R, j);
  return j;
}

}  // namespace

int main(int argc, char** argv) {
  return ms::bench::EstimateMain(argc, argv, "meshstream_codec_levers_v3",
                                 "Estimates the candidate levers of codec version 3 (issue 24), bits per split, against\n"
                                 "today's version 2 coding on the same replayed hierarchy; prints one JSON object per model.\n",
                                 {"stanford-bunny.obj"}, "horse.ply", MeasureModel);
}
