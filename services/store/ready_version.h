// The version an export or a session of an asset reads: a number names that
// version, which must be READY; 0 names the latest READY one. The refusals
// say what the version is instead (FailedPrecondition "asset A version V is
// PROCESSING (job J)", "... is FAILED: why", "asset A has no READY version
// yet (version V is ...)"), NotFound for an unknown asset or version,
// InvalidArgument for a negative number.
// Thread safety: as the store's reads.
#ifndef MESHSTREAM_SERVICES_STORE_READY_VERSION_H_
#define MESHSTREAM_SERVICES_STORE_READY_VERSION_H_

#include <cstdint>
#include <string>

#include "codec/core/status.h"
#include "services/store/store.h"

namespace meshstream {

StatusOr<VersionRecord> ResolveReadyVersion(Store& store, const std::string& tenant, const std::string& asset,
                                            int64_t version);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STORE_READY_VERSION_H_
