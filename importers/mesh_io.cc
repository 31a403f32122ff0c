// OBJ, PLY, OFF and STL into a one-primitive Scene (see importers/mesh_io.h).
//
// Contract (the parts mesh_io.h leaves open):
// - Parsing is done by libraries: OpenMesh's PLY, OFF and STL readers feed
//   MeshRecorder, our own OpenMesh::IO::BaseImporter that only appends to
//   plain arrays (no half-edge structure: non-manifold faces stay, vertices
//   are never duplicated or dropped); tinyobjloader reads OBJ.
// - Before a library sees a byte, this file reads the header itself and walks
//   the body just enough to prove that every declared count and every list
//   length fits in the bytes present, and that every number the library will
//   parse with `std::istream >>` really is a finite decimal number in float
//   range (a failed `>>` would silently desynchronise OpenMesh's readers).
//   What the libraries do not guard is refused here with an error naming the
//   file and the problem: a PLY header without end_header makes OpenMesh
//   loop forever, a huge list length makes it allocate without bound, an OBJ
//   "t" line makes tinyobjloader allocate 300 KiB for 20 bytes.
// - PLY: OpenMesh reads a canonical copy of the header that we write from
//   our own parse (comments, obj_info, CRLF and blank lines dropped), so its
//   token-based header parser and its binary-offset arithmetic cannot
//   disagree with ours; the body bytes are the file's, not copied.
// - Kept: every vertex, including unreferenced ones, in file order; faces in
//   file order, polygons fanned (c0, ci, ci+1); PLY/OFF vertex normals,
//   colours and texture coordinates; OBJ texture coordinates, normals and
//   vertex colours, unified per vertex by splitting a position where its
//   (uv, normal) pairs differ: vertex i < source_vertices is the file's
//   position i with the attributes of its first corner, splits are appended
//   in order of first use. Normals are scaled to unit length as glTF
//   requires (one warning says how many were not). Texture coordinates are
//   stored as in the file (no V flip). Colours (8-bit, or floats in [0, 1])
//   are taken as sRGB and converted to linear RGBA (mesh.h: COLOR_0 is
//   linear).
// - STL: OpenMesh merges corners with equal positions into one vertex and
//   drops triangles that become degenerate by it; the count of dropped
//   triangles goes to Scene::warnings. source_vertices is the merged count.
// - Refused (InvalidInput unless noted): empty files; files above
//   ImportOptions::max_input_bytes (ResourceExhausted, before reading);
//   counts that the bytes present cannot hold; truncated bodies; non-finite
//   or out-of-float-range numbers; faces with fewer than 3 corners or an
//   index out of range (the message names the face, 0-based in file order);
//   files with vertices but no faces ("no triangles").
// - PLY triangle strips: OpenMesh's reader knows only 'face' elements, so an
//   element 'tristrips' (one integer list 'vertex_indices', -1 restarts a
//   strip) is read here while walking the body, hidden from the header
//   OpenMesh reads (it must be the last element, so the bytes OpenMesh reads
//   are unchanged), and turned into triangles as glTF does TRIANGLE_STRIP
//   (odd triangles swap their first two corners; triangles repeating a
//   vertex are skipped). They follow the faces of the 'face' element, which
//   may then be absent. A strip index out of range names the strip record.
//   Unsupported: PLY tristrips that are not the last element or have other
//   properties; PLY list properties other than face and tristrips
//   vertex_indices; face
//   properties declared before vertex_indices (OpenMesh forgets them and
//   misreads the records); binary PLY coordinates that are not float/double;
//   binary OFF, OFF comments and the STOFF/4OFF/nOFF variants; OBJ tag lines.
// - No exception leaves this file: library calls are wrapped in try/catch.
// - Thread safety: OpenMesh's readers are process-wide singletons with
//   mutable state and its log streams are global, so every OpenMesh read runs
//   under one mutex with omerr/omlog/omout silenced for its duration. OBJ
//   imports run fully in parallel.
// - OFF is the one format OpenMesh must read by file name: its reader takes
//   the header variant (NOFF, COFF) only from can_u_read(filename), never
//   from a stream. The bytes were validated just before; MeshRecorder also
//   refuses more vertices, faces or corners than were validated, so a file
//   replaced between the check and the read cannot grow our arrays.
#include "importers/mesh_io.h"

#include <OpenMesh/Core/IO/Options.hh>
#include <OpenMesh/Core/IO/importer/BaseImporter.hh>
#include <OpenMesh/Core/IO/reader/OFFReader.hh>
#include <OpenMesh/Core/IO/reader/PLYReader.hh>
#include <OpenMesh/Core/IO/reader/STLReader.hh>
#include <OpenMesh/Core/System/omstream.hh>
#include <tiny_obj_loader.h>

#include <algorithm>
#include <cctype>
#include <cfloat>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <exception>
#include <istream>
#include <limits>
#include <locale>
#include <mutex>
#include <new>
#include <streambuf>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

namespace meshstream {
namespace {

// ============================================================ [1] helpers

constexpr uint64_t kU32Max = std::numeric_limits<uint32_t>::max();

bool IsSpaceChar(char c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f';
}
bool IsDigit(char c) { return c >= '0' && c <= '9'; }

// A token for an error message: quoted, at most 40 characters, printable.
std::string Quote(std::string_view s) {
  std::string out = "'";
  const size_t n = std::min<size_t>(s.size(), 40);
  for (size_t i = 0; i < n; ++i) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    out += (c >= 0x20 && c < 0x7f) ? static_cast<char>(c) : '?';
  }
  if (s.size() > n) out += "...";
  return out + "'";
}

std::string Num(uint64_t v) { return std::to_string(v); }

Status Bad(const std::string& path, const std::string& what) { return InvalidInput(path + ": " + what); }
Status Refuse(const std::string& path, const std::string& what) {
  return Unsupported(path + ": " + what);
}

// a * b + *acc without overflow; false when it would overflow.
bool MulAdd(uint64_t a, uint64_t b, uint64_t* acc) {
  uint64_t product = 0;
  if (__builtin_mul_overflow(a, b, &product)) return false;
  return !__builtin_add_overflow(*acc, product, acc);
}

// Digits only (what OpenMesh's `>> unsigned int` reads without surprise), at
// most 2^32 - 1.
bool ParseU32(std::string_view t, uint32_t* out) {
  if (t.empty() || t.size() > 10) return false;
  uint64_t v = 0;
  for (char c : t) {
    if (!IsDigit(c)) return false;
    v = v * 10 + static_cast<uint64_t>(c - '0');
  }
  if (v > kU32Max) return false;
  *out = static_cast<uint32_t>(v);
  return true;
}

// [+-]digits within int32 (what `>> int` reads).
bool IsInt32Token(std::string_view t) {
  const bool negative = !t.empty() && t[0] == '-';
  if (!t.empty() && (t[0] == '+' || t[0] == '-')) t.remove_prefix(1);
  if (t.empty() || t.size() > 10) return false;
  uint64_t v = 0;
  for (char c : t) {
    if (!IsDigit(c)) return false;
    v = v * 10 + static_cast<uint64_t>(c - '0');
  }
  return v <= (negative ? uint64_t{2147483648} : uint64_t{2147483647});
}

enum class NumberCheck { kOk, kNotDecimal, kOutOfRange };

// A decimal number as `std::istream >> float` reads it completely:
// [+-]? (d+ (. d*)? | . d+) ([eE] [+-]? d+)?, and within float range
// (`>> float` fails on overflow; underflow to 0 is fine). "nan", "inf" and
// hexadecimal floats are not decimal numbers.
NumberCheck CheckDecimal(std::string_view t) {
  size_t i = 0;
  if (i < t.size() && (t[i] == '+' || t[i] == '-')) ++i;
  const size_t mantissa_begin = i;
  size_t int_digits = 0, frac_digits = 0;
  while (i < t.size() && IsDigit(t[i])) ++i, ++int_digits;
  if (i < t.size() && t[i] == '.') {
    ++i;
    while (i < t.size() && IsDigit(t[i])) ++i, ++frac_digits;
  }
  if (int_digits + frac_digits == 0) return NumberCheck::kNotDecimal;
  const size_t mantissa_end = i;
  int64_t exponent = 0;
  if (i < t.size() && (t[i] == 'e' || t[i] == 'E')) {
    ++i;
    bool negative = false;
    if (i < t.size() && (t[i] == '+' || t[i] == '-')) negative = t[i++] == '-';
    size_t exp_digits = 0;
    while (i < t.size() && IsDigit(t[i])) {
      if (exponent < 100000) exponent = exponent * 10 + (t[i] - '0');
      ++i, ++exp_digits;
    }
    if (exp_digits == 0) return NumberCheck::kNotDecimal;
    if (negative) exponent = -exponent;
  }
  if (i != t.size()) return NumberCheck::kNotDecimal;

  // Decimal magnitude: position of the first non-zero mantissa digit.
  int64_t magnitude = 0;
  bool nonzero = false;
  int64_t position = static_cast<int64_t>(int_digits);  // digits before the point
  for (size_t k = mantissa_begin; k < mantissa_end; ++k) {
    if (t[k] == '.') continue;
    --position;
    if (t[k] != '0') {
      magnitude = position;  // the first non-zero digit is d * 10^position
      nonzero = true;
      break;
    }
  }
  if (!nonzero) return NumberCheck::kOk;  // zero
  magnitude += exponent;
  if (magnitude < 37) return NumberCheck::kOk;
  if (magnitude > 38) return NumberCheck::kOutOfRange;
  // Close to FLT_MAX: let the library-independent parser decide.
  double value = 0;
  std::string_view digits = t;
  if (!digits.empty() && digits[0] == '+') digits.remove_prefix(1);
  const auto result = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  if (result.ec != std::errc() || !(std::fabs(value) <= FLT_MAX)) return NumberCheck::kOutOfRange;
  return NumberCheck::kOk;
}

std::string DescribeBadNumber(NumberCheck check, std::string_view token) {
  if (check == NumberCheck::kOutOfRange) return Quote(token) + " is outside the float range";
  return Quote(token) + " is not a finite decimal number";
}

// Whitespace-separated tokens over a byte range, counting lines.
class Tokens {
 public:
  Tokens(std::string_view text, size_t first_line) : text_(text), line_(first_line) {}

