#include "services/server/server.h"

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <mutex>
#include <optional>
#include <thread>
#include <utility>
#include <vector>

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/impl/server_builder_option.h>
#include <grpcpp/resource_quota.h>

#include "importers/import.h"
#include "net/udp_socket.h"
#include "proto/sha256.h"
#include "services/auth/authenticator.h"
#include "services/grpc/asset_service.h"
#include "services/grpc/stream_service.h"
#include "services/http/cors.h"
#include "services/http/http_server.h"
#include "services/http_routes/asset_route.h"
#include "services/http_routes/router.h"
#include "services/http_routes/static_route.h"
#include "services/http_routes/stream_socket.h"
#include "services/jobs/worker_pool.h"
#include "services/store/open_store.h"
#include "services/streaming/udp_endpoint.h"

namespace meshstream {

namespace {

// Turns reflection on or off for one builder. Linking grpc++_reflection
// registers its plugin for every server of the process (a static
// initializer), so "off" removes it and "on" adds it only when missing.
class ReflectionOption final : public grpc::ServerBuilderOption {
 public:
  explicit ReflectionOption(bool enabled) : enabled_(enabled) {}
  void UpdateArguments(grpc::ChannelArguments*) override {}
  void UpdatePlugins(std::vector<std::unique_ptr<grpc::ServerBuilderPlugin>>* plugins) override {
    const std::string name = grpc::reflection::ProtoServerReflectionPlugin().name();
    bool present = false;
    for (auto it = plugins->begin(); it != plugins->end();) {
      if ((*it)->name() == name && (!enabled_ || present)) {
        it = plugins->erase(it);
        continue;
      }
      present = present || (*it)->name() == name;
      ++it;
    }
    if (enabled_ && !present) plugins->push_back(std::make_unique<grpc::reflection::ProtoServerReflectionPlugin>());
  }

