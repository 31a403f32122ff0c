// Distortion metrics: the triangle grid, point-to-surface and vertex Hausdorff
// distances, the paper's Laplacian distortion (Eq. 4-5) and equality on the
// position grid. All meshes are built here, so the answers are known exactly.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "codec/metrics/grid_equality.h"
#include "codec/metrics/hausdorff.h"
#include "codec/metrics/laplacian.h"
#include "codec/mesh/mesh.h"
#include "codec/mesh/quantization.h"
#include "codec/metrics/triangle_grid.h"

namespace meshstream {
namespace {

// Axis-aligned unit cube [0,1]^3 moved by `offset`, outward-facing triangles.
Primitive Cube(const Vec3f& offset = {0, 0, 0}) {
  Primitive p;
  for (int i = 0; i < 8; ++i) {
    p.positions.push_back({static_cast<float>(i & 1) + offset[0],
                           static_cast<float>((i >> 1) & 1) + offset[1],
                           static_cast<float>((i >> 2) & 1) + offset[2]});
  }
  p.indices = {0, 2, 3, 0, 3, 1,   // z = 0
               4, 5, 7, 4, 7, 6,   // z = 1
               0, 1, 5, 0, 5, 4,   // y = 0
               2, 6, 7, 2, 7, 3,   // y = 1
               0, 4, 6, 0, 6, 2,   // x = 0
               1, 3, 7, 1, 7, 5};  // x = 1
  return p;
}

// The square [0,1]^2 in the plane z = 0 as n x n quads, two triangles each.
Primitive Plane(int n) {
  Primitive p;
  for (int y = 0; y <= n; ++y) {
    for (int x = 0; x <= n; ++x) {
      p.positions.push_back({static_cast<float>(x) / n, static_cast<float>(y) / n, 0.0f});
    }
  }
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      const uint32_t v = static_cast<uint32_t>(y * (n + 1) + x);
      const uint32_t right = v + 1, up = v + static_cast<uint32_t>(n + 1), diag = up + 1;
      p.indices.insert(p.indices.end(), {v, right, diag, v, diag, up});
    }
  }
  return p;
}

// A closed latitude-longitude sphere with a bumpy radius, 2 * slices *
// (stacks - 1) faces: a stand-in for a scanned model like the bunny.
Primitive BumpySphere(int stacks, int slices) {
  const double pi = 3.14159265358979323846;
  Primitive p;
  auto radius = [](double theta, double phi) {
    return 1.0 + 0.1 * std::sin(5 * theta) * std::cos(7 * phi);
  };
  p.positions.push_back({0, 0, 1});
  for (int s = 1; s < stacks; ++s) {
    const double theta = pi * s / stacks;
    for (int k = 0; k < slices; ++k) {
      const double phi = 2 * pi * k / slices;
      const double r = radius(theta, phi);
      p.positions.push_back({static_cast<float>(r * std::sin(theta) * std::cos(phi)),
                             static_cast<float>(r * std::sin(theta) * std::sin(phi)),
                             static_cast<float>(r * std::cos(theta))});
    }
  }
  p.positions.push_back({0, 0, -1});
  const uint32_t south = static_cast<uint32_t>(p.positions.size() - 1);
  auto ring = [slices](int s, int k) {
    return static_cast<uint32_t>(1 + (s - 1) * slices + (k % slices));
  };
  for (int k = 0; k < slices; ++k) {
    p.indices.insert(p.indices.end(), {0, ring(1, k), ring(1, k + 1)});
    p.indices.insert(p.indices.end(), {south, ring(stacks - 1, k + 1), ring(stacks - 1, k)});
  }
  for (int s = 1; s + 1 < stacks; ++s) {
    for (int k = 0; k < slices; ++k) {
      const uint32_t a = ring(s, k), b = ring(s + 1, k), c = ring(s + 1, k + 1),
                     d = ring(s, k + 1);
      p.indices.insert(p.indices.end(), {a, b, c, a, c, d});
    }
  }
  return p;
}

