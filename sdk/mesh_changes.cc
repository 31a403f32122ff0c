// Changed ranges between two reads of a mesh (sdk/mesh_changes.h).
#include "sdk/mesh_changes.h"

#include <algorithm>
#include <cstring>

namespace meshstream::sdk {

namespace {

// Appends element i to the ranges: extends the last one when adjacent.
inline void Mark(std::vector<Range>& ranges, uint32_t i) {
  if (!ranges.empty() && ranges.back().first + ranges.back().count == i) {
    ++ranges.back().count;
  } else {
    ranges.push_back({i, 1});
  }
}

inline void MarkSpan(std::vector<Range>& ranges, uint32_t first, uint32_t count) {
  if (count == 0) return;
  if (!ranges.empty() && ranges.back().first + ranges.back().count == first) {
    ranges.back().count += count;
  } else {
    ranges.push_back({first, count});
  }
}

}  // namespace

void MeshChanges::Update(const QuantizedMesh& mesh, const std::vector<uint8_t>& exact) {
  const size_t n = mesh.vertex_count();
  const size_t t = mesh.face_count();
  const int channels = mesh.layout.channels();
  vertices_.clear();
  triangles_.clear();
  everything_ = !has_last_ || channels != channels_;
  previous_vertices_ = everything_ ? 0 : positions_.size();
  previous_triangles_ = everything_ ? 0 : indices_.size() / 3;
  const size_t old_n = previous_vertices_;
  const size_t old_t = previous_triangles_;
  const size_t ch = static_cast<size_t>(channels);

  // Vertices: the common prefix compared (position, attributes, flag), the rest new.
  positions_.resize(n);
  attributes_.resize(n * ch);
  predicted_.resize(n);
  const size_t common_n = std::min(old_n, n);
  for (size_t v = 0; v < n; ++v) {
    const uint8_t predicted = (v < exact.size() && exact[v] == 0) ? 1 : 0;
    const int32_t* a = mesh.attributes.data() + v * ch;
    int32_t* kept = attributes_.data() + v * ch;
    if (v < common_n && positions_[v] == mesh.positions[v] && predicted_[v] == predicted &&
        (ch == 0 || std::memcmp(kept, a, ch * sizeof(int32_t)) == 0)) {
      continue;
    }
    positions_[v] = mesh.positions[v];
    if (ch != 0) std::memcpy(kept, a, ch * sizeof(int32_t));
    predicted_[v] = predicted;
    Mark(vertices_, static_cast<uint32_t>(v));
  }

  // Triangles: the same.
  indices_.resize(3 * t);
  const size_t common_t = std::min(old_t, t);
  const uint32_t* in = mesh.indices.data();
  uint32_t* kept = indices_.data();
  for (size_t f = 0; f < common_t; ++f) {
    const uint32_t* a = in + 3 * f;
    uint32_t* b = kept + 3 * f;
    if (a[0] == b[0] && a[1] == b[1] && a[2] == b[2]) continue;
    b[0] = a[0];
    b[1] = a[1];
    b[2] = a[2];
    Mark(triangles_, static_cast<uint32_t>(f));
  }
  if (t > common_t) {
    std::memcpy(kept + 3 * common_t, in + 3 * common_t, 3 * (t - common_t) * sizeof(uint32_t));
    MarkSpan(triangles_, static_cast<uint32_t>(common_t), static_cast<uint32_t>(t - common_t));
  }

  changed_vertices_ = RangeElements(vertices_);
  changed_triangles_ = RangeElements(triangles_);
  channels_ = channels;
  has_last_ = true;
}

void LimitRanges(std::vector<Range>& ranges, size_t max) {
  if (max == 0 || ranges.size() <= max) return;
  // The gap after each range but the last; keep the max - 1 largest gaps.
  std::vector<uint32_t> gaps(ranges.size() - 1);
  for (size_t i = 0; i + 1 < ranges.size(); ++i) {
    gaps[i] = ranges[i + 1].first - (ranges[i].first + ranges[i].count);
  }
  const size_t merges = ranges.size() - max;  // at least this many gaps close
  std::vector<uint32_t> sorted = gaps;
  std::nth_element(sorted.begin(), sorted.begin() + (merges - 1), sorted.end());
  const uint32_t threshold = sorted[merges - 1];
  // Gaps below the threshold close; of those equal to it, only as many as needed.
  size_t below = 0;
  for (uint32_t g : gaps) below += g < threshold ? 1 : 0;
  size_t equal_to_close = merges - below;
  std::vector<Range> out;
  out.reserve(max);
  out.push_back(ranges[0]);
  for (size_t i = 1; i < ranges.size(); ++i) {
    const uint32_t g = gaps[i - 1];
    bool close = g < threshold;
    if (!close && g == threshold && equal_to_close > 0) {
      close = true;
      --equal_to_close;
    }
    if (close) {
      out.back().count = ranges[i].first + ranges[i].count - out.back().first;
    } else {
      out.push_back(ranges[i]);
    }
  }
  ranges = std::move(out);
}

uint64_t RangeElements(const std::vector<Range>& ranges) {
  uint64_t sum = 0;
  for (const Range& r : ranges) sum += r.count;
  return sum;
}

}  // namespace meshstream::sdk
