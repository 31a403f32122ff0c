#include "services/store/open_store.h"

#include <utility>

#include "services/store/sqlite_store.h"

#include "services/store/pg_store.h"

namespace meshstream {

bool IsPostgresSpec(const std::string& spec) {
  return spec.rfind("postgresql://", 0) == 0 || spec.rfind("postgres://", 0) == 0;
}

StatusOr<std::unique_ptr<Store>> OpenStore(const std::string& spec, StoreLock lock) {
  if (spec.empty()) return InvalidArgument("store: must not be empty (a folder or a postgresql:// URI)");
  if (IsPostgresSpec(spec)) {
    auto pg = OpenPgStore(spec);
    if (!pg.ok()) return pg.status();
    return std::unique_ptr<Store>(std::move(pg).value());
  }
  auto sqlite = SqliteStore::Open(spec, lock);
  if (!sqlite.ok()) return sqlite.status();
  return std::unique_ptr<Store>(std::move(sqlite).value());
}

}  // namespace meshstream
