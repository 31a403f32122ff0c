#include "codec/progressive/seam_twins.h"

#include <algorithm>
#include <string>

namespace meshstream {

Status SeamPartners(const std::vector<uint32_t>& split_vertices, const std::vector<uint32_t>& twin,
                    std::vector<uint32_t>* partner) {
  partner->assign(split_vertices.size(), kNoTwin);
  for (size_t j = 0; j < split_vertices.size(); ++j) {
    const uint32_t w = split_vertices[j];
    if (w >= twin.size() || twin[w] == kNoTwin) continue;
    const uint32_t t = twin[w];
    const auto it = std::lower_bound(split_vertices.begin(), split_vertices.end(), t);
    if (it == split_vertices.end() || *it != t) {
      return InvalidInput("seam vertex " + std::to_string(w) + " splits without its twin " + std::to_string(t));
    }
    (*partner)[j] = static_cast<uint32_t>(it - split_vertices.begin());
  }
  return Status::Ok();
}

Status TwinTable(const std::vector<std::array<uint32_t, 2>>& pairs, uint32_t vertex_count,
                 std::vector<uint32_t>* twin) {
  twin->assign(vertex_count, kNoTwin);
  for (const auto& p : pairs) {
    for (int k = 0; k < 2; ++k) {
      if (p[k] >= vertex_count) {
        return InvalidInput("seam twins: vertex " + std::to_string(p[k]) + " is beyond the base's " +
                            std::to_string(vertex_count));
      }
      if ((*twin)[p[k]] != kNoTwin || p[0] == p[1]) {
        return InvalidInput("seam twins: vertex " + std::to_string(p[k]) + " is in more than one pair");
      }
    }
    (*twin)[p[0]] = p[1];
    (*twin)[p[1]] = p[0];
  }
  return Status::Ok();
}

}  // namespace meshstream
