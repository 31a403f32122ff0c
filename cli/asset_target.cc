#include "cli/asset_target.h"

#include <cstdlib>

#include "proto/api_names.h"

namespace meshstream::cli {

StatusOr<AssetVersion> ParseAssetVersion(const std::string& target) {
  AssetVersion out;
  out.asset = target;
  const size_t at = target.find('@');
  if (at != std::string::npos) {
    const std::string number = target.substr(at + 1);
    out.asset = target.substr(0, at);
    char* end = nullptr;
    out.version = std::strtoll(number.c_str(), &end, 10);
    if (number.empty() || *end != '\0' || out.version < 0) {
      return InvalidArgument(target + ": expected ASSET or ASSET@VERSION (a number >= 0)");
    }
  }
  MS_RETURN_IF_ERROR(CheckName("ASSET", out.asset));
  return out;
}

}  // namespace meshstream::cli
