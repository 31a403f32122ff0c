// The throwaway PostgreSQL cluster the store's tests run against
// (testing/pg_cluster.h): it starts on a socket in its own folder, takes
// SQL through libpqxx, and is gone afterwards. Failing here, with the reason,
// is what a machine that cannot run PostgreSQL gets (never a skip).
#include "testing/pg_cluster.h"

#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <pqxx/pqxx>

namespace meshstream {
namespace {

TEST(PgCluster, StartsTakesSqlAndIsRemoved) {
  std::string folder;
  {
    auto cluster = test_util::PgCluster::Start();
    ASSERT_TRUE(cluster.ok()) << cluster.status().ToString();
    folder = cluster.value()->socket_dir();
    pqxx::connection connection(cluster.value()->connection_string());
    pqxx::work tx(connection);
    tx.exec0("CREATE TABLE blobs (digest TEXT PRIMARY KEY, bytes BYTEA NOT NULL)");
    tx.exec_params0("INSERT INTO blobs VALUES ($1, $2)", "ab", std::string("\x01\x02", 2));
    const pqxx::row row = tx.exec1("SELECT count(*), max(length(bytes)) FROM blobs");
    EXPECT_EQ(row[0].as<int>(), 1);
    EXPECT_EQ(row[1].as<int>(), 2);
    tx.commit();
    const pqxx::row version = pqxx::nontransaction(connection).exec1("SHOW server_version_num");
    EXPECT_GE(std::stoi(version[0].c_str()), 150000);
  }
  EXPECT_FALSE(std::filesystem::exists(folder)) << folder;
}

}  // namespace
}  // namespace meshstream
