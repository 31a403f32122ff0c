// meshstream ingest FILE --asset NAME [--server ADDR] [--qp ...] [--wait] [--json]
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli/exit_codes.h"
#include "cli/json_out.h"
#include "cli/remote.h"
#include "cli/verbs.h"
#include "services/store/store.h"
#include "importers/import.h"
#include "services/pipeline/resource_path.h"
#include "services/store/blob_store.h"

namespace meshstream::cli {

namespace {

const char kDetails[] =
    "Uploads a mesh or scene (.gltf with its external files, .glb .obj .ply .off .stl) to a\n"
    "server as the next version of ASSET; the server stores it durably, then encodes it as a job.\n"
    "Files above 1 MiB are uploaded resumably: if the connection breaks, running the same command\n"
    "again continues where the server's copy ends. --wait follows the job until it succeeds or\n"
    "fails (exit 1 with the importer's message). Encoding options left at 0 are the server's\n"
    "defaults (those of 'meshstream encode').\n"
    "\n"
    "Examples:\n"
    "  meshstream ingest bunny.obj --asset bunny --wait\n"
    "  MESHSTREAM_SERVER=assets:7600 MESHSTREAM_TOKEN=mst_... meshstream ingest scene.gltf --json";

constexpr size_t kChunkBytes = size_t{1} << 20;
constexpr uint64_t kResumableFrom = uint64_t{1} << 20;
constexpr int kAttempts = 5;

struct IngestArgs {
  std::string file, asset, comment;
  std::vector<std::string> labels;
  v1::EncodeOptions options;
  int qp = 0, qn = 0, qt = 0;
  std::string packing;
  uint32_t packet_bytes = 0;
  double base_ratio = 0;
  bool wait = false, json = false;
  RemoteOptions remote;
};

struct LocalFile {
  std::string path;  // on disk
  std::string name;  // in the upload
  uint64_t size = 0;
  std::string sha256;
};

StatusOr<LocalFile> Describe(const std::string& path, const std::string& name) {
  const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return NotFound(path + ": cannot open");
  struct stat st {};
  fstat(fd, &st);
  if (!S_ISREG(st.st_mode)) {
    close(fd);
    return InvalidInput(path + ": not a regular file");
  }
  Sha256Hasher hasher;
  std::vector<uint8_t> buffer(kChunkBytes);
  uint64_t size = 0;
  for (;;) {
    const ssize_t n = read(fd, buffer.data(), buffer.size());
    if (n < 0) {
      close(fd);
      return IoError(path + ": read failed");
    }
    if (n == 0) break;
    hasher.Update(buffer.data(), static_cast<size_t>(n));
    size += static_cast<uint64_t>(n);
  }
  close(fd);
  if (size == 0) return InvalidInput(path + ": the file is empty");
  return LocalFile{path, name, size, hasher.FinishHex()};
}

std::string Folder(const std::string& path) {
  const size_t slash = path.rfind('/');
  return slash == std::string::npos ? "" : path.substr(0, slash + 1);
}

std::string BaseName(const std::string& path) {
  const size_t slash = path.rfind('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

std::string PercentDecode(const std::string& uri) {
  std::string out;
  for (size_t i = 0; i < uri.size(); ++i) {
    if (uri[i] == '%' && i + 2 < uri.size() && std::isxdigit(static_cast<unsigned char>(uri[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(uri[i + 2]))) {
      out.push_back(static_cast<char>(std::stoi(uri.substr(i + 1, 2), nullptr, 16)));
      i += 2;
    } else {
      out.push_back(uri[i]);
    }
  }
  return out;
}

// The external files a .gltf names (buffers and images with a relative URI).
StatusOr<std::vector<LocalFile>> Resources(const std::string& gltf_path) {
  auto bytes = ReadFileBytes(gltf_path, uint64_t{256} << 20);
  if (!bytes.ok()) return bytes.status();
  const nlohmann::json doc = nlohmann::json::parse(bytes->begin(), bytes->end(), nullptr, false);
  if (doc.is_discarded() || !doc.is_object()) return InvalidInput(gltf_path + ": not a glTF JSON document");
  std::vector<LocalFile> files;
  for (const char* array : {"buffers", "images"}) {
    const auto it = doc.find(array);
    if (it == doc.end() || !it->is_array()) continue;
    for (size_t i = 0; i < it->size(); ++i) {
      const nlohmann::json& entry = (*it)[i];
      if (!entry.is_object() || !entry.contains("uri") || !entry["uri"].is_string()) continue;
      const std::string uri = entry["uri"].get<std::string>();
      if (uri.rfind("data:", 0) == 0) continue;
      const std::string name = PercentDecode(uri);
      Status s = CheckResourceName(name);
      if (!s.ok()) return s.WithContext(gltf_path + ": " + array + "[" + std::to_string(i) + "].uri");
      bool seen = false;
      for (const LocalFile& f : files) seen = seen || f.name == name;
      if (seen) continue;
      auto file = Describe(Folder(gltf_path) + name, name);
      if (!file.ok()) return file.status().WithContext(gltf_path + ": " + array + "[" + std::to_string(i) + "]");
      files.push_back(std::move(file).value());
    }
  }
  return files;
}

std::string Mib(uint64_t bytes) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f MiB", bytes / 1048576.0);
  return text;
}

// Sends `file` from `offset` as chunks. False when the stream broke.
bool SendFile(grpc::ClientWriter<v1::IngestRequest>& writer, const LocalFile& file, uint64_t offset,
              ProgressLine& progress, uint64_t& sent, uint64_t total, Status& error) {
  const int fd = open(file.path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    error = NotFound(file.path + ": cannot open");
    return false;
  }
  if (offset > 0 && lseek(fd, static_cast<off_t>(offset), SEEK_SET) < 0) {
    close(fd);
    error = IoError(file.path + ": cannot seek");
    return false;
  }
  std::vector<uint8_t> buffer(kChunkBytes);
  v1::IngestRequest request;
  for (;;) {
    const ssize_t n = read(fd, buffer.data(), buffer.size());
    if (n < 0) {
      close(fd);
      error = IoError(file.path + ": read failed");
      return false;
    }
    if (n == 0) break;
    request.set_chunk(buffer.data(), static_cast<size_t>(n));
    if (!writer.Write(request)) {
      close(fd);
      return false;
    }
    sent += static_cast<uint64_t>(n);
    progress.Show("uploading " + file.name + ": " + std::to_string(total ? 100 * sent / total : 100) + "% (" +
                  Mib(sent) + " of " + Mib(total) + ")");
  }
  close(fd);
  return true;
}

struct Uploaded {
  v1::IngestResponse response;
  uint64_t resumed_from = 0;
};

StatusOr<Uploaded> Upload(v1::AssetService::Stub& stub, IngestArgs& args, const LocalFile& main,
                          const std::vector<LocalFile>& resources) {
  uint64_t total = main.size;
  for (const LocalFile& r : resources) total += r.size;
  const bool resumable = main.size >= kResumableFrom;
  std::string upload_id;
  if (resumable) {
    const std::string key = args.asset + "\n" + main.sha256;
    upload_id = "cli-" + Sha256Hex(reinterpret_cast<const uint8_t*>(key.data()), key.size()).substr(0, 48);
  }
  ProgressLine progress(!args.json);
  Uploaded result;
  for (int attempt = 1;; ++attempt) {
    uint64_t offset = 0;
    if (resumable) {
      grpc::ClientContext context;
      PrepareContext(context, args.remote, args.remote.timeout_s);
      v1::QueryUploadRequest query;
      query.set_upload_id(upload_id);
      v1::UploadStatus status;
      const grpc::Status rpc = stub.QueryUpload(&context, query, &status);
      if (rpc.ok()) {
        offset = status.committed_size();
      } else if (rpc.error_code() != grpc::StatusCode::NOT_FOUND) {
        if (rpc.error_code() == grpc::StatusCode::UNAVAILABLE && attempt < kAttempts) {
          std::this_thread::sleep_for(std::chrono::seconds(attempt));
          continue;
        }
        return RemoteError(rpc, args.remote);
      }
      if (offset > main.size) offset = 0;  // not our bytes: the server will say so
      if (offset > 0 && result.resumed_from == 0) result.resumed_from = offset;
    }
    grpc::ClientContext context;
    // Uploads get the per-request timeout per MiB, at least a minute.
    PrepareContext(context, args.remote, std::max(60.0, args.remote.timeout_s * (1.0 + total / 1048576.0)));
    auto writer = stub.Ingest(&context, &result.response);
    v1::IngestRequest request;
    v1::IngestMetadata& m = *request.mutable_metadata();
    m.set_asset(args.asset);
    m.set_filename(main.name);
    m.set_size(main.size);
    m.set_sha256(main.sha256);
    *m.mutable_options() = args.options;
    m.set_comment(args.comment);
    for (const std::string& label : args.labels) {
      const size_t eq = label.find('=');
      (*m.mutable_labels())[label.substr(0, eq)] = eq == std::string::npos ? "" : label.substr(eq + 1);
    }
    m.set_upload_id(upload_id);
    m.set_write_offset(offset);
    Status local;
    uint64_t sent = offset;
    bool streamed = writer->Write(request) && SendFile(*writer, main, offset, progress, sent, total, local);
    for (size_t i = 0; streamed && i < resources.size(); ++i) {
      v1::IngestRequest header;
      header.mutable_resource()->set_name(resources[i].name);
      header.mutable_resource()->set_size(resources[i].size);
      header.mutable_resource()->set_sha256(resources[i].sha256);
      streamed = writer->Write(header) && SendFile(*writer, resources[i], 0, progress, sent, total, local);
    }
    if (!local.ok()) {
      context.TryCancel();
      writer->Finish();
      return local;
    }
    const bool finished_writing = streamed && writer->WritesDone();
    const grpc::Status rpc = writer->Finish();
    progress.Clear();
    if (rpc.ok()) return result;
    // A stream that broke while the bytes were still travelling is resumed;
    // once every byte was sent the server may have made the version, so a
    // retry could make a second one: report instead.
    if (resumable && !finished_writing && rpc.error_code() == grpc::StatusCode::UNAVAILABLE && attempt < kAttempts) {
      std::fprintf(stderr, "meshstream ingest: connection lost (%s); resuming\n", rpc.error_message().c_str());
      std::this_thread::sleep_for(std::chrono::seconds(attempt));
      continue;
    }
    return RemoteError(rpc, args.remote);
  }
}

StatusOr<v1::Job> Wait(v1::AssetService::Stub& stub, const IngestArgs& args, const std::string& job_id) {
  ProgressLine progress(!args.json);
  std::optional<v1::Job> last;
  for (int attempt = 1;; ++attempt) {
    grpc::ClientContext context;
    PrepareContext(context, args.remote, 0);
    v1::GetJobRequest request;
    request.set_job_id(job_id);
    auto reader = stub.WatchJob(&context, request);
    v1::Job job;
    while (reader->Read(&job)) {
      last = job;
      progress.Show("processing " + job.asset() + " v" + std::to_string(job.version()) + ": " +
                    std::to_string(static_cast<int>(job.progress() * 100)) + "% " + job.message());
      if (job.state() == v1::JOB_STATE_SUCCEEDED || job.state() == v1::JOB_STATE_FAILED) break;
    }
    const grpc::Status rpc = reader->Finish();
    if (last && (last->state() == v1::JOB_STATE_SUCCEEDED || last->state() == v1::JOB_STATE_FAILED)) {
      progress.Clear();
      return *last;
    }
    // A draining or restarting server: watch again (the job continues).
    if ((rpc.ok() || rpc.error_code() == grpc::StatusCode::UNAVAILABLE) && attempt < 60) {
      std::this_thread::sleep_for(std::chrono::seconds(1));
      continue;
    }
    return RemoteError(rpc, args.remote);
  }
}

int RunIngest(IngestArgs& args) {
  if (args.asset.empty()) {
    std::string stem = BaseName(args.file);
    stem = stem.substr(0, stem.rfind('.'));
    args.asset = stem;
  }
  Status s = CheckName("--asset", args.asset);
  if (!s.ok()) return ReportError("ingest", s);
  s = CheckMainFilename(BaseName(args.file));
  if (!s.ok()) return ReportError("ingest", s.WithContext(args.file));
  for (const std::string& label : args.labels) {
    if (label.empty() || label[0] == '=') return ReportError("ingest", InvalidArgument("--label '" + label + "': expected KEY=VALUE"));
  }
  args.options.set_qp(args.qp);
  args.options.set_qn(args.qn);
  args.options.set_qt(args.qt);
  args.options.set_packing(args.packing);
  args.options.set_packet_bytes(args.packet_bytes);
  args.options.set_base_ratio(args.base_ratio);
  auto main = Describe(args.file, BaseName(args.file));
  if (!main.ok()) return ReportError("ingest", main.status());
  std::vector<LocalFile> resources;
  if (FileExtension(args.file) == ".gltf") {
    auto found = Resources(args.file);
    if (!found.ok()) return ReportError("ingest", found.status());
    resources = std::move(found).value();
  }
  auto stub = Connect(args.remote);
  if (!stub.ok()) return ReportError("ingest", stub.status());
  auto uploaded = Upload(**stub, args, main.value(), resources);
  if (!uploaded.ok()) return ReportError("ingest", uploaded.status());
  const v1::IngestResponse& r = uploaded->response;
  nlohmann::json j = {{"asset", r.asset()}, {"version", r.version()}, {"job_id", r.job_id()}, {"sha256", r.sha256()}};
  if (uploaded->resumed_from > 0) j["resumed_from"] = uploaded->resumed_from;
  if (!args.json) {
    std::printf("%s -> %s version %lld (job %s, sha256 %s)%s\n", args.file.c_str(), r.asset().c_str(),
                static_cast<long long>(r.version()), r.job_id().c_str(), r.sha256().substr(0, 12).c_str(),
                uploaded->resumed_from ? (" resumed at " + Mib(uploaded->resumed_from)).c_str() : "");
  }
  if (!args.wait) {
    if (args.json) PrintJson(j);
    return kExitOk;
  }
  auto job = Wait(**stub, args, r.job_id());
  if (!job.ok()) return ReportError("ingest", job.status());
  j["job"] = JobJson(job.value());
  if (args.json) {
    PrintJson(j);
  } else if (job->state() == v1::JOB_STATE_SUCCEEDED) {
    std::printf("%s version %lld ready\n", r.asset().c_str(), static_cast<long long>(r.version()));
  }
  if (job->state() == v1::JOB_STATE_FAILED) {
    return ReportError("ingest", InvalidInput(r.asset() + " version " + std::to_string(r.version()) +
                                              " failed: " + job->message()));
  }
  return kExitOk;
}

}  // namespace

Verb AddIngest(CLI::App& root) {
  auto args = std::make_shared<IngestArgs>();
  CLI::App* cmd = AddVerb(root, "ingest", "Uploads a mesh to a server as the next version of an asset.", kDetails);
  cmd->add_option("FILE", args->file, "the file to upload")->required();
  cmd->add_option("--asset", args->asset, "the asset, [A-Za-z0-9._-]{1,128} (default: the file's stem)");
  cmd->add_option("--comment", args->comment, "a note stored with the version");
  cmd->add_option("--label", args->labels, "KEY=VALUE stored with the version (repeatable)")->expected(1)->allow_extra_args(false)->take_all();
  FromEnv(cmd->add_option("--qp", args->qp, "position quantization bits (0: server default)"));
  FromEnv(cmd->add_option("--qn", args->qn, "normal quantization bits (0: server default)"));
  FromEnv(cmd->add_option("--qt", args->qt, "texture coordinate bits (0: server default)"));
  FromEnv(cmd->add_option("--packing", args->packing, "split or bundled (empty: server default)")
              ->check(CLI::IsMember({"", "split", "bundled"})));
  FromEnv(cmd->add_option("--packet-bytes", args->packet_bytes, "datagram payload limit (0: server default)"));
  FromEnv(cmd->add_option("--base-ratio", args->base_ratio, "fraction of the vertices in the base (0: default)")
              ->check(NumberIn(0.0, 1.0)));
  cmd->add_flag("--wait", args->wait, "follow the job until it succeeds or fails");
  cmd->add_flag("--json", args->json, "print one JSON object: the IngestResponse (and with --wait the final job)");
  AddRemoteOptions(cmd, args->remote);
  return {cmd, [args] { return RunIngest(*args); }};
}

}  // namespace meshstream::cli
