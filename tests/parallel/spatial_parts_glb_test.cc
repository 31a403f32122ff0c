// Spatial parts through the progressive .glb (importers/progressive_glb.h,
// codec/mesh/spatial_parts.h): the file is the same with any thread count,
// the parts decode to the mesh encoded as one part (lossless for every part
// count and thread count), and no crack opens between parts at any
// combination of their levels.
#include <algorithm>
#include <array>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "importers/import.h"
#include "importers/progressive_glb.h"
#include "parallel/fork_join_pool.h"
#include "testing/test_util.h"

namespace meshstream {
namespace {

using Point = std::array<float, 3>;
using Triangle = std::array<Point, 3>;
using Edge = std::pair<Point, Point>;

const Scene& Bunny() {
  static const Scene* scene = [] {
    auto s = ImportFile(test_util::ModelPath("stanford-bunny.obj"));
    if (!s.ok()) throw std::runtime_error(s.status().ToString());
    return new Scene(std::move(s).value());
  }();
  return *scene;
}

std::vector<uint8_t> Encode(uint64_t part_vertices, TaskRunner* runner, ProgressiveGlbReport* report = nullptr) {
  ProgressiveGlbOptions options;
  options.part_vertices = part_vertices;
  options.runner = runner;
  auto glb = EncodeProgressiveGlb(Bunny(), options, report);
  EXPECT_TRUE(glb.ok()) << glb.status().ToString();
  return glb.ok() ? glb.value() : std::vector<uint8_t>();
}

Scene Decode(const std::vector<uint8_t>& glb, int lod, TaskRunner* runner) {
  ProgressiveDecodeOptions options;
  options.lod = lod;
  options.runner = runner;
  ProgressiveDecodeReport report;
  auto scene = DecodeProgressiveGlb(glb, options, &report);
  EXPECT_TRUE(scene.ok()) << scene.status().ToString();
  return scene.ok() ? std::move(scene).value() : Scene();
}

Point At(const Primitive& p, uint32_t v) { return {p.positions[v][0], p.positions[v][1], p.positions[v][2]}; }

// Every triangle of every primitive of mesh 0, by its positions, corners
// rotated so that the smallest comes first.
std::multiset<Triangle> TrianglesOf(const Scene& scene) {
  std::multiset<Triangle> out;
  for (const Primitive& p : scene.meshes.at(0).primitives) {
    for (size_t f = 0; f < p.face_count(); ++f) {
      Triangle t = {At(p, p.indices[3 * f]), At(p, p.indices[3 * f + 1]), At(p, p.indices[3 * f + 2])};
      std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
      out.insert(t);
    }
  }
  return out;
}

// The directed edges of `p` that only one of its triangles has.
std::set<Edge> BoundaryEdges(const Primitive& p) {
  std::map<std::pair<uint32_t, uint32_t>, int> count;
  for (size_t f = 0; f < p.face_count(); ++f) {
    for (int c = 0; c < 3; ++c) {
      uint32_t a = p.indices[3 * f + c], b = p.indices[3 * f + (c + 1) % 3];
      ++count[{std::min(a, b), std::max(a, b)}];
    }
  }
  std::set<Edge> out;
  for (size_t f = 0; f < p.face_count(); ++f) {
    for (int c = 0; c < 3; ++c) {
      uint32_t a = p.indices[3 * f + c], b = p.indices[3 * f + (c + 1) % 3];
      if (count[{std::min(a, b), std::max(a, b)}] == 1) out.insert({At(p, a), At(p, b)});
    }
  }
  return out;
}

// Boundary edges of one part that are neither the mesh's own boundary nor,
// reversed, a boundary edge of another part: where a crack opens.
size_t Cracks(const std::vector<const std::set<Edge>*>& parts, const std::set<Edge>& own_boundary) {
  size_t cracks = 0;
  for (size_t p = 0; p < parts.size(); ++p) {
    for (const Edge& e : *parts[p]) {
      if (own_boundary.count(e)) continue;
      bool matched = false;
      for (size_t q = 0; q < parts.size() && !matched; ++q) {
        matched = q != p && parts[q]->count({e.second, e.first}) > 0;
      }
      cracks += !matched;
    }
  }
  return cracks;
}

TEST(SpatialPartsGlb, SameFileAndMeshForEveryPartAndThreadCount) {
  ForkJoinPool two(2), three(3);
  const std::vector<uint8_t> whole = Encode(0, nullptr);
  const std::multiset<Triangle> expected = TrianglesOf(Decode(whole, -1, nullptr));
  ASSERT_GT(expected.size(), 60000u);
  // The bunny has 35,947 vertices: 1, 2, 4 and 16 parts.
  for (const auto& [part_vertices, parts] : std::vector<std::pair<uint64_t, size_t>>{
           {0, 1}, {20000, 2}, {10000, 4}, {3000, 16}}) {
    SCOPED_TRACE(part_vertices);
    ProgressiveGlbReport report;
    const std::vector<uint8_t> one = Encode(part_vertices, nullptr, &report);
    EXPECT_EQ(report.primitives.size(), parts);
    EXPECT_TRUE(Encode(part_vertices, &two) == one);
    EXPECT_TRUE(Encode(part_vertices, &three) == one);
    const Scene decoded = Decode(one, -1, nullptr);
    ASSERT_EQ(decoded.meshes.size(), 1u);
    EXPECT_EQ(decoded.meshes[0].primitives.size(), parts);
    EXPECT_TRUE(TrianglesOf(decoded) == expected);
    for (TaskRunner* runner : {static_cast<TaskRunner*>(&two), static_cast<TaskRunner*>(&three)}) {
      const Scene again = Decode(one, -1, runner);
      ASSERT_EQ(again.meshes.at(0).primitives.size(), parts);
      for (size_t p = 0; p < parts; ++p) {
        EXPECT_EQ(again.meshes[0].primitives[p].positions, decoded.meshes[0].primitives[p].positions);
        EXPECT_EQ(again.meshes[0].primitives[p].indices, decoded.meshes[0].primitives[p].indices);
      }
    }
  }
}

TEST(SpatialPartsGlb, NoCrackAtAnyCombinationOfLevels) {
  const std::vector<uint8_t> glb = Encode(10000, nullptr);  // 4 parts
  ProgressiveDecodeReport report;
  ASSERT_TRUE(DecodeProgressiveGlb(glb, ProgressiveDecodeOptions{}, &report).ok());
  const int levels = static_cast<int>(report.levels);
  ASSERT_GT(levels, 4);
  const std::set<Edge> own_boundary = BoundaryEdges(Decode(Encode(0, nullptr), -1, nullptr).meshes[0].primitives[0]);
  // Each part at five of its levels: those of scene levels 0, N/4, N/2, 3N/4, N.
  std::vector<std::vector<std::set<Edge>>> edges(4);  // [part][which]
  std::vector<std::vector<size_t>> vertices(4);
  for (int which = 0; which < 5; ++which) {
    const Scene scene = Decode(glb, levels * which / 4, nullptr);
    ASSERT_EQ(scene.meshes.at(0).primitives.size(), 4u);
    for (size_t p = 0; p < 4; ++p) {
      edges[p].push_back(BoundaryEdges(scene.meshes[0].primitives[p]));
      vertices[p].push_back(scene.meshes[0].primitives[p].vertex_count());
    }
  }
  for (size_t p = 0; p < 4; ++p) {
    EXPECT_LT(vertices[p].front(), vertices[p].back()) << "part " << p << " refines";
  }
  // Every combination: 5^4.
  size_t combinations = 0;
  for (int c = 0; c < 625; ++c) {
    std::vector<const std::set<Edge>*> parts;
    for (int p = 0, code = c; p < 4; ++p, code /= 5) parts.push_back(&edges[p][code % 5]);
    ASSERT_EQ(Cracks(parts, own_boundary), 0u) << "combination " << c;
    ++combinations;
  }
  EXPECT_EQ(combinations, 625u);
  // The check sees a crack: one border vertex of part 0 moved.
  std::set<Edge> moved;
  bool done = false;
  for (const Edge& e : edges[0][0]) {
    Edge m = e;
    if (!done && !own_boundary.count(e)) {
      m.first[0] += 0.001f;
      done = true;
    }
    moved.insert(m);
  }
  ASSERT_TRUE(done);
  EXPECT_GT(Cracks({&moved, &edges[1][0], &edges[2][0], &edges[3][0]}, own_boundary), 0u);
}

TEST(SpatialPartsGlb, ProgressCountsPrimitivesAndAThrowCancels) {
  ForkJoinPool two(2);
  ProgressiveGlbOptions options;
  options.part_vertices = 10000;
  options.runner = &two;
  size_t calls = 0, largest_index = 0, first_left = 0;
  options.progress = [&](size_t primitive, int, size_t left) {
    if (calls++ == 0) first_left = left;
    largest_index = std::max(largest_index, primitive);
  };
  ASSERT_TRUE(EncodeProgressiveGlb(Bunny(), options, nullptr).ok());
  EXPECT_GT(calls, 4u);
  EXPECT_EQ(largest_index, 0u);  // one primitive, four parts
  EXPECT_LE(first_left, 35947u);
  options.progress = [](size_t, int, size_t) { throw std::runtime_error("stop"); };
  auto failed = EncodeProgressiveGlb(Bunny(), options, nullptr);
  ASSERT_FALSE(failed.ok());
  EXPECT_NE(failed.status().message().find("stop"), std::string::npos) << failed.status().ToString();
}

}  // namespace
}  // namespace meshstream
