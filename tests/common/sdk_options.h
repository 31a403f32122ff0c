// SDK session options in one call, for the tests that open many sessions.
#ifndef MESHSTREAM_TESTS_COMMON_SDK_OPTIONS_H_
#define MESHSTREAM_TESTS_COMMON_SDK_OPTIONS_H_

#include <string>

#include "sdk/session.h"

namespace meshstream::test_util {

inline sdk::SessionOptions SessionFor(const std::string& asset, int64_t version = 0, int32_t max_level = -1,
                                      bool tcp_only = false, const std::string& udp_via = "") {
  sdk::SessionOptions o;
  o.asset = asset;
  o.version = version;
  o.max_level = max_level;
  o.tcp_only = tcp_only;
  o.udp_via = udp_via;
  return o;
}

}  // namespace meshstream::test_util

#endif  // MESHSTREAM_TESTS_COMMON_SDK_OPTIONS_H_
