#include "codec/progressive/batch_simplifier.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <new>
#include <numeric>
#include <type_traits>
#include <unordered_map>

#include "codec/progressive/seam_twins.h"

namespace meshstream {

namespace {

using Quadric = std::array<double, 10>;  // symmetric 4x4: a2 ab ac ad b2 bc bd c2 cd d2

// A candidate edge (u, v), u < v. The top bit of `v_flags` marks a candidate
// found illegal by an earlier batch whose surroundings have not changed since
// (Simplifier::MarkChanged), so the scan skips it without checking again.
constexpr uint32_t kKnownIllegal = 1u << 31;
struct Candidate {
  double cost;
  uint32_t u, v_flags;
  uint32_t v() const { return v_flags & ~kKnownIllegal; }
};

// The candidates' order: by cost, then by edge (a strict total order: the
// sort's result does not depend on the algorithm). A function object, not a
// function pointer, so that std::sort inlines it.
struct CandidateOrder {
  bool operator()(const Candidate& a, const Candidate& b) const {
    if (a.cost != b.cost) return a.cost < b.cost;
    return a.u != b.u ? a.u < b.u : a.v() < b.v();
  }
};

// The candidate list: an array of trivially copyable records that gives
// memory back without copying. The list only shrinks after it is built (a
// batch replaces the edges it dropped by fewer), while the batches grow;
// std::vector's shrink_to_fit would hold the old and the new block at once,
// which at the first shrink is above the simplifier's peak. realloc to a
// smaller size keeps the block (it frees the tail, or remaps the pages).
template <typename T>
class ShrinkableArray {
  static_assert(std::is_trivially_copyable_v<T>);

 public:
  ShrinkableArray() = default;
  ShrinkableArray(const ShrinkableArray&) = delete;
  ShrinkableArray& operator=(const ShrinkableArray&) = delete;
  ~ShrinkableArray() { std::free(data_); }

  T* begin() { return data_; }
  T* end() { return data_ + size_; }
  const T* begin() const { return data_; }
  const T* end() const { return data_ + size_; }
  T& operator[](size_t i) { return data_[i]; }
  size_t size() const { return size_; }
  size_t capacity() const { return capacity_; }

  void clear() { size_ = 0; }
  void push_back(const T& x) {
    if (size_ == capacity_) SetCapacity(std::max<size_t>(16, 2 * capacity_));
    data_[size_++] = x;
  }
  // New elements (n > size()) are uninitialized. Grows by a sixteenth
  // beyond n (the list outgrows its capacity rarely, and by little).
  void resize(size_t n) {
    if (n > capacity_) SetCapacity(n + n / 16);
    size_ = n;
  }
  void reserve(size_t n) {
    if (n > capacity_) SetCapacity(n);
  }
  void shrink_to_fit() {
    if (size_ < capacity_) SetCapacity(size_);
  }
  void swap(ShrinkableArray& other) {
    std::swap(data_, other.data_);
    std::swap(size_, other.size_);
    std::swap(capacity_, other.capacity_);
  }
  // Frees the memory.
  void Release() {
    std::free(data_);
    data_ = nullptr;
    size_ = capacity_ = 0;
  }

 private:
  void SetCapacity(size_t n) {
    if (n == 0) {
      Release();
      return;
    }
    void* p = std::realloc(data_, n * sizeof(T));
    if (p == nullptr) throw std::bad_alloc();
    data_ = static_cast<T*>(p);
    capacity_ = n;
  }

  T* data_ = nullptr;
  size_t size_ = 0, capacity_ = 0;
};

// The triangles, in the index array the mesh came with (taken, not copied:
// three indices a triangle, the triangles that repeat an index removed in
// place). A collapse renames a corner (Rename); a triangle that dies keeps
// its indices.
class Triangles {
 public:
  Triangles() = default;
  // Takes `indices` (three per triangle; a trailing partial triangle is
  // dropped) and removes the triangles that repeat an index, keeping the
  // order of the others; returns how many it removed.
  uint64_t Take(std::vector<uint32_t> indices) {
    indices_ = std::move(indices);
    const size_t count = indices_.size() / 3;
    size_t kept = 0;
    for (size_t f = 0; f < count; ++f) {
      const Face face = {indices_[3 * f], indices_[3 * f + 1], indices_[3 * f + 2]};
      if (RepeatsAnIndex(face)) continue;
      std::copy(face.begin(), face.end(), indices_.begin() + 3 * kept);
      ++kept;
    }
    indices_.resize(3 * kept);
    return count - kept;
  }
  size_t size() const { return indices_.size() / 3; }
  Face operator[](size_t f) const { return {indices_[3 * f], indices_[3 * f + 1], indices_[3 * f + 2]}; }
  // Renames `from` to `to` in triangle f.
  void Rename(size_t f, uint32_t from, uint32_t to) {
    for (size_t i = 3 * f; i < 3 * f + 3; ++i)
      if (indices_[i] == from) indices_[i] = to;
  }
  void Release() { indices_ = std::vector<uint32_t>(); }

 private:
  std::vector<uint32_t> indices_;
};

// The live triangles of every vertex, as spans of one pool (a vector per
// vertex cost about 72 bytes a vertex in headers, allocator chunks and
// growth; this, 12 bytes plus 4 per entry). A collapse moves v's triangles
// to u: u's span grows in place when it has room, else moves to the pool's
// end, and the space left behind is reclaimed by Compact. Order within a
// span is kept as a vector's would be (erase keeps order, append at the end).
class VertexFaces {
 public:
  struct Range {
    const uint32_t* b;
    const uint32_t* e;
    const uint32_t* begin() const { return b; }
    const uint32_t* end() const { return e; }
    size_t size() const { return static_cast<size_t>(e - b); }
    bool empty() const { return b == e; }
  };

