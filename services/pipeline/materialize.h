// A version's source files on disk, for the importers: a fresh private work
// folder holding the main file under its filename and every resource (the
// external files of a .gltf) under its relative path, removed when the
// WorkFolder goes away.
//
// Contract: the names in the VersionRecord are untrusted: the main filename
// must pass CheckMainFilename and every resource name CheckResourceName
// (proto/api_names.h), names may not repeat or collide (a file where another
// name needs a folder), else InvalidArgument and nothing is left on disk.
// The folder is made by mkdtemp (mode 0700), files are created 0600 with
// O_EXCL|O_NOFOLLOW, so nothing outside the folder is ever written. Blobs
// are read with Store::GetBlob (re-hashed by the store); a blob whose size
// differs from the record is DataLoss; the files together may not exceed
// `max_source_bytes` (ResourceExhausted, checked on the recorded sizes
// before anything is read). Thread safety: distinct calls are independent;
// a WorkFolder is owned by one thread.
#ifndef MESHSTREAM_SERVICES_PIPELINE_MATERIALIZE_H_
#define MESHSTREAM_SERVICES_PIPELINE_MATERIALIZE_H_

#include <cstdint>
#include <string>

#include "codec/core/status.h"
#include "importers/import.h"
#include "services/store/store.h"

namespace meshstream {

// Removes its folder and everything in it on destruction. Move-only.
class WorkFolder {
 public:
  WorkFolder() = default;
  ~WorkFolder();
  WorkFolder(WorkFolder&& other) noexcept;
  WorkFolder& operator=(WorkFolder&& other) noexcept;
  WorkFolder(const WorkFolder&) = delete;
  WorkFolder& operator=(const WorkFolder&) = delete;

  // Makes an empty folder "<parent>/meshstream-job-XXXXXX" (mode 0700);
  // `parent` empty: the system's temporary folder ($TMPDIR or /tmp).
  static StatusOr<WorkFolder> Create(const std::string& parent);

  const std::string& path() const { return path_; }
  // The main file (empty until MaterializeVersion wrote it).
  const std::string& main_path() const { return main_path_; }
  uint64_t bytes_written() const { return bytes_written_; }

  // Writes `size` bytes under the relative `name` (checked by the caller),
  // making its folders. InvalidArgument when the name collides with a file
  // or folder already written.
  Status WriteFile(const std::string& name, const uint8_t* data, size_t size);

 private:
  friend StatusOr<WorkFolder> MaterializeVersion(Store&, const VersionRecord&, const std::string&, uint64_t);
  void Remove();
  std::string path_;
  std::string main_path_;
  uint64_t bytes_written_ = 0;
};

// Writes `version`'s main file and resources into a new WorkFolder under
// `parent` ("" = the system's temporary folder).
StatusOr<WorkFolder> MaterializeVersion(Store& store, const VersionRecord& version, const std::string& parent,
                                        uint64_t max_source_bytes = kDefaultMaxInputBytes);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_PIPELINE_MATERIALIZE_H_
