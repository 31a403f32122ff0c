// Scanning the bytes of mesh files before a library sees them: tokens and
// lines, the numbers OpenMesh's `std::istream >>` would read, integers in
// either byte order, and the error messages that quote what was found.
//
// Used by the OBJ, PLY, OFF and STL importers (obj_import.h, ply_import.h,
// off_import.h, stl_import.h) to prove that a file is what the library
// expects, so that a library never parses a byte we did not check.
//
// Contract: pure functions over caller-owned byte ranges (string_views must
// outlive the Tokens reading them); no allocation beyond the returned
// strings; no exceptions beyond std::bad_alloc from std::string.
// Safe on untrusted input: every function accepts any bytes; Quote never
// returns more than 45 printable ASCII characters, whatever the input.
// Thread safety: no state; Tokens is a value owned by its caller.
#ifndef MESHSTREAM_IMPORTERS_TEXT_SCAN_H_
#define MESHSTREAM_IMPORTERS_TEXT_SCAN_H_

#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "codec/core/status.h"

namespace meshstream {
namespace mesh_io {

constexpr uint64_t kU32Max = std::numeric_limits<uint32_t>::max();

inline bool IsSpaceChar(char c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f';
}
inline bool IsDigit(char c) { return c >= '0' && c <= '9'; }

// A token for an error message: quoted, at most 40 characters, printable
// ASCII (anything else becomes '?').
std::string Quote(std::string_view s);

inline std::string Num(uint64_t v) { return std::to_string(v); }

// InvalidInput / Unsupported errors starting with the file's path.
inline Status Bad(const std::string& path, const std::string& what) { return InvalidInput(path + ": " + what); }
inline Status Refuse(const std::string& path, const std::string& what) { return Unsupported(path + ": " + what); }

// a * b + *acc without overflow; false when it would overflow.
bool MulAdd(uint64_t a, uint64_t b, uint64_t* acc);

// Digits only (what OpenMesh's `>> unsigned int` reads without surprise), at
// most 2^32 - 1.
bool ParseU32(std::string_view t, uint32_t* out);

// [+-]digits within int32 (what `>> int` reads).
bool IsInt32Token(std::string_view t);

enum class NumberCheck { kOk, kNotDecimal, kOutOfRange };

// A decimal number as `std::istream >> float` reads it completely:
// [+-]? (d+ (. d*)? | . d+) ([eE] [+-]? d+)?, and within float range
// (`>> float` fails on overflow; underflow to 0 is fine). "nan", "inf" and
// hexadecimal floats are not decimal numbers.
NumberCheck CheckDecimal(std::string_view t);

// "'<token>' is outside the float range" / "... is not a finite decimal number".
std::string DescribeBadNumber(NumberCheck check, std::string_view token);

// Whitespace-separated tokens over a byte range, counting lines.
class Tokens {
 public:
  Tokens(std::string_view text, size_t first_line) : text_(text), line_(first_line) {}

  // The next token, or an empty view at the end.
  std::string_view Next();

  // The rest of the current line (as std::getline would return it) and moves
  // past its '\n'.
  std::string_view RestOfLine();

  size_t line() const { return line_; }

 private:
  std::string_view text_;
  size_t pos_ = 0;
  size_t line_;
};

std::vector<std::string_view> SplitWords(std::string_view line);

// An unsigned integer of `size` bytes (at most 8) at `p`.
uint64_t ReadUnsigned(const uint8_t* p, int size, bool big_endian);

}  // namespace mesh_io
}  // namespace meshstream

#endif  // MESHSTREAM_IMPORTERS_TEXT_SCAN_H_