  // faces: the live triangles; n: the vertex count; room: spare entries to
  // reserve for the first batch's growth.
  void Build(size_t n, const Triangles& faces, size_t room) {
    spans_.assign(n, Span{});
    for (size_t id = 0; id < faces.size(); ++id)
      for (uint32_t v : faces[id]) ++spans_[v].cap;
    uint32_t at = 0;
    for (Span& sp : spans_) {
      sp.begin = at;
      at += sp.cap;
    }
    pool_.reserve(size_t(at) + room);
    pool_.resize(at);
    for (uint32_t id = 0; id < faces.size(); ++id)
      for (uint32_t v : faces[id]) {
        Span& sp = spans_[v];
        pool_[sp.begin + sp.size++] = id;
      }
  }

  Range operator[](uint32_t v) const {
    const Span& sp = spans_[v];
    const uint32_t* b = pool_.data() + sp.begin;
    return {b, b + sp.size};
  }

  // Removes every occurrence of face f from v's list.
  void Remove(uint32_t v, uint32_t f) {
    Span& sp = spans_[v];
    uint32_t* b = pool_.data() + sp.begin;
    uint32_t* e = std::remove(b, b + sp.size, f);
    sp.size = static_cast<uint32_t>(e - b);
  }

  // Appends v's list to u's and empties v's.
  void MoveInto(uint32_t u, uint32_t v) {
    Span& su = spans_[u];
    Span& sv = spans_[v];
    const uint32_t need = su.size + sv.size;
    if (need > su.cap) {
      const size_t at = pool_.size();
      pool_.resize(at + need);  // within what MakeRoom reserved; else the pool grows as a vector does
      std::copy(pool_.begin() + su.begin, pool_.begin() + su.begin + su.size, pool_.begin() + at);
      garbage_ += su.cap;
      su.begin = static_cast<uint32_t>(at);
      su.cap = need;
    }
    std::copy(pool_.begin() + sv.begin, pool_.begin() + sv.begin + sv.size, pool_.begin() + su.begin + su.size);
    su.size = need;
    garbage_ += sv.cap;
    sv = Span{};
  }

  // Makes sure `extra` more entries fit without reallocating the pool:
  // compacts first (in place), grows only when that is not enough.
  void MakeRoom(size_t extra) {
    if (pool_.size() + extra <= pool_.capacity()) return;
    if (garbage_ > 0) Compact();
    if (pool_.size() + extra > pool_.capacity()) pool_.reserve(pool_.size() + extra + pool_.size() / 8);
  }

  // Entries of the pool the lists may address (begin offsets are 32-bit).
  static constexpr uint64_t kMaxEntries = uint64_t{1} << 31;

 private:
  struct Span {
    uint32_t begin = 0, size = 0, cap = 0;
  };

  void Compact() {
    std::vector<uint32_t> order;
    order.reserve(spans_.size());
    for (uint32_t v = 0; v < spans_.size(); ++v)
      if (spans_[v].size > 0) order.push_back(v);
    std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return spans_[a].begin < spans_[b].begin; });
    uint32_t at = 0;
    for (uint32_t v : order) {
      Span& sp = spans_[v];
      std::copy(pool_.begin() + sp.begin, pool_.begin() + sp.begin + sp.size, pool_.begin() + at);
      sp.begin = at;
      sp.cap = sp.size;
      at += sp.size;
    }
    for (Span& sp : spans_)
      if (sp.size == 0) sp = Span{};
    pool_.resize(at);
    garbage_ = 0;
  }

  std::vector<Span> spans_;
  std::vector<uint32_t> pool_;
  uint64_t garbage_ = 0;  // entries no span owns any more (Compact reclaims them)
};

using CandidateList = ShrinkableArray<Candidate>;

// Per-vertex marks, all in one byte a vertex (a byte table for each cost
// five bytes a vertex).
enum VertexFlag : uint8_t {
  kLocked = 1,       // never collapsed (see the header)
  kClosed = 2,       // closed for the rest of the batch (the strict rule)
  kSeam = 4,         // has a seam twin (an unlocked boundary vertex)
  kTouched = 8,      // a collapse touched it (dirty_, during UpdateCandidates)
  kChanged = 16,     // next to the last batch's collapses (MarkChanged)
  kReferenced = 32,  // in a triangle of the input (after clean-up)
  kBatchEnd = 64,    // kMatching: an end of a collapse of the current batch
};
class VertexFlags {
 public:
  void Init(size_t n) { bits_.assign(n, 0); }
  bool Has(uint32_t v, uint8_t flag) const { return (bits_[v] & flag) != 0; }
  void Set(uint32_t v, uint8_t flag) { bits_[v] |= flag; }
  void Unset(uint32_t v, uint8_t flag) { bits_[v] &= static_cast<uint8_t>(~flag); }
  void UnsetAll(uint8_t flag) {
    for (uint8_t& b : bits_) b &= static_cast<uint8_t>(~flag);
  }
  size_t Count(uint8_t flag) const {
    size_t n = 0;
    for (uint8_t b : bits_) n += (b & flag) != 0;
    return n;
  }
  void Release() { bits_ = std::vector<uint8_t>(); }

 private:
  std::vector<uint8_t> bits_;
};

class Simplifier {
 public:
  // Takes the mesh's arrays (the caller's copy, or the mesh it gave up).
  Simplifier(QuantizedMesh&& mesh, const SimplifyOptions& options)
      : options_(options), channels_(mesh.layout.channels()) {
    const size_t n = mesh.vertex_count();
    positions_ = std::move(mesh.positions);
    attributes_ = std::move(mesh.attributes);
    removed_faces_ = faces_.Take(std::move(mesh.indices));
    // Room for the first batch's collapses (a sixth of the vertices, each
    // moving both ends' dozen triangles to the pool's end).
    vertex_faces_.Build(n, faces_, n * 2 + 1024);
    face_alive_.assign(faces_.size(), 1);
    quadrics_.assign(n, Quadric{});
    for (size_t f = 0; f < faces_.size(); ++f) AddFaceQuadric(faces_[f]);
    InitLocks();
  }

