// Two `meshstream serve` processes on one PostgreSQL (a throwaway cluster the
// test starts): what one ingests the other lists and exports, and when the
// first is killed during a job, the second takes the job over once its
// lease expires and finishes it.
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "testing/asset_calls.h"
#include "testing/pg_cluster.h"
#include "testing/serve_process.h"
#include "testing/test_util.h"

namespace meshstream {
namespace {

using test_util::ServeProcess;

TEST(SharedPostgres, TwoServersShareOneDatabase) {
  auto cluster = test_util::PgCluster::Start();
  ASSERT_TRUE(cluster.ok()) << cluster.status().ToString();
  const std::string spec = "postgresql:///postgres?host=" + (*cluster)->socket_dir() + "&user=postgres";
  auto a = ServeProcess::Start({"--store", spec, "--workers", "1", "--lease", "1500", "--server-id", "server-a"});
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  auto b = ServeProcess::Start({"--store", spec, "--workers", "1", "--lease", "1500", "--server-id", "server-b"});
  ASSERT_TRUE(b.ok()) << b.status().ToString();
  const auto on_a = test_util::NewAssetClient((*a)->address());
  const auto on_b = test_util::NewAssetClient((*b)->address());

  v1::IngestResponse r;
  ASSERT_TRUE(test_util::Ingest(*on_a, "spot", test_util::LoadFile(test_util::ModelPath("spot.obj"), "spot.obj"), &r).ok());
  v1::Job job;
  ASSERT_TRUE(test_util::Watch(*on_b, r.job_id(), &job).ok()) << "the job is visible on the other server";
  EXPECT_EQ(job.state(), v1::JOB_STATE_SUCCEEDED) << job.message();
  const auto from_a = test_util::Export(*on_a, "spot", 0, v1::FORMAT_DRACO_GLB);
  const auto from_b = test_util::Export(*on_b, "spot", 0, v1::FORMAT_DRACO_GLB);
  ASSERT_TRUE(from_a.status.ok() && from_b.status.ok()) << from_b.status.ToString();
  EXPECT_EQ(from_a.sha256, from_b.sha256);
  v1::Version v;
  ASSERT_TRUE(test_util::GetVersion(*on_b, "spot", 1, &v).ok());
  EXPECT_EQ(v.source_sha256(), r.sha256());

  // Only A works now; it is killed while it encodes the horse.
  EXPECT_EQ((*b)->Terminate(), 0) << (*b)->log();
  ASSERT_TRUE(test_util::Ingest(*on_a, "horse", test_util::LoadFile(test_util::ModelPath("horse.ply"), "horse.ply"), &r).ok());
  for (int i = 0; i < 600; ++i) {
    grpc::ClientContext c;
    test_util::Prepare(*on_a, c);
    v1::GetJobRequest q;
    q.set_job_id(r.job_id());
    ASSERT_TRUE(on_a->stub().GetJob(&c, q, &job).ok());
    if (job.state() != v1::JOB_STATE_PENDING) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_EQ(job.state(), v1::JOB_STATE_RUNNING) << "A should be encoding the horse now";
  (*a)->Kill();
  auto b2 = ServeProcess::Start({"--store", spec, "--workers", "1", "--lease", "1500", "--server-id", "server-b2"});
  ASSERT_TRUE(b2.ok()) << b2.status().ToString();
  const auto on_b2 = test_util::NewAssetClient((*b2)->address());
  ASSERT_TRUE(test_util::Watch(*on_b2, r.job_id(), &job).ok());
  EXPECT_EQ(job.state(), v1::JOB_STATE_SUCCEEDED) << job.message();
  EXPECT_GE(job.attempts(), 2) << "taken over after A's lease expired";
  EXPECT_TRUE(test_util::Export(*on_b2, "horse", 0, v1::FORMAT_GLB).status.ok());
  EXPECT_EQ((*b2)->Terminate(), 0) << (*b2)->log();
}

}  // namespace
}  // namespace meshstream