// Deterministic pseudo-random numbers in [0, 1) for the brute-force checks.
class Lcg {
 public:
  explicit Lcg(uint64_t seed) : state_(seed) {}
  double Next() {
    state_ = state_ * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(state_ >> 11) / 9007199254740992.0;
  }

 private:
  uint64_t state_;
};

double Distance(const Vec3d& a, const Vec3d& b) {
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                   (a[2] - b[2]) * (a[2] - b[2]));
}

// Fewer samples than the default where the answer does not depend on them,
// to keep sanitizer builds quick.
SurfaceDistanceOptions FewSamples() {
  SurfaceDistanceOptions options;
  options.samples_per_side = 20000;
  return options;
}

// ---------------------------------------------------------------- triangle grid

TEST(TriangleGridTest, ClosestPointInEveryRegion) {
  const Vec3d a = {0, 0, 0}, b = {2, 0, 0}, c = {0, 2, 0};
  auto closest = [&](const Vec3d& p) { return ClosestPointOnTriangle(p, a, b, c); };
  EXPECT_EQ(closest({-1, -1, 3}), a);                 // corner region of a
  EXPECT_EQ(closest({3, -1, -2}), b);                 // corner region of b
  EXPECT_EQ(closest({-1, 3, 1}), c);                  // corner region of c
  EXPECT_EQ(closest({1, -1, 5}), (Vec3d{1, 0, 0}));   // edge ab
  EXPECT_EQ(closest({-1, 1, 5}), (Vec3d{0, 1, 0}));   // edge ca
  EXPECT_EQ(closest({2, 2, 0}), (Vec3d{1, 1, 0}));    // edge bc
  EXPECT_EQ(closest({0.5, 0.5, 7}), (Vec3d{0.5, 0.5, 0}));  // interior
}

TEST(TriangleGridTest, DegenerateTrianglesAreSegmentsOrPoints) {
  // Collinear corners: the segment from (0,0,0) to (4,0,0).
  const Vec3d s = ClosestPointOnTriangle({3, 1, 0}, {0, 0, 0}, {1, 0, 0}, {4, 0, 0});
  EXPECT_EQ(s, (Vec3d{3, 0, 0}));
  // Two equal corners.
  const Vec3d t = ClosestPointOnTriangle({-1, 5, 0}, {0, 0, 0}, {0, 2, 0}, {0, 2, 0});
  EXPECT_EQ(t, (Vec3d{0, 2, 0}));
  // A point.
  const Vec3d u = ClosestPointOnTriangle({1, 1, 1}, {2, 2, 2}, {2, 2, 2}, {2, 2, 2});
  EXPECT_EQ(u, (Vec3d{2, 2, 2}));
}

TEST(TriangleGridTest, MatchesBruteForce) {
  Lcg rng(7);
  std::vector<TriangleGrid::Triangle> triangles;
  for (int t = 0; t < 500; ++t) {
    const Vec3d o = {rng.Next() * 10, rng.Next() * 10, rng.Next() * 3};
    auto corner = [&]() {
      return Vec3d{o[0] + rng.Next() - 0.5, o[1] + rng.Next() - 0.5, o[2] + rng.Next() - 0.5};
    };
    const Vec3d a = corner(), b = corner();
    // Every tenth triangle is degenerate.
    triangles.push_back({a, b, t % 10 == 0 ? a : corner()});
  }
  auto grid = TriangleGrid::Build(triangles);
  ASSERT_TRUE(grid.ok()) << grid.status().ToString();
  TriangleGrid::Searcher searcher(*grid);
  for (int q = 0; q < 1000; ++q) {
    // Queries inside the box and far outside it.
    const double spread = (q % 4 == 0) ? 60 : 12;
    const Vec3d p = {rng.Next() * spread - (spread - 10) / 2, rng.Next() * spread - (spread - 10) / 2,
                     rng.Next() * spread - (spread - 3) / 2};
    double best = std::numeric_limits<double>::infinity();
    for (const auto& t : triangles) {
      best = std::min(best, Distance(p, ClosestPointOnTriangle(p, t.a, t.b, t.c)));
    }
    const TriangleGrid::Hit hit = searcher.Closest(p);
    ASSERT_NE(hit.triangle, TriangleGrid::kNone);
    EXPECT_NEAR(hit.distance, best, 1e-12) << "query " << q;
    EXPECT_NEAR(Distance(p, hit.point), hit.distance, 1e-12);
  }
}