  StatusOr<Hierarchy> Run() {
    Hierarchy h;
    h.removed_faces = removed_faces_;
    h.locked_vertices = flags_.Count(kLocked);
    h.input_faces = faces_.size();
    size_t alive = 0;
    for (size_t f = 0; f < faces_.size(); ++f)
      for (uint32_t v : faces_[f]) flags_.Set(v, kReferenced);
    alive = flags_.Count(kReferenced);
    const size_t target = std::max<size_t>(4, static_cast<size_t>(std::ceil(alive * options_.base_ratio)));
    while (alive > target && h.batches.size() < options_.max_levels) {
      const size_t min_collapses = std::min<size_t>(
          options_.min_batch_collapses, static_cast<size_t>(std::ceil(double(alive) * options_.min_batch_share)));
      CollapseBatch batch = NextBatch(min_collapses, alive);
      if (candidates_differ_) {
        return Internal("batch " + std::to_string(h.batches.size() + 1) +
                        ": the candidates kept up to date differ from a fresh evaluation");
      }
      if (batch.collapses.empty()) break;
      alive -= batch.collapses.size();
      h.batches.push_back(std::move(batch));
      if (options_.observer && !options_.observer(static_cast<int>(h.batches.size()), alive)) {
        return Status(StatusCode::kInternal, "simplification cancelled");
      }
    }
    // The hierarchy is assembled after the working state is gone: this is
    // the simplifier's last step, and the batches are then at their largest.
    h.in_base.resize(positions_.size());
    for (uint32_t v = 0; v < positions_.size(); ++v) h.in_base[v] = flags_.Has(v, kReferenced) ? 1 : 0;
    ReleaseWorkingState();
    for (const CollapseBatch& b : h.batches)
      for (const Collapse& c : b.collapses) h.in_base[c.v] = 0;
    size_t base_faces = 0;
    for (uint8_t alive : face_alive_) base_faces += alive;
    h.base_indices.reserve(base_faces * 3);
    for (size_t f = 0; f < faces_.size(); ++f) {
      if (!face_alive_[f]) continue;
      const Face face = faces_[f];
      h.base_indices.insert(h.base_indices.end(), face.begin(), face.end());
    }
    faces_.Release();
    face_alive_ = decltype(face_alive_)();
    h.positions = std::move(positions_);
    h.attributes = std::move(attributes_);
    h.twin.assign(h.in_base.size(), kNoTwin);
    for (const std::array<uint32_t, 2>& t : twins_) h.twin[t[0]] = t[1];
    return h;
  }

 private:
  // Frees what only the batches need (Run ends with the hierarchy; the
  // simplifier is not used afterwards). (`x = {}` would not free: it assigns
  // an empty initializer list and keeps the capacity.)
  void ReleaseWorkingState() {
    vertex_faces_ = VertexFaces();
    quadrics_ = decltype(quadrics_)();
    candidates_.Release();
    fresh_.Release();
    flags_.Release();
    dirty_ = decltype(dirty_)();
  }

  void AddFaceQuadric(const Face& f) {
    const Vec3i& p0 = positions_[f[0]];
    const Vec3i& p1 = positions_[f[1]];
    const Vec3i& p2 = positions_[f[2]];
    const double ux = double(p1[0]) - p0[0], uy = double(p1[1]) - p0[1], uz = double(p1[2]) - p0[2];
    const double vx = double(p2[0]) - p0[0], vy = double(p2[1]) - p0[1], vz = double(p2[2]) - p0[2];
    double nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
    const double len = std::sqrt(nx * nx + ny * ny + nz * nz);
    if (!(len > 0)) return;
    const double area = 0.5 * len;
    nx /= len; ny /= len; nz /= len;
    const double d = -(nx * p0[0] + ny * p0[1] + nz * p0[2]);
    const Quadric q = {nx * nx, nx * ny, nx * nz, nx * d, ny * ny, ny * nz, ny * d, nz * nz, nz * d, d * d};
    for (uint32_t v : f)
      for (int k = 0; k < 10; ++k) quadrics_[v][k] += area * q[k];
  }

  static double Evaluate(const Quadric& a, const Quadric& b, double x, double y, double z) {
    Quadric q;
    for (int k = 0; k < 10; ++k) q[k] = a[k] + b[k];
    return q[0] * x * x + 2 * q[1] * x * y + 2 * q[2] * x * z + 2 * q[3] * x + q[4] * y * y + 2 * q[5] * y * z +
           2 * q[6] * y + q[7] * z * z + 2 * q[8] * z + q[9];
  }

  // A vertex is free when its triangles form one closed fan.
  bool IsClosedFan(uint32_t w) {
    const VertexFaces::Range fs = vertex_faces_[w];
    if (fs.size() < 3) return false;
    pairs_.clear();
    for (uint32_t f : fs) {
      if (!face_alive_[f]) continue;
      const Face r = RotateTo(faces_[f], w);
      pairs_.push_back({r[1], r[2]});
    }
    const size_t n = pairs_.size();
    if (n < 3) return false;
    std::sort(pairs_.begin(), pairs_.end());
    for (size_t i = 1; i < n; ++i) {
      if (pairs_[i][0] == pairs_[i - 1][0]) return false;
    }
    uint32_t cur = pairs_[0][0];
    for (size_t step = 0; step < n; ++step) {
      auto it = std::lower_bound(pairs_.begin(), pairs_.end(), std::array<uint32_t, 2>{cur, 0});
      if (it == pairs_.end() || (*it)[0] != cur) return false;
      cur = (*it)[1];
      if (cur == pairs_[0][0]) return step + 1 == n;
    }
    return false;
  }

