// The connectivity that the progressive decoder refines, and that the encoder
// replays to produce exactly what the decoder will see: triangles plus, per
// vertex, the list of incident triangles.
//
// A vertex split of w with wings a and b (both neighbours of w) creates a new
// vertex n. Walk w's ring in the direction of its triangles (x -> y for every
// triangle (w, x, y)) from b to a: the triangles on that path move to n, and
// the triangles (w, n, a) and (n, w, b) are added. This is the exact inverse
// of collapsing the edge (w, n) whose left and right triangles were
// (w, n, a) and (n, w, b) (docs/spec/progressive-format.md, "Vertex split").
//
// Contract: pure, no allocation beyond its vectors. A split needs w to be a
// closed manifold fan: CyclicRing says so, and SplitAt may only follow a
// CyclicRing(w) that returned true. Thread safety: none.
#ifndef MESHSTREAM_CODEC_PROGRESSIVE_SPLIT_CONNECTIVITY_H_
#define MESHSTREAM_CODEC_PROGRESSIVE_SPLIT_CONNECTIVITY_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "codec/core/status.h"

#if defined(__GNUC__) || defined(__clang__)
// The empty asm makes the hint an effect: GCC deletes a loop whose body is
// only __builtin_prefetch (it has no side effect, and C++ loops are assumed
// to finish), which had silently removed PrefetchFaces since issue 11.
#define MESHSTREAM_PREFETCH(p)        \
  do {                                \
    __builtin_prefetch(p);            \
    asm volatile("" : : "r"(p));      \
  } while (0)
#else
#define MESHSTREAM_PREFETCH(p) ((void)(p))
#endif

namespace meshstream {

using Face = std::array<uint32_t, 3>;

class SplitConnectivity {
 public:
  // `indices` must refer to vertices below `vertex_count` (checked).
  Status Reset(uint32_t vertex_count, const std::vector<uint32_t>& indices);

  uint32_t vertex_count() const { return static_cast<uint32_t>(slots_.size()); }
  size_t face_count() const { return faces_.size(); }
  const std::vector<Face>& faces() const { return faces_; }
  // The triangles of v (ids into faces()), in no particular order.
  struct FaceList {
    const uint32_t* first;
    uint32_t count;
    const uint32_t* begin() const { return first; }
    const uint32_t* end() const { return first + count; }
    uint32_t size() const { return count; }
  };
  FaceList faces_of(uint32_t v) const { return {pool_.data() + slots_[v].offset, slots_[v].count}; }

  // What a ring walk needs besides the ring: the walk's scratch and the
  // ring's triangles, which SplitAt reads. The walks only read the
  // connectivity, so with one RingWalk each, rings can be walked
  // concurrently (a refinement's splits in parallel, docs/results/decode-profile.md).
  struct RingWalk {
    std::vector<uint32_t> xy;     // x then y per triangle of the ring
    std::vector<uint32_t> faces;  // triangle (w, ring[k], ring[k + 1])
    std::vector<uint32_t> table;  // large rings' (x, triangle) table; OpenRing's pairs
  };

  // The neighbours of w in cyclic order (x -> y over w's triangles), starting
  // at the first vertex of w's first triangle. Returns false (ring
  // unspecified) when the triangles of w do not form one closed fan. The
  // triangle (w, ring[k], ring[k + 1]) is remembered for SplitAt.
  bool CyclicRing(uint32_t w, std::vector<uint32_t>& ring) const { return CyclicRing(w, ring, walk_); }
  // The same with the caller's walk (its triangles then in walk.faces).
  bool CyclicRing(uint32_t w, std::vector<uint32_t>& ring, RingWalk& walk) const;
  // The neighbours of a boundary vertex w in order (x -> y over w's
  // triangles) from the one that no triangle of w enters (ring[0]) to the one
  // that none leaves (ring.back()): one more vertex than triangles. Returns
  // false (ring unspecified) when w's triangles do not form one open fan.
  // The triangle (w, ring[k], ring[k + 1]) is remembered for SplitOpenAt.
  // O(valence log valence).
  bool OpenRing(uint32_t w, std::vector<uint32_t>& ring) const;
  // The neighbours of w sorted by id (any connectivity).
  void SortedNeighbours(uint32_t w, std::vector<uint32_t>& out) const;