TEST(TriangleGridTest, MatchesBruteForceAroundAClosedSurface) {
  // Queries on, near and far from a bumpy sphere: the grid rings answer the
  // near ones, the tree the far ones; both must agree with brute force.
  const Primitive sphere = BumpySphere(16, 32);
  std::vector<TriangleGrid::Triangle> triangles;
  for (size_t f = 0; f < sphere.face_count(); ++f) {
    TriangleGrid::Triangle t;
    Vec3d* corners[3] = {&t.a, &t.b, &t.c};
    for (int k = 0; k < 3; ++k) {
      const Vec3f& p = sphere.positions[sphere.indices[3 * f + k]];
      *corners[k] = {p[0], p[1], p[2]};
    }
    triangles.push_back(t);
  }
  auto grid = TriangleGrid::FromPrimitive(sphere);
  ASSERT_TRUE(grid.ok()) << grid.status().ToString();
  TriangleGrid::Searcher searcher(*grid);
  Lcg rng(11);
  for (int q = 0; q < 1000; ++q) {
    const double radius = (q % 3 == 0) ? 1.0 + 0.2 * (rng.Next() - 0.5) : 5 * rng.Next();
    const double z = 2 * rng.Next() - 1, phi = 6.283185307179586 * rng.Next();
    const double s = std::sqrt(1 - z * z);
    const Vec3d p = {radius * s * std::cos(phi), radius * s * std::sin(phi), radius * z};
    double best = std::numeric_limits<double>::infinity();
    for (const auto& t : triangles) {
      best = std::min(best, Distance(p, ClosestPointOnTriangle(p, t.a, t.b, t.c)));
    }
    const TriangleGrid::Hit hit = searcher.Closest(p);
    ASSERT_LT(hit.triangle, sphere.face_count());
    EXPECT_NEAR(hit.distance, best, 1e-12) << "query " << q;
    const TriangleGrid::Triangle& t = triangles[hit.triangle];
    EXPECT_NEAR(Distance(p, ClosestPointOnTriangle(p, t.a, t.b, t.c)), hit.distance, 1e-12);
  }
}

TEST(TriangleGridTest, PointsGiveNearestNeighbours) {
  const std::vector<Vec3d> points = {{0, 0, 0}, {1, 0, 0}, {0, 5, 0}, {3, 3, 3}};
  auto grid = TriangleGrid::FromPoints(points);
  ASSERT_TRUE(grid.ok());
  TriangleGrid::Searcher searcher(*grid);
  EXPECT_EQ(searcher.Closest({0.9, 0.2, 0}).triangle, 1u);
  EXPECT_EQ(searcher.Closest({0, 4, 0}).triangle, 2u);
  EXPECT_EQ(searcher.Closest({-10, -10, -10}).triangle, 0u);
  const TriangleGrid::Hit far = searcher.Closest({3, 3, 7});
  EXPECT_EQ(far.triangle, 3u);
  EXPECT_DOUBLE_EQ(far.distance, 4.0);
}

TEST(TriangleGridTest, RejectsEmptyAndNonFiniteInput) {
  EXPECT_EQ(TriangleGrid::Build({}).status().code(), StatusCode::kInvalidInput);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(TriangleGrid::FromPoints({{0, nan, 0}}).status().code(), StatusCode::kInvalidInput);
  Primitive no_faces;
  no_faces.positions = {{0, 0, 0}};
  EXPECT_EQ(TriangleGrid::FromPrimitive(no_faces).status().code(), StatusCode::kInvalidInput);
}

// ----------------------------------------------------------- surface distance

