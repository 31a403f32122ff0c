// The client of meshstream.v1.AssetService (docs/spec/api.md): upload a mesh as
// the next version of an asset (resumable, with progress), follow its job,
// list assets and versions, export a version with its digest checked. The
// one client of the API in meshstream: the CLI's client verbs (ingest,
// versions, assets, export) and the tests use it, and an engine or a content
// pipeline can too (sessions: session.h).
//
// Ownership: an AssetClient shares its Client (client.h: the channel, the
// token, TLS, the request timeout); several AssetClients and Sessions may
// share one Client. Callbacks are called on the calling thread, inside the
// call, and must not call back into the same AssetClient.
//
// Thread safety: every method may be called from several threads at once
// (each call has its own gRPC context); the callbacks of one call run on that
// call's thread only.
//
// Errors: every method returns the server's Status as FromGrpcStatus reads it
// (proto/rpc_status.h): kNotFound, kInvalidArgument (the server refused the
// request), kUnauthenticated, kPermissionDenied, kResourceExhausted,
// kDataLoss, ... A server that cannot be reached is kUnavailable and a
// request that ran out of time kDeadlineExceeded, both with the server's
// address in the message ("127.0.0.1:1: the server cannot be reached").
// Local files that cannot be read are kNotFound / kIoError / kInvalidInput
// naming the path. Export refuses bytes whose SHA-256 is not the one the
// server announced (kDataLoss; nothing is returned). What the server sends
// is not trusted further than that: an announced size reserves at most 64 MiB
// ahead of the bytes themselves, and an export stops at ExportRequest::max_bytes.
//
// Retries: only where a retry cannot do harm twice.
//   - Ingest: a resumable upload (IngestOptions::resume) whose stream broke
//     with kUnavailable before every byte was sent is resumed: the client asks
//     the server how much it holds (QueryUpload) and sends the rest, up to
//     IngestOptions::attempts in all, waiting attempt x retry_wait between
//     them. Once every byte was sent the server may have made the version, so
//     a failure then is returned, never retried (a retry could make a second
//     version). A non-resumable upload is never retried.
//   - Watch: reconnects (WatchOptions::reconnects times) when the stream ends
//     before the job finished or breaks with kUnavailable: a server that
//     drains or restarts keeps the job.
//   - Nothing else is retried.
#ifndef MESHSTREAM_SDK_ASSET_CLIENT_H_
#define MESHSTREAM_SDK_ASSET_CLIENT_H_

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "codec/core/status.h"
#include "meshstream/v1/asset_service.grpc.pb.h"
#include "sdk/client.h"

namespace meshstream::sdk {

// One file of an upload: read from `path` when it is set, else `bytes`.
struct UploadFile {
  std::string name;             // in the upload: the main file's file name, or a resource's relative path
  uint64_t size = 0;
  std::string sha256;           // lower-case hex of the whole file
  std::string path;             // on disk; empty: the file is `bytes`
  std::vector<uint8_t> bytes;