  // A vertex is on a boundary when its triangles form one open fan: every
  // triangle leaves a distinct vertex, exactly one of those is entered by
  // none, and the walk from it visits every triangle.
  bool IsOpenFan(uint32_t w) {
    pairs_.clear();
    for (uint32_t f : vertex_faces_[w]) {
      if (!face_alive_[f]) continue;
      const Face r = RotateTo(faces_[f], w);
      pairs_.push_back({r[1], r[2]});
    }
    const size_t n = pairs_.size();
    if (n == 0) return false;
    std::sort(pairs_.begin(), pairs_.end());
    for (size_t i = 1; i < n; ++i)
      if (pairs_[i][0] == pairs_[i - 1][0]) return false;
    uint32_t start = UINT32_MAX;
    for (const auto& p : pairs_) {
      bool entered = false;
      for (const auto& q : pairs_) entered |= q[1] == p[0];
      if (entered) continue;
      if (start != UINT32_MAX) return false;
      start = p[0];
    }
    if (start == UINT32_MAX) return false;
    uint32_t cur = start;
    for (size_t step = 0; step < n; ++step) {
      auto it = std::lower_bound(pairs_.begin(), pairs_.end(), std::array<uint32_t, 2>{cur, 0});
      if (it == pairs_.end() || (*it)[0] != cur) return false;
      cur = (*it)[1];
    }
    auto end = std::lower_bound(pairs_.begin(), pairs_.end(), std::array<uint32_t, 2>{cur, 0});
    return end == pairs_.end() || (*end)[0] != cur;
  }

  // Seam twins: open-fan vertices whose position exactly one other vertex,
  // also an open fan, shares. They are unlocked; their quadrics are summed.
  void InitSeams() {
    const size_t n = positions_.size();
    twins_.clear();
    flags_.UnsetAll(kSeam);
    std::vector<uint32_t> open;
    for (uint32_t v = 0; v < n; ++v)
      if (!vertex_faces_[v].empty() && !flags_.Has(v, kLocked) && IsOpenFan(v)) open.push_back(v);
    std::vector<uint32_t> by_position(n);
    std::iota(by_position.begin(), by_position.end(), 0);
    std::sort(by_position.begin(), by_position.end(), [&](uint32_t a, uint32_t b) {
      return positions_[a] != positions_[b] ? positions_[a] < positions_[b] : a < b;
    });
    std::vector<uint8_t> is_open(n, 0);
    for (uint32_t v : open) is_open[v] = 1;
    for (size_t i = 0; i < n;) {
      size_t e = i;
      size_t referenced = 0;
      while (e < n && positions_[by_position[e]] == positions_[by_position[i]]) {
        referenced += vertex_faces_[by_position[e]].empty() ? 0 : 1;
        ++e;
      }
      if (referenced == 2 && e - i >= 2) {
        uint32_t pair[2];
        int k = 0;
        for (size_t t = i; t < e; ++t)
          if (!vertex_faces_[by_position[t]].empty() && k < 2) pair[k++] = by_position[t];
        if (is_open[pair[0]] && is_open[pair[1]]) {
          twins_.push_back({pair[0], pair[1]});
          twins_.push_back({pair[1], pair[0]});
          for (uint32_t x : pair) {
            flags_.Set(x, kSeam);
            flags_.Unset(x, kLocked);
          }
          Quadric q;
          for (int c = 0; c < 10; ++c) q[c] = quadrics_[pair[0]][c] + quadrics_[pair[1]][c];
          quadrics_[pair[0]] = quadrics_[pair[1]] = q;
        }
      }
      i = e;
    }
    std::sort(twins_.begin(), twins_.end());
  }

  // The seam twin of a seam vertex (kSeam), else kNoTwin.
  uint32_t TwinOf(uint32_t v) const {
    auto it = std::lower_bound(twins_.begin(), twins_.end(), std::array<uint32_t, 2>{v, 0});
    return it != twins_.end() && (*it)[0] == v ? (*it)[1] : kNoTwin;
  }

  void InitLocks() {
    const size_t n = positions_.size();
    flags_.Init(n);
    twins_.clear();
    std::vector<uint8_t> fan_locked(n, 0);
    for (uint32_t v = 0; v < n; ++v) {
      if (!vertex_faces_[v].empty() && !IsClosedFan(v)) fan_locked[v] = 1;
    }
    // Duplicated triangles (the same three vertices twice, in any order):
    // found among the triangles of each triangle's smallest vertex, without
    // a sorted copy of every triangle (32 bytes a vertex).
    // (Another triangle of the smallest vertex that holds the other two is
    // the same three vertices: no triangle repeats an index.)
    for (uint32_t f = 0; f < faces_.size(); ++f) {
      Face s = faces_[f];
      std::sort(s.begin(), s.end());
      for (uint32_t g : vertex_faces_[s[0]]) {
        const Face t = faces_[g];
        auto holds = [&t](uint32_t x) { return t[0] == x || t[1] == x || t[2] == x; };
        if (g == f || !holds(s[1]) || !holds(s[2])) continue;
        for (uint32_t x : s) flags_.Set(x, kLocked);
        break;
      }
    }
    // Seam twins are found among the boundary vertices not locked otherwise.
    if (options_.collapse_seams) InitSeams();
    for (uint32_t v = 0; v < n; ++v)
      if (fan_locked[v] && !flags_.Has(v, kSeam)) flags_.Set(v, kLocked);
  }

  void Neighbours(uint32_t w, std::vector<uint32_t>& out) const {
    out.clear();
    for (uint32_t f : vertex_faces_[w])
      for (uint32_t x : faces_[f])
        if (x != w) out.push_back(x);
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
  }

  // Whether w has at least `count` (at most 4) distinct neighbours:
  // Neighbours(w).size() >= count, without the sorted list the wings' test
  // does not need.
  bool HasNeighbours(uint32_t w, size_t count) const {
    uint32_t seen[4];
    size_t found = 0;
    for (uint32_t f : vertex_faces_[w]) {
      for (uint32_t x : faces_[f]) {
        if (x == w || std::find(seen, seen + found, x) != seen + found) continue;
        seen[found++] = x;
        if (found >= count) return true;
      }
    }
    return found >= count;
  }