 private:
  bool enabled_;
};

std::string HostOf(const std::string& listen) {
  if (listen.rfind("unix:", 0) == 0) return "unix";
  if (!listen.empty() && listen[0] == '[') {
    const size_t end = listen.find(']');
    return end == std::string::npos ? listen : listen.substr(1, end - 1);
  }
  const size_t colon = listen.rfind(':');
  return colon == std::string::npos ? listen : listen.substr(0, colon);
}

std::string DefaultServerId() {
  char host[256] = {0};
  if (gethostname(host, sizeof host - 1) != 0) host[0] = 0;
  return std::string(host[0] ? host : "meshstream") + "-" + std::to_string(getpid()) + "-" + RandomHex(4);
}

StatusOr<std::shared_ptr<grpc::ServerCredentials>> Credentials(const ServerOptions& o) {
  if (o.tls_cert.empty() != o.tls_key.empty()) {
    return InvalidArgument("--tls-cert and --tls-key: give both or neither");
  }
  if (o.tls_cert.empty()) return grpc::InsecureServerCredentials();
  auto cert = ReadFileBytes(o.tls_cert, 1 << 20);
  if (!cert.ok()) return cert.status().WithContext("--tls-cert");
  auto key = ReadFileBytes(o.tls_key, 1 << 20);
  if (!key.ok()) return key.status().WithContext("--tls-key");
  grpc::SslServerCredentialsOptions ssl;
  ssl.pem_key_cert_pairs.push_back({std::string(key->begin(), key->end()), std::string(cert->begin(), cert->end())});
  return grpc::SslServerCredentials(ssl);
}

}  // namespace

// Longer than any ingest between its first blob and its version row.
constexpr int64_t kOrphanAgeMs = int64_t{3600} * 1000;

bool IsLoopbackListen(const std::string& listen) {
  const std::string host = HostOf(listen);
  return host == "unix" || host == "localhost" || host == "::1" || host.rfind("127.", 0) == 0;
}

struct StreamingSetup {
  std::optional<SocketAddress> udp_listen;  // unset: UDP off
  SessionHostOptions service;
};

// The streaming flags checked and turned into the service's options.
StatusOr<StreamingSetup> StreamingOptions(const ServerOptions& o, bool loopback,
                                          const std::function<void(const std::string&)>& log) {
  (void)loopback;
  StreamingSetup setup;
  if (o.max_sessions < 1) return InvalidArgument("--max-sessions: at least 1");
  if (o.hello_timeout_ms < 10 || o.hello_timeout_ms > 60000) return InvalidArgument("--hello-timeout: 10..60000 ms");
  if (o.session_idle_timeout_ms < 100) return InvalidArgument("--session-idle-timeout: at least 100 ms");
  if (o.max_session_rate_bps < 64e3) return InvalidArgument("--max-session-rate: at least 0.064 Mbit/s");
  if (o.max_rate_bps < 0) return InvalidArgument("--max-rate: not negative (0: no server cap)");
  setup.service.max_sessions = o.max_sessions;
  setup.service.hello_timeout = std::chrono::milliseconds(o.hello_timeout_ms);
  setup.service.wait_for_hello = o.udp_wait_hello;
  setup.service.reliable_cut = !o.no_reliable_cut;
  setup.service.parity = !o.no_parity;
  setup.service.idle_timeout = std::chrono::milliseconds(o.session_idle_timeout_ms);
  setup.service.stream_cache_bytes = o.stream_cache_bytes;
  setup.service.rate.max_bps = o.max_session_rate_bps;
  setup.service.rate.initial_bps = std::min(setup.service.rate.initial_bps, o.max_session_rate_bps);
  if (o.max_rate_bps > 0) {
    setup.service.rate.max_bps = std::min(setup.service.rate.max_bps, o.max_rate_bps);
    setup.service.rate.initial_bps = std::min(setup.service.rate.initial_bps, o.max_rate_bps);
  }
  setup.service.log = log;
  std::string listen = o.udp_listen;
  if (listen == "off") return setup;
  if (listen.empty()) {
    if (o.listen.rfind("unix:", 0) == 0) return setup;  // no host to derive it from
    std::string host;
    uint16_t port = 0;
    Status s = SplitHostPort(o.listen, &host, &port);
    if (!s.ok()) return s.WithContext("--listen");
    if (port == 65535) return InvalidArgument("--listen port 65535 leaves no next port for UDP: give --udp-listen");
    const std::string bracketed = host.find(':') != std::string::npos ? "[" + host + "]" : host;
    listen = bracketed + ":" + std::to_string(port == 0 ? 0 : port + 1);
  }
  auto address = SocketAddress::Parse(listen);
  if (!address.ok()) return address.status().WithContext("--udp-listen");
  setup.udp_listen = address.value();
  if (!o.udp_advertise.empty()) {
    std::string host;
    uint16_t port = 0;
    Status s = SplitHostPort(o.udp_advertise, &host, &port);
    if (!s.ok()) return s.WithContext("--udp-advertise");
    if (port == 0) return InvalidArgument("--udp-advertise: the port must not be 0");
    setup.service.udp_advertise_host = host;
    setup.service.udp_advertise_port = port;
  }
  return setup;
}

struct Server::Impl {
  ServerOptions options;
  std::function<void(const std::string&)> log;
  std::unique_ptr<Store> store;
  std::unique_ptr<Authenticator> auth;
  std::unique_ptr<WorkerPool> pool;
  std::unique_ptr<AssetServiceImpl> service;
  std::unique_ptr<UdpEndpoint> udp;   // before streams: sessions use it until they end
  std::unique_ptr<RateShare> share;
  std::unique_ptr<SessionHost> sessions;  // every session, whatever its transport (below)
  std::unique_ptr<StreamServiceImpl> streams;
  std::unique_ptr<grpc::Server> server;
  // HTTP (docs/spec/http-api.md): the routes before the server, so that the
  // server (its pool runs the routes) stops first.
  std::unique_ptr<AssetRoute> http_assets;
  std::unique_ptr<StaticRoute> http_files;
  std::unique_ptr<HttpRouter> http_router;
  std::shared_ptr<StreamSocketRoute> http_sessions;  // GET /v1/stream over WebSocket
  std::unique_ptr<HttpServer> http;
  std::string address;
  std::string streams_advertise;
  bool shared_store = false;  // not the embedded SQLite store: others may write to it
  int workers = 0;            // job workers
  bool reflection = false;
  std::atomic<bool> draining{false};
  std::atomic<bool> waited{false};

  std::mutex mutex;
  std::condition_variable wake;
  bool stopping = false;    // the maintenance thread ends
  bool drain_done = false;  // Drain has returned (Wait waits for it)
  std::thread maintenance;