  // Reads the file once to size and hash it (it is read again when sent).
  // kNotFound / kIoError / kInvalidInput (not a regular file) naming `path`.
  static StatusOr<UploadFile> FromPath(const std::string& path, const std::string& name);
  static UploadFile FromBytes(std::string name, std::vector<uint8_t> bytes);
};

// What Ingest uploads: the main file, its resources (the external files of a
// .gltf) and what is stored with the version.
struct Upload {
  std::string asset;
  UploadFile main;
  std::vector<UploadFile> resources;
  v1::EncodeOptions options;    // fields left at 0 / "": the server's defaults
  std::string comment;
  std::map<std::string, std::string> labels;
};

// The upload of the file at `path` (named by its base name) as `asset`; for a
// .gltf also every file it names by a relative URI, from its folder
// (importers/gltf_files.h). The files are sized and hashed here.
StatusOr<Upload> UploadFromPath(const std::string& asset, const std::string& path);

// The upload id Ingest uses for a resumable upload unless one is given: "cli-"
// and 48 hex digits of SHA-256(asset + "\n" + the main file's sha256), so the
// same file sent again as the same asset continues the same upload (the name
// is the CLI's, docs/spec/cli.md, kept so that both resume each other's uploads).
std::string DefaultUploadId(const std::string& asset, const std::string& main_sha256);

// The messages of an Ingest stream that name its files (docs/spec/api.md): the
// first, the metadata with the asset and the main file's name, size and
// sha256 (Ingest adds the upload's options, comment, labels, upload id and
// offset), and the header before each resource's chunks (its name, size and
// sha256). Tests of the API build raw streams from them.
v1::IngestRequest IngestMetadataMessage(const std::string& asset, const UploadFile& main);
v1::IngestRequest IngestResourceMessage(const UploadFile& resource);

struct IngestProgress {
  std::string file;     // the file being sent
  uint64_t sent = 0;    // bytes of the whole upload the server has or was sent, resumed bytes included
  uint64_t total = 0;   // bytes of the whole upload
  int attempt = 1;
};

struct IngestOptions {
  enum class Resume { kAuto, kAlways, kNever };
  // kAuto: resumable when the main file has at least kResumableFrom bytes.
  Resume resume = Resume::kAuto;
  static constexpr uint64_t kResumableFrom = uint64_t{1} << 20;
  std::string upload_id;        // empty: DefaultUploadId
  int attempts = 5;             // of a resumable upload, the first included
  std::chrono::milliseconds retry_wait{1000};  // before attempt k + 1: k x retry_wait
  size_t chunk_bytes = size_t{1} << 20;         // per IngestRequest (the server's limit is 2 MiB)
  std::function<void(const IngestProgress&)> on_progress;      // after every chunk sent
  std::function<void(const Status& cause, int next_attempt)> on_retry;  // before each resumed attempt
};

struct IngestResult {
  v1::IngestResponse response;
  uint64_t resumed_from = 0;    // the server's bytes the first resumed attempt started from (0: none)
  int attempts = 1;
};

struct WatchOptions {
  int reconnects = 0;           // watch again this many times when the stream ends early (see Retries)
  std::chrono::milliseconds reconnect_wait{1000};
  std::function<void(const v1::Job&)> on_update;  // every state the server sends, in order
};

struct ExportRequest {
  std::string asset;
  int64_t version = 0;          // 0: the latest READY version
  v1::Format format = v1::FORMAT_GLB;
  std::optional<int32_t> lod;   // unset: the full mesh
  // The most bytes accepted (the server's own cap is 4 GiB); beyond it the
  // export is cancelled with kResourceExhausted.
  uint64_t max_bytes = uint64_t{4} << 30;
};

struct Exported {
  std::vector<uint8_t> bytes;   // the whole file; its SHA-256 was checked
  std::string sha256;
  int64_t version = 0;          // the version exported (the latest when 0 was asked)
  size_t chunks = 0;
  size_t largest_chunk = 0;
};

class AssetClient {
 public:
  // A client on a new connection (Client::Create).
  static StatusOr<std::unique_ptr<AssetClient>> Create(const ClientOptions& options);
  // A client on an existing connection; `client` must not be null.
  explicit AssetClient(std::shared_ptr<const Client> client);

  const Client& client() const { return *client_; }
  const std::shared_ptr<grpc::Channel>& channel() const { return client_->channel(); }

  // Uploads `upload` and returns the server's answer (the version made and its
  // job). Local checks before any byte is sent: an asset and a main file name
  // (kInvalidArgument), files with a size and a digest (UploadFile::From*).
  // The deadline is the request timeout per MiB of the upload, at least 60 s.
  StatusOr<IngestResult> Ingest(const Upload& upload, const IngestOptions& options = {}) const;
  // The bytes the server holds of a resumable upload; kNotFound when it holds none.
  StatusOr<uint64_t> QueryUpload(const std::string& upload_id) const;

  StatusOr<v1::Job> GetJob(const std::string& job_id) const;
  // Follows the job until it SUCCEEDED or FAILED (both are OK here: the job's
  // state says which) and returns its last state. No deadline.
  StatusOr<v1::Job> Watch(const std::string& job_id, const WatchOptions& options = {}) const;

  // Every page, in the server's order.
  StatusOr<std::vector<v1::Asset>> ListAssets() const;
  StatusOr<std::vector<v1::Version>> ListVersions(const std::string& asset) const;
  StatusOr<v1::Version> GetVersion(const std::string& asset, int64_t version) const;

  // Downloads a version; `on_progress(received, total)` after every chunk
  // (total: the server's announced size, 0 when unknown). The bytes are
  // returned only when their SHA-256 is the one the server sent with the last
  // chunk (kDataLoss otherwise). No deadline: a large export decodes and
  // sends as long as it takes.
  StatusOr<Exported> Export(const ExportRequest& request,
                            const std::function<void(uint64_t received, uint64_t total)>& on_progress = {}) const;

  // The generated stub on this client's channel, for calls this class does not
  // wrap (tests of the API itself send malformed streams through it); prepare
  // its contexts with client().Prepare.
  v1::AssetService::Stub& stub() const { return *stub_; }

 private:
  // A failed call's Status, with the server's address for the transport codes.
  Status CallStatus(const grpc::Status& status) const;

  std::shared_ptr<const Client> client_;
  std::unique_ptr<v1::AssetService::Stub> stub_;
};

}  // namespace meshstream::sdk

#endif  // MESHSTREAM_SDK_ASSET_CLIENT_H_
