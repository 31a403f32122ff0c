// An std::streambuf over two byte ranges read back to back (a header we
// rewrote, then the file's own body), so that a library reading a stream
// (OpenMesh's PLY and STL readers, tinyobjloader) sees the bytes we checked
// without a copy.
//
// Contract: the buffer borrows both ranges, which must outlive it and any
// stream using it; it is read-only (writes and putback fail) and supports
// the seekoff/seekpos calls that OpenMesh's PLY reader makes, within
// [0, head.size() + body.size()].
// Safe on untrusted input: the bytes are never interpreted here; seeks
// outside the two ranges fail instead of moving.
// Thread safety: one buffer per reader; distinct buffers are independent.
#ifndef MESHSTREAM_IMPORTERS_TWO_PART_STREAMBUF_H_
#define MESHSTREAM_IMPORTERS_TWO_PART_STREAMBUF_H_

#include <ios>
#include <streambuf>
#include <string_view>

namespace meshstream {
namespace mesh_io {

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

}  // namespace mesh_io
}  // namespace meshstream

#endif  // MESHSTREAM_IMPORTERS_TWO_PART_STREAMBUF_H_
