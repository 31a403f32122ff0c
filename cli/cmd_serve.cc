// meshstream serve [--listen 127.0.0.1:7600] [--store S] [--workers N] [--auth] ...
#include <signal.h>

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <thread>

#include <nlohmann/json.hpp>

#include "cli/exit_codes.h"
#include "cli/verbs.h"
#include "importers/import.h"
#include "services/server/server.h"

namespace meshstream::cli {

namespace {

const char kDetails[] =
    "Serves meshstream.v1.AssetService (docs/spec/api.md) with grpc.health.v1, on an embedded store\n"
    "(a folder: SQLite + blobs) or a shared one (postgresql://...: several servers, one database).\n"
    "Without --auth it listens only on loopback; on any other address --auth (or --insecure) is\n"
    "required. SIGTERM or SIGINT drains: health NOT_SERVING, running requests finish within\n"
    "--grace-period, unfinished jobs resume at the next start. The first line on stdout is\n"
    "'listening on HOST:PORT' (port 0 picks a free port); --ready-file PATH also writes the\n"
    "addresses as JSON once the server listens. docs/design/deploy.md has the details.\n"
    "--http-listen adds HTTP (docs/spec/http-api.md): the assets as files with ranges and ETags, and\n"
    "the viewer's files; same tokens, same loopback rule, same TLS files.\n"
    "\n"
    "Examples:\n"
    "  meshstream serve --store ./meshstream-data\n"
    "  meshstream serve --listen 0.0.0.0:7600 --auth --tls-cert cert.pem --tls-key key.pem \\\n"
    "                   --store postgresql://meshstream@db/meshstream\n"
    "  meshstream serve --http-listen 127.0.0.1:7680 --http-cors-origin http://localhost:5173";

struct ServeArgs {
  ServerOptions options;
  double max_rate_mbps = 1000;
  double max_session_rate_mbps = 400;
  double idle_timeout_s = 30;
  int64_t stream_cache_mb = 256;
  bool reflection = false;
  bool no_reflection = false;
  std::string ready_file;
};

// --ready-file: {"grpc": ADDRESS, "udp": ADDRESS or null, "http": ADDRESS or
// null}, written whole (a temporary file renamed) once every listener is
// up, so that a script or a test waits for the file instead of scraping
// stdout. Removed when the server stops.
Status WriteReadyFile(const std::string& path, const Server& server) {
  nlohmann::json ready = {{"grpc", server.address()}, {"udp", nullptr}, {"http", nullptr}};
  if (!server.udp_address().empty()) ready["udp"] = server.udp_address();
  if (!server.http_address().empty()) ready["http"] = server.http_address();
  const std::string text = ready.dump() + "\n";
  return WriteFileBytes(path, std::vector<uint8_t>(text.begin(), text.end()));
}

int RunServe(ServeArgs& args) {
  if (args.reflection && args.no_reflection) {
    return ReportError("serve", InvalidArgument("--reflection and --no-reflection: choose one"));
  }
  if (args.reflection) args.options.reflection = true;
  args.options.max_rate_bps = args.max_rate_mbps * 1e6;
  args.options.max_session_rate_bps = args.max_session_rate_mbps * 1e6;
  args.options.session_idle_timeout_ms = static_cast<int64_t>(args.idle_timeout_s * 1000);
  args.options.stream_cache_bytes = static_cast<uint64_t>(args.stream_cache_mb) << 20;
  if (args.no_reflection) args.options.reflection = false;
  // The signals are taken by one thread (sigwait), so they are blocked in
  // every thread the server starts.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  auto server = Server::Start(args.options);
  if (!server.ok()) return ReportError("serve", server.status());
  std::printf("listening on %s\n", (*server)->address().c_str());
  if (!(*server)->udp_address().empty()) std::printf("udp on %s\n", (*server)->udp_address().c_str());
  if (!(*server)->http_address().empty()) std::printf("http on %s\n", (*server)->http_address().c_str());
  std::fflush(stdout);
  if (!args.ready_file.empty()) {
    const Status written = WriteReadyFile(args.ready_file, **server);
    if (!written.ok()) {
      (*server)->Drain();
      return ReportError("serve", written.WithContext("--ready-file"));
    }
  }
  Server* raw = server->get();
  // The first signal drains (in its own thread); a second one while it
  // drains ends the process at once.
  std::thread waiter([raw, signals] {
    int signal = 0;
    sigwait(&signals, &signal);
    std::thread([raw] { raw->Drain(); }).detach();
    sigwait(&signals, &signal);
    std::fprintf(stderr, "meshstream serve: second signal: exiting without waiting\n");
    std::_Exit(128 + signal);
  });
  waiter.detach();
  raw->Wait();
  if (!args.ready_file.empty()) std::remove(args.ready_file.c_str());
  return kExitOk;
}

}  // namespace

Verb AddServe(CLI::App& root) {
  auto args = std::make_shared<ServeArgs>();
  CLI::App* cmd = AddVerb(root, "serve", "Runs the asset service (gRPC) and the streaming sessions (gRPC and UDP) on an embedded or a PostgreSQL store.", kDetails);
  ServerOptions& o = args->options;
  FromEnv(cmd->add_option("--listen", o.listen, "HOST:PORT, [V6]:PORT or unix:PATH"))->capture_default_str();
  FromEnv(cmd->add_option("--store", o.store, "a folder (embedded) or postgresql://... (shared)"))->capture_default_str();
  FromEnv(cmd->add_option("--workers", o.workers, "processing threads (0: the core count)")->check(CLI::Range(0, 256)))
      ->capture_default_str();
  FromEnv(cmd->add_option("--encode-threads", o.encode_threads,
                          "threads each processing job encodes a large mesh's spatial parts and a scene's primitives "
                          "on (0: the core count; the artifact does not depend on it)")
              ->check(CLI::Range(0, 64)))
      ->capture_default_str();
  FromEnv(cmd->add_flag("--auth", o.auth, "require 'authorization: Bearer TOKEN' (meshstream token create)"));
  FromEnv(cmd->add_flag("--insecure", o.insecure, "allow a non-loopback --listen without --auth (not recommended)"));
  FromEnv(cmd->add_option("--tls-cert", o.tls_cert, "PEM certificate chain (with --tls-key)")->check(CLI::ExistingFile));
  FromEnv(cmd->add_option("--tls-key", o.tls_key, "PEM private key (with --tls-cert)")->check(CLI::ExistingFile));
  FromEnv(cmd->add_flag("--reflection", args->reflection, "serve gRPC reflection (default: only on loopback)"));
  FromEnv(cmd->add_flag("--no-reflection", args->no_reflection, "never serve gRPC reflection"));
  FromEnv(cmd->add_option("--max-upload", o.max_upload_bytes,
                          "largest upload, file and resources together (bytes, or 512M, 1G, ...)")
              ->transform(CLI::AsSizeValue(false))
              ->check(CLI::Range(uint64_t{1}, uint64_t{1} << 40)))
      ->capture_default_str();
  FromEnv(cmd->add_option("--grace-period", o.grace_period_s, "seconds running requests get on SIGTERM")
              ->check(NumberIn(0, 3600)))
      ->capture_default_str();
  FromEnv(cmd->add_option("--drain-delay", o.drain_delay_s,
                          "seconds health says NOT_SERVING before new calls are refused (behind a load balancer: 5)")
              ->check(NumberIn(0, 600)))
      ->capture_default_str();
  FromEnv(cmd->add_option("--upload-ttl", o.upload_ttl_ms, "milliseconds an unfinished resumable upload is kept")
              ->check(CLI::Range(int64_t{1000}, int64_t{30} * 24 * 3600 * 1000)))
      ->capture_default_str();
  FromEnv(cmd->add_option("--lease", o.lease_ms, "milliseconds of a job lease (renewed every third)")
              ->check(CLI::Range(int64_t{300}, int64_t{3600} * 1000)))
      ->capture_default_str();
  FromEnv(cmd->add_option("--max-threads", o.max_threads, "gRPC threads; calls beyond them are RESOURCE_EXHAUSTED")
              ->check(CLI::Range(4, 100000)))
      ->capture_default_str();
  FromEnv(cmd->add_option("--max-watchers", o.max_watchers, "concurrent WatchJob streams")->check(CLI::Range(1, 100000)))
      ->capture_default_str();
  FromEnv(cmd->add_option("--max-exports", o.max_exports, "concurrent exports that decode (0: the worker count)")
              ->check(CLI::Range(0, 1024)))
      ->capture_default_str();
  FromEnv(cmd->add_option("--max-attempts", o.max_attempts,
                          "claims of a job before it fails (a file that keeps killing servers)")
              ->check(CLI::Range(1, 1000)))
      ->capture_default_str();
  FromEnv(cmd->add_option("--udp-listen", o.udp_listen,
                          "UDP HOST:PORT of the sessions' datagrams (default: the --listen host and the next port; "
                          "off: every session over gRPC)"));
  FromEnv(cmd->add_option("--udp-advertise", o.udp_advertise,
                          "the UDP HOST:PORT clients are told (NAT, load balancers, relays; default: the bound one)"));
  FromEnv(cmd->add_option("--max-rate", args->max_rate_mbps, "Mbit/s of UDP datagrams of all sessions together (0: no cap)")
              ->check(CLI::Range(0.0, 1e6)))
      ->capture_default_str();
  FromEnv(cmd->add_option("--max-session-rate", args->max_session_rate_mbps, "Mbit/s of one session at most")
              ->check(CLI::Range(0.064, 1e6)))
      ->capture_default_str();
  FromEnv(cmd->add_option("--max-sessions", o.max_sessions, "concurrent streaming sessions; then RESOURCE_EXHAUSTED")
              ->check(CLI::Range(1, 100000)))
      ->capture_default_str();
  FromEnv(cmd->add_option("--hello-timeout", o.hello_timeout_ms,
                          "milliseconds a session waits for the client's UDP HELLO before it falls back to gRPC")
              ->check(CLI::Range(int64_t{10}, int64_t{60000})))
      ->capture_default_str();
  FromEnv(cmd->add_flag("--udp-wait-hello", o.udp_wait_hello,
                        "UDP sessions wait (up to --hello-timeout) for the client's HELLO before their first refinement, "
                        "instead of starting on the stream: everything off the reliable cut then travels as UDP"));
  FromEnv(cmd->add_flag("--no-reliable-cut", o.no_reliable_cut,
                        "send every datagram as UDP, also those of the artifact's reliable cut (the paper's scheme)"));
  FromEnv(cmd->add_flag("--no-parity", o.no_parity,
                        "send no parity datagrams: what UDP loses is predicted, never rebuilt (docs/design/loss-protection.md)"));
  FromEnv(cmd->add_option("--session-idle-timeout", args->idle_timeout_s,
                          "seconds a session may go without a message from its client")
              ->check(CLI::Range(0.1, 86400.0)))
      ->capture_default_str();
  FromEnv(cmd->add_option("--stream-cache-mb", args->stream_cache_mb,
                          "MiB of hot artifacts kept for streaming sessions with their plans and scenes "
                          "(least recently used go first; 0: only what running sessions hold)")
              ->check(CLI::Range(int64_t{0}, int64_t{1} << 20)))
      ->capture_default_str();
  FromEnv(cmd->add_option("--http-listen", o.http_listen,
                          "HTTP HOST:PORT of the assets by ranges and the viewer (docs/spec/http-api.md); off by default, "
                          "7680 is the documented port (gRPC 7600, UDP 7601); port 0 picks a free one"));
  FromEnv(cmd->add_option("--http-cors-origin", o.http_cors_origins,
                          "an origin (https://HOST[:PORT]) whose pages may read the HTTP routes; repeatable; "
                          "'*' allows any (unsafe with --auth)")
              ->delimiter(','));
  FromEnv(cmd->add_option("--http-root", o.http_root,
                          "folder of the viewer's files served at / (default: ../share/meshstream/web or ../web "
                          "beside the binary)")
              ->check(CLI::ExistingDirectory));
  FromEnv(cmd->add_option("--server-id", o.server_id, "name in job leases and logs (default host-pid-random)"));
  FromEnv(cmd->add_option("--ready-file", args->ready_file,
                          "once listening, write {\"grpc\": ADDRESS, \"udp\": ADDRESS|null, \"http\": ADDRESS|null} "
                          "to this file (whole, by a rename); removed when the server stops"));
  return {cmd, [args] { return RunServe(*args); }};
}

}  // namespace meshstream::cli