  Vec3i DeltaOf(uint32_t u, uint32_t v) const {
    return {positions_[u][0] - positions_[v][0], positions_[u][1] - positions_[v][1],
            positions_[u][2] - positions_[v][2]};
  }

  static std::array<double, 3> Normal(const Vec3i& p0, const Vec3i& p1, const Vec3i& p2) {
    const double ux = double(p1[0]) - p0[0], uy = double(p1[1]) - p0[1], uz = double(p1[2]) - p0[2];
    const double vx = double(p2[0]) - p0[0], vy = double(p2[1]) - p0[1], vz = double(p2[2]) - p0[2];
    return {uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx};
  }

  // Moving `moved` to `target` keeps every triangle of `moved` that does not
  // contain `other` from flipping or collapsing to zero area.
  bool KeepsOrientation(uint32_t moved, uint32_t other, const Vec3i& target) const {
    for (uint32_t f : vertex_faces_[moved]) {
      const Face face = faces_[f];
      if (face[0] == other || face[1] == other || face[2] == other) continue;
      Vec3i p[3];
      for (int k = 0; k < 3; ++k) p[k] = positions_[face[k]];
      const auto before = Normal(p[0], p[1], p[2]);
      for (int k = 0; k < 3; ++k)
        if (face[k] == moved) p[k] = target;
      const auto after = Normal(p[0], p[1], p[2]);
      const double dot = before[0] * after[0] + before[1] * after[1] + before[2] * after[2];
      const double len2 = after[0] * after[0] + after[1] * after[1] + after[2] * after[2];
      if (!(len2 > 0) || !(dot > 0)) return false;
    }
    return true;
  }

  // Fills nu_, nv_ and common_ (the neighbours u and v share); true when
  // they share exactly `count`.
  bool SharedNeighbours(uint32_t u, uint32_t v, size_t count) {
    Neighbours(u, nu_);
    Neighbours(v, nv_);
    common_.clear();
    std::set_intersection(nu_.begin(), nu_.end(), nv_.begin(), nv_.end(), std::back_inserter(common_));
    return common_.size() == count;
  }

  // Both ends of (u, v) moved to its midpoint keep their other triangles' orientation.
  bool MidpointKeepsOrientation(uint32_t u, uint32_t v) const {
    Vec3i m;
    for (int k = 0; k < 3; ++k) m[k] = Midpoint(positions_[u][k], positions_[v][k]);
    return KeepsOrientation(u, v, m) && KeepsOrientation(v, u, m);
  }

  // Is the edge (u, v) in exactly one alive triangle?
  bool IsBoundaryEdge(uint32_t u, uint32_t v) const {
    int count = 0;
    for (uint32_t f : vertex_faces_[u]) {
      const Face face = faces_[f];
      count += (face[0] == v || face[1] == v || face[2] == v) ? 1 : 0;
    }
    return count == 1;
  }

  // One side of a seam collapse (u, v): legal on its own (see the header).
  // Fills nu_ and nv_.
  bool LegalSeamSide(uint32_t u, uint32_t v, Collapse& c) {
    uint32_t a = UINT32_MAX, fa = 0;
    int shared = 0;
    bool uva = false;
    for (uint32_t f : vertex_faces_[u]) {
      const Face r = RotateTo(faces_[f], u);
      if (r[1] == v) { a = r[2]; uva = true; ++shared; fa = f; }
      else if (r[2] == v) { a = r[1]; uva = false; ++shared; fa = f; }
    }
    if (shared != 1) return false;
    if (!SharedNeighbours(u, v, 1) || common_[0] != a) return false;
    if (IsBoundaryEdge(u, a) && IsBoundaryEdge(v, a)) return false;
    const size_t valence = nu_.size() + nv_.size() - 3;
    if (valence < 2 || valence > static_cast<size_t>(options_.max_valence) || valence >= kMaxSeamValence) return false;
    if (!HasNeighbours(a, 3)) return false;
    if (!MidpointKeepsOrientation(u, v)) return false;
    c = Collapse{u, v, FineCorner(fa, a), kNoWing, DeltaOf(u, v)};
    c.uva = uva;
    return true;
  }

  // kMatching applies a batch's collapses as it goes, renaming the removed
  // end of each in its triangles: a later collapse of the batch then finds
  // the kept end as its wing where the batch's finer mesh (the one its
  // split refines) has the removed one. The corner of face f that holds x
  // now held this vertex before the batch.
  uint32_t FineCorner(uint32_t f, uint32_t x) const {
    const auto it = batch_faces_.find(f);
    if (it == batch_faces_.end()) return x;
    const Face now = faces_[f];
    for (int k = 0; k < 3; ++k)
      if (now[k] == x) return it->second[k];
    return x;
  }

  // A seam edge and its twin edge, collapsed together; `twin_side` gets the
  // other side's collapse, and seam_neighbours_ both sides' neighbours.
  bool LegalSeam(uint32_t u, uint32_t v, Collapse& c, Collapse& twin_side) {
    if (!flags_.Has(u, kSeam) || !flags_.Has(v, kSeam)) return false;
    const uint32_t u2 = TwinOf(u), v2 = TwinOf(v);
    if (flags_.Has(u2, kClosed) || flags_.Has(v2, kClosed) || u2 == v || v2 == u || u2 == v2) return false;
    if (!LegalSeamSide(u2, v2, twin_side)) return false;
    seam_neighbours_ = nu_;
    seam_neighbours_.insert(seam_neighbours_.end(), nv_.begin(), nv_.end());
    if (!LegalSeamSide(u, v, c)) return false;
    // The twin edge runs the other way (one surface across the seam), and
    // the two sides' split vertices are not adjacent (the strict rule).
    if (c.uva == twin_side.uva) return false;
    for (uint32_t x : {u2, v2})
      if (std::binary_search(nu_.begin(), nu_.end(), x) || std::binary_search(nv_.begin(), nv_.end(), x)) return false;
    seam_neighbours_.insert(seam_neighbours_.end(), nu_.begin(), nu_.end());
    seam_neighbours_.insert(seam_neighbours_.end(), nv_.begin(), nv_.end());
    return true;
  }