  // The next token, or an empty view at the end.
  std::string_view Next() {
    while (pos_ < text_.size() && IsSpaceChar(text_[pos_])) {
      if (text_[pos_] == '\n') ++line_;
      ++pos_;
    }
    const size_t begin = pos_;
    while (pos_ < text_.size() && !IsSpaceChar(text_[pos_])) ++pos_;
    return text_.substr(begin, pos_ - begin);
  }

  // The rest of the current line (as std::getline would return it) and moves
  // past its '\n'.
  std::string_view RestOfLine() {
    const size_t begin = pos_;
    while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
    std::string_view rest = text_.substr(begin, pos_ - begin);
    if (pos_ < text_.size()) {
      ++pos_;
      ++line_;
    }
    return rest;
  }

  size_t line() const { return line_; }

 private:
  std::string_view text_;
  size_t pos_ = 0;
  size_t line_;
};

std::vector<std::string_view> SplitWords(std::string_view line) {
  std::vector<std::string_view> words;
  Tokens tokens(line, 1);
  for (std::string_view t = tokens.Next(); !t.empty(); t = tokens.Next()) words.push_back(t);
  return words;
}

// An std::streambuf reading two byte ranges back to back (a header we
// rewrote, then the file's own body) without copying them; supports the
// seeks and tells that OpenMesh's PLY reader makes.
class TwoPartStreamBuf final : public std::streambuf {
 public:
  TwoPartStreamBuf(std::string_view head, std::string_view body) : head_(head), body_(body) {
    if (head_.empty()) {
      Select(1, 0);
    } else {
      Select(0, 0);
    }
  }

 protected:
  int_type underflow() override {
    if (gptr() < egptr()) return traits_type::to_int_type(*gptr());
    if (part_ == 0 && !body_.empty()) {
      Select(1, 0);
      return traits_type::to_int_type(*gptr());
    }
    return traits_type::eof();
  }

  pos_type seekoff(off_type off, std::ios_base::seekdir dir, std::ios_base::openmode which) override {
    if (!(which & std::ios_base::in)) return pos_type(off_type(-1));
    off_type base = 0;
    if (dir == std::ios_base::cur) {
      base = Position();
    } else if (dir == std::ios_base::end) {
      base = static_cast<off_type>(head_.size() + body_.size());
    }
    return seekpos(pos_type(base + off), which);
  }

  pos_type seekpos(pos_type pos, std::ios_base::openmode which) override {
    const off_type target = off_type(pos);
    const off_type total = static_cast<off_type>(head_.size() + body_.size());
    if (!(which & std::ios_base::in) || target < 0 || target > total) return pos_type(off_type(-1));
    const size_t t = static_cast<size_t>(target);
    if (t < head_.size() || (t == head_.size() && body_.empty() && !head_.empty())) {
      Select(0, t);
    } else {
      Select(1, t - head_.size());
    }
    return pos;
  }

 private:
  void Select(int part, size_t offset) {
    part_ = part;
    std::string_view s = part == 0 ? head_ : body_;
    char* begin = const_cast<char*>(s.data());  // never written through
    setg(begin, begin + offset, begin + s.size());
  }
  off_type Position() const {
    const off_type in_part = static_cast<off_type>(gptr() - eback());
    return part_ == 0 ? in_part : static_cast<off_type>(head_.size()) + in_part;
  }

  std::string_view head_;
  std::string_view body_;
  int part_ = 0;
};

// sRGB-encoded channel in [0, 1] to linear.
float SrgbToLinear(float c) {
  if (c <= 0.04045f) return c / 12.92f;
  return static_cast<float>(std::pow((static_cast<double>(c) + 0.055) / 1.055, 2.4));
}

// =========================================== [2] MeshRecorder (BaseImporter)

// Thrown by MeshRecorder to stop a library that delivers more than was
// validated; caught at the importer boundary.
struct RecorderLimit {
  std::string message;
};

// Records what an OpenMesh reader delivers into plain arrays. Never builds
// connectivity, so it keeps every vertex and every face exactly as read.
class MeshRecorder final : public OpenMesh::IO::BaseImporter {
 public:
  using VertexHandle = OpenMesh::VertexHandle;
  using HalfedgeHandle = OpenMesh::HalfedgeHandle;
  using EdgeHandle = OpenMesh::EdgeHandle;
  using FaceHandle = OpenMesh::FaceHandle;

  MeshRecorder(uint64_t max_vertices, uint64_t max_faces, uint64_t max_corners)
      : max_vertices_(max_vertices), max_faces_(max_faces), max_corners_(max_corners) {}

  template <typename T>
  struct Attribute {
    std::vector<T> values;
    std::vector<uint8_t> set;
    size_t count = 0;
    void Set(size_t vertex, const T& value, size_t vertex_count) {
      if (vertex >= vertex_count) return;
      if (values.size() < vertex_count) {
        values.resize(vertex_count);
        set.resize(vertex_count, 0);
      }
      values[vertex] = value;
      if (!set[vertex]) {
        set[vertex] = 1;
        ++count;
      }
    }
  };

  std::vector<Vec3f> positions;
  Attribute<Vec3f> normals;
  Attribute<Vec4f> colors;  // linear RGBA
  Attribute<Vec2f> texcoords;
  std::vector<size_t> face_starts;  // into corners; face i is [starts[i], starts[i+1])
  std::vector<int> corners;

  size_t face_corner_count(size_t f) const {
    const size_t end = f + 1 < face_starts.size() ? face_starts[f + 1] : corners.size();
    return end - face_starts[f];
  }

  // --- vertices
  VertexHandle add_vertex(const OpenMesh::Vec3f& p) override {
    if (positions.size() >= max_vertices_) {
      throw RecorderLimit{"the reader delivered more than the " + Num(max_vertices_) +
                          " vertices that were validated"};
    }
    positions.push_back({p[0], p[1], p[2]});
    return VertexHandle(static_cast<int>(positions.size() - 1));
  }
  VertexHandle add_vertex(const OpenMesh::Vec3d& p) override {
    return add_vertex(OpenMesh::Vec3f(static_cast<float>(p[0]), static_cast<float>(p[1]),
                                      static_cast<float>(p[2])));
  }
  VertexHandle add_vertex() override { return add_vertex(OpenMesh::Vec3f(0.f, 0.f, 0.f)); }
  void set_point(VertexHandle vh, const OpenMesh::Vec3f& p) override {
    if (Valid(vh)) positions[static_cast<size_t>(vh.idx())] = {p[0], p[1], p[2]};
  }
  void set_normal(VertexHandle vh, const OpenMesh::Vec3f& n) override {
    if (Valid(vh)) normals.Set(static_cast<size_t>(vh.idx()), {n[0], n[1], n[2]}, positions.size());
  }
  void set_normal(VertexHandle vh, const OpenMesh::Vec3d& n) override {
    set_normal(vh, OpenMesh::Vec3f(static_cast<float>(n[0]), static_cast<float>(n[1]),
                                   static_cast<float>(n[2])));
  }
  void set_color(VertexHandle vh, const OpenMesh::Vec3uc& c) override {
    SetColor(vh, c[0] / 255.f, c[1] / 255.f, c[2] / 255.f, 1.f);
  }
  void set_color(VertexHandle vh, const OpenMesh::Vec4uc& c) override {
    SetColor(vh, c[0] / 255.f, c[1] / 255.f, c[2] / 255.f, c[3] / 255.f);
  }
  void set_color(VertexHandle vh, const OpenMesh::Vec3f& c) override { SetColor(vh, c[0], c[1], c[2], 1.f); }
  void set_color(VertexHandle vh, const OpenMesh::Vec4f& c) override {
    SetColor(vh, c[0], c[1], c[2], c[3]);
  }
  void set_texcoord(VertexHandle vh, const OpenMesh::Vec2f& t) override {
    if (Valid(vh)) texcoords.Set(static_cast<size_t>(vh.idx()), {t[0], t[1]}, positions.size());
  }
  void set_texcoord(VertexHandle vh, const OpenMesh::Vec3f& t) override {
    set_texcoord(vh, OpenMesh::Vec2f(t[0], t[1]));
  }

  // --- faces
  FaceHandle add_face(const VHandles& handles) override {
    if (face_starts.size() >= max_faces_) {
      throw RecorderLimit{"the reader delivered more than the " + Num(max_faces_) +
                          " faces that were validated"};
    }
    if (corners.size() + handles.size() > max_corners_) {
      throw RecorderLimit{"the reader delivered more than the " + Num(max_corners_) +
                          " face corners that were validated"};
    }
    face_starts.push_back(corners.size());
    for (const VertexHandle& h : handles) corners.push_back(h.idx());
    return FaceHandle(static_cast<int>(face_starts.size() - 1));
  }