TEST(SurfaceDistanceTest, TranslatedCube) {
  // B's face x = 1.1 is 0.1 from A's face x = 1, A's face x = 0 is 0.1 from
  // B's face x = 0.1; every other point is at most 0.1 from the other cube.
  // Eq. 3: every corner's nearest corner of the other cube is 0.1 away.
  // (0.1 and 1.1 are rounded to float, hence the tolerance.)
  auto d = ComputeSurfaceDistance(Cube(), Cube({0.1f, 0, 0}), FewSamples());
  ASSERT_TRUE(d.ok()) << d.status().ToString();
  EXPECT_NEAR(d->hausdorff, 0.1, 1e-6);
  EXPECT_NEAR(d->hausdorff_vertex, 0.1, 1e-6);
  EXPECT_NEAR(d->hausdorff_rel, 0.1 / std::sqrt(3.0), 1e-6);
  EXPECT_NEAR(d->hausdorff_vertex_rel, 0.1 / std::sqrt(3.0), 1e-6);
  EXPECT_GT(d->mean_distance, 0.0);
  EXPECT_LT(d->mean_distance, 0.1);
}

TEST(SurfaceDistanceTest, FarApartAndFarFromTheOrigin) {
  // Cubes 5 apart: A's face x = 0 is 5 from B's nearest face x = 5.
  auto far = ComputeSurfaceDistance(Cube(), Cube({5, 0, 0}), FewSamples());
  ASSERT_TRUE(far.ok()) << far.status().ToString();
  EXPECT_NEAR(far->hausdorff, 5.0, 1e-12);
  EXPECT_NEAR(far->hausdorff_vertex, 5.0, 1e-12);
  // Large coordinates, a translation exact in float.
  auto offset = ComputeSurfaceDistance(Cube({1000, -2000, 3000}),
                                       Cube({1000.125f, -2000, 3000}), FewSamples());
  ASSERT_TRUE(offset.ok()) << offset.status().ToString();
  EXPECT_NEAR(offset->hausdorff, 0.125, 1e-9);
  EXPECT_NEAR(offset->hausdorff_vertex, 0.125, 1e-9);
}

TEST(SurfaceDistanceTest, PlaneWithOneVertexBumped) {
  // A vertex in the middle of a 20x20 plane raised by h: that vertex is h
  // from the flat plane, and no point of the flat plane is farther than h
  // from the bumped one. Its nearest vertex of the flat plane is its old place.
  const float h = 0.05f;
  const Primitive flat = Plane(20);
  Primitive bumped = flat;
  bumped.positions[10 * 21 + 10][2] = h;
  auto d = ComputeSurfaceDistance(flat, bumped, FewSamples());
  ASSERT_TRUE(d.ok()) << d.status().ToString();
  EXPECT_NEAR(d->hausdorff, h, 1e-9);
  EXPECT_NEAR(d->hausdorff_vertex, h, 1e-9);
  EXPECT_NEAR(d->hausdorff_rel, h / std::sqrt(2.0), 1e-9);
  // Only the six triangles around the vertex move, so the mean is small.
  EXPECT_GT(d->mean_distance, 0.0);
  EXPECT_LT(d->mean_distance, 0.01 * h);
  // Symmetric.
  auto back = ComputeSurfaceDistance(bumped, flat, FewSamples());
  ASSERT_TRUE(back.ok());
  EXPECT_DOUBLE_EQ(back->hausdorff, d->hausdorff);
}

TEST(SurfaceDistanceTest, IdenticalMeshesGiveZero) {
  const Primitive sphere = BumpySphere(30, 60);  // 3,480 faces
  auto d = ComputeSurfaceDistance(sphere, sphere);
  ASSERT_TRUE(d.ok()) << d.status().ToString();
  EXPECT_LT(d->hausdorff_rel, 1e-9);
  EXPECT_LT(d->mean_distance, 1e-9);
  EXPECT_EQ(d->hausdorff_vertex, 0.0);

  // The same faces over reordered vertices, plus an unreferenced far vertex.
  Primitive shuffled;
  const size_t n = sphere.positions.size();
  std::vector<uint32_t> where(n);
  for (size_t v = 0; v < n; ++v) {
    where[v] = static_cast<uint32_t>((v * 7919) % n);  // 7919 is prime, n is not a multiple
  }
  shuffled.positions.resize(n);
  for (size_t v = 0; v < n; ++v) shuffled.positions[where[v]] = sphere.positions[v];
  for (uint32_t i : sphere.indices) shuffled.indices.push_back(where[i]);
  shuffled.positions.push_back({100, 100, 100});
  auto e = ComputeSurfaceDistance(sphere, shuffled, FewSamples());
  ASSERT_TRUE(e.ok()) << e.status().ToString();
  EXPECT_LT(e->hausdorff_rel, 1e-9);
  EXPECT_EQ(e->hausdorff_vertex, 0.0);
}

