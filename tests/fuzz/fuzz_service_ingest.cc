// libFuzzer target for the Ingest state machine (services/ingest/
// ingest_upload.h) as the gRPC service drives it (services/grpc/
// asset_service.cc): serialized meshstream.v1.IngestRequest messages from
// the client, converted by proto_convert's FromProto, fed to an IngestUpload
// over a real SqliteStore, then Finish.
//
// Input:
//   byte 0       flags: bit 0 keep going after an error (the service ends the
//                call at its first error; with the bit set every later
//                message and Finish still reach the object, which must stay
//                safe), bit 1 the tenant ("default" or "fuzz-b");
//   then frames  action (1 byte), length (2 bytes, little endian), payload
//                (a length past the end takes what is left). Action % 4:
//                0, 3  the payload is one IngestRequest (skipped when it does
//                      not parse), delivered to the current call;
//                1     the client closes its stream: Finish, a new call;
//                2     the client goes away: the call is dropped without
//                      Finish, a new call.
//   The end of the input closes the stream of the current call when it got a
//   message.
//
// The store lives in a per-process temporary folder (under /dev/shm when it
// exists), opened once and removed at exit; every kResetRuns runs it is
// removed and opened again, and every run ends with ExpireUploads(0), so
// neither disk use nor state grows without bound and resumable uploads do
// not leak from one input into the next. Limits are small (64 KiB per
// upload, 16 KiB per chunk, 4 resources, 4 labels of 16/32 bytes, 64-byte
// comment) so the fuzzer reaches every limit.
//
// The harness keeps its own model of what the store must hold: the bytes of
// each resumable upload and, per call, the main file's and each resource's
// accepted bytes. Invariants (a violation stops the fuzzer, __builtin_trap):
//   - no crash, and no Internal error except "Finish called twice";
//   - a resumable upload's committed size is what the model holds: Begin
//     accepts a write_offset only when it equals it, and after every call
//     the store's UploadSize agrees (or the upload is gone because Finish
//     committed or discarded it);
//   - when Finish succeeds: the version is the next one of its asset, of this
//     tenant, with the announced file name and size; its source digest is
//     the SHA-256 of exactly the bytes the client sent (the announced digest,
//     lower-cased, when there was one), and GetBlob (which re-hashes) returns
//     those bytes; the same holds for every resource; GetVersion returns the
//     record; its job exists; its options_json parses;
//   - when Finish fails, no version appears.
#include <signal.h>
#include <sys/types.h>
#include <unistd.h>

#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <google/protobuf/stubs/logging.h>

#include "codec/core/status.h"
#include "meshstream/v1/asset_service.pb.h"
#include "proto/api_names.h"
#include "services/auth/authenticator.h"
#include "services/grpc/proto_convert.h"
#include "services/ingest/ingest_upload.h"
#include "services/pipeline/encode_options.h"
#include "services/store/blob_store.h"
#include "services/store/sqlite_store.h"
#include "services/store/store.h"
#include "tests/fuzz/fuzz_service_util.h"