  // --- what the PLY/OFF/STL readers never call for our options (the OM and
  // OBJ readers do): accepted and ignored.
  HalfedgeHandle add_edge(VertexHandle, VertexHandle) override { return HalfedgeHandle(); }
  FaceHandle add_face(HalfedgeHandle) override { return FaceHandle(); }
  void add_face_texcoords(FaceHandle, VertexHandle, const std::vector<OpenMesh::Vec2f>&) override {}
  void add_face_texcoords(FaceHandle, VertexHandle, const std::vector<OpenMesh::Vec3f>&) override {}
  void set_face_texindex(FaceHandle, int) override {}
  void set_halfedge(VertexHandle, HalfedgeHandle) override {}
  void set_status(VertexHandle, const OpenMesh::Attributes::StatusInfo&) override {}
  void set_next(HalfedgeHandle, HalfedgeHandle) override {}
  void set_face(HalfedgeHandle, FaceHandle) override {}
  void request_face_texcoords2D() override {}
  void set_texcoord(HalfedgeHandle, const OpenMesh::Vec2f&) override {}
  void set_texcoord(HalfedgeHandle, const OpenMesh::Vec3f&) override {}
  void set_status(HalfedgeHandle, const OpenMesh::Attributes::StatusInfo&) override {}
  void set_color(EdgeHandle, const OpenMesh::Vec3uc&) override {}
  void set_color(EdgeHandle, const OpenMesh::Vec4uc&) override {}
  void set_color(EdgeHandle, const OpenMesh::Vec3f&) override {}
  void set_color(EdgeHandle, const OpenMesh::Vec4f&) override {}
  void set_status(EdgeHandle, const OpenMesh::Attributes::StatusInfo&) override {}
  void set_normal(FaceHandle, const OpenMesh::Vec3f&) override {}
  void set_normal(FaceHandle, const OpenMesh::Vec3d&) override {}
  void set_color(FaceHandle, const OpenMesh::Vec3uc&) override {}
  void set_color(FaceHandle, const OpenMesh::Vec4uc&) override {}
  void set_color(FaceHandle, const OpenMesh::Vec3f&) override {}
  void set_color(FaceHandle, const OpenMesh::Vec4f&) override {}
  void set_status(FaceHandle, const OpenMesh::Attributes::StatusInfo&) override {}
  void add_texture_information(int, std::string) override {}

  // Reserves no more than was validated, whatever the reader asks for.
  void reserve(unsigned int vertices, unsigned int, unsigned int faces) override {
    positions.reserve(std::min<uint64_t>(vertices, max_vertices_));
    face_starts.reserve(std::min<uint64_t>(faces, max_faces_));
  }

  size_t n_vertices() const override { return positions.size(); }
  size_t n_faces() const override { return face_starts.size(); }
  size_t n_edges() const override { return 0; }

 private:
  bool Valid(VertexHandle vh) const {
    return vh.idx() >= 0 && static_cast<size_t>(vh.idx()) < positions.size();
  }
  void SetColor(VertexHandle vh, float r, float g, float b, float a) {
    if (!Valid(vh)) return;
    colors.Set(static_cast<size_t>(vh.idx()), {SrgbToLinear(r), SrgbToLinear(g), SrgbToLinear(b), a},
               positions.size());
  }

  uint64_t max_vertices_;
  uint64_t max_faces_;
  uint64_t max_corners_;
};

// Silences OpenMesh's global log streams for the lifetime of the object.
class OpenMeshQuiet {
 public:
  OpenMeshQuiet()
      : err_(omerr().is_enabled()), log_(omlog().is_enabled()), out_(omout().is_enabled()) {
    omerr().disable();
    omlog().disable();
    omout().disable();
  }
  ~OpenMeshQuiet() {
    if (err_) omerr().enable();
    if (log_) omlog().enable();
    if (out_) omout().enable();
  }
  OpenMeshQuiet(const OpenMeshQuiet&) = delete;
  OpenMeshQuiet& operator=(const OpenMeshQuiet&) = delete;