  bool Legal(uint32_t u, uint32_t v, Collapse& c) {
    constexpr uint8_t kNot = kLocked | kClosed | kSeam;  // a seam is LegalSeam's
    if (flags_.Has(u, kNot) || flags_.Has(v, kNot)) return false;
    uint32_t a = UINT32_MAX, b = UINT32_MAX, fa = 0, fb = 0;
    int shared = 0;
    for (uint32_t f : vertex_faces_[u]) {
      const Face r = RotateTo(faces_[f], u);
      if (r[1] == v) { a = r[2]; ++shared; fa = f; }
      else if (r[2] == v) { b = r[1]; ++shared; fb = f; }
    }
    if (shared != 2 || a == UINT32_MAX || b == UINT32_MAX || a == b) return false;
    if (!SharedNeighbours(u, v, 2)) return false;
    const size_t valence = nu_.size() + nv_.size() - 4;
    if (valence < 3 || valence > static_cast<size_t>(options_.max_valence)) return false;
    if (!HasNeighbours(a, 4) || !HasNeighbours(b, 4)) return false;
    if (!MidpointKeepsOrientation(u, v)) return false;
    c = Collapse{u, v, FineCorner(fa, a), FineCorner(fb, b), DeltaOf(u, v)};
    return true;
  }

  void Apply(const Collapse& c) {
    const uint32_t u = c.u, v = c.v;
    std::vector<uint32_t>& gone = gone_;
    gone.clear();
    for (uint32_t f : vertex_faces_[u]) {
      const Face face = faces_[f];
      if (face[0] == v || face[1] == v || face[2] == v) gone.push_back(f);
    }
    for (uint32_t f : gone) {
      face_alive_[f] = 0;
      for (uint32_t x : faces_[f]) vertex_faces_.Remove(x, f);
    }
    for (uint32_t f : vertex_faces_[v]) {
      if (options_.rule == BatchRule::kMatching) batch_faces_.emplace(f, faces_[f]);  // FineCorner
      faces_.Rename(f, v, u);
    }
    vertex_faces_.MoveInto(u, v);
    for (int k = 0; k < 3; ++k) positions_[u][k] = Midpoint(positions_[u][k], positions_[v][k]);
    for (int k = 0; k < channels_; ++k) {
      int32_t& au = attributes_[size_t(u) * channels_ + k];
      au = Midpoint(au, attributes_[size_t(v) * channels_ + k]);
    }
    for (int k = 0; k < 10; ++k) quadrics_[u][k] += quadrics_[v][k];
    dirty_.push_back(u);
    dirty_.push_back(v);
  }

  // The channels of c.u and c.v before c is applied, into the batch.
  void RecordAttributes(const Collapse& c, CollapseBatch& batch) const {
    for (int k = 0; k < channels_; ++k) batch.attr_u.push_back(attributes_[size_t(c.u) * channels_ + k]);
    for (int k = 0; k < channels_; ++k) batch.attr_v.push_back(attributes_[size_t(c.v) * channels_ + k]);
  }

  static bool CandidateBefore(const Candidate& a, const Candidate& b) { return CandidateOrder()(a, b); }

  // Appends the candidate of edge (x, y) of a live face when it is one: x < y
  // in the face's order (an interior edge is seen once, from the face where
  // it runs upwards) and neither end locked.
  void AddCandidate(uint32_t x, uint32_t y, CandidateList& out) const {
    if (x > y || flags_.Has(x, kLocked) || flags_.Has(y, kLocked)) return;
    const double mx = 0.5 * (double(positions_[x][0]) + positions_[y][0]);
    const double my = 0.5 * (double(positions_[x][1]) + positions_[y][1]);
    const double mz = 0.5 * (double(positions_[x][2]) + positions_[y][2]);
    out.push_back({Evaluate(quadrics_[x], quadrics_[y], mx, my, mz), x, y});
  }

  // Every candidate edge, by cost: built once, then kept up to date by
  // UpdateCandidates (a batch changes only the costs of edges at the
  // vertices it collapsed), so that a batch costs O(E + k log k) for k
  // collapses instead of evaluating and sorting every edge again.
  void BuildCandidates() {
    size_t count = 0;
    for (size_t f = 0; f < faces_.size(); ++f) {
      if (!face_alive_[f]) continue;
      const Face face = faces_[f];
      for (int k = 0; k < 3; ++k) {
        const uint32_t x = face[k], y = face[(k + 1) % 3];
        count += (x < y && !flags_.Has(x, kLocked) && !flags_.Has(y, kLocked)) ? 1 : 0;
      }
    }
    candidates_.clear();
    candidates_.reserve(count);
    for (size_t f = 0; f < faces_.size(); ++f) {
      if (!face_alive_[f]) continue;
      const Face face = faces_[f];
      for (int k = 0; k < 3; ++k) AddCandidate(face[k], face[(k + 1) % 3], candidates_);
    }
    std::sort(candidates_.begin(), candidates_.end(), CandidateOrder());
  }

