// The backend-independent store suite: every Store (services/store/store.h)
// passes the same TEST_P cases (tests/services/store_suite_test.cc).
//
// A backend joins by instantiating the suite in its own test file:
//
//   INSTANTIATE_TEST_SUITE_P(Sqlite, StoreSuite,
//                            ::testing::Values(std::make_shared<StoreBackendFactory>(
//                                StoreBackendFactory{"Sqlite", &MakeSqliteBackend})),
//                            StoreBackendName);
//
// where MakeSqliteBackend returns a StoreBackend on its own fresh storage (a
// temporary folder, a new database in a throwaway cluster). Each test makes
// one backend in SetUp, opens the store once, and may Reopen() it (the
// store is destroyed first, as a server stops before it starts again).
//
// What the suite asserts: the exact status code of every refusal, and for
// the refusals a backend decides the exact message (both backends take them
// from services/store/store_records.h); InvalidArgument messages name the
// field ("tenant", "asset", "upload_id", "job_id", "page_size",
// "page_token", ...); a wrong upload offset names both sizes; reading
// another tenant's object gives exactly the message of a missing one.
// Jobs are claimed in the order their versions were created, even within one
// millisecond. `now_ms` arguments are the real clock (NowMs()), the clock the
// store stamps rows with.
#ifndef MESHSTREAM_TESTS_SERVICES_STORE_SUITE_H_
#define MESHSTREAM_TESTS_SERVICES_STORE_SUITE_H_

#include <functional>
#include <memory>
#include <ostream>
#include <string>
#include <utility>

#include <gtest/gtest.h>

#include "codec/core/status.h"
#include "services/store/store.h"

namespace meshstream {

// One store's storage, for one test.
struct StoreBackend {
  std::string name;
  // Opens a fresh, empty store (called once, first).
  std::function<StatusOr<std::unique_ptr<Store>>()> open;
  // Opens the same store again, as after a restart (the previous one has
  // been destroyed).
  std::function<StatusOr<std::unique_ptr<Store>>()> reopen;
  // Keeps the storage alive (a temporary folder, a cluster) while the
  // backend is; may be empty.
  std::shared_ptr<void> keep_alive;
  // Write a raw state into a stored row behind the store's back, as a
  // hand-edited or damaged database would, while the store is open: for the
  // refusals no call of Store can provoke (a version no longer PROCESSING
  // under a running job, a state that is no value of the enum).
  std::function<Status(const std::string& tenant, const std::string& asset, int64_t version, int64_t state)>
      set_version_state;
  std::function<Status(const std::string& job_id, int64_t state)> set_job_state;
};

// Makes a new backend for each test. `name` becomes the gtest parameter name
// (letters and digits only).
struct StoreBackendFactory {
  std::string name;
  std::function<StatusOr<StoreBackend>()> make;
};

class StoreSuite : public ::testing::TestWithParam<std::shared_ptr<StoreBackendFactory>> {
 protected:
  void SetUp() override {
    auto backend = GetParam()->make();
    ASSERT_TRUE(backend.ok()) << backend.status().ToString();
    backend_ = std::move(backend).value();
    auto store = backend_.open();
    ASSERT_TRUE(store.ok()) << store.status().ToString();
    store_ = std::move(store).value();
  }
  void TearDown() override { store_.reset(); }

  // Destroys the store and opens the same one again.
  void Reopen() {
    store_.reset();
    auto store = backend_.reopen();
    ASSERT_TRUE(store.ok()) << store.status().ToString();
    store_ = std::move(store).value();
  }

  Store& store() { return *store_; }

  StoreBackend backend_;
  std::unique_ptr<Store> store_;
};

// Status helpers for store tests.
inline const Status& StatusOf(const Status& status) { return status; }
template <typename T>
const Status& StatusOf(const StatusOr<T>& value) {
  return value.status();
}
#define MS_EXPECT_OK(expr)                                               \
  do {                                                                   \
    const ::meshstream::Status ms_s_ = ::meshstream::StatusOf(expr);     \
    EXPECT_TRUE(ms_s_.ok()) << ms_s_.ToString();                         \
  } while (false)
#define MS_ASSERT_OK(expr)                                               \
  do {                                                                   \
    const ::meshstream::Status ms_s_ = ::meshstream::StatusOf(expr);     \
    ASSERT_TRUE(ms_s_.ok()) << ms_s_.ToString();                         \
  } while (false)
// The status of `expr` (a Status or StatusOr) has code `code_` (a StatusCode).
#define EXPECT_CODE(expr, code_)                                                \
  do {                                                                          \
    const ::meshstream::Status ms_c_ = ::meshstream::StatusOf(expr);            \
    EXPECT_EQ(ms_c_.code(), code_) << #expr << " gave " << ms_c_.ToString();    \
  } while (false)
// `status` (a Status or StatusOr) has code `code` and exactly `message`.
template <typename S>
void ExpectStatus(const S& status_or, StatusCode code, const std::string& message) {
  const Status& status = StatusOf(status_or);
  EXPECT_EQ(status.code(), code) << message << ": " << status.ToString();
  EXPECT_EQ(status.message(), message);
}
// `lhs = value of expr`, or the test stops with the status.
#define MS_ASSERT_OK_AND_ASSIGN(lhs, expr) \
  MS_ASSERT_OK_AND_ASSIGN_IMPL_(MS_STATUS_CONCAT_(ms_assert_, __LINE__), lhs, expr)
#define MS_ASSERT_OK_AND_ASSIGN_IMPL_(tmp, lhs, expr)     \
  auto tmp = (expr);                                      \
  ASSERT_TRUE(tmp.ok()) << tmp.status().ToString();       \
  lhs = std::move(tmp).value()

// So gtest names the backend in failure messages.
inline void PrintTo(const StoreBackendFactory& factory, std::ostream* os) { *os << factory.name; }

inline std::string StoreBackendName(const ::testing::TestParamInfo<std::shared_ptr<StoreBackendFactory>>& info) {
  return info.param->name;
}

}  // namespace meshstream

#endif  // MESHSTREAM_TESTS_SERVICES_STORE_SUITE_H_