  // Splits w right after CyclicRing(w, ring) returned true, with the wings
  // given by their positions in the ring; the new vertex gets id
  // vertex_count(), which is returned.
  uint32_t SplitAt(uint32_t w, const std::vector<uint32_t>& ring, size_t a_at, size_t b_at) {
    return SplitAt(w, ring.data(), walk_.faces.data(), ring.size(), a_at, b_at);
  }
  // The same with the ring (`degree` entries) and its triangles as a
  // CyclicRing with its own walk found them (walk.faces), while nothing
  // changed w's triangles since.
  uint32_t SplitAt(uint32_t w, const uint32_t* ring, const uint32_t* ring_faces, size_t degree, size_t a_at,
                   size_t b_at);
  // Splits a boundary vertex w right after OpenRing(w, ring) returned true,
  // with the wing a = ring[a_at] (docs/spec/progressive-format.md, "Seam split"):
  // the triangles after a (toward ring.back()) move to the new vertex n when
  // `tail` is true, the triangles before a when it is false, and the
  // triangle (w, a, n) (tail) or (w, n, a) (head) is added. Returns n.
  uint32_t SplitOpenAt(uint32_t w, const std::vector<uint32_t>& ring, size_t a_at, bool tail);
  // A vertex without triangles (a split that LwoP abandoned keeps its id);
  // returns its id.
  uint32_t AddIsolatedVertex() { return NewSlot(0); }
  // Room for this many vertices in total, to avoid reallocation while refining.
  void Reserve(uint32_t vertices, size_t faces);

  std::vector<uint32_t> Indices() const;
  // The same into `out` (its capacity reused: no allocation once it fits).
  void IndicesInto(std::vector<uint32_t>& out) const;

  // Hints for a vertex about to be split (no effect on the state): its
  // slot, then its triangle list (reads the slot), then its triangles
  // (reads the list). A caller that knows the next splits issues them a few
  // splits ahead, one stage per split, so that the ring walk finds its
  // triangles in the cache. Ids beyond vertex_count() are ignored.
  void PrefetchSlot(uint32_t v) const {
    if (v < slots_.size()) MESHSTREAM_PREFETCH(&slots_[v]);
  }
  void PrefetchList(uint32_t v) const {
    if (v < slots_.size()) MESHSTREAM_PREFETCH(pool_.data() + slots_[v].offset);
  }
  void PrefetchFaces(uint32_t v) const {
    if (v >= slots_.size()) return;
    for (uint32_t f : faces_of(v)) MESHSTREAM_PREFETCH(&faces_[f]);
  }
  // Hints values[x] for the corners x of v's triangles (x < count).
  template <typename T>
  void PrefetchCorners(uint32_t v, const T* values, size_t count) const {
    if (v >= slots_.size()) return;
    for (uint32_t f : faces_of(v))
      for (uint32_t x : faces_[f])
        if (x < count) MESHSTREAM_PREFETCH(values + x);
  }

 private:
  // Per-vertex triangle lists live in one pool: a vertex owns `capacity`
  // entries from `offset`, and moves to the end of the pool with twice the
  // room when it outgrows them (no allocation per vertex; the pool itself
  // grows geometrically).
  struct Slot {
    uint32_t offset = 0, count = 0, capacity = 0;
  };
  void Append(uint32_t v, uint32_t face);
  // Moves v's list to the end of the pool with room for at least `needed`.
  void Grow(uint32_t v, uint32_t needed);
  uint32_t NewSlot(uint32_t capacity);
  // The offset of `entries` fresh pool entries.
  uint32_t Take(uint32_t entries);

  std::vector<Face> faces_;
  std::vector<uint32_t> pool_;
  uint32_t pool_end_ = 0;  // entries of pool_ in use; the rest is spare room
  std::vector<Slot> slots_;
  mutable RingWalk walk_;  // the last ring's walk (CyclicRing and OpenRing without a walk of their own)
  mutable std::vector<uint32_t> sorted_ys_;   // OpenRing's y's, sorted
  static constexpr uint32_t kMinCapacity = 8;  // entries per vertex, at least
  static constexpr uint32_t kEmpty = UINT32_MAX;
};

// A triangle that names a vertex twice: it has no area, and the encoder
// removes it before simplifying (docs/design/codec.md, "Locks and clean-up").
inline bool RepeatsAnIndex(const Face& f) { return f[0] == f[1] || f[1] == f[2] || f[0] == f[2]; }

// Rotates a face so that vertex v comes first; v must be in the face.
inline Face RotateTo(const Face& f, uint32_t v) {
  if (f[0] == v) return f;
  if (f[1] == v) return {f[1], f[2], f[0]};
  return {f[2], f[0], f[1]};
}

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_PROGRESSIVE_SPLIT_CONNECTIVITY_H_
