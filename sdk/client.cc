#include "sdk/client.h"

#include <chrono>

namespace meshstream::sdk {

StatusOr<std::unique_ptr<Client>> Client::Create(const ClientOptions& options) {
  if (options.server.empty()) return InvalidArgument("server: must not be empty (HOST:PORT)");
  if (options.session_deadline_ms < 0) return InvalidArgument("session_deadline_ms: not negative (0: none)");
  std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::InsecureChannelCredentials();
  grpc::ChannelArguments args;
  if (options.tls || !options.tls_ca_pem.empty()) {
    grpc::SslCredentialsOptions ssl;
    ssl.pem_root_certs = options.tls_ca_pem;
    credentials = grpc::SslCredentials(ssl);
    if (!options.tls_server_name.empty()) args.SetSslTargetNameOverride(options.tls_server_name);
  }
  args.SetMaxReceiveMessageSize(256 << 20);  // a session start holds every base mesh and the scene
  auto channel = grpc::CreateCustomChannel(options.server, credentials, args);
  if (!channel) return InvalidArgument("server " + options.server + ": not an address");
  return std::unique_ptr<Client>(new Client(options, std::move(channel)));
}

void LossMemory::Add(uint64_t lost, uint64_t received_over_udp) {
  const uint64_t seen = lost + received_over_udp;
  if (seen < kMinimum) return;
  std::lock_guard<std::mutex> lock(mutex_);
  lost_ = lost_ / 2 + static_cast<double>(lost);
  seen_ = seen_ / 2 + static_cast<double>(seen);
}

double LossMemory::Rate() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return seen_ > 0 ? lost_ / seen_ : -1.0;
}

void Client::Authorize(grpc::ClientContext& context) const {
  // The token as for any call; the deadline in whole milliseconds, not through
  // Prepare's seconds (ms / 1000.0 * 1e6 truncates some to a microsecond less).
  Prepare(context, 0);
  if (options_.session_deadline_ms > 0) {
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::milliseconds(options_.session_deadline_ms));
  }
}

void Client::Prepare(grpc::ClientContext& context, double timeout_s) const {
  if (!options_.token.empty()) context.AddMetadata("authorization", "Bearer " + options_.token);
  if (timeout_s > 0) {
    context.set_deadline(std::chrono::system_clock::now() +
                         std::chrono::microseconds(static_cast<int64_t>(timeout_s * 1e6)));
  }
}

}  // namespace meshstream::sdk