 private:
  bool err_, log_, out_;
};

std::mutex& OpenMeshMutex() {
  static std::mutex mutex;
  return mutex;
}

// Runs `read` (a call into an OpenMesh reader returning its bool) under the
// OpenMesh lock, turning every exception into a Status.
template <typename ReadFn>
Status RunOpenMeshReader(const std::string& path, const char* format, ReadFn read) {
  try {
    std::lock_guard<std::mutex> lock(OpenMeshMutex());
    OpenMeshQuiet quiet;
    if (!read()) {
      return Bad(path, std::string("OpenMesh's ") + format + " reader could not read the file");
    }
  } catch (const RecorderLimit& e) {
    return Bad(path, e.message + " (the file changed while it was read, or the library read it "
                                 "differently from our check)");
  } catch (const std::bad_alloc&) {
    return ResourceExhausted(path + ": out of memory while reading the " + format + " data");
  } catch (const std::exception& e) {
    return Internal(path + ": OpenMesh's " + format + " reader failed: " + e.what());
  } catch (...) {
    return Internal(path + ": OpenMesh's " + format + " reader failed with an unknown exception");
  }
  return Status::Ok();
}

// Faces of the recorder fanned into triangles, every index checked.
StatusOr<Primitive> PrimitiveFromRecorder(const std::string& path, MeshRecorder& rec,
                                          std::vector<std::string>* warnings) {
  Primitive prim;
  const size_t n = rec.positions.size();
  prim.positions = std::move(rec.positions);
  uint64_t triangles = 0;
  for (size_t f = 0; f < rec.face_starts.size(); ++f) {
    const size_t k = rec.face_corner_count(f);
    if (k < 3) {
      return Bad(path, "face " + Num(f) + " has " + Num(k) + " corners (a face needs at least 3)");
    }
    triangles += k - 2;
  }
  prim.indices.reserve(static_cast<size_t>(triangles * 3));
  for (size_t f = 0; f < rec.face_starts.size(); ++f) {
    const size_t begin = rec.face_starts[f];
    const size_t k = rec.face_corner_count(f);
    for (size_t c = 0; c < k; ++c) {
      const int index = rec.corners[begin + c];
      if (index < 0 || static_cast<size_t>(index) >= n) {
        // OpenMesh hands indices over as int; above 2^31 they arrive negative.
        const uint64_t shown = static_cast<uint32_t>(index);
        return Bad(path, "face " + Num(f) + ": corner " + Num(c) + " names vertex " + Num(shown) +
                             ", out of range (the file has " + Num(n) + " vertices)");
      }
    }
    const uint32_t c0 = static_cast<uint32_t>(rec.corners[begin]);
    for (size_t c = 1; c + 1 < k; ++c) {
      prim.indices.push_back(c0);
      prim.indices.push_back(static_cast<uint32_t>(rec.corners[begin + c]));
      prim.indices.push_back(static_cast<uint32_t>(rec.corners[begin + c + 1]));
    }
  }
  auto take = [&](auto& attribute, const char* name, auto* out) {
    if (attribute.count == 0) return;
    if (attribute.count != n) {
      warnings->push_back(std::string("dropped ") + name + ": only " + Num(attribute.count) + " of " +
                          Num(n) + " vertices have one");
      return;
    }
    attribute.values.resize(n);
    *out = std::move(attribute.values);
  };
  take(rec.normals, "normals", &prim.normals);
  take(rec.colors, "colours", &prim.colors);
  std::vector<Vec2f> uv;
  take(rec.texcoords, "texture coordinates", &uv);
  if (!uv.empty()) prim.texcoords.push_back(std::move(uv));
  return prim;
}

// ================================================================ [3] PLY

enum class PlyFormat { kAscii, kBinaryLittleEndian, kBinaryBigEndian };

struct PlyType {
  const char* name;
  int size;
  bool is_float;
  bool is_signed;
};

// The type names OpenMesh's PLY reader knows (get_property_type).
const PlyType kPlyTypes[] = {
    {"char", 1, false, true},     {"int8", 1, false, true},    {"uchar", 1, false, false},
    {"uint8", 1, false, false},   {"short", 2, false, true},   {"int16", 2, false, true},
    {"ushort", 2, false, false},  {"uint16", 2, false, false}, {"int", 4, false, true},
    {"int32", 4, false, true},    {"uint", 4, false, false},   {"uint32", 4, false, false},
    {"float", 4, true, true},     {"float32", 4, true, true},  {"double", 8, true, true},
    {"float64", 8, true, true},
};

const PlyType* FindPlyType(std::string_view name) {
  for (const PlyType& t : kPlyTypes) {
    if (name == t.name) return &t;
  }
  return nullptr;
}

struct PlyProperty {
  std::string name;
  const PlyType* type = nullptr;        // the value type (entry type of a list)
  const PlyType* count_type = nullptr;  // set for lists
  bool is_list() const { return count_type != nullptr; }
};

struct PlyElement {
  std::string name;
  uint32_t count = 0;
  std::vector<PlyProperty> properties;
};

struct PlyHeader {
  PlyFormat format = PlyFormat::kAscii;
  std::vector<PlyElement> elements;
  size_t body_offset = 0;   // first byte after the end_header line
  size_t header_lines = 0;  // lines up to and including end_header
};

const char* PlyFormatName(PlyFormat f) {
  switch (f) {
    case PlyFormat::kAscii: return "ascii";
    case PlyFormat::kBinaryLittleEndian: return "binary_little_endian";
    case PlyFormat::kBinaryBigEndian: return "binary_big_endian";
  }
  return "ascii";
}

// Line-by-line, strict: every line is one of ply / format / comment /
// obj_info / element / property / end_header with the right number of words.
StatusOr<PlyHeader> ParsePlyHeader(const std::string& path, std::string_view data) {
  PlyHeader header;
  size_t pos = 0;
  size_t line_no = 0;
  bool have_format = false;
  auto where = [&]() { return "PLY header line " + Num(line_no) + ": "; };
  while (true) {
    if (pos >= data.size()) return Bad(path, "PLY header has no end_header line");
    size_t end = data.find('\n', pos);
    const bool last = end == std::string_view::npos;
    if (last) end = data.size();
    std::string_view line = data.substr(pos, end - pos);
    pos = last ? data.size() : end + 1;
    ++line_no;
    if (line_no > 100000) return Bad(path, "PLY header is longer than 100000 lines");
    const std::vector<std::string_view> w = SplitWords(line);
    if (line_no == 1) {
      if (w.size() != 1 || w[0] != "ply") return Bad(path, "not a PLY file (the first line is not 'ply')");
      continue;
    }
    if (line_no == 2) {
      if (w.size() != 3 || w[0] != "format") {
        return Bad(path, where() + "expected 'format <ascii|binary_little_endian|binary_big_endian> 1.0'");
      }
      if (w[1] == "ascii") {
        header.format = PlyFormat::kAscii;
      } else if (w[1] == "binary_little_endian") {
        header.format = PlyFormat::kBinaryLittleEndian;
      } else if (w[1] == "binary_big_endian") {
        header.format = PlyFormat::kBinaryBigEndian;
      } else {
        return Bad(path, where() + "unknown format " + Quote(w[1]));
      }
      if (CheckDecimal(w[2]) != NumberCheck::kOk) return Bad(path, where() + "bad version " + Quote(w[2]));
      have_format = true;
      continue;
    }
    if (w.empty()) continue;
    if (w[0] == "comment" || w[0] == "obj_info") continue;
    if (w[0] == "end_header") {
      if (w.size() != 1) return Bad(path, where() + "'end_header' must stand alone");
      header.body_offset = pos;
      header.header_lines = line_no;
      break;
    }
    if (w[0] == "element") {
      if (w.size() != 3) return Bad(path, where() + "expected 'element <name> <count>'");
      PlyElement element;
      element.name = std::string(w[1]);
      if (!ParseU32(w[2], &element.count)) {
        return Bad(path, where() + "element " + Quote(w[1]) + " has count " + Quote(w[2]) +
                             ", not an integer between 0 and " + Num(kU32Max));
      }
      header.elements.push_back(std::move(element));
      continue;
    }
    if (w[0] == "property") {
      if (header.elements.empty()) return Bad(path, where() + "property before any element");
      PlyElement& element = header.elements.back();
      PlyProperty property;
      std::string_view type_name;
      if (w.size() == 5 && w[1] == "list") {
        property.count_type = FindPlyType(w[2]);
        type_name = w[3];
        property.name = std::string(w[4]);
        // OpenMesh's reader accepts only these list length types.
        if (w[2] != "uchar" && w[2] != "uint8" && w[2] != "uint16" && w[2] != "int") {
          return Refuse(path, where() + "list length type " + Quote(w[2]) +
                                  " is not supported (use uchar, uint8, uint16 or int)");
        }
      } else if (w.size() == 3 && w[1] != "list") {
        type_name = w[1];
        property.name = std::string(w[2]);
      } else {
        return Bad(path, where() + "expected 'property <type> <name>' or 'property list <type> <type> <name>'");
      }
      property.type = FindPlyType(type_name);
      if (property.type == nullptr) {
        return Refuse(path, where() + "property " + Quote(property.name) + " has type " + Quote(type_name) +
                                ", which is not supported");
      }
      if (FindPlyType(property.name) != nullptr || property.name == "list") {
        return Bad(path, where() + "property name " + Quote(property.name) + " is a type name");
      }
      for (const PlyProperty& other : element.properties) {
        if (other.name == property.name) {
          return Bad(path, where() + "element " + Quote(element.name) + " has property " +
                               Quote(property.name) + " twice");
        }
      }
      element.properties.push_back(std::move(property));
      continue;
    }
    return Bad(path, where() + "unknown keyword " + Quote(w[0]));
  }
  if (!have_format) return Bad(path, "PLY header has no format line");
  return header;
}

bool IsVertexFloatProperty(const std::string& n) {
  return n == "x" || n == "y" || n == "z" || n == "nx" || n == "ny" || n == "nz" || n == "u" ||
         n == "v" || n == "s" || n == "t";
}
bool IsColorProperty(const std::string& element, const std::string& n) {
  if (n == "red" || n == "green" || n == "blue" || n == "alpha") return true;
  return element == "vertex" && (n == "diffuse_red" || n == "diffuse_green" || n == "diffuse_blue");
}
bool IsFaceIndexList(const PlyElement& e, const PlyProperty& p) {
  return e.name == "face" && p.is_list() && (p.name == "vertex_indices" || p.name == "vertex_index");
}

constexpr size_t kNoElement = std::numeric_limits<size_t>::max();

struct PlyLayout {
  size_t vertex = 0;           // element indices
  size_t face = kNoElement;    // kNoElement: none (then there are strips)
  size_t strips = kNoElement;  // 'tristrips', always the last element
  // The last element whose values OpenMesh reads and we check.
  size_t last_checked() const { return face != kNoElement ? face : vertex; }
};

bool IsStripsElement(const PlyElement& e) { return e.name == "tristrips"; }

// Everything OpenMesh's PLY reader would misread, loop on, or silently drop.
StatusOr<PlyLayout> CheckPlyForOpenMesh(const std::string& path, const PlyHeader& h) {
  int vertex = -1, face = -1, strips = -1;
  for (size_t i = 0; i < h.elements.size(); ++i) {
    const PlyElement& e = h.elements[i];
    if (e.count > 0 && e.properties.empty()) {
      return Bad(path, "PLY element " + Quote(e.name) + " has " + Num(e.count) + " records but no properties");
    }
    if (e.name == "vertex" || e.name == "face" || IsStripsElement(e)) {
      int& slot = e.name == "vertex" ? vertex : e.name == "face" ? face : strips;
      if (slot >= 0) return Bad(path, "PLY header declares element " + Quote(e.name) + " twice");
      slot = static_cast<int>(i);
    }
  }
  if (vertex < 0) return Bad(path, "PLY file has no 'vertex' element");
  if (face < 0 && strips < 0) {
    return Bad(path, "no triangles: the PLY file has no 'face' or 'tristrips' element");
  }
  if (face >= 0 && face < vertex) {
    return Refuse(path, "PLY 'face' element before the 'vertex' element is not supported");
  }
  if (strips >= 0) {
    const PlyElement& e = h.elements[static_cast<size_t>(strips)];
    if (static_cast<size_t>(strips) + 1 != h.elements.size()) {
      // OpenMesh reads every element of the header it is given; the strips
      // are hidden from it, which works only when nothing follows them.
      return Refuse(path, "PLY element 'tristrips' must be the last element (element " +
                              Quote(h.elements[static_cast<size_t>(strips) + 1].name) + " follows it)");
    }
    if (e.properties.size() != 1 || !e.properties[0].is_list() || e.properties[0].name != "vertex_indices") {
      return Refuse(path, "PLY element 'tristrips' must have exactly one property, the list "
                          "'vertex_indices'");
    }
    if (e.properties[0].type->is_float) {
      return Refuse(path, "PLY tristrips property 'vertex_indices' has float entries; vertex indices "
                          "must be integers");
    }
  }
  const bool binary = h.format != PlyFormat::kAscii;
  const size_t last_checked = static_cast<size_t>(face >= 0 ? face : vertex);
  for (size_t i = 0; i <= last_checked; ++i) {
    const PlyElement& e = h.elements[i];
    bool has_indices = false;
    for (const PlyProperty& p : e.properties) {
      const std::string what = "PLY " + e.name + " property " + Quote(p.name);
      if (IsFaceIndexList(e, p)) {
        if (has_indices) return Bad(path, "PLY face element has two vertex index lists");
        if (&p != &e.properties.front()) {
          // OpenMesh forgets the properties declared before the index list
          // and would read the face records misaligned.
          return Refuse(path, "PLY face properties before 'vertex_indices' are not supported (" +
                                  Quote(e.properties.front().name) + " comes first)");
        }
        has_indices = true;
        if (p.type->is_float) return Refuse(path, what + " has float entries; vertex indices must be integers");
        continue;
      }
      if (p.is_list()) {
        return Refuse(path, what + " is a list; OpenMesh's PLY reader supports lists only for face "
                                   "vertex_indices");
      }
      if (!binary) continue;
      // Binary: OpenMesh reads these with type-specific code that skips no
      // bytes for other types, which would shift everything after.
      if (e.name == "vertex" && IsVertexFloatProperty(p.name) && !p.type->is_float) {
        return Refuse(path, what + " has type " + p.type->name + "; binary PLY coordinates, normals "
                                   "and texture coordinates must be float or double");
      }
      if ((e.name == "vertex" || e.name == "face") && IsColorProperty(e.name, p.name) && p.type->size == 8) {
        return Refuse(path, what + " has type double; colours must be integers or float");
      }
    }
    if (i == static_cast<size_t>(face) && !has_indices) {
      return Bad(path, "PLY face element has no 'vertex_indices' list");
    }
  }
  const PlyElement& v = h.elements[static_cast<size_t>(vertex)];
  for (const char* axis : {"x", "y", "z"}) {
    bool found = false;
    for (const PlyProperty& p : v.properties) found = found || p.name == axis;
    if (!found) return Bad(path, std::string("PLY vertex element has no '") + axis + "' property");
  }
  PlyLayout layout;
  layout.vertex = static_cast<size_t>(vertex);
  if (face >= 0) layout.face = static_cast<size_t>(face);
  if (strips >= 0) layout.strips = static_cast<size_t>(strips);
  return layout;
}

// The header as OpenMesh will parse it: one canonical line per item, so that
// OpenMesh's token-based header parser and its binary-offset arithmetic
// ("end_header" + newline, counted from the previous token) agree with ours.
// The tristrips element (the last one) is left out: OpenMesh would not read
// it, and stops before its bytes.
std::string CanonicalPlyHeader(const PlyHeader& h) {
  std::string s = "ply\nformat ";
  s += PlyFormatName(h.format);
  s += " 1.0\n";
  for (const PlyElement& e : h.elements) {
    if (IsStripsElement(e)) continue;
    s += "element " + e.name + " " + Num(e.count) + "\n";
    for (const PlyProperty& p : e.properties) {
      if (p.is_list()) {
        s += std::string("property list ") + p.count_type->name + " " + p.type->name + " " + p.name + "\n";
      } else {
        s += std::string("property ") + p.type->name + " " + p.name + "\n";
      }
    }
  }
  s += "end_header\n";
  return s;
}

std::string RecordName(const PlyElement& e, uint64_t r) {
  return e.name + " " + Num(r) + " of " + Num(e.count);
}

// Marks a restart in PlyBodyStats::strips (never a valid vertex index: a
// PLY has at most 2^32 - 1 vertices).
constexpr uint32_t kStripRestart = std::numeric_limits<uint32_t>::max();

struct PlyBodyStats {
  uint64_t face_corners = 0;
  // Every tristrips entry in file order, kStripRestart for -1 and after each
  // record; every other entry is a checked vertex index.
  std::vector<uint32_t> strips;
};

// Checks one tristrips entry (entry k of record r) and appends it.
Status AddStripEntry(const std::string& path, const PlyElement& e, uint64_t r, uint64_t k, int64_t value,
                     uint64_t vertex_count, std::vector<uint32_t>* strips) {
  if (value == -1) {
    strips->push_back(kStripRestart);
    return Status::Ok();
  }
  if (value < 0) {
    return Bad(path, RecordName(e, r) + ": entry " + Num(k) + " is " + std::to_string(value) +
                         " (a strip index must be -1, a restart, or a vertex index)");
  }
  if (static_cast<uint64_t>(value) >= vertex_count) {
    return Bad(path, RecordName(e, r) + ": entry " + Num(k) + " names vertex " +
                         Num(static_cast<uint64_t>(value)) + ", out of range (the file has " +
                         Num(vertex_count) + " vertices)");
  }
  strips->push_back(static_cast<uint32_t>(value));
  return Status::Ok();
}

// glTF's TRIANGLE_STRIP within each run between restarts: triangle i is
// (v[i], v[i+1], v[i+2]) for even i, (v[i+1], v[i], v[i+2]) for odd i;
// triangles repeating a vertex (restart degenerates) are skipped.
void AppendStripTriangles(const std::vector<uint32_t>& strips, std::vector<uint32_t>* indices) {
  size_t run = 0;
  while (run < strips.size()) {
    size_t end = run;
    while (end < strips.size() && strips[end] != kStripRestart) ++end;
    for (size_t i = run; i + 2 < end; ++i) {
      const bool odd = (i - run) % 2 == 1;
      const uint32_t a = odd ? strips[i + 1] : strips[i];
      const uint32_t b = odd ? strips[i] : strips[i + 1];
      const uint32_t c = strips[i + 2];
      if (a == b || b == c || a == c) continue;
      indices->push_back(a);
      indices->push_back(b);
      indices->push_back(c);
    }
    run = end + 1;
  }
}

uint64_t ReadUnsigned(const uint8_t* p, int size, bool big_endian) {
  uint64_t v = 0;
  for (int i = 0; i < size; ++i) {
    const int shift = big_endian ? 8 * (size - 1 - i) : 8 * i;
    v |= static_cast<uint64_t>(p[i]) << shift;
  }
  return v;
}

// Reads a list length of type `t`; negative lengths come back as < 0.
int64_t ReadListLength(const uint8_t* p, const PlyType* t, bool big_endian) {
  const uint64_t raw = ReadUnsigned(p, t->size, big_endian);
  if (!t->is_signed) return static_cast<int64_t>(raw);
  const uint64_t sign = uint64_t{1} << (8 * t->size - 1);
  if (raw & sign) return static_cast<int64_t>(raw) - static_cast<int64_t>(sign << 1);
  return static_cast<int64_t>(raw);
}

Status WalkPlyBinary(const std::string& path, const PlyHeader& h, const PlyLayout& layout,
                     std::string_view body, PlyBodyStats* stats) {
  const bool big = h.format == PlyFormat::kBinaryBigEndian;
  const uint8_t* data = reinterpret_cast<const uint8_t*>(body.data());
  const uint64_t size = body.size();
  // First the cheap bound: every record at its smallest (lists empty).
  uint64_t minimum = 0;
  for (const PlyElement& e : h.elements) {
    uint64_t record = 0;
    for (const PlyProperty& p : e.properties) record += p.is_list() ? p.count_type->size : p.type->size;
    if (!MulAdd(e.count, record, &minimum) || minimum > size) {
      return Bad(path, "PLY header declares " + Num(e.count) + " " + e.name + " records (at least " +
                           Num(record) + " bytes each), more than the " + Num(size) +
                           " bytes after the header can hold");
    }
  }
  uint64_t offset = 0;
  for (size_t ei = 0; ei < h.elements.size(); ++ei) {
    const PlyElement& e = h.elements[ei];
    bool has_list = false;
    uint64_t record = 0;
    for (const PlyProperty& p : e.properties) {
      has_list = has_list || p.is_list();
      record += p.is_list() ? 0 : p.type->size;
    }
    if (!has_list) {
      uint64_t need = 0;
      if (!MulAdd(e.count, record, &need) || need > size - offset) {
        return Bad(path, "truncated: the file ends inside " + RecordName(e, (size - offset) / record));
      }
      offset += need;
      continue;
    }
    for (uint64_t r = 0; r < e.count; ++r) {
      for (const PlyProperty& p : e.properties) {
        if (!p.is_list()) {
          if (static_cast<uint64_t>(p.type->size) > size - offset) {
            return Bad(path, "truncated: the file ends inside " + RecordName(e, r));
          }
          offset += p.type->size;
          continue;
        }
        if (static_cast<uint64_t>(p.count_type->size) > size - offset) {
          return Bad(path, "truncated: the file ends inside " + RecordName(e, r));
        }
        const int64_t length = ReadListLength(data + offset, p.count_type, big);
        offset += p.count_type->size;
        if (length < 0) {
          return Bad(path, RecordName(e, r) + ": list " + Quote(p.name) + " has negative length " +
                               std::to_string(length));
        }
        const bool indices = ei == layout.face && IsFaceIndexList(e, p);
        if (indices && length < 3) {
          return Bad(path, RecordName(e, r) + " has " + std::to_string(length) +
                               " corners (a face needs at least 3)");
        }
        const uint64_t bytes = static_cast<uint64_t>(length) * static_cast<uint64_t>(p.type->size);
        if (bytes > size - offset) {
          return Bad(path, "truncated: " + RecordName(e, r) + " declares " + Num(static_cast<uint64_t>(length)) +
                               " list entries, more than the file holds");
        }
        if (ei == layout.strips) {
          const uint64_t vertex_count = h.elements[layout.vertex].count;
          for (int64_t k = 0; k < length; ++k) {
            const int64_t value = ReadListLength(data + offset + static_cast<uint64_t>(k) * p.type->size,
                                                 p.type, big);
            MS_RETURN_IF_ERROR(AddStripEntry(path, e, r, static_cast<uint64_t>(k), value, vertex_count,
                                             &stats->strips));
          }
          stats->strips.push_back(kStripRestart);
        }
        offset += bytes;
        if (indices) stats->face_corners += static_cast<uint64_t>(length);
      }
    }
  }
  return Status::Ok();
}

Status WalkPlyAscii(const std::string& path, const PlyHeader& h, const PlyLayout& layout,
                    std::string_view body, PlyBodyStats* stats) {
  // The cheap bound first: a value takes at least two bytes (a digit and a
  // separator), a list at least its length.
  uint64_t minimum = 0;
  for (const PlyElement& e : h.elements) {
    if (!MulAdd(e.count, 2 * e.properties.size(), &minimum) || minimum > body.size() + 1) {
      return Bad(path, "PLY header declares " + Num(e.count) + " " + e.name + " records (" +
                           Num(e.properties.size()) + " values each, at least 2 bytes per value), more than "
                           "the " + Num(body.size()) + " bytes after the header can hold");
    }
  }
  Tokens tokens(body, h.header_lines + 1);
  for (size_t ei = 0; ei < h.elements.size(); ++ei) {
    const PlyElement& e = h.elements[ei];
    const bool read_by_openmesh = ei <= layout.last_checked();
    const bool strips = ei == layout.strips;
    for (uint64_t r = 0; r < e.count; ++r) {
      for (const PlyProperty& p : e.properties) {
        auto where = [&]() { return "line " + Num(tokens.line()) + ": " + RecordName(e, r) + ": "; };
        std::string_view t = tokens.Next();
        if (t.empty()) return Bad(path, "truncated: the file ends inside " + RecordName(e, r));
        if (p.is_list()) {
          uint32_t length = 0;
          if (!ParseU32(t, &length)) {
            return Bad(path, where() + "list length " + Quote(t) + " is not a non-negative integer");
          }
          const bool indices = ei == layout.face && IsFaceIndexList(e, p);
          if (indices && length < 3) {
            return Bad(path, "line " + Num(tokens.line()) + ": " + RecordName(e, r) + " has " + Num(length) +
                                 " corners (a face needs at least 3)");
          }
          if (indices) stats->face_corners += length;
          for (uint32_t k = 0; k < length; ++k) {
            t = tokens.Next();
            if (t.empty()) return Bad(path, "truncated: the file ends inside " + RecordName(e, r));
            uint32_t index = 0;
            if (indices && !ParseU32(t, &index)) {
              return Bad(path, where() + "vertex index " + Quote(t) + " is not a non-negative integer");
            }
            if (strips) {
              int64_t value = -1;
              if (t != "-1") {
                if (!ParseU32(t, &index)) {
                  return Bad(path, where() + "entry " + Num(k) + ": strip index " + Quote(t) +
                                       " is neither -1 nor a non-negative integer");
                }
                value = index;
              }
              MS_RETURN_IF_ERROR(AddStripEntry(path, e, r, k, value, h.elements[layout.vertex].count,
                                               &stats->strips));
            }
          }
          if (strips) stats->strips.push_back(kStripRestart);
          continue;
        }
        if (!read_by_openmesh) continue;
        const bool float_read = (e.name == "vertex" && IsVertexFloatProperty(p.name)) ||
                                (IsColorProperty(e.name, p.name) && p.type->is_float && p.type->size == 4);
        const bool int_read = IsColorProperty(e.name, p.name) && !float_read;
        if (float_read) {
          const NumberCheck check = CheckDecimal(t);
          if (check != NumberCheck::kOk) {
            return Bad(path, where() + "property " + Quote(p.name) + ": " + DescribeBadNumber(check, t));
          }
        } else if (int_read && !IsInt32Token(t)) {
          return Bad(path, where() + "property " + Quote(p.name) + ": " + Quote(t) + " is not an integer");
        }
      }
    }
  }
  return Status::Ok();
}

StatusOr<Primitive> ImportPly(const std::string& path, std::string_view data,
                              std::vector<std::string>* warnings) {
  MS_ASSIGN_OR_RETURN(PlyHeader header, ParsePlyHeader(path, data));
  MS_ASSIGN_OR_RETURN(PlyLayout layout, CheckPlyForOpenMesh(path, header));
  const std::string_view body = data.substr(header.body_offset);
  PlyBodyStats stats;
  if (header.format == PlyFormat::kAscii) {
    MS_RETURN_IF_ERROR(WalkPlyAscii(path, header, layout, body, &stats));
  } else {
    MS_RETURN_IF_ERROR(WalkPlyBinary(path, header, layout, body, &stats));
  }
  const uint64_t vertex_count = header.elements[layout.vertex].count;
  const uint64_t face_count = layout.face != kNoElement ? header.elements[layout.face].count : 0;
  std::vector<uint32_t> strip_triangles;
  AppendStripTriangles(stats.strips, &strip_triangles);
  stats.strips = std::vector<uint32_t>();
  if (face_count == 0 && strip_triangles.empty()) {
    return Bad(path, "no triangles: the PLY file has " + Num(vertex_count) + " vertices but no faces" +
                         (layout.strips != kNoElement ? " and no non-degenerate strip triangles" : ""));
  }

  MeshRecorder recorder(vertex_count, face_count, stats.face_corners);
  const std::string head = CanonicalPlyHeader(header);
  MS_RETURN_IF_ERROR(RunOpenMeshReader(path, "PLY", [&]() {
    TwoPartStreamBuf buffer(head, body);
    std::istream in(&buffer);
    in.imbue(std::locale::classic());
    OpenMesh::IO::Options options;
    options += OpenMesh::IO::Options::VertexNormal;
    options += OpenMesh::IO::Options::VertexColor;
    options += OpenMesh::IO::Options::VertexTexCoord;
    return OpenMesh::IO::PLYReader().read(in, recorder, options);
  }));
  if (recorder.positions.size() != vertex_count || recorder.face_starts.size() != face_count) {
    return Bad(path, "OpenMesh's PLY reader delivered " + Num(recorder.positions.size()) + " of " +
                         Num(vertex_count) + " vertices and " + Num(recorder.face_starts.size()) + " of " +
                         Num(face_count) + " faces");
  }
  MS_ASSIGN_OR_RETURN(Primitive prim, PrimitiveFromRecorder(path, recorder, warnings));
  prim.indices.insert(prim.indices.end(), strip_triangles.begin(), strip_triangles.end());
  return prim;
}

// ================================================================ [4] OFF

struct OffInfo {
  bool colors = false;
  bool normals = false;
  uint32_t vertices = 0;
  uint32_t faces = 0;
  uint64_t corners = 0;
};

// Mirrors OpenMesh's ascii OFF reader token by token: counts with `>>`, each
// vertex as 3 (6 with N) values with `>>` and then the rest of its line,
// each face as a length and that many indices with `>>` (then, for COFF, the
// rest of its line).
StatusOr<OffInfo> CheckOff(const std::string& path, std::string_view data) {
  OffInfo info;
  const size_t first_end = std::min(data.find('\n'), data.size());
  std::string_view first = data.substr(0, first_end);
  while (!first.empty() && IsSpaceChar(first.back())) first.remove_suffix(1);
  std::string_view keyword = first.substr(0, std::min(first.find_first_of(" \t"), first.size()));
  if (keyword.size() < 3 || keyword.substr(keyword.size() - 3) != "OFF") {
    return Bad(path, "not an OFF file (the first line does not start with OFF)");
  }
  std::string_view prefix = keyword.substr(0, keyword.size() - 3);
  if (prefix.size() >= 2 && prefix.substr(0, 2) == "ST") {
    return Refuse(path, "OFF with texture coordinates (STOFF) is not supported");
  }
  if (!prefix.empty() && prefix[0] == 'C') {
    info.colors = true;
    prefix.remove_prefix(1);
  }
  if (!prefix.empty() && prefix[0] == 'N') {
    info.normals = true;
    prefix.remove_prefix(1);
  }
  if (!prefix.empty()) return Refuse(path, "OFF variant " + Quote(keyword) + " is not supported");
  if (first.size() > keyword.size()) {
    std::string_view rest = first.substr(keyword.size());
    while (!rest.empty() && IsSpaceChar(rest.front())) rest.remove_prefix(1);
    if (rest == "BINARY") return Refuse(path, "binary OFF is not supported");
    return Bad(path, "OFF line 1: the counts must be on the line after " + Quote(keyword));
  }
  const std::string_view text = data.substr(std::min(first_end + 1, data.size()));
  const size_t hash = text.find('#');
  if (hash != std::string_view::npos) {
    const size_t line = 2 + static_cast<size_t>(std::count(text.begin(), text.begin() + hash, '\n'));
    return Refuse(path, "OFF line " + Num(line) + ": comments after the first line are not supported");
  }

  Tokens tokens(text, 2);
  uint32_t counts[3] = {0, 0, 0};
  const char* count_names[3] = {"vertex", "face", "edge"};
  for (int i = 0; i < 3; ++i) {
    std::string_view t = tokens.Next();
    if (t.empty()) return Bad(path, "OFF file ends before its vertex, face and edge counts");
    if (!ParseU32(t, &counts[i])) {
      return Bad(path, "OFF line " + Num(tokens.line()) + ": " + count_names[i] + " count " + Quote(t) +
                           " is not an integer between 0 and " + Num(kU32Max));
    }
  }
  info.vertices = counts[0];
  info.faces = counts[1];
  // A vertex needs at least 3 values, a face 4 ("3 a b c"), each 2 bytes.
  uint64_t minimum = 0;
  if (!MulAdd(info.vertices, 6, &minimum) || !MulAdd(info.faces, 8, &minimum) ||
      minimum > text.size() + 1) {
    return Bad(path, "OFF header declares " + Num(info.vertices) + " vertices and " + Num(info.faces) +
                         " faces, more than the " + Num(data.size()) + " bytes of the file can hold");
  }
  const int values_per_vertex = info.normals ? 6 : 3;
  // COFF colour fields: OpenMesh counts them by single spaces; anything but
  // 0, 3 or 4 plain numbers would be misread or reported on std::cerr.
  auto check_colors = [&](std::string_view rest, const std::string& what) -> Status {
    while (!rest.empty() && IsSpaceChar(rest.back())) rest.remove_suffix(1);
    while (!rest.empty() && IsSpaceChar(rest.front())) rest.remove_prefix(1);
    if (rest.empty()) return Status::Ok();
    const std::vector<std::string_view> words = SplitWords(rest);
    bool single_spaced = true;
    for (char c : rest) single_spaced = single_spaced && (c != '\t' && c != '\r' && c != '\v' && c != '\f');
    single_spaced = single_spaced && rest.find("  ") == std::string_view::npos;
    if ((words.size() != 3 && words.size() != 4) || !single_spaced) {
      return Bad(path, what + ": colour must be 3 or 4 numbers separated by single spaces");
    }
    for (std::string_view w : words) {
      if (CheckDecimal(w) != NumberCheck::kOk) {
        return Bad(path, what + ": colour " + DescribeBadNumber(CheckDecimal(w), w));
      }
    }
    return Status::Ok();
  };
  for (uint64_t v = 0; v < info.vertices; ++v) {
    for (int k = 0; k < values_per_vertex; ++k) {
      std::string_view t = tokens.Next();
      if (t.empty()) return Bad(path, "truncated: the file ends inside vertex " + Num(v) + " of " + Num(info.vertices));
      const NumberCheck check = CheckDecimal(t);
      if (check != NumberCheck::kOk) {
        return Bad(path, "OFF line " + Num(tokens.line()) + ": vertex " + Num(v) + ": " +
                             DescribeBadNumber(check, t));
      }
    }
    const size_t line = tokens.line();
    std::string_view rest = tokens.RestOfLine();
    if (info.colors) MS_RETURN_IF_ERROR(check_colors(rest, "OFF line " + Num(line) + ": vertex " + Num(v)));
  }
  for (uint64_t f = 0; f < info.faces; ++f) {
    std::string_view t = tokens.Next();
    if (t.empty()) return Bad(path, "truncated: the file ends before face " + Num(f) + " of " + Num(info.faces));
    uint32_t length = 0;
    if (!ParseU32(t, &length)) {
      return Bad(path, "OFF line " + Num(tokens.line()) + ": face " + Num(f) + ": corner count " + Quote(t) +
                           " is not a non-negative integer");
    }
    if (length < 3) {
      return Bad(path, "OFF line " + Num(tokens.line()) + ": face " + Num(f) + " of " + Num(info.faces) +
                           " has " + Num(length) + " corners (a face needs at least 3)");
    }
    for (uint32_t k = 0; k < length; ++k) {
      t = tokens.Next();
      if (t.empty()) return Bad(path, "truncated: the file ends inside face " + Num(f) + " of " + Num(info.faces));
      uint32_t index = 0;
      if (!ParseU32(t, &index)) {
        return Bad(path, "OFF line " + Num(tokens.line()) + ": face " + Num(f) + ": vertex index " + Quote(t) +
                             " is not a non-negative integer");
      }
    }
    info.corners += length;
    const size_t line = tokens.line();
    std::string_view rest = tokens.RestOfLine();
    const std::string what = "OFF line " + Num(line) + ": face " + Num(f);
    if (info.colors) {
      MS_RETURN_IF_ERROR(check_colors(rest, what));
    } else if (!SplitWords(rest).empty()) {
      return Bad(path, what + ": unexpected values after its " + Num(length) +
                           " corners (face colours need a COFF header)");
    }
  }
  return info;
}

StatusOr<Primitive> ImportOff(const std::string& path, std::string_view data,
                              std::vector<std::string>* warnings) {
  MS_ASSIGN_OR_RETURN(OffInfo info, CheckOff(path, data));
  if (info.faces == 0) {
    return Bad(path, "no triangles: the OFF file has " + Num(info.vertices) + " vertices but no faces");
  }
  MeshRecorder recorder(info.vertices, info.faces, info.corners);
  MS_RETURN_IF_ERROR(RunOpenMeshReader(path, "OFF", [&]() {
    OpenMesh::IO::Options options;
    options += OpenMesh::IO::Options::VertexNormal;
    options += OpenMesh::IO::Options::VertexColor;
    // By name: only can_u_read(filename) sets the reader's NOFF/COFF flags.
    if (!OpenMesh::IO::OFFReader().can_u_read(path)) return false;
    return OpenMesh::IO::OFFReader().read(path, recorder, options);
  }));
  if (recorder.positions.size() != info.vertices || recorder.face_starts.size() != info.faces) {
    return Bad(path, "OpenMesh's OFF reader delivered " + Num(recorder.positions.size()) + " of " +
                         Num(info.vertices) + " vertices and " + Num(recorder.face_starts.size()) + " of " +
                         Num(info.faces) + " faces (did the file change while it was read?)");
  }
  return PrimitiveFromRecorder(path, recorder, warnings);
}

// ================================================================ [5] STL

struct StlInfo {
  bool binary = false;
  uint64_t triangles = 0;
};

float ReadFloatLE(const uint8_t* p) {
  const uint32_t bits = static_cast<uint32_t>(ReadUnsigned(p, 4, false));
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

bool LooksLikeText(std::string_view data) {
  for (char ch : data) {
    const unsigned char c = static_cast<unsigned char>(ch);
    if (c < 0x20 && c != '\n' && c != '\r' && c != '\t' && c != '\v' && c != '\f') return false;
  }
  return true;
}

// Binary when the size is exactly 84 + 50 n (as OpenMesh decides), ascii when
// the file is text starting with "solid", else an error naming the count.
StatusOr<StlInfo> CheckStl(const std::string& path, std::string_view data) {
  StlInfo info;
  const uint8_t* bytes = reinterpret_cast<const uint8_t*>(data.data());
  uint64_t declared = 0;
  if (data.size() >= 84) declared = ReadUnsigned(bytes + 80, 4, false);
  std::string_view start = data;
  while (!start.empty() && IsSpaceChar(start.front())) start.remove_prefix(1);
  const bool ascii_like = start.substr(0, 5) == "solid" && LooksLikeText(data);
  if (data.size() >= 84 && data.size() == 84 + 50 * declared) {
    info.binary = true;
    info.triangles = declared;
    for (uint64_t t = 0; t < declared; ++t) {
      const uint8_t* record = bytes + 84 + 50 * t;
      for (int c = 3; c < 12; ++c) {  // skip the facet normal (unused)
        const float value = ReadFloatLE(record + 4 * c);
        if (!std::isfinite(value)) {
          return Bad(path, "triangle " + Num(t) + ": corner " + Num(c / 3 - 1) +
                               " has a coordinate that is not a finite number");
        }
      }
    }
    return info;
  }
  if (!ascii_like) {
    if (data.size() < 84) return Bad(path, "not an STL file (too short for binary STL, and not ascii 'solid')");
    return Bad(path, "binary STL declares " + Num(declared) + " triangles, which need " +
                         Num(84 + 50 * declared) + " bytes, but the file has " + Num(data.size()));
  }
  // Ascii: OpenMesh takes a line containing "outer" (or "OUTER") as the start
  // of a facet and reads the next three lines as "<word> x y z".
  size_t pos = 0, line_no = 0;
  auto next_line = [&](std::string_view* line) {
    if (pos >= data.size()) return false;
    size_t end = data.find('\n', pos);
    if (end == std::string_view::npos) end = data.size();
    *line = data.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    return true;
  };
  std::string_view line;
  while (next_line(&line)) {
    if (line.find("outer") == std::string_view::npos && line.find("OUTER") == std::string_view::npos) continue;
    for (int corner = 0; corner < 3; ++corner) {
      if (!next_line(&line)) {
        return Bad(path, "truncated: the file ends inside facet " + Num(info.triangles));
      }
      const std::vector<std::string_view> w = SplitWords(line);
      std::string keyword = w.empty() ? "" : std::string(w[0]);
      std::transform(keyword.begin(), keyword.end(), keyword.begin(),
                     [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
      if (w.size() < 4 || keyword != "vertex") {
        return Bad(path, "STL line " + Num(line_no) + ": facet " + Num(info.triangles) +
                             ": expected 'vertex x y z'");
      }
      for (int k = 1; k < 4; ++k) {
        const NumberCheck check = CheckDecimal(w[static_cast<size_t>(k)]);
        if (check != NumberCheck::kOk) {
          return Bad(path, "STL line " + Num(line_no) + ": facet " + Num(info.triangles) + ": " +
                               DescribeBadNumber(check, w[static_cast<size_t>(k)]));
        }
      }
    }
    ++info.triangles;
  }
  return info;
}

StatusOr<Primitive> ImportStl(const std::string& path, std::string_view data,
                              std::vector<std::string>* warnings) {
  MS_ASSIGN_OR_RETURN(StlInfo info, CheckStl(path, data));
  if (info.triangles == 0) return Bad(path, "no triangles: the STL file has no facets");
  MeshRecorder recorder(3 * info.triangles, info.triangles, 3 * info.triangles);
  MS_RETURN_IF_ERROR(RunOpenMeshReader(path, "STL", [&]() {
    TwoPartStreamBuf buffer(std::string_view(), data);
    std::istream in(&buffer);
    in.imbue(std::locale::classic());
    OpenMesh::IO::Options options;
    if (info.binary) options += OpenMesh::IO::Options::Binary;
    return OpenMesh::IO::STLReader().read(in, recorder, options);
  }));
  if (recorder.face_starts.size() < info.triangles) {
    warnings->push_back("STL: dropped " + Num(info.triangles - recorder.face_starts.size()) + " of " +
                        Num(info.triangles) + " triangles with two corners at the same position");
  }
  return PrimitiveFromRecorder(path, recorder, warnings);
}

// ================================================================ [6] OBJ

// What tinyobjloader does not guard: non-finite numbers (it reads "nan" as
// 0), "t" tag lines (each allocates ~300 KiB whatever its length).
Status PrescanObj(const std::string& path, std::string_view data) {
  size_t pos = 0, line_no = 0;
  while (pos < data.size()) {
    // Lines end at \n, \r or \r\n, as tinyobjloader's safeGetline reads them.
    size_t end = pos;
    while (end < data.size() && data[end] != '\n' && data[end] != '\r') ++end;
    std::string_view line = data.substr(pos, end - pos);
    pos = end + 1;
    if (end + 1 < data.size() && data[end] == '\r' && data[end + 1] == '\n') pos = end + 2;
    ++line_no;
    size_t i = 0;
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    line.remove_prefix(i);
    if (line.size() < 2) continue;
    const bool space1 = line[1] == ' ' || line[1] == '\t';
    const bool space2 = line.size() > 2 && (line[2] == ' ' || line[2] == '\t');
    if (line[0] == 't' && space1) {
      return Refuse(path, "OBJ line " + Num(line_no) + ": tag lines ('t') are not supported");
    }
    size_t skip = 0;
    if (line[0] == 'v' && space1) {
      skip = 2;
    } else if (line[0] == 'v' && (line[1] == 't' || line[1] == 'n') && space2) {
      skip = 3;
    } else {
      continue;
    }
    Tokens tokens(line.substr(skip), line_no);
    for (std::string_view t = tokens.Next(); !t.empty(); t = tokens.Next()) {
      if (t[0] == '#') break;  // a trailing comment
      const NumberCheck check = CheckDecimal(t);
      if (check != NumberCheck::kOk) {
        return Bad(path, "OBJ line " + Num(line_no) + ": " + DescribeBadNumber(check, t));
      }
    }
  }
  return Status::Ok();
}

struct CornerKey {
  int position, texcoord, normal;
  bool operator==(const CornerKey& o) const {
    return position == o.position && texcoord == o.texcoord && normal == o.normal;
  }
};
struct CornerKeyHash {
  size_t operator()(const CornerKey& k) const {
    uint64_t h = static_cast<uint32_t>(k.position);
    h = h * 0x9E3779B97F4A7C15ull ^ static_cast<uint32_t>(k.texcoord);
    h = h * 0x9E3779B97F4A7C15ull ^ static_cast<uint32_t>(k.normal);
    return static_cast<size_t>(h ^ (h >> 29));
  }
};

StatusOr<Primitive> ImportObj(const std::string& path, std::string_view data, uint64_t* source_vertices,
                              std::vector<std::string>* warnings) {
  MS_RETURN_IF_ERROR(PrescanObj(path, data));
  tinyobj::attrib_t attrib;
  std::vector<tinyobj::shape_t> shapes;
  std::vector<tinyobj::material_t> materials;
  std::string warn, err;
  bool ok = false;
  try {
    TwoPartStreamBuf buffer(std::string_view(), data);
    std::istream in(&buffer);
    // No MaterialReader: mtllib names no file we open; faces keep corners
    // (triangulate = false) so that we fan them ourselves; vertex colours
    // only when every vertex has one.
    ok = tinyobj::LoadObj(&attrib, &shapes, &materials, &warn, &err, &in, nullptr,
                          /*triangulate=*/false, /*default_vcols_fallback=*/false);
  } catch (const std::bad_alloc&) {
    return ResourceExhausted(path + ": out of memory while reading the OBJ data");
  } catch (const std::exception& e) {
    return Internal(path + ": tinyobjloader failed: " + e.what());
  } catch (...) {
    return Internal(path + ": tinyobjloader failed with an unknown exception");
  }
  if (!ok || !err.empty()) {
    std::string message = err.substr(0, err.find('\n'));
    if (message.empty()) message = "tinyobjloader could not read the file";
    return Bad(path, message);
  }
  {
    // tinyobjloader's warnings that still matter once we checked every index.
    size_t begin = 0;
    while (begin < warn.size()) {
      size_t end = warn.find('\n', begin);
      if (end == std::string::npos) end = warn.size();
      std::string w = warn.substr(begin, end - begin);
      begin = end + 1;
      if (w.empty() || w == "." || w.rfind("material", 0) == 0 || w.find("out of bounds") != std::string::npos) {
        continue;
      }
      if (w.rfind("Degenerated face", 0) == 0) w = "OBJ: dropped a face with fewer than 3 corners";
      if (std::find(warnings->begin(), warnings->end(), w) == warnings->end()) warnings->push_back(w);
    }
  }

  const size_t position_count = attrib.vertices.size() / 3;
  const size_t texcoord_count = attrib.texcoords.size() / 2;
  const size_t normal_count = attrib.normals.size() / 3;
  const bool has_colors = !attrib.colors.empty() && attrib.colors.size() == attrib.vertices.size();
  if (position_count > kU32Max) return Bad(path, "more than 2^32 - 1 vertices");

  bool any_texcoord = false, any_normal = false;
  for (const tinyobj::shape_t& shape : shapes) {
    uint64_t corners = 0;
    for (unsigned char n : shape.mesh.num_face_vertices) corners += n;
    if (corners != shape.mesh.indices.size()) {
      return Refuse(path, "a face has more than 255 corners");
    }
    for (const tinyobj::index_t& i : shape.mesh.indices) {
      any_texcoord = any_texcoord || i.texcoord_index >= 0;
      any_normal = any_normal || i.normal_index >= 0;
    }
  }

  Primitive prim;
  prim.positions.resize(position_count);
  for (size_t i = 0; i < position_count; ++i) {
    prim.positions[i] = {attrib.vertices[3 * i], attrib.vertices[3 * i + 1], attrib.vertices[3 * i + 2]};
  }
  std::vector<Vec2f> uv;
  if (any_texcoord) uv.assign(position_count, Vec2f{0.f, 0.f});
  if (any_normal) prim.normals.assign(position_count, Vec3f{0.f, 0.f, 1.f});
  if (has_colors) {
    prim.colors.resize(position_count);
    for (size_t i = 0; i < position_count; ++i) {
      prim.colors[i] = {SrgbToLinear(attrib.colors[3 * i]), SrgbToLinear(attrib.colors[3 * i + 1]),
                        SrgbToLinear(attrib.colors[3 * i + 2]), 1.f};
    }
  }

  // Vertex i < position_count is position i with its first corner's
  // attributes; other (position, uv, normal) combinations are appended.
  std::vector<uint8_t> claimed(position_count, 0);
  std::unordered_map<CornerKey, uint32_t, CornerKeyHash> vertex_of;
  auto vertex_for = [&](const tinyobj::index_t& i) -> uint32_t {
    const CornerKey key{i.vertex_index, i.texcoord_index, i.normal_index};
    const size_t p = static_cast<size_t>(i.vertex_index);
    auto fill = [&](size_t v) {
      if (any_texcoord && i.texcoord_index >= 0) {
        const size_t t = static_cast<size_t>(i.texcoord_index);
        uv[v] = {attrib.texcoords[2 * t], attrib.texcoords[2 * t + 1]};
      }
      if (any_normal && i.normal_index >= 0) {
        const size_t n = static_cast<size_t>(i.normal_index);
        prim.normals[v] = {attrib.normals[3 * n], attrib.normals[3 * n + 1], attrib.normals[3 * n + 2]};
      }
    };
    if (!claimed[p]) {
      claimed[p] = 1;
      vertex_of.emplace(key, static_cast<uint32_t>(p));
      fill(p);
      return static_cast<uint32_t>(p);
    }
    auto found = vertex_of.find(key);
    if (found != vertex_of.end()) return found->second;
    const size_t v = prim.positions.size();
    prim.positions.push_back(prim.positions[p]);
    if (any_texcoord) uv.push_back({0.f, 0.f});
    if (any_normal) prim.normals.push_back({0.f, 0.f, 1.f});
    if (has_colors) prim.colors.push_back(prim.colors[p]);
    fill(v);
    vertex_of.emplace(key, static_cast<uint32_t>(v));
    return static_cast<uint32_t>(v);
  };

  uint64_t face = 0;
  std::vector<uint32_t> polygon;
  for (const tinyobj::shape_t& shape : shapes) {
    size_t offset = 0;
    for (unsigned char corner_count : shape.mesh.num_face_vertices) {
      polygon.clear();
      for (size_t c = 0; c < corner_count; ++c) {
        const tinyobj::index_t& i = shape.mesh.indices[offset + c];
        const std::string where = "face " + Num(face) + ": corner " + Num(c) + ": ";
        if (i.vertex_index < 0 || static_cast<size_t>(i.vertex_index) >= position_count) {
          return Bad(path, where + "vertex index " + std::to_string(i.vertex_index + 1) +
                               " is out of range (the file has " + Num(position_count) + " vertices)");
        }
        if (i.texcoord_index >= 0 && static_cast<size_t>(i.texcoord_index) >= texcoord_count) {
          return Bad(path, where + "texture coordinate index " + std::to_string(i.texcoord_index + 1) +
                               " is out of range (the file has " + Num(texcoord_count) + ")");
        }
        if (i.normal_index >= 0 && static_cast<size_t>(i.normal_index) >= normal_count) {
          return Bad(path, where + "normal index " + std::to_string(i.normal_index + 1) +
                               " is out of range (the file has " + Num(normal_count) + ")");
        }
        if (i.texcoord_index < -1 || i.normal_index < -1) {
          return Bad(path, where + "relative attribute index points before the first value");
        }
        polygon.push_back(vertex_for(i));
      }
      for (size_t c = 1; c + 1 < polygon.size(); ++c) {
        prim.indices.push_back(polygon[0]);
        prim.indices.push_back(polygon[c]);
        prim.indices.push_back(polygon[c + 1]);
      }
      offset += corner_count;
      ++face;
    }
  }
  if (prim.positions.size() > kU32Max) return Bad(path, "more than 2^32 - 1 vertices after splitting seams");
  if (any_texcoord) prim.texcoords.push_back(std::move(uv));
  *source_vertices = position_count;
  return prim;
}

// ============================================================ [7] assembly

// glTF normals are unit vectors; files (horse.ply) may store them scaled.
void NormalizeNormals(Primitive* prim, std::vector<std::string>* warnings) {
  uint64_t scaled = 0, zero = 0;
  for (Vec3f& n : prim->normals) {
    const double length = std::sqrt(static_cast<double>(n[0]) * n[0] + static_cast<double>(n[1]) * n[1] +
                                     static_cast<double>(n[2]) * n[2]);
    if (!(length > 0)) {
      ++zero;  // zero (or NaN, which ValidateScene refuses)
      continue;
    }
    if (std::fabs(length - 1.0) <= 1e-6) continue;
    for (float& c : n) c = static_cast<float>(c / length);
    ++scaled;
  }
  if (scaled > 0) warnings->push_back("normalized " + Num(scaled) + " normals that were not unit length");
  if (zero > 0) warnings->push_back(Num(zero) + " normals have zero length");
}

std::string Stem(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
  const size_t dot = name.find_last_of('.');
  if (dot != std::string::npos && dot > 0) name.resize(dot);
  return name;
}

}  // namespace

StatusOr<Scene> ImportMeshFile(const std::string& path, const ImportOptions& options) {
  const std::string ext = FileExtension(path);
  if (ext != ".obj" && ext != ".ply" && ext != ".off" && ext != ".stl") {
    return Unsupported(path + ": not an OBJ, PLY, OFF or STL file (extension '" + ext + "')");
  }
  MS_ASSIGN_OR_RETURN(std::vector<uint8_t> bytes, ReadFileBytes(path, options.max_input_bytes));
  if (bytes.empty()) return Bad(path, "empty file");
  const std::string_view data(reinterpret_cast<const char*>(bytes.data()), bytes.size());

  std::vector<std::string> warnings;
  uint64_t source_vertices = 0;
  bool have_source_vertices = false;
  StatusOr<Primitive> primitive = Internal(path + ": no reader ran");
  try {
    if (ext == ".obj") {
      primitive = ImportObj(path, data, &source_vertices, &warnings);
      have_source_vertices = true;
    } else if (ext == ".ply") {
      primitive = ImportPly(path, data, &warnings);
    } else if (ext == ".off") {
      primitive = ImportOff(path, data, &warnings);
    } else {
      primitive = ImportStl(path, data, &warnings);
    }
  } catch (const std::bad_alloc&) {
    return ResourceExhausted(path + ": out of memory");
  } catch (const std::exception& e) {
    return Internal(path + ": " + e.what());
  } catch (...) {
    return Internal(path + ": unknown exception");
  }
  if (!primitive.ok()) return primitive.status();
  Primitive& prim = primitive.value();
  if (prim.indices.empty()) {
    return Bad(path, "no triangles: the file has " + Num(prim.positions.size()) + " vertices but no faces");
  }
  if (!have_source_vertices) source_vertices = prim.positions.size();
  NormalizeNormals(&prim, &warnings);
  Scene scene = SceneFromPrimitive(std::move(prim), Stem(path));
  scene.source_vertices = source_vertices;
  scene.warnings = std::move(warnings);
  const Status valid = ValidateScene(scene);
  if (!valid.ok()) return valid.WithContext(path);
  return scene;
}

}  // namespace meshstream
