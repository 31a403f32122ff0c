// The service benchmark's references, measured without a server: a durable
// commit of 4 KiB, and per model the job's import + encode run in this
// process, the upload's messages streamed into the echo server's sink, the
// bytes written and fsync'd into a file, their SHA-256; and PostgreSQL's
// insert of the file as one bytea value, compressed and not.
#ifndef MESHSTREAM_BENCH_SERVICE_REFERENCES_H_
#define MESHSTREAM_BENCH_SERVICE_REFERENCES_H_

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/service/args.h"
#include "bench/service/backend.h"
#include "bench/service/models.h"

namespace meshstream::bench::service {

// The "references" object.
nlohmann::json References(const Args& args, const std::vector<Model>& models, const std::vector<Backend*>& backends,
                          const std::string& echo_address);

}  // namespace meshstream::bench::service

#endif  // MESHSTREAM_BENCH_SERVICE_REFERENCES_H_