  // After Apply of a batch: drops the candidates at any vertex a collapse
  // touched (dirty_) and adds the surviving vertices' edges with their new
  // costs, merged in order; the list equals what BuildCandidates would make.
  void UpdateCandidates() {
    if (dirty_.empty()) return;
    for (uint32_t x : dirty_) flags_.Set(x, kTouched);
    // Drop the edges at collapsed vertices; forget "illegal" near any change.
    size_t kept = 0;
    for (size_t i = 0; i < candidates_.size(); ++i) {
      Candidate c = candidates_[i];
      if (flags_.Has(c.u, kTouched) || flags_.Has(c.v(), kTouched)) continue;
      if (flags_.Has(c.u, kChanged) || flags_.Has(c.v(), kChanged)) c.v_flags &= ~kKnownIllegal;
      candidates_[kept++] = c;
    }
    candidates_.resize(kept);
    // The surviving vertices' edges, a chunk of vertices at a time so that
    // the sorted fresh candidates stay a small share of the list (each chunk
    // costs one merge pass over it). The list hardly ever outgrows its
    // capacity: a fresh edge (u, x) replaces the (u, x) or (v, x) it dropped
    // (only a boundary edge that now runs upwards in its one triangle is new).
    const size_t chunk_edges = std::max<size_t>(1 << 16, candidates_.size() / 8);
    fresh_.reserve(chunk_edges + 64);
    size_t next = 0;
    while (next < dirty_.size()) {
      fresh_.clear();
      for (; next < dirty_.size() && fresh_.size() < chunk_edges; ++next) {
        const uint32_t x = dirty_[next];
        if (vertex_faces_[x].empty()) continue;  // collapsed away
        for (uint32_t f : vertex_faces_[x]) {
          const Face face = faces_[f];
          for (int k = 0; k < 3; ++k) {
            const uint32_t p = face[k], q = face[(k + 1) % 3];
            // Each edge once: from its smaller surviving end when both moved.
            const bool p_moved_too = flags_.Has(p, kTouched) && !vertex_faces_[p].empty();
            if (p == x || (q == x && !p_moved_too)) AddCandidate(p, q, fresh_);
          }
        }
      }
      std::sort(fresh_.begin(), fresh_.end(), CandidateOrder());
      // Merge from the back into the grown list: only fresh_ is extra memory.
      size_t i = candidates_.size(), j = fresh_.size();
      candidates_.resize(i + j);
      size_t out = i + j;
      while (j > 0) {
        if (i > 0 && CandidateBefore(fresh_[j - 1], candidates_[i - 1])) {
          candidates_[--out] = candidates_[--i];
        } else {
          candidates_[--out] = fresh_[--j];
        }
      }
    }
    // The list shrinks by a few edges per collapse while the batches grow:
    // give back what it no longer needs (in place: ShrinkableArray).
    candidates_.shrink_to_fit();
    for (uint32_t x : dirty_) flags_.Unset(x, kTouched);
    dirty_.clear();
    flags_.UnsetAll(kChanged);  // (a pass over a byte a vertex: cheaper than a list of the marks)
  }

  // After a collapse into u. Whether an edge (x, y) is legal reads the
  // triangle lists of x and y, the positions of their neighbours and the
  // number of neighbours of its wings. A collapse into u changes u's
  // position and triangles and the triangles of u's new ring (a vertex
  // renamed, a triangle gone), raises no valence but u's, and lowers its
  // two wings' (which never makes an edge legal). So an edge found illegal
  // can become legal only when an end is u or in u's ring: those are marked,
  // and their edges are checked again.
  void MarkChanged(uint32_t u) {
    for (uint32_t f : vertex_faces_[u])
      for (uint32_t x : faces_[f]) flags_.Set(x, kChanged);
    flags_.Set(u, kChanged);
  }

