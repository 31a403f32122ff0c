#include "codec/mesh/scene_flatten.h"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

namespace meshstream {

namespace {

constexpr Mat4d kIdentity = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};

Vec3f TransformPoint(const Mat4d& m, const Vec3f& p) {
  Vec3f out;
  for (int r = 0; r < 3; ++r) {
    out[r] = static_cast<float>(m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r]);
  }
  return out;
}

// Normal matrix: inverse-transpose of the upper 3x3, up to scale (cofactors).
Vec3f TransformNormal(const Mat4d& m, const Vec3f& n) {
  auto a = [&](int r, int c) { return m[c * 4 + r]; };
  double cof[3][3];
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      const int r1 = (r + 1) % 3, r2 = (r + 2) % 3, c1 = (c + 1) % 3, c2 = (c + 2) % 3;
      cof[r][c] = a(r1, c1) * a(r2, c2) - a(r1, c2) * a(r2, c1);
    }
  }
  double out[3];
  for (int r = 0; r < 3; ++r) out[r] = cof[r][0] * n[0] + cof[r][1] * n[1] + cof[r][2] * n[2];
  const double len = std::sqrt(out[0] * out[0] + out[1] * out[1] + out[2] * out[2]);
  if (!(len > 0)) return n;
  return {float(out[0] / len), float(out[1] / len), float(out[2] / len)};
}

void Append(Primitive& out, const Primitive& p, const Mat4d& m, bool identity) {
  const uint32_t base = static_cast<uint32_t>(out.positions.size());
  const bool keep_normals = !p.normals.empty() && (out.positions.empty() || !out.normals.empty());
  if (!keep_normals) out.normals.clear();
  for (size_t i = 0; i < p.positions.size(); ++i) {
    out.positions.push_back(identity ? p.positions[i] : TransformPoint(m, p.positions[i]));
    if (keep_normals) out.normals.push_back(identity ? p.normals[i] : TransformNormal(m, p.normals[i]));
  }
  for (uint32_t idx : p.indices) out.indices.push_back(base + idx);
}

}  // namespace

Mat4d Multiply(const Mat4d& a, const Mat4d& b) {
  Mat4d out{};
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) {
      double s = 0;
      for (int k = 0; k < 4; ++k) s += a[k * 4 + r] * b[c * 4 + k];
      out[c * 4 + r] = s;
    }
  return out;
}

Mat4d NodeLocalMatrix(const Node& node) {
  if (node.has_matrix) return node.matrix;
  const double x = node.rotation[0], y = node.rotation[1], z = node.rotation[2], w = node.rotation[3];
  const double sx = node.scale[0], sy = node.scale[1], sz = node.scale[2];
  Mat4d m = {
      (1 - 2 * (y * y + z * z)) * sx, (2 * (x * y + z * w)) * sx, (2 * (x * z - y * w)) * sx, 0,
      (2 * (x * y - z * w)) * sy, (1 - 2 * (x * x + z * z)) * sy, (2 * (y * z + x * w)) * sy, 0,
      (2 * (x * z + y * w)) * sz, (2 * (y * z - x * w)) * sz, (1 - 2 * (x * x + y * y)) * sz, 0,
      node.translation[0], node.translation[1], node.translation[2], 1};
  return m;
}

void ForEachMeshInstance(const Scene& scene, const std::function<void(int32_t mesh, const Mat4d& world, bool identity)>& visit) {
  std::vector<int32_t> roots;
  if (scene.default_scene >= 0 && static_cast<size_t>(scene.default_scene) < scene.scenes.size()) {
    roots = scene.scenes[scene.default_scene].nodes;
  } else if (!scene.scenes.empty()) {
    roots = scene.scenes[0].nodes;
  }
  if (roots.empty()) {
    for (size_t m = 0; m < scene.meshes.size(); ++m) visit(static_cast<int32_t>(m), kIdentity, true);
    return;
  }
  // Depth-first with an explicit stack; a visit budget guards against cycles.
  std::vector<std::pair<int32_t, Mat4d>> stack;
  for (auto it = roots.rbegin(); it != roots.rend(); ++it) stack.emplace_back(*it, kIdentity);
  size_t budget = scene.nodes.size() * 4 + 16;
  while (!stack.empty() && budget-- > 0) {
    auto [index, parent] = stack.back();
    stack.pop_back();
    if (index < 0 || static_cast<size_t>(index) >= scene.nodes.size()) continue;
    const Node& node = scene.nodes[index];
    const Mat4d local = NodeLocalMatrix(node);
    const bool identity = parent == kIdentity && local == kIdentity;
    const Mat4d world = identity ? kIdentity : Multiply(parent, local);
    if (node.mesh >= 0 && static_cast<size_t>(node.mesh) < scene.meshes.size()) visit(node.mesh, world, identity);
    for (auto it = node.children.rbegin(); it != node.children.rend(); ++it) stack.emplace_back(*it, world);
  }
}

Primitive FlattenScene(const Scene& scene) {
  Primitive out;
  ForEachMeshInstance(scene, [&](int32_t mesh, const Mat4d& world, bool identity) {
    for (const Primitive& p : scene.meshes[mesh].primitives) Append(out, p, world, identity);
  });
  return out;
}

std::vector<double> MeshScales(const Scene& scene) {
  std::vector<double> scales(scene.meshes.size(), 0.0);
  ForEachMeshInstance(scene, [&](int32_t mesh, const Mat4d& m, bool) {
    // The largest column norm: exactly the largest stretch for a rotation
    // with scale (glTF's translation-rotation-scale), an estimate for shear.
    double largest = 0;
    for (int c = 0; c < 3; ++c) {
      largest = std::max(largest, std::sqrt(m[4 * c] * m[4 * c] + m[4 * c + 1] * m[4 * c + 1] + m[4 * c + 2] * m[4 * c + 2]));
    }
    if (std::isfinite(largest)) scales[mesh] = std::max(scales[mesh], largest);
  });
  return scales;
}

}  // namespace meshstream
