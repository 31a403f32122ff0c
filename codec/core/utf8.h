// Making names from files valid UTF-8 before they reach any JSON.
//
// File names, OBJ `o`/`g`/`usemtl` names, PLY comments and glTF names come
// from outside and may hold any bytes; JSON (and every JSON library) needs
// valid UTF-8. ToValidUtf8 keeps every well-formed sequence (RFC 3629: no
// overlong forms, no surrogates, nothing above U+10FFFF) and replaces each
// maximal ill-formed subpart by U+FFFD, as the Unicode standard recommends
// (section 3.9, "U+FFFD Substitution of Maximal Subparts").
//
// Contract: pure, safe on any bytes, linear time, output at most three times
// the input. Thread safety: none needed.
#ifndef MESHSTREAM_CODEC_CORE_UTF8_H_
#define MESHSTREAM_CODEC_CORE_UTF8_H_

#include <string>
#include <string_view>

namespace meshstream {

// True when `s` is well-formed UTF-8.
bool IsValidUtf8(std::string_view s);

// `s` with every ill-formed sequence replaced by U+FFFD; `*replaced` (when
// given) says whether anything was replaced.
std::string ToValidUtf8(std::string_view s, bool* replaced = nullptr);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_CORE_UTF8_H_
