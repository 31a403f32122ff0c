// Measures the levers of codec version 2 before they are built into the
// format: replays the encoder's hierarchy exactly as the decoder sees it and
// estimates, per refinement (order-0 entropy with the format's binarization
// of signed values), what each candidate predictor of a split's geometry,
// structure and attributes would cost. Sizes only; the coder itself is
// measured by meshstream_bench.
// Usage: meshstream_codec_levers [--model NAME] [--qp N] [--out FILE.json]
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>

#include <nlohmann/json.hpp>

#include "bench/bench_util.h"
#include "experiments/estimate_main.h"
#include "codec/entropy/symbol_model.h"
#include "codec/progressive/refinement_state.h"
#include "importers/import.h"

namespace ms = meshstream;
using ms::Vec3d;
using ms::Vec3i;

namespace {

// Order-0 bits of signed values with the format's binarization (symbol +
// raw bits), one model per refinement.
struct SignedTally {
  std::map<uint32_t, uint64_t> symbols;
  double raw_bits = 0;
  uint64_t n = 0;
  void Add(int64_t v) {
    v = std::clamp<int64_t>(v, INT32_MIN / 2, INT32_MAX / 2);
    const uint32_t s = ms::SignedSymbol(static_cast<int32_t>(v));
    ++symbols[s];
    const uint32_t z = ms::ZigZag(static_cast<int32_t>(v));
    if (z >= ms::kDirectSymbols) raw_bits += (32 - __builtin_clz(z)) - 2;
    ++n;
  }
  double Bits() const {
    double h = 0;
    for (auto& [s, c] : symbols) h -= c * std::log2(double(c) / n);
    return h + raw_bits;
  }
};

struct BitTally {
  std::map<uint32_t, uint64_t> symbols;
  uint64_t n = 0;
  void Add(uint32_t s) {
    ++symbols[s];
    ++n;
  }
  double Bits() const {
    double h = 0;
    for (auto& [s, c] : symbols) h -= c * std::log2(double(c) / n);
    return h;
  }
};

Vec3d Pos(const Vec3i& p) { return ms::ToDouble(p); }

// The fan normal of w's ring (area-weighted).
Vec3d FanNormal(const Vec3d& w, const std::vector<Vec3d>& ring) {
  Vec3d n{0, 0, 0};
  for (size_t k = 0; k < ring.size(); ++k) n = ms::Add(n, ms::Cross(ms::Sub(ring[k], w), ms::Sub(ring[(k + 1) % ring.size()], w)));
  const double l = ms::Norm(n);
  return l > 0 ? ms::Scale(n, 1 / l) : Vec3d{0, 0, 1};
}

// A tangent frame (t1, t2, n).
void Frame(const Vec3d& n, Vec3d* t1, Vec3d* t2) {
  const Vec3d ref = std::fabs(n[0]) < 0.6 ? Vec3d{1, 0, 0} : Vec3d{0, 1, 0};
  *t1 = ms::Cross(ref, n);
  *t1 = ms::Scale(*t1, 1 / ms::Norm(*t1));
  *t2 = ms::Cross(n, *t1);
}

struct Level {
  // geometry: per predictor, per-split residual vectors are kept for alpha search
  std::vector<Vec3d> d, side_diff, side_diff_strict, lap, normal, lap_guess;
  std::vector<double> scale;  // mean distance of the ring from w
  BitTally wing_a, wing_k, rank_given_k, rank_pair, rank_geom, rank_l2[5];
  BitTally rank_by_valence[4];  // the rank of weight 16, one model per valence class (<= 5, 6, 7, >= 8)
  SignedTally nrm_raw[2], nrm_pred[2], nrm_b[2], nrm_c[2];
  // Texture coordinate and colour channels (all channels after the normals):
  // per split and channel the true difference e and each candidate's
  // (unscaled) prediction, for a per-level scale search.
  std::vector<double> att_e, att_lap, att_map, att_map3, att_axis;
};

// Order-0 bits of the attribute residuals e - round(alpha p), one model per channel.
double AttributeBits(const std::vector<double>& e, const std::vector<double>& p, double alpha, int channels) {
  double bits = 0;
  for (int c = 0; c < channels; ++c) {
    SignedTally t;
    for (size_t k = c; k < e.size(); k += channels) t.Add(std::llround(e[k] - std::round(alpha * p[k])));
    bits += t.Bits();
  }
  return bits;
}

double GeometryBits(const std::vector<Vec3d>& d, const std::vector<Vec3d>& pred, double alpha, int frame,
                    const std::vector<Vec3d>& normals) {
  SignedTally t[3];
  for (size_t j = 0; j < d.size(); ++j) {
    Vec3d r;
    for (int c = 0; c < 3; ++c) r[c] = d[j][c] - std::round(alpha * pred[j][c]);
    if (frame == 0) {
      for (int c = 0; c < 3; ++c) t[c].Add(std::llround(r[c]));
    } else if (frame == 1) {  // dominant axis of the normal is the normal component (shared tangential model)
      const Vec3d& n = normals[j];
      int ax = 0;
      for (int c = 1; c < 3; ++c)
        if (std::fabs(n[c]) > std::fabs(n[ax])) ax = c;
      for (int c = 0; c < 3; ++c) (c == ax ? t[2] : t[0]).Add(std::llround(r[c]));
    } else if (frame == 3) {  // t1 along the prediction's tangential part, t2 = n x t1 (estimate)
      const Vec3d& n = normals[j];
      Vec3d p = pred[j];
      const double pn = ms::Dot(p, n);
      p = ms::Sub(p, ms::Scale(n, pn));
      const double l = ms::Norm(p);
      Vec3d t1, t2;
      if (l > 1e-9) {
        t1 = ms::Scale(p, 1 / l);
        t2 = ms::Cross(n, t1);
      } else {
        Frame(n, &t1, &t2);
      }
      t[0].Add(std::llround(ms::Dot(r, t1)));
      t[1].Add(std::llround(ms::Dot(r, t2)));
      t[2].Add(std::llround(ms::Dot(r, n)));
    } else {  // exact rotation (estimate only: not a bijection on the grid)
      Vec3d t1, t2;
      Frame(normals[j], &t1, &t2);
      t[0].Add(std::llround(ms::Dot(r, t1)));
      t[0].Add(std::llround(ms::Dot(r, t2)));
      t[2].Add(std::llround(ms::Dot(r, normals[j])));
    }
  }
  return t[0].Bits() + t[1].Bits() + t[2].Bits();
}

// As GeometryBits with the rotation (frame 2), but one pair of models
// (tangential, normal) per class of the ring's scale against the level's
// median: below 3/4 of it, above 4/3 of it, or between.
double GeometryBitsByScale(const std::vector<Vec3d>& d, const std::vector<Vec3d>& pred, double alpha,
                           const std::vector<Vec3d>& normals, const std::vector<double>& scale) {
  if (d.empty()) return 0;
  std::vector<double> sorted = scale;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double median = sorted[sorted.size() / 2];
  SignedTally t[3][2];
  for (size_t j = 0; j < d.size(); ++j) {
    const int cls = scale[j] < 0.75 * median ? 0 : scale[j] > median * 4 / 3 ? 2 : 1;
    Vec3d r;
    for (int c = 0; c < 3; ++c) r[c] = d[j][c] - std::round(alpha * pred[j][c]);
    Vec3d t1, t2;
    Frame(normals[j], &t1, &t2);
    t[cls][0].Add(std::llround(ms::Dot(r, t1)));
    t[cls][0].Add(std::llround(ms::Dot(r, t2)));
    t[cls][1].Add(std::llround(ms::Dot(r, normals[j])));
  }
  double bits = 0;
  for (auto& c : t) bits += c[0].Bits() + c[1].Bits();
  return bits;
}

// The rotated residual (frame 2) with the prediction's tangential and
// normal parts scaled by alphas of their own.
double GeometryBitsTwoAlphas(const std::vector<Vec3d>& d, const std::vector<Vec3d>& pred, double alpha_t,
                             double alpha_n, const std::vector<Vec3d>& normals, int part) {
  SignedTally t[2];
  for (size_t j = 0; j < d.size(); ++j) {
    Vec3d t1, t2;
    const Vec3d& n = normals[j];
    Frame(n, &t1, &t2);
    const double r1 = ms::Dot(d[j], t1) - std::round(alpha_t * ms::Dot(pred[j], t1));
    const double r2 = ms::Dot(d[j], t2) - std::round(alpha_t * ms::Dot(pred[j], t2));
    const double rn = ms::Dot(d[j], n) - std::round(alpha_n * ms::Dot(pred[j], n));
    t[0].Add(std::llround(r1));
    t[0].Add(std::llround(r2));
    t[1].Add(std::llround(rn));
  }
  return t[part].Bits();
}

// The split bits of every refinement, as coded today (context: the vertex's
// age and its parent's or its own previous bit) and with the bits the strict
// rule infers left out (a vertex next to an earlier split vertex over
// reliable adjacency never splits): order-0 bits and symbols coded.
class SplitBitModel {
 public:
  // Reliable adjacency that only reliable data define: the base's edges.
  explicit SplitBitModel(const ms::ProgressiveMesh& pm) : rel_(pm.base.vertex_count()) {
    for (size_t f = 0; f + 2 < pm.base.indices.size(); f += 3)
      for (int c = 0; c < 3; ++c) {
        const uint32_t x = pm.base.indices[f + c], y = pm.base.indices[f + (c + 1) % 3];
        rel_[x].push_back(y);
        rel_[y].push_back(x);
      }
    for (auto& l : rel_) {
      std::sort(l.begin(), l.end());
      l.erase(std::unique(l.begin(), l.end()), l.end());
    }
  }

