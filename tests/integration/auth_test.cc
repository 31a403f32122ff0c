// Secure by default: tokens, tenants, read-only tokens, revocation, the
// loopback rule without --auth, TLS with a certificate made by openssl, and
// the upload size limit. Real `meshstream serve` processes; tokens are made
// with `meshstream token create` while the server runs.
#include <memory>
#include <thread>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "testing/asset_calls.h"
#include "testing/grpc_probe.h"
#include "testing/serve_process.h"
#include "testing/test_util.h"

namespace meshstream {
namespace {

using test_util::RunCommand;
using test_util::ServeProcess;
using sdk::UploadFile;

UploadFile Tet() {
  const std::string text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\n";
  return UploadFile::FromBytes("tet.obj", std::vector<uint8_t>(text.begin(), text.end()));
}

// The token: the last line of `meshstream token create`'s stdout.
std::string CreateToken(const std::string& store, const std::string& tenant, bool read_only = false) {
  const auto r = RunCommand(test_util::Cli() + " token create --store " + test_util::Quote(store) + " --tenant " +
                            tenant + (read_only ? " --read-only" : ""));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  std::string out = r.out;
  while (!out.empty() && out.back() == '\n') out.pop_back();
  const size_t nl = out.rfind('\n');
  return nl == std::string::npos ? out : out.substr(nl + 1);
}

std::string TokenId(const std::string& store, const std::string& tenant) {
  const auto r = RunCommand(test_util::Cli() + " token list --json --store " + test_util::Quote(store));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out, nullptr, false);
  for (const auto& t : j["tokens"]) {
    if (t["tenant"] == tenant) return t["id"].get<std::string>();
  }
  return "";
}

TEST(AuthAndTls, TenantsSeeOnlyTheirOwnAssets) {
  test_util::TempDir dir;
  const std::string store = dir.File("store");
  auto server = ServeProcess::Start({"--store", store, "--auth", "--workers", "1"});
  ASSERT_TRUE(server.ok()) << server.status().ToString();
  const std::string a = CreateToken(store, "studio-a");
  const std::string a_read = CreateToken(store, "studio-a", true);
  const std::string b = CreateToken(store, "studio-b");
  ASSERT_EQ(a.rfind("mst_", 0), 0u) << a;
  const std::string address = (*server)->address();

  const auto none = test_util::NewAssetClient(address);
  const auto bad = test_util::NewAssetClient(address, "mst_" + std::string(64, '0'));
  const auto junk = test_util::NewAssetClient(address, "hello");
  const auto client_a = test_util::NewAssetClient(address, a);
  const auto reader_a = test_util::NewAssetClient(address, a_read);
  const auto client_b = test_util::NewAssetClient(address, b);
  v1::IngestResponse r;
  EXPECT_EQ(test_util::Ingest(*none, "tet", Tet(), &r).code(), StatusCode::kUnauthenticated);
  EXPECT_EQ(test_util::Ingest(*bad, "tet", Tet(), &r).code(), StatusCode::kUnauthenticated);
  EXPECT_EQ(test_util::Ingest(*junk, "tet", Tet(), &r).code(), StatusCode::kUnauthenticated);
  v1::Version v;
  EXPECT_EQ(test_util::GetVersion(*none, "tet", 0, &v).code(), StatusCode::kUnauthenticated);

  ASSERT_TRUE(test_util::Ingest(*client_a, "tet", Tet(), &r).ok());
  v1::Job job;
  ASSERT_TRUE(test_util::Watch(*client_a, r.job_id(), &job).ok());
  EXPECT_EQ(job.state(), v1::JOB_STATE_SUCCEEDED) << job.message();

  // Tenant B: the asset, its version, its job and its export do not exist.
  const Status other = test_util::GetVersion(*client_b, "tet", 1, &v);
  EXPECT_EQ(other.code(), StatusCode::kNotFound);
  v1::Version missing;
  const Status truly_missing = test_util::GetVersion(*client_b, "never-made", 1, &missing);
  EXPECT_EQ(truly_missing.code(), StatusCode::kNotFound);
  EXPECT_EQ(test_util::Export(*client_b, "tet", 0, v1::FORMAT_GLB).status.code(), StatusCode::kNotFound);
  v1::Job other_job;
  EXPECT_EQ(test_util::Watch(*client_b, r.job_id(), &other_job).code(), StatusCode::kNotFound);
  {
    grpc::ClientContext c;
    test_util::Prepare(*client_b, c);
    v1::ListAssetsResponse assets;
    ASSERT_TRUE(client_b->stub().ListAssets(&c, v1::ListAssetsRequest(), &assets).ok());
    EXPECT_EQ(assets.assets_size(), 0);
  }
  // B's own asset of the same name is its version 1, not A's version 2, and
  // the same bytes are encoded again for B: a cache hit would tell B that
  // another tenant has this file.
  v1::IngestResponse rb;
  ASSERT_TRUE(test_util::Ingest(*client_b, "tet", Tet(), &rb).ok());
  EXPECT_EQ(rb.version(), 1);
  v1::Job job_b;
  ASSERT_TRUE(test_util::Watch(*client_b, rb.job_id(), &job_b).ok());
  EXPECT_EQ(job_b.state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(job_b.message().find("reused"), std::string::npos) << job_b.message();
  // ... while A's own second upload of it is a cache hit.
  v1::IngestResponse ra2;
  ASSERT_TRUE(test_util::Ingest(*client_a, "tet", Tet(), &ra2).ok());
  v1::Job job_a2;
  ASSERT_TRUE(test_util::Watch(*client_a, ra2.job_id(), &job_a2).ok());
  EXPECT_NE(job_a2.message().find("reused"), std::string::npos) << job_a2.message();
  // Uploads and jobs are per tenant too.
  {
    grpc::ClientContext c;
    test_util::Prepare(*client_b, c);
    v1::GetJobRequest q;
    q.set_job_id(r.job_id());
    v1::Job j;
    const grpc::Status s = client_b->stub().GetJob(&c, q, &j);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::NOT_FOUND);
  }
  // The CLI with its token from the environment.
  const auto env_ok = RunCommand("MESHSTREAM_TOKEN=" + a + " " + test_util::Cli() + " assets --json --server " + address);
  EXPECT_EQ(env_ok.exit_code, 0) << env_ok.err;
  EXPECT_NE(env_ok.out.find("\"tet\""), std::string::npos) << env_ok.out;
  const auto no_token = RunCommand(test_util::Cli() + " assets --server " + address);
  EXPECT_EQ(no_token.exit_code, 1) << no_token.err;
  EXPECT_NE(no_token.err.find("MESHSTREAM_TOKEN"), std::string::npos) << no_token.err;

  // Read-only: reads and exports, never ingests.
  EXPECT_TRUE(test_util::GetVersion(*reader_a, "tet", 1, &v).ok());
  EXPECT_TRUE(test_util::Export(*reader_a, "tet", 1, v1::FORMAT_GLB).status.ok());
  EXPECT_EQ(test_util::Ingest(*reader_a, "tet", Tet(), &r).code(), StatusCode::kPermissionDenied);

  // Revocation takes effect at the next request.
  const std::string id = TokenId(store, "studio-b");
  ASSERT_FALSE(id.empty());
  const auto revoked = RunCommand(test_util::Cli() + " token revoke --store " + test_util::Quote(store) + " " + id);
  ASSERT_EQ(revoked.exit_code, 0) << revoked.err;
  EXPECT_EQ(test_util::GetVersion(*client_b, "tet", 1, &v).code(), StatusCode::kUnauthenticated);
  const auto list = RunCommand(test_util::Cli() + " token list --store " + test_util::Quote(store));
  EXPECT_EQ(list.out.find(b), std::string::npos) << "token list never shows a secret";
  EXPECT_NE(list.out.find("revoked"), std::string::npos) << list.out;
  EXPECT_EQ((*server)->Terminate(), 0) << (*server)->log();
}

TEST(AuthAndTls, TokenVerbsNeverMistakeATypoForAnEmptyStore) {
  test_util::TempDir dir;
  const auto list = RunCommand(test_util::Cli() + " token list --store " + test_util::Quote(dir.File("typo")));
  EXPECT_EQ(list.exit_code, 1) << list.err;
  EXPECT_NE(list.err.find("no meshstream store"), std::string::npos) << list.err;
  const auto revoke = RunCommand(test_util::Cli() + " token revoke 0123456789abcdef --store " + test_util::Quote(dir.File("typo")));
  EXPECT_EQ(revoke.exit_code, 1) << revoke.err;
  // create makes the store (tokens before the server's first start), and says so.
  EXPECT_EQ(CreateToken(dir.File("new"), "studio").rfind("mst_", 0), 0u);
  EXPECT_EQ(RunCommand(test_util::Cli() + " token list --store " + test_util::Quote(dir.File("new"))).exit_code, 0);
}

TEST(AuthAndTls, OnlyLoopbackWithoutAuth) {
  test_util::TempDir dir;
  const auto refused = RunCommand(test_util::Cli() + " serve --listen 0.0.0.0:0 --store " +
                                  test_util::Quote(dir.File("store")));
  EXPECT_EQ(refused.exit_code, 2) << refused.err;
  EXPECT_NE(refused.err.find("--auth"), std::string::npos) << refused.err;
  auto insecure = ServeProcess::Start({"--listen", "0.0.0.0:0", "--insecure", "--store", dir.File("store")});
  ASSERT_TRUE(insecure.ok()) << insecure.status().ToString();
  EXPECT_NE((*insecure)->log().find("warning"), std::string::npos) << (*insecure)->log();
  EXPECT_EQ((*insecure)->Terminate(), 0);
}

TEST(AuthAndTls, TlsWithACertificateFromOpenssl) {
  test_util::TempDir dir;
  const std::string cert = dir.File("cert.pem"), key = dir.File("key.pem");
  const auto made = RunCommand("openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -days 2 "
                               "-subj /CN=localhost -addext subjectAltName=DNS:localhost,IP:127.0.0.1 -keyout " +
                               test_util::Quote(key) + " -out " + test_util::Quote(cert));
  ASSERT_EQ(made.exit_code, 0) << made.err;
  auto server = ServeProcess::Start({"--store", dir.File("store"), "--tls-cert", cert, "--tls-key", key});
  ASSERT_TRUE(server.ok()) << server.status().ToString();
  sdk::ClientOptions tls_options;
  tls_options.tls = true;
  tls_options.tls_ca_pem = test_util::ReadText(cert);
  tls_options.tls_server_name = "localhost";
  const auto tls = test_util::NewAssetClient((*server)->address(), "", tls_options);
  v1::IngestResponse r;
  ASSERT_TRUE(test_util::Ingest(*tls, "tet", Tet(), &r).ok());
  v1::Job job;
  ASSERT_TRUE(test_util::Watch(*tls, r.job_id(), &job).ok());
  EXPECT_EQ(job.state(), v1::JOB_STATE_SUCCEEDED);
  // A plaintext client gets nowhere.
  const auto plain = test_util::NewAssetClient((*server)->address());
  v1::Version v;
  EXPECT_EQ(test_util::GetVersion(*plain, "tet", 1, &v).code(), StatusCode::kUnavailable);
  // The CLI over TLS.
  const auto versions = RunCommand(test_util::Cli() + " versions tet --json --server " + (*server)->address() +
                                   " --tls-ca " + test_util::Quote(cert));
  EXPECT_EQ(versions.exit_code, 0) << versions.err;
  EXPECT_EQ((*server)->Terminate(), 0);
}

TEST(AuthAndTls, UploadsAboveMaxUploadAreRefusedBeforeAnyByte) {
  test_util::TempDir dir;
  auto server = ServeProcess::Start({"--store", dir.File("store"), "--max-upload", "1K", "--no-reflection"});
  ASSERT_TRUE(server.ok()) << server.status().ToString();
  const auto client = test_util::NewAssetClient((*server)->address());
  std::vector<uint8_t> big(4096, ' ');
  v1::IngestResponse r;
  const Status s = test_util::Ingest(*client, "big", UploadFile::FromBytes("big.obj", big), &r);
  EXPECT_EQ(s.code(), StatusCode::kResourceExhausted) << s.ToString();
  EXPECT_NE(s.ToString().find("--max-upload"), std::string::npos) << s.ToString();
  // Reflection off when asked.
  const auto [status, bytes] = test_util::ListServicesByReflection(client->channel());
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNIMPLEMENTED) << bytes;
  EXPECT_EQ(test_util::CheckHealth(client->channel()).serving_status, 1);
  EXPECT_EQ((*server)->Terminate(), 0);
}

