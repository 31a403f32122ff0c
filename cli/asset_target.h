// "ASSET" or "ASSET@VERSION" on the command line of export and fetch.
#ifndef MESHSTREAM_CLI_ASSET_TARGET_H_
#define MESHSTREAM_CLI_ASSET_TARGET_H_

#include <cstdint>
#include <string>

#include "codec/core/status.h"

namespace meshstream::cli {

// VERSION is a number >= 0 (0 and none: the latest READY); the asset is
// checked as a name (services/store/store_checks.h CheckName). InvalidArgument
// naming the argument otherwise.
struct AssetVersion {
  std::string asset;
  int64_t version = 0;
};
StatusOr<AssetVersion> ParseAssetVersion(const std::string& target);

}  // namespace meshstream::cli

#endif  // MESHSTREAM_CLI_ASSET_TARGET_H_
