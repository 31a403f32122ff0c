#include "codec/loss/datagram_harm.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "codec/bitstream/reader.h"
#include "codec/metrics/hausdorff.h"

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

}  // namespace

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