TEST(SurfaceDistanceTest, DegenerateFaceCountsAsItsSegment) {
  // B is A plus a zero-area face (0, 4, 4): the segment from the corner
  // (0,0,0) up to (0,0,0.5), which is 0.5 from A at its top.
  const Primitive a = Plane(2);
  Primitive b = a;
  b.positions.push_back({0, 0, 0.5f});
  b.indices.insert(b.indices.end(), {0, 9, 9});
  auto d = ComputeSurfaceDistance(a, b, FewSamples());
  ASSERT_TRUE(d.ok()) << d.status().ToString();
  EXPECT_NEAR(d->hausdorff, 0.5, 1e-12);
  EXPECT_NEAR(d->hausdorff_vertex, 0.5, 1e-12);
  // A mesh of degenerate faces only is still measurable.
  Primitive segment;
  segment.positions = {{0, 0, 0}, {1, 0, 0}};
  segment.indices = {0, 1, 1};
  auto s = ComputeSurfaceDistance(segment, segment, FewSamples());
  ASSERT_TRUE(s.ok()) << s.status().ToString();
  EXPECT_EQ(s->hausdorff, 0.0);
}

TEST(SurfaceDistanceTest, DeterministicAndStableInTheSampleCount) {
  // A fine sphere against a coarse one: the largest distance lies inside
  // faces, so it depends on the sampling, but not at the third digit.
  const Primitive fine = BumpySphere(30, 60);
  const Primitive coarse = BumpySphere(8, 16);
  SurfaceDistanceOptions options;
  options.samples_per_side = 20000;
  auto d1 = ComputeSurfaceDistance(fine, coarse, options);
  auto d2 = ComputeSurfaceDistance(fine, coarse, options);
  SurfaceDistanceOptions dense;
  dense.samples_per_side = 80000;
  auto d3 = ComputeSurfaceDistance(fine, coarse, dense);
  ASSERT_TRUE(d1.ok() && d2.ok() && d3.ok());
  EXPECT_EQ(d1->hausdorff, d2->hausdorff);
  EXPECT_EQ(d1->mean_distance, d2->mean_distance);
  EXPECT_GT(d1->hausdorff, 0.01);
  EXPECT_NEAR(d1->hausdorff, d3->hausdorff, 1e-3 * d3->hausdorff);
  EXPECT_NEAR(d1->mean_distance, d3->mean_distance, 1e-3 * d3->mean_distance);
}

