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
  const int channels = mesh.layout.channels();
  vertices_.clear();
  indices_ranges_.clear();
  everything_ = !has_last_ || channels != channels_;
  previous_vertices_ = everything_ ? 0 : positions_.size();
  previous_indices_ = everything_ ? 0 : indices_.size();
  const size_t old_n = previous_vertices_;
  const size_t old_i = previous_indices_;
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

  // Indices: the same, one by one.
  const size_t count = mesh.indices.size();
  indices_.resize(count);
  const size_t common_i = std::min(old_i, count);
  const uint32_t* in = mesh.indices.data();
  uint32_t* kept = indices_.data();
  for (size_t i = 0; i < common_i; ++i) {
    if (in[i] == kept[i]) continue;
    kept[i] = in[i];
    Mark(indices_ranges_, static_cast<uint32_t>(i));
  }
  if (count > common_i) {
    std::memcpy(kept + common_i, in + common_i, (count - common_i) * sizeof(uint32_t));
    MarkSpan(indices_ranges_, static_cast<uint32_t>(common_i), static_cast<uint32_t>(count - common_i));
  }

  changed_vertices_ = RangeElements(vertices_);
  changed_indices_ = RangeElements(indices_ranges_);
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