  void Add(const ms::Refinement& r) {
    const uint32_t nb = r.vertices_before;
    std::vector<uint8_t> bits(nb, 0);
    for (uint32_t v : r.split_vertices) bits[v] = 1;
    // contexts as today: age (0 new in i-1, else 1) x related bit
    std::map<int, std::array<uint64_t, 2>> now, inf;
    for (uint32_t v = 0; v < nb; ++v) {
      int ctx;
      if (v >= prev_start_ && !parent_of_.empty() && v - prev_start_ < parent_of_.size()) ctx = 10 + bits[parent_of_[v - prev_start_]];
      else ctx = 20 + (v < prev_bits_.size() ? prev_bits_[v] : 0);
      ++now[ctx][bits[v]];
      bool inferred = false;
      for (uint32_t u : rel_[v]) if (u < v && bits[u]) { inferred = true; break; }
      if (inferred) {
        if (bits[v]) ms::bench::Die("inference contradicts the strict rule");
        continue;
      }
      // richer context: number of rel-neighbours (capped) not yet decided
      ++inf[ctx][bits[v]];
    }
    bits_now += Entropy(now, &coded_now);
    bits_inferred += Entropy(inf, &coded_inferred);
    // Reliable adjacency after the refinement: (w, new vertex) edges, the
    // others forgotten at a vertex once it splits.
    std::vector<uint32_t> parents;
    for (size_t j = 0; j < r.split_count(); ++j) {
      const uint32_t w = r.split_vertices[j];
      for (uint32_t x : rel_[w]) {
        auto& l = rel_[x];
        l.erase(std::remove(l.begin(), l.end(), w), l.end());
      }
      const uint32_t n = nb + static_cast<uint32_t>(j);
      rel_[w] = {n};
      rel_.push_back({w});
      parents.push_back(w);
    }
    prev_bits_ = bits;
    parent_of_ = parents;
    prev_start_ = nb;
  }