  // The next batch, or none when the strict rule finds fewer than
  // `min_collapses` (then nothing is applied).
  CollapseBatch NextBatch(size_t min_collapses, size_t alive) {
    if (!candidates_built_) {
      BuildCandidates();
      candidates_built_ = true;
    } else {
      UpdateCandidates();
      if (options_.check_candidates) {
        CandidateList kept;
        kept.swap(candidates_);
        BuildCandidates();
        const bool same = std::equal(kept.begin(), kept.end(), candidates_.begin(), candidates_.end(),
                                     [](const Candidate& a, const Candidate& b) {
                                       return a.u == b.u && a.v() == b.v() && a.cost == b.cost;
                                     });
        if (!same) candidates_differ_ = true;
        candidates_.swap(kept);  // go on with the kept list and its marks
      }
    }
    flags_.UnsetAll(kClosed | kBatchEnd);
    batch_faces_.clear();
    CollapseBatch batch;
    // Room for the batch at once, not grown by doubling and then copied to
    // its size (a second block at the peak): a batch collapses about a
    // seventh of the vertices left (at most a half: the strict rule; past a
    // quarter it grows as a vector does). The room it does not fill is
    // never written, so it costs address space, not resident memory (a copy
    // to size at the end of Run measured worse: new pages beside the old).
    batch.collapses.reserve(alive / 4 + 16);
    const bool matching = options_.rule == BatchRule::kMatching;
    // kMatching: at most this many collapses (SimplifyOptions::max_batch_share).
    const size_t most = matching && options_.max_batch_share < 1
                            ? std::max<size_t>(1, static_cast<size_t>(double(alive) * options_.max_batch_share))
                            : SIZE_MAX;
    for (Candidate& cand : candidates_) {
      if (batch.collapses.size() >= most) break;
      Collapse c;
      const uint32_t cv = cand.v();
      if (options_.rule != BatchRule::kPaper && flags_.Has(cand.u, kSeam) && flags_.Has(cv, kSeam)) {
        Collapse t;
        if (flags_.Has(cand.u, kClosed) || flags_.Has(cv, kClosed) || !LegalSeam(cand.u, cv, c, t)) continue;
        const uint32_t at = static_cast<uint32_t>(batch.collapses.size());
        c.twin = at + 1;
        t.twin = at;
        if (matching && (flags_.Has(c.a, kBatchEnd) || flags_.Has(t.a, kBatchEnd))) continue;
        for (uint32_t x : {c.u, c.v, t.u, t.v}) flags_.Set(x, kClosed);
        if (matching) {
          for (uint32_t x : {c.a, t.a}) flags_.Set(x, kClosed);
          for (uint32_t x : {c.u, c.v, t.u, t.v}) flags_.Set(x, kBatchEnd);
          RecordAttributes(c, batch);
          Apply(c);
          RecordAttributes(t, batch);
          Apply(t);
        } else {
          for (uint32_t x : seam_neighbours_) flags_.Set(x, kClosed);
        }
        batch.collapses.push_back(c);
        batch.collapses.push_back(t);
        continue;
      }
      if (flags_.Has(cand.u, kClosed) || flags_.Has(cv, kClosed)) continue;
      if (cand.v_flags & kKnownIllegal) {
        // (Tests: the mark must never hide a legal collapse.)
        if (options_.check_candidates && Legal(cand.u, cv, c)) candidates_differ_ = true;
        continue;
      }
      if (!Legal(cand.u, cv, c)) {
        // Illegal until a collapse next to u or v (MarkChanged).
        if (options_.rule == BatchRule::kStrict) cand.v_flags |= kKnownIllegal;
        continue;
      }
      flags_.Set(c.u, kClosed);
      flags_.Set(c.v, kClosed);
      if (matching) {
        // A wing of a collapse is never an end of another of its batch, nor
        // the reverse: the split of either then finds its wings and its two
        // sides the same whichever is applied first (the decoder's order is
        // the split vertices' ids, not this one).
        if (flags_.Has(c.a, kBatchEnd) || flags_.Has(c.b, kBatchEnd)) {
          flags_.Unset(c.u, kClosed);
          flags_.Unset(c.v, kClosed);
          continue;
        }
        flags_.Set(c.a, kClosed);
        flags_.Set(c.b, kClosed);
        flags_.Set(c.u, kBatchEnd);
        flags_.Set(c.v, kBatchEnd);
        // Applied at once, so that the next candidate is checked on the
        // mesh as it is now (its values recorded first: untouched by the
        // batch's other collapses, which share no vertex with it).
        RecordAttributes(c, batch);
        Apply(c);
      } else if (options_.rule == BatchRule::kStrict) {
        // Close every neighbour too: the produced vertices stay pairwise
        // non-adjacent in the coarser mesh.
        for (uint32_t x : nu_) flags_.Set(x, kClosed);
        for (uint32_t x : nv_) flags_.Set(x, kClosed);
      } else {
        // Neighbouring collapses change each other's surroundings: apply at
        // once, so that the next candidate is checked on the current mesh.
        // (The scan goes on over the list of the batch's start, as it always
        // did; the list is brought up to date before the next batch.)
        Apply(c);
      }
      batch.collapses.push_back(c);
    }
    // kPaper and kMatching applied their collapses one by one above
    // (kPaper without recording attributes).
    if (options_.rule != BatchRule::kStrict) {
      for (const Collapse& c : batch.collapses) MarkChanged(c.u);
      return batch;
    }
    if (batch.collapses.size() < min_collapses) return CollapseBatch();
    // Record attributes before applying anything (collapses are disjoint).
    for (const Collapse& c : batch.collapses) {
      for (int k = 0; k < channels_; ++k) {
        batch.attr_u.push_back(attributes_[size_t(c.u) * channels_ + k]);
        batch.attr_v.push_back(attributes_[size_t(c.v) * channels_ + k]);
      }
    }
    size_t room = 0;
    for (const Collapse& c : batch.collapses) room += vertex_faces_[c.u].size() + vertex_faces_[c.v].size();
    vertex_faces_.MakeRoom(room);
    for (const Collapse& c : batch.collapses) Apply(c);
    for (const Collapse& c : batch.collapses) MarkChanged(c.u);
    return batch;
  }

  const SimplifyOptions& options_;
  const int channels_;
  std::vector<Vec3i> positions_;
  std::vector<int32_t> attributes_;
  Triangles faces_;
  std::vector<uint32_t> gone_;  // Apply's
  std::vector<uint8_t> face_alive_;
  VertexFaces vertex_faces_;
  std::vector<Quadric> quadrics_;
  VertexFlags flags_;
  // (vertex, its seam twin) for every vertex that has one, by vertex (a
  // few boundary vertices: not a table of every vertex).
  std::vector<std::array<uint32_t, 2>> twins_;
  std::vector<uint32_t> seam_neighbours_;
  uint64_t removed_faces_ = 0;
  std::vector<std::array<uint32_t, 2>> pairs_;
  std::vector<uint32_t> nu_, nv_, common_;
  CandidateList candidates_, fresh_;  // by cost (CandidateBefore)
  bool candidates_built_ = false;
  bool candidates_differ_ = false;  // check_candidates found a difference
  std::vector<uint32_t> dirty_;    // vertices collapses touched since the list was made
  // kMatching: the triangles the batch has renamed so far, as they were
  // before it (FineCorner).
  std::unordered_map<uint32_t, Face> batch_faces_;
};

}  // namespace

StatusOr<Hierarchy> SimplifyInBatches(QuantizedMesh mesh, const SimplifyOptions& options) {
  if (mesh.face_count() == 0) return InvalidInput("nothing to simplify: the mesh has no triangle");
  if (options.base_ratio <= 0 || options.base_ratio > 1) return InvalidArgument("base ratio must be in (0, 1]");
  if (mesh.vertex_count() >= kKnownIllegal) return InvalidInput("too many vertices to simplify: at most 2^31 - 1");
  if (mesh.indices.size() > VertexFaces::kMaxEntries / 2) {
    return InvalidInput("too many triangles to simplify: " + std::to_string(mesh.face_count()) + " (at most " +
                        std::to_string(VertexFaces::kMaxEntries / 6) + ")");
  }
  Simplifier simplifier(std::move(mesh), options);
  return simplifier.Run();
}

}  // namespace meshstream