TEST(SurfaceDistanceTest, RejectsEmptyAndInvalidInput) {
  Primitive empty;
  EXPECT_EQ(ComputeSurfaceDistance(empty, Cube()).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(ComputeSurfaceDistance(Cube(), empty).status().code(), StatusCode::kInvalidInput);
  Primitive bad = Cube();
  bad.indices.back() = 99;
  EXPECT_EQ(ComputeSurfaceDistance(Cube(), bad).status().code(), StatusCode::kInvalidInput);
  SurfaceDistanceOptions negative;
  negative.samples_per_side = -1;
  EXPECT_EQ(ComputeSurfaceDistance(Cube(), Cube(), negative).status().code(),
            StatusCode::kInvalidArgument);
  SurfaceDistanceOptions huge;
  huge.samples_per_side = kMaxSamplesPerSide + 1;
  EXPECT_EQ(ComputeSurfaceDistance(Cube(), Cube(), huge).status().code(),
            StatusCode::kInvalidArgument);
}

// ------------------------------------------------------ Laplacian distortion

// The unit square as two triangles: v0 (0,0,0), v1 (1,0,0), v2 (0,1,0),
// v3 (1,1,0), faces (0,1,2) and (1,3,2). Neighbours: N(0) = {1,2},
// N(1) = {0,2,3}, N(2) = {0,1,3}, N(3) = {1,2}; the diagonal 1-2 is sqrt(2).
Primitive Square() {
  Primitive p;
  p.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  p.indices = {0, 1, 2, 1, 3, 2};
  return p;
}

TEST(LaplacianTest, GeometricLaplacianOfTheSquare) {
  // GL(v0) = v0 - (v1 + v2)/2 = (-1/2, -1/2, 0); GL(v3) = (1/2, 1/2, 0).
  // GL(v1): weights 1 (v0), 1/sqrt2 (v2), 1 (v3), sum W = 2 + 1/sqrt2;
  // sum w v = (1, 1 + 1/sqrt2, 0); GL = (1 - 1/W, -(1 + 1/sqrt2)/W, 0)
  // = (c, -c, 0) with c = (1 + 1/sqrt2)/(2 + 1/sqrt2) = (sqrt2+1)/(2 sqrt2+1).
  // GL(v2) = (-c, c, 0) by symmetry.
  const double c = (std::sqrt(2.0) + 1) / (2 * std::sqrt(2.0) + 1);
  const std::vector<Vec3d> gl = GeometricLaplacian(Square());
  ASSERT_EQ(gl.size(), 4u);
  const Vec3d expected[4] = {{-0.5, -0.5, 0}, {c, -c, 0}, {-c, c, 0}, {0.5, 0.5, 0}};
  for (int v = 0; v < 4; ++v) {
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(gl[v][k], expected[v][k], 1e-15) << v << "," << k;
  }
}

TEST(LaplacianTest, SquareAgainstItsDoubleHandComputed) {
  // B = 2 A. Edge weights all halve, so GL(2v) = 2 GL(v), and
  //   sum ||v - v'||         = sum ||v||  = 0 + 1 + 1 + sqrt2 = 2 + sqrt2
  //   sum ||GL(v) - GL(v')|| = sum ||GL(v)|| = 2/sqrt2 + 2 sqrt2 c
  //                          = sqrt2 + 2 sqrt2 c
  // ||M - M'|| = (2 + 2 sqrt2 + 2 sqrt2 c) / (2 * 4) = (1 + sqrt2 + sqrt2 c) / 4
  //            = 0.82650484370467...
  Primitive doubled = Square();
  for (Vec3f& p : doubled.positions) {
    for (float& x : p) x *= 2;
  }
  auto d = LaplacianDistortion(Square(), doubled);
  ASSERT_TRUE(d.ok()) << d.status().ToString();
  const double s = std::sqrt(2.0), c = (s + 1) / (2 * s + 1);
  EXPECT_NEAR(*d, (1 + s + s * c) / 4, 1e-12);
  EXPECT_NEAR(*d, 0.8265048437046767, 1e-12);
}

TEST(LaplacianTest, SquareWithOneCornerLiftedHandComputed) {
  // B = A with v3 lifted to (1,1,1). sum ||v - v'|| = 1.
  // GL'(v0) = GL(v0) (its ring did not move): difference 0.
  // GL'(v3): neighbours v1, v2 both at sqrt2, mean (1/2,1/2,0),
  //   GL' = (1/2, 1/2, 1): difference (0, 0, 1), norm 1.
  // GL'(v1): weights 1 (v0), 1/sqrt2 (v2), 1/sqrt2 (v3' at distance sqrt2),
  //   W = 1 + sqrt2, sum w v = (1, 2, 1)/sqrt2, mean = (1, 2, 1)/(2 + sqrt2),
  //   1/(2 + sqrt2) = 1 - sqrt2/2, so GL' = (sqrt2/2, -(2 - sqrt2), -(1 - sqrt2/2))
  //   = (0.70711, -0.58579, -0.29289); GL = (c, -c, 0) = (0.63060, -0.63060, 0);
  //   difference norm e = 0.30601937481870...
  // GL'(v2): the mirror image, the same e.
  // ||M - M'|| = (1 + 1 + 2e) / 8 = 0.32650484370467...
  Primitive lifted = Square();
  lifted.positions[3] = {1, 1, 1};
  const double s = std::sqrt(2.0), c = (s + 1) / (2 * s + 1);
  const double dx = s / 2 - c, dy = -(2 - s) + c, dz = -(1 - s / 2);
  const double e = std::sqrt(dx * dx + dy * dy + dz * dz);
  auto d = LaplacianDistortion(Square(), lifted);
  ASSERT_TRUE(d.ok()) << d.status().ToString();
  EXPECT_NEAR(*d, (2 + 2 * e) / 8, 1e-12);
  EXPECT_NEAR(*d, 0.3265048437046768, 1e-12);
}

TEST(LaplacianTest, TranslationMovesOnlyThePositionTerm) {
  // GL is translation invariant: (4 * 0.5 + 0) / 8 = 0.25.
  Primitive moved = Square();
  for (Vec3f& p : moved.positions) p[1] += 0.5f;
  auto d = LaplacianDistortion(Square(), moved);
  ASSERT_TRUE(d.ok());
  EXPECT_NEAR(*d, 0.25, 1e-7);
  auto same = LaplacianDistortion(Square(), Square());
  ASSERT_TRUE(same.ok());
  EXPECT_EQ(*same, 0.0);
}

TEST(LaplacianTest, UnreferencedVerticesAndZeroLengthEdgesAreSkipped) {
  // An unreferenced vertex in front of B shifts its indices but not the
  // correspondence of referenced vertices.
  Primitive b;
  b.positions = {{50, 50, 50}, {0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  b.indices = {1, 2, 3, 2, 4, 3};
  auto d = LaplacianDistortion(Square(), b);
  ASSERT_TRUE(d.ok()) << d.status().ToString();
  EXPECT_EQ(*d, 0.0);

  // A zero-length edge: v4 coincides with v0. v4's only neighbours are v0
  // (skipped, distance 0) and v1; v0's neighbour v4 is skipped too.
  Primitive z = Square();
  z.positions.push_back({0, 0, 0});
  z.indices.insert(z.indices.end(), {0, 1, 4});
  const std::vector<Vec3d> gl = GeometricLaplacian(z);
  for (double x : gl[4]) EXPECT_TRUE(std::isfinite(x));
  // v4's ring: v0 (skipped) and v1 at (1,0,0), so GL(v4) = v4 - v1.
  EXPECT_NEAR(gl[4][0], -1.0, 1e-15);
  // v0's ring: v1, v2 (v4 skipped), as in the plain square.
  EXPECT_NEAR(gl[0][0], -0.5, 1e-15);
  EXPECT_NEAR(gl[0][1], -0.5, 1e-15);
}

TEST(LaplacianTest, IsolatedVertexHasZeroLaplacian) {
  // A face whose three corners coincide: no neighbour has a finite weight.
  Primitive p;
  p.positions = {{1, 2, 3}};
  p.indices = {0, 0, 0};
  const std::vector<Vec3d> gl = GeometricLaplacian(p);
  EXPECT_EQ(gl[0], (Vec3d{0, 0, 0}));
  auto d = LaplacianDistortion(p, p);
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(*d, 0.0);
}

TEST(LaplacianTest, DifferentVertexCountsAreAnError) {
  Primitive more = Square();
  more.positions.push_back({2, 0, 0});
  more.indices.insert(more.indices.end(), {1, 4, 3});
  EXPECT_EQ(LaplacianDistortion(Square(), more).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(LaplacianDistortion(Primitive(), Primitive()).status().code(),
            StatusCode::kInvalidInput);
}

// ------------------------------------------------------- equality on a grid

TEST(GridEqualityTest, PermutedVerticesAndRotatedCornersAreEqual) {
  const Primitive a = Plane(4);
  // Reverse the vertex order and add an unreferenced vertex.
  Primitive permuted;
  const uint32_t n = static_cast<uint32_t>(a.positions.size());
  for (uint32_t v = 0; v < n; ++v) permuted.positions.push_back(a.positions[n - 1 - v]);
  permuted.positions.push_back({9, 9, 9});
  for (uint32_t i : a.indices) permuted.indices.push_back(n - 1 - i);
  auto same = SameOnGrid(a, permuted, 11);
  ASSERT_TRUE(same.ok()) << same.status().ToString();
  EXPECT_TRUE(*same);

  // Rotate the corners of every face, (p,q,r) -> (q,r,p) or (r,p,q), and
  // reverse the face order.
  Primitive rotated;
  rotated.positions = a.positions;
  for (size_t f = a.face_count(); f-- > 0;) {
    const uint32_t* t = &a.indices[3 * f];
    if (f % 2) {
      rotated.indices.insert(rotated.indices.end(), {t[1], t[2], t[0]});
    } else {
      rotated.indices.insert(rotated.indices.end(), {t[2], t[0], t[1]});
    }
  }
  auto comparison = CompareOnGrid(a, rotated, 11);
  ASSERT_TRUE(comparison.ok());
  EXPECT_TRUE(comparison->equal);
  EXPECT_EQ(comparison->differing(), 0u);
  EXPECT_EQ(comparison->faces_a, 32u);
  EXPECT_EQ(comparison->faces_b, 32u);
}

TEST(GridEqualityTest, ReversedWindingDiffers) {
  const Primitive a = Plane(4);
  Primitive reversed = a;
  std::swap(reversed.indices[1], reversed.indices[2]);  // one face flipped
  auto comparison = CompareOnGrid(a, reversed, 11);
  ASSERT_TRUE(comparison.ok());
  EXPECT_FALSE(comparison->equal);
  EXPECT_EQ(comparison->only_in_a, 1u);
  EXPECT_EQ(comparison->only_in_b, 1u);
  EXPECT_EQ(comparison->differing(), 2u);
}

TEST(GridEqualityTest, MovedVertexDiffersUnlessWithinHalfAStep) {
  const Primitive a = Plane(4);  // extent 1, so one step at qp 8 is 1/255;
  // vertex 6 is (0.25, 0.25, 0), 63.75 steps: a quarter step from its centre
  const double step = 1.0 / 255;
  Primitive small = a;
  small.positions[6][0] += static_cast<float>(0.4 * step);
  small.positions[6][2] -= static_cast<float>(0.4 * step);
  auto same = SameOnGrid(a, small, 8);
  ASSERT_TRUE(same.ok());
  EXPECT_TRUE(*same);

  Primitive moved = a;
  moved.positions[6][2] += static_cast<float>(step);  // interior vertex, in 6 faces
  auto comparison = CompareOnGrid(a, moved, 8);
  ASSERT_TRUE(comparison.ok());
  EXPECT_FALSE(comparison->equal);
  EXPECT_EQ(comparison->only_in_a, 6u);
  EXPECT_EQ(comparison->only_in_b, 6u);
}

TEST(GridEqualityTest, FacesAreAMultiset) {
  const Primitive a = Plane(1);
  Primitive twice = a;
  twice.indices.insert(twice.indices.end(), {0, 1, 3});  // face 0 again
  auto comparison = CompareOnGrid(a, twice, 11);
  ASSERT_TRUE(comparison.ok());
  EXPECT_FALSE(comparison->equal);
  EXPECT_EQ(comparison->only_in_b, 1u);
  EXPECT_EQ(comparison->only_in_a, 0u);
}

TEST(GridEqualityTest, Errors) {
  EXPECT_EQ(SameOnGrid(Primitive(), Plane(1), 11).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(SameOnGrid(Plane(1), Plane(1), 0).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(SameOnGrid(Plane(1), Plane(1), 31).status().code(), StatusCode::kInvalidArgument);
  Primitive bad = Plane(1);
  bad.indices[0] = 42;
  EXPECT_EQ(SameOnGrid(Plane(1), bad, 11).status().code(), StatusCode::kInvalidInput);
  Primitive far = Plane(1);
  far.positions[0] = {3e38f, 0, 0};
  EXPECT_EQ(SameOnGrid(Plane(1), far, 30).status().code(), StatusCode::kInvalidInput);
}

}  // namespace
}  // namespace meshstream
