// Opens the store a --store spec names (docs/design/store.md):
//
//   postgresql://...  or  postgres://...   a PostgreSQL database (a libpq
//       connection URI: host, port, user, password, dbname, parameters), the
//       backend for several servers sharing one store (services/store/pg_store.h);
//   anything else                           a folder for the embedded store
//       (SqliteStore, services/store/sqlite_store.h), created when missing.
//
// `lock` matters to the embedded store only: kExclusive (the default) is for
// `meshstream serve`, the one process that owns the folder; kShared is for a
// tool beside a running server (the token verbs), which may read metadata and
// manage tokens (services/store/sqlite_store.h). A PostgreSQL store is shared
// by design and ignores it.
//
// Contract: the spec comes from the operator (a flag or a config file); an
// empty one is InvalidArgument. Errors are those of the backend's Open: for
// example Unavailable when another process holds the folder or the database
// cannot be reached. When this build has no PostgreSQL backend, a
// PostgreSQL spec is Unsupported. Thread safety: may be called from any
// thread; each call opens a new store.
#ifndef MESHSTREAM_SERVICES_STORE_OPEN_STORE_H_
#define MESHSTREAM_SERVICES_STORE_OPEN_STORE_H_

#include <memory>
#include <string>

#include "codec/core/status.h"
#include "services/store/sqlite_store.h"  // StoreLock
#include "services/store/store.h"

namespace meshstream {

// True when `spec` names a PostgreSQL database rather than a folder.
bool IsPostgresSpec(const std::string& spec);

StatusOr<std::unique_ptr<Store>> OpenStore(const std::string& spec, StoreLock lock = StoreLock::kExclusive);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STORE_OPEN_STORE_H_