TEST(AuthAndTls, WatchStreamsAreCapped) {
  test_util::TempDir dir;
  auto server = ServeProcess::Start({"--store", dir.File("store"), "--workers", "1", "--max-watchers", "1"});
  ASSERT_TRUE(server.ok()) << server.status().ToString();
  const auto client = test_util::NewAssetClient((*server)->address());
  v1::IngestResponse r;
  ASSERT_TRUE(test_util::Ingest(*client, "horse", test_util::LoadFile(test_util::ModelPath("horse.ply"), "horse.ply"), &r).ok());
  // The first watch holds the only slot from its first message until the
  // job ends (the horse's encode takes seconds; the second watch starts
  // right after that first message).
  grpc::ClientContext first_context;
  test_util::Prepare(*client, first_context);
  v1::GetJobRequest request;
  request.set_job_id(r.job_id());
  auto first = client->stub().WatchJob(&first_context, request);
  v1::Job seen;
  ASSERT_TRUE(first->Read(&seen));
  ASSERT_NE(seen.state(), v1::JOB_STATE_SUCCEEDED) << "the job must still run while the cap is tested";
  v1::Job second_last;
  const Status second = test_util::Watch(*client, r.job_id(), &second_last);
  EXPECT_EQ(second.code(), StatusCode::kResourceExhausted) << second.ToString();
  while (first->Read(&seen)) {
  }
  EXPECT_TRUE(first->Finish().ok());
  EXPECT_EQ(seen.state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ((*server)->Terminate(), 0);
}

}  // namespace
}  // namespace meshstream
