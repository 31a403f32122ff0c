#include "bench/stream/snapshots.h"

#include <cstring>
#include <fstream>
#include <utility>

#include "bench/bench_util.h"
#include "codec/core/fnv.h"
#include "codec/mesh/scene_flatten.h"

namespace meshstream::bench::stream {

namespace {

constexpr char kSnapshotMagic[8] = {'M', 'S', 'S', 'N', 'A', 'P', '1', '\n'};

}  // namespace

void WriteSnapshots(const std::string& path, const std::vector<Snapshot>& snapshots) {
  std::ofstream f(path, std::ios::binary);
  auto put = [&](const void* p, size_t n) { f.write(static_cast<const char*>(p), static_cast<std::streamsize>(n)); };
  put(kSnapshotMagic, sizeof kSnapshotMagic);
  const uint32_t count = static_cast<uint32_t>(snapshots.size());
  put(&count, sizeof count);
  for (const Snapshot& s : snapshots) {
    const uint64_t nv = s.mesh.positions.size(), ni = s.mesh.indices.size();
    put(&s.level, sizeof s.level);
    put(&nv, sizeof nv);
    put(&ni, sizeof ni);
    put(s.mesh.positions.data(), nv * sizeof(Vec3f));
    put(s.mesh.indices.data(), ni * sizeof(uint32_t));
  }
  if (!f) Die(path + ": cannot write the snapshots");
}

std::vector<Snapshot> ReadSnapshots(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  auto get = [&](void* p, size_t n) {
    f.read(static_cast<char*>(p), static_cast<std::streamsize>(n));
    if (!f) Die(path + ": truncated snapshot file");
  };
  char magic[8];
  get(magic, sizeof magic);
  if (std::memcmp(magic, kSnapshotMagic, sizeof magic) != 0) Die(path + ": not a snapshot file");
  uint32_t count = 0;
  get(&count, sizeof count);
  std::vector<Snapshot> out(count);
  for (Snapshot& s : out) {
    uint64_t nv = 0, ni = 0;
    get(&s.level, sizeof s.level);
    get(&nv, sizeof nv);
    get(&ni, sizeof ni);
    if (nv > (uint64_t{1} << 28) || ni > (uint64_t{1} << 30)) Die(path + ": implausible snapshot sizes");
    s.mesh.positions.resize(nv);
    s.mesh.indices.resize(ni);
    get(s.mesh.positions.data(), nv * sizeof(Vec3f));
    get(s.mesh.indices.data(), ni * sizeof(uint32_t));
  }
  return out;
}

uint64_t MeshHash(const Primitive& p) {
  Fnv1a h;
  const uint64_t nv = p.positions.size(), ni = p.indices.size();
  h.Add(&nv, sizeof nv);
  h.Add(&ni, sizeof ni);
  h.Add(p.positions.data(), nv * sizeof(Vec3f));
  h.Add(p.indices.data(), ni * sizeof(uint32_t));
  return h.value;
}

Primitive Geometry(const Scene& scene) {
  Primitive flat = FlattenScene(scene);
  Primitive g;
  g.positions = std::move(flat.positions);
  g.indices = std::move(flat.indices);
  return g;
}

}  // namespace meshstream::bench::stream
