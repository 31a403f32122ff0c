// What the CLI prints as JSON can never throw and is always valid UTF-8.
//
// Paths, names, attribute names, warnings and messages come from outside (a
// file name may hold any bytes); each string passes through ToValidUtf8
// (codec/core/utf8.h) before it enters a JSON value, and PrintJson dumps with
// the replacing error handler as a second guard.
#ifndef MESHSTREAM_CLI_JSON_OUT_H_
#define MESHSTREAM_CLI_JSON_OUT_H_

#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "codec/mesh/mesh.h"

namespace meshstream::cli {

// `s` as valid UTF-8 (ill-formed bytes become U+FFFD).
std::string Utf8(std::string_view s);
std::vector<std::string> Utf8(const std::vector<std::string>& v);

// One JSON object on stdout, on one line; never throws on any string content.
void PrintJson(const nlohmann::json& j);

}  // namespace meshstream::cli

#endif  // MESHSTREAM_CLI_JSON_OUT_H_
