// Token, number and byte scanning for the mesh importers (see text_scan.h).
#include "importers/text_scan.h"

#include <algorithm>
#include <cfloat>
#include <charconv>
#include <cmath>

namespace meshstream {
namespace mesh_io {

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

std::string_view Tokens::Next() {
  while (pos_ < text_.size() && IsSpaceChar(text_[pos_])) {
    if (text_[pos_] == '\n') ++line_;
    ++pos_;
  }
  const size_t begin = pos_;
  while (pos_ < text_.size() && !IsSpaceChar(text_[pos_])) ++pos_;
  return text_.substr(begin, pos_ - begin);
}

std::string_view Tokens::RestOfLine() {
  const size_t begin = pos_;
  while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
  std::string_view rest = text_.substr(begin, pos_ - begin);
  if (pos_ < text_.size()) {
    ++pos_;
    ++line_;
  }
  return rest;
}

std::vector<std::string_view> SplitWords(std::string_view line) {
  std::vector<std::string_view> words;
  Tokens tokens(line, 1);
  for (std::string_view t = tokens.Next(); !t.empty(); t = tokens.Next()) words.push_back(t);
  return words;
}

uint64_t ReadUnsigned(const uint8_t* p, int size, bool big_endian) {
  uint64_t v = 0;
  for (int i = 0; i < size; ++i) {
    const int shift = big_endian ? 8 * (size - 1 - i) : 8 * i;
    v |= static_cast<uint64_t>(p[i]) << shift;
  }
  return v;
}

}  // namespace mesh_io
}  // namespace meshstream
