// The WebSocket upgrade's checks (StreamSocketRoute::CheckRequest) for
// fuzz_http_request, in a translation unit of their own, so that Beast's
// and the stream service's headers stay out of the fuzzer's main file.
#ifndef MESHSTREAM_TESTS_FUZZ_HTTP_UPGRADE_REQUEST_H_
#define MESHSTREAM_TESTS_FUZZ_HTTP_UPGRADE_REQUEST_H_

#include <optional>
#include <string>
#include <vector>

#include "codec/core/status.h"
#include "services/http/cors.h"

namespace meshstream::fuzz {

// The fields of a `GET /v1/stream` upgrade that CheckRequest reads.
struct UpgradeFields {
  bool tls = false;
  std::optional<std::string> origin, host, authorization;
  std::vector<std::string> protocols;  // the Sec-WebSocket-Protocol lines, at most two
  bool split = false;                  // the second protocol line comes after Host and Sec-WebSocket-Version
};

// The subprotocol the server selects (kStreamSubprotocol).
extern const char kUpgradeSubprotocol[];

// A boost::beast request with those fields, in that order, through
// StreamSocketRoute::CheckRequest.
StatusOr<std::string> CheckUpgradeRequest(const UpgradeFields& fields, const CorsPolicy& cors, int* http_status,
                                          bool* offered_subprotocol);

}  // namespace meshstream::fuzz

#endif  // MESHSTREAM_TESTS_FUZZ_HTTP_UPGRADE_REQUEST_H_