namespace {

namespace fs = std::filesystem;
using meshstream::IngestUpload;
using meshstream::Status;
using meshstream::StatusCode;

constexpr char kTarget[] = "fuzz_service_ingest";
[[noreturn]] void Bug(const std::string& what) { meshstream::fuzz::FuzzBug(kTarget, what); }
using meshstream::fuzz::TempRoot;
using meshstream::fuzz::RemoveStaleFolders;
constexpr size_t kMaxInputBytes = size_t{256} << 10;
constexpr uint64_t kResetRuns = 500;
constexpr uint8_t kKeepGoing = 1, kOtherTenant = 2;
constexpr uint8_t kMessage = 0, kClose = 1, kGoAway = 2;

meshstream::IngestLimits Limits() {
  meshstream::IngestLimits limits;
  limits.max_upload_bytes = 64 << 10;
  limits.max_chunk_bytes = 16 << 10;
  limits.max_resources = 4;
  limits.max_labels = 4;
  limits.max_label_key_bytes = 16;
  limits.max_label_value_bytes = 32;
  limits.max_comment_bytes = 64;
  return limits;
}

// MESHSTREAM_FUZZ_TRACE=1: every message's and Finish's status on stderr.
void Trace(const char* what, const Status& s) {
  static const bool on = std::getenv("MESHSTREAM_FUZZ_TRACE") != nullptr;
  if (on) std::fprintf(stderr, "%s: %s: %s\n", kTarget, what, s.ToString().c_str());
}

std::string Sha(const std::string& bytes) {
  return meshstream::Sha256Hex(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
}

std::string Lower(std::string s) {
  for (char& c : s) {
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  }
  return s;
}

// --- the temporary store ---------------------------------------------------

struct Fixture {
  std::string dir;
  std::unique_ptr<meshstream::SqliteStore> store;
  uint64_t runs = 0;
  // (tenant, asset) -> the last version this store created.
  std::map<std::pair<std::string, std::string>, int64_t> versions;
};

Fixture* fixture = nullptr;

void CloseStore() {
  if (fixture == nullptr) return;
  fixture->store.reset();
  fixture->versions.clear();
  std::error_code ec;
  fs::remove_all(fixture->dir, ec);
}

void OpenStore() {
  CloseStore();
  auto store = meshstream::SqliteStore::Open(fixture->dir);
  if (!store.ok()) Bug("cannot open the store in " + fixture->dir + ": " + store.status().ToString());
  fixture->store = std::move(store).value();
}

Fixture& GetFixture() {
  if (fixture == nullptr) {
    const std::string root = TempRoot();
    const std::string prefix = std::string("meshstream-") + kTarget + "-";
    RemoveStaleFolders(root, prefix);
    fixture = new Fixture;
    fixture->dir = root + "/" + prefix + std::to_string(getpid());
    std::atexit(CloseStore);
    OpenStore();
  } else if (++fixture->runs % kResetRuns == 0) {
    OpenStore();
  }
  return *fixture;
}

// --- one call ----------------------------------------------------------------

// What the client sent that the upload accepted.
struct Expected {
  bool begun = false;
  meshstream::IngestMeta meta;
  std::string main;  // this call's accepted bytes of the main file
  std::vector<std::pair<std::string, std::string>> resources;  // name, accepted bytes
};

class Session {
 public:
  Session(Fixture& f, std::string tenant, bool keep_going)
      : f_(f), tenant_(std::move(tenant)), keep_going_(keep_going) {}

  // The model of the resumable uploads: upload_id -> committed bytes.
  std::map<std::string, std::string> uploads;

  void Deliver(const meshstream::v1::IngestRequest& request) {
    if (!call_) call_ = std::make_unique<IngestUpload>(f_.store.get(), meshstream::Principal{tenant_, false}, Limits());
    if (failed_ && !keep_going_) return;
    Status s;
    switch (request.kind_case()) {
      case meshstream::v1::IngestRequest::kMetadata: s = Begin(meshstream::FromProto(request.metadata())); break;
      case meshstream::v1::IngestRequest::kResource: s = BeginResource(meshstream::FromProto(request.resource())); break;
      case meshstream::v1::IngestRequest::kChunk: s = Chunk(request.chunk()); break;
      default: s = meshstream::InvalidArgument("a message with none of metadata, resource or chunk set"); break;
    }
    if (s.ok() && !call_->begun()) s = meshstream::InvalidArgument("the first message must be metadata");
    Trace(request.kind_case() == meshstream::v1::IngestRequest::kMetadata   ? "metadata"
          : request.kind_case() == meshstream::v1::IngestRequest::kResource ? "resource"
          : request.kind_case() == meshstream::v1::IngestRequest::kChunk    ? "chunk"
                                                                            : "empty message",
          s);
    if (!s.ok()) {
      CheckError(s, "a message");
      failed_ = true;
    }
  }

  // The client closed its stream (finish) or went away (!finish).
  void End(bool finish) {
    if (!call_) return;
    std::optional<Status> finished;
    if (finish && (!failed_ || keep_going_)) {
      finished = Finish();
      Trace("Finish", *finished);
    } else {
      Trace(finish ? "closed after an error" : "client went away", Status::Ok());
    }
    if (expected_.begun && !expected_.meta.upload_id.empty()) SyncUpload(finished);
    call_.reset();
    expected_ = Expected{};
    failed_ = false;
  }

 private:
  Status Begin(const meshstream::IngestMeta& meta) {
    const bool first = !call_->begun();
    Status s = call_->Begin(meta);
    if (!s.ok()) return s;
    if (!first) Bug("a second metadata message was accepted");
    if (meta.size == 0 || meta.size > Limits().max_upload_bytes) Bug("Begin accepted size " + std::to_string(meta.size));
    if (!meshstream::IsValidName(meta.asset) || !meshstream::CheckMainFilename(meta.filename).ok()) {
      Bug("Begin accepted an invalid asset or file name");
    }
    if (!meta.upload_id.empty()) {
      const auto it = uploads.find(meta.upload_id);
      const uint64_t have = it == uploads.end() ? 0 : it->second.size();
      if (meta.write_offset != have) {
        Bug("Begin accepted write_offset " + std::to_string(meta.write_offset) + " for an upload of " +
            std::to_string(have) + " bytes");
      }
    } else if (meta.write_offset != 0) {
      Bug("Begin accepted a write_offset without an upload_id");
    }
    expected_.begun = true;
    expected_.meta = meta;
    return s;
  }

  Status BeginResource(const meshstream::ResourceMeta& resource) {
    Status s = call_->BeginResource(resource);
    if (!s.ok()) return s;
    if (!expected_.begun) Bug("a resource was accepted before the metadata");
    if (!meshstream::CheckResourceName(resource.name).ok()) Bug("an invalid resource name was accepted");
    if (expected_.resources.size() >= Limits().max_resources) Bug("more resources than the limit were accepted");
    expected_.resources.emplace_back(resource.name, std::string());
    return s;
  }

  Status Chunk(const std::string& bytes) {
    Status s = call_->Chunk(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
    if (!s.ok()) return s;
    if (!expected_.begun) Bug("a chunk was accepted before the metadata");
    if (expected_.resources.empty()) {
      expected_.main += bytes;
      if (!expected_.meta.upload_id.empty()) uploads[expected_.meta.upload_id] += bytes;
      if (expected_.meta.write_offset + expected_.main.size() > expected_.meta.size) {
        Bug("more bytes than the announced size were accepted");
      }
    } else {
      expected_.resources.back().second += bytes;
    }
    return s;
  }

  void CheckError(const Status& s, const char* what) {
    if (s.message().empty()) Bug(std::string(what) + " failed without a message: " + s.ToString());
    if (s.code() == StatusCode::kInternal && s.message() != "Finish called twice") {
      Bug(std::string(what) + " failed internally: " + s.ToString());
    }
  }

  std::string MainBytes() const {
    const auto& m = expected_.meta;
    if (m.upload_id.empty()) return expected_.main;
    const auto it = uploads.find(m.upload_id);
    return it == uploads.end() ? std::string() : it->second;
  }

  void CheckBlob(const std::string& what, const std::string& sha256, const std::string& bytes) {
    auto blob = f_.store->GetBlob(sha256, bytes.size());
    if (!blob.ok()) Bug(what + ": GetBlob(" + sha256 + ") failed: " + blob.status().ToString());
    if (std::string(blob->begin(), blob->end()) != bytes) Bug(what + ": the stored bytes are not the bytes sent");
  }

  Status Finish() {
    const auto& m = expected_.meta;
    const auto key = std::make_pair(tenant_, m.asset);
    const int64_t last = f_.versions.count(key) ? f_.versions[key] : 0;
    auto version = call_->Finish();
    if (!version.ok()) {
      CheckError(version.status(), "Finish");
      if (expected_.begun) {
        auto absent = f_.store->GetVersion(tenant_, m.asset, last + 1);
        if (absent.ok()) Bug("a failed Finish created version " + std::to_string(last + 1));
        if (absent.status().code() != StatusCode::kNotFound) Bug("GetVersion: " + absent.status().ToString());
      }
      return version.status();
    }
    if (!expected_.begun) Bug("Finish succeeded without accepted metadata");
    const meshstream::VersionRecord& v = version.value();
    const std::string main = MainBytes();
    const std::string sha = Sha(main);
    if (v.tenant != tenant_ || v.asset != m.asset || v.version != last + 1) {
      Bug("Finish created " + v.tenant + "/" + v.asset + " v" + std::to_string(v.version) + ", expected " + tenant_ +
          "/" + m.asset + " v" + std::to_string(last + 1));
    }
    f_.versions[key] = v.version;
    if (v.source.name != m.filename || v.source.size != m.size || main.size() != m.size) {
      Bug("the version's source is not the announced file (" + std::to_string(v.source.size) + " bytes recorded, " +
          std::to_string(main.size()) + " sent, " + std::to_string(m.size) + " announced)");
    }
    if (v.source.sha256 != sha || call_->source_sha256() != sha) {
      Bug("the version's source digest " + v.source.sha256 + " is not the SHA-256 of the bytes sent, " + sha);
    }
    if (!m.sha256.empty() && Lower(m.sha256) != sha) Bug("Finish accepted bytes whose digest is not the announced one");
    CheckBlob("the source", sha, main);
    if (v.resources.size() != expected_.resources.size()) Bug("the version does not list every resource");
    uint64_t total = main.size();
    for (size_t i = 0; i < v.resources.size(); ++i) {
      const auto& [name, bytes] = expected_.resources[i];
      const meshstream::SourceFile& r = v.resources[i];
      if (r.name != name || r.size != bytes.size() || r.sha256 != Sha(bytes)) {
        Bug("resource " + std::to_string(i) + " is recorded as '" + r.name + "' (" + std::to_string(r.size) +
            " bytes, " + r.sha256 + "), sent as '" + name + "' (" + std::to_string(bytes.size()) + " bytes)");
      }
      CheckBlob("resource '" + name + "'", r.sha256, bytes);
      total += bytes.size();
    }
    if (total > Limits().max_upload_bytes) Bug("an upload above max_upload_bytes was stored");
    auto stored = f_.store->GetVersion(tenant_, m.asset, v.version);
    if (!stored.ok()) Bug("GetVersion of the new version: " + stored.status().ToString());
    if (stored->source.sha256 != sha || stored->source.size != m.size || stored->resources.size() != v.resources.size() ||
        stored->job_id != v.job_id || stored->state != meshstream::VersionState::kProcessing ||
        stored->labels != m.labels || stored->comment != m.comment) {
      Bug("GetVersion does not return what Finish recorded");
    }
    auto job = f_.store->GetJob(tenant_, v.job_id);
    if (!job.ok()) Bug("the new version's job: " + job.status().ToString());
    if (!meshstream::ParseSettingsJson(v.options_json).ok()) Bug("options_json does not parse: " + v.options_json);
    if (!m.upload_id.empty()) uploads.erase(m.upload_id);
    return Status::Ok();
  }

  // After a call with an upload_id: the store's committed size is the model's.
  void SyncUpload(const std::optional<Status>& finished) {
    const std::string& id = expected_.meta.upload_id;
    auto size = f_.store->UploadSize(tenant_, id);
    const auto it = uploads.find(id);
    const uint64_t have = it == uploads.end() ? 0 : it->second.size();
    if (size.ok()) {
      if (size.value() != have) {
        Bug("upload " + id + " holds " + std::to_string(size.value()) + " bytes, " + std::to_string(have) + " were sent");
      }
      if (finished.has_value() && finished->ok()) Bug("upload " + id + " is still there after Finish succeeded");
      return;
    }
    if (size.status().code() != StatusCode::kNotFound) Bug("UploadSize: " + size.status().ToString());
    // Gone: committed by Finish or discarded as data that can never match.
    const bool consumed = finished.has_value() && (finished->ok() || finished->code() == StatusCode::kDataLoss);
    if (have > 0 && !consumed) Bug("upload " + id + " lost its " + std::to_string(have) + " bytes");
    uploads.erase(id);
  }

  Fixture& f_;
  const std::string tenant_;
  const bool keep_going_;
  std::unique_ptr<IngestUpload> call_;
  Expected expected_;
  bool failed_ = false;
};

// --- seeds -----------------------------------------------------------------

void WriteSeeds();

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const bool seeded = (WriteSeeds(), true);
  (void)seeded;
  if (size < 1 || size > kMaxInputBytes) return 0;
  Fixture& f = GetFixture();
  const uint8_t flags = data[0];
  Session session(f, flags & kOtherTenant ? "fuzz-b" : meshstream::kDefaultTenant, flags & kKeepGoing);
  bool pending = false;  // the current call got a message
  for (size_t at = 1; at < size;) {
    const uint8_t action = data[at] % 4;
    size_t length = at + 1 < size ? data[at + 1] : 0;
    if (at + 2 < size) length |= size_t{data[at + 2]} << 8;
    at = std::min(at + 3, size);
    length = std::min(length, size - at);
    const uint8_t* payload = data + at;
    at += length;
    if (action == kClose || action == kGoAway) {
      session.End(action == kClose);
      pending = false;
      continue;
    }
    meshstream::v1::IngestRequest request;
    {
      // Protobuf logs every string field that is not UTF-8; the fuzzer makes many.
      google::protobuf::LogSilencer quiet;
      if (!request.ParseFromArray(payload, static_cast<int>(length))) continue;
    }
    session.Deliver(request);
    pending = true;
  }
  if (pending) session.End(/*finish=*/true);
  // Resumable uploads do not outlive the input.
  auto expired = f.store->ExpireUploads(0);
  if (!expired.ok()) Bug("ExpireUploads: " + expired.status().ToString());
  return 0;
}

namespace {

// --- seeds -------------------------------------------------------------------

class SeedWriter {
 public:
  explicit SeedWriter(uint8_t flags) { bytes_.push_back(flags); }
  SeedWriter& Message(const meshstream::v1::IngestRequest& request) {
    return Frame(kMessage, request.SerializeAsString());
  }
  SeedWriter& Metadata(const std::string& asset, const std::string& filename, uint64_t size, const std::string& sha256,
                       const std::string& upload_id = "", uint64_t write_offset = 0) {
    meshstream::v1::IngestRequest r;
    auto* m = r.mutable_metadata();
    m->set_asset(asset);
    m->set_filename(filename);
    m->set_size(size);
    m->set_sha256(sha256);
    m->set_upload_id(upload_id);
    m->set_write_offset(write_offset);
    return Message(r);
  }
  SeedWriter& Resource(const std::string& name, uint64_t size, const std::string& sha256) {
    meshstream::v1::IngestRequest r;
    r.mutable_resource()->set_name(name);
    r.mutable_resource()->set_size(size);
    r.mutable_resource()->set_sha256(sha256);
    return Message(r);
  }
  SeedWriter& Chunk(const std::string& bytes) {
    meshstream::v1::IngestRequest r;
    r.set_chunk(bytes);
    return Message(r);
  }
  SeedWriter& Frame(uint8_t action, const std::string& payload) {
    bytes_.push_back(action);
    bytes_.push_back(static_cast<uint8_t>(payload.size()));
    bytes_.push_back(static_cast<uint8_t>(payload.size() >> 8));
    bytes_.insert(bytes_.end(), payload.begin(), payload.end());
    return *this;
  }
  SeedWriter& Close() { return Frame(kClose, ""); }
  SeedWriter& GoAway() { return Frame(kGoAway, ""); }
  void Write(const std::string& dir, const std::string& name) const {
    const std::string path = dir + "/" + name;
    FILE* file = std::fopen(path.c_str(), "wb");
    if (file == nullptr || std::fwrite(bytes_.data(), 1, bytes_.size(), file) != bytes_.size()) {
      Bug("cannot write seed " + path);
    }
    std::fclose(file);
  }

 private:
  std::vector<uint8_t> bytes_;
};

void WriteSeeds() {
  const char* env = std::getenv("MESHSTREAM_FUZZ_SEED_DIR");
  if (env == nullptr) return;
  const std::string dir = env;
  const std::string obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n";
  const std::string gltf =
      R"({"asset":{"version":"2.0"},"buffers":[{"uri":"data/tri.bin","byteLength":42}],"images":[{"uri":"tex.png"}]})";
  const std::string bin(42, '\x01');
  const std::string png = "\x89PNG\r\n\x1a\n";

  SeedWriter(0).Metadata("tetra", "tetra.obj", obj.size(), Sha(obj)).Chunk(obj).Write(dir, "seed-obj");
  SeedWriter(0)
      .Metadata("tetra", "Tetra.OBJ", obj.size(), "")
      .Chunk(obj.substr(0, 20))
      .Chunk(obj.substr(20))
      .Write(dir, "seed-obj-two-chunks");
  {
    meshstream::v1::IngestRequest r;
    auto* m = r.mutable_metadata();
    m->set_asset("scene-1");
    m->set_filename("scene.gltf");
    m->set_size(gltf.size());
    m->set_sha256(Lower(Sha(gltf)));
    m->mutable_options()->set_qp(14);
    m->mutable_options()->set_packing("bundled");
    m->mutable_options()->set_packet_bytes(600);
    m->mutable_options()->set_base_ratio(0.05);
    m->set_comment("a comment");
    (*m->mutable_labels())["lod"] = "high";
    (*m->mutable_labels())["team"] = "fuzz";
    SeedWriter(2)
        .Message(r)
        .Chunk(gltf)
        .Resource("data/tri.bin", bin.size(), Sha(bin))
        .Chunk(bin)
        .Resource("tex.png", png.size(), "")
        .Chunk(png)
        .Write(dir, "seed-gltf-resources");
  }
  // Resumable: the first call breaks off after half, the second resumes.
  const size_t half = obj.size() / 2;
  SeedWriter(0)
      .Metadata("resumed", "tetra.obj", obj.size(), "", "up-1")
      .Chunk(obj.substr(0, half))
      .GoAway()
      .Metadata("resumed", "tetra.obj", obj.size(), Sha(obj), "up-1", half)
      .Chunk(obj.substr(half))
      .Close()
      .Write(dir, "seed-resume");
  SeedWriter(0)
      .Metadata("resumed", "tetra.obj", obj.size(), "", "up-2")
      .Chunk(obj.substr(0, half))
      .Close()  // incomplete: DataLoss, the upload stays
      .Metadata("resumed", "tetra.obj", obj.size(), "", "up-2", half + 1)  // wrong offset
      .Close()
      .Metadata("resumed", "tetra.obj", obj.size(), "", "up-2", half)
      .Chunk(obj.substr(half))
      .Write(dir, "seed-resume-wrong-offset");
  // Near misses.
  SeedWriter(0).Metadata("tetra", "tetra.obj", obj.size(), std::string(64, 'a')).Chunk(obj).Write(dir, "bad-digest");
  SeedWriter(0).Metadata("tetra", "tetra.obj", obj.size() - 1, "").Chunk(obj).Write(dir, "too-many-bytes");
  SeedWriter(0).Metadata("tetra", "tetra.obj", obj.size() + 1, "").Chunk(obj).Write(dir, "too-few-bytes");
  SeedWriter(0).Metadata("tetra", "../tetra.obj", obj.size(), "").Chunk(obj).Write(dir, "bad-filename");
  SeedWriter(0).Metadata("a/b", "tetra.obj", obj.size(), "").Chunk(obj).Write(dir, "bad-asset");
  SeedWriter(0).Metadata("tetra", "tetra.obj", uint64_t{1} << 20, "").Chunk(obj).Write(dir, "above-max-upload");
  SeedWriter(0)
      .Metadata("tetra", "tetra.obj", obj.size(), "")
      .Resource("x.bin", 1, "")
      .Write(dir, "resource-for-obj");
  SeedWriter(0)
      .Metadata("scene", "scene.gltf", gltf.size(), "")
      .Chunk(gltf)
      .Resource("../escape.bin", bin.size(), "")
      .Chunk(bin)
      .Write(dir, "resource-escapes");
  SeedWriter(0)
      .Metadata("scene", "scene.gltf", gltf.size(), "")
      .Chunk(gltf)
      .Resource("a.bin", 1, "")
      .Chunk("x")
      .Resource("a.bin", 1, "")
      .Chunk("x")
      .Write(dir, "resource-twice");
  SeedWriter(0).Chunk(obj).Metadata("tetra", "tetra.obj", obj.size(), "").Chunk(obj).Write(dir, "chunk-first");
  SeedWriter(1)
      .Chunk(obj)
      .Metadata("tetra", "tetra.obj", obj.size(), "")
      .Metadata("tetra", "tetra.obj", obj.size(), "")
      .Chunk(obj)
      .Write(dir, "keep-going");
  SeedWriter(0).Frame(kMessage, "").Write(dir, "empty-message");
  SeedWriter(0).Frame(kMessage, std::string("\x0a\xff\xff\xff\xff\x0f", 6)).Write(dir, "truncated-message");
}

}  // namespace
