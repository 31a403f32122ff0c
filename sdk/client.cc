#include "sdk/client.h"

namespace meshstream::sdk {

StatusOr<std::unique_ptr<Client>> Client::Create(const ClientOptions& options) {
  if (options.server.empty()) return InvalidArgument("server: must not be empty (HOST:PORT)");
  std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::InsecureChannelCredentials();
  if (options.tls || !options.tls_ca_pem.empty()) {
    grpc::SslCredentialsOptions ssl;
    ssl.pem_root_certs = options.tls_ca_pem;
    credentials = grpc::SslCredentials(ssl);
  }
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(256 << 20);  // a session start holds every base mesh and the scene
  auto channel = grpc::CreateCustomChannel(options.server, credentials, args);
  if (!channel) return InvalidArgument("server " + options.server + ": not an address");
  return std::unique_ptr<Client>(new Client(options, std::move(channel)));
}

void Client::Authorize(grpc::ClientContext& context) const {
  if (!options_.token.empty()) context.AddMetadata("authorization", "Bearer " + options_.token);
}

}  // namespace meshstream::sdk
