#include "codec/loss/datagram_harm.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <string>

#include "codec/bitstream/reader.h"
#include "codec/metrics/hausdorff.h"
#include "codec/metrics/triangle_grid.h"

namespace meshstream {
namespace {

using Face = std::array<uint32_t, 3>;

// A face with its smallest index first (orientation kept).
Face Canonical(const uint32_t* f) {
  Face out = {f[0], f[1], f[2]};
  const int at = f[1] < f[0] ? (f[2] < f[1] ? 2 : 1) : (f[2] < f[0] ? 2 : 0);
  std::rotate(out.begin(), out.begin() + at, out.end());
  return out;
}

std::vector<Face> SortedFaces(const QuantizedMesh& m) {
  std::vector<Face> faces(m.indices.size() / 3);
  for (size_t f = 0; f < faces.size(); ++f) faces[f] = Canonical(&m.indices[3 * f]);
  std::sort(faces.begin(), faces.end());
  return faces;
}

// Vertices touched by any face of `m` that has a vertex marked in `in`.
void Grow(const QuantizedMesh& m, const std::vector<uint8_t>& in, std::vector<uint8_t>* out) {
  for (size_t f = 0; f + 2 < m.indices.size(); f += 3) {
    const uint32_t* v = &m.indices[f];
    if (in[v[0]] || in[v[1]] || in[v[2]]) (*out)[v[0]] = (*out)[v[1]] = (*out)[v[2]] = 1;
  }
}

// The faces of `m` with a vertex in `region`, all vertices dequantized.
Primitive Part(const QuantizedMesh& m, const std::vector<uint8_t>& region) {
  Primitive p;
  p.positions.resize(m.positions.size());
  for (size_t v = 0; v < m.positions.size(); ++v) {
    for (int c = 0; c < 3; ++c) p.positions[v][c] = m.position_grid.Dequantize(m.positions[v][c], c);
  }
  for (size_t f = 0; f + 2 < m.indices.size(); f += 3) {
    const uint32_t* v = &m.indices[f];
    if (region[v[0]] || region[v[1]] || region[v[2]]) p.indices.insert(p.indices.end(), v, v + 3);
  }
  return p;
}

double Diagonal(const QuantizedMesh& m) {
  if (m.positions.empty()) return 0;
  Vec3i lo = m.positions[0], hi = m.positions[0];
  for (const Vec3i& p : m.positions) {
    for (int c = 0; c < 3; ++c) {
      lo[c] = std::min(lo[c], p[c]);
      hi[c] = std::max(hi[c], p[c]);
    }
  }
  double sum = 0;
  for (int c = 0; c < 3; ++c) {
    const double d = static_cast<double>(m.position_grid.Dequantize(hi[c], c)) - m.position_grid.Dequantize(lo[c], c);
    sum += d * d;
  }
  return std::sqrt(sum);
}

Status DecodeFrom(StreamReader& reader, const ProgressiveStream& stream, size_t from, size_t skip_refinement,
                  size_t skip_datagram) {
  for (size_t i = from; i < stream.control.size(); ++i) {
    MS_RETURN_IF_ERROR(reader.BeginRefinement(stream.control[i].data(), stream.control[i].size()));
    for (size_t d = 0; d < stream.datagrams[i].size(); ++d) {
      if (i == skip_refinement && d == skip_datagram) continue;
      reader.OfferDatagram(stream.datagrams[i][d].data(), stream.datagrams[i][d].size());
    }
    MS_RETURN_IF_ERROR(reader.FinishRefinement(Recovery::kPredict));
  }
  return Status::Ok();
}

// The triangles of w and n in `state` (grid units), prepared for distances.
void Fans(const RefinementState& state, uint32_t w, uint32_t n, std::vector<PreparedTriangle>* out) {
  out->clear();
  const SplitConnectivity& c = state.connectivity;
  if (w >= c.vertex_count() || n >= c.vertex_count()) return;
  auto add = [&](uint32_t f) {
    const Face& t = c.faces()[f];
    out->push_back(PrepareTriangle(ToDouble(state.positions[t[0]]), ToDouble(state.positions[t[1]]),
                                   ToDouble(state.positions[t[2]])));
  };
  for (uint32_t f : c.faces_of(w)) add(f);
  for (uint32_t f : c.faces_of(n)) {
    const Face& t = c.faces()[f];
    if (t[0] != w && t[1] != w && t[2] != w) add(f);  // (w, n, x) is w's too
  }
}

// The larger distance of w and n to the triangles `to`.
double PointsToFans(const std::vector<PreparedTriangle>& to, const Vec3d& w, const Vec3d& n) {
  if (to.empty()) return 0;
  auto distance = [&](const Vec3d& p) {
    double best = std::numeric_limits<double>::infinity();
    for (const PreparedTriangle& t : to) {
      const Vec3d d = Sub(p, ClosestPoint(t, p));
      best = std::min(best, Dot(d, d));
      if (best == 0) break;
    }
    return best;
  };
  return std::sqrt(std::max(distance(w), distance(n)));
}

// Scratch of one worker of the estimate.
struct FanScratch {
  std::vector<PreparedTriangle> coded, predicted;
  std::vector<std::pair<double, uint32_t>> order;  // (bound, split) of one datagram
};

// The local distance of split (w, n) between the coded and the predicted
// state, in grid units: the largest distance of w or n in either state to
// the other state's fans (0 when both placed them alike). Measured on the
// loss bench (docs/design/loss-protection.md, "The harm estimate"), adding the
// fans' centroids (a cut the prediction placed elsewhere) changed the
// largest distance of a refinement by at most 0.02 % of the diagonal on
// the shared models and tripled the cost.
double SplitDistance(const RefinementState& coded, const RefinementState& predicted, uint32_t w, uint32_t n,
                     FanScratch& s) {
  if (n >= predicted.positions.size() || n >= coded.positions.size()) return 0;
  if (coded.positions[w] == predicted.positions[w] && coded.positions[n] == predicted.positions[n]) return 0;
  Fans(coded, w, n, &s.coded);
  Fans(predicted, w, n, &s.predicted);
  return std::max(PointsToFans(s.predicted, ToDouble(coded.positions[w]), ToDouble(coded.positions[n])),
                  PointsToFans(s.coded, ToDouble(predicted.positions[w]), ToDouble(predicted.positions[n])));
}

// Whether two datagrams carry no split in common.
bool Disjoint(const DatagramHeader& a, const DatagramHeader& b) {
  if (a.stride == b.stride) return a.offset != b.offset;
  std::vector<uint64_t> in_a;
  for (uint64_t k = 0; k < a.count; ++k) in_a.push_back(a.offset + k * uint64_t{a.stride});
  for (uint64_t k = 0; k < b.count; ++k) {
    if (std::binary_search(in_a.begin(), in_a.end(), b.offset + k * uint64_t{b.stride})) return false;
  }
  return true;
}

}  // namespace

StatusOr<DatagramHarm> EstimateDatagramHarm(const ProgressiveStream& stream, const QuantizedMesh& base,
                                            TaskRunner* runner, const HarmOptions& options) {
  MS_ASSIGN_OR_RETURN(StreamReader reader, StreamReader::Create(stream.header.data(), stream.header.size()));
  MS_RETURN_IF_ERROR(reader.SetBase(base));
  const size_t n = std::min(stream.control.size(), stream.datagrams.size());
  const std::vector<uint32_t> level_vertices = reader.header().level_vertices();
  const bool bundled = reader.header().packing == Packing::kBundled;
  DatagramHarm out;
  out.harm.resize(n);
  // Distances in grid units first; the diagonal is the final level's.
  const int workers = runner != nullptr ? std::max(1, runner->workers()) : 1;
  std::vector<FanScratch> scratch(static_cast<size_t>(workers));
  for (size_t i = 0; i < n; ++i) {
    const auto& list = stream.datagrams[i];
    const std::string where = "refinement " + std::to_string(i);
    // Which splits each datagram carries, and of which kind.
    std::vector<DatagramHeader> headers;
    headers.reserve(list.size());
    for (size_t d = 0; d < list.size(); ++d) {
      auto p = ParsedDatagram::Parse(list[d].data(), list[d].size());
      if (!p.ok()) return p.status().WithContext(where + ", datagram " + std::to_string(d));
      headers.push_back(p->header());
    }
    // The datagrams to measure, and the lossy decodes that lose them: with
    // every_datagram, all structure datagrams in one decode and all geometry
    // ones in another (bundled: all in one); else the largest of each kind,
    // in one decode when they carry different splits (a split loses one of
    // its two units, as when one datagram is lost).
    std::vector<std::vector<uint32_t>> lossy_sets;
    if (options.every_datagram) {
      std::vector<uint32_t> structure, geometry;
      for (uint32_t d = 0; d < list.size(); ++d) {
        (headers[d].kind == DatagramKind::kGeometry ? geometry : structure).push_back(d);
      }
      for (auto* set : {&structure, &geometry}) {
        if (!set->empty()) lossy_sets.push_back(std::move(*set));
      }
    } else if (!list.empty()) {
      auto largest = [&](DatagramKind kind) {
        uint32_t best = UINT32_MAX;
        for (uint32_t d = 0; d < list.size(); ++d) {
          if (headers[d].kind != kind) continue;
          if (best == UINT32_MAX || list[d].size() > list[best].size()) best = d;
        }
        return best;
      };
      const uint32_t s = largest(bundled ? DatagramKind::kBundled : DatagramKind::kStructure);
      const uint32_t g = bundled ? UINT32_MAX : largest(DatagramKind::kGeometry);
      if (s != UINT32_MAX) lossy_sets.push_back({s});
      if (g != UINT32_MAX) {
        if (s != UINT32_MAX && Disjoint(headers[s], headers[g])) {
          lossy_sets.back().push_back(g);
        } else {
          lossy_sets.push_back({g});
        }
      }
    }
    // One decode of refinement i from the same state per set, and the
    // loss-free one, which advances `reader` itself.
    std::vector<StreamReader> lossy(lossy_sets.size(), reader);
    std::vector<Status> errors(lossy_sets.size() + 1, Status::Ok());
    auto decode = [&](size_t t, int) {
      StreamReader& r = t == 0 ? reader : lossy[t - 1];
      Status s = r.BeginRefinement(stream.control[i].data(), stream.control[i].size());
      for (uint32_t d = 0; s.ok() && d < list.size(); ++d) {
        if (t > 0 && std::find(lossy_sets[t - 1].begin(), lossy_sets[t - 1].end(), d) != lossy_sets[t - 1].end()) {
          continue;
        }
        r.OfferDatagram(list[d].data(), list[d].size());
      }
      if (s.ok()) s = r.FinishRefinement(Recovery::kPredict);
      errors[t] = s;
    };
    if (runner != nullptr && workers > 1) {
      runner->Run(errors.size(), decode);
    } else {
      for (size_t t = 0; t < errors.size(); ++t) decode(t, 0);
    }
    for (const Status& e : errors) MS_RETURN_IF_ERROR(e.WithContext(where));
    const Refinement& r = reader.current();
    const size_t splits = r.split_count();
    const uint32_t first_new = level_vertices[i];
    // One task per measured datagram: the largest distance of the splits it
    // carries, in the decode that lost it.
    std::vector<std::pair<uint32_t, uint32_t>> measured;  // (datagram, lossy decode)
    for (uint32_t t = 0; t < lossy_sets.size(); ++t) {
      for (uint32_t d : lossy_sets[t]) measured.push_back({d, t});
    }
    std::vector<double> distance(measured.size(), 0.0);
    auto measure = [&](size_t m, int worker) {
      FanScratch& s = scratch[static_cast<size_t>(worker)];
      const DatagramHeader& h = headers[measured[m].first];
      const RefinementState& predicted = lossy[measured[m].second].state();
      const RefinementState& coded = reader.state();
      // A vertex is no farther from the other fans than from its own other
      // position (which lies on them): splits in descending order of that
      // bound, until it cannot beat the largest distance found.
      s.order.clear();
      for (uint64_t j = h.offset; j < splits && (j - h.offset) / h.stride < h.count; j += h.stride) {
        const uint32_t w = r.split_vertices[j], v = first_new + static_cast<uint32_t>(j);
        if (v >= predicted.positions.size() || v >= coded.positions.size()) continue;
        const double moved = std::max(Norm(Sub(ToDouble(coded.positions[w]), ToDouble(predicted.positions[w]))),
                                      Norm(Sub(ToDouble(coded.positions[v]), ToDouble(predicted.positions[v]))));
        if (moved > 0) s.order.push_back({moved, static_cast<uint32_t>(j)});
      }
      std::sort(s.order.begin(), s.order.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
      double worst = 0;
      for (const auto& [bound, j] : s.order) {
        if (bound <= worst) break;
        worst = std::max(worst, SplitDistance(coded, predicted, r.split_vertices[j], first_new + j, s));
      }
      distance[m] = worst;
    };
    if (runner != nullptr && workers > 1 && measured.size() > 1) {
      runner->Run(measured.size(), measure);
    } else {
      for (size_t m = 0; m < measured.size(); ++m) measure(m, 0);
    }
    if (options.every_datagram) {
      out.harm[i].assign(list.size(), 0.0);
      for (size_t m = 0; m < measured.size(); ++m) out.harm[i][measured[m].first] = distance[m];
    } else if (!measured.empty()) {
      out.harm[i].assign(1, *std::max_element(distance.begin(), distance.end()));
    }
  }
  // The spread to finer refinements (header): a refinement with finer ones
  // after it counts kSpreadMargin times its own distance.
  const double margin = options.spread_margin >= 0 ? options.spread_margin : kSpreadMargin;
  for (size_t i = 0; i + 1 < n; ++i)
    for (double& h : out.harm[i]) h *= margin;
  // The final level's diagonal, in grid units (one step on every axis).
  const std::vector<Vec3i>& p = reader.state().positions;
  if (!p.empty()) {
    Vec3i lo = p[0], hi = p[0];
    for (const Vec3i& q : p) {
      for (int c = 0; c < 3; ++c) {
        lo[c] = std::min(lo[c], q[c]);
        hi[c] = std::max(hi[c], q[c]);
      }
    }
    double sum = 0;
    for (int c = 0; c < 3; ++c) sum += (double(hi[c]) - lo[c]) * (double(hi[c]) - lo[c]);
    const double diagonal = std::sqrt(sum);
    out.diagonal = diagonal * reader.header().grids.position_grid.step();
    for (auto& list : out.harm)
      for (double& h : list) h = diagonal > 0 ? h / diagonal : 0.0;
  }
  return out;
}

double DatagramHarm::RefinementMax(size_t i) const {
  if (i >= harm.size() || harm[i].empty()) return 0;
  return *std::max_element(harm[i].begin(), harm[i].end());
}

StatusOr<double> LocalHausdorff(const QuantizedMesh& a, const QuantizedMesh& b, double diagonal) {
  if (a.positions.size() != b.positions.size()) {
    return InvalidArgument("local distance: " + std::to_string(a.positions.size()) + " and " +
                           std::to_string(b.positions.size()) + " vertices");
  }
  const size_t n = a.positions.size();
  std::vector<uint8_t> changed(n, 0);
  bool any = false;
  for (size_t v = 0; v < n; ++v) {
    if (a.positions[v] != b.positions[v]) changed[v] = 1, any = true;
  }
  const std::vector<Face> fa = SortedFaces(a), fb = SortedFaces(b);
  if (fa != fb) {
    std::vector<Face> diff;
    std::set_symmetric_difference(fa.begin(), fa.end(), fb.begin(), fb.end(), std::back_inserter(diff));
    for (const Face& f : diff) {
      for (uint32_t v : f) {
        if (v < n) changed[v] = 1, any = true;
      }
    }
  }
  if (!any) return 0.0;
  // Two rings around what changed, in either mesh.
  std::vector<uint8_t> ring = changed;
  for (int step = 0; step < 2; ++step) {
    std::vector<uint8_t> grown = ring;
    Grow(a, ring, &grown);
    Grow(b, ring, &grown);
    ring.swap(grown);
  }
  const Primitive pa = Part(a, ring), pb = Part(b, ring);
  if (pa.indices.empty() || pb.indices.empty()) return diagonal > 0 ? 1.0 : 0.0;
  SurfaceDistanceOptions o;
  o.samples_per_side = 0;  // every vertex, edge midpoint and face centroid
  MS_ASSIGN_OR_RETURN(SurfaceDistance d, ComputeSurfaceDistance(pa, pb, o));
  return diagonal > 0 ? d.hausdorff / diagonal : 0.0;
}

StatusOr<DatagramHarm> MeasureDatagramHarm(const ProgressiveStream& stream, const QuantizedMesh& base,
                                           TaskRunner* runner, const HarmOptions& options) {
  MS_ASSIGN_OR_RETURN(StreamReader reader, StreamReader::Create(stream.header.data(), stream.header.size()));
  MS_RETURN_IF_ERROR(reader.SetBase(base));
  const size_t n = std::min(stream.control.size(), stream.datagrams.size());
  // The reader before each refinement, from the loss-free decode.
  std::vector<StreamReader> before;
  before.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    before.push_back(reader);
    MS_RETURN_IF_ERROR(reader.BeginRefinement(stream.control[i].data(), stream.control[i].size()));
    for (const auto& d : stream.datagrams[i]) reader.OfferDatagram(d.data(), d.size());
    MS_RETURN_IF_ERROR(reader.FinishRefinement(Recovery::kPredict));
  }
  const QuantizedMesh reference = reader.Mesh();
  DatagramHarm out;
  out.diagonal = Diagonal(reference);
  out.harm.resize(n);
  // Tasks: (refinement, datagram), finest refinement first.
  std::vector<std::pair<size_t, size_t>> tasks;
  for (size_t i = n; i-- > 0;) {
    const auto& list = stream.datagrams[i];
    if (list.empty()) continue;
    if (options.every_datagram) {
      out.harm[i].assign(list.size(), 0.0);
      for (size_t d = 0; d < list.size(); ++d) tasks.push_back({i, d});
    } else {
      out.harm[i].assign(1, 0.0);
      size_t largest = 0;
      for (size_t d = 1; d < list.size(); ++d) {
        if (list[d].size() > list[largest].size()) largest = d;
      }
      tasks.push_back({i, largest});
    }
  }
  std::vector<Status> errors(tasks.size(), Status::Ok());  // one slot per task: no lock
  std::vector<double> measured(tasks.size(), 0.0);
  auto work = [&](size_t t, int) {
    const auto [i, d] = tasks[t];
    StreamReader r = before[i];
    Status s = DecodeFrom(r, stream, i, i, d);
    StatusOr<double> h = s.ok() ? LocalHausdorff(r.Mesh(), reference, out.diagonal) : StatusOr<double>(s);
    if (!h.ok()) {
      errors[t] = h.status().WithContext("refinement " + std::to_string(i) + ", datagram " + std::to_string(d));
      return;
    }
    measured[t] = h.value();
  };
  // In batches of the runner's workers, so that the early stop is checked
  // between them (the same tasks whatever the number of workers).
  const size_t batch = runner != nullptr ? static_cast<size_t>(std::max(1, runner->workers())) : 1;
  const size_t stop_after = static_cast<size_t>(std::max(1, options.stop_after));
  size_t done = 0, above_in_a_row = 0;
  double largest = 0;
  bool stopped = false;
  while (done < tasks.size() && !stopped) {
    const size_t count = std::min(batch, tasks.size() - done);
    if (runner != nullptr && count > 1) {
      runner->Run(count, [&](size_t t, int w) { work(done + t, w); });
    } else {
      for (size_t t = 0; t < count; ++t) work(done + t, 0);
    }
    for (size_t t = done; t < done + count; ++t) {
      MS_RETURN_IF_ERROR(errors[t]);
      const auto [i, d] = tasks[t];
      out.harm[i][options.every_datagram ? d : 0] = measured[t];
      largest = std::max(largest, measured[t]);
      if (!options.every_datagram) {
        above_in_a_row = measured[t] > options.stop_above ? above_in_a_row + 1 : 0;
        if (above_in_a_row >= stop_after) stopped = true;
      }
    }
    done += count;
  }
  for (size_t t = done; t < tasks.size(); ++t) out.harm[tasks[t].first][0] = largest;
  return out;
}

}  // namespace meshstream