  double bits_now = 0, bits_inferred = 0;
  uint64_t coded_now = 0, coded_inferred = 0;

 private:
  static double Entropy(const std::map<int, std::array<uint64_t, 2>>& t, uint64_t* n) {
    double h = 0;
    for (auto& [c, k] : t) {
      const double total = double(k[0] + k[1]);
      *n += k[0] + k[1];
      for (int b = 0; b < 2; ++b) if (k[b]) h -= k[b] * std::log2(k[b] / total);
    }
    return h;
  }

  std::vector<std::vector<uint32_t>> rel_;
  std::vector<uint8_t> prev_bits_;
  std::vector<uint32_t> parent_of_;  // per vertex created by the previous refinement: its parent
  uint32_t prev_start_ = 0;
};

// One split as the decoder sees it before applying it: w's cyclic ring (ids
// and positions), the wings' ring positions, w's position and fan normal,
// and the position delta.
struct Split {
  const ms::Refinement* r = nullptr;
  size_t j = 0;
  uint32_t w = 0;
  const std::vector<uint32_t>* ids_ring = nullptr;
  std::vector<Vec3d> ring;
  size_t a_at = 0, b_at = 0, d = 0;
  Vec3d m, n, dd;
};

// Geometry predictors. w keeps ring[a..b], the new vertex ring[b..a].
void AddGeometry(const Split& s, Level& L) {
  const auto& ring = s.ring;
  const size_t d = s.d;
  Vec3d sw{0, 0, 0}, sn{0, 0, 0}, sws{0, 0, 0}, sns{0, 0, 0};
  size_t kw = 0, kn = 0, kws = 0, kns = 0;
  for (size_t st = 0; st < d; ++st) {
    const size_t k = (s.a_at + st) % d;
    const size_t from_b = (k + d - s.b_at) % d;  // steps from b
    const size_t path = (s.a_at + d - s.b_at) % d;  // b..a length
    const bool on_n = from_b <= path;           // ring[b..a] inclusive
    const bool on_w = from_b >= path || from_b == 0;  // ring[a..b] inclusive
    if (on_n) { sn = ms::Add(sn, ring[k]); ++kn; }
    if (on_w) { sw = ms::Add(sw, ring[k]); ++kw; }
    if (on_n && !on_w) { sns = ms::Add(sns, ring[k]); ++kns; }
    if (on_w && !on_n) { sws = ms::Add(sws, ring[k]); ++kws; }
  }
  const Vec3d mid_ab = ms::Scale(ms::Add(ring[s.a_at], ring[s.b_at]), 0.5);
  const Vec3d cw = ms::Scale(sw, 1.0 / kw), cn = ms::Scale(sn, 1.0 / kn);
  const Vec3d cws = kws ? ms::Scale(sws, 1.0 / kws) : mid_ab, cns = kns ? ms::Scale(sns, 1.0 / kns) : mid_ab;
  const double D = double(kw + 1) * double(kn + 1) - 1;
  Vec3d lap;
  for (int c = 0; c < 3; ++c) lap[c] = (sw[c] * kn - sn[c] * kw) / D;
  L.d.push_back(s.dd);
  L.side_diff.push_back(ms::Sub(cw, cn));
  L.side_diff_strict.push_back(ms::Sub(cws, cns));
  L.lap.push_back(lap);
  L.normal.push_back(s.n);
  double sc = 0;
  for (const Vec3d& x : ring) sc += ms::Norm(ms::Sub(x, s.m));
  L.scale.push_back(sc / double(d));
}

// The spread of the ring across the cut (x, y), less twice the chord's
// distance from w (the chord should pass through w).
double Spread(const Split& s, size_t x, size_t y) {
  const Vec3d c = ms::Sub(s.ring[x], s.ring[y]);
  Vec3d t = ms::Cross(s.n, c);
  const double l = ms::Norm(t);
  if (l <= 0) return 0.0;
  t = ms::Scale(t, 1 / l);
  double sp = 0;
  for (size_t k = 0; k < s.d; ++k) sp += std::fabs(ms::Dot(ms::Sub(s.ring[k], s.m), t));
  const double off = std::fabs(ms::Dot(ms::Sub(s.ring[x], s.m), t));
  return sp - 2.0 * off;
}

// Structure from ring geometry: K, then the rank of a among the d pairs
// (a, a + K) by the spread of the ring across the cut; and the Laplacian
// prediction on the cut the ring's geometry favours.
void AddSpreadRanks(const Split& s, Level& L) {
  const size_t d = s.d, K = s.r->wings[s.j][1];
  {
    const double mine = Spread(s, s.a_at, (s.a_at + K) % d);
    uint32_t rank = 0;
    for (size_t x = 0; x < d; ++x) {
      if (x == s.a_at) continue;
      const double sp = Spread(s, x, (x + K) % d);
      if (sp > mine || (sp == mine && x < s.a_at)) ++rank;
    }
    L.rank_given_k.Add(rank);
  }
  double bs = -1e300;
  size_t bx = 0, bk = 1;
  for (size_t x = 0; x < d; ++x)
    for (size_t k = 1; 2 * k <= d; ++k) {
      const double sc = Spread(s, x, (x + k) % d);
      if (sc > bs) { bs = sc; bx = x; bk = k; }
    }
  const size_t ga = bx, gb = (bx + bk) % d;
  Vec3d gsw{0, 0, 0}, gsn{0, 0, 0};
  size_t gkw = 0, gkn = 0;
  const size_t gpath = (ga + d - gb) % d;
  for (size_t st2 = 0; st2 <= gpath; ++st2) { gsn = ms::Add(gsn, s.ring[(gb + st2) % d]); ++gkn; }
  for (size_t st2 = 0; st2 <= d - gpath; ++st2) { gsw = ms::Add(gsw, s.ring[(ga + st2) % d]); ++gkw; }
  const double gD = double(gkw + 1) * double(gkn + 1) - 1;
  Vec3d gl;
  for (int c = 0; c < 3; ++c) gl[c] = (gsw[c] * gkn - gsn[c] * gkw) / gD;
  L.lap_guess.push_back(gl);
}

// The pair rank with a quadratic spread (O(1) per pair after O(d)): the
// variance of the ring across the cut minus lambda times the chord's
// squared offset from w; and the pair rank among all (x, y) with steps
// 1..d/2 by the plain spread (the orientation rule).
void AddPairRanks(const Split& s, Level& L) {
  const size_t d = s.d, K = s.r->wings[s.j][1];
  static const double kLambda[5] = {8, 16, 32, 64, 1e6};
  for (int li = 0; li < 5; ++li) {
    auto spread2 = [&](size_t x, size_t y) {
      const Vec3d c = ms::Sub(s.ring[x], s.ring[y]);
      Vec3d t = ms::Cross(s.n, c);
      const double l = ms::Norm(t);
      if (l <= 0) return -1e300;
      t = ms::Scale(t, 1 / l);
      double s2 = 0;
      for (size_t k = 0; k < d; ++k) {
        const double pr = ms::Dot(ms::Sub(s.ring[k], s.m), t);
        s2 += pr * pr;
      }
      const double off = ms::Dot(ms::Sub(s.ring[x], s.m), t);
      return s2 - kLambda[li] * off * off;
    };
    const double mine = spread2(s.a_at, s.b_at);
    uint32_t rank = 0;
    for (size_t x = 0; x < d; ++x)
      for (size_t k = 1; 2 * k <= d; ++k) {
        if (x == s.a_at && k == K) continue;
        if (spread2(x, (x + k) % d) > mine) ++rank;
      }
    L.rank_l2[li].Add(std::min<uint32_t>(rank, 40));
    if (li == 1) L.rank_by_valence[std::clamp<size_t>(d, 5, 8) - 5].Add(std::min<uint32_t>(rank, 40));
  }
  const double mine = Spread(s, s.a_at, s.b_at);
  uint32_t rank = 0;
  for (size_t x = 0; x < d; ++x)
    for (size_t k = 1; 2 * k <= d; ++k) {
      if (x == s.a_at && k == K) continue;
      const double sp = Spread(s, x, (x + k) % d) - 0.0;
      if (sp > mine) ++rank;
    }
  L.rank_pair.Add(std::min<uint32_t>(rank, 40));
}

// Geometry first (bundled): the rank of the true (a, K) by how well the cut
// separates the ring between u and v.
void AddGeometryFirstRank(const Split& s, Level& L) {
  const size_t d = s.d, K = s.r->wings[s.j][1];
  Vec3d u, v;
  for (int c = 0; c < 3; ++c) {
    u[c] = std::floor((2 * s.m[c] + (int(s.dd[c]) & 1) + s.dd[c]) / 2);
    v[c] = u[c] - s.dd[c];
  }
  const Vec3d dir = ms::Sub(v, u), mid = ms::Scale(ms::Add(u, v), 0.5);
  std::vector<double> score(d);
  for (size_t k = 0; k < d; ++k) score[k] = ms::Dot(ms::Sub(s.ring[k], mid), dir);
  auto value = [&](size_t x, size_t k) {  // n takes ring[x+K .. x]... b = x + k steps from a = x
    // new vertex takes ring[b..a]: b = (x + k) % d to a = x going forward
    const size_t bb = (x + k) % d;
    const size_t path = (x + d - bb) % d;
    double sc = score[x] + score[bb];
    for (size_t t = 1; t < path; ++t) sc += 2 * score[(bb + t) % d];
    return sc;
  };
  const double mine = value(s.a_at, K);
  uint32_t rank = 0;
  for (size_t x = 0; x < d; ++x)
    for (size_t k = 1; k < d; ++k) {
      if (x == s.a_at && k == K) continue;
      if (value(x, k) > mine) ++rank;
    }
  L.rank_geom.Add(std::min<uint32_t>(rank, 40));
}

// Structure: the current coding of the wings, and the candidates from the
// ring's geometry.
void AddStructure(const Split& s, Level& L) {
  L.wing_a.Add(s.r->wings[s.j][0]);
  L.wing_k.Add(s.r->wings[s.j][1]);
  AddSpreadRanks(s, L);
  AddPairRanks(s, L);
  AddGeometryFirstRank(s, L);
}

// The channel value of vertex `x` (attribute channel `c` after the normals).
struct Channels {
  const ms::RefinementState* st = nullptr;
  int ch = 0, att0 = 0, att_ch = 0;
  double At(uint32_t x, int c) const { return st->attributes[size_t(x) * ch + att0 + c]; }
};

// The ring's least-squares linear map from the two coordinates other than
// the normal's dominant axis to the channels (an oblique projection onto a
// coordinate plane, no rotation), applied to the split vector.
void AddAxisMap(const Split& s, const Channels& a, Level& L) {
  int drop = 0;
  for (int x = 1; x < 3; ++x)
    if (std::fabs(s.n[x]) > std::fabs(s.n[drop])) drop = x;
  const int ax0 = drop == 0 ? 1 : 0, ax1 = drop == 2 ? 1 : 2;
  double Ax[3] = {0, 0, 0};
  std::vector<std::array<double, 2>> Bx(a.att_ch, {0, 0});
  for (size_t k = 0; k < s.d; ++k) {
    const Vec3d e3 = ms::Sub(s.ring[k], s.m);
    Ax[0] += e3[ax0] * e3[ax0];
    Ax[1] += e3[ax0] * e3[ax1];
    Ax[2] += e3[ax1] * e3[ax1];
    for (int c = 0; c < a.att_ch; ++c) {
      const double du = a.At((*s.ids_ring)[k], c) - a.At(s.w, c);
      Bx[c][0] += du * e3[ax0];
      Bx[c][1] += du * e3[ax1];
    }
  }
  const double detx = Ax[0] * Ax[2] - Ax[1] * Ax[1];
  const double tx = s.dd[ax0], ty = s.dd[ax1];
  for (int c = 0; c < a.att_ch; ++c) {
    double p = 0;
    if (detx > 0) p = (Bx[c][0] * (Ax[2] * tx - Ax[1] * ty) + Bx[c][1] * (Ax[0] * ty - Ax[1] * tx)) / detx;
    L.att_axis.push_back(p);
  }
}

// M3^-1 d by Cramer's rule (zero when M3 is not positive definite).
Vec3d Solve3(const double M3[3][3], const Vec3d& d) {
  auto det3 = [](const double m3[3][3]) {
    return m3[0][0] * (m3[1][1] * m3[2][2] - m3[1][2] * m3[2][1]) -
           m3[0][1] * (m3[1][0] * m3[2][2] - m3[1][2] * m3[2][0]) +
           m3[0][2] * (m3[1][0] * m3[2][1] - m3[1][1] * m3[2][0]);
  };
  const double D3 = det3(M3);
  Vec3d sol{0, 0, 0};
  if (D3 > 0) {
    for (int x = 0; x < 3; ++x) {
      double mx[3][3];
      for (int a2 = 0; a2 < 3; ++a2)
        for (int b2 = 0; b2 < 3; ++b2) mx[a2][b2] = b2 == x ? d[a2] : M3[a2][b2];
      sol[x] = det3(mx) / D3;
    }
  }
  return sol;
}

// Texture coordinates and colours (the channels after the normals): (a) the
// Laplacian closed form of the geometry on the channel values; (b) the
// ring's least-squares linear map from the tangent plane to the channels
// applied to the split vector; (b3) the same map from 3D (ridge-regularized),
// for comparison; (c) zero; and the map from a coordinate plane (AddAxisMap).
void AddAttributes(const Split& s, const Channels& a, Level& L) {
  Vec3d t1, t2;
  Frame(s.n, &t1, &t2);
  AddAxisMap(s, a, L);
  const size_t d = s.d;
  double A[3] = {0, 0, 0};  // sum q q^T
  double M3[3][3] = {{0}};
  std::vector<std::array<double, 2>> Bq(a.att_ch, {0, 0});
  std::vector<std::array<double, 3>> B3(a.att_ch, {0, 0, 0});
  const size_t path = (s.a_at + d - s.b_at) % d;
  const double kn2 = double(path) + 1, kw2 = double(d - path) + 1;
  const double D2 = (kw2 + 1) * (kn2 + 1) - 1;
  const std::vector<uint32_t>& ids_ring = *s.ids_ring;
  for (int c = 0; c < a.att_ch; ++c) {
    const double mc = a.At(s.w, c);
    double s_n = 0, s_w = 0;
    for (size_t s2 = 0; s2 <= path; ++s2) s_n += a.At(ids_ring[(s.b_at + s2) % d], c);
    for (size_t s2 = 0; s2 <= d - path; ++s2) s_w += a.At(ids_ring[(s.a_at + s2) % d], c);
    L.att_lap.push_back((s_w * kn2 - s_n * kw2) / D2);
    for (size_t k = 0; k < d; ++k) {
      const Vec3d e3 = ms::Sub(s.ring[k], s.m);
      const double du = a.At(ids_ring[k], c) - mc;
      Bq[c][0] += du * ms::Dot(e3, t1);
      Bq[c][1] += du * ms::Dot(e3, t2);
      for (int x = 0; x < 3; ++x) B3[c][x] += du * e3[x];
    }
    L.att_e.push_back(s.r->attribute_delta[s.j * a.ch + a.att0 + c]);
  }
  double scale2 = 0;
  for (size_t k = 0; k < d; ++k) {
    const Vec3d e3 = ms::Sub(s.ring[k], s.m);
    const double x = ms::Dot(e3, t1), y = ms::Dot(e3, t2);
    A[0] += x * x;
    A[1] += x * y;
    A[2] += y * y;
    for (int a2 = 0; a2 < 3; ++a2)
      for (int b2 = 0; b2 < 3; ++b2) M3[a2][b2] += e3[a2] * e3[b2];
    scale2 += ms::Dot(e3, e3);
  }
  const double det = A[0] * A[2] - A[1] * A[1];
  const double tx = ms::Dot(s.dd, t1), ty = ms::Dot(s.dd, t2);
  // 3D: (M3 + lambda I)^-1 d with lambda a small fraction of the trace.
  const double lambda = 1e-3 * scale2;
  for (int a2 = 0; a2 < 3; ++a2) M3[a2][a2] += lambda;
  const Vec3d sol = Solve3(M3, s.dd);
  for (int c = 0; c < a.att_ch; ++c) {
    double p = 0;
    if (det > 1e-9 * A[0] * A[2] && det > 0) {
      const double sx = (A[2] * tx - A[1] * ty) / det, sy = (-A[1] * tx + A[0] * ty) / det;
      p = Bq[c][0] * sx + Bq[c][1] * sy;
    }
    L.att_map.push_back(p);
    L.att_map3.push_back(B3[c][0] * sol[0] + B3[c][1] * sol[1] + B3[c][2] * sol[2]);
  }
}

// Normals: predicted from the split's geometry (vertex normals of u and v
// over their new triangles, after the split), in octahedral codes.
void AddNormals(const ms::RefinementState& st, const ms::Refinement& r, size_t j, uint32_t w, uint32_t nv, int ch,
                int qn, Level& L) {
  auto vnormal = [&](uint32_t x) {
    Vec3d acc{0, 0, 0};
    for (uint32_t f : st.connectivity.faces_of(x)) {
      const auto& F = st.connectivity.faces()[f];
      const Vec3d p0 = Pos(st.positions[F[0]]), p1 = Pos(st.positions[F[1]]), p2 = Pos(st.positions[F[2]]);
      acc = ms::Add(acc, ms::Cross(ms::Sub(p1, p0), ms::Sub(p2, p0)));
    }
    return acc;
  };
  auto oct = [&](Vec3d v, int out[2]) {
    const double l = std::fabs(v[0]) + std::fabs(v[1]) + std::fabs(v[2]);
    if (l <= 0) v = {0, 0, 1};
    else v = ms::Scale(v, 1 / l);
    double s = v[0], t = v[1];
    if (v[2] < 0) {
      s = (1 - std::fabs(v[1])) * (v[0] >= 0 ? 1 : -1);
      t = (1 - std::fabs(v[0])) * (v[1] >= 0 ? 1 : -1);
    }
    const double M = (1 << qn) - 1;
    out[0] = int(std::lround((s + 1) * 0.5 * M));
    out[1] = int(std::lround((t + 1) * 0.5 * M));
  };
  int pu[2], pv[2];
  oct(vnormal(w), pu);
  oct(vnormal(nv), pv);
  for (int c = 0; c < 2; ++c) {
    const int32_t e = r.attribute_delta[j * ch + c];
    L.nrm_raw[c].Add(e);
    L.nrm_pred[c].Add(e - (pu[c] - pv[c]));
    const int32_t mid = st.attributes[size_t(w) * ch + c];  // after the split: u's value
    const int32_t coarse_mid = mid - ((e + ((e & 1))) / 2);  // approx m (diagnostic only)
    L.nrm_b[c].Add(e - 2 * (pu[c] - coarse_mid));
    L.nrm_c[c].Add(e - 2 * (coarse_mid - pv[c]));
  }
}

// Replays refinement i: the candidates of every split into L, each split
// applied to `st` as the decoder would.
void ReplayRefinement(const ms::Refinement& r, ms::RefinementState& st, const Channels& a, bool normals, int qn,
                      Level& L) {
  st.ReserveSplits(r.split_count());
  Split s;
  s.r = &r;
  for (size_t j = 0; j < r.split_count(); ++j) {
    s.j = j;
    s.w = r.split_vertices[j];
    std::vector<uint32_t>& ids_ring = st.scratch_ring;
    if (!st.connectivity.CyclicRing(s.w, ids_ring)) ms::bench::Die("not a fan");
    if (!ms::WingPositions(ids_ring, r.wings[j], &s.a_at, &s.b_at)) ms::bench::Die("wings");
    s.ids_ring = &ids_ring;
    s.d = ids_ring.size();
    s.ring.clear();
    for (uint32_t x : ids_ring) s.ring.push_back(Pos(st.positions[x]));
    s.m = Pos(st.positions[s.w]);
    s.n = FanNormal(s.m, s.ring);
    for (int c = 0; c < 3; ++c) s.dd[c] = r.position_delta[j][c];
    AddGeometry(s, L);
    AddStructure(s, L);
    if (a.att_ch > 0) AddAttributes(s, a, L);
    const uint32_t nv = st.ApplySplitAt(r, j, s.a_at, s.b_at);
    if (normals) AddNormals(st, r, j, s.w, nv, a.ch, qn, L);
  }
}

// The order-0 bits of geometry `d` predicted by `p` in `frame`, at the best
// alpha of 0, 1/32, ..., 40/32 (into *alpha_out when not null).
double BestAlpha(const std::vector<Vec3d>& d, const std::vector<Vec3d>& p, int frame, const std::vector<Vec3d>& nrm,
                 double* alpha_out) {
  double best = 1e300;
  for (int k = 0; k <= 40; ++k) {
    const double b = GeometryBits(d, p, k / 32.0, frame, nrm);
    if (b < best) {
      best = b;
      if (alpha_out) *alpha_out = k / 32.0;
    }
  }
  return best;
}

// Bits per split of `fn(level)` summed over the levels.
template <class Fn>
double PerSplit(std::vector<Level>& levels, uint64_t splits, Fn fn) {
  double bits = 0;
  for (auto& L : levels) bits += fn(L);
  return bits / double(splits);
}

void ReportGeometry(std::vector<Level>& levels, uint64_t splits, nlohmann::json& j) {
  auto total = [&](auto fn) { return PerSplit(levels, splits, fn); };
  j["geometry_raw"] = total([&](Level& L) { return GeometryBits(L.d, L.d, 0, 0, L.normal); });
  j["geometry_raw_frame"] = total([&](Level& L) { return GeometryBits(L.d, L.d, 0, 1, L.normal); });
  for (int frame = 0; frame < 4; ++frame) {
    const std::string suffix = frame == 0 ? "" : frame == 1 ? "_axis" : frame == 2 ? "_rotated" : "_aligned";
    j["geometry_sides" + suffix] = total([&](Level& L) { return BestAlpha(L.d, L.side_diff, frame, L.normal, nullptr); });
    j["geometry_strict_sides" + suffix] =
        total([&](Level& L) { return BestAlpha(L.d, L.side_diff_strict, frame, L.normal, nullptr); });
    j["geometry_laplacian" + suffix] = total([&](Level& L) { return BestAlpha(L.d, L.lap, frame, L.normal, nullptr); });
  }
  j["geometry_laplacian_rotated_by_scale"] = total([&](Level& L) {
    double best = 1e300;
    for (int k = 0; k <= 40; ++k) best = std::min(best, GeometryBitsByScale(L.d, L.lap, k / 32.0, L.normal, L.scale));
    return best;
  });
  j["geometry_laplacian_rotated_two_alphas"] = total([&](Level& L) {
    double bt = 1e300, bn = 1e300;
    for (int k = 0; k <= 48; ++k) {
      bt = std::min(bt, GeometryBitsTwoAlphas(L.d, L.lap, k / 32.0, 0, L.normal, 0));
      bn = std::min(bn, GeometryBitsTwoAlphas(L.d, L.lap, 0, k / 32.0, L.normal, 1));
    }
    return bt + bn;
  });
  j["geometry_on_guessed_cut_rotated"] = total([&](Level& L) { return BestAlpha(L.d, L.lap_guess, 2, L.normal, nullptr); });
  std::vector<double> alphas;
  for (auto& L : levels) {
    double a = 0;
    BestAlpha(L.d, L.lap, 1, L.normal, &a);
    alphas.push_back(a);
  }
  j["laplacian_alpha_per_level"] = alphas;
}

void ReportStructure(std::vector<Level>& levels, uint64_t splits, const SplitBitModel& bits, nlohmann::json& j) {
  auto total = [&](auto fn) { return PerSplit(levels, splits, fn); };
  j["split_bits_now"] = bits.bits_now / double(splits);
  j["split_bits_inferred"] = bits.bits_inferred / double(splits);
  j["split_bits_coded_fraction"] = double(bits.coded_inferred) / double(bits.coded_now);
  j["structure_now"] = total([&](Level& L) { return L.wing_a.Bits() + L.wing_k.Bits(); });
  j["structure_k"] = total([&](Level& L) { return L.wing_k.Bits(); });
  j["structure_k_then_rank"] = total([&](Level& L) { return L.wing_k.Bits() + L.rank_given_k.Bits(); });
  j["structure_pair_rank"] = total([&](Level& L) { return L.rank_pair.Bits(); });
  for (int li = 0; li < 5; ++li)
    j["structure_pair_rank_l2_" + std::to_string(li)] = total([&](Level& L) { return L.rank_l2[li].Bits(); });
  j["structure_rank_by_valence"] = total([&](Level& L) {
    double b = 0;
    for (const BitTally& t : L.rank_by_valence) b += t.Bits();
    return b;
  });
  j["structure_geometry_first_rank"] = total([&](Level& L) { return L.rank_geom.Bits(); });
}

void ReportNormals(std::vector<Level>& levels, uint64_t splits, nlohmann::json& j) {
  auto total = [&](auto fn) { return PerSplit(levels, splits, fn); };
  j["normals_raw"] = total([&](Level& L) { return L.nrm_raw[0].Bits() + L.nrm_raw[1].Bits(); });
  j["normals_predicted"] = total([&](Level& L) { return L.nrm_pred[0].Bits() + L.nrm_pred[1].Bits(); });
  j["normals_predicted_u_anchor"] = total([&](Level& L) { return L.nrm_b[0].Bits() + L.nrm_b[1].Bits(); });
  j["normals_predicted_v_anchor"] = total([&](Level& L) { return L.nrm_c[0].Bits() + L.nrm_c[1].Bits(); });
}

void ReportAttributes(std::vector<Level>& levels, uint64_t splits, int att_ch, nlohmann::json& j) {
  auto total = [&](auto fn) { return PerSplit(levels, splits, fn); };
  auto att_best = [&](const std::vector<double>& e, const std::vector<double>& p, double* alpha_out) {
    double best = 1e300;
    for (int k = 0; k <= 48; ++k) {
      const double b = AttributeBits(e, p, k / 32.0, att_ch);
      if (b < best) {
        best = b;
        if (alpha_out) *alpha_out = k / 32.0;
      }
    }
    return best;
  };
  j["attribute_channels"] = att_ch;
  j["attributes_raw"] = total([&](Level& L) { return AttributeBits(L.att_e, L.att_e, 0, att_ch); });
  j["attributes_laplacian_alpha1"] = total([&](Level& L) { return AttributeBits(L.att_e, L.att_lap, 1, att_ch); });
  j["attributes_laplacian_best_alpha"] = total([&](Level& L) { return att_best(L.att_e, L.att_lap, nullptr); });
  j["attributes_ring_map"] = total([&](Level& L) { return AttributeBits(L.att_e, L.att_map, 1, att_ch); });
  j["attributes_ring_map_best_alpha"] = total([&](Level& L) { return att_best(L.att_e, L.att_map, nullptr); });
  j["attributes_ring_map_axis_dropped"] = total([&](Level& L) { return AttributeBits(L.att_e, L.att_axis, 1, att_ch); });
  j["attributes_ring_map_3d"] = total([&](Level& L) { return AttributeBits(L.att_e, L.att_map3, 1, att_ch); });
  std::vector<double> alphas2;
  for (auto& L : levels) {
    double a = 0;
    att_best(L.att_e, L.att_map, &a);
    alphas2.push_back(a);
  }
  j["ring_map_alpha_per_level"] = alphas2;
}

// One model at `qp`: encoded with a Draco base, its hierarchy replayed,
// every candidate's bits per split.
nlohmann::json MeasureModel(const std::string& name, int qp) {
  auto scene = ms::bench::Check(ms::ImportFile(std::string(MESHSTREAM_MODELS_DIR) + "/" + name), name);
  ms::ProgressiveEncodeOptions options;
  options.quantization.qp = qp;
  ms::DracoAttributeIds ids;
  const ms::ProgressiveEncoded e = ms::bench::EncodeWithDracoBase(*ms::bench::Primitives(scene)[0], options, &ids, name);
  const ms::ProgressiveMesh& pm = e.mesh;
  ms::RefinementState st;
  ms::bench::Check(st.Reset(pm.base).ok() ? ms::StatusOr<int>(0) : ms::StatusOr<int>(ms::Internal("reset")), "reset");
  const bool normals = pm.base.layout.has_normals;
  Channels a;
  a.st = &st;
  a.ch = pm.base.layout.channels();
  a.att0 = normals ? 2 : 0;
  a.att_ch = a.ch - a.att0;
  std::vector<Level> levels(pm.refinements.size());
  SplitBitModel bits(pm);
  uint64_t splits = 0;
  for (size_t i = 0; i < pm.refinements.size(); ++i) {
    bits.Add(pm.refinements[i]);
    ReplayRefinement(pm.refinements[i], st, a, normals, pm.base.layout.qn, levels[i]);
    splits += pm.refinements[i].split_count();
  }
  nlohmann::json j;
  j["model"] = name;
  j["qp"] = qp;
  j["splits"] = splits;
  ReportGeometry(levels, splits, j);
  ReportStructure(levels, splits, bits, j);
  if (normals) ReportNormals(levels, splits, j);
  if (a.att_ch > 0) ReportAttributes(levels, splits, a.att_ch, j);
  return j;
}

}  // namespace

int main(int argc, char** argv) {
  return ms::bench::EstimateMain(argc, argv, "meshstream_codec_levers",
                                 "Estimates what each candidate lever of codec version 2 would cost, per split, on the\n"
                                 "replayed hierarchy of each model; prints one JSON object per model (and writes them\n"
                                 "as an array with --out).\n",
                                 ms::bench::kSharedModels, "spot.obj", MeasureModel);
}