  // Server::Start's stages, in order (below).
  Status CheckHttp(CorsPolicy* cors, std::string* root_note);
  Status OpenStorage();
  Status MakeAssetService();
  Status StartGrpc(const std::shared_ptr<grpc::ServerCredentials>& credentials, bool loopback);
  Status StartHttp(CorsPolicy cors);

  // Every 10 minutes: expired uploads, and blobs no row names that are older
  // than an hour (what a failed upload or a crash left behind).
  void Maintain() {
    std::unique_lock<std::mutex> lock(mutex);
    while (!stopping) {
      wake.wait_for(lock, std::chrono::minutes(10));
      if (stopping) break;
      lock.unlock();
      auto expired = store->ExpireUploads(options.upload_ttl_ms);
      if (!expired.ok()) log("upload expiry failed: " + expired.status().ToString());
      else if (expired.value() > 0) log("removed " + std::to_string(expired.value()) + " expired uploads");
      auto orphans = store->RemoveOrphanBlobs(kOrphanAgeMs);
      if (!orphans.ok()) log("orphan removal failed: " + orphans.status().ToString());
      else if (orphans.value() > 0) log("removed " + std::to_string(orphans.value()) + " orphan blobs");
      lock.lock();
    }
  }
};

Server::Server(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

Server::~Server() {
  if (!impl_) return;
  Drain();
  Wait();
}

const std::string& Server::address() const { return impl_->address; }

// Serving a non-loopback address without --auth needs --insecure (then a
// warning); with --auth but without TLS, tokens travel in clear text.
// `flag` names the listen flag, `what` what is served ("", "HTTP on ").
Status CheckExposure(const ServerOptions& options, const std::string& flag, const std::string& listen,
                     const std::string& insecure_warning, const std::function<void(const std::string&)>& log) {
  const bool loopback = IsLoopbackListen(listen);
  if (!loopback && !options.auth) {
    if (!options.insecure) {
      return InvalidArgument(flag + " " + listen +
                             ": not a loopback address, so --auth is required (or --insecure to serve anyone)");
    }
    log(insecure_warning);
  }
  if (!loopback && options.auth && options.tls_cert.empty()) {
    log("warning: tokens travel in clear text on " + listen + " (give --tls-cert and --tls-key)");
  }
  return Status::Ok();
}

// Stage 1, before anything is opened: HTTP's flags, CORS and the viewer's
// files (impl->http_files); the note the start's log line gives about them.
Status Server::Impl::CheckHttp(CorsPolicy* cors, std::string* root_note) {
  if (options.http_listen.empty()) return Status::Ok();
  if (options.http_listen.rfind("unix:", 0) == 0) {
    return InvalidArgument("--http-listen " + options.http_listen + ": HTTP listens on HOST:PORT, not a unix socket");
  }
  std::string http_host;
  uint16_t http_port = 0;
  Status http_address = SplitHostPort(options.http_listen, &http_host, &http_port);
  if (!http_address.ok()) return http_address.WithContext("--http-listen");
  MS_RETURN_IF_ERROR(CheckExposure(options, "--http-listen", options.http_listen,
                                   "warning: --insecure: serving HTTP on " + options.http_listen +
                                       " without authentication",
                                   log));
  auto policy = CorsPolicy::Make(options.http_cors_origins);
  if (!policy.ok()) return policy.status();
  *cors = std::move(policy).value();
  if (cors->allows_any() && options.auth) {
    log("warning: --http-cors-origin '*' with --auth: any web page may use a token it holds to read assets");
  }
  WebRootSearch search;
  if (options.http_root.empty()) search = FindDefaultWebRoot();
  const std::string root = options.http_root.empty() ? search.found : options.http_root;
  auto files = StaticRoute::Open(root, search.searched);
  if (!files.ok()) return files.status();
  http_files = std::move(files).value();
  if (!http_files->root().empty()) {
    *root_note = "viewer files from " + http_files->root();
  } else {
    std::string where;
    for (const std::string& w : search.searched) where += (where.empty() ? "" : ", ") + w;
    *root_note = "no viewer files (looked in " + where + "; give --http-root DIR)";
  }
  return Status::Ok();
}

// Stage 2: the store opened and tidied: orphan blobs, interrupted jobs (an
// embedded store's), expired uploads.
Status Server::Impl::OpenStorage() {
  auto opened = OpenStore(options.store);
  if (!opened.ok()) return opened.status().WithContext("--store " + options.store);
  store = std::move(opened).value();
  log("store: " + store->backend() + " at " + options.store);
  // An embedded store belongs to this process alone (its lock): nothing
  // another writer could be about to name, so orphans go at once. A shared
  // one waits an hour, longer than any ingest between blob and row.
  shared_store = store->backend() != "sqlite";
  auto orphans = store->RemoveOrphanBlobs(shared_store ? kOrphanAgeMs : 0);
  if (!orphans.ok()) return orphans.status().WithContext("removing orphan blobs");
  if (orphans.value() > 0) log("removed " + std::to_string(orphans.value()) + " orphan blobs");
  if (!shared_store) {
    auto released = store->ReleaseAllLeases();
    if (!released.ok()) return released.status();
    if (released.value() > 0) log("resuming " + std::to_string(released.value()) + " interrupted jobs");
  }
  auto expired = store->ExpireUploads(options.upload_ttl_ms);
  if (!expired.ok()) return expired.status();
  return Status::Ok();
}

// Stage 3: who a request is, the job workers (not started yet) and the
// asset service.
Status Server::Impl::MakeAssetService() {
  auth = std::make_unique<Authenticator>(store.get(), options.auth);
  WorkerPoolOptions pool_options;
  pool_options.workers =
      options.workers > 0 ? options.workers : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  pool_options.encode_threads = options.encode_threads > 0
                                    ? options.encode_threads
                                    : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  pool_options.worker_id_prefix = options.server_id.empty() ? DefaultServerId() : options.server_id;
  pool_options.lease_ms = options.lease_ms;
  pool_options.max_source_bytes = options.max_upload_bytes;
  pool_options.max_attempts = options.max_attempts;
  if (!shared_store) {
    // Work folders of the embedded store live in it, so what a killed
    // process left there is removed at the next start (nobody else uses it).
    pool_options.work_dir = options.store + "/work";
    std::error_code ec;
    std::filesystem::remove_all(pool_options.work_dir, ec);
    std::filesystem::create_directories(pool_options.work_dir, ec);
    if (ec) return IoError(pool_options.work_dir + ": " + ec.message());
  }
  workers = pool_options.workers;
  pool = std::make_unique<WorkerPool>(*store, pool_options);
  AssetServiceOptions service_options;
  service_options.ingest.max_upload_bytes = options.max_upload_bytes;
  service_options.max_watchers = options.max_watchers;
  service_options.max_exports = options.max_exports > 0 ? options.max_exports : pool_options.workers;
  Impl* raw = this;
  service = std::make_unique<AssetServiceImpl>(store.get(), auth.get(), service_options,
                                               [raw] { raw->pool->Wake(); }, &draining);
  return Status::Ok();
}

// Stage 4: the session host (with its UDP endpoint and the server's rate
// share) and the gRPC server with both services, listening.
Status Server::Impl::StartGrpc(const std::shared_ptr<grpc::ServerCredentials>& credentials, bool loopback) {
  grpc::EnableDefaultHealthCheckService(true);
  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort(options.listen, credentials, &port);
  builder.RegisterService(service.get());
  auto stream_options = StreamingOptions(options, loopback, log);
  if (!stream_options.ok()) return stream_options.status();
  if (stream_options->udp_listen.has_value()) {
    auto endpoint = UdpEndpoint::Start(*stream_options->udp_listen);
    if (!endpoint.ok()) return endpoint.status();
    udp = std::move(endpoint).value();
    stream_options->service.udp = udp.get();
    if (stream_options->service.udp_advertise_port == 0) {
      stream_options->service.udp_advertise_port = udp->local().port();
      if (!udp->local().IsUnspecified()) stream_options->service.udp_advertise_host = udp->local().host();
    }
    streams_advertise = stream_options->service.udp_advertise_host.empty()
                            ? std::string()
                            : stream_options->service.udp_advertise_host + ":" +
                                  std::to_string(stream_options->service.udp_advertise_port);
  }
  if (options.max_rate_bps > 0) {
    share = std::make_unique<RateShare>(options.max_rate_bps);
    stream_options->service.server_share = share.get();
  }
  sessions = std::make_unique<SessionHost>(store.get(), auth.get(), stream_options->service, &draining);
  streams = std::make_unique<StreamServiceImpl>(sessions.get());
  builder.RegisterService(streams.get());
  // Chunks are at most 1 MiB; a message is a chunk and a little framing.
  // A bounded number of threads for the synchronous AssetService: calls
  // beyond it are RESOURCE_EXHAUSTED instead of a thread each (a flood of
  // WatchJob streams). StreamService is a callback service: its sessions
  // hold none of these threads (their bound is --max-sessions, and their
  // sending is one thread of the service's own), so a server full of
  // sessions still has every thread for AssetService and health.
  grpc::ResourceQuota quota("meshstream-serve");
  quota.SetMaxThreads(options.max_threads);
  builder.SetResourceQuota(quota);
  builder.SetMaxReceiveMessageSize(2 << 20);
  // A session's start carries every base mesh and the scene at level 0:
  // far more than a chunk for a large asset (the client's receive limit
  // is what protects it; the SDK allows 256 MiB).
  builder.SetMaxSendMessageSize(256 << 20);
  reflection = options.reflection.value_or(loopback);
  builder.SetOption(std::make_unique<ReflectionOption>(reflection));
  server = builder.BuildAndStart();
  if (!server || (port == 0 && options.listen.rfind("unix:", 0) != 0)) {
    return Unavailable("--listen " + options.listen + ": cannot listen there (address in use, or not this host's)");
  }
  if (options.listen.rfind("unix:", 0) == 0) {
    address = options.listen;
  } else {
    const size_t colon = options.listen.rfind(':');
    address = options.listen.substr(0, colon) + ":" + std::to_string(port);
  }
  server->GetHealthCheckService()->SetServingStatus(true);
  return Status::Ok();
}

// Stage 5: HTTP, when asked for: the file routes on the asset service's
// export limit and the session host's hot artifacts, the WebSocket sessions
// on the same host, listening.
Status Server::Impl::StartHttp(CorsPolicy cors) {
  if (options.http_listen.empty()) return Status::Ok();
  AssetRouteOptions asset_options;
  asset_options.max_export_bytes = service->options().max_export_bytes;
  asset_options.export_wait_ms = service->options().export_wait_ms;
  http_assets = std::make_unique<AssetRoute>(store.get(), auth.get(), service->export_limit(), asset_options,
                                             sessions.get());
  // The live session over WebSocket: the gRPC stream service's sessions
  // (services/http_routes/stream_socket.h), its origins those of CORS.
  StreamSocketOptions socket_options;
  socket_options.cors = cors;
  socket_options.log = log;
  http_sessions = std::make_shared<StreamSocketRoute>(sessions.get(), std::move(socket_options));
  http_router = std::make_unique<HttpRouter>(http_assets.get(), http_files.get(), std::move(cors), &draining, log);
  HttpServerOptions http_options;
  http_options.upgrades["/v1/stream"] = http_sessions;
  http_options.listen = options.http_listen;
  http_options.tls_cert = options.tls_cert;
  http_options.tls_key = options.tls_key;
  http_options.log = log;
  HttpRouter* router = http_router.get();
  auto started = HttpServer::Start(std::move(http_options),
                                   [router](const HttpRequest& request) { return router->Handle(request); });
  if (!started.ok()) return started.status();
  http = std::move(started).value();
  return Status::Ok();
}

StatusOr<std::unique_ptr<Server>> Server::Start(const ServerOptions& options) {
  auto impl = std::make_unique<Impl>();
  impl->options = options;
  impl->log = options.log ? options.log : [](const std::string& line) {
    std::fprintf(stderr, "meshstream serve: %s\n", line.c_str());
    std::fflush(stderr);
  };
  const bool loopback = IsLoopbackListen(options.listen);
  MS_RETURN_IF_ERROR(CheckExposure(options, "--listen", options.listen,
                                   "warning: --insecure: serving " + options.listen +
                                       " without authentication; anyone who reaches it can read and write every asset",
                                   impl->log));
  auto credentials = Credentials(options);
  if (!credentials.ok()) return credentials.status();
  CorsPolicy cors;
  std::string http_root_note;
  MS_RETURN_IF_ERROR(impl->CheckHttp(&cors, &http_root_note));
  MS_RETURN_IF_ERROR(impl->OpenStorage());
  MS_RETURN_IF_ERROR(impl->MakeAssetService());
  MS_RETURN_IF_ERROR(impl->StartGrpc(credentials.value(), loopback));
  MS_RETURN_IF_ERROR(impl->StartHttp(std::move(cors)));
  Status started = impl->pool->Start();
  if (!started.ok()) return started;
  Impl* raw = impl.get();
  impl->maintenance = std::thread([raw] { raw->Maintain(); });
  impl->log("listening on " + impl->address + (options.tls_cert.empty() ? "" : " (TLS)") +
            (options.auth ? ", tokens required" : loopback ? ", no authentication (loopback)" : ", no authentication (--insecure)") + ", " +
            std::to_string(impl->workers) + " workers" + (impl->reflection ? ", reflection on" : ""));
  if (impl->udp) {
    impl->log("udp on " + impl->udp->local().ToString() + ", advertised as " +
              (impl->streams_advertise.empty() ? "the client's server host" : impl->streams_advertise));
  }
  if (impl->http) {
    impl->log("http on " + impl->http->address() + (impl->http->tls() ? " (TLS)" : "") + ", " + http_root_note);
  }
  return std::unique_ptr<Server>(new Server(std::move(impl)));
}

std::string Server::udp_address() const { return impl_->udp ? impl_->udp->local().ToString() : std::string(); }

std::string Server::http_address() const { return impl_->http ? impl_->http->address() : std::string(); }

void Server::Drain() {
  Impl& s = *impl_;
  if (s.draining.exchange(true)) return;
  char seconds[32];
  std::snprintf(seconds, sizeof seconds, "%g", s.options.grace_period_s);
  s.log(std::string("draining: health NOT_SERVING, finishing running requests within ") + seconds + " s");
  s.server->GetHealthCheckService()->SetServingStatus(false);
  if (s.options.drain_delay_s > 0) {
    std::this_thread::sleep_for(std::chrono::milliseconds(static_cast<int64_t>(s.options.drain_delay_s * 1000)));
  }
  {
    std::lock_guard<std::mutex> lock(s.mutex);
    s.stopping = true;
  }
  s.wake.notify_all();
  const auto grace = std::chrono::milliseconds(static_cast<int64_t>(s.options.grace_period_s * 1000));
  const auto steady_deadline = std::chrono::steady_clock::now() + grace;
  // HTTP: no new connection, idle keep-alive ones closed, running responses
  // finish (each then closes its connection) within the same grace period.
  if (s.http) s.http->BeginDrain();
  s.server->Shutdown(std::chrono::system_clock::now() + grace);
  if (s.http) s.http->Stop(steady_deadline);
  const int64_t abandoned = s.pool->Drain(steady_deadline);
  if (abandoned > 0) {
    s.log("left " + std::to_string(abandoned) + " running jobs to the next start (or to another server)");
  }
  std::lock_guard<std::mutex> lock(s.mutex);
  s.drain_done = true;
  s.wake.notify_all();
}

void Server::Wait() {
  Impl& s = *impl_;
  if (s.waited.exchange(true)) return;
  s.server->Wait();
  {
    // Shutdown (so Wait) returns inside Drain: let Drain finish first.
    std::unique_lock<std::mutex> lock(s.mutex);
    s.wake.wait(lock, [&s] { return s.drain_done; });
  }
  if (s.maintenance.joinable()) s.maintenance.join();
  s.pool->Stop();
  if (s.udp) {
    const UdpEndpointStats u = s.udp->stats();
    std::string drops;
    for (size_t r = 1; r < kDropReasonCount; ++r) {
      if (u.received.by_reason[r] > 0) {
        drops += std::string(drops.empty() ? "" : ", ") + DropReasonName(static_cast<DropReason>(r)) + "=" +
                 std::to_string(u.received.by_reason[r]);
      }
    }
    s.log("udp: " + std::to_string(u.received.accepted()) + " datagrams accepted, " +
          std::to_string(u.received.dropped()) + " dropped" + (drops.empty() ? "" : " (" + drops + ")") + ", " +
          std::to_string(u.addresses_refused) + " addresses refused, " + std::to_string(u.hello_acks_sent) +
          " HELLO_ACKs and " + std::to_string(u.data_sent) + " DATA sent, " + std::to_string(u.send_errors) +
          " send errors");
  }
  if (s.http) {
    const HttpServerStats h = s.http->stats();
    s.log("http: " + std::to_string(h.accepted) + " connections, " + std::to_string(h.requests) + " responses, " +
          std::to_string(h.refused) + " connections refused (too many at once)");
  }
  s.log("stopped");
}

}  // namespace meshstream
